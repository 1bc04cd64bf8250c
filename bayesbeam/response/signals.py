"""Conditioning of measured input signals.

The force window of impact testing: outside the impact a hammer's force channel holds only noise,
and that noise, fed to the model as a force, drives a spurious response over the whole record.
The standard remedy keeps the samples around the impact and zeroes the rest.

The samples it keeps still carry their noise: the force is an errors-in-variables input.
:func:`force_noise` measures that noise where the window is closed and states what is left of it
in the kept samples, so the likelihood can marginalise the response it drives
(:mod:`bayesbeam.inference.likelihood`).
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from bayesbeam.response.linear import daq_passband

#: default force window: samples kept before the first and after the last sample above
#: THRESHOLD x peak, and the length of the half-cosine tapers outside them. Every kept sample
#: also keeps its noise, which drives a response of its own (the force is an errors-in-variables
#: input), so the window is short: it holds the pulse whole (the threshold follows a soft tip)
#: and the strongest anti-alias ringing next to it, which lies near 0.45 fs, out of the band
#: that is fitted. On the paper_q3_hammer example (1% force noise) the in-band residual at the
#: true parameters is 1.8x the sensor noise with (8, 16) and 4.2x with (24, 64).
PRE, POST, TAPER, THRESHOLD = 8, 16, 8, 0.05


def impact_window(force: np.ndarray, *, pre: int = PRE, post: int = POST, taper: int = TAPER,
                  threshold: float = THRESHOLD) -> np.ndarray:
    """Window (same length as ``force``, values in [0, 1]) around the impact(s).

    It is 1 from ``pre`` samples before the first sample whose magnitude exceeds
    ``threshold`` times the peak to ``post`` samples after the last such sample (so a double
    hit is kept whole), falls to 0 over ``taper`` samples by a half cosine, and is 0 elsewhere.
    """
    force = np.asarray(force, dtype=float)
    n = force.size
    peak = np.max(np.abs(force))
    if not peak > 0:
        raise ValueError("the force channel is zero everywhere: no impact to window")
    above = np.flatnonzero(np.abs(force) >= threshold * peak)
    first, last = max(above[0] - pre, 0), min(above[-1] + post, n - 1)
    window = np.zeros(n)
    window[first : last + 1] = 1.0
    ramp = 0.5 * (1 + np.cos(np.pi * np.arange(1, taper + 1) / (taper + 1)))
    left = np.arange(first - 1, first - 1 - taper, -1)
    right = np.arange(last + 1, last + 1 + taper)
    window[left[left >= 0]] = ramp[left >= 0]
    window[right[right < n]] = ramp[right < n]
    return window


@dataclass(frozen=True)
class ForceNoise:
    """The noise left in the windowed, decimated force: independent samples of known variance.

    ``sd``: the force channel's noise sd at the recorded rate (N); ``index``: the samples of the
    (decimated) record that keep some noise; ``variance``: their noise variance (N^2).
    """

    sd: float
    index: np.ndarray
    variance: np.ndarray

    @property
    def size(self) -> int:
        return int(self.index.size)


def force_noise(recording, factor: int = 1) -> ForceNoise | None:
    r"""The noise of a measured force inside its impact window, at the rate fs/``factor``.

    Its sd :math:`\sigma_f` is measured robustly (1.4826 x the median absolute deviation) where
    the window (:func:`impact_window`) is zero, so the pulse does not inflate it. Inside the
    window the kept noise is :math:`w_j e_j`. After the decimating low-pass its samples are
    correlated, but below the passband edge, the only band a fit uses, independent samples of
    variance

    .. math:: s_k^2 = \frac{\sigma_f^2}{D}\,\overline{w^2}_k

    have the same spectral density (:math:`\overline{w^2}_k` is the mean of :math:`w^2` over
    the D = ``factor`` recorded samples centred on sample k; exact for D = 1).
    Returns None for recordings without a measured force or with a noise-free force channel.
    """
    force = recording.force
    if recording.excitation.kind != "force" or force is None:
        return None
    window = impact_window(force)
    quiet = force[window == 0]
    if quiet.size < 16:
        return None
    sd = 1.4826 * float(np.median(np.abs(quiet - np.median(quiet))))
    if not sd > 0:
        return None
    factor = int(factor)
    n_out = -(-force.size // factor)
    pad = np.zeros(n_out * factor + factor)
    pad[factor // 2 : factor // 2 + force.size] = window**2     # sample k covers k D -/+ D/2
    mean_w2 = pad[: n_out * factor].reshape(n_out, factor).mean(axis=1)
    index = np.flatnonzero(mean_w2 > 0)
    return ForceNoise(sd, index, sd**2 / factor * mean_w2[index])


def decimate(recording, factor: int, *, force_window: bool | None = None):
    """The recording low-passed and resampled at fs/factor, as the DAQ would have recorded it.

    Force and response channels pass the same zero-phase DAQ passband at the new rate
    (:func:`bayesbeam.response.linear.daq_passband`, flat to 0.40 fs', zero from 0.50 fs'), by
    FFT with zero padding, so a model built on the result sees consistent band-limited signals.
    The impact force window (on by default for ``kind = "force"``) is applied at the full rate
    first, so the noise it removes is not smeared into the kept samples. The last few dozen
    samples carry the filter's response to the end of the record: leave them out of a fit
    (:data:`EDGE` samples of the new rate).
    """
    factor = int(factor)
    if factor < 1:
        raise ValueError(f"decimation factor must be >= 1, got {factor}")
    force = recording.force
    if force is not None and (force_window is None or force_window):
        force = force * impact_window(force)
    if factor == 1:
        return replace(recording, force=force)
    n = recording.n_samples
    n_fft = 2 * n
    weight = daq_passband(np.fft.rfftfreq(n_fft, recording.dt), recording.fs / factor)

    def low_pass(x):
        return np.fft.irfft(np.fft.rfft(x, n_fft, axis=0) * weight.reshape((-1,) + (1,) * (x.ndim - 1)),
                            n_fft, axis=0)[:n:factor]

    return replace(recording, time=recording.time[::factor], signals=low_pass(recording.signals),
                   force=None if force is None else low_pass(force))


#: samples (of the decimated rate) at the end of a decimated record disturbed by the low-pass
EDGE = 128
