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


# ----------------------------------------------------------------------------------- friction
#: what :func:`friction_slide` stopped at
SLID_TO_END, STUCK = 0, 1


@numba.njit(cache=True)
def accumulate(c0, c1, k, a, b, g_a, g_b):
    """Add the force, linear from g_a to g_b over [a, b] of step k, to its mean c0 and 12 x first
    moment c1 (both per step)."""
    if b <= a:
        return
    m = 0.5 * (a + b)
    c0[k] += (b - a) * 0.5 * (g_a + g_b)
    c1[k] += 2.0 * (b - a) * ((a - 0.5) * g_a + 2.0 * (m - 0.5) * (g_a + g_b) + (b - 0.5) * g_b)


@numba.njit(cache=True)
def lagrange_row(table, k, theta, lagrange):
    """Row of ``table`` (nodes x ch) at node k + theta by the 6-point Lagrange interpolant on the
    nodes around it; ``lagrange`` (6, 6): weight of node j at xi is sum_p lagrange[j, p] xi^p."""
    base = min(max(k - 2, 0), table.shape[0] - 6)
    xi = k + theta - base
    out = np.zeros(table.shape[1])
    for j in range(6):
        w, power = 0.0, 1.0
        for q in range(6):
            w += lagrange[j, q] * power
            power *= xi
        for c in range(table.shape[1]):
            out[c] += w * table[base + j, c]
    return out


@numba.njit(cache=True)
def step_poly(column, k, shifted):
    """The 6-point interpolant of a node signal on step k, in ascending powers of theta in [0, 1];
    ``shifted[o]`` (6, 6) maps the six node values to those coefficients with step k at offset o."""
    base = min(max(k - 2, 0), column.shape[0] - 6)
    out = np.zeros(6)
    for j in range(6):
        for q in range(6):
            out[q] += column[base + j] * shifted[k - base, j, q]
    return out


@numba.njit(cache=True)
def _re_dot(a, z):
    """Re(sum a z) of two complex vectors."""
    out = 0.0
    for r in range(z.size):
        out += a[r].real * z[r].real - a[r].imag * z[r].imag
    return out


@numba.njit(cache=True)
def _row_dot(row, z):
    """Re(sum a z) for a row given as Re a, -Im a interleaved (the window tables)."""
    out = 0.0
    for r in range(z.size):
        out += row[2 * r] * z[r].real + row[2 * r + 1] * z[r].imag
    return out


@numba.njit(cache=True)
def friction_slide(k, a, n, z, gam, sgn, v, last, free, tables, lin, lagrange, shifted, F, mu,
                   c0, c1, counts, keep, rec_u, rec_v, max_events):
    """The sliding tip from node k + a: full steps by the window tables, the steps with events
    one by one, until the tip sticks or the last node is reached.

    State: z the free-part modal state at k + a, the force gam = -F sgn, v the tip velocity,
    n the events so far in step k. ``free`` (8, m) complex: E = e^{lambda h}, lambda h, beta /
    lambda, cv, cv beta / lambda, cv lambda, cu and gamma_h (the state change per unit force over
    a step); ``tables``: pv, qv, pu, qu, epow, spow as in the
    integrator (window rows 0 .. W). ``lin`` (nodes, 4): the forced tip velocity, acceleration,
    held force and displacement at the nodes (zeros for a release). Adds to c0, c1 (per step),
    counts (stick, slip, reversal, tangency), and with ``keep`` rec_u, rec_v (per node).

    Returns (status, k, a, n, z, gam, sgn, v, demand): :data:`STUCK` at k + a with the friction
    demand there, or :data:`SLID_TO_END`.
    """
    E, lam_h, beta_lam, cv, cvb, cv_lam, cu, gamma_h = free[0], free[1], free[2], free[3], free[4], free[5], free[6], free[7]
    pv, qv, pu, qu, epow, spow = tables
    cvb_sum = 0.0
    for r in range(cvb.size):
        cvb_sum += cvb[r].real
    z = z.copy()
    W = pv.shape[0] - 1
    while k < last:
        if a == 0.0:
            # full steps from node k while the tip keeps sliding the same way (windows of W nodes)
            n = 0
            L = min(W, last - k)
            j = 0
            while j < L:
                vj = _row_dot(pv[j + 1], z) + gam * qv[j + 1] + lin[k + j + 1, 0]
                if sgn * vj <= 0:
                    break
                c0[k + j] = gam
                if keep:
                    rec_v[k + j + 1] = vj
                    rec_u[k + j + 1] = _row_dot(pu[j + 1], z) + gam * qu[j + 1] + lin[k + j + 1, 3]
                v = vj
                j += 1
            for r in range(z.size):
                z[r] = epow[j, r] * z[r] + spow[j, r] * gamma_h[r] * gam
            k += j
            if j == L:
                continue
        # step k from k + a, with a velocity zero inside it
        if a == 0.0:
            ez = E
        else:
            ez = np.exp(lam_h * (1.0 - a))
        z_b = ez * z + gam * (ez - 1) * beta_lam
        v_b = lin[k + 1, 0] + _re_dot(cv, z_b)
        if sgn * v_b > 0 or n >= max_events - 1:
            accumulate(c0, c1, k, a, 1.0, gam, gam)
            z, v, k, a = z_b, v_b, k + 1, 0.0
            if keep:
                rec_v[k] = v
                rec_u[k] = _re_dot(cu, z) + lin[k, 3]
            continue
        # sgn * v_tip(theta): the free-part state at a under the constant force gam
        amp = cv * z + gam * cvb
        poly = step_poly(lin[:, 0], k, shifted)
        lo, hi, f_lo, f_hi = a, 1.0, sgn * v, sgn * v_b
        moving = f_lo > 0
        if not moving:                          # the slip starts at a: find it moving
            for _ in range(16):
                t = 0.5 * (a + hi)
                ft = intra_step(lam_h, amp, amp * lam_h, -gam * cvb_sum, poly, a, sgn, t)[0]
                if ft > 0:
                    lo, f_lo, moving = t, ft, True
                    break
                hi, f_hi = t, ft
        if moving:
            theta = intra_step_root(lam_h, amp, amp * lam_h, -gam * cvb_sum, poly, a, sgn, lo, hi, f_lo, f_hi, 1e-9)
        else:
            theta = hi
        ez = np.exp(lam_h * (theta - a))
        z = ez * z + gam * (ez - 1) * beta_lam
        accumulate(c0, c1, k, a, theta, gam, gam)
        acc_lin = lin[k, 1] if theta == 0.0 else lagrange_row(lin, k, theta, lagrange)[1]
        demand = -(acc_lin + _re_dot(cv_lam, z)) / mu
        n += 1
        if abs(demand) <= F:                    # friction holds the tip: stick
            counts[0] += 1
            return STUCK, k, theta, n, z, gam, sgn, v, demand
        turned = -np.sign(demand)               # it slides on (normally reversed)
        counts[2 if turned != sgn else 3] += 1
        sgn, gam, v, a = turned, -F * turned, 0.0, theta
    return SLID_TO_END, k, a, n, z, gam, sgn, v, 0.0


