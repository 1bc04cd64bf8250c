r"""Independent reference solvers for the response tests (time domain, no FFT).

Nothing here calls :mod:`bayesbeam.response`: the references integrate the Galerkin equations

.. math:: M \ddot w + D \dot w + K w - K_h \int_0^t g(\sigma)\, w(t - \sigma)\, d\sigma = b\, f(t)

from rest in the time domain, in the undamped modal coordinates of :math:`(K, M)`, where every
system used with them decouples (``D`` and ``K_h`` diagonal in those modes; this is checked).
Only the Galerkin matrices (:mod:`bayesbeam.physics`) are shared with the code under test.

* :func:`memory_newmark` -- time hysteresis by product integration (piecewise-linear history,
  exact kernel weights from incomplete gamma functions) and Newmark average acceleration:
  second order in the step.
* :func:`half_sine_response` -- the exact response of viscously damped modes to a half-sine
  force pulse (matrix exponentials of the oscillator augmented with the sine generator, then
  the closed-form free decay).
* :func:`first_order_hold_response` -- the exact response to the straight-line interpolant of
  force samples (exact discretisation of the modal oscillators with a first-order hold).
* :class:`KaiserDAQ` -- a zero-phase Kaiser-windowed-sinc anti-alias filter followed by
  sampling (a model of the DAQ), applied to fine-grid signals or, exactly, to a half-sine.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import linalg, signal, special

from bayesbeam.physics.assembly import BeamOperators
from bayesbeam.physics.basis import SplineBasis

#: the paper's beam (Table 1): l = 1 m, rho*A = 1710 * 0.597e-3 kg/m, EI = 2.7e10 * 1.64e-9 N m^2
LENGTH, RHO_A, EI = 1.0, 1.02087, 44.28


def paper_operators(n_intervals: int = 16, m_T: float = 0.0, J: float = 0.0) -> BeamOperators:
    """Galerkin forms of the paper's beam with N intervals and an optional tip body."""
    return BeamOperators(SplineBasis(LENGTH, n_intervals), rho_a=RHO_A, m_T=m_T, J=J)


def state_matrix(M, D, K) -> np.ndarray:
    """First-order state matrix [[0, I], [-M^-1 K, -M^-1 D]] of M w'' + D w' + K w = f (K may be complex)."""
    n, minv = M.shape[0], np.linalg.inv(M)
    return np.block([[np.zeros((n, n)), np.eye(n)], [-minv @ K, -minv @ D]])


def gaussian(t, centre: float, std: float, peak: float = 1.0):
    """peak * exp(-(t - centre)^2 / (2 std^2)): a force whose spectrum is exp(-(2 pi f std)^2 / 2)."""
    return peak * np.exp(-0.5 * ((np.asarray(t) - centre) / std) ** 2)


# ---------------------------------------------------------------------------- modal coordinates
@dataclass(frozen=True)
class Modal:
    """Undamped modes of (K, M) and the modal forms of D, K_h and the load vector.

    ``lam`` = omega^2, ``phi`` mass-normalised; ``c`` = diag(phi^T D phi) (1/s);
    ``kappa`` = diag(phi^T K_h phi); ``p`` = phi^T b.
    """

    lam: np.ndarray
    phi: np.ndarray
    c: np.ndarray
    kappa: np.ndarray
    p: np.ndarray

    def out(self, rows: np.ndarray) -> np.ndarray:
        """Output rows in modal coordinates: rows @ phi."""
        return np.atleast_2d(rows) @ self.phi


def modal(M, K, load, D=None, K_h=None, tol: float = 1e-9) -> Modal:
    """Decouple the system; raise AssertionError if D or K_h is not diagonal in the modes."""
    lam, phi = linalg.eigh(K, M)
    n = lam.size
    diags = []
    for a in (D, K_h):
        if a is None:
            diags.append(np.zeros(n))
            continue
        am = phi.T @ a @ phi
        off = am - np.diag(np.diag(am))
        assert np.max(np.abs(off)) <= tol * np.max(np.abs(np.diag(am))), "not modally diagonal"
        diags.append(np.diag(am).copy())
    return Modal(lam, phi, diags[0], diags[1], phi.T @ load)


