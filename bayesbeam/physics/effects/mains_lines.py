r"""Mains pickup on the response channels: sinusoids at the harmonics of the mains frequency.

A sensor's cable, a ground loop or the DAQ's supply picks up the mains: every response channel
reads the motion plus :math:`\sum_k a_{ck}\cos(2\pi k f_{mains} t) + b_{ck}\sin(2\pi k f_{mains} t)`,
with its own unknown amplitudes per channel c and harmonic k. The pickup is not beam motion:
the model's simulated response is unchanged, and the force channel is not touched (a hammer's
pulse lasts a millisecond and the force window keeps only its samples).

Linear in a and b, the pickup is marginalised analytically beside the other latent terms of the
likelihood (:mod:`bayesbeam.inference.likelihood`), never sampled: this module gives the columns
(:meth:`MainsLines.latent_columns`), the likelihood their prior. Harmonics: every k >= 1 with
k f_mains at or below the top of the fitted band.

f_mains is fixed at the nominal mains frequency (a default, not a sampled parameter): ``[setup]
mains_hz`` where beam.toml states it, else 50 or 60 Hz by which has more harmonics standing
:data:`LINE_FACTOR` above the noise floor that keep :data:`PERSISTENT` of their amplitude over the
record from a free decay's start (:func:`persistent_lines`; a beam mode decays; the test
``bayesbeam check`` applies), else 50 Hz. Grids hold their frequency within +-0.2 Hz (typically +-0.05 Hz); a shift
of 0.02 Hz turns the fundamental by 0.08 cycles over a 4 s record, so the columns at the nominal
frequency carry the line, and sampling f_mains would buy little for a posterior that is its
prior on short records and multimodal (side lobes every 1/(k T)) on long ones.
"""
from __future__ import annotations

import copy
from dataclasses import dataclass
from typing import ClassVar

import numpy as np
from scipy import signal

from bayesbeam.physics.effects.base import Effect

#: the nominal mains frequencies (Hz) and the one taken when neither is found in the record
MAINS = (50.0, 60.0)
#: a harmonic's periodogram peak stands this many times above the median density (15 dB, as the
#: spectral peaks of ``bayesbeam check``)
LINE_FACTOR = 30.0
#: a line keeps this fraction of its amplitude from the first to the last third of the analysed span
#: (:func:`line_persistence`), where a beam mode would decay
PERSISTENT = 0.8
#: a line's peak is looked for within this many bins of the harmonic
LINE_BINS = 2
#: the top of the record's spectrum searched for harmonics, as a fraction of fs: the DAQ passband
#: (bayesbeam.response.linear.PASSBAND, a layer above this one)
PASSBAND = 0.4


class MainsLines(Effect):
    name = "mains_lines"
    parameters = ("f_mains",)
    units: ClassVar[dict[str, str]] = {"f_mains": "Hz"}
    defaults: ClassVar[dict[str, float]] = {"f_mains": MAINS[0]}
    description = ("mains pickup on every response channel: sinusoids at each harmonic k f_mains in the fitted "
                   "band with free amplitude and phase per channel, marginalised (f_mains fixed: [setup] mains_hz, "
                   "else the record's lines, else 50 Hz)")

    def bind(self, recording) -> MainsLines:
        """The effect for ``recording``: f_mains its nominal mains frequency (:func:`nominal_mains`)."""
        bound = copy.copy(self)
        bound.defaults = {"f_mains": nominal_mains(recording)}
        return bound

    def check(self, values) -> None:
        f = values["f_mains"]
        if not (np.isfinite(f) and f > 0):
            raise ValueError(f"{self.name}: f_mains = {f!r} Hz is not physical (must be finite and > 0)")

    def latent_columns(self, time, values, n_sensors, max_frequency):
        """Unit cos and sin of each harmonic k f_mains <= ``max_frequency`` on each response channel:
        (n_samples, n_sensors, 2 K n_sensors), column (c, k, cos/sin) nonzero on channel c only."""
        harmonics = harmonics_in_band(values["f_mains"], max_frequency)
        phase = 2 * np.pi * np.outer(time - time[0], harmonics)                       # (n, K)
        waves = np.concatenate([np.cos(phase), np.sin(phase)], axis=1)                # (n, 2K)
        columns = np.zeros((time.size, n_sensors, n_sensors * waves.shape[1]))
        for c in range(n_sensors):
            columns[:, c, c * waves.shape[1]:(c + 1) * waves.shape[1]] = waves
        return columns


def harmonics_in_band(f_mains: float, max_frequency: float) -> np.ndarray:
    """The frequencies k f_mains (Hz), k = 1, 2, ..., at or below ``max_frequency``."""
    return f_mains * np.arange(1, int(np.floor(max_frequency / f_mains + 1e-9)) + 1)