@numba.njit(cache=True)
def change_and_size(new, old):
    """max |new - old| and max |new| over two arrays of the same shape, in one pass."""
    a, b = new.ravel(), old.ravel()
    change, size = 0.0, 0.0
    for i in range(a.size):
        change = max(change, abs(a[i] - b[i]))
        size = max(size, abs(a[i]))
    return change, size


@numba.njit(cache=True)
def drag_block(z0, u, cubic, quad, E, vlin, to_velocity, rows_t, rows_w, to_modal, c_q, c_v, rtol, sweeps):
    """The fixed-point iteration of one drag block: forces g = -c_q |v| v - c_v v at the Gauss
    points of nodes k+1 .. k+S, each sweep the states from the last sweep's forces.

    ``u`` (S + 2, m): the modal forces at nodes k-1 .. k+S, rows 0 and 1 known (the rest is
    overwritten). ``vlin`` (S, n): the linear response's generalized velocities at the block's
    nodes, or (0, n) for none. First guess: the block's own forces zero. Stops when the largest
    change of a force is at most ``rtol`` x the largest force (or exactly 0); gives up after
    ``sweeps`` sweeps or when a sweep changes the forces by more than half the sweep before.
    Returns (converged, sweeps taken, forces (S, n_q) the states were computed from, states
    (S, m), Gauss-point velocities (S, n_q), the forces those velocities give).
    """
    S = u.shape[0] - 2
    m = E.size
    states = np.empty((S, m), dtype=np.complex128)
    u[2:] = 0.0
    v = drag_velocities(z0, u, cubic, quad, E, vlin, to_velocity, rows_t, states)
    g = drag_law(v, c_q, c_v)
    g_new = g
    u_real = u.view(np.float64)
    prev = np.inf
    for sweep in range(1, sweeps + 1):
        u_real[2:] = np.dot(np.dot(g, rows_w), to_modal)
        v = drag_velocities(z0, u, cubic, quad, E, vlin, to_velocity, rows_t, states)
        g_new = drag_law(v, c_q, c_v)
        delta, size = change_and_size(g_new, g)
        if delta <= rtol * size or delta == 0.0:
            return True, sweep, g, states, v, g_new
        if delta > 0.5 * prev:
            return False, sweep, g, states, v, g_new
        prev, g = delta, g_new
    return False, sweeps, g, states, v, g_new


@numba.njit(cache=True)
def drag_law(v, c_q, c_v):
    """The drag per unit length (N/m) at the velocities v (m/s): -c_q |v| v - c_v v."""
    return -c_q * np.abs(v) * v - c_v * v


@numba.njit(cache=True)
def drag_velocities(z0, u, cubic, quad, E, vlin, to_velocity, rows_t, states):
    """Gauss-point velocities (S, n_q) of the states (:func:`drag_states`, into ``states``)."""
    drag_states(z0, u, cubic, quad, E, states)
    wd = np.dot(states.view(np.float64), to_velocity)
    if vlin.shape[0]:
        wd += vlin
    return np.dot(wd, rows_t)
