"""The data-acquisition model: a zero-phase anti-alias FIR on the fine grid, then decimation.

Every channel (force and responses alike) is simulated on a grid ``oversample`` times finer than
the recording rate fs, convolved with one symmetric Kaiser-windowed-sinc low-pass (cut-off
0.45 fs, transition 0.40-0.50 fs, ripple and stop band 1e-5, i.e. flat to 1e-5 below 0.40 fs and
-100 dB above 0.50 fs) centred on each recorded sample, and kept at every ``oversample``-th
point. Symmetric taps centred on the sample: no delay, no phase.

Before it, the response channels may pass a measurement chain (:func:`measurement_chain`): an AC
coupling (first-order high-pass) and a calibration gain per channel; the force channel does not.
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np
from scipy import signal

#: Kaiser design targets: band edges as fractions of the recording rate, attenuation in dB
PASS_EDGE, STOP_EDGE, ATTENUATION_DB = 0.40, 0.50, 100.0


@dataclass(frozen=True)
class AntiAlias:
    """The FIR for recording rate ``fs`` (Hz) applied on a grid ``oversample`` times finer."""

    fs: float
    oversample: int = 16

    @cached_property
    def taps(self) -> np.ndarray:
        """Odd-length symmetric taps (sum 1) on the fine grid."""
        width = (STOP_EDGE - PASS_EDGE) / (self.oversample / 2)  # transition, fraction of the fine Nyquist
        n, beta = signal.kaiserord(ATTENUATION_DB, width)
        n += 1 - n % 2
        cutoff = (PASS_EDGE + STOP_EDGE) / 2 / (self.oversample / 2)
        return signal.firwin(n, cutoff, window=("kaiser", beta))

    @property
    def half(self) -> int:
        """Fine samples on either side of the centre tap."""
        return (self.taps.size - 1) // 2

    def sample(self, fine: np.ndarray, n: int) -> np.ndarray:
        """Recorded samples (n, ...) from fine-grid values at times (i - half) h, i = 0 .. (n-1) R + 2 half.

        Recorded sample k is centred on fine time k R h = k / fs.
        """
        fine = np.asarray(fine, dtype=float)
        if fine.shape[0] != (n - 1) * self.oversample + 2 * self.half + 1:
            raise ValueError(f"need {(n - 1) * self.oversample + 2 * self.half + 1} fine samples, got {fine.shape[0]}")
        windows = np.lib.stride_tricks.sliding_window_view(fine, self.taps.size, axis=0)[:: self.oversample]
        return windows @ self.taps


def measurement_chain(fine: np.ndarray, h: float, f_hp: float = 0.0, gains=None) -> np.ndarray:
    """Response channels (time first, a column per sensor) on the fine grid of step ``h`` (s) seen
    through an AC coupling s/(s + 2 pi f_hp) (f_hp in Hz; 0: DC coupled) and read with gains 1 + g.

    The coupling is integrated exactly for values linear between fine points: the blocked part x
    obeys x' = w (u - x), w = 2 pi f_hp, and over a step x_{k+1} = a x_k + (1 - a - b) u_k + b u_{k+1}
    with a = e^{-w h}, b = 1 - (1 - a)/(w h); the channel reads u - x. What came before the first
    value has long been blocked (a release's static deflection, a beam at rest): x starts there.
    """
    out = np.asarray(fine, dtype=float)
    if f_hp > 0:
        wh = 2 * np.pi * f_hp * h
        a, b = np.exp(-wh), 1 + np.expm1(-wh) / wh
        change = out - out[:1]
        out = change - signal.lfilter([b, 1 - a - b], [1.0, -a], change, axis=0)
    return out if gains is None else out * (1.0 + np.asarray(gains, dtype=float))


def mains_pickup(t: np.ndarray, f_mains: float, amplitudes, phases) -> np.ndarray:
    """Mains pickup at times ``t`` (s): sum_k A_k cos(2 pi k f_mains t + phi_k), k = 1, 2, ... over
    ``amplitudes`` (A_k, the channel's unit) and ``phases`` (rad). Added where the channel is read,
    after the beam: it passes the anti-alias filter unchanged (flat to 1e-5 below 0.40 fs), so it
    may be sampled at the recorded instants directly."""
    t = np.asarray(t, dtype=float)
    return sum(a * np.cos(2 * np.pi * (k + 1) * f_mains * t + p) for k, (a, p) in enumerate(zip(amplitudes, phases)))
