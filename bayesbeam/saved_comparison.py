"""A comparison already run, read back from its folder (``bayesbeam compare --out DIR``), so that a
diagnosis reuses its fits instead of fitting its baseline models again.

comparison.json holds, per model, the log evidence and its SMC repeats, the optimum and the spline
grid N; ``posteriors/<model>.nc`` the repeats' final particles (physical values, one chain per
repeat) with their log likelihood and log prior. Each model's problem is prepared again at the
comparison's N with the diagnosis's fit settings. A folder is refused (``RecordingError`` naming
the file, the key and the fix) when it is not a comparison, when it was made from another recording
(:func:`~bayesbeam.comparison.fingerprint`), when its fit settings differ from the diagnosis's
(:func:`~bayesbeam.comparison.fit_settings`: the band, the window, the noise model, the splines, the
priors), or when it lacks a model the diagnosis needs.
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from bayesbeam.comparison import ModelResult, fingerprint, fit_settings, posterior_file_name, ranked, verdict
from bayesbeam.inference.evidence import Evidence, SMCRun
from bayesbeam.inference.fit import FitConfig, prepare
from bayesbeam.inference.sampler import Optimum
from bayesbeam.io import RecordingError

#: the option (of compare and diagnose) behind each key of comparison.json's "fit"
FIT_OPTIONS = {"max_frequency": "--max-frequency", "decimation": "--max-frequency",
               "window_samples": "--start/--stop", "block": "[fit] block of --config", "noise": "--noise",
               "degree": "--degree", "n_intervals": "--n-intervals", "force_window": "--no-force-window",
               "force_noise": "--no-force-noise", "effects": "[fit] effects of --config",
               "priors": "[prior.NAME] tables of --config"}
#: what every comparison.json a diagnosis can reuse has
REQUIRED = ("models", "ranking", "fingerprint", "fit")


class SavedComparison:
    """The comparison in ``folder``, checked against the recording ``rec`` and the fit settings
    ``fit`` of the diagnosis that reuses it."""

    def __init__(self, folder, rec, fit: FitConfig):
        self.folder = Path(folder)
        self.file = self.folder / "comparison.json"
        self.rec, self.fit = rec, fit
        self.document = _read(self.file)
        self._problems = {}
        _check_recording(self.file, self.document, rec)
        _check_fit(self.file, self.document["fit"], fit_settings(fit, self.problem(self.document["ranking"][0])))

    @property
    def models(self) -> list[str]:
        return list(self.document["models"])

    def problem(self, model: str):
        """``model``'s problem, prepared at the comparison's N."""
        if model not in self._problems:
            self._problems[model] = prepare(self.rec, model, self.fit, self.document["models"][model]["n_intervals"])
        return self._problems[model]

    def results(self, models) -> dict:
        """model -> :class:`~bayesbeam.comparison.ModelResult` of each of ``models``, as compare returned it
        (but the posterior predictive check and the screens' pointwise terms, which are not stored)."""
        missing = [m for m in models if m not in self.document["models"]]
        if missing:
            raise RecordingError(self.file, '"models"', f"has no {', '.join(missing)} (it holds {', '.join(self.models)}), "
                                 "which the diagnosis needs", f"compare them on this recording (bayesbeam compare "
                                 f"--models {','.join(models)}) and give that folder, or leave out --from-comparison")
        return {m: self._result(m) for m in models}

    def summary(self, models) -> dict:
        """comparison.json restricted to ``models``: their ranking, probabilities, log Bayes factors
        against the best and verdict among themselves (compare's summary of those models)."""
        entries = self.document["models"]
        ranking, prob = ranked({m: entries[m]["log_evidence"] for m in models})
        best = entries[ranking[0]]["log_evidence"]
        kept = {m: {**entries[m], "probability": float(p), "log_bayes_factor_vs_best": float(entries[m]["log_evidence"] - best)}
                for m, p in zip(ranking, prob)}
        return {**self.document, "best": ranking[0], "ranking": ranking, "models": kept,
                "verdict": verdict(ranking, kept)}

    def _result(self, model: str) -> ModelResult:
        entry, problem = self.document["models"][model], self.problem(model)
        o = entry["optimum"]
        optimum = Optimum(np.array(o["theta"]), o["log_posterior"], np.array(o["covariance"]), o["n_evaluations"])
        evidence = Evidence(entry["log_evidence"], entry["log_evidence_sd"],
                            self._runs(model, entry["evidence"], problem.posterior))
        return ModelResult(model, problem, optimum, entry["discretisation_check"], evidence, check=None,
                           screens=entry["screens"], pointwise=None, stopped=entry["evidence"].get("stopped_early"))

    def _runs(self, model: str, evidence: dict, posterior) -> list[SMCRun]:
        """The SMC repeats of ``model`` from its NetCDF file: particles back in sampling coordinates.
        Their tempering ladders, acceptances, evaluations and times are not stored (NaN, 0)."""
        import warnings

        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            import arviz as az
        path = self.folder / "posteriors" / f"{posterior_file_name(model)}.nc"
        if not path.is_file():
            raise RecordingError(path, "file", "not found: the comparison's posterior of " + model,
                                 "give the whole --out folder of bayesbeam compare, posteriors/ included")
        data = az.from_netcdf(path)
        missing = [n for n in posterior.names if n not in data.posterior]
        if missing or data.posterior.sizes["chain"] != len(evidence["repeats"]):
            raise RecordingError(path, "posterior", f"does not match comparison.json's {model} (parameters "
                                 f"{', '.join(missing) or 'present'}, {data.posterior.sizes['chain']} chains for "
                                 f"{len(evidence['repeats'])} repeats)", "compare the recording again")
        values = np.stack([data.posterior[n].values for n in posterior.names], axis=-1)
        particles = np.stack([p.to_coordinate(values[..., i]) for i, p in enumerate(posterior.priors)], axis=-1)
        stats = data.sample_stats
        return [SMCRun(log_z, np.full(stages + 1, np.nan), particles[i], stats["log_likelihood_total"].values[i],
                       stats["log_prior"].values[i], np.full(stages, np.nan), 0, 0.0)
                for i, (log_z, stages) in enumerate(zip(evidence["repeats"], evidence["stages"]))]


def _read(file: Path) -> dict:
    """comparison.json, refused unless it is one a diagnosis can reuse."""
    fix = "give the --out folder of `bayesbeam compare` run on this recording"
    if not file.is_file():
        raise RecordingError(file, "file", "not found: the folder holds no comparison", fix)
    try:
        document = json.loads(file.read_text())
    except json.JSONDecodeError as exc:
        raise RecordingError(file, f"line {exc.lineno}", f"not JSON ({exc.msg})", fix) from None
    absent = [key for key in REQUIRED if key not in (document if isinstance(document, dict) else {})]
    if absent:
        raise RecordingError(file, ", ".join(f'"{k}"' for k in absent), "missing: not a comparison a diagnosis can "
                             "reuse (made by another command, or by a bayesbeam that did not record it)",
                             "run bayesbeam compare on the recording again and give its --out folder")
    return document


def _check_recording(file: Path, document: dict, rec) -> None:
    saved, own = document["fingerprint"], fingerprint(rec)
    if saved != own:
        raise RecordingError(file, '"fingerprint"', f"the comparison was made from another recording "
                             f"({document.get('recording') or 'unnamed'}, {saved.get('samples')} samples; this one: "
                             f"{rec.source or 'unnamed'}, "
                             f"{own['samples']} samples; their SHA-256 of samples and description differ)",
                             "give the folder of a comparison of this recording, or compare it first")


def _check_fit(file: Path, saved: dict, own: dict) -> None:
    own = json.loads(json.dumps(own))           # as comparison.json reads back: lists, not tuples
    # the band first: it moves the window and the blocks too, and its option is the one to name
    for key in [*FIT_OPTIONS, *sorted((set(saved) | set(own)) - set(FIT_OPTIONS))]:
        if saved.get(key) != own.get(key):
            raise RecordingError(file, f'"fit".{key}', f"the comparison used {saved.get(key)}, this diagnosis "
                                 f"{own.get(key)}: its fits are not this diagnosis's",
                                 f"give the diagnosis the comparison's {FIT_OPTIONS.get(key, key)}, or compare again "
                                 "with the diagnosis's settings")
