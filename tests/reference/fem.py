r"""Hermite cubic Euler-Bernoulli finite elements of a cantilever (the reference's space discretisation).

Each node carries the deflection w and the slope w_x; on an element of length h with local
coordinate :math:`\xi = (x - x_e)/h \in [0, 1]` the shape functions are

.. math::

    N_1 = 1 - 3\xi^2 + 2\xi^3,\quad N_2 = h(\xi - 2\xi^2 + \xi^3),\quad
    N_3 = 3\xi^2 - 2\xi^3,\quad N_4 = h(-\xi^2 + \xi^3).

Every matrix comes from the weak form of the beam equation with the test function psi, integrated
by Gauss-Legendre quadrature (exact for the polynomial integrands):

* mass: :math:`\rho A \int w\psi` plus the tip body (:math:`m_T w(l)\psi(l) + J w_x(l)\psi_x(l)`)
  and point masses;
* bending: :math:`\int w_{xx}\psi_{xx}` (per unit EI, N m^2), so strain rate adds
  :math:`c_dI \int w_{xxt}\psi_{xx}` and time hysteresis :math:`-\int_0^\infty g \int w_{xx}\psi_{xx}`:
  their moments sit inside the same integral as the elastic moment, which is how they reach the
  free-end conditions (natural boundary conditions of the weak form);
* air: :math:`\gamma \int w_t \psi`;
* spatial hysteresis: :math:`\tfrac12\iint h(x,\xi)\{w_{xt}(x)-w_{xt}(\xi)\}\{\psi_x(x)-\psi_x(\xi)\}`
  (the paper's eq. 15 integrated by parts; its boundary term is the free-end damping moment);
* axial load: :math:`P \int w_x \psi_x`; root spring: :math:`k_\theta w_x(0)\psi_x(0)`;
* a translating base under the clamp: :math:`(m_b w_{tt}(0) + c_b w_t(0) + k_b w(0))\psi(0)`.

The root is clamped (w = w_x = 0), pinned in w only with a root spring, held in w_x only on a
translating base, or free in both with a root spring on a base.
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

#: Gauss-Legendre rule on [0, 1] exact to degree 11 (products of two cubics are degree 6)
_XI, _WEIGHT = (np.polynomial.legendre.leggauss(6)[0] + 1) / 2, np.polynomial.legendre.leggauss(6)[1] / 2
#: the root dofs each root condition fixes (0: the deflection w(0), 1: the slope w_x(0))
ROOT_DOFS = {"clamped": (0, 1), "spring": (0,), "base": (1,), "spring_base": ()}


def hermite(xi: np.ndarray, h: float, order: int) -> np.ndarray:
    """The four shape functions' ``order``-th x-derivative at local coordinates xi: (len(xi), 4)."""
    xi = np.asarray(xi, dtype=float)
    if order == 0:
        cols = [1 - 3 * xi**2 + 2 * xi**3, h * (xi - 2 * xi**2 + xi**3), 3 * xi**2 - 2 * xi**3, h * (xi**3 - xi**2)]
    elif order == 1:
        cols = [(6 * xi**2 - 6 * xi) / h, 1 - 4 * xi + 3 * xi**2, (6 * xi - 6 * xi**2) / h, 3 * xi**2 - 2 * xi]
    elif order == 2:
        cols = [(12 * xi - 6) / h**2, (6 * xi - 4) / h, (6 - 12 * xi) / h**2, (6 * xi - 2) / h]
    else:
        raise ValueError(f"shape function derivative order must be 0, 1 or 2, got {order}")
    return np.stack(cols, axis=-1)


