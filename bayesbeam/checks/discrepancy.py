r"""Where a fitted model misses its recording: the mismatch map ("Locate" of the diagnosis).

Input: a :class:`~bayesbeam.inference.posterior.LogPosterior` and draws of it. For S draws
:math:`\theta_s` the model predicts :math:`\hat y_s`, with band coordinates :math:`\hat z_s` (the
likelihood's orthonormal block-DFT coordinates, :class:`~bayesbeam.inference.likelihood.BandProjection`)
and noise variance :math:`v_s` per coordinate.

Noise floor
-----------
The fitted noise sd is a *parameter*: a model that misses the data inflates it until the misfit
looks like noise (at the optimum :math:`\sigma^2` is the mean residual power, so residuals
standardized by it always average 1). The map therefore measures residual power against the
noise floor of the cells where the model does fit: per coordinate

.. math:: u_j = \frac1S\sum_s \frac{(z_j - \hat z_{s,j})^2}{v_{s,j}}, \qquad
          \kappa_c = \frac{\sum_{j \notin \mathcal F} u_j}{\#\{j \notin \mathcal F\}},

with :math:`\mathcal F` the cells flagged below (iterated from a median start to a fixed point).
:math:`\kappa_c` is the floor over the fitted noise variance of channel c (``inflation`` in
``noise`` is :math:`1/\sqrt{\kappa_c}`, the fitted sd over the floor sd :math:`\sigma_c`); the
standardized residual power is :math:`u_j/\kappa_c`, expectation 1 where the model is right (the
residual at the posterior mean plus the posterior variance of the prediction: leverage h and 1 - h
add to 1). ``rms_standardized_residual`` is :math:`\sqrt{\mathrm{mean}_j\, u_j/\kappa_c}`.

The posterior's width scales with its noise sd too (its Laplace covariance is proportional to the
noise variance), so a misfit also widens it and would hide itself in wide replicates. The draws
are therefore first narrowed about their median by :math:`\sqrt{\max_c\kappa_c}` (never widened):
the posterior the model would have at the noise the data show.

(a) Standardized residual spectrogram
-------------------------------------
Cells are (time block, DFT bin) per sensor, with k = 2 coordinates (real and imaginary part; 1
for DC). Under the model :math:`\sum_{j\in\text{cell}} u_j/\kappa_c` is approximately
:math:`\chi^2_k` scaled by the floor, which is itself estimated from N coordinates, so the cell
statistic :math:`F = \overline{u}_\text{cell}/\kappa_c` is tested against :math:`F(k, N)`;
p-values of all cells of all sensors are corrected by Holm's step-down procedure (family-wise).

(b) Per mode
------------
For the model's modes in the fitted band (posterior median), the recording and S replicates
:math:`y^{rep}_s = \hat y_s + e_s` (noise at the floor) go through the same estimators, so their
bias cancels:

* frequency f and damping ratio :math:`\zeta` by ERA on the free decay after the impact
  (:func:`bayesbeam.checks.ppc.era_modes`): error :math:`\ln f^{obs} - \mathrm{med}_s \ln f^{rep}_s`;
* amplitude per sensor: :math:`A = \sqrt{\max(\sum_{j\in B} z_j^2 - |B|\sigma_c^2, 0.01|B|\sigma_c^2)}`
  over the coordinates of the mode's band B (:func:`bayesbeam.checks.envelope.band_edges`; the
  floor's noise power subtracted, so that noise-free simulations compare too), error in ln A;
* decay shape: the band-pass/Hilbert envelope's decay rate at the start and at the end of the
  decay (:func:`bayesbeam.checks.envelope.mode_estimates`), on the sensor where the mode is
  strongest; curvature :math:`c = \sigma_{start} - \sigma_{end}` (1/s). Linear damping: c equals
  the replicates'; damping that falls as the vibration decays (drag) gives a larger c, damping
  that rises as it decays (friction, a straight-line envelope) a smaller one.

Each error is divided by its sd (the replicates' sd times :math:`\sqrt{1 + \pi/(2S)}`, for the
scatter of their median) and tested two-sided against Student's t with S - 1 degrees of freedom,
Bonferroni over the tests of all modes.

(c) Phase against frequency
---------------------------
Per bin, the cross-spectrum :math:`C(f) = \sum_b Z_b(f)\,\overline{\hat Z_b(f)}` of the data and the
prediction at the posterior median (Z: complex bin of block b) has phase :math:`-2\pi f\tau` when
the data lag the prediction by :math:`\tau`, with sd :math:`1/\sqrt{w}`, :math:`w = \sum_b |\hat
Z_b|^2/\sigma^2`; bins with :math:`w \ge` :data:`PHASE_MIN_SNR` are kept for the figure. Its slope is
*not* used for the delay: a model that misses a mode's frequency by :math:`\delta\omega` accumulates
:math:`\delta\omega\,t` of phase over the block, and a fitted model trades frequency against delay
(on the paper's beam a 0.5 ms delay reads 0.15 ms from the slope). The delay comes instead from
each mode's phase *at the excitation time* :math:`t_0` (the force's centroid; the release), before
a frequency error has accumulated: the data and the prediction are band-passed around the mode
(the envelope estimator's Butterworth filter forward and backward, gain :math:`|H|^2`, applied by
FFT with zero padding), and the phase of
:math:`a_{data}(t)\,\overline{a_{pred}(t)}` (analytic signals) is fitted by a weighted line
:math:`\varphi_m + \delta\omega_m (t - t_0)` over the decay (weights :math:`|a_{pred}|^2`, where
:math:`|a_{pred}|` exceeds three band-passed noise sds). The intercept's error :math:`e_m` against
the replicates (sd :math:`s_m`) is a per-mode statistic, and

.. math:: \hat\tau = -\frac{\sum \omega_m e_m/s_m^2}{\sum \omega_m^2/s_m^2}, \qquad
          \mathrm{sd}(\hat\tau) = \frac{\max(1, \sqrt{\chi^2/(n-1)})}{\sqrt{\sum \omega_m^2/s_m^2}},

after a coarse search over :math:`|\tau| \le` :data:`MAX_DELAY` that maximises
:math:`\sum \cos(e_m + \omega_m\tau)/s_m^2` (no unwrapping); :math:`\chi^2 = \sum (e_m +
\omega_m\hat\tau)^2/s_m^2` says whether the phase error is a pure delay. A free decay has no
excitation time (its modal phases are fitted): no delay there.

*The latent force.* When the likelihood marginalises the force channel's noise, the prediction
includes the latent force's posterior mean :math:`c`, and a delay between the force and the
response channels (for a linear beam, a shifted force) is absorbed by it, out of sight of
everything above. :func:`latent_force` tests :math:`\chi^2 = \sum_j c_j^2/s_j^2` (:math:`s_j^2`
the samples' noise variance) against :math:`\chi^2_J` at ALPHA / 3: conservative, since the
posterior mean varies less than the prior. A significant latent force is a flag and a region.

(e) Practical significance
--------------------------
A statistically significant region need not matter: at a displacement channel's signal-to-noise
ratio at mode 1, a phase difference of 1e-3 rad is detectable. Each region therefore carries its
``misfit_share``: over the region's rectangle R (its blocks x its bins, on its sensor; the largest
over sensors for the delay), the residual energy at the posterior median above the noise floor
relative to what the recording holds there (the prediction's energy plus the noise's), as an
amplitude ratio,

.. math:: s = \sqrt{\max\Big(\sum_{j \in R} (z_j - \hat z_j)^2 - |R|\,\sigma_c^2,\; 0\Big)
          \Big/ \Big(\sum_{j \in R} \hat z_j^2 + |R|\,\sigma_c^2\Big)}.

It is measured against the region's own signal, not the channel's, so that a weak mode's misfit
is judged by that mode (the latent force's region: the share of the prediction that force
carries in excess of its noise, that share times :math:`\sqrt{1 - J/\chi^2}`). A region is
``practically_significant`` when :math:`s \ge`
:data:`PRACTICAL_SHARE` (1 %): a cantilever's clamp, geometry and sensor calibration are rarely
known better than that, and the forward model's own in-band error at the grids the discretisation
check accepts is of the same order, so a smaller misfit is no evidence of missing physics. Only
practically significant beam-physics regions make a diagnosis ``unexplained``; the statistical
flags alone still decide whether effects are tried.

False alarms
------------
:data:`ALPHA` is split equally over the three families (cells; per-mode tests; the delay), so the
map flags something on a recording the model explains with probability about ALPHA; the latent
force's test, also at ALPHA / 3, is conservative and adds less.

(d) Regions
-----------
Connected flagged cells (8-neighbourhood in block x bin) of one sensor form a region with the note
of the mode it covers. A narrow region away from every mode is a *line*: its residual is band-passed
and its amplitude in the last third of the window compared with the first; a line that keeps
:data:`PERSISTENT` of it while the beam would have decayed does not decay with the beam and is
flagged "not beam physics" (mains pickup when at a multiple of 50 or 60 Hz).
"""
from __future__ import annotations

