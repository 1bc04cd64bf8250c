r"""Cubic B-spline Galerkin basis on a uniform grid, modified at the root.

The standard cubic B-splines :math:`\tilde B_j`, :math:`j = -1, \dots, N+1`, on the grid
:math:`x_i = i h`, :math:`h = l/N`, span the :math:`C^2` cubic splines (dimension :math:`N+3`).
Only :math:`\tilde B_{-1}, \tilde B_0, \tilde B_1` are non-zero at :math:`x = 0`, with values
:math:`(1/6, 2/3, 1/6)` and slopes :math:`(-1, 0, 1)/(2h)`.

*Clamped root* (:math:`u(0) = u_x(0) = 0`, the paper's space
:math:`V = \{\psi \in H^2 : \psi(0) = \psi'(0) = 0\}`): a combination
:math:`c_{-1}\tilde B_{-1} + c_0 \tilde B_0 + c_1 \tilde B_1` vanishes with its slope iff
:math:`c_{-1} = c_1` and :math:`c_{-1}/6 + 2c_0/3 + c_1/6 = 0`, i.e. it is a multiple of

.. math:: B_0 = \tilde B_{-1} - \tfrac12 \tilde B_0 + \tilde B_1 ,

and the basis is :math:`\{B_0, \tilde B_2, \dots, \tilde B_{N+1}\}`: :math:`N+1` functions, as in the
paper's eq. (35). (The paper's printed modification formulas are garbled: its
:math:`\tilde B_0 - 4\tilde B_{-1}` enforces :math:`u(0) = 0` only.)

*Pinned root* (:math:`u(0) = 0`, slope free; used when the root is a rotational spring): the
clamped basis plus :math:`\tilde B_{-1} - \tilde B_1`, which vanishes at 0 with slope
:math:`-1/h`: :math:`N+2` functions.

The free end is natural: all splines non-zero at :math:`x = l` are kept, so the free-end
conditions (including damping moments) come out of the weak form.
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

ROOTS = ("clamped", "pinned")


def _local_pieces(t: np.ndarray, deriv: int) -> np.ndarray:
    """Values (or t-derivatives) of the four cubic B-spline pieces on one element.

    Column k is the piece of :math:`\\tilde B_{i-1+k}` on element i, as a function of the local
    coordinate t in [0, 1].
    """
    t = np.asarray(t, dtype=float)
    s = 1.0 - t
    if deriv == 0:
        cols = (s**3 / 6, (3 * t**3 - 6 * t**2 + 4) / 6, (-3 * t**3 + 3 * t**2 + 3 * t + 1) / 6, t**3 / 6)
    elif deriv == 1:
        cols = (-(s**2) / 2, 1.5 * t**2 - 2 * t, -1.5 * t**2 + t + 0.5, t**2 / 2)
    elif deriv == 2:
        cols = (s, 3 * t - 2, 1 - 3 * t, t)
    elif deriv == 3:
        one = np.ones_like(t)
        cols = (-one, 3 * one, -3 * one, one)
    else:
        raise ValueError(f"derivative order {deriv} not available for cubic splines (0 to 3)")
    return np.stack(cols, axis=-1)


@dataclass(frozen=True)
class SplineBasis:
    """Modified cubic B-spline basis on [0, length] with ``n_intervals`` uniform intervals.

    Parameters
    ----------
    length : float
        Beam length l (m).
    n_intervals : int
        Number of grid intervals N (the paper's approximation index).
    root : {"clamped", "pinned"}
        Essential conditions at x = 0: u = u_x = 0, or u = 0 only.
    """

    length: float
    n_intervals: int
    root: str = "clamped"

    def __post_init__(self):
        if self.n_intervals < 2:
            raise ValueError(f"n_intervals must be at least 2, got {self.n_intervals}")
        if self.root not in ROOTS:
            raise ValueError(f"root must be one of {ROOTS}, got {self.root!r}")
        if not self.length > 0:
            raise ValueError(f"length must be positive, got {self.length}")

    @property
    def h(self) -> float:
        """Grid spacing l/N (m)."""
        return self.length / self.n_intervals

    @property
    def size(self) -> int:
        """Number of basis functions (degrees of freedom)."""
        return self.n_intervals + (1 if self.root == "clamped" else 2)

    @cached_property
    def combination(self) -> np.ndarray:
        """Matrix C (N+3, size): basis function k is sum_j C[j, k] * B~_{j-1}."""
        n_std = self.n_intervals + 3
        c = np.zeros((n_std, self.size))
        c[0:3, 0] = (1.0, -0.5, 1.0)
        c[3:, 1 : self.n_intervals + 1] = np.eye(self.n_intervals)
        if self.root == "pinned":
            c[0, -1], c[2, -1] = 1.0, -1.0
        return c

    def standard(self, x, deriv: int = 0) -> np.ndarray:
        """Standard B-splines (or their x-derivatives) at points x: array (len(x), N+3)."""
        x = np.atleast_1d(np.asarray(x, dtype=float))
        if np.any(x < -1e-12 * self.length) or np.any(x > self.length * (1 + 1e-12)):
            raise ValueError(f"points must lie in [0, {self.length}] m")
        u = np.clip(x / self.h, 0.0, self.n_intervals)
        elem = np.minimum(np.floor(u).astype(int), self.n_intervals - 1)
        pieces = _local_pieces(u - elem, deriv) / self.h**deriv
        out = np.zeros((x.size, self.n_intervals + 3))
        rows = np.arange(x.size)[:, None]
        out[rows, elem[:, None] + np.arange(4)] = pieces
        return out

    def evaluate(self, x, deriv: int = 0) -> np.ndarray:
        """Basis functions (or derivatives) at points x: array (len(x), size)."""
        return self.standard(x, deriv) @ self.combination

    def quadrature(self, points_per_interval: int = 4) -> tuple[np.ndarray, np.ndarray]:
        """Gauss-Legendre points and weights on every interval (exact to degree 2n-1 per interval)."""
        g, w = np.polynomial.legendre.leggauss(points_per_interval)
        left = np.arange(self.n_intervals)[:, None] * self.h
        x = (left + (g + 1.0) * self.h / 2).ravel()
        weights = np.tile(w * self.h / 2, self.n_intervals)
        return x, weights
