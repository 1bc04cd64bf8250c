r"""Shared pieces of the benchmarks: the band-limited force, state-space forms, the memory kernel.

Everything here is built from the *same* matrices bayesbeam uses (``model.system(params)``:
M, D, K, the relaxation transform and K_h) and the *same* force (``model.force``, the windowed
samples), so the baselines differ from bayesbeam only in how they integrate in time.

Band-limited force
------------------
bayesbeam defines its output as :math:`y = \mathcal F^{-1}\{H(i\omega) W(\omega) F(\omega)\}`
sampled at the record's times, with :math:`F` the DTFT of the force samples and :math:`W` the DAQ
passband (:func:`bayesbeam.response.linear.daq_passband`). A time integrator that should give the
same samples therefore has to be driven by the continuous signal

.. math:: f_c(t) = \sum_k f_k\, w_c(t - k\,\Delta t), \qquad
          w_c(t) = \Delta t \int_{-f_s/2}^{f_s/2} W(\nu) e^{2\pi i \nu t} d\nu ,

the band-limited interpolant of the samples with W applied. :class:`BandLimitedForce` computes it
*exactly* on a grid ``U`` times finer than the record's by zero-padded FFT upsampling (the
samples are zero-padded to twice their length so that the periodic images of the FFT are one
record away, where w_c, a sinc under a Gaussian envelope of standard deviation ~20 samples,
is below 1e-10: it gets there after ~140 samples), and, for
integrators with adaptive steps, joins the fine values with a cubic spline.

Why the spline is accurate enough: a cubic spline through samples spaced h of a signal with
highest angular frequency omega errs by about (omega h)^4 / 384 of that component's amplitude.
With h = dt/32 and the highest frequency the passband lets through (0.5 fs, and W < 1e-2 above
0.47 fs), omega h <= pi/32, so the error is below 2.4e-7 of the amplitude at the band edge
and ~1e-8 at 0.25 fs. :meth:`BandLimitedForce.spline_error` *measures* it: it compares the spline
at the midpoints of the fine grid with the exact interpolant there (from an FFT upsampling by
2U) and returns the max error relative to the force's peak (1.7e-8 on the example record).

Sum of exponentials for the memory kernel
-----------------------------------------
Time hysteresis has the weakly singular kernel :math:`g(\sigma) = \alpha e^{-\beta\sigma}/\sqrt\sigma`
whose transform :math:`\hat G(s) = \alpha\sqrt\pi/\sqrt{s+\beta}` bayesbeam uses exactly. A
time-stepping integrator needs internal variables instead. From

.. math:: \frac{1}{\sqrt\sigma} = \frac{1}{\sqrt\pi}\int_0^\infty \lambda^{-1/2} e^{-\lambda\sigma}
          d\lambda = \frac{1}{\sqrt\pi}\int_{-\infty}^{\infty} e^{x/2} e^{-e^x\sigma} dx
          \quad (\lambda = e^x),

the trapezoid rule in x with step h (nodes x_k = k h) gives
:math:`g(\sigma) \approx \sum_k c_k e^{-\mu_k\sigma}`, :math:`c_k = \alpha h e^{x_k/2}/\sqrt\pi`,
:math:`\mu_k = \beta + e^{x_k}`, i.e. :math:`\hat G(s) \approx \sum_k c_k/(s + \mu_k)`. In the
Laplace domain the integrand :math:`e^{x/2}/(s+\beta+e^x)` is analytic in the strip
:math:`|\operatorname{Im} x| < \pi/2` for Re(s) >= 0, so the infinite trapezoid sum errs by about
:math:`e^{-\pi^2/h}` relative. The infinite sum is then cut at x_lo <= x_k <= x_hi and its two tails
are summed in closed form (geometric series) in their limits, which stay sums of exponentials:

* nodes with :math:`e^{x_k} \ll |s+\beta|` (x_k < x_lo) all act like :math:`c_k/(s+\beta)`: one extra term
  :math:`c_0 = \alpha h \sum_{x_k<x_{lo}} e^{x_k/2}/\sqrt\pi` with :math:`\mu_0 = \beta`;
* nodes with :math:`e^{x_k} \gg |s+\beta|` (x_k > x_hi) act like the constant :math:`c_k e^{-x_k}`, an
  instantaneous kernel :math:`c_\infty\delta(\sigma)`, :math:`c_\infty = \alpha h\sum_{x_k>x_{hi}} e^{-x_k/2}/\sqrt\pi`.

The tails' errors are O((e^{x_lo}/|s+beta|)^{3/2}) and O((|s+beta|/e^{x_hi})^{3/2}) relative.
:func:`sum_of_exponentials` picks the step and the cut-offs and checks the result on the band.

The equations with internal variables: with :math:`z_k(t) = \int_0^t e^{-\mu_k\sigma} w(t-\sigma)d\sigma`
(the beam at rest before t = 0),

.. math::

    M \ddot w + D \dot w + (K - c_\infty K_h) w - K_h \sum_k c_k z_k = b f(t), \qquad
    \dot z_k = w - \mu_k z_k ,

whose transfer function is exactly bayesbeam's with :math:`\hat G` replaced by
:math:`c_\infty + \sum_k c_k/(s+\mu_k)`.
"""
from __future__ import annotations

