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


# ------------------------------------------------------------------ friction: the event loop
#: what :func:`friction_run` stopped at: the last node, or a conversion between the held and the
#: free state of a forced record that needs the held-minus-free forced response (built by the
#: caller at that first use, after which the call resumes from the state it left)
DONE, NEED_DIFF = 0, 1
#: the tip's phase in :func:`friction_run`'s state: before node 0's conversion, held, sliding, and
#: a conversion pending at k + a (into the held state with the demand ``reals[DEMAND]``, or out of it)
START, HELD, SLIDING, TO_HELD, TO_FREE = 0, 1, 2, 3, 4
#: slots of the integer state: node k, phase, events in step k, initial hold still on, window
K, PHASE, EVENTS, INITIAL, WINDOW = 0, 1, 2, 3, 4
#: slots of the real state: a in [0, 1) past node k, held tip deflection U_s, held-tip force
#: (demand) g, sliding force gam, sliding direction sgn, tip velocity v, demand at a pending stick
A, U_S, G, GAM, SGN, V, DEMAND = 0, 1, 2, 3, 4, 5, 6
#: half-width and shape of the windowed sinc that reads the held-minus-free table (:func:`kaiser_read`)
SINC_HALF, SINC_BETA = 16, 16.0


@numba.njit(cache=True)
def bessel_i0(x):
    """The modified Bessel function I0(x) by its power series sum (x^2/4)^k / (k!)^2 (x <= 16:
    terms below 1e-17 of the sum after 60)."""
    term, total, q = 1.0, 1.0, 0.25 * x * x
    for k in range(1, 80):
        term *= q / (k * k)
        total += term
        if term < 1e-17 * total:
            break
    return total


@numba.njit(cache=True)
def kaiser_read(values, t0, step, t):
    """Row of a table sampled at t0 + i step, at time t, by a 32-tap Kaiser-windowed sinc (the
    signal is band-limited to 0.51 fs, a quarter of the table's rate: error ~1e-8 of its peak)."""
    x = (t - t0) / step
    k0 = int(np.floor(x)) - SINC_HALF + 1
    out = np.zeros(values.shape[1])
    norm = bessel_i0(SINC_BETA)
    for i in range(2 * SINC_HALF):
        u = x - (k0 + i)
        sinc = 1.0 if u == 0.0 else np.sin(np.pi * u) / (np.pi * u)
        w = sinc * bessel_i0(SINC_BETA * np.sqrt(max(1.0 - (u / SINC_HALF) ** 2, 0.0))) / norm
        for c in range(values.shape[1]):
            out[c] += w * values[k0 + i, c]
    return out


@numba.njit(cache=True)
def spectrum_read(spectrum, s, n_fft, t):
    """Row at time t of a signal and of its rate, given on the bins s (the band-limited
    interpolant of an exponentially windowed FFT: (2 / n_fft) Re sum_k c_k e^{s_k t} X_k, c_0 = 1/2,
    and the same with s_k X_k), for a signal read once."""
    ch = spectrum.shape[1]
    out = np.zeros(2 * ch)
    for b in range(s.size):
        kernel = np.exp(s[b] * t) * (0.5 if b == 0 else 1.0)
        for c in range(ch):
            x = kernel * spectrum[b, c]
            out[c] += x.real
            out[ch + c] += (x * s[b]).real
    return out * (2.0 / n_fft)


@numba.njit(cache=True)
def _diff_at(k, theta, exact, timing, diff):
    """(w_held - w_free, its rate) of the forced responses at node k + theta, stacked.

    Zero for a release and at node 0 of a forced record (both still at rest there). ``exact``:
    summed over the bins (:func:`spectrum_read`), for the end of the hold that starts at node 0,
    whose entry is that exact zero; else read from the table (:func:`kaiser_read`). A stick's
    entry and exit must read the same representation: their errors, ~1e-8 of the peak, do not
    cancel otherwise. ``timing``: forced (1 or 0), t_start, h, the table's t0 and step, n_fft.
    """
    spectrum, s, table = diff
    if timing[0] == 0.0 or k + theta == 0.0:
        return np.zeros(2 * spectrum.shape[1])
    t = timing[1] + (k + theta) * timing[2]
    if exact:
        return spectrum_read(spectrum, s, timing[5], t)
    return kaiser_read(table, timing[3], timing[4], t)


@numba.njit(cache=True)
def _needs_diff(k, theta, timing, diff):
    """Whether a conversion at node k + theta reads a held-minus-free response not yet built."""
    return timing[0] != 0.0 and k + theta != 0.0 and diff[0].shape[0] == 0


