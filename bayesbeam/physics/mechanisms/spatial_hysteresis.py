r"""Spatial hysteresis (Russell), the paper's eqs. (13)-(15) with the Gaussian kernel (14).

The damping force is :math:`-\partial_x \int_0^l h(x,\xi)\{u_{xt}(x) - u_{xt}(\xi)\}\,d\xi` with

.. math:: h(x, \xi) = \frac{a}{b\sqrt{2\pi}}\, e^{-(x-\xi)^2 / 2b^2},

a in N s, b in m. Integrating by parts (the boundary term is the damping moment of the
free-end condition) and using the symmetry of h gives the symmetric form

.. math::

    d(v, \psi) = \tfrac12 \int_0^l\!\!\int_0^l h(x,\xi)\,
        \{v'(x) - v'(\xi)\}\{\psi'(x) - \psi'(\xi)\}\,d\xi\,dx ,

which is manifestly non-negative.

Small-b limit: with :math:`v'(\xi) \approx v'(x) + v''(x)(\xi - x)` and
:math:`\int h(x,\xi)(\xi-x)^2 d\xi = a b^2`, away from the ends
:math:`d(v,\psi) \to \tfrac{a b^2}{2}\int v''\psi''`: Kelvin-Voigt with :math:`c_dI = a b^2/2`.

Assembly, exact for every width b. With :math:`\xi = x + s` the two halves of the square are
equal, and

.. math::

    d(v, \psi) = a \int_0^l \varphi_b(s)\, F_{v\psi}(s)\, ds, \qquad
    F_{v\psi}(s) = \int_0^{l-s} \{v'(x) - v'(x+s)\}\{\psi'(x) - \psi'(x+s)\}\, dx,

:math:`\varphi_b` the normal density of sd b. On a uniform grid of spacing h, for s in
:math:`[kh, (k+1)h]` the x-integral splits at the knots and at the knots shifted by -s into
pieces on which both factors are single polynomials of degree p - 1 in (x, s), with limits
linear in s: :math:`F` is a polynomial of degree 2p - 1 in s there, and on the first interval
:math:`F = s^2 Q(s)` with Q of degree 2p - 3 (each factor vanishes at s = 0). So the matrices
:math:`F_k(s)` (entries :math:`F_{B_i B_j}`) are stored once per grid as Legendre coefficient
matrices in s, interpolated from 2p (2p - 2 for Q) Chebyshev nodes at which each is computed
exactly (Gauss-Legendre with p points on every piece, exact for its degree 2p - 2). They are
computed on the grid of unit spacing (the splines are the same functions of x/h on every grid,
so :math:`F_k` scales as 1/h): a beam whose length is a parameter reuses them. A call only
integrates the normal density against those polynomials,

.. math:: D = a \sum_k \sum_j \mu_{kj}(b)\, C_{kj}, \qquad
    \mu_{kj} = \int_{kh}^{(k+1)h} \varphi_b(s)\, P_j(t_k(s))\, ds

(times :math:`s^2` for k = 0), by Gauss-Legendre on sub-intervals no wider than b
(:data:`S_POINTS` points: exact to round-off for a Gaussian over one width times a polynomial
of degree below 20). The kernel's width enters only there, so a kernel narrower than any
quadrature spacing is integrated as exactly as a wide one, and the factor :math:`s^2` carries
the Kelvin-Voigt limit to b -> 0 without cancellation. A kernel that is below
:math:`e^{-40}` of its peak (:data:`UNDERFLOW`) beyond an interval's start adds nothing there,
and the offsets k beyond are skipped.
"""
import math
from functools import lru_cache

import numpy as np
from numpy.polynomial import legendre

from bayesbeam.physics.basis import SplineBasis
from bayesbeam.physics.mechanisms.base import Mechanism

#: -ln of the smallest kernel value kept (relative to its peak, 1): beyond s = b sqrt(2 UNDERFLOW)
#: the kernel is below exp(-40) = 4e-18 and adds less to D than the round-off of its entries
UNDERFLOW = 40.0
#: Gauss-Legendre points per sub-interval (at most one width b) of the s-integrals
S_POINTS = 20
_S_NODES, _S_WEIGHTS = np.polynomial.legendre.leggauss(S_POINTS)


def _chebyshev(n: int) -> np.ndarray:
    """n Chebyshev points of the first kind on [-1, 1]."""
    return np.cos(np.pi * (np.arange(n) + 0.5) / n)


