r"""Spatial hysteresis (Russell), the paper's eqs. (13)-(15) with the Gaussian kernel (14).

The damping force is :math:`-\partial_x \int_0^l h(x,\xi)\{u_{xt}(x) - u_{xt}(\xi)\}\,d\xi` with

.. math:: h(x, \xi) = \frac{a}{b\sqrt{2\pi}}\, e^{-(x-\xi)^2 / 2b^2},

a in N s, b in m. Integrating by parts (the boundary term is the damping moment of the
free-end condition) and using the symmetry of h gives the symmetric form

.. math::

    d(v, \psi) = \tfrac12 \int_0^l\!\!\int_0^l h(x,\xi)\,
        \{v'(x) - v'(\xi)\}\{\psi'(x) - \psi'(\xi)\}\,d\xi\,dx ,

which is manifestly non-negative. With quadrature nodes :math:`x_q`, weights :math:`w_q` and
:math:`G_{qi} = B_i'(x_q)` the same quadrature is applied to both integrals,

.. math:: D = G^T\,[\mathrm{diag}(w \odot H w) - W H W]\,G, \qquad H_{qr} = h(x_q, x_r),

a weighted graph Laplacian: symmetric positive semi-definite for any quadrature.

Small-b limit: with :math:`v'(\xi) \approx v'(x) + v''(x)(\xi - x)` and
:math:`\int h(x,\xi)(\xi-x)^2 d\xi = a b^2`, away from the ends
:math:`d(v,\psi) \to \tfrac{a b^2}{2}\int v''\psi''`: Kelvin-Voigt with :math:`c_dI = a b^2/2`.

Assembly (the same quadrature sums, regrouped; the result differs only by round-off). The
grid is uniform and every interval carries the same Gauss rule, so with points
:math:`x_{e,i}` (interval e, local point i), local weights :math:`w_i` and the slopes
:math:`P_{i\alpha}` of the q = p + 1 spline pieces of degree p (the same on every interval),
H is block Toeplitz:
the block of intervals (e, e+k) is :math:`T_k[i,j] = h(x_{0,i}, x_{k,j})` and that of (e+k, e)
is :math:`T_k^T`. Only the :math:`N p^2` exponentials of :math:`T_0 .. T_{N-1}` are evaluated
(not :math:`(N p)^2`), and in the standard B-spline coordinates (interval e, piece alpha) the
inner matrix reduces to q x q blocks,

.. math::

    X_{e,e+k} = -P^T W T_k W P \ (k \ge 1), \qquad
    X_{e,e} = P^T \mathrm{diag}(w \odot s_e) P
        + \tfrac12 \sum_{i,j} w_i w_j T_0[i,j] (P_i - P_j)(P_i - P_j)^T,

with :math:`s_e = \sum_{k=1}^{N-1-e} T_k w + \sum_{k=1}^{e} T_k^T w` the kernel's row sums over
the other intervals, and :math:`D = (EC)^T X (EC)`, where EC maps (e, alpha) to the modified
basis. The pairs within one interval are summed in the Laplacian form itself, so the
self-terms h(x_q, x_q), which cancel between diag(w * Hw) and W H W, never enter: for b below
the point spacing this is more accurate than forming the bracket (against extended precision,
at most 7e-15 of max |D| over N = 2..128, b = 0.005..50 m; the bracket form erred by up to
7e-12 at N = 2, b = 0.005 m). Everything that does not depend on (a, b) (points, weights,
slopes, squared distances, the linear maps, the layout of X, EC) is computed once per (basis,
points per interval) and cached; D is linear in a, so a only scales the result. A narrow
kernel (b a small fraction of h) vanishes beyond a few intervals: the offsets k whose closest
pair has :math:`T_k < e^{-40}` everywhere are left at zero and not evaluated. This takes
about 40 us per call at N = 16, b = 0.18 m (8 Gauss points per interval, cubic splines),
against 210 us for the dense 128 x 128 kernel.
"""
import math
from functools import lru_cache

import numpy as np

from bayesbeam.physics.basis import SplineBasis
from bayesbeam.physics.mechanisms.base import Mechanism


def points_per_interval(h: float, b: float) -> int:
    """Gauss points per interval that resolve a Gaussian of width b on intervals of width h.

    Chosen so that doubling them changes D by less than 1e-8 relative (tested).
    """
    ratio = 3.0 * h / b             # plain floats: this runs on every call of damping
    if not ratio < 42.0:            # ceil(ratio) + 6 >= 48 (also for ratio = inf)
        return 48
    return max(math.ceil(ratio) + 6, 6)


#: -ln of the smallest kernel value kept (relative to its peak, 1): a block whose every value is
#: below exp(-40) = 4e-18 adds less to D than the round-off of its largest entries (1e-16 of
#: them), and is left at zero
UNDERFLOW = 40.0


@lru_cache(maxsize=32)
def _slope_rows(basis: SplineBasis, n_points: int):
    x, w = basis.quadrature(n_points)
    return x, w, basis.evaluate(x, 1)


