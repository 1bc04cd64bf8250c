"""Conditioning of measured input signals.

The force window of impact testing: outside the impact a hammer's force channel holds only noise,
and that noise, fed to the model as a force, drives a spurious response over the whole record.
The standard remedy keeps the samples around the impact and zeroes the rest.

What counts as the impact is judged against the channel's own noise, pulse by pulse
(:func:`find_pulses`): a sample belongs to a pulse when it stands out of the noise by
:data:`NOISE_MULTIPLE` robust standard deviations as well as by :data:`THRESHOLD` of the peak;
samples close together form one pulse; the main impact and every later pulse with the shape of a
hit (a double hit, a bounce of the hammer) are kept, while a spike of one or two samples away from
every hit (a noise extreme, an electrical glitch) is not. The window (:func:`impact_window`) is
the union of short windows around the hits, so a stray sample late in the record cannot stretch
it over the record.

The samples it keeps still carry their noise: the force is an errors-in-variables input.
:func:`force_noise` measures that noise where the window is closed and states what is left of it
in the kept samples, so the likelihood can marginalise the response it drives
(:mod:`bayesbeam.inference.likelihood`).
"""
from __future__ import annotations

import warnings
from dataclasses import dataclass, replace

import numpy as np

from bayesbeam.response.linear import daq_passband

#: default force window: samples kept before the first and after the last sample of each hit,
#: and the length of the half-cosine tapers outside them. Every kept sample also keeps its
#: noise, which drives a response of its own (the force is an errors-in-variables input), so
#: the window is short: it holds the pulse whole (the threshold follows a soft tip) and the
#: strongest anti-alias ringing next to it, which lies near 0.45 fs, out of the band that is
#: fitted. On the paper_q3_hammer example (1% force noise) the in-band residual at the true
#: parameters is 1.8x the sensor noise with (8, 16) and 4.2x with (24, 64).
PRE, POST, TAPER, THRESHOLD = 8, 16, 8, 0.05
#: a pulse sample also stands this many robust noise sd (1.4826 x MAD) off the channel's
#: median: Gaussian noise passes 5 sd in 6e-7 of its samples, about one record in a hundred at
#: 20 000 samples, and such a lone sample is then a spike, not a hit (:func:`find_pulses`)
NOISE_MULTIPLE = 5.0
#: samples above the threshold less than GAP samples apart belong to one pulse: the anti-alias
#: ringing of one pulse dips below the threshold for a sample or two (its period is about
#: 2.2 samples), while a hammer's bounce comes milliseconds later
GAP = 8
#: a pulse spanning fewer samples than this, away from the main impact, is a spike: any
#: contact force lasts at least a few samples once the DAQ's low-pass has smoothed it
MIN_HIT_SAMPLES = 3
#: more latent force-noise samples than this draw a warning (:func:`force_noise`). The cost of a
#: likelihood grows about in proportion to them: on the paper_q3_hammer example at N = 16, 64 of
#: them take 4-6x the time of the 6 a single hit leaves at a decimated rate; one window at the
#: recorded rate holds about 45
MAX_LATENT = 64


@dataclass(frozen=True)
class Pulse:
    """One cluster of force samples above the threshold.

    ``start``, ``stop``: its first and last sample above the threshold (inclusive);
    ``peak_index``, ``peak``: its largest deviation from the channel's median (N, signed);
    ``hit``: True for the main impact and every later pulse with the shape of a hit, False for a
    spike of one or two samples away from every hit.
    """

    start: int
    stop: int
    peak_index: int
    peak: float
    hit: bool

    @property
    def width(self) -> int:
        """Samples from the first to the last above the threshold."""
        return self.stop - self.start + 1


@dataclass(frozen=True)
class ForcePulses:
    """The pulses of a force channel and how they were judged.

    ``threshold`` (N): the deviation from ``baseline`` (the channel's median, N) a pulse sample
    reaches: the larger of THRESHOLD x the peak and NOISE_MULTIPLE x ``noise_sd`` (the robust sd
    of the channel, N), but at most the peak.
    """

    pulses: tuple[Pulse, ...]
    threshold: float
    noise_sd: float
    baseline: float

    @property
    def hits(self) -> tuple[Pulse, ...]:
        return tuple(p for p in self.pulses if p.hit)

    @property
    def spikes(self) -> tuple[Pulse, ...]:
        return tuple(p for p in self.pulses if not p.hit)


def robust_sd(x: np.ndarray) -> float:
    """1.4826 x the median absolute deviation: the sd of Gaussian noise, unmoved by a few pulses."""
    x = np.asarray(x, dtype=float)
    return 1.4826 * float(np.median(np.abs(x - np.median(x))))


