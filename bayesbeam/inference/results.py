"""A fit's results in the ecosystem's formats: arviz InferenceData and a JSON summary.

InferenceData groups: ``posterior`` (physical values; one chain per emcee walker, after
burn-in and thinning), ``sample_stats`` (``lp``), ``log_likelihood`` (``y``: the per-block
pointwise terms of :class:`~bayesbeam.inference.likelihood.Likelihood`, in time order, for
PSIS-LOO/LFO), ``observed_data`` (the fitted recording's signals), ``posterior_predictive``
(replicated recordings for a random subset of draws: model plus noise, chain dimension 1).
"""
from __future__ import annotations

import warnings

import numpy as np

from bayesbeam.inference.sampler import effective_sample_size

#: posterior-predictive replicates stored with a fit
N_PREDICTIVE = 200
#: at most this many posterior draws get pointwise log-likelihood terms
MAX_POINTWISE_DRAWS = 1000


def build_inference_data(result, rng):
    """InferenceData (arviz) of a FitResult."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", FutureWarning)
        import arviz as az

    post = result.problem.posterior
    lik = result.problem.likelihood
    values = result.values()
    posterior = {n: values[..., i] for i, n in enumerate(post.names)}
    pointwise = _pointwise(post, result.chains.samples)
    rec = lik.model.recording
    replicates = predictive_replicates(result, rng, N_PREDICTIVE)
    sensors = [s.name for s in rec.sensors]
    coords = {"block": np.arange(lik.projection.n_blocks), "time": rec.time, "sensor": sensors}
    return with_units(az.from_dict(
        posterior=posterior,
        sample_stats={"lp": result.chains.log_prob},
        log_likelihood={"y": pointwise},
        observed_data={"signals": np.asarray(rec.signals)},
        posterior_predictive={"signals": replicates[None]},
        coords=coords,
        dims={"y": ["block"], "signals": ["time", "sensor"]},
    ), lik.model)


def with_units(idata, model):
    """``idata`` with ``units`` (SI) and ``description`` attributes on its posterior variables, the
    parameters of BeamModel ``model`` and its noise (so a table or plot of them can say what they are)."""
    descriptions = parameter_descriptions(model)
    for name, variable in idata.posterior.data_vars.items():
        variable.attrs["units"] = parameter_unit(name, model)
        variable.attrs["description"] = descriptions.get(name, "")
    return idata


def parameter_unit(name: str, model) -> str:
    """The SI unit of a parameter of ``model`` or of its noise."""
    units = model.units
    return units[name] if name in units else _noise_unit(name, model)


def parameter_descriptions(model) -> dict[str, str]:
    """A sentence per parameter of ``model``: the mechanism or effect it belongs to, or the noise."""
    out = {name: f"{part.name}: {part.description}" for part in (*model.mechanisms, *model.effects)
           for name in part.parameters}
    out["EI"] = "bending stiffness (the Euler-Bernoulli beam's EI)"
    for sensor in model.recording.sensors:
        out[f"sigma_{sensor.name}"] = f"white-noise sd of sensor {sensor.name} in the fitted band"
        out[f"phi_{sensor.name}"] = f"AR(1) coefficient of sensor {sensor.name}'s noise"
    return out


def _pointwise(post, samples):
    """Per-block log-likelihood for every stored draw: (walkers, draws, blocks); -inf if unusable."""
    n_walkers, n_draws, _ = samples.shape
    n_blocks = post.likelihood.projection.n_blocks
    out = np.full((n_walkers, n_draws, n_blocks), -np.inf)
    step = max(1, int(np.ceil(n_walkers * n_draws / MAX_POINTWISE_DRAWS)))
    flat = [(w, d) for w in range(n_walkers) for d in range(n_draws)]
    for w, d in flat[::step]:
        params, noise = post.split(samples[w, d])
        try:
            out[w, d] = post.likelihood.pointwise(params, noise)
        except (ValueError, np.linalg.LinAlgError):
            pass
    if step > 1:  # draws not evaluated: nearest evaluated draw of the same walker
        for w in range(n_walkers):
            done = np.isfinite(out[w, :, 0])
            if done.any():
                idx = np.flatnonzero(done)
                nearest = idx[np.abs(np.arange(n_draws)[:, None] - idx[None, :]).argmin(axis=1)]
                out[w] = out[w, nearest]
    return out


def predictive_replicates(result, rng, n: int) -> np.ndarray:
    """Replicated recordings (n, n_samples, n_sensors): the model at a random draw plus its noise.

    The noise is white with the draw's sd per channel (for AR(1), the AR(1) process).
    """
    post = result.problem.posterior
    flat = result.chains.samples.reshape(-1, post.ndim)
    picks = rng.choice(len(flat), size=min(n, len(flat)), replace=len(flat) < n)
    lik = post.likelihood
    out = []
    for theta in flat[picks]:
        params, noise = post.split(theta)
        clean = lik.predict(params, noise)
        out.append(clean + lik.draw_noise(noise, clean.shape, rng))
    return np.array(out)


def _stats(draws: np.ndarray, tau: float, n_walkers: int, n_steps: int, burn: int) -> dict:
    flat = draws.ravel()
    q05, q50, q95 = np.quantile(flat, [0.05, 0.5, 0.95])
    return {"mean": float(flat.mean()), "sd": float(flat.std(ddof=1)), "q05": float(q05), "q50": float(q50),
            "q95": float(q95), "ess": float(effective_sample_size(tau, n_walkers, n_steps, burn)) if tau > 0 else None,
            "tau": float(tau)}


def _force_noise_summary(lik) -> dict | None:
    """What the likelihood marginalised of the force channel's noise (None: nothing)."""
    noise = lik.force_noise
    if noise is None:
        return None
    return {"sd_N": noise.sd, "samples": noise.size,
            "note": "the response driven by the noise of the force samples inside the impact window "
                    "is marginalised (errors in variables); sd measured where the window is closed"}