# ---------------------------------------------------------------------------- time hysteresis
def kernel_moments(x, alpha: float, beta: float, r: float):
    r"""F0(x) = int_0^min(x,r) g, F1(x) = int_0^min(x,r) sigma g for g = alpha e^{-beta s}/sqrt(s).

    int_0^X s^{a-1} e^{-beta s} ds = Gamma(a) P(a, beta X) / beta^a (regularised lower incomplete
    gamma function P), with a = 1/2 and 3/2. Requires beta > 0.
    """
    if not beta > 0:
        raise ValueError("the product-integration weights need beta > 0")
    xc = np.minimum(np.asarray(x, dtype=float), r)
    f0 = alpha * special.gamma(0.5) * special.gammainc(0.5, beta * xc) / beta**0.5
    f1 = alpha * special.gamma(1.5) * special.gammainc(1.5, beta * xc) / beta**1.5
    return f0, f1


def hat_weights(h: float, n: int, alpha: float, beta: float, r: float = np.inf) -> np.ndarray:
    r"""W_j = int g(sigma) hat_j(sigma) d sigma, j = 0..n, for the hats on the grid sigma_j = j h.

    For a piecewise-linear history w, int_0^{t_k} g(sigma) w(t_k - sigma) d sigma
    = sum_j W_j w_{k-j} exactly (hat_0 is the half hat on [0, h]). Computed exactly from the
    moments of :func:`kernel_moments` (so the 1/sqrt singularity at 0 is integrated exactly).
    """
    grid = h * np.arange(n + 2)
    f0, f1 = kernel_moments(grid, alpha, beta, r)
    i0, i1 = np.diff(f0), np.diff(f1)           # integrals over [sigma_j, sigma_{j+1}]
    rising = (i1 - grid[:-1] * i0) / h          # int g (sigma - sigma_j)/h over cell j
    falling = (grid[1:] * i0 - i1) / h          # int g (sigma_{j+1} - sigma)/h over cell j
    w = np.empty(n + 1)
    w[0] = falling[0]
    w[1:] = rising[: n] + falling[1 : n + 1]
    return w


def memory_newmark(mod: Modal, force: np.ndarray, h: float, alpha: float, beta: float,
                   r: float = np.inf):
    r"""Modal solution of q'' + c q' + lam q - kappa (g * q) = p f(t) from rest.

    Newmark average acceleration (the trapezoidal rule) for the mechanical part; the memory
    integral by product integration with the history piecewise linear on the step h and the
    current value implicit (weight W_0). Both are second order in h for a smooth solution.
    O(n^2) history sums. ``force`` holds f(k h), k = 0..n. Returns q, v, a: arrays (n+1, modes).
    """
    n = force.size - 1
    w = hat_weights(h, n, alpha, beta, r)
    lam, c, kappa, p = mod.lam, mod.c, mod.kappa, mod.p
    q = np.zeros((n + 1, lam.size))
    v = np.zeros_like(q)
    a = np.zeros_like(q)
    a[0] = p * force[0]
    stiff = lam - kappa * w[0]                   # the implicit part of the memory term
    lhs = 1.0 + h * c / 2 + h * h / 4 * stiff
    w_rev = w[::-1]                               # w_rev[n - j] = w[j]
    for k in range(n):
        # history part of the memory integral at t_{k+1}: sum_{j=1}^{k+1} W_j q_{k+1-j}
        hist = w_rev[n - k - 1 : n] @ q[: k + 1]
        pred_q = q[k] + h * v[k] + h * h / 4 * a[k]
        pred_v = v[k] + h / 2 * a[k]
        # equilibrium at t_{k+1} with q = pred_q + h^2/4 a, v = pred_v + h/2 a, solved for a
        a[k + 1] = (p * force[k + 1] + kappa * hist - stiff * pred_q - c * pred_v) / lhs
        q[k + 1] = pred_q + h * h / 4 * a[k + 1]
        v[k + 1] = pred_v + h / 2 * a[k + 1]
    return q, v, a