def find_pulses(force: np.ndarray, *, threshold: float = THRESHOLD,
                noise_multiple: float = NOISE_MULTIPLE) -> ForcePulses:
    """The pulses of a force channel (N), each a hit or a spike (module docstring).

    The noise sd is measured over the whole channel: the pulses hold a few dozen of its
    thousands of samples, which do not move a median. Raises ValueError for a channel that is
    constant (no impact).
    """
    force = np.asarray(force, dtype=float)
    baseline = float(np.median(force))
    deviation = force - baseline
    main = int(np.argmax(np.abs(deviation)))
    peak = abs(deviation[main])
    if not peak > 0:
        raise ValueError("the force channel is constant: no impact to window")
    noise_sd = robust_sd(force)
    # never above the peak: a channel that is all noise still has its main impact
    level = min(max(threshold * peak, noise_multiple * noise_sd), peak)
    above = np.flatnonzero(np.abs(deviation) >= level)
    breaks = np.flatnonzero(np.diff(above) >= GAP) + 1
    pulses = tuple(_pulse(cluster, deviation, main) for cluster in np.split(above, breaks))
    return ForcePulses(pulses, float(level), noise_sd, baseline)


def _pulse(cluster: np.ndarray, deviation: np.ndarray, main: int) -> Pulse:
    start, stop = int(cluster[0]), int(cluster[-1])
    top = start + int(np.argmax(np.abs(deviation[start : stop + 1])))
    hit = start <= main <= stop or stop - start + 1 >= MIN_HIT_SAMPLES
    return Pulse(start, stop, top, float(deviation[top]), hit)


def impact_window(force: np.ndarray, *, pre: int = PRE, post: int = POST, taper: int = TAPER,
                  threshold: float = THRESHOLD) -> np.ndarray:
    """Window (same length as ``force``, values in [0, 1]) around the hits of the impact.

    Around each hit of :func:`find_pulses` it is 1 from ``pre`` samples before its first sample
    above the threshold to ``post`` samples after its last, falls to 0 over ``taper`` samples
    by a half cosine, and is 0 elsewhere; the windows of several hits are joined by their
    maximum. Spikes are left out.
    """
    force = np.asarray(force, dtype=float)
    return _hits_window(force.size, find_pulses(force, threshold=threshold).hits, pre, post, taper)


def _hits_window(n: int, hits, pre: int = PRE, post: int = POST, taper: int = TAPER) -> np.ndarray:
    window = np.zeros(n)
    for hit in hits:
        window = np.maximum(window, _hit_window(n, hit, pre, post, taper))
    return window


def _hit_window(n: int, hit: Pulse, pre: int, post: int, taper: int) -> np.ndarray:
    first, last = max(hit.start - pre, 0), min(hit.stop + post, n - 1)
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
    r"""The noise left in the windowed force, as latent inputs of known prior variance.

    ``sd``: the force channel's noise sd at the recorded rate (N). ``position`` (J,): the recorded
    samples the window keeps, in samples of the fitted (decimated) record, fractional when it is
    decimated by ``factor``. ``variance`` (K,): the prior variance of each latent coefficient.
    ``mixing`` (J, K) or None: the noise of recorded sample j is
    :math:`\varepsilon_j = \sum_k M_{jk}\,\eta_k` (N) with independent
    :math:`\eta_k \sim N(0, \text{variance}_k)`; None means :math:`M = I` (each kept sample is
    a latent term of its own, at an integer ``position``).
    """

    sd: float
    position: np.ndarray
    variance: np.ndarray
    mixing: np.ndarray | None = None
    factor: int = 1

    @property
    def size(self) -> int:
        """The number of latent terms K."""
        return int(self.variance.size)

    @property
    def index(self) -> np.ndarray:
        """The samples of the fitted record nearest to each kept recorded sample (J,)."""
        return np.rint(self.position).astype(int)

    def recorded(self, coef: np.ndarray) -> np.ndarray:
        """The force noise at the kept recorded samples (J,) for latent coefficients ``coef`` (K,)."""
        return coef if self.mixing is None else self.mixing @ coef