def nominal_mains(recording) -> float:
    """``[setup] mains_hz`` where stated; else the nominal of :data:`MAINS` with more persistent lines
    in the record's response channels (:func:`persistent_lines`; the higher summed peak ratio breaks a
    tie); else 50 Hz."""
    stated = recording.setup.mains_hz
    if stated is not None:
        return float(stated)
    counts = [persistent_lines(recording, m) for m in MAINS]
    best = max(range(len(MAINS)), key=lambda i: counts[i])
    return MAINS[best] if counts[best][0] > 0 else MAINS[0]


def persistent_lines(recording, f_mains: float) -> tuple[int, float]:
    """(how many (channel, harmonic) pairs carry a persistent line, their summed peak ratio) at the
    harmonics of ``f_mains`` below the DAQ passband, over the analysed span (:func:`analysed_span`):
    the span's periodogram peaks within LINE_BINS of the harmonic and LINE_FACTOR above the median
    density, and the line keeps PERSISTENT of its amplitude over the span (:func:`line_persistence`,
    the test ``bayesbeam check`` applies: a mode decays)."""
    span = analysed_span(recording)
    x = recording.signals[span.i0 : span.i1]
    peak, at, floor, where = _harmonic_peaks(x, span.fs, f_mains)
    ratio = peak / floor
    found = at & (ratio >= LINE_FACTOR)
    for k, c in zip(*np.nonzero(found)):          # the band-pass envelope only where a peak stands
        found[k, c] = line_persistence(recording.signals[:, c], span, where[k, c]) >= PERSISTENT
    return int(found.sum()), float(ratio[found].sum())


@dataclass(frozen=True)
class Span:
    """Samples ``i0:i1`` of a record at ``fs`` (Hz) that :func:`line_persistence` compares (the
    attributes of a band projection it reads): its band-pass is two bins of the span's resolution wide."""

    fs: float
    i0: int
    i1: int

    @property
    def block(self) -> int:
        return self.i1 - self.i0


def analysed_span(recording) -> Span:
    """The record from the start of a free decay (the record's first sample otherwise) to its end."""
    i0 = (int(np.searchsorted(recording.time, recording.excitation.start))
          if recording.excitation.kind == "free_decay" else 0)
    return Span(recording.fs, i0, recording.n_samples)


def line_persistence(residual: np.ndarray, proj, f_line: float) -> float:
    """Amplitude of ``residual`` near f_line in the last third of the window ``proj.i0:proj.i1`` over
    that in the first.

    The residual is band-passed to f_line +- 2 bins (2nd-order Butterworth, zero phase); the
    Hilbert envelope is averaged over each third, leaving out one period of the pass band's width
    at the window's ends (the filter's start-up).
    """
    seg = residual[proj.i0 : proj.i1]
    df = proj.fs / proj.block
    lo, hi = max(f_line - 2 * df, df / 2), min(f_line + 2 * df, 0.49 * proj.fs)
    sos = signal.butter(2, [lo, hi], btype="bandpass", fs=proj.fs, output="sos")
    env = np.abs(signal.hilbert(signal.sosfiltfilt(sos, seg)))
    settle = int(np.ceil(proj.fs / (hi - lo)))
    env = env[settle : len(env) - settle]
    third = max(len(env) // 3, 1)
    first = np.mean(env[:third])
    return float(np.mean(env[-third:]) / first) if first > 0 else 0.0      # a silent channel holds no line


def _harmonic_peaks(x: np.ndarray, fs: float, f_mains: float):
    """Per harmonic below the DAQ passband and channel, (K, c): the periodogram's peak density
    within a window of LINE_BINS + 1 bins about the harmonic, whether that peak lies within
    LINE_BINS of it (as ``bayesbeam check``'s mains test: a grid's frequency and a DAQ's clock
    differ by a few hundredths of a hertz), the median density below the passband (c,), and the
    peak's frequency (K, c) in Hz."""
    f, density = signal.periodogram(x, fs, window="hann", axis=0)
    step = f[1]
    harmonics = [h for h in harmonics_in_band(f_mains, PASSBAND * fs) if h >= LINE_BINS * step]
    shape = (len(harmonics), x.shape[1])
    peaks, at, where = np.zeros(shape), np.zeros(shape, bool), np.zeros(shape)
    for i, h in enumerate(harmonics):
        near = np.flatnonzero(np.abs(f - h) <= (LINE_BINS + 1) * step)
        top = near[np.argmax(density[near], axis=0)]
        peaks[i], at[i], where[i] = density[top, np.arange(x.shape[1])], np.abs(f[top] - h) <= LINE_BINS * step, f[top]
    band = (f > 0) & (f < PASSBAND * fs)
    return peaks, at, np.maximum(np.median(density[band], axis=0), np.finfo(float).tiny), where