import warnings
from dataclasses import dataclass, field
from functools import lru_cache

import numpy as np
from scipy import ndimage, signal, stats

from bayesbeam.checks.envelope import SETTLE, band_edges, band_pass, mode_estimates
from bayesbeam.checks.ppc import decay_start, era_modes, modes_in_band
from bayesbeam.inference.likelihood import _marginal

# one test of a line that does not decay, the mains effect's own (used by the map, the survey and the screen)
from bayesbeam.physics.effects.mains_lines import MAINS, PERSISTENT, line_persistence

#: family-wise false-alarm level of the whole map, split over cells, per-mode tests and the delay
ALPHA = 0.01
#: replicated recordings (posterior draws plus noise)
N_REPLICATES = 40
#: bins with less coherent signal-to-noise w than this are left out of the phase figure (sd 0.32 rad)
PHASE_MIN_SNR = 10.0
#: the per-mode phase uses samples where the band-passed prediction exceeds this many noise sds
PHASE_FLOOR = 3.0
#: the delay search reaches this (s): the default prior's bound on tau
MAX_DELAY = 0.005
#: a region within this relative distance (or two bins) of a model mode is at that mode
MODE_TOLERANCE = 0.05
#: iterations of the noise floor's fixed point
FLOOR_ITERATIONS = 20
#: a region's misfit must reach this share of its channel's signal to count toward "unexplained"
PRACTICAL_SHARE = 0.01
#: the per-mode statistics
MODE_STATISTICS = ("frequency", "damping", "amplitude", "curvature", "phase")


@dataclass
class Spectrogram:
    """Standardized residual power per (block, bin, sensor); expectation 1 where the model is right."""

    frequencies_hz: np.ndarray      # (n_bins,)
    block_times_s: np.ndarray       # (n_blocks,) start of each block
    block_duration_s: float
    power: np.ndarray               # (n_blocks, n_bins, c): mean standardized power per coordinate
    dof: np.ndarray                 # (n_bins,) coordinates per cell
    p_values: np.ndarray            # (n_blocks, n_bins, c), before the multiple-comparison correction
    significant: np.ndarray         # (n_blocks, n_bins, c) bool, Holm at ALPHA / 3


@dataclass(frozen=True)
class Setting:
    """What the per-mode estimators need besides the signal; the same for data, replicates and
    the signatures' simulations, so that estimator biases cancel."""

    projection: object
    dt: float
    f_model: np.ndarray             # (m,) model frequencies in band (Hz)
    bands: list                     # (m,) pass bands (Hz)
    channel: np.ndarray             # (m,) sensor index where each mode is strongest
    sigma: np.ndarray               # (c,) noise floor sd
    start_index: int                # first sample of the free decay
    t_ref: float | None             # excitation time (s from the first sample); None for a free decay
    reference: np.ndarray           # (n, c) the prediction at the posterior median
    reference_bands: tuple = ()     # (m,) its analytic signal in each mode's band, on the mode's sensor