def force_noise(recording, factor: int = 1, lead: int = 0) -> ForceNoise | None:
    r"""The noise of a measured force inside its impact window, as the latent inputs of a fit of
    the record :func:`decimate` makes with the same ``factor`` and ``lead``.

    Its sd :math:`\sigma_f` is measured robustly (1.4826 x the median absolute deviation) where
    the window (:func:`impact_window`) is zero, so the pulse does not inflate it. Inside the
    window the kept noise is :math:`\varepsilon_j = w_j e_j`: independent, of variance
    :math:`\sigma_f^2 w_j^2`, at the recorded samples j. At the recorded rate (``factor`` 1)
    each is a latent term of its own. Decimated, a recorded sample lies between two samples of
    the fitted record (up to half a sample from either: 1.15 rad of phase at 152 Hz when 4096 Hz
    is decimated by 10), so the noise is not a set of independent samples of the decimated
    record; its exact content in the band the model passes (W(f) > 0, below fs'/2) is spanned by
    a few principal inputs (:func:`_principal_inputs`), each a fixed mixture of the recorded
    samples with unit prior variance. Returns None for recordings without a measured force or
    with a noise-free force channel.
    """
    force = recording.force
    if recording.excitation.kind != "force" or force is None:
        return None
    pulses = find_pulses(force)
    _report_pulses(recording, pulses)
    window = _hits_window(force.size, pulses.hits)
    quiet = force[window == 0]
    if quiet.size < 16:
        return None
    sd = robust_sd(quiet)
    if not sd > 0:
        return None
    factor = int(factor)
    kept = np.flatnonzero(window > 0)
    position = kept / factor + int(lead)
    if factor == 1:
        noise = ForceNoise(sd, position, sd**2 * window[kept] ** 2)
    else:
        mixing = _principal_inputs(kept, sd * window[kept], recording.fs / factor, recording.dt)
        noise = ForceNoise(sd, position, np.ones(mixing.shape[1]), mixing, factor)
    if noise.size > MAX_LATENT:
        _warn_many_latent(recording, pulses.hits, kept.size, noise.size, factor)
    return noise


#: the share of the kept noise's in-band variance the principal inputs may leave out: a
#: resonance amplifies one frequency by about Q^2 ~ 1e4-1e6 over the band's average, so what is
#: left out stays below 1e-6 of the response to the noise at any frequency
PRINCIPAL_TAIL = 1e-12


def _principal_inputs(kept: np.ndarray, sd: np.ndarray, fs_fit: float, dt: float) -> np.ndarray:
    r"""The mixing matrix M (J, K) of the fewest inputs that carry the in-band content of
    independent noise of sd ``sd`` (N) at the recorded samples ``kept``.

    The noise's spectrum :math:`\sum_j \varepsilon_j e^{-i\omega t_j}`, weighted by the
    passband W of the fitted rate ``fs_fit``, is :math:`B\xi` with
    :math:`B_{fj} = W(f)\,\sigma_j e^{-i\omega t_j}` (real and imaginary parts stacked, f
    dense to fs_fit / 2) and :math:`\xi \sim N(0, I)`. With :math:`B = L \Sigma R^T`, the
    inputs :math:`M = \operatorname{diag}(\sigma) R_K` with unit variances reproduce its
    covariance :math:`L\Sigma^2L^T` but for the smallest singular values, whose share of
    :math:`\sum\Sigma^2` is below :data:`PRINCIPAL_TAIL`. The time-bandwidth product of a
    window of T s and a band of fs_fit / 2 bounds K near T fs_fit + a few: a 10 ms window at
    409.6 Hz needs 12 where it keeps 43 recorded samples.
    """
    t = (kept - kept[0]) * dt
    freq = np.linspace(0.0, 0.5 * fs_fit, 16 * kept.size + 64)
    phase = np.exp(-2j * np.pi * np.outer(freq, t)) * daq_passband(freq, fs_fit)[:, None]
    b = np.vstack([phase.real, phase.imag]) * sd[None, :]
    _, singular, rt = np.linalg.svd(b, full_matrices=False)
    power = singular**2
    tail = np.cumsum(power[::-1])[::-1] / power.sum()           # share of the inputs from k on
    k = max(int(np.sum(tail > PRINCIPAL_TAIL)), 1)
    return sd[:, None] * rt[:k].T


def _pulse_times(recording, pulses) -> str:
    return ", ".join(f"{recording.time[p.peak_index]:.4g} s ({p.width} sample{'s' * (p.width > 1)})" for p in pulses)


def _report_pulses(recording, pulses: ForcePulses) -> None:
    """Say in the run's output when the force holds more than one hit, or spikes left out."""
    where = recording.source or "recording"
    if len(pulses.hits) > 1:
        warnings.warn(f"{where}: the force channel holds {len(pulses.hits)} hits, at "
                      f"{_pulse_times(recording, pulses.hits)}; every hit stays in the force window.",
                      stacklevel=3)
    if pulses.spikes:
        warnings.warn(f"{where}: isolated spike(s) in the force channel at {_pulse_times(recording, pulses.spikes)} "
                      f"without a pulse's shape: left out of the force window.", stacklevel=3)


