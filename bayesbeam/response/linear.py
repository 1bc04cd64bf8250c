r"""Exact-in-time response of linear models to band-limited inputs.

What the samples mean
---------------------
Every channel of a recording has passed the DAQ's anti-alias low-pass before sampling, so the
recorded force is a *band-limited* signal and its samples determine it completely (Shannon):
joining them with straight lines (a first-order hold) is wrong by a factor
:math:`\mathrm{sinc}^2(f/f_s)` in amplitude, a third of the amplitude at 0.36 fs. Because the
anti-alias filter acts on force and response alike and commutes with the beam, the recorded
response samples are exactly the samples of the beam's response to the band-limited force.
The model's output is therefore defined as

.. math:: y[n] = \mathcal{F}^{-1}\{ H(i\omega)\, W(\omega)\, F(\omega) \}(t_n),

where :math:`F` is the spectrum of the band-limited force (the DTFT of its samples) and
:math:`W` is the documented DAQ passband (:func:`daq_passband`): 1 to within 1e-10 below
0.40 fs, 0 to within 1e-10 from 0.50 fs, an erf-shaped transition in between. Inside 0.40 fs
the output is exact; the DAQ's own transition band, whose shape a recording does not state, is
tapered smoothly. The taper also makes the discrete impulse response decay like a Gaussian
(standard deviation about 20 samples: negligible beyond about 150) instead of like 1/n.

How it is computed (exactly, in O(n log n))
-------------------------------------------
A lightly damped beam rings for much longer than the record, so a plain FFT convolution would
wrap around. The exponential window method removes the wrap: the input is multiplied by
:math:`e^{-\sigma t}`, the convolution is done with :math:`H(\sigma + i\omega)` on an FFT grid of
length :math:`P \ge 2n`, and the output is multiplied by :math:`e^{\sigma t}`. The wrapped tail
is damped by :math:`e^{-\sigma (P-n) \Delta t}` while round-off grows by at most
:math:`e^{\sigma n \Delta t}`; :math:`\sigma (P - n)\Delta t = 18` keeps both near 1e-8 relative.
Any linear model with a computable :math:`H(s)` is handled the same way, including the weakly
singular memory kernel of time hysteresis, whose transform is known in closed form.
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np
from scipy import fft, special

from bayesbeam.response.system import SecondOrderSystem

#: DAQ passband edge and stopband start, as fractions of the sampling rate
PASSBAND, STOPBAND = 0.40, 0.50
_WRAP_EXPONENT = 18.0   # sigma (P - n) dt: wrap-around damped by e^-18 = 1.5e-8

#: derivative order of each sensor quantity
ORDERS = {"displacement": 0, "velocity": 1, "acceleration": 2}


def daq_passband(freq, fs: float, passband: float = PASSBAND, stopband: float = STOPBAND):
    """W(f): the anti-alias passband assumed for the DAQ (dimensionless).

    An erf step centred between ``passband*fs`` and ``stopband*fs`` whose width puts both edges
    6.4 standard deviations away, so W = 1 - O(1e-10) in the passband and O(1e-10) at the stopband.
    """
    return np.real(_passband_step(np.abs(freq), fs, passband, stopband))


def _passband_step(f, fs, passband=PASSBAND, stopband=STOPBAND):
    """The erf step E(f) of :func:`daq_passband` for real or complex f."""
    centre = 0.5 * (passband + stopband) * fs
    width = 0.5 * (stopband - passband) * fs / 6.4
    return 0.5 * special.erfc((f - centre) / (np.sqrt(2.0) * width))


@dataclass(frozen=True)
class FrequencyGrid:
    """The exponential-window FFT grid for a record of ``n`` samples spaced ``dt`` (s)."""

    n: int
    dt: float

    @cached_property
    def n_fft(self) -> int:
        return fft.next_fast_len(2 * self.n, real=True)

    @cached_property
    def sigma(self) -> float:
        """Window decay rate sigma (1/s)."""
        return _WRAP_EXPONENT / ((self.n_fft - self.n) * self.dt)

    @cached_property
    def freq(self) -> np.ndarray:
        """FFT frequencies in Hz, 0 to fs/2."""
        return fft.rfftfreq(self.n_fft, self.dt)

    @cached_property
    def s(self) -> np.ndarray:
        """Complex frequencies sigma + i omega (1/s)."""
        return self.sigma + 2j * np.pi * self.freq

    @cached_property
    def weight(self) -> np.ndarray:
        """The passband at the window's complex frequency, W(f - i sigma/2pi).

        The window turns the output's filter W into a filter of the windowed signal; applying W
        unchanged there would filter the force with a kernel tilted by e^{sigma t}, a 3e-4 error
        in the 0.40-0.50 fs band that would depend on the record length. The erf step is entire,
        so its analytic continuation E(z) + E(-z) - 1 (= W on the real axis) is exact.
        """
        fs = 1.0 / self.dt
        z = self.freq - 1j * self.sigma / (2 * np.pi)
        return _passband_step(z, fs) + _passband_step(-z, fs) - 1.0

    @cached_property
    def damp(self) -> np.ndarray:
        """exp(-sigma t_n), the input window."""
        return np.exp(-self.sigma * self.dt * np.arange(self.n))

    def delay(self, tau: float) -> np.ndarray:
        r"""The delay factor :math:`e^{-s\tau}` on every bin (tau in s).

        With :math:`s_k = \sigma + i k\,\Delta\omega`, :math:`e^{-s_k\tau} = e^{-\sigma\tau} z^k`,
        :math:`z = e^{-i\Delta\omega\tau}`; writing k = q m + j with m ~ sqrt(K), :math:`z^k =
        (z^m)^q z^j` is the outer product of two short exact exponentials: two roundings per bin
        (error < 3 eps) and 2 sqrt(K) complex exponentials instead of K (8200 bins: the delay had
        cost 15 % of a simulation).
        """
        k = self.freq.size
        m = int(np.ceil(np.sqrt(k)))
        step = 2 * np.pi * (self.freq[1] - self.freq[0]) * tau
        fine = np.exp(-1j * step * np.arange(m))
        coarse = np.exp(-1j * step * m * np.arange(-(-k // m))) * np.exp(-self.sigma * tau)
        return np.outer(coarse, fine).ravel()[:k]

    def spectrum(self, x: np.ndarray) -> np.ndarray:
        """Windowed DFT of samples x (n, ...) on all n_fft/2 + 1 bins of :attr:`freq` (x's units)."""
        return fft.rfft(x * self.damp.reshape((-1,) + (1,) * (x.ndim - 1)), self.n_fft, axis=0)

    def samples(self, spectrum: np.ndarray) -> np.ndarray:
        """Inverse of :meth:`spectrum`: undo the window and return n samples."""
        x = fft.irfft(spectrum, self.n_fft, axis=0)[: self.n]
        return x / self.damp.reshape((-1,) + (1,) * (x.ndim - 1))

    def samples_last(self, spectrum: np.ndarray) -> np.ndarray:
        """:meth:`samples` of spectra with frequency on the last axis (..., n_freq) -> (..., n):
        for many signals at once, where contiguous transforms take a third of the time."""
        return fft.irfft(spectrum, self.n_fft, axis=-1)[..., : self.n] / self.damp


def drive_spectrum(grid: FrequencyGrid, orders, input_spectrum: np.ndarray) -> np.ndarray:
    """Parameter-free factor of every output: s^q W(w) U(s), array (n_freq, n_out).

    ``orders`` holds each output's time-derivative order (0, 1, 2 for displacement, velocity,
    acceleration) and ``input_spectrum`` the windowed input spectrum on the grid.
    """
    powers = np.stack([grid.s**q for q in orders], axis=1)
    return powers * (grid.weight * input_spectrum)[:, None]


def force_spectrum(grid: FrequencyGrid, force: np.ndarray) -> np.ndarray:
    """Input spectrum of a measured, band-limited force history (N)."""
    return grid.spectrum(force)


def release_spectrum(grid: FrequencyGrid, tip_load: float, t0: float = 0.0) -> np.ndarray:
    """Input spectrum of releasing a static tip load (N) at t = 0, sampled from t0.

    For t <= 0 the beam rests in its (relaxed) static deflection under ``tip_load``; removing the
    load is the step -tip_load H(t), whose Laplace transform is -tip_load/s. The sampled
    transform carries 1/dt (a DFT of samples approximates the continuous transform over dt).
    """
    return -tip_load * np.exp(grid.s * t0) / (grid.s * grid.dt)


def transfer(system: SecondOrderSystem, grid: FrequencyGrid, rows: np.ndarray,
             load: np.ndarray) -> np.ndarray:
    """H(s) on the grid from the load vector to every output row: (n_freq, n_out).

    ``rows`` (n_out, n_dof) are displacement rows, ``load`` (n_dof,) the generalized load vector.
    """
    return system.transfer(grid.s, rows, load[:, None])[:, :, 0]


def respond(system: SecondOrderSystem, grid: FrequencyGrid, rows: np.ndarray, load: np.ndarray,
            drive: np.ndarray) -> np.ndarray:
    """Outputs (n, n_out): the inverse transform of H(s) times :func:`drive_spectrum`."""
    return grid.samples(transfer(system, grid, rows, load) * drive)


def unit_sample_responses(grid: FrequencyGrid, spectrum: np.ndarray, index: np.ndarray) -> np.ndarray:
    """Responses (n, n_out, K) to a unit input sample at each of the samples ``index`` (K,).

    ``spectrum`` is H(s) times the drive of a unit sample at t = 0
    (:func:`drive_spectrum` of an all-ones input spectrum). Its impulse response x is computed
    once; the column of sample k is x(n - k) (time invariance), and for n < k it is the
    band-limited pre-response of the DAQ passband, which the FFT buffer holds at its end. The
    window is undone there too (x e^{sigma t} with t < 0); the wrapped tail of the ring-down
    that shares those bins is damped by e^{-sigma P dt} < e^{-36}.
    """
    x = fft.irfft(spectrum, grid.n_fft, axis=0)                       # (n_fft, n_out), windowed
    lag = np.arange(grid.n)[:, None] - np.asarray(index)[None, :]     # (n, K), from -max(index)
    return lagged_samples(grid, x, lag).transpose(0, 2, 1)


def lagged_samples(grid: FrequencyGrid, x: np.ndarray, lags: np.ndarray) -> np.ndarray:
    """Samples at integer ``lags`` (any shape; negative ones wrap to the buffer's end) of the
    windowed inverse transform ``x`` (n_fft, ...), the window undone: (lags.shape + x.shape[1:]).

    Valid for lags in (-(n_fft - n), n): see :func:`unit_sample_responses` for what the negative
    lags hold.
    """
    factor = np.exp(grid.sigma * grid.dt * lags)
    return x[lags % grid.n_fft] * factor.reshape(factor.shape + (1,) * (x.ndim - 1))


def static_offset(system: SecondOrderSystem, rows: np.ndarray, orders, load: np.ndarray,
                  tip_load: float) -> np.ndarray:
    """Static deflection under the tip load at displacement outputs, 0 elsewhere (n_out,)."""
    static = rows @ np.linalg.solve(system.static_stiffness(), load * tip_load)
    return static * (np.asarray(orders) == 0)


def force_response(system: SecondOrderSystem, grid: FrequencyGrid, rows: np.ndarray, orders,
                   load: np.ndarray, force: np.ndarray) -> np.ndarray:
    """Outputs (n, n_out) for a measured force history (N) applied through the load vector.

    The beam is at rest at the first sample; the force samples are band-limited signals.
    """
    return respond(system, grid, rows, load, drive_spectrum(grid, orders, force_spectrum(grid, force)))


def release_response(system: SecondOrderSystem, grid: FrequencyGrid, rows: np.ndarray, orders,
                     load: np.ndarray, tip_load: float, t0: float = 0.0) -> np.ndarray:
    """Outputs (n, n_out) after releasing a static load at t = 0; samples at t0 + n dt."""
    drive = drive_spectrum(grid, orders, release_spectrum(grid, tip_load, t0))
    y = respond(system, grid, rows, load, drive)
    return y + static_offset(system, rows, orders, load, tip_load)[None, :]
