r"""Posterior predictive checks: does the recording look like the model's own replicates?

For posterior draws :math:`\theta_s` a replicated recording is the model's prediction plus a
fresh draw of its noise, :math:`y^{rep}_s = \hat y(\theta_s) + e_s`. A discrepancy statistic
:math:`T` is computed on the measured and on each replicated recording, and the posterior
predictive p-value is :math:`p = \Pr(T(y^{rep}) \ge T(y))` over the draws (Gelman, Meng & Stern
1996). Values near 0 (or, for two-sided statistics, near 0 or 1) say the data are unlike the
model's replicates. Statistics chosen to expose a wrong damping mechanism:

* ``zeta_mode<m>``, ``frequency_mode<m>``: damping ratio and frequency of mode m, identified by
  ERA (:mod:`bayesbeam.modal.era`) on the free decay after the impact (or release), measured vs
  replicated. Two-sided: :math:`p = 2 \min(p_+, 1 - p_+)`. A wrong mechanism gets the damping of
  some modes wrong (air damping dominates low modes, internal damping high ones).
* ``residual_spectrum``: the largest, over 16 equal frequency bands of the fitted band, of the
  residual power :math:`|y - \hat y(\theta_s)|^2` over the noise variance; replicated with
  :math:`y^{rep}_s`. Large when the residual stands above the noise somewhere in frequency.
* ``ljung_box``: Ljung-Box :math:`Q = n(n+2)\sum_{k=1}^{h} \hat\rho_k^2/(n-k)` (h = 20) of the
  band-limited residual in time; large when the residual is autocorrelated (structure left in
  it). Its reference distribution is the replicates', not chi-square: band-limiting alone makes
  residuals autocorrelated, and that is the same for both.

The per-mode table compares the measured damping ratio and frequency with each model's
predictive 90 % interval: the paper's argument made visible.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from bayesbeam.modal.era import era, hankel_svd
from bayesbeam.response.signals import impact_window

#: replicated recordings per model
N_REPLICATES = 100
#: a statistic whose predictive p-value falls below this fails its check (a model passes when every
#: p-value is at least this); with ~6 statistics per model the chance that the true model fails one
#: by chance stays near 6 %
PASS_P_VALUE = 0.01
#: Ljung-Box lags
LJUNG_BOX_LAGS = 20
#: frequency bands of the residual-spectrum statistic
SPECTRUM_BANDS = 16
#: a mode is matched to an ERA pole within this relative frequency distance
MATCH_TOLERANCE = 0.05


@dataclass
class PredictiveCheck:
    """Observed and replicated statistics, p-values, and the figures' data for one model."""

    statistics: dict                       # name -> {"observed", "replicated" (array), "p_value"}
    modes: dict                            # {"frequency_hz": (m,), "observed_zeta", "observed_f", "rep_zeta" (S, m), "rep_f"}
    band: dict = field(default_factory=dict)   # time-history quantiles and residual spectrum

    def p_values(self) -> dict:
        return {k: {"p_value": v["p_value"], "observed": v["observed"]} for k, v in self.statistics.items()}


def posterior_predictive_check(posterior, draws: np.ndarray, rng: np.random.Generator,
                               n_replicates: int = N_REPLICATES, truncated_era: bool = True) -> PredictiveCheck:
    """Run the checks of the module docstring for draws (n, ndim) in sampling coordinates.

    ``truncated_era``: passed to :func:`era_modes` (False: the full-SVD reference)."""
    lik = posterior.likelihood
    model, proj = lik.model, lik.projection
    rec = model.recording
    picks = draws[rng.choice(len(draws), size=n_replicates, replace=len(draws) < n_replicates)]
    start_index = decay_start(rec, proj)
    f_model = modes_in_band(model, posterior, draws, proj.max_frequency)
    observed = rec.signals
    stats = {"residual_spectrum": ([], []), "ljung_box": ([], [])}
    rep_modes, predictions = [], []
    for theta in picks:
        params, noise = posterior.split(theta)
        clean = lik.predict(params, noise)
        replicate = clean + lik.draw_noise(noise, clean.shape, rng)
        sigma = np.array([noise[f"sigma_{c}"] for c in lik.channels])
        for name, fn in (("residual_spectrum", _spectrum_statistic), ("ljung_box", _ljung_box)):
            stats[name][0].append(fn(observed - clean, proj, sigma))
            stats[name][1].append(fn(replicate - clean, proj, sigma))
        rep_modes.append(era_modes(replicate, rec.dt, start_index, proj.i1, f_model, truncated_era))
        predictions.append(clean)
    obs_modes = era_modes(observed, rec.dt, start_index, proj.i1, f_model, truncated_era)
    out = {name: _p_value(np.array(obs), np.array(rep), two_sided=False)
           for name, (obs, rep) in stats.items()}
    rep_modes = np.array(rep_modes)                                  # (S, m, 2)
    for m in range(len(f_model)):
        for k, label in ((1, "zeta"), (0, "frequency")):
            out[f"{label}_mode{m + 1}"] = _p_value(np.full(len(picks), obs_modes[m, k]), rep_modes[:, m, k],
                                                 two_sided=True)
    modes = {"frequency_hz": f_model, "observed_f": obs_modes[:, 0], "observed_zeta": obs_modes[:, 1],
             "rep_f": rep_modes[:, :, 0], "rep_zeta": rep_modes[:, :, 1]}
    return PredictiveCheck(out, modes, _band_data(np.array(predictions), observed, proj, rec))