def _warn_many_latent(recording, hits, n_kept: int, n_latent: int, factor: int) -> None:
    """Say that the force-noise marginalisation has grown, and where the hits are."""
    times = _pulse_times(recording, hits)
    rate = "" if factor == 1 else f" fitted at {recording.fs / factor:.6g} Hz"
    warnings.warn(
        f"{recording.source or 'recording'}: the force window keeps {n_kept} samples at "
        f"{recording.fs:.6g} Hz{rate}, whose noise takes {n_latent} latent terms (more than "
        f"{MAX_LATENT}) in the force-noise marginalisation, which slows every likelihood "
        f"evaluation. The window holds {len(hits)} hit(s): {times}. Fix: check the force channel "
        f"(bayesbeam check), lower --max-frequency (the terms scale with the fitted rate), or trim "
        f"the record to the hits that matter.",
        stacklevel=3)


def decimate(recording, factor: int, *, force_window: bool | None = None, lead: int = 0, rest=None):
    """The recording low-passed and resampled at fs/factor, as the DAQ would have recorded it.

    Force and response channels pass the same zero-phase DAQ passband at the new rate
    (:func:`bayesbeam.response.linear.daq_passband`, flat to 0.40 fs', zero from 0.50 fs'), by
    FFT with zero padding, so a model built on the result sees consistent band-limited signals.
    The impact force window (on by default for ``kind = "force"``) is applied at the full rate
    first, so the noise it removes is not smeared into the kept samples. The last few dozen
    samples carry the filter's response to the end of the record: leave them out of a fit
    (:data:`EDGE` samples of the new rate).

    ``lead`` (factor > 1 only): samples of the new rate added before the record's start, where the
    beam rests (every channel zero at the full rate). The zero-phase low-pass spreads a hit near
    the start back over them (its kernel reaches about :data:`EDGE` samples of the new rate), and
    a model driven by the decimated force needs that part of it: without it the force lacks a few
    % of its in-band content (a hit 10 ms into a record decimated from 4096 to 409.6 Hz: -3 % at
    DC, +5 % at 127 Hz), and so does the modelled response. The samples from the record's start
    on are the same with or without the lead.

    ``rest`` (n_sensors,): what the response channels read before the record's start, where they
    are not zero (:func:`release_rest`: a release's static deflection); the low-pass then sees
    those values over the kernel's reach before the start, as the DAQ's filter saw them, instead
    of a step from zero to the first sample, which would disturb the first :data:`EDGE` samples
    (by 40 % of the static deflection at the first, on a displacement channel).
    """
    factor = int(factor)
    if factor < 1:
        raise ValueError(f"decimation factor must be >= 1, got {factor}")
    force = recording.force
    if force is not None and (force_window is None or force_window):
        force = force * impact_window(force)
    if factor == 1:
        return replace(recording, force=force)
    before = int(lead) * factor
    # full-rate samples of ``rest`` the kernel sees (none where every channel rested at zero: the padding's zeros)
    reach = EDGE * factor if rest is not None and np.any(rest) else 0
    n = recording.n_samples + before
    n_fft = 2 * (n + reach)
    weight = daq_passband(np.fft.rfftfreq(n_fft, recording.dt), recording.fs / factor)

    def low_pass(x, held=0.0):
        x = np.concatenate([np.broadcast_to(held, (reach,) + x.shape[1:]), np.zeros((before,) + x.shape[1:]), x])
        return np.fft.irfft(np.fft.rfft(x, n_fft, axis=0) * weight.reshape((-1,) + (1,) * (x.ndim - 1)),
                            n_fft, axis=0)[reach:reach + n:factor]

    time = np.concatenate([recording.time[0] - recording.dt * np.arange(before, 0, -factor), recording.time[::factor]])
    return replace(recording, time=time, signals=low_pass(recording.signals, 0.0 if rest is None else rest),
                   force=None if force is None else low_pass(force))


def release_rest(recording) -> np.ndarray | None:
    """What each response channel of a release recording read while the tip load was held, for
    :func:`decimate`'s ``rest``: a displacement channel its static deflection (the mean of its
    samples up to the release at t = 0), acceleration and velocity zero. None for other
    recordings, and for a release recorded from after t = 0 (the beam was already moving)."""
    if recording.excitation.kind != "release" or recording.time[0] > 0:
        return None
    held = recording.time <= 0
    return np.array([recording.signals[held, i].mean() if sensor.quantity == "displacement" else 0.0
                     for i, sensor in enumerate(recording.sensors)])


#: samples (of the decimated rate) at the end of a decimated record disturbed by the low-pass
EDGE = 128