# ---------------------------------------------------------------------------- viscous modes
def _free_decay(mod: Modal, q0, v0, tau):
    """Closed-form free response (q, v) of q'' + c q' + lam q = 0 at times tau >= 0 (per mode)."""
    disc = np.sqrt((mod.c**2 - 4 * mod.lam).astype(complex))
    mu1, mu2 = (-mod.c + disc) / 2, (-mod.c - disc) / 2
    a1 = (v0 - mu2 * q0) / (mu1 - mu2)
    a2 = (mu1 * q0 - v0) / (mu1 - mu2)
    e1, e2 = np.exp(np.outer(tau, mu1)), np.exp(np.outer(tau, mu2))
    q = (a1 * e1 + a2 * e2).real
    v = (a1 * mu1 * e1 + a2 * mu2 * e2).real
    return q, v


def half_sine_response(mod: Modal, t: np.ndarray, t0: float, width: float, peak: float,
                       n_pulse_steps: int):
    r"""Exact modal response to f(t) = peak sin(pi (t - t0)/width) on [t0, t0 + width], else 0.

    During the pulse each mode is augmented with the sine generator (s' = Omega c,
    c' = -Omega s), a linear autonomous system integrated exactly by its matrix exponential
    over ``n_pulse_steps`` equal steps; after the pulse the closed-form free decay is used.
    ``t`` must contain t0 + k width/n_pulse_steps for k = 0..n_pulse_steps (a uniform fine grid
    aligned with the pulse). Returns q, v, a (len(t), modes) and f(t).
    """
    omega = np.pi / width
    step = width / n_pulse_steps
    nm = mod.lam.size
    z = np.zeros((nm, 4))
    z[:, 3] = peak  # s = 0, c = peak at t0
    aug = np.zeros((nm, 4, 4))
    aug[:, 0, 1] = 1.0
    aug[:, 1, 0], aug[:, 1, 1], aug[:, 1, 2] = -mod.lam, -mod.c, mod.p
    aug[:, 2, 3], aug[:, 3, 2] = omega, -omega
    prop = np.array([linalg.expm(step * m) for m in aug])
    states = [z.copy()]
    for _ in range(n_pulse_steps):
        z = np.einsum("mij,mj->mi", prop, z)
        states.append(z.copy())
    states = np.array(states)  # (n_pulse_steps + 1, modes, 4)
    inside = (t >= t0) & (t <= t0 + width)
    force = np.where(inside, peak * np.sin(omega * np.clip(t - t0, 0, width)), 0.0)
    q, v = np.zeros((t.size, nm)), np.zeros((t.size, nm))
    k = np.rint((t - t0) / step).astype(int)
    during = (k >= 0) & (k <= n_pulse_steps) & (t >= t0 - 1e-9 * step)
    aligned = np.allclose(t[during], t0 + k[during] * step, rtol=0, atol=1e-9 * step)
    assert aligned, "the fine grid must contain the pulse's steps"
    q[during], v[during] = states[k[during], :, 0], states[k[during], :, 1]
    after = t > t0 + width + 1e-9 * step
    qa, va = _free_decay(mod, states[-1, :, 0], states[-1, :, 1], t[after] - (t0 + width))
    q[after], v[after] = qa, va
    a = mod.p * force[:, None] - mod.lam * q - mod.c * v
    return q, v, a, force


def first_order_hold_response(mod: Modal, force: np.ndarray, dt: float):
    r"""Exact modal response (q, v, a at the samples) to the straight-line interpolant of ``force``.

    On each interval the input is u_k + (t - t_k) (u_{k+1} - u_k)/dt; the oscillator augmented
    with (u, u') is autonomous there and its matrix exponential over dt is the exact
    discretisation (first-order hold).
    """
    nm = mod.lam.size
    aug = np.zeros((nm, 4, 4))
    aug[:, 0, 1] = 1.0
    aug[:, 1, 0], aug[:, 1, 1], aug[:, 1, 2] = -mod.lam, -mod.c, mod.p
    aug[:, 2, 3] = 1.0
    prop = np.array([linalg.expm(dt * m) for m in aug])[:, :2, :]  # rows for (q, v)
    x = np.zeros((force.size, nm, 2))
    slope = np.diff(force) / dt
    for k in range(force.size - 1):
        full = np.concatenate([x[k], np.broadcast_to([force[k], slope[k]], (nm, 2))], axis=1)
        x[k + 1] = np.einsum("mij,mj->mi", prop, full)
    q, v = x[..., 0], x[..., 1]
    a = mod.p * force[:, None] - mod.lam * q - mod.c * v
    return q, v, a