@dataclass
class Features:
    """Observed errors (data minus the model's replicates' median) and the replicates' sd.

    Per mode m: ``ln_f<m>``, ``zeta<m>``, ``ln_A<m>_<sensor>``, ``curvature<m>`` (1/s), ``phase<m>`` (rad).
    ``replicated`` (S, n): each replicate's features minus the replicates' median, the same
    quantity as ``observed`` under the model (NaN where an estimator found nothing).
    """

    names: list
    observed: np.ndarray
    sd: np.ndarray
    replicated: np.ndarray

    def as_dict(self) -> dict:
        return dict(zip(self.names, zip(self.observed.tolist(), self.sd.tolist())))


@dataclass
class Mismatch:
    """The mismatch map of one fitted model and recording (see the module docstring)."""

    channels: tuple
    spectrogram: Spectrogram
    noise: dict                     # sensor -> {"floor_sd", "fitted_sd", "inflation"}
    rms_standardized_residual: float
    modes: list                     # per-mode rows
    phase: dict                     # per-bin phase (figure) and the delay
    features: Features
    setting: Setting
    regions: list = field(default_factory=list)     # {"band_hz", "time_s", "sensor", "note", ...}
    notes: list = field(default_factory=list)

    def to_dict(self) -> dict:
        """JSON-ready summary (the spectrogram and per-bin phase are left to the report's figures)."""
        phase = {k: self.phase.get(k) for k in ("delay_s", "delay_sd_s", "significant", "linear_p_value", "n_modes",
                                                 "force")}
        return {"rms_standardized_residual": self.rms_standardized_residual, "noise": self.noise,
                "mismatch": self.regions, "modes": self.modes, "phase": phase, "notes": self.notes,
                "features": {k: [_num(o), _num(s)] for k, (o, s) in self.features.as_dict().items()},
                "flagged_cells": int(self.spectrogram.significant.sum()), "alpha": ALPHA}


# ---------------------------------------------------------------------------- entry point
def locate(posterior, draws: np.ndarray, rng: np.random.Generator, n_replicates: int = N_REPLICATES) -> Mismatch:
    """The mismatch map for draws (n, ndim) in sampling coordinates (``posterior.split``)."""
    lik = posterior.likelihood
    centre = np.median(draws, axis=0)
    picks = draws[rng.choice(len(draws), size=n_replicates, replace=len(draws) < n_replicates)]
    picks = _narrowed(picks, centre, len(posterior.model_names), _residuals(lik, posterior, picks)[1])
    spec, kappa, u, (split, preds, var) = _residuals(lik, posterior, picks)
    sigma = np.sqrt(np.mean(var * kappa, axis=(0, 1)))
    setting = _setting(lik, posterior, centre, preds, sigma)
    reps = preds + np.array([lik.draw_noise(_scaled(n, kappa, lik.channels), preds.shape[1:], rng) for _, n in split])
    obs = statistics(lik.model.recording.signals, setting)
    rep = [statistics(y, setting) for y in reps]
    err = {k: _errors(obs[k], np.array([r[k] for r in rep])) for k in (*MODE_STATISTICS, "rates")}
    params = posterior.split(centre)[0]
    noise = {c: {"floor_sd": float(s), "fitted_sd": float(f), "inflation": float(f / s)}
             for c, s, f in zip(lik.channels, sigma, np.sqrt(np.mean(var, axis=(0, 1))))}
    phase = {**phase_spectrum(lik.z_data, lik.projection.project(setting.reference), lik.projection, sigma),
             **delay_fit(err["phase"][0], err["phase"][1], setting.f_model),
             "force": latent_force(lik, *posterior.split(centre))}
    out = Mismatch(lik.channels, spec, noise, float(np.sqrt(np.mean(u / kappa))),
                   _mode_rows(lik, params, setting, obs, err, len(reps)), phase, _features(err, rep, lik.channels),
                   setting)
    out.regions = _all_regions(out, lik, params)
    out.notes = _summary_notes(out)
    return out


def _residuals(lik, posterior, picks):
    """Spectrogram, floor kappa (c,), standardized residual u (D, c), and (split, predictions, variances)."""
    split = [posterior.split(theta) for theta in picks]
    preds = np.array([lik.predict(p, n) for p, n in split])                        # (S, n, c)
    var = np.array([lik.variance(n) for _, n in split])                            # (S, D, c)
    z_pred = np.array([lik.projection.project(y) for y in preds])
    u = np.mean((lik.z_data[None] - z_pred) ** 2 / var, axis=0)
    spec, kappa = _spectrogram(u, lik.projection, lik.model.recording.time)
    return spec, kappa, u, (split, preds, var)


def _narrowed(picks, centre, k, kappa) -> np.ndarray:
    """Draws with the model parameters' spread about the median scaled by sqrt(max_c kappa_c): the
    posterior the model would have at the noise floor (its Laplace covariance scales as the noise
    variance; the least-inflated channel sets the factor, and it never widens)."""
    out = picks.copy()
    out[:, :k] = centre[:k] + (picks[:, :k] - centre[:k]) * np.sqrt(min(float(np.max(kappa)), 1.0))
    return out


def _setting(lik, posterior, centre, preds, sigma) -> Setting:
    rec, proj, model = lik.model.recording, lik.projection, lik.model
    f_model = modes_in_band(model, posterior, centre[None], proj.max_frequency)
    bands = mode_bands(f_model, proj)
    strength = np.median([mode_amplitudes(y, proj, bands, 0 * sigma) for y in preds], axis=0)
    if rec.excitation.kind == "force":
        t_ref = float(np.sum(np.arange(rec.n_samples) * np.abs(model.force)) / np.sum(np.abs(model.force)) / rec.fs)
    else:
        t_ref = 0.0 if rec.excitation.kind == "release" else None
    reference = lik.predict(*posterior.split(centre))
    channel = np.argmax(strength - np.log(sigma), axis=1)
    return Setting(proj, rec.dt, f_model, bands, channel, sigma, decay_start(rec, proj), t_ref, reference,
                   tuple(_analytic(reference[proj.i0 : proj.i1], bands, channel, proj.fs)))


def _scaled(noise: dict, kappa: np.ndarray, channels) -> dict:
    """Noise parameters with each channel's sd brought to the floor."""
    out = dict(noise)
    for c, k in zip(channels, kappa):
        out[f"sigma_{c}"] = noise[f"sigma_{c}"] * np.sqrt(k)
    return out