import os
import platform
import time
from dataclasses import dataclass

import numpy as np
from scipy import fft, interpolate, signal, sparse

from bayesbeam import BeamModel, load_recording
from bayesbeam.response.linear import daq_passband
from bayesbeam.response.system import SecondOrderSystem

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
RECORDING = os.path.join(ROOT, "data", "examples", "paper_q3_hammer")

#: parameters of the benchmark (q3: the example's truth.json)
PARAMS = {
    "q1": {"EI": 44.28, "gamma": 0.12, "cdI": 2e-5},
    "q2": {"EI": 44.28, "alpha": 0.05, "beta": 20.0},
    "q3": {"EI": 44.28, "gamma": 0.12, "a": 0.025, "b": 0.18},
}


def load_model(mechanisms: str, n_intervals: int, recording=None) -> BeamModel:
    rec = load_recording(RECORDING) if recording is None else recording
    return BeamModel.from_recording(rec, mechanisms, n_intervals)


# ----------------------------------------------------------------------------- the force
class BandLimitedForce:
    """The band-limited continuous force f_c(t) of the samples ``force`` (see module docstring)."""

    def __init__(self, force: np.ndarray, dt: float):
        self.force = np.asarray(force, dtype=float)
        self.dt = float(dt)
        self.n = self.force.size
        self._n_pad = fft.next_fast_len(2 * self.n, real=True)
        freq = fft.rfftfreq(self._n_pad, self.dt)
        self._spectrum = fft.rfft(self.force, self._n_pad) * daq_passband(freq, 1.0 / self.dt)
        if self._n_pad % 2 == 0:          # the Nyquist bin is shared by +-fs/2: halve it
            self._spectrum[-1] *= 0.5

    def fine(self, factor: int, pre: int = 0) -> np.ndarray:
        """f_c at t = j dt/factor for j = -pre*factor .. n*factor - 1 (exact, by FFT upsampling).

        ``pre`` samples before the record are included because f_c is not causal: w_c reaches
        back ~7 x 20 samples before the first non-zero force sample (and after the last).
        """
        m = self._n_pad * factor
        if pre > self._n_pad - self.n:
            raise ValueError("pre reaches into the periodic image of the record")
        full = np.zeros(m // 2 + 1, dtype=complex)
        full[: self._spectrum.size] = self._spectrum
        values = fft.irfft(full, m) * factor
        return np.concatenate([values[m - pre * factor:], values[: self.n * factor]])

    def times(self, factor: int, pre: int = 0) -> np.ndarray:
        """The times (s) of :meth:`fine`."""
        return (np.arange(-pre * factor, self.n * factor)) * (self.dt / factor)

    def spline(self, factor: int = 32, pre: int = 0) -> interpolate.CubicSpline:
        """Cubic spline through :meth:`fine` for integrators with adaptive steps."""
        return interpolate.CubicSpline(self.times(factor, pre), self.fine(factor, pre))

    def spline_error(self, factor: int = 32, pre: int = 0) -> float:
        """max |spline - f_c| at the fine grid's midpoints, relative to max |f_c|."""
        exact = self.fine(2 * factor, pre)
        t_mid = self.times(2 * factor, pre)[1:-1:2]
        err = self.spline(factor, pre)(t_mid) - exact[1:-1:2]
        return float(np.max(np.abs(err)) / np.max(np.abs(exact)))

    def leak(self, pre: int = 0) -> float:
        """max |f_c(t)| for t before -pre dt (what an integrator started there misses), / peak."""
        m = self._n_pad * 4
        full = np.zeros(m // 2 + 1, dtype=complex)
        full[: self._spectrum.size] = self._spectrum
        values = fft.irfft(full, m)
        before = values[self.n * 4 + (self._n_pad - self.n) * 2: m - pre * 4]
        return float(np.max(np.abs(before)) / np.max(np.abs(values)))


# ----------------------------------------------------------------------------- memory kernel
@dataclass(frozen=True)
class ExponentialSum:
    """G(s) ~ c_inf + sum_k c[k]/(s + mu[k]) (N m^2), the kernel g ~ c_inf delta + sum c e^{-mu t}."""

    c: np.ndarray
    mu: np.ndarray
    c_inf: float

    def __call__(self, s):
        s = np.asarray(s, dtype=complex)
        return (self.c / (s[..., None] + self.mu)).sum(-1) + self.c_inf

    @property
    def size(self) -> int:
        return self.c.size


def sum_of_exponentials(alpha: float, beta: float, step: float = 0.55, x_lo: float = -8.0,
                        x_hi: float = 20.0) -> ExponentialSum:
    """Trapezoid rule in log(lambda) for alpha e^{-beta t}/sqrt(t), tails in closed form."""
    k = np.arange(np.ceil(x_lo / step), np.floor(x_hi / step) + 1)
    x = k * step
    scale = alpha * step / np.sqrt(np.pi)
    q = np.exp(-step / 2)
    c = scale * np.exp(x / 2)
    mu = beta + np.exp(x)
    c_low = scale * np.exp((x[0] - step) / 2) / (1 - q)     # sum over x_k < x[0]
    c_inf = scale * np.exp(-(x[-1] + step) / 2) / (1 - q)   # sum over x_k > x[-1]
    return ExponentialSum(np.r_[c, c_low], np.r_[mu, beta], float(c_inf))


def approximate_system(system: SecondOrderSystem, kernel: ExponentialSum) -> SecondOrderSystem:
    """``system`` with its relaxation transform replaced by the exponential sum."""
    return SecondOrderSystem(system.M, system.D, system.K, kernel, system.K_h)


def transfer_error(model: BeamModel, system: SecondOrderSystem, kernel: ExponentialSum) -> tuple[float, float]:
    """Error of the exponential sum on the band, for the model's output (tip acceleration).

    Returns (max |H_soe - H| / max |H|, max |G_soe - G| / |G|) over the frequencies of the
    model's grid (0 to fs/2), with s = i omega.
    """
    s = 2j * np.pi * model.grid.freq
    load = model.ops.rows([model.recording.excitation.location])[0]
    exact = system.transfer(s, model.rows, load[:, None])[:, :, 0]
    approx = approximate_system(system, kernel).transfer(s, model.rows, load[:, None])[:, :, 0]
    power = s[:, None] ** model.orders[None, :]
    h_err = np.max(np.abs((approx - exact) * power)) / np.max(np.abs(exact * power))
    g = system.relaxation(s)
    return float(h_err), float(np.max(np.abs(kernel(s) - g) / np.abs(g)))


# ----------------------------------------------------------------------------- state space
@dataclass
class StateSpace:
    """x' = A x + B f(t); the outputs are C x' (accelerations = the velocity rows of x').

    State order: (w, w', z_1 .. z_m) with z_k the memory variables (none without memory).
    """

    A: np.ndarray | sparse.csr_matrix
    B: np.ndarray
    C: np.ndarray
    n_dof: int

    def output(self, x: np.ndarray, f: np.ndarray) -> np.ndarray:
        """C (A x + B f) for states x (n_state, nt) and forces f (nt,): (nt, n_out)."""
        xdot = self.A @ x + self.B[:, None] * f[None, :]
        return (self.C @ xdot).T


def state_space(model: BeamModel, system: SecondOrderSystem, kernel: ExponentialSum | None = None,
                sparse_form: bool = False) -> StateSpace:
    """First-order form of ``system`` driven at the model's force location, tip outputs.

    With ``kernel`` the memory term is represented by its internal variables (module docstring).
    """
    n = system.size
    load = model.ops.rows([model.recording.excitation.location])[0]
    m_inv_b = np.linalg.solve(system.M, load)
    K = system.K if kernel is None else system.K - kernel.c_inf * system.K_h
    m_inv_k = np.linalg.solve(system.M, K)
    m_inv_d = np.linalg.solve(system.M, system.D)
    m = 0 if kernel is None else kernel.size
    eye = sparse.identity(n, format="csr")
    blocks = [[None] * (2 + m) for _ in range(2 + m)]
    blocks[0][1] = eye
    blocks[1][0] = sparse.csr_matrix(-m_inv_k)
    blocks[1][1] = sparse.csr_matrix(-m_inv_d) if np.any(m_inv_d) else None
    if kernel is not None:
        m_inv_kh = np.linalg.solve(system.M, system.K_h)
        for k in range(m):
            blocks[1][2 + k] = sparse.csr_matrix(kernel.c[k] * m_inv_kh)
            blocks[2 + k][0] = eye
            blocks[2 + k][2 + k] = -kernel.mu[k] * eye
    A = sparse.bmat(blocks, format="csr")
    B = np.zeros(A.shape[0])
    B[n:2 * n] = m_inv_b
    C = np.zeros((model.rows.shape[0], A.shape[0]))
    C[:, n:2 * n] = model.rows        # the v rows of x' are the accelerations
    if not np.all(model.orders == 2):
        raise NotImplementedError("the benchmark compares acceleration outputs only")
    return StateSpace(A if sparse_form else A.toarray(), B, C, n)


def state_scale(system: SecondOrderSystem, space: StateSpace, force: np.ndarray, dt: float,
                kernel: ExponentialSum | None = None) -> np.ndarray:
    """Rough magnitude of each state after the impact, from the impulse J = sum |f| dt.

    Velocities jump by about M^-1 b J; displacements reach about that over the lowest natural
    angular frequency; memory variables z_k about the displacement over mu_k.
    """
    n = space.n_dof
    impulse = np.sum(np.abs(force)) * dt
    v = np.max(np.abs(space.B[n:2 * n])) * impulse
    w1 = np.sqrt(max(system.undamped[0][0], 1e-30))
    u = v / w1
    scale = [np.full(n, u), np.full(n, v)]
    if kernel is not None:
        scale += [np.full(n, u / mu) for mu in kernel.mu]
    return np.concatenate(scale)


# ----------------------------------------------------------------------------- machine, timing
def machine() -> str:
    cpu = platform.processor() or "unknown CPU"
    try:
        with open("/proc/cpuinfo") as fh:
            for line in fh:
                if line.startswith("model name"):
                    cpu = line.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
    import scipy

    threads = ", ".join(f"{k}={os.environ.get(k, 'unset')}" for k in
                        ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"))
    return (f"{cpu}; {os.cpu_count()} logical CPUs; Python {platform.python_version()}, "
            f"numpy {np.__version__}, scipy {scipy.__version__}; {threads}")


#: the clock of every timing: process CPU time by default (the work is single-threaded, so on
#: an idle machine it equals wall time, and other processes sharing the cores barely change it);
#: forward.py --wall switches to time.perf_counter
CLOCK = {"clock": time.process_time}


def now() -> float:
    return CLOCK["clock"]()


def best_time(func, number: int, repeat: int) -> float:
    """timeit-style: the best over ``repeat`` batches of ``number`` calls, seconds per call."""
    best = np.inf
    for _ in range(repeat):
        t0 = now()
        for _ in range(number):
            func()
        best = min(best, (now() - t0) / number)
    return best


def relative_difference(y: np.ndarray, reference: np.ndarray) -> float:
    """max |y - reference| / max |reference| over all samples and outputs."""
    return float(np.max(np.abs(y - reference)) / np.max(np.abs(reference)))


# ----------------------------------------------------------------------------- exact reference
def documented_response(model: BeamModel, system: SecondOrderSystem, pre: int = 128) -> np.ndarray:
    r"""The documented output :math:`\mathcal F^{-1}\{H W F\}(t_n)`, computed independently of bayesbeam.

    The force is band-limited with W by a plain zero-padded FFT (no exponential window), giving
    the samples f_c(k dt) for k = -pre .. n-1 (f_c is not causal: see :class:`BandLimitedForce`);
    the response to these band-limited samples is then computed by the exponential-window FFT
    with H(sigma + i omega) alone. Up to the window's e^-18 wrap-around this is exact.
    bayesbeam applies W to the windowed spectrum at the window's complex frequency instead, the
    same thing in exact arithmetic. H is bayesbeam's own ``system.transfer``: this reference
    checks the time-domain convention, not H (which is checked against 40-digit solves).
    """
    from bayesbeam.response.linear import FrequencyGrid

    rec = model.recording
    samples = BandLimitedForce(model.force, rec.dt).fine(1, pre)
    grid = FrequencyGrid(samples.size, rec.dt)
    load = model.ops.rows([rec.excitation.location])[0]
    h = system.transfer(grid.s, model.rows, load[:, None])[:, :, 0]
    h = h * grid.s[:, None] ** model.orders[None, :]
    return grid.samples(h * grid.spectrum(samples)[:, None])[pre:]


def in_band(x: np.ndarray, fs: float) -> np.ndarray:
    """The part of x (n, n_out) below 0.40 fs, as in tests/response/test_band_limited_input.py.

    Zero-phase Kaiser FIR, flat (1e-6) to 0.37 fs, -120 dB from 0.40 fs; the last half-length
    samples are dropped (the record continues past its end). The first samples see the filter's
    start-up (x before the record is taken as 0): skip ~128 of them when comparing.
    """
    numtaps, beta = signal.kaiserord(120.0, 2 * 0.03)
    numtaps |= 1
    taps = signal.firwin(numtaps, 0.385 * fs, window=("kaiser", beta), fs=fs)
    half = numtaps // 2
    cols = [np.convolve(col, taps)[half: col.size][: col.size - half] for col in np.asarray(x).T]
    return np.stack(cols, axis=1)