@numba.njit(cache=True)
def to_held(k, theta, z, lin, lagrange, conv, mu, timing, diff, exact):
    """Held-tip state (y, U_s) at node k + theta from the free-part modal state z.

    The tip velocity left (zero at a located crossing, round-off otherwise) is removed by the
    constraint's impulse. ``conv``: V, V^-1, Vr, Vr^-1 (the free and the held modes), T, T^T,
    psi, M^-1 e and e (see :class:`bayesbeam.response.nonlinear._Friction`).
    """
    V, Vri, T, Tt, psi, minv_e, e = conv[0], conv[3], conv[4], conv[5], conv[6], conv[7], conv[8]
    n = T.shape[0]
    row = lin[k] if theta == 0.0 else lagrange_row(lin, k, theta, lagrange)
    x = np.dot(V, z).real
    w, wd = x[:n].copy(), x[n:].copy()
    impulse = -(row[0] + np.dot(e, wd)) / mu
    wd += minv_e * impulse
    u_s = row[3] + np.dot(e, w)
    d = _diff_at(k, theta, exact, timing, diff)
    held = np.concatenate((np.dot(Tt, w - psi * u_s - d[:n]), np.dot(Tt, wd - d[n:])))
    return np.dot(Vri, held.astype(np.complex128)), u_s


@numba.njit(cache=True)
def to_free(k, theta, y, u_s, conv, timing, diff, exact):
    """Free-part modal state z at node k + theta from the held-tip state (y, U_s) (:func:`to_held`)."""
    Vi, Vr, T, psi = conv[1], conv[2], conv[4], conv[6]
    n, m = T.shape
    qq = np.dot(Vr, y).real
    d = _diff_at(k, theta, exact, timing, diff)
    x = np.concatenate((np.dot(T, qq[:m].copy()) + psi * u_s + d[:n], np.dot(T, qq[m:].copy()) + d[n:]))
    return np.dot(Vi, x.astype(np.complex128))


@numba.njit(cache=True)
def _held_window(ints, reals, y, last, held, lin, F, c0, c1, keep, rec_u, window_min, window_max):
    """Full steps of the held tip from node k while the demand stays within +-F (a window of
    nodes at a time, each node's demand a row of the window tables times y); returns whether
    the window ended inside a step whose demand leaves +-F (which then needs :func:`_hold_step`)."""
    k_tip, er_pow, pg, pg_mean, pg_moment, moments = held[2], held[3], held[4], held[5], held[6], held[7]
    k, u_s = ints[K], reals[U_S]
    L = min(ints[WINDOW], last - k)
    ints[EVENTS] = 0
    j, g_j = L, 0.0
    for i in range(L + 1):
        g_i = k_tip * u_s + _row_dot(pg[i], y) + lin[k + i, 2]
        if i > 0 and abs(g_i) > F:
            j = i - 1
            break
        g_j = g_i
    for i in range(j):
        c0[k + i] = k_tip * u_s + _row_dot(pg_mean[i], y) + moments[0, k + i]
        c1[k + i] = _row_dot(pg_moment[i], y) + moments[1, k + i]
    if keep:
        rec_u[k:k + j + 1] = u_s
    for r in range(y.size):
        y[r] = er_pow[j, r] * y[r]
    reals[G] = g_j
    ints[K] = k + j
    if j == L:
        ints[WINDOW] = min(2 * ints[WINDOW], window_max)
        return False
    ints[WINDOW] = min(window_max, max(window_min, 2 * j))
    return True


@numba.njit(cache=True)
def _hold_step(ints, reals, y, held, lin, shifted, F, c0, c1, counts, keep, rec_u, max_events):
    """Advance the held tip from node k + a to node k + 1, or to the instant where the demand
    leaves +-F inside the step (the tip starts to slide: phase :data:`TO_FREE` at k + theta)."""
    lr_h, cg, k_tip = held[0], held[1], held[2]
    k, a, u_s, g_a = ints[K], reals[A], reals[U_S], reals[G]
    y_b = np.exp(lr_h * (1.0 - a)) * y
    g_b = lin[k + 1, 2] + k_tip * u_s + _re_dot(cg, y_b)
    if abs(g_b) <= F or ints[EVENTS] >= max_events - 1:
        accumulate(c0, c1, k, a, 1.0, g_a, g_b)
        y[:] = y_b
        reals[G], reals[A], ints[K] = g_b, 0.0, k + 1
        if keep:
            rec_u[k + 1] = u_s
        return
    side = np.sign(g_b)
    # F - side * demand(theta), decreasing through zero at the exit
    f_a = F - side * g_a
    theta = a
    if f_a > 0:
        amp = cg * y
        theta = intra_step_root(lr_h, amp, amp * lr_h, k_tip * u_s - side * F, step_poly(lin[:, 2], k, shifted),
                                a, -side, a, 1.0, f_a, F - side * g_b, 1e-9)
    y[:] = np.exp(lr_h * (theta - a)) * y
    accumulate(c0, c1, k, a, theta, g_a, side * F)
    reals[A], reals[SGN], reals[GAM], reals[V] = theta, -side, side * F, 0.0
    ints[PHASE] = TO_FREE
    ints[EVENTS] += 1
    counts[1] += 1