# ---------------------------------------------------------------------------- (a) spectrogram
def _cells(x: np.ndarray, proj) -> tuple[np.ndarray, np.ndarray]:
    """Sum of x (D, c) over each (block, bin) cell: (n_blocks, n_bins, c), and coordinates per cell."""
    nb, k = proj.n_blocks, proj.n_bins
    per_block = x.reshape(nb, 2 * k - 1, -1)
    sums = per_block[:, :k].copy()
    sums[:, 1:] += per_block[:, k:]
    dof = np.full(k, 2.0)
    dof[0] = 1.0
    return sums, dof


def _spectrogram(u: np.ndarray, proj, time) -> tuple[Spectrogram, np.ndarray]:
    """Cells, the noise floor kappa (c,) by the fixed point of the module docstring, and the tests."""
    sums, dof = _cells(u, proj)
    d = dof[None, :, None] * np.ones_like(sums)
    kappa = np.median(u, axis=0) / stats.chi2.median(1)
    flagged = np.zeros(sums.shape, bool)
    for _ in range(FLOOR_ITERATIONS):
        n_kept = np.sum(np.where(flagged, 0.0, d), axis=(0, 1))
        p = stats.f.sf(sums / d / kappa, d, n_kept)
        new = holm(p, ALPHA / 3)
        kappa = np.sum(np.where(new, 0.0, sums), axis=(0, 1)) / np.sum(np.where(new, 0.0, d), axis=(0, 1))
        if np.array_equal(new, flagged):
            break
        flagged = new
    freq = np.arange(proj.n_bins) * proj.fs / proj.block
    spec = Spectrogram(freq, proj.block_times(time), proj.block / proj.fs, sums / d / kappa, dof, p, flagged)
    return spec, kappa


def holm(p: np.ndarray, alpha: float) -> np.ndarray:
    """Holm's step-down rejections at family-wise level alpha, same shape as p."""
    flat = p.ravel()
    order = np.argsort(flat)
    m = flat.size
    passed = flat[order] <= alpha / (m - np.arange(m))
    n_reject = m if passed.all() else int(np.argmin(passed))
    out = np.zeros(m, bool)
    out[order[:n_reject]] = True
    return out.reshape(p.shape)


# ---------------------------------------------------------------------------- (b) per mode
def mode_bands(f_model, proj) -> list[tuple[float, float]]:
    """Each mode's band (Hz), :func:`~bayesbeam.checks.envelope.band_edges` cut at the fitted band."""
    return [(lo, min(hi, proj.max_frequency)) for lo, hi in band_edges(f_model)]


def mode_amplitudes(y: np.ndarray, proj, bands, sigma: np.ndarray) -> np.ndarray:
    """ln A (m, c): noise-corrected band amplitude of each mode in y (n_samples, c), see docstring."""
    z = proj.project(y)
    out = []
    for lo, hi in bands:
        inside = (proj.frequencies >= lo) & (proj.frequencies < hi)
        noise = inside.sum() * sigma**2
        power = np.sum(z[inside] ** 2, axis=0)
        out.append(0.5 * np.log(np.maximum(power - noise, np.maximum(0.01 * noise, 1e-300))))
    return np.array(out)


def statistics(y: np.ndarray, s: Setting, noisy: bool = True) -> dict:
    """Per-mode statistics of a recording's signals y (n, c): ln frequency and damping ratio (ERA),
    ln amplitude (m, c), envelope decay rates at start and end (m, 2) and their difference
    (curvature), phase against the reference at the excitation time (rad).

    ``noisy``: y carries noise at the floor (the amplitudes subtract its power); False for a
    noise-free simulation.
    """
    era = era_modes(y, s.dt, s.start_index, s.projection.i1, s.f_model)
    rates = decay_rates(y, s)
    with np.errstate(invalid="ignore", divide="ignore"):
        ln_f = np.log(era[:, 0])
    sigma = s.sigma if noisy else 0 * s.sigma
    return {"frequency": ln_f, "damping": era[:, 1], "amplitude": mode_amplitudes(y, s.projection, s.bands, sigma),
            "rates": rates, "curvature": rates[:, 0] - rates[:, 1], "phase": mode_phases(y, s)}


def decay_rates(y: np.ndarray, s: Setting) -> np.ndarray:
    """(m, 2): envelope decay rate (1/s) at the start and end of the decay, mode m on its sensor."""
    proj = s.projection
    seg = y[proj.i0 : proj.i1]
    start = (s.start_index - proj.i0) / proj.fs
    out = np.full((len(s.f_model), 2), np.nan)
    for c in np.unique(s.channel):
        est = mode_estimates(seg[:, c], proj.fs, s.f_model, start=start, noise_sd=float(s.sigma[c]))
        rows = s.channel == c
        out[rows] = np.column_stack([est.decay_start, est.decay_end])[rows]
    return out


def mode_phases(y: np.ndarray, s: Setting) -> np.ndarray:
    """(m,): phase (rad) of y against the reference at the excitation time, per mode (docstring (c))."""
    out = np.full(len(s.f_model), np.nan)
    if s.t_ref is None:
        return out
    proj = s.projection
    t = np.arange(proj.i0, proj.i1) / proj.fs - s.t_ref
    t_decay = s.start_index / proj.fs - s.t_ref
    analytic = _analytic(y[proj.i0 : proj.i1], s.bands, s.channel, proj.fs)
    for m, ((lo, hi), c, b, a) in enumerate(zip(s.bands, s.channel, s.reference_bands, analytic)):
        settle = SETTLE / (hi - lo)
        floor = PHASE_FLOOR * s.sigma[c] * np.sqrt(2 * (hi - lo) / proj.fs)
        keep = (t >= t_decay + settle) & (t <= t[-1] - settle) & (np.abs(b) > floor)
        if keep.sum() >= 16:
            phi = np.unwrap(np.angle(a[keep] * np.conj(b[keep])))
            out[m] = np.angle(np.exp(1j * _weighted_intercept(t[keep], phi, np.abs(b[keep]) ** 2)))
    return out


