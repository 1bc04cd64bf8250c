r"""B-spline Galerkin basis of degree p on a uniform grid, modified at the root.

The standard (cardinal) B-splines :math:`\tilde B_j` of degree p on the grid :math:`x_i = i h`,
:math:`h = l/N`, extended by uniform knots beyond both ends, span the :math:`C^{p-1}` splines of
degree p on [0, l] (dimension :math:`N+p`). Column j of :meth:`SplineBasis.standard` is the
spline supported on :math:`[(j-p)h, (j+1)h]`; columns :math:`0, \dots, p-1` are the ones that
do not vanish at :math:`x = 0`. The default, p = 3, is the paper's cubic basis; every odd or
even :math:`p \ge 3` is admissible (:math:`C^2 \subset H^2`).

*Clamped root* (:math:`u(0) = u_x(0) = 0`, the paper's space
:math:`V = \{\psi \in H^2 : \psi(0) = \psi'(0) = 0\}`): the combinations of the p root splines
that vanish with their slope form a space of dimension p - 2. Its basis here: each root spline
:math:`k = 2, \dots, p-1` plus the multiples of the first two that cancel its value and slope,

.. math:: B_k = \tilde B_k + c_{0k} \tilde B_0 + c_{1k} \tilde B_1 ,

(columns counted from 0). The basis is :math:`\{B_2, \dots, B_{p-1}, \tilde B_p, \dots,
\tilde B_{N+p-1}\}`: :math:`N + p - 2` functions. For p = 3 the one root function is
:math:`\tilde B_0 - \tfrac12 \tilde B_1 + \tilde B_2`, the basis has N + 1 functions, as in the
paper's eq. (35). (The paper's printed modification formulas are garbled: its
:math:`\tilde B_0 - 4\tilde B_{-1}` enforces :math:`u(0) = 0` only.)

*Pinned root* (:math:`u(0) = 0`, slope free; used when the root is a rotational spring): the
clamped basis plus :math:`\tilde B_0 - \tilde B_{p-1}`, which vanishes at 0 (the root splines
are mirror images about x = 0) with a non-zero slope: :math:`N + p - 1` functions.

*Sliding root* (:math:`u_x(0) = 0`, value free; used when the clamp sits on a translating base):
the clamped basis plus the sum of the p root splines :math:`\tilde B_0 + \dots + \tilde B_{p-1}`,
which is :math:`1 - \tilde B_p` on :math:`[0, h]` (the splines partition unity), and
:math:`\tilde B_p` starts at x = 0 with value and slope 0: value 1 and slope 0 at the root,
:math:`N + p - 1` functions. (The even :math:`\tilde B_0 + \tilde B_{p-1}` would do too, but
its value is only 2/p!: 4e-4 at p = 7, a badly scaled degree of freedom.)

*Free root* (neither fixed; a rotating clamp on a translating base): the clamped basis plus both,
:math:`N + p` functions, the whole spline space. Each extra function is appended after the
clamped ones (value-free last), so the clamped basis's columns keep their numbers.

The free end is natural: all splines non-zero at :math:`x = l` are kept, so the free-end
conditions (including damping moments) come out of the weak form.

Values and derivatives are evaluated by the Cox-de Boor recursion on one interval's local
coordinate (the pieces are the same on every interval of a uniform grid): only products and
sums of non-negative numbers for the values, so no digits are lost at any degree.
"""
from __future__ import annotations

from dataclasses import dataclass
from fractions import Fraction
from functools import cache, cached_property

import numpy as np

ROOTS = ("clamped", "pinned", "sliding", "free")
#: the root values each condition leaves free: the slope u_x(0), the value u(0)
FREED = {"clamped": (), "pinned": ("slope",), "sliding": ("value",), "free": ("slope", "value")}
#: admissible spline degrees: C^(p-1) splines are in H^2 for p >= 3; the mass matrix's condition
#: number grows about 3000-fold per two degrees (1.4e3 at p = 3, 4.6e6 at p = 5, 3.7e10 at p = 7,
#: N = 32), so the degrees stop at 9
DEGREES = range(3, 10)


def combined_root(roots) -> str:
    """The root condition that frees every root value any of ``roots`` frees: a rotational spring
    ("pinned") and a translating base ("sliding") together leave the root "free".

    >>> combined_root(["pinned", "sliding"]), combined_root([])
    ('free', 'clamped')
    """
    freed = {f for r in roots for f in FREED[r]}
    return next(r for r in ROOTS if set(FREED[r]) == freed)


def _local_pieces(t: np.ndarray, deriv: int, degree: int = 3) -> np.ndarray:
    """Values (or t-derivatives) of the p + 1 B-spline pieces of degree p on one interval.

    Column k is the piece of the standard spline ``j = i + k`` on interval i (the spline that
    ends at the interval's right end is k = 0), as a function of the local coordinate t in
    [0, 1]. Cox-de Boor on unit knots: :math:`N_{k,d} = ((t - k + d) N_{k-1,d-1} +
    (k + 1 - t) N_{k,d-1}) / d`; a derivative is the difference of two neighbours one degree
    lower, :math:`N'_{k,d} = N_{k-1,d-1} - N_{k,d-1}`. An object array of Fractions gives exact
    rationals.
    """
    if not 0 <= deriv <= degree:
        raise ValueError(f"derivative order {deriv} not available for splines of degree {degree} "
                         f"(0 to {degree})")
    t = np.asarray(t)[..., None]
    values = np.ones_like(t)
    for d in range(1, degree - deriv + 1):
        k = np.arange(d + 1)
        lower = np.concatenate([np.zeros_like(t), values], axis=-1)       # N_{k-1, d-1}
        same = np.concatenate([values, np.zeros_like(t)], axis=-1)        # N_{k, d-1}
        values = ((t - k + d) * lower + (k + 1 - t) * same) / d
    for _ in range(deriv):
        values = (np.concatenate([np.zeros_like(t), values], axis=-1)
                  - np.concatenate([values, np.zeros_like(t)], axis=-1))
    return values