@numba.njit(cache=True)
def friction_run(ints, reals, z, y, last, free, tables, held, conv, lin, lagrange, shifted, F, mu, timing, diff,
                 c0, c1, counts, keep, rec_u, rec_v, max_events, window_min, window_max):
    """The whole stick-slip history from the state (``ints``, ``reals``, free-part modal state z,
    held state y) to the last node, where z is left as the final free-part state.

    Phase :data:`START`: z is the state at node 0, converted to the held state, and to the
    sliding one if friction cannot hold the demand there. Held phases: :func:`_held_window` and
    :func:`_hold_step`; sliding ones: :func:`friction_slide`; conversions: :func:`to_held`,
    :func:`to_free`. Adds to c0, c1 (per step), counts (stick, slip, reversal, tangency), and
    with ``keep`` rec_u, rec_v (per node). Returns :data:`DONE`, or :data:`NEED_DIFF` with the
    state left where a conversion needs the held-minus-free response (``diff`` empty); called
    again with it, the run goes on from there.
    """
    if ints[PHASE] == START:
        y[:], reals[U_S] = to_held(0, 0.0, z, lin, lagrange, conv, mu, timing, diff, False)
        reals[G] = lin[0, 2] + held[2] * reals[U_S] + _re_dot(held[1], y)
        ints[PHASE], ints[INITIAL], ints[WINDOW] = HELD, 1, window_min
        if abs(reals[G]) > F:                              # the initial state cannot be held
            z[:] = to_free(0, 0.0, y, reals[U_S], conv, timing, diff, False)
            reals[SGN] = -np.sign(reals[G])
            reals[GAM], reals[V] = -F * reals[SGN], 0.0
            ints[PHASE], ints[INITIAL] = SLIDING, 0
        if keep:
            rec_u[0] = reals[U_S]
    while True:
        phase, k, a = ints[PHASE], ints[K], reals[A]
        if phase == TO_HELD or phase == TO_FREE:
            if _needs_diff(k, a, timing, diff):
                return NEED_DIFF
            if phase == TO_HELD:
                y[:], reals[U_S] = to_held(k, a, z, lin, lagrange, conv, mu, timing, diff, False)
                reals[G], ints[PHASE] = reals[DEMAND], HELD
            else:
                z[:] = to_free(k, a, y, reals[U_S], conv, timing, diff, ints[INITIAL] == 1)
                ints[PHASE], ints[INITIAL] = SLIDING, 0
            continue
        if k >= last:
            break
        if phase == SLIDING:
            status, k, a, n, z_new, gam, sgn, v, demand = friction_slide(
                k, a, ints[EVENTS], z, reals[GAM], reals[SGN], reals[V], last, free, tables, lin, lagrange, shifted,
                F, mu, c0, c1, counts, keep, rec_u, rec_v, max_events)
            z[:] = z_new
            ints[K], ints[EVENTS], reals[A], reals[GAM], reals[SGN], reals[V] = k, n, a, gam, sgn, v
            if status == STUCK:
                ints[PHASE], reals[DEMAND] = TO_HELD, demand
            continue
        if a == 0.0 and not _held_window(ints, reals, y, last, held, lin, F, c0, c1, keep, rec_u,
                                         window_min, window_max):
            continue
        _hold_step(ints, reals, y, held, lin, shifted, F, c0, c1, counts, keep, rec_u, max_events)
    if ints[PHASE] == HELD:
        if _needs_diff(last, 0.0, timing, diff):
            return NEED_DIFF
        z[:] = to_free(last, 0.0, y, reals[U_S], conv, timing, diff, ints[INITIAL] == 1)
    return DONE


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