def mode_table(check: PredictiveCheck) -> list[dict]:
    """Per mode: measured f and zeta against the model's predictive 90 % intervals."""
    rows = []
    m = check.modes
    for i, f in enumerate(m["frequency_hz"]):
        zeta, freq = m["rep_zeta"][:, i], m["rep_f"][:, i]
        ok_z, ok_f = np.isfinite(zeta), np.isfinite(freq)
        rows.append({"mode": i + 1, "model_frequency_hz": float(f),
                     "measured_frequency_hz": _finite(m["observed_f"][i]),
                     "measured_damping_ratio": _finite(m["observed_zeta"][i]),
                     "predicted_frequency_hz_90": _interval(freq[ok_f]),
                     "predicted_damping_ratio_90": _interval(zeta[ok_z])})
    return rows


# ---------------------------------------------------------------------------- statistics
def _p_value(observed, replicated, two_sided):
    ok = np.isfinite(observed) & np.isfinite(replicated)
    if not ok.any():
        return {"observed": None, "replicated": replicated, "p_value": None}
    p = float(np.mean(replicated[ok] >= observed[ok]))
    if two_sided:
        p = float(min(1.0, 2 * min(p, 1 - p)))
    return {"observed": float(np.median(observed[ok])), "replicated": replicated, "p_value": p}


def _spectrum_statistic(residual, proj, sigma) -> float:
    z = proj.project(residual) / sigma[None, :]
    edges = np.linspace(0, proj.max_frequency, SPECTRUM_BANDS + 1)
    band = np.clip(np.digitize(proj.frequencies, edges) - 1, 0, SPECTRUM_BANDS - 1)
    power = np.array([np.mean(z[band == b] ** 2) for b in range(SPECTRUM_BANDS) if np.any(band == b)])
    return float(power.max())


def _band_limited(x, proj):
    """x in the fitted window with everything above the fitted band removed (per channel)."""
    seg = x[proj.i0 : proj.i1]
    spec = np.fft.rfft(seg, axis=0)
    freq = np.fft.rfftfreq(len(seg), 1 / proj.fs)
    spec[freq > proj.max_frequency] = 0
    return np.fft.irfft(spec, len(seg), axis=0)


def _ljung_box(residual, proj, sigma) -> float:
    r = _band_limited(residual, proj)
    r = r - r.mean(axis=0)
    n = len(r)
    total = 0.0
    for c in range(r.shape[1]):
        denom = np.dot(r[:, c], r[:, c])
        for k in range(1, LJUNG_BOX_LAGS + 1):
            rho = np.dot(r[k:, c], r[:-k, c]) / denom
            total += rho * rho / (n - k)
    return float(n * (n + 2) * total)


# ---------------------------------------------------------------------------- modes
def decay_start(rec, proj) -> int:
    """First sample of the free decay: after the impact force window; the window's start for a
    release (the decay starts at t = 0) or a free decay."""
    if rec.excitation.kind != "force":
        return proj.i0
    # the model's force is already windowed; its last non-zero sample ends the impact
    window = impact_window(rec.force)
    return max(proj.i0, int(np.flatnonzero(window)[-1]) + 1)


def modes_in_band(model, posterior, draws, max_frequency) -> np.ndarray:
    params, _ = posterior.split(np.median(draws, axis=0))
    f = np.asarray(model.natural_frequencies(params))
    return f[f < 0.9 * max_frequency]


def era_modes(y, dt, i0, i1, f_model, truncated: bool = True) -> np.ndarray:
    """(m, 2): frequency (Hz) and damping ratio of the ERA pole nearest each model mode, or NaN.

    ERA runs at order 2 m + 8 and uses only that many leading singular triplets of the Hankel
    matrix; ``truncated`` computes just those (:func:`bayesbeam.modal.era.hankel_svd` with
    ``rank``, through the Gram matrix), ``False`` the full SVD, the reference benchmarks/ppc.py
    and tests/checks/test_ppc.py compare it with. The check calls this once per replicate, so the
    decomposition is most of its cost.
    """
    seg = np.asarray(y[i0:i1], float)
    seg = seg / np.maximum(seg.std(axis=0), np.finfo(float).tiny)
    out = np.full((len(f_model), 2), np.nan)
    order = 2 * len(f_model) + 8
    try:
        modes = era(hankel_svd(seg, rank=order if truncated else None), dt, order=order)
    except (np.linalg.LinAlgError, ValueError):
        return out
    for i, f in enumerate(f_model):
        if modes.frequencies_hz.size == 0:
            break
        j = int(np.argmin(np.abs(modes.frequencies_hz - f)))
        if abs(modes.frequencies_hz[j] - f) < MATCH_TOLERANCE * f:
            out[i] = modes.frequencies_hz[j], modes.damping_ratios[j]
    return out


# ---------------------------------------------------------------------------- figure data
def _band_data(predictions, observed, proj, rec) -> dict:
    """Predictive bands of the time history and residual spectra for the report."""
    window = slice(proj.i0, proj.i1)
    q05, q50, q95 = np.quantile(predictions[:, window], [0.05, 0.5, 0.95], axis=0)
    residual = _band_limited(observed - np.median(predictions, axis=0), proj)
    spec = np.abs(np.fft.rfft(residual * np.hanning(len(residual))[:, None], axis=0))
    freq = np.fft.rfftfreq(len(residual), rec.dt)
    keep = freq <= proj.max_frequency
    return {"time": rec.time[window], "observed": observed[window], "q05": q05, "q50": q50, "q95": q95,
            "residual_frequency_hz": freq[keep], "residual_amplitude": spec[keep]}


def _finite(x):
    return float(x) if np.isfinite(x) else None


def _interval(x):
    return [float(v) for v in np.quantile(x, [0.05, 0.95])] if len(x) else None