# ---------------------------------------------------------------------------- anti-alias filter
@dataclass(frozen=True)
class KaiserDAQ:
    r"""A zero-phase anti-alias filter followed by sampling at ``fs``: a model of the DAQ.

    Its continuous impulse response is a Kaiser-windowed sinc,
    :math:`\ell(\tau) = 2 f_c\, \mathrm{sinc}(2 f_c \tau)\, I_0(\beta\sqrt{1-(\tau/T)^2})/I_0(\beta)`
    on :math:`|\tau| < T`, with cut-off :math:`f_c` midway between ``passband`` and ``stopband``
    (fractions of fs) and :math:`\beta`, T from Kaiser's formulas for ``attenuation_db``: gain
    within 10^(-attenuation/20) of 1 below the passband edge and of 0 above the stopband edge.
    """

    fs: float
    passband: float = 0.40
    stopband: float = 0.50
    attenuation_db: float = 100.0

    @property
    def cutoff(self) -> float:
        return 0.5 * (self.passband + self.stopband) * self.fs

    @property
    def beta(self) -> float:
        return float(signal.kaiser_beta(self.attenuation_db))

    @property
    def half_length(self) -> float:
        """T (s): Kaiser's length estimate (A - 7.95) / (2.285 * 2 pi * transition width) / 2."""
        width = (self.stopband - self.passband) * self.fs
        return (self.attenuation_db - 7.95) / (2.285 * 2 * np.pi * width) / 2

    def impulse(self, tau) -> np.ndarray:
        """ell(tau) (1/s)."""
        tau = np.asarray(tau, dtype=float)
        x = np.clip(tau / self.half_length, -1.0, 1.0)
        win = special.i0(self.beta * np.sqrt(1.0 - x * x)) / special.i0(self.beta)
        inside = np.abs(tau) < self.half_length
        return np.where(inside, 2 * self.cutoff * np.sinc(2 * self.cutoff * tau) * win, 0.0)

    def sample_fine(self, x_fine: np.ndarray, sub: int, n: int) -> np.ndarray:
        r"""The filter applied to x(t) given by samples x_fine[i] = x(i dt/sub) (x = 0 for t < 0),
        sampled at k dt, k = 0..n-1.

        The convolution integral is evaluated by the trapezoid (Riemann) sum on the fine grid. ell
        is smooth, so the sum is spectrally accurate for smooth x; a jump in the m-th derivative of
        x costs O((dt/sub)^(m+1)). A kink (m = 1) would cost 1e-4 at 32 sub-steps per sample: keep
        kinked parts (a half-sine force) out of x and filter them with :meth:`sample_half_sine`.
        """
        step = 1.0 / (self.fs * sub)
        half = int(np.floor(self.half_length / step))
        taps = step * self.impulse(step * np.arange(-half, half + 1))
        assert x_fine.shape[0] >= (n - 1) * sub + half + 1, "fine record too short for the filter"
        y = signal.fftconvolve(x_fine, taps, mode="full")
        return y[half : half + (n - 1) * sub + 1 : sub]

    def sample_half_sine(self, n: int, t0: float, width: float, peak: float,
                         nodes: int = 64) -> np.ndarray:
        r"""The filter applied to peak sin(pi (t - t0)/width) on [t0, t0 + width], sampled at
        k/fs: int ell(t_k - tau) f(tau) d tau by Gauss-Legendre quadrature over the pulse, where
        the integrand is smooth except for the window's cut at |tau| = T (a step of ~1e-6 of the
        peak): 64 nodes vs 128 differ by 2e-8 of the peak for a 2.5-sample pulse."""
        g, w = np.polynomial.legendre.leggauss(nodes)
        tau = t0 + (g + 1) * width / 2
        f = peak * np.sin(np.pi * (tau - t0) / width) * w * width / 2
        t = np.arange(n) / self.fs
        return self.impulse(t[:, None] - tau[None, :]) @ f
