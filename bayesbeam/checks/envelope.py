r"""Per-mode frequency and damping of a decaying signal by band-pass filtering and its envelope.

For each mode m near a frequency :math:`f_m` the signal is band-pass filtered (4th-order
Butterworth, zero phase) over :math:`f_m (1 \pm w_m)`, with :math:`w_m` half the relative gap to
the nearest neighbouring mode (at most 0.3), and its analytic signal
:math:`y_m + i\,\mathcal H y_m = A(t) e^{i\phi(t)}` is formed. A single damped mode gives
:math:`\log A = c - \sigma t` and :math:`\phi = \omega_d t + \phi_0`, so least-squares lines through
:math:`\log A` and the unwrapped phase give

.. math:: f_m = \frac{\omega_d}{2\pi}, \qquad
          \zeta_m = \frac{\sigma}{\sqrt{\sigma^2 + \omega_d^2}}.

The fit uses the part of the window where the envelope stands above ``floor`` x its final
level and away from the filter's start-up (``settle`` periods of the pass band). It is the
band-pass-and-envelope estimator a lab applies to a free decay; the posterior predictive checks
apply the same estimator to measured and replicated signals, so its bias (filter leakage,
neighbouring modes) cancels in the comparison.

:func:`envelope_curvature` also returns the decay rate at the start and at the end of the fitted
stretch: equal for linear damping, unequal when the damping depends on the amplitude.
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from scipy import signal

#: filter start-up left out at both ends, in periods of the pass band's width
SETTLE = 1.0
#: widest half-band, relative to the mode frequency
MAX_HALF_WIDTH = 0.3
#: envelope kept while above this multiple of the band-passed noise's sd
FLOOR = 10.0


@dataclass(frozen=True)
class ModeEstimate:
    frequency_hz: np.ndarray      # (modes,), NaN where no estimate
    damping_ratio: np.ndarray     # (modes,)
    decay_start: np.ndarray       # envelope decay rate sigma (1/s) over the first third
    decay_end: np.ndarray         # ... and over the last third


def band_edges(frequencies) -> list[tuple[float, float]]:
    """Pass band (Hz) of each mode: +-(half the relative gap to the nearest neighbour), <= 30 %."""
    f = np.asarray(frequencies, float)
    out = []
    for i, fm in enumerate(f):
        gaps = [abs(fm - g) / fm for j, g in enumerate(f) if j != i]
        w = min([MAX_HALF_WIDTH] + [0.5 * g for g in gaps])
        out.append((fm * (1 - w), fm * (1 + w)))
    return out


def mode_estimates(y: np.ndarray, fs: float, frequencies, start: float = 0.0,
                   noise_sd: float = 0.0) -> ModeEstimate:
    """Frequency and damping of the modes near ``frequencies`` (Hz) in y (samples,), from ``start`` (s).

    ``noise_sd``: sd of white measurement noise in y; the fit keeps the stretch where the
    envelope exceeds :data:`FLOOR` x the band-passed noise's envelope (0: no floor).
    """
    y = np.asarray(y, float)
    time = np.arange(len(y)) / fs
    rows = [_one_mode(y, time, fs, lo, hi, start, noise_sd) for lo, hi in band_edges(frequencies)]
    return ModeEstimate(*(np.array(col) for col in zip(*rows)))


@lru_cache(maxsize=256)
def band_pass(lo: float, hi: float, fs: float) -> np.ndarray:
    """The estimator's 4th-order Butterworth band-pass over (lo, hi) Hz as second-order sections
    (also the mismatch map's phase filter, :mod:`bayesbeam.checks.discrepancy`): the same bands
    are filtered in every replicate of a check and every evaluation of a screen, and the design
    costs more than the filtering."""
    return signal.butter(4, [lo, hi], btype="bandpass", fs=fs, output="sos")


def _one_mode(y, time, fs, lo, hi, start, noise_sd):
    nan = (np.nan,) * 4
    if hi >= 0.45 * fs or lo <= 0:
        return nan
    analytic = signal.hilbert(signal.sosfiltfilt(band_pass(lo, hi, fs), y))
    settle = SETTLE / (hi - lo)
    keep = (time >= start + settle) & (time <= time[-1] - settle)
    if keep.sum() < 16:
        return nan
    # white noise band-passed to (lo, hi) has sd noise_sd sqrt(2 (hi - lo) / fs)
    floor = FLOOR * noise_sd * np.sqrt(2 * (hi - lo) / fs)
    keep &= np.abs(analytic) > floor
    if not keep[-1]:
        # the envelope sank into the noise: stop at its first dip below the floor
        first = np.argmax(keep)
        keep[first + np.argmin(keep[first:]):] = False
    if keep.sum() < 16:
        return nan
    amp = np.abs(analytic[keep])
    t = time[keep]
    phase = np.unwrap(np.angle(analytic[keep]))
    omega = np.polyfit(t, phase, 1)[0]
    log_amp = np.log(np.maximum(amp, np.finfo(float).tiny))
    sigma = -np.polyfit(t, log_amp, 1)[0]
    third = len(t) // 3
    s_start = -np.polyfit(t[:third], log_amp[:third], 1)[0] if third > 8 else np.nan
    s_end = -np.polyfit(t[-third:], log_amp[-third:], 1)[0] if third > 8 else np.nan
    zeta = sigma / np.hypot(sigma, omega)
    return abs(omega) / (2 * np.pi), zeta, s_start, s_end