@dataclass(frozen=True)
class Mesh:
    """Uniform mesh of ``n_elements`` Hermite elements on [0, length] (m).

    ``root`` is "clamped" (w(0) = w_x(0) = 0), "spring" (w(0) = 0, the root slope free: a
    rotational spring is added by :meth:`root_spring`), "base" (w_x(0) = 0, the root deflection
    free: a base is added by :meth:`root_translation`) or "spring_base" (both free). Free dofs are
    numbered in node order.
    """

    length: float
    n_elements: int
    root: str = "clamped"

    def __post_init__(self):
        if self.root not in ROOT_DOFS:
            raise ValueError(f"root must be one of {', '.join(ROOT_DOFS)}, got {self.root!r}")
        if self.n_elements < 1 or self.length <= 0:
            raise ValueError("Mesh needs n_elements >= 1 and length > 0")

    @property
    def h(self) -> float:
        return self.length / self.n_elements

    @cached_property
    def free(self) -> np.ndarray:
        """Global dof numbers (node i: 2i deflection, 2i+1 slope) that are not constrained."""
        return np.array([d for d in range(2 * (self.n_elements + 1)) if d not in ROOT_DOFS[self.root]])

    @property
    def n_dof(self) -> int:
        return self.free.size

    def _element_dofs(self, e: int) -> np.ndarray:
        return np.arange(2 * e, 2 * e + 4)

    def _restrict(self, full: np.ndarray) -> np.ndarray:
        return full[np.ix_(self.free, self.free)]

    def rows(self, x, order: int = 0) -> np.ndarray:
        """Rows r with r @ w = the ``order``-th derivative of the deflection at x: (len(x), n_dof)."""
        x = np.atleast_1d(np.asarray(x, dtype=float))
        if np.any(x < -1e-12 * self.length) or np.any(x > self.length * (1 + 1e-12)):
            raise ValueError(f"positions must lie in [0, {self.length}] m, got {x}")
        e = np.minimum((x / self.h).astype(int), self.n_elements - 1)
        values = hermite(x / self.h - e, self.h, order)
        full = np.zeros((x.size, 2 * (self.n_elements + 1)))
        for k in range(4):
            full[np.arange(x.size), 2 * e + k] = values[:, k]
        return full[:, self.free]

    def _assemble(self, order: int) -> np.ndarray:
        """Integral of the order-th derivatives' products over the beam (identical elements)."""
        shapes = hermite(_XI, self.h, order)
        local = shapes.T @ (self.h * _WEIGHT[:, None] * shapes)
        full = np.zeros((2 * (self.n_elements + 1),) * 2)
        for e in range(self.n_elements):
            dofs = self._element_dofs(e)
            full[np.ix_(dofs, dofs)] += local
        return self._restrict(full)

    @cached_property
    def M0(self) -> np.ndarray:
        """int psi_i psi_j dx (m): mass per unit rho*A, air damping per unit gamma."""
        return self._assemble(0)

    @cached_property
    def G0(self) -> np.ndarray:
        """int psi_i' psi_j' dx (1/m): geometric stiffness per unit axial load."""
        return self._assemble(1)

    @cached_property
    def K0(self) -> np.ndarray:
        """int psi_i'' psi_j'' dx (1/m^3): bending stiffness per unit EI."""
        return self._assemble(2)

    def point(self, x: float, order: int = 0) -> np.ndarray:
        """r r^T for the row r of the order-th derivative at x (a point mass or spring)."""
        r = self.rows([x], order)[0]
        return np.outer(r, r)

    def root_spring(self) -> np.ndarray:
        """w_x(0) psi_x(0): the root spring's stiffness per unit k_theta (needs root = "spring")."""
        if 1 in ROOT_DOFS[self.root]:
            raise ValueError('a root spring needs Mesh(root="spring") or "spring_base"')
        return self.point(0.0, order=1)

    def root_translation(self) -> np.ndarray:
        """w(0) psi(0): a base's mass, dashpot or spring per unit m_b, c_b, k_b (needs root = "base")."""
        if 0 in ROOT_DOFS[self.root]:
            raise ValueError('a translating base needs Mesh(root="base") or "spring_base"')
        return self.point(0.0)

    def quadrature(self, points_per_element: int) -> tuple[np.ndarray, np.ndarray]:
        """Gauss-Legendre points and weights (m) covering the beam, ``points_per_element`` per element."""
        xi, w = np.polynomial.legendre.leggauss(points_per_element)
        starts = self.h * np.arange(self.n_elements)[:, None]
        return (starts + self.h * (xi + 1) / 2).ravel(), np.tile(self.h * w / 2, self.n_elements)

    def spatial_hysteresis(self, a: float, b: float, points_per_element: int = 8) -> np.ndarray:
        r"""Damping matrix (N s m) of the Gaussian kernel h = a/(b sqrt(2 pi)) exp(-(x-xi)^2/2b^2).

        The double integral :math:`\tfrac12\sum_{q,r} w_q w_r h_{qr}(s_q - s_r)(s_q - s_r)^T`
        with slope rows s_q = rows(x_q, 1), expanded as
        :math:`S^T[\mathrm{diag}(w \odot Hw) - W H W] S` (the term q = r vanishes).
        """
        x, w = self.quadrature(points_per_element)
        kernel = a / (b * np.sqrt(2 * np.pi)) * np.exp(-((x[:, None] - x[None, :]) ** 2) / (2 * b * b))
        slopes = self.rows(x, 1)
        inner = np.diag(w * (kernel @ w)) - (w[:, None] * kernel * w[None, :])
        return slopes.T @ inner @ slopes