def _difference_form(basis: SplineBasis, s: float) -> np.ndarray:
    """The matrix F(s) of the module doc, exactly: p Gauss points on every piece of [0, l - s]
    between the knots and the knots shifted by -s."""
    h, n, p = basis.h, basis.n_intervals, basis.degree
    k, sigma = divmod(s, h)
    k = int(k)
    edges = np.sort(np.concatenate([np.arange(n - k) * h, np.arange(1, n - k) * h - sigma,
                                    [(n - k) * h - sigma]]))
    edges = edges[np.concatenate([[True], np.diff(edges) > 1e-14 * h])]
    g, w = np.polynomial.legendre.leggauss(p)
    left, width = edges[:-1, None], np.diff(edges)[:, None]
    x = (left + (g + 1.0) * width / 2).ravel()
    weights = (w * width / 2).ravel()
    delta = basis.evaluate(x, 1) - basis.evaluate(np.minimum(x + s, basis.length), 1)
    f = delta.T @ (weights[:, None] * delta)
    return 0.5 * (f + f.T)


class _Moments:
    """The (a, b)-independent part of D for one grid (N, root, degree) of unit spacing: per offset
    k the 2p Legendre coefficient matrices of F_k (of Q on k = 0, whose last two are zero), as
    rows of ``size**2``."""

    def __init__(self, basis: SplineBasis):
        h, n, p, size = basis.h, basis.n_intervals, basis.degree, basis.size
        coefficients = np.zeros((n, 2 * p, size * size))
        t = _chebyshev(2 * p - 2)
        q = np.array([_difference_form(basis, s) / s**2 for s in (t + 1.0) * h / 2])
        coefficients[0, :2 * p - 2] = np.linalg.solve(legendre.legvander(t, 2 * p - 3), q.reshape(len(t), -1))
        t = _chebyshev(2 * p)
        inverse = np.linalg.inv(legendre.legvander(t, 2 * p - 1))
        for k in range(1, n):
            f = np.array([_difference_form(basis, (k + (tm + 1.0) / 2) * h) for tm in t])
            coefficients[k] = inverse @ f.reshape(len(t), -1)
        self.coefficients = coefficients.reshape(n * 2 * p, size * size)
        self.n, self.p, self.size = n, p, size

    def unit_matrix(self, b: float, h: float) -> np.ndarray:
        """D for a = 1 (the kernel is the normal density of sd b) on the grid of spacing h."""
        width = h / b                                          # an interval, in units of b
        reach = math.sqrt(2.0 * UNDERFLOW)                     # the kernel's reach, in units of b
        if not 0 < width < math.inf:        # b = inf: no kernel; b below 1e-308 h: D ~ a b^2 = 0
            return np.zeros((self.size, self.size))
        used = min(self.n, math.ceil(reach / width))           # the offsets k the kernel reaches
        parts = math.ceil(width) if width > 1.0 else 1         # sub-intervals per interval: <= b wide
        step = width / parts
        count = min(used * parts, math.ceil(reach / step))     # the sub-intervals up to the reach
        parts = min(parts, count)           # a narrow kernel's count stops inside the first interval
        index = np.arange(count)
        k = index // parts
        u = (index[:, None] + (_S_NODES + 1.0) / 2) * step     # s / b at the Gauss points
        density = np.exp(-0.5 * u * u) * (_S_WEIGHTS * step / (2.0 * math.sqrt(2.0 * math.pi)))
        density[k == 0] *= (u[k == 0] / width) ** 2             # F = s^2 Q on the first interval
        t = 2.0 * (u / width - k[:, None]) - 1.0               # Legendre variable on interval k
        rows = legendre.legvander(t, 2 * self.p - 1) * density[..., None]
        mu = np.add.reduceat(rows.sum(axis=1), np.arange(0, count, parts), axis=0)
        return (mu.ravel() @ self.coefficients[:mu.size]).reshape(self.size, self.size) / h


@lru_cache(maxsize=8)
def _moments(n_intervals: int, root: str, degree: int) -> _Moments:
    return _Moments(SplineBasis(float(n_intervals), n_intervals, root, degree))


def kernel(x: np.ndarray, xi: np.ndarray, a: float, b: float) -> np.ndarray:
    """The Gaussian kernel h(x, xi) of eq. (14), N s/m."""
    d = np.subtract.outer(x, xi)
    return a / (b * np.sqrt(2 * np.pi)) * np.exp(-0.5 * (d / b) ** 2)


class SpatialHysteresis(Mechanism):
    name = "spatial_hysteresis"
    bare_modal = False      # a Gaussian-kernel integral operator, not a combination of M_0 and K_0
    parameters = ("a", "b")
    units = {"a": "N s", "b": "m"}
    description = "spatial hysteresis, Gaussian kernel h = a/(b sqrt(2 pi)) exp(-(x-xi)^2/(2 b^2))"

    def check(self, values):
        super().check(values)
        if not values["b"] > 0:
            raise ValueError(f"spatial_hysteresis: b = {values['b']!r} must be > 0 m")

    def damping(self, ops, values):
        basis = ops.basis
        moments = _moments(basis.n_intervals, basis.root, basis.degree)
        return values["a"] * moments.unit_matrix(values["b"], basis.h)
