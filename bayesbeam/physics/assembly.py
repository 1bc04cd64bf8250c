r"""Parameter-free Galerkin forms of the cantilever and its tip body.

With the basis :math:`\{B_i\}` of :mod:`bayesbeam.physics.basis`, the weak form of the beam
equation (the paper's eq. 32 and 36) needs three integrals, each assembled once and scaled by
the parameters later:

.. math::

    (M_0)_{ij} = \int_0^l B_i B_j \,dx, \qquad
    (K_0)_{ij} = \int_0^l B_i'' B_j'' \,dx, \qquad
    (G_0)_{ij} = \int_0^l B_i' B_j' \,dx .

The mass matrix is :math:`M = \rho A\, M_0 + m_T\, e e^T + J\, e' e'^T` with
:math:`e = B(l)`, :math:`e' = B'(l)`: the tip body's inertia enters at :math:`x = l`, which is
how the weak form carries the free-end conditions (4)-(5) of the paper. The elastic stiffness is
:math:`EI\, K_0`. With splines of degree p all integrands are polynomials of degree at most 2p
on each interval, so (p+1)-point Gauss-Legendre quadrature is exact.
"""
from __future__ import annotations

from dataclasses import dataclass, replace
from functools import cached_property

import numpy as np

from bayesbeam.physics.basis import SplineBasis

#: point matrices :meth:`BeamOperators.point_matrix` keeps (a few fixed points and the latest
#: fitted ones; 16 of them at N = 48 hold 0.4 MB)
POINT_MATRICES_KEPT = 16


@dataclass(frozen=True)
class BeamOperators:
    """The Galerkin forms of one beam discretisation.

    Parameters
    ----------
    basis : SplineBasis
    rho_a : float
        Mass per unit length rho*A (kg/m).
    m_T, J : float
        Tip mass (kg) and rotary inertia (kg m^2) at x = l.
    """

    basis: SplineBasis
    rho_a: float
    m_T: float = 0.0
    J: float = 0.0

    @property
    def length(self) -> float:
        return self.basis.length

    @property
    def size(self) -> int:
        return self.basis.size

    @cached_property
    def _gauss(self):
        x, w = self.basis.quadrature()
        return x, w, [self.basis.evaluate(x, d) for d in (0, 1, 2)]

    def _gram(self, deriv: int) -> np.ndarray:
        _, w, values = self._gauss
        b = values[deriv]
        return (b * w[:, None]).T @ b

    @cached_property
    def M0(self) -> np.ndarray:
        """Integral of B_i B_j (m)."""
        return self._gram(0)

    @cached_property
    def G0(self) -> np.ndarray:
        """Integral of B_i' B_j' (1/m)."""
        return self._gram(1)

    @cached_property
    def K0(self) -> np.ndarray:
        """Integral of B_i'' B_j'' (1/m^3): the stiffness per unit EI."""
        return self._gram(2)

    @cached_property
    def tip_value(self) -> np.ndarray:
        """B_i(l): the tip displacement row."""
        return self.basis.evaluate([self.length])[0]

    @cached_property
    def tip_slope(self) -> np.ndarray:
        """B_i'(l): the tip rotation row."""
        return self.basis.evaluate([self.length], 1)[0]

    @cached_property
    def root_slope(self) -> np.ndarray:
        """B_i'(0): zero for a clamped basis, the root rotation row for a pinned one."""
        return self.basis.evaluate([0.0], 1)[0]

    @cached_property
    def M(self) -> np.ndarray:
        """Mass matrix (kg): beam plus tip body."""
        e, s = self.tip_value, self.tip_slope
        return self.rho_a * self.M0 + self.m_T * np.outer(e, e) + self.J * np.outer(s, s)

    def at_length(self, length: float) -> BeamOperators:
        """The forms of the same beam (rho_a, m_T, J, grid N, degree, root) at another free length.

        A uniform grid of N intervals on [0, l] is the grid on [0, l_0] stretched by s = l/l_0, and
        its splines are those of [0, l_0] at x/s (the root combinations are in the grid's local
        coordinate), so the integrals scale exactly: M_0 s, G_0 / s, K_0 / s^3 (each derivative
        brings 1/s, dx brings s). They are scaled here rather than integrated again; point rows,
        the tip's rows and the quadrature come from the basis on [0, l] itself, so a mechanism
        that integrates in x (a kernel of width b in m) sees the beam of length l.
        """
        s = length / self.length
        other = BeamOperators(replace(self.basis, length=length), self.rho_a, self.m_T, self.J)
        # the cached properties' own slots: the scaled forms instead of a second quadrature
        vars(other).update(M0=self.M0 * s, G0=self.G0 / s, K0=self.K0 / s**3)
        return other

    def rows(self, x, deriv: int = 0) -> np.ndarray:
        """Point-evaluation rows: u(x_k) = rows[k] @ w for the coefficient vector w."""
        return self.basis.evaluate(x, deriv)

    def point_matrix(self, x: float) -> np.ndarray:
        """r r^T with r = B(x): the Galerkin matrix of a unit point mass at x (m from the clamp).

        Cached per x: a point-mass effect asks for it on every likelihood call, and evaluating
        the splines cost it more than the rest of its assembly. Only the last
        :data:`POINT_MATRICES_KEPT` points are kept: where the point is a fitted sensor position,
        x changes on every call.
        """
        cached = self._point_matrices.pop(x, None)
        if cached is None:
            r = self.rows([x])[0]
            cached = np.outer(r, r)
            if len(self._point_matrices) >= POINT_MATRICES_KEPT:
                del self._point_matrices[next(iter(self._point_matrices))]     # the least recently used
        self._point_matrices[x] = cached
        return cached

    @cached_property
    def _point_matrices(self) -> dict[float, np.ndarray]:
        return {}
