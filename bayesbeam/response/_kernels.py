"""Compiled inner loops of the nonlinear effects' integrator (:mod:`bayesbeam.response.nonlinear`).

numba compiles them at their first call and caches the machine code beside this file
(``cache=True``), so a process pays the compilation once per installation, not per call.
"""
from __future__ import annotations

import numba
import numpy as np


@numba.njit(cache=True)
def drag_states(z0, u, cubic, quad, E, out):
    """States z_1 .. z_S of a drag block: z_{i+1} = E z_i + w_i from z_0 = ``z0``, into ``out`` (S, m).

    ``u`` (S + 2, m) holds the modal forces at the nodes k-1 .. k+S. Step i (node k+i to k+i+1)
    takes w_i = sum_j cubic[j] u[i + j] (the cubic through nodes k+i-1 .. k+i+2), the last step
    w_{S-1} = sum_j quad[j] u[S - 1 + j] (the quadratic through k+S-2 .. k+S). The recurrence
    runs step by step, exactly as stated: no power of E^-1 and no rounding growth.
    """
    S, m = out.shape
    z = z0.copy()
    for i in range(S - 1):
        for r in range(m):
            z[r] = E[r] * z[r] + (cubic[0, r] * u[i, r] + cubic[1, r] * u[i + 1, r]
                                  + cubic[2, r] * u[i + 2, r] + cubic[3, r] * u[i + 3, r])
            out[i, r] = z[r]
    for r in range(m):
        z[r] = E[r] * z[r] + (quad[0, r] * u[S - 1, r] + quad[1, r] * u[S, r] + quad[2, r] * u[S + 1, r])
        out[S - 1, r] = z[r]


@numba.njit(cache=True)
def intra_step(mu, amp, amp_d, const, poly, a, sign, theta):
    """sign (Re sum_j amp_j e^{mu_j (theta - a)} + const + poly(theta)) and its theta-derivative.

    ``amp_d`` = amp mu; ``poly`` holds ascending coefficients (empty for none).
    """
    v, d = 0.0, 0.0
    for j in range(mu.size):
        ex = np.exp(mu[j] * (theta - a))
        v += (ex * amp[j]).real
        d += (ex * amp_d[j]).real
    pv, pd = 0.0, 0.0
    for i in range(poly.size - 1, -1, -1):           # Horner, with the derivative
        pd = pd * theta + pv
        pv = pv * theta + poly[i]
    return sign * (v + const + pv), sign * (d + pd)


@numba.njit(cache=True)
def intra_step_root(mu, amp, amp_d, const, poly, a, sign, lo, hi, f_lo, f_hi, tol):
    """Root in [lo, hi] of :func:`intra_step`'s value, given f(lo) = f_lo > 0 >= f(hi) = f_hi.

    Newton's method from the false-position point; a step that leaves the bracket is replaced
    by an Illinois false-position step, so the bracket always shrinks.
    """
    t = lo + (hi - lo) * f_lo / (f_lo - f_hi)
    side = 0
    for _ in range(100):
        v, d = intra_step(mu, amp, amp_d, const, poly, a, sign, t)
        if v > 0:
            lo, f_lo = t, v
            if side == 1:
                f_hi *= 0.5
            side = 1
        else:
            hi, f_hi = t, v
            if side == -1:
                f_lo *= 0.5
            side = -1
        new = t - v / d if d != 0 else lo
        if not lo < new < hi:
            new = lo + (hi - lo) * f_lo / (f_lo - f_hi)
        if abs(new - t) <= tol or hi - lo <= tol:
            return new
        t = new
    return t