def build_summary(result) -> dict:
    """The summary.json of a fit (SI units, the paper's parameter names)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        import arviz as az

        rhat = az.rhat(result.idata)
    post = result.problem.posterior
    model = result.problem.model
    chains = result.chains
    values = result.values()
    n_walkers = values.shape[0]
    stats = {}
    for i, name in enumerate(post.names):
        entry = _stats(values[..., i], chains.tau[i], n_walkers, chains.n_steps, chains.burn)
        entry["r_hat"] = float(rhat[name].values)
        entry["unit"] = parameter_unit(name, model)
        entry["prior"] = post.priors[i].describe()
        stats[name] = entry
    lik = result.problem.likelihood
    proj = lik.projection
    rec = result.recording
    return {
        "recording": str(rec.source) if rec.source else None,
        "model": result.model_spec,
        "mechanisms": [m.name for m in model.mechanisms],
        "effects": [e.name for e in model.effects],
        "parameters": {n: stats[n] for n in post.model_names},
        "noise": {"model": lik.noise, **{n: stats[n] for n in lik.noise_names},
                  "force_noise": _force_noise_summary(lik)},
        "converged": bool(chains.converged),
        "convergence": {"rule": f"chain > {result.config.tau_factor:g} tau and tau stable to 5%",
                        "reason": chains.reason, "n_steps": chains.n_steps, "n_walkers": n_walkers,
                        "burn": chains.burn, "thin": chains.thin, "seconds": round(chains.seconds, 2),
                        "r_hat_note": "rank-normalised split R-hat with each walker taken as a chain; "
                                      "emcee walkers are not independent, so it is a secondary check"},
        "tau": float(np.max(chains.tau)),
        "acceptance": chains.acceptance,
        "n_intervals": model.n_intervals,
        "discretisation_check": result.discretisation,
        "band": {"max_frequency_hz": proj.max_frequency, "fs_hz": rec.fs / result.problem.decimation,
                 "decimation": result.problem.decimation, "window_s": [float(model.recording.time[proj.i0]),
                 float(model.recording.time[proj.i0 + proj.n_blocks * proj.block - 1])],
                 "block_samples": proj.block, "n_blocks": proj.n_blocks},
        "optimum": {"log_posterior": float(result.optimum.log_posterior),
                    "values": post.values(result.optimum.theta),
                    "evaluations": result.optimum.n_evaluations},
    }


def _noise_unit(name: str, model) -> str:
    if name.startswith("phi_"):
        return "1"
    sensor = next(s for s in model.recording.sensors if f"sigma_{s.name}" == name)
    return {"acceleration": "m/s^2", "velocity": "m/s", "displacement": "m"}[sensor.quantity]