def _weighted_intercept(t: np.ndarray, y: np.ndarray, w: np.ndarray) -> float:
    """The value at t = 0 of the straight line fitted to (t, y) by least squares with weights w
    (minimising sum w (y - line)^2; centred sums, exact for any offset of t)."""
    total = w.sum()
    t_mean, y_mean = w @ t / total, w @ y / total
    dt = t - t_mean
    return float(y_mean - t_mean * (w @ (dt * (y - y_mean))) / (w @ (dt * dt)))


def _analytic(x: np.ndarray, bands, channel, fs: float) -> np.ndarray:
    """(m, n): analytic signal of channel ``channel[m]`` of x (n, channels) band-passed to
    ``bands[m]`` (Hz): the envelope estimator's filter applied forward and backward (gain |H|^2,
    zero phase), in the frequency domain with zero padding; one FFT per channel and one inverse
    FFT of all bands."""
    n = x.shape[0]
    spectra = np.fft.fft(x, 2 * n, axis=0)
    gains = np.array([_analytic_gain(float(lo), float(hi), float(fs), n) for lo, hi in bands]).reshape(len(bands), 2 * n)
    return np.fft.ifft(spectra[:, np.asarray(channel)].T * gains, axis=1)[:, :n]


@lru_cache(maxsize=64)
def _analytic_gain(lo: float, hi: float, fs: float, n: int) -> np.ndarray:
    """2 |H(f)|^2 at positive frequencies of a 2n-point FFT, |H(0)|^2 at 0, and 0 at negative ones."""
    f = np.fft.fftfreq(2 * n, 1 / fs)
    _, h = signal.sosfreqz(band_pass(lo, hi, fs), worN=np.abs(f), fs=fs)
    return np.where(f > 0, 2.0, np.where(f == 0, 1.0, 0.0)) * np.abs(h) ** 2