@cache
def _root_combination(degree: int) -> np.ndarray:
    """(p, p - 2): the root splines' coefficients of the clamped root functions B_2 .. B_{p-1}.

    Solved in exact rational arithmetic (values and slopes of the root splines at x = 0 are
    rationals), so the cubic's (1, -1/2, 1) comes out exactly.
    """
    value, slope = _root_rows(degree)
    det = value[0] * slope[1] - value[1] * slope[0]
    out = np.zeros((degree, degree - 2))
    for col, k in enumerate(range(2, degree)):
        # c0 v0 + c1 v1 = -v_k and c0 s0 + c1 s1 = -s_k (Cramer's rule)
        c0 = (-value[k] * slope[1] + value[1] * slope[k]) / det
        c1 = (-value[0] * slope[k] + value[k] * slope[0]) / det
        out[0, col], out[1, col], out[k, col] = float(c0), float(c1), 1.0
    return out


def _root_rows(degree: int) -> tuple[np.ndarray, np.ndarray]:
    """Exact values and t-slopes (Fractions) at t = 0 of the first p pieces: the root splines at x = 0."""
    zero = np.array(Fraction(0), dtype=object)
    return _local_pieces(zero, 0, degree)[:degree], _local_pieces(zero, 1, degree)[:degree]


@dataclass(frozen=True)
class SplineBasis:
    """Modified B-spline basis of degree ``degree`` on [0, length] with ``n_intervals`` uniform intervals.

    Parameters
    ----------
    length : float
        Beam length l (m).
    n_intervals : int
        Number of grid intervals N (the paper's approximation index).
    root : {"clamped", "pinned", "sliding", "free"}
        Essential conditions at x = 0: u = u_x = 0, u = 0 only, u_x = 0 only, or none.
    degree : int
        Polynomial degree p of the splines, 3 (cubic, the paper's) to 9.
    """

    length: float
    n_intervals: int
    root: str = "clamped"
    degree: int = 3

    def __post_init__(self):
        if self.n_intervals < 2:
            raise ValueError(f"n_intervals must be at least 2, got {self.n_intervals}")
        if self.root not in ROOTS:
            raise ValueError(f"root must be one of {ROOTS}, got {self.root!r}")
        if not self.length > 0:
            raise ValueError(f"length must be positive, got {self.length}")
        if self.degree not in DEGREES:
            raise ValueError(f"degree must be an integer from {DEGREES.start} to {DEGREES.stop - 1}, "
                             f"got {self.degree!r}")

    @property
    def h(self) -> float:
        """Grid spacing l/N (m)."""
        return self.length / self.n_intervals

    @property
    def size(self) -> int:
        """Number of basis functions (degrees of freedom): N + p - 2 clamped, N + p - 1 pinned or
        sliding, N + p free."""
        return self.n_intervals + self.degree - 2 + len(FREED[self.root])

    @property
    def pieces(self) -> int:
        """Splines non-zero on one interval: p + 1."""
        return self.degree + 1

    @property
    def quadrature_points(self) -> int:
        """Gauss points per interval that integrate the mass form (degree 2p) exactly: p + 1."""
        return self.degree + 1

    @cached_property
    def combination(self) -> np.ndarray:
        """Matrix C (N+p, size): basis function k is sum_j C[j, k] * (standard spline j)."""
        p, n = self.degree, self.n_intervals
        c = np.zeros((n + p, self.size))
        c[:p, : p - 2] = _root_combination(p)
        c[p:, p - 2 : p - 2 + n] = np.eye(n)
        for col, freed in enumerate(FREED[self.root], start=p - 2 + n):
            if freed == "slope":            # mirror images about x = 0: their difference is odd
                c[0, col], c[p - 1, col] = 1.0, -1.0
            else:                           # 1 near the root: value 1, slope 0
                c[:p, col] = 1.0
        return c

    def standard(self, x, deriv: int = 0) -> np.ndarray:
        """Standard B-splines (or their x-derivatives) at points x: array (len(x), N+p)."""
        x = np.atleast_1d(np.asarray(x, dtype=float))
        if np.any(x < -1e-12 * self.length) or np.any(x > self.length * (1 + 1e-12)):
            raise ValueError(f"points must lie in [0, {self.length}] m")
        u = np.clip(x / self.h, 0.0, self.n_intervals)
        elem = np.minimum(np.floor(u).astype(int), self.n_intervals - 1)
        pieces = _local_pieces(u - elem, deriv, self.degree) / self.h**deriv
        out = np.zeros((x.size, self.n_intervals + self.degree))
        rows = np.arange(x.size)[:, None]
        out[rows, elem[:, None] + np.arange(self.pieces)] = pieces
        return out

    def evaluate(self, x, deriv: int = 0) -> np.ndarray:
        """Basis functions (or derivatives) at points x: array (len(x), size)."""
        return self.standard(x, deriv) @ self.combination

    def quadrature(self, points_per_interval: int | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Gauss-Legendre points and weights on every interval (exact to degree 2n-1 per interval);
        default n = p + 1 (:attr:`quadrature_points`)."""
        n_points = self.quadrature_points if points_per_interval is None else points_per_interval
        g, w = np.polynomial.legendre.leggauss(n_points)
        left = np.arange(self.n_intervals)[:, None] * self.h
        x = (left + (g + 1.0) * self.h / 2).ravel()
        weights = np.tile(w * self.h / 2, self.n_intervals)
        return x, weights