class _Assembly:
    """The (a, b)-independent part of D for one basis and one Gauss rule (see the module doc).

    Per call only T_k = exp(-d_k^2 / 2b^2) changes, and everything after it is linear in T_k:
    one product ``t @ maps`` gives, for every offset k, the q * q numbers of each of -Q_k,
    P^T diag(w T_k w) P, P^T diag(w T_k^T w) P and the within-interval term; a second sums the
    diagonal blocks; a gather lays out X; two products project it onto the basis.
    """

    SLOTS = 4     # per offset k: -Q_k, row-sum term, column-sum term, within-interval term

    def __init__(self, basis: SplineBasis, n_points: int):
        n, p, q = basis.n_intervals, n_points, basis.pieces
        x, w = basis.quadrature(p)
        # d[k, i, j] = x_{0,i} - x_{k,j}: the differences in the blocks (e, e+k) of H
        d = np.subtract.outer(x[:p], x).reshape(p, n, p).transpose(1, 0, 2)
        d[0, np.arange(p), np.arange(p)] = basis.h   # self-pairs: zero weight in every map (dP = 0)
        # and a non-zero distance keeps their T finite for any b (0 * inf would give nan)
        self.minus_half_d2 = np.ascontiguousarray((-0.5 * d**2).reshape(n, p * p))
        # the closest pair of each offset k (self-pairs at h): a narrow kernel leaves the far
        # offsets' blocks T_k at zero in double precision, and they are skipped
        self.closest = np.min(d**2, axis=(1, 2))
        w = w[:p]                                                        # local weights
        slopes = basis.standard(x[:p], 1)[:, :q]                         # P (p, q), interval 0
        wp = w[:, None] * slopes
        pp = w[:, None, None] * slopes[:, :, None] * slopes[:, None, :]  # (p, q, q)
        diff = slopes[:, None, :] - slopes[None, :, :]                   # P_i - P_j, (p, p, q)
        maps = np.empty((p, p, self.SLOTS, q, q))                        # [(i, j), slot, a, b]
        maps[:, :, 0] = -wp[:, None, :, None] * wp[None, :, None, :]     # -> -Q_k
        maps[:, :, 1] = w[None, :, None, None] * pp[:, None]             # -> P^T diag(w T_k w) P
        maps[:, :, 2] = w[:, None, None, None] * pp[None, :]             # -> P^T diag(w T_k^T w) P
        maps[:, :, 3] = (0.5 * w[:, None, None, None] * w[None, :, None, None]
                         * diff[:, :, :, None] * diff[:, :, None, :])    # (k = 0) 1/2 sum w w T0 dP dP^T
        self.maps = maps.reshape(p * p, self.SLOTS * q * q)
        # diagonal block e = sum over the rows (k, slot) of t @ maps: the within-interval term of
        # k = 0, the row-sum terms of k = 1 .. n-1-e and the column-sum terms of k = 1 .. e
        sums = np.zeros((n, n, self.SLOTS))
        for e in range(n):
            sums[e, 0, 3] = 1.0
            sums[e, 1:n - e, 1] = 1.0
            sums[e, 1:e + 1, 2] = 1.0
        self.sums = sums.reshape(n, n * self.SLOTS)
        # X[(e, alpha), (f, beta)] = buffer[index]; buffer = (t @ maps, the diagonal blocks)
        e, f = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
        alpha, beta = np.meshgrid(np.arange(q), np.arange(q), indexing="ij")
        e, f = e[:, :, None, None], f[:, :, None, None]
        k, ab, ba = np.abs(f - e), q * alpha + beta, q * beta + alpha
        off = q * q * self.SLOTS * k + np.where(f > e, ab, ba)          # -Q_k or -Q_k^T
        index = np.where(f == e, q * q * (self.SLOTS * n + e) + ab, off)
        self.index = np.ascontiguousarray(index.transpose(0, 2, 1, 3).reshape(q * n, q * n))
        # EC: row (e, alpha) holds the modified basis' coefficients of standard spline e + alpha
        rows = (np.arange(n)[:, None] + np.arange(q)).ravel()
        self.ec = np.ascontiguousarray(basis.combination[rows])          # (q n, size)
        self.ect = np.ascontiguousarray(self.ec.T)
        self.n, self.q2 = n, q * q

    def unit_matrix(self, b: float) -> np.ndarray:
        """D for a = b sqrt(2 pi), i.e. the kernel exp(-(x - xi)^2 / 2b^2); not symmetrised."""
        n, q2 = self.n, self.q2
        m = q2 * self.SLOTS * n
        b2 = b * b
        # the offsets whose closest pair's T is below exp(-UNDERFLOW) are left at zero
        k_max = max(1, int(np.searchsorted(self.closest, 2.0 * b2 * UNDERFLOW)))
        t = np.exp(self.minus_half_d2[:k_max] * (1.0 / b2 if b2 > 0 else math.inf))   # T_0 .. T_{k_max-1}
        buffer = np.empty(m + q2 * n)
        np.matmul(t, self.maps, out=buffer[:m].reshape(n, -1)[:k_max])
        buffer[k_max * q2 * self.SLOTS:m] = 0.0
        np.matmul(self.sums, buffer[:m].reshape(-1, q2), out=buffer[m:].reshape(n, q2))
        return self.ect @ (buffer[self.index] @ self.ec)


@lru_cache(maxsize=32)
def _assembly(basis: SplineBasis, n_points: int) -> _Assembly:
    return _Assembly(basis, n_points)


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
        a, b = values["a"], values["b"]
        basis = ops.basis
        d = _assembly(basis, points_per_interval(basis.h, b)).unit_matrix(b)
        scale = 0.5 * a / (b * math.sqrt(2 * math.pi))
        return scale * (d + d.T)