def _errors(observed: np.ndarray, replicated: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(error, sd, median replicate): observed minus the replicates' median, and the error's sd,
    the replicates' sd times sqrt(1 + pi/(2S)) for the median's own scatter (NaN where fewer than
    two replicates have a value)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        med = np.nanmedian(replicated, axis=0)
        n = np.sum(np.isfinite(replicated), axis=0)
        sd = np.nanstd(replicated, axis=0, ddof=1) * np.sqrt(1 + np.pi / (2 * np.maximum(n, 1)))
    return observed - med, sd, med


def _mode_rows(lik, params, s: Setting, obs, err, n_rep) -> list[dict]:
    """Per-mode rows: Bonferroni over all the per-mode tests at ALPHA / 3."""
    m = len(s.f_model)
    model_f = lik.model.natural_frequencies(params)[:m]
    model_zeta = lik.model.modal_damping_ratios(params)[:m]
    labels = lik.model.mode_labels(params)
    level = ALPHA / 3 / (len(MODE_STATISTICS) * max(m, 1))
    stats_ = {k: err[k] for k in MODE_STATISTICS}
    return [_mode_row(i, labels[i], stats_, obs, s.channel[i], lik.channels, level, n_rep, model_f[i],
                      model_zeta[i], err["rates"][2][i]) for i in range(m)]


def _mode_row(m, label, err, obs, ch, channels, level, n_rep, model_f, model_zeta, rates_rep) -> dict:
    """One row of the per-mode table, with its flags and plain-language note. ``mode`` counts the
    model's modes (the features' index); ``label`` names it, the beam's numbered without an
    effect's own (:meth:`bayesbeam.model.BeamModel.mode_labels`)."""
    pick = {k: tuple(v[m, ch] if k == "amplitude" else v[m] for v in err[k]) for k in err}
    p = {k: _t_p_value(e, sd, n_rep) for k, (e, sd, _) in pick.items()}
    flags = [k for k in MODE_STATISTICS if p[k] is not None and p[k] < level]
    zeta_rep = pick["damping"][2]
    row = {"mode": m + 1, "label": label, "sensor": channels[ch], "model_frequency_hz": float(model_f),
           "measured_frequency_hz": _num(np.exp(obs["frequency"][m])),
           "replicated_frequency_hz": _num(np.exp(pick["frequency"][2])),
           "frequency_error_pct": _num(100 * np.expm1(pick["frequency"][0])),
           "frequency_error_sd_pct": _num(100 * pick["frequency"][1]),
           "model_damping_ratio": float(model_zeta), "measured_damping_ratio": _num(obs["damping"][m]),
           "replicated_damping_ratio": _num(zeta_rep),
           "damping_error_pct": _num(100 * pick["damping"][0] / zeta_rep),
           "damping_error_sd_pct": _num(100 * pick["damping"][1] / zeta_rep),
           "amplitude_error_pct": _num(100 * np.expm1(pick["amplitude"][0])),
           "amplitude_error_sd_pct": _num(100 * pick["amplitude"][1]),
           "phase_error_rad": _num(pick["phase"][0]), "phase_error_sd_rad": _num(pick["phase"][1]),
           "decay_rate_per_s": {"measured": [_num(v) for v in obs["rates"][m]],
                                "replicated": [_num(v) for v in rates_rep]},
           "curvature_error_per_s": _num(pick["curvature"][0]), "curvature_error_sd_per_s": _num(pick["curvature"][1]),
           "decay": _decay_shape(pick["curvature"][0], "curvature" in flags),
           "p_values": p, "flags": flags}
    row["note"] = _mode_note(row)
    return row


def _t_p_value(error, sd, n_rep):
    if not (np.isfinite(error) and np.isfinite(sd) and sd > 0):
        return None
    return float(2 * stats.t.sf(abs(error) / sd, n_rep - 1))


def _decay_shape(curvature_error, flagged) -> str:
    if not np.isfinite(curvature_error):
        return "not judged: too few cycles above the noise after the impact"
    if not flagged:
        return "exponential, like the model's"
    if curvature_error > 0:
        return "amplitude-dependent: damping falls as the vibration decays"
    return "amplitude-dependent: damping rises as the vibration decays"


def _mode_note(row) -> str:
    """The flagged findings of one mode in words, e.g. 'mode 1 is 2.1% low (3.61 Hz measured, ...)'."""
    m, flags, parts = mode_label(row), row["flags"], []
    if "frequency" in flags:
        e = row["frequency_error_pct"]
        parts.append(f"{m} is {abs(e):.2g}% {'low' if e < 0 else 'high'} ({row['measured_frequency_hz']:.5g} Hz "
                     f"measured, {row['replicated_frequency_hz']:.5g} Hz in the model's replicates)")
    if "damping" in flags:
        e = row["damping_error_pct"]
        parts.append(f"its damping ratio is {abs(e):.2g}% {'lower' if e < 0 else 'higher'} than the model's "
                     f"({row['measured_damping_ratio']:.3g} vs {row['replicated_damping_ratio']:.3g})")
    if "amplitude" in flags:
        e = row["amplitude_error_pct"]
        parts.append(f"its amplitude at {row['sensor']} is {abs(e):.2g}% {'lower' if e < 0 else 'higher'} "
                     f"than the model's")
    if "curvature" in flags:
        meas, rep = row["decay_rate_per_s"]["measured"], row["decay_rate_per_s"]["replicated"]
        parts.append(f"its {row['decay'].split(': ')[1]} (decay rate {meas[0]:.3g} 1/s at the start, "
                     f"{meas[1]:.3g} 1/s at the end; the model's replicates give {rep[0]:.3g} and {rep[1]:.3g})")
    if "phase" in flags:
        e = row["phase_error_rad"]
        parts.append(f"at the excitation its phase {'lags' if e < 0 else 'leads'} the model's by {abs(e):.2g} rad")
    if not parts:
        return (f"{m} ({row['model_frequency_hz']:.4g} Hz): frequency, damping, amplitude, decay shape and "
                f"phase each within the model's replicates")
    text = "; ".join(parts)
    return text if "frequency" in flags else f"{m}: {text}"


def mode_label(row) -> str:
    """A per-mode row's name ('mode 2', "the attached body's own mode"); a row without a label
    (a diagnosis.json that does not store one) is named by its index."""
    return row.get("label") or f"mode {row['mode']}"


def feature_names(n_modes: int, channels) -> list[str]:
    """Names of the feature vector (see :class:`Features`)."""
    names = []
    for m in range(1, n_modes + 1):
        names += [f"ln_f{m}", f"zeta{m}", *(f"ln_A{m}_{c}" for c in channels), f"curvature{m}", f"phase{m}"]
    return names


def feature_vector(stats_: dict) -> np.ndarray:
    """Per-mode statistics (keys of :data:`MODE_STATISTICS`) as one vector, in :func:`feature_names` order."""
    n = len(stats_["frequency"])
    return np.concatenate([np.concatenate([np.atleast_1d(stats_[k][m]) for k in MODE_STATISTICS])
                           for m in range(n)]).astype(float)


def _features(err, rep, channels) -> Features:
    median = feature_vector({k: err[k][2] for k in MODE_STATISTICS})
    return Features(feature_names(len(err["frequency"][0]), channels),
                    feature_vector({k: err[k][0] for k in MODE_STATISTICS}),
                    feature_vector({k: err[k][1] for k in MODE_STATISTICS}),
                    np.array([feature_vector(r) - median for r in rep]))


# ---------------------------------------------------------------------------- (c) phase
def complex_bins(z: np.ndarray, proj) -> np.ndarray:
    """Complex DFT bins (n_blocks, n_bins, c) from band coordinates (D, c)."""
    k = proj.n_bins
    per_block = z.reshape(proj.n_blocks, 2 * k - 1, z.shape[-1])
    out = per_block[:, :k].astype(complex)
    out[:, 1:] += 1j * per_block[:, k:]
    return out


def phase_spectrum(z_data: np.ndarray, z_ref: np.ndarray, proj, sigma: np.ndarray) -> dict:
    """Phase (rad) of the cross-spectrum of data and reference per bin and sensor, and its sd;
    NaN where the coherent signal-to-noise is below :data:`PHASE_MIN_SNR`."""
    zd, zr = complex_bins(z_data, proj), complex_bins(z_ref, proj)
    w = np.sum(np.abs(zr) ** 2, axis=0) / sigma**2
    keep = w >= PHASE_MIN_SNR
    return {"frequency_hz": np.arange(proj.n_bins) * proj.fs / proj.block,
            "phase_rad": np.where(keep, np.angle(np.sum(zd * np.conj(zr), axis=0)), np.nan),
            "phase_sd_rad": np.where(keep, 1 / np.sqrt(np.maximum(w, 1e-300)), np.nan)}


def delay_fit(error: np.ndarray, sd: np.ndarray, f_model) -> dict:
    """Delay (s) of the data behind the model from the per-mode phase errors (docstring (c))."""
    ok = np.isfinite(error) & np.isfinite(sd) & (sd > 0)
    out = {"mode_frequency_hz": np.asarray(f_model), "n_modes": int(ok.sum())}
    if not ok.any():
        return {**out, "delay_s": None, "delay_sd_s": None, "linear_p_value": None, "significant": False}
    e, w, omega = error[ok], 1 / sd[ok] ** 2, 2 * np.pi * np.asarray(f_model)[ok]
    grid = np.arange(-MAX_DELAY, MAX_DELAY, 0.05 / omega.max())
    tau0 = grid[np.argmax(np.cos(e[None] + np.outer(grid, omega)) @ w)]
    r = np.angle(np.exp(1j * (e + omega * tau0)))
    tau = tau0 - np.sum(w * omega * r) / np.sum(w * omega**2)
    chi2 = float(np.sum(w * np.angle(np.exp(1j * (e + omega * tau))) ** 2))
    n = int(ok.sum())
    spread = max(1.0, np.sqrt(chi2 / (n - 1))) if n > 1 else 1.0
    tau_sd = spread / np.sqrt(np.sum(w * omega**2))
    return {**out, "delay_s": float(tau), "delay_sd_s": float(tau_sd),
            "linear_p_value": float(stats.chi2.sf(chi2, n - 1)) if n > 1 else None,
            "significant": bool(2 * stats.norm.sf(abs(tau) / tau_sd) < ALPHA / 3)}


def latent_force(lik, params: dict, noise: dict) -> dict:
    """Does the measured force drive the response as the model has it? (docstring (c), the latent
    force). Empty for a likelihood without force-noise latent terms."""
    if getattr(lik, "force_noise", None) is None or lik.free_decay:
        return {}
    _, _, z, psi, s2 = lik._latent(params)
    coef = _marginal(z, psi, s2, lik.variance(noise))[1]
    k = lik.force_noise.size                # the force's latent terms come first (then any effect's)
    psi, coef, s2 = psi[..., :k], coef[:k], s2[:k]
    chi2 = float(np.sum(coef**2 / s2))
    # the force's slope at the kept recorded samples, which lie between a decimated record's
    slope = np.gradient(lik.model.force, lik.model.recording.dt)
    slope = np.interp(lik.force_noise.position, np.arange(slope.size), slope)
    force = lik.force_noise.recorded(coef)
    z_ref = lik.projection.project(lik.predict(params, noise))
    # the share of the prediction the latent force carries beyond what its noise would (the
    # excess fraction of chi2): noise alone carries a few percent, none of it in excess
    carried = np.sqrt(np.sum((psi @ coef) ** 2, axis=0) / np.maximum(np.sum(z_ref**2, axis=0), 1e-300))
    carried *= np.sqrt(max(1.0 - coef.size / chi2, 0.0)) if chi2 > 0 else 0.0
    return {"chi2": chi2, "dof": int(coef.size), "p_value": float(stats.chi2.sf(chi2, coef.size)),
            "significant": bool(stats.chi2.sf(chi2, coef.size) < ALPHA / 3),
            "delay_s": float(-np.dot(force, slope) / np.dot(slope, slope)) if np.any(slope) else None,
            "share": float(np.max(carried))}


# ---------------------------------------------------------------------------- (d) regions
def _all_regions(mis: Mismatch, lik, params) -> list[dict]:
    """Flagged cells, then modes with a flagged statistic no cell covers, then the delay."""
    rec, proj = lik.model.recording, lik.projection
    cells = _regions(mis.spectrogram, lik, mis.modes, mis.setting, params)
    regions = cells + _mode_regions(mis.modes, rec, proj, cells) + _delay_region(mis.phase, rec, proj)
    energy = _cell_energies(lik, mis.setting)
    for r in regions:
        r["misfit_share"] = misfit_share(r, energy, mis.spectrogram, lik.channels)
    regions += _force_region(mis.phase, rec, proj)
    for r in regions:
        r["practically_significant"] = r["misfit_share"] >= PRACTICAL_SHARE
    return regions


def _cell_energies(lik, s: Setting) -> tuple[np.ndarray, np.ndarray]:
    """Per cell (n_blocks, n_bins, c): residual energy at the posterior median above the noise
    floor, and the energy the recording holds (prediction plus noise), docstring (e)."""
    z_ref = s.projection.project(s.reference)
    residual, dof = _cells((lik.z_data - z_ref) ** 2, s.projection)
    prediction = _cells(z_ref**2, s.projection)[0]
    noise = dof[None, :, None] * s.sigma[None, None, :] ** 2
    return residual - noise, prediction + noise


def misfit_share(region: dict, energy: tuple, spec: Spectrogram, channels) -> float:
    """Amplitude share of the recording, inside the region's rectangle, that its misfit carries."""
    excess, held = energy
    t, f = spec.block_times_s, spec.frequencies_hz
    half_bin = (f[1] - f[0]) / 2 if f.size > 1 else 0.0
    blocks = (t + spec.block_duration_s > region["time_s"][0]) & (t < region["time_s"][1])
    bins = (f + half_bin > region["band_hz"][0]) & (f - half_bin < region["band_hz"][1])
    sensors = range(len(channels)) if region["sensor"] == "all" else [list(channels).index(region["sensor"])]
    cells = [np.ix_(blocks, bins, [c]) for c in sensors]
    return float(max(np.sqrt(max(float(excess[i].sum()), 0.0) / float(held[i].sum())) for i in cells))


def share_words(share: float) -> str:
    """A region's ``misfit_share`` in words. The share is unbounded: the misfit is measured against
    the signal the fitted model and its noise put in the region, and where the model puts little
    (a line or a mode it lacks) the misfit exceeds it; so a share of 1 or more reads as a multiple
    ('the misfit is 3.6 x the signal the model puts there'), never as a percentage over 100."""
    percent = 100 * share
    if round(percent) >= 100:
        return f"the misfit is {share:.2g} x the signal the model puts there"
    return f"the misfit is {percent:{'.2g' if percent < 10 else '.0f'}} % of the signal the model puts there"


def _regions(spec: Spectrogram, lik, modes, s: Setting, params) -> list[dict]:
    """Connected flagged cells of each sensor, with the note of the mode they cover or of the line."""
    out = []
    df = spec.frequencies_hz[1] - spec.frequencies_hz[0]
    for c, name in enumerate(lik.channels):
        labels, n = ndimage.label(spec.significant[:, :, c], structure=np.ones((3, 3)))
        for i in range(1, n + 1):
            blocks, bins = np.nonzero(labels == i)
            power = spec.power[blocks, bins, c]
            peak = float(spec.frequencies_hz[bins[np.argmax(power)]])
            band = [float(max(0.0, spec.frequencies_hz[bins.min()] - df / 2)),
                    float(spec.frequencies_hz[bins.max()] + df / 2)]
            time = [float(spec.block_times_s[blocks.min()]),
                    float(spec.block_times_s[blocks.max()] + spec.block_duration_s)]
            mode = _mode_at(peak, band, modes, df)
            note = modes[mode]["note"] if mode is not None else _line_note(peak, c, lik, s, params)
            out.append({"band_hz": band, "time_s": time, "sensor": name, "note": note, "peak_hz": peak,
                        "peak_standardized_power": float(power.max()), "mode": None if mode is None else mode + 1,
                        "beam_physics": "not beam physics" not in note})
    return out


def _mode_at(peak, band, modes, df):
    """Index of the mode whose model or measured frequency lies in or next to the band, or None."""
    best, dist = None, np.inf
    for i, row in enumerate(modes):
        for f in (row["model_frequency_hz"], row["measured_frequency_hz"]):
            if f is None:
                continue
            tol = max(MODE_TOLERANCE * f, 2 * df)
            if band[0] - tol <= f <= band[1] + tol and abs(f - peak) < dist:
                best, dist = i, abs(f - peak)
    return best


def _line_note(f_line, c, lik, s: Setting, params) -> str:
    """Does a residual line away from the modes decay with the beam? See the module docstring."""
    proj = s.projection
    ratio = line_persistence(lik.model.recording.signals[:, c] - s.reference[:, c], proj, f_line)
    f = lik.model.natural_frequencies(params)
    near = int(np.argmin(np.abs(f - f_line)))
    if abs(f[near] - f_line) <= max(MODE_TOLERANCE * f[near], 2 * proj.fs / proj.block):
        # a mode above 0.9 of the band's top is fitted but has no per-mode statistics
        label = lik.model.mode_labels(params)[near]
        return (f"residual at {f_line:.4g} Hz, at the model's {label} ({f[near]:.4g} Hz) near the top of the "
                f"band, where the per-mode statistics are not computed: that mode's misfit")
    zeta = np.interp(f_line, f, lik.model.modal_damping_ratios(params))
    beam = float(np.exp(-2 * np.pi * f_line * zeta * 2 / 3 * (proj.i1 - proj.i0) / proj.fs))
    text = f"residual line at {f_line:.4g} Hz, away from every model mode"
    harmonic = mains_harmonic(f_line, proj.fs / proj.block)
    if ratio >= PERSISTENT and beam < PERSISTENT:
        cause = f" (at {harmonic[0]} x {harmonic[1]:g} Hz: mains pickup)" if harmonic else ""
        return (f"{text}; its amplitude keeps {ratio:.0%} from the first to the last third of the window where "
                f"the beam would keep {beam:.0%}: it does not decay with the beam, not beam physics{cause}")
    if ratio >= PERSISTENT:
        return (f"{text}; it does not decay ({ratio:.0%} kept), but neither would the beam ({beam:.0%}) in "
                f"this window: cannot tell from its decay whether it is beam physics")
    return f"{text}; it decays ({ratio:.0%} kept over the window): physics the model lacks (a mode it does not have?)"


def mains_harmonic(f: float, tolerance: float) -> tuple[int, float] | None:
    """(k, mains frequency) when ``f`` lies within ``tolerance`` (Hz) of k x 50 or k x 60 Hz, else None."""
    for m in MAINS:
        k = round(f / m)
        if k >= 1 and abs(f - k * m) <= tolerance:
            return k, m
    return None


def _mode_regions(modes, rec, proj, regions) -> list[dict]:
    """A region for each mode with a flagged statistic that no flagged cell already covers."""
    covered = {r["mode"] for r in regions}
    window = [float(rec.time[proj.i0]), float(rec.time[proj.i1 - 1])]
    bands = mode_bands([r["model_frequency_hz"] for r in modes], proj)
    return [{"band_hz": [float(lo), float(hi)], "time_s": window, "sensor": row["sensor"], "note": row["note"],
             "peak_hz": row["model_frequency_hz"], "peak_standardized_power": None, "mode": row["mode"],
             "beam_physics": True}
            for row, (lo, hi) in zip(modes, bands) if row["flags"] and row["mode"] not in covered]


def _delay_region(phase, rec, proj) -> list[dict]:
    if not phase["significant"]:
        return []
    linear = phase["linear_p_value"] is None or phase["linear_p_value"] >= ALPHA / 3
    shape = "linear in frequency, as a pure delay" if linear else \
        "not linear in frequency: more than a delay"
    note = (f"the measured response lags the model by {phase['delay_s'] * 1e3:.3g} +- "
            f"{phase['delay_sd_s'] * 1e3:.2g} ms at the excitation; phase error {shape}")
    f = phase["mode_frequency_hz"]
    return [{"band_hz": [float(f.min()), float(f.max())],
             "time_s": [float(rec.time[proj.i0]), float(rec.time[proj.i1 - 1])], "sensor": "all", "note": note,
             "peak_hz": None, "peak_standardized_power": None, "mode": None, "beam_physics": True}]


def _force_region(phase, rec, proj) -> list[dict]:
    """A region when the latent force carries more than the force channel's noise allows; its
    misfit share is the share of the prediction that latent force carries (docstring (e))."""
    force = phase.get("force") or {}
    if not force.get("significant"):
        return []
    shift = "" if force["delay_s"] is None else \
        f"; read as a shift of the measured force, the response lags it by {force['delay_s'] * 1e3:.3g} ms"
    f = phase["mode_frequency_hz"]
    note = (f"the force-noise latent terms carry {force['chi2'] / force['dof']:.3g} x the variance the force "
            f"channel's measured noise allows (chi2 {force['chi2']:.4g} on {force['dof']} samples): the response "
            f"is not driven by the measured force as modelled{shift}")
    return [{"band_hz": [float(f.min()), float(f.max())] if f.size else [0.0, float(proj.max_frequency)],
             "time_s": [float(rec.time[proj.i0]), float(rec.time[proj.i1 - 1])], "sensor": "all", "note": note,
             "peak_hz": None, "peak_standardized_power": None, "mode": None, "beam_physics": True,
             "misfit_share": force["share"]}]


# ---------------------------------------------------------------------------- notes
def _summary_notes(mis: Mismatch) -> list[str]:
    n_cells = int(mis.spectrogram.significant.sum())
    notes = [(f"RMS standardized residual {mis.rms_standardized_residual:.3g} (1 where the model explains the "
              f"recording down to its noise floor)")]
    for c, v in mis.noise.items():
        if v["inflation"] > 1.2:
            notes.append(f"{c}: the fitted noise sd is {v['inflation']:.2g} x the noise floor; the model's noise "
                         f"absorbed part of the mismatch")
    if not mis.regions:
        notes.append(f"nothing stands above the noise (family-wise false-alarm level {ALPHA:g})")
    else:
        notes.append(f"{n_cells} time-frequency cells stand above the noise; {len(mis.regions)} mismatch "
                     f"region(s)")
    notes += [f"{r['sensor']}, {r['band_hz'][0]:.4g}-{r['band_hz'][1]:.4g} Hz: {r['note']}" for r in mis.regions]
    return notes


def _num(x):
    return float(x) if np.isfinite(x) else None
