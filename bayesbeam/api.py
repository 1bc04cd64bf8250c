"""The Python interface for study scripts and notebooks: :func:`check`, :func:`fit`, :func:`compare`,
:func:`diagnose` and :func:`load`, importable from ``bayesbeam``.

Each function takes a recording (a folder or a loaded :class:`~bayesbeam.io.Recording`) and the
command line's options as keyword arguments, named as its flags (``--max-frequency 150`` is
``max_frequency=150``, ``--effect root_compliance`` is ``effect="root_compliance"`` or a list,
``--models q1,q3`` is ``models=["q1", "q3"]``, a switch such as ``--no-force-noise`` is
``no_force_noise=True``; ``progress=False`` is ``--quiet``). The options are parsed by the
command's own argument parser, so their defaults, checks and messages are the command line's
(all cores, seed 1, ...). Nothing is written until ``.write(folder)``, which writes exactly what
the command writes; the command line is this module plus printing.

The results are objects: ``.summary()`` (a pandas table with units: a row per model or parameter),
``.idata`` (arviz InferenceData whose variables carry ``units`` and ``description``), ``.best``
(compare, diagnose), ``.plot_*()`` (matplotlib figures) and ``.write(folder)``. :func:`load`
reopens any output folder as the same kind of object (without what only a live run holds, such
as the fitted problem).
"""
from __future__ import annotations

import argparse
import importlib
import json
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from types import SimpleNamespace

import numpy as np

from bayesbeam.io import Recording, load_recording
from bayesbeam.report.truth import recording_truths

__all__ = ["Check", "Comparison", "Diagnosis", "Fit", "check", "compare", "diagnose", "fit", "load"]

#: where an unwritten run's --out points: the parsers require the option, .write() chooses the folder
UNWRITTEN = "<not written: call .write(folder)>"


# ---------------------------------------------------------------------------- options
class _Parser(argparse.ArgumentParser):
    """A command's parser that raises ValueError instead of exiting the interpreter."""

    def error(self, message):
        raise ValueError(f"bayesbeam.{self.prog}(): {message}")


def options(command: str, recording, **kwargs) -> argparse.Namespace:
    """The command line's namespace of ``bayesbeam COMMAND RECORDING`` with ``kwargs`` as its flags.

    TypeError names an option the command does not have and lists those it has."""
    from bayesbeam.cli import COMMANDS

    parser = _Parser(prog=command, add_help=False)
    importlib.import_module(f"bayesbeam.cli.{COMMANDS[command]}").add_arguments(parser)
    actions = {a.dest: a for a in parser._actions if a.option_strings and a.dest not in ("out", "overwrite")}
    if "progress" in kwargs:
        kwargs["quiet"] = not kwargs.pop("progress")
    argv = [str(_source(recording))]
    if any(a.dest == "out" for a in parser._actions):
        argv += ["--out", UNWRITTEN]
    for name, value in kwargs.items():
        if name not in actions:
            raise TypeError(f"bayesbeam.{command}() has no option {name!r}; its options: "
                            f"{', '.join(sorted(actions))}" + (", progress" if "quiet" in actions else ""))
        argv += _flag(actions[name], value)
    return parser.parse_args(argv)


def _flag(action: argparse.Action, value) -> list[str]:
    """The command-line words of one option's value."""
    flag = action.option_strings[-1]
    if isinstance(action, argparse._StoreTrueAction):
        return [flag] if value else []
    if value is None:
        return []
    if isinstance(action, argparse._AppendAction):
        return [word for v in ([value] if isinstance(value, str) else value) for word in (flag, str(v))]
    if isinstance(value, (list, tuple)):
        return [flag, ",".join(map(str, value))]
    return [flag, str(value)]


def _source(recording) -> Path:
    return Path(recording.source) if isinstance(recording, Recording) else Path(recording)


def _recording(recording, args) -> Recording:
    return recording if isinstance(recording, Recording) else load_recording(args.recording)


def _log(args):
    from bayesbeam.progress import Progress

    return Progress(enabled=not args.quiet)


#: what a reopened fit lacks, and the fix (:func:`_live`)
FIT_REOPENED = ("the fitted model", "fit", "run bayesbeam.fit() again, or look at the folder's PNG files.")


def _live(value, what: str, needs: str, kind: str, fix: str):
    """``value`` (what a live run holds and a reopened folder does not); ValueError naming the
    method, what it needs and the fix when it is None."""
    if value is None:
        raise ValueError(f"{what}() needs {needs}, which a reopened {kind} does not hold. Fix: {fix}")
    return value


def _folder(folder, overwrite: bool) -> Path:
    """``folder`` as the commands check their --out (not a file; empty unless ``overwrite``)."""
    from bayesbeam.cli.common import output_folder

    out = output_folder(argparse.Namespace(out=str(folder), overwrite=overwrite))
    out.mkdir(parents=True, exist_ok=True)
    return out


# ---------------------------------------------------------------------------- tables and plots
def _table(rows: list[dict], index: str):
    import pandas as pd

    return pd.DataFrame(rows).set_index(index)


def _parameter_rows(parameters: dict) -> list[dict]:
    """A row per parameter of a summary's ``{name: {q05, q50, q95, unit, ...}}``."""
    rows = []
    for name, s in parameters.items():
        row = {"parameter": name, "unit": s.get("unit", ""), "median": s["q50"], "q05": s["q05"], "q95": s["q95"]}
        row.update({k: s[k] for k in ("ess", "r_hat") if k in s})
        rows.append(row)
    return rows


def _corner(idatas: dict, names: list[str] | None, units: dict, truth: dict, title: str):
    """Corner plot of one or several posteriors (InferenceData by label) over their common parameters."""
    from bayesbeam.report.plots import corner_overlay

    posteriors = [i.posterior for i in idatas.values()]
    common = [n for n in posteriors[0].data_vars if all(n in p.data_vars for p in posteriors)]
    names = names or [n for n in common if not n.startswith(("sigma_", "phi_"))]
    samples = [np.stack([p[n].values.ravel() for n in names], axis=1) for p in posteriors]
    return corner_overlay(samples, names, list(idatas), units=units, truths=truth or None, title=title)


def _units(idata) -> dict[str, str]:
    return {n: v.attrs.get("units", "") for n, v in idata.posterior.data_vars.items()}


# ---------------------------------------------------------------------------- check
@dataclass
class Check:
    """What ``bayesbeam check`` finds in a recording (:func:`bayesbeam.checks.survey.survey`)."""

    summary_dict: dict
    found: object = None
    recording: Recording | None = None

    def summary(self):
        """A row per channel: unit, RMS, noise sd and the spectral peaks the check found."""
        return _table([{"channel": c["name"], "unit": c["unit"], "RMS": c["rms"], "noise sd": c["noise_sd"],
                        "peaks (Hz)": c["peaks_hz"]} for c in self.summary_dict["channels"]], "channel")

    def report(self) -> str:
        from bayesbeam.checks.survey import report_lines

        return "\n".join(report_lines(self.summary_dict))

    def plot_quicklook(self):
        """Each channel over time and its spectrum against the nominal modes, and the force pulses."""
        from bayesbeam.report.quicklook import quicklook_figure

        return quicklook_figure(self.recording, self.found)

    def write(self, folder, overwrite: bool = False) -> list[Path]:
        from bayesbeam.io.provenance import write_json
        from bayesbeam.report.quicklook import save_quicklook

        out = _folder(folder, overwrite)
        return [write_json(self.summary_dict, out / "check.json"), save_quicklook(self.recording, self.found, out / "quicklook.png")]


def check(recording) -> Check:
    """Validate a recording and say what it holds (``bayesbeam check``)."""
    from bayesbeam import __version__
    from bayesbeam.checks.survey import survey

    rec = recording if isinstance(recording, Recording) else load_recording(recording)
    found = survey(rec)
    return Check({"bayesbeam": __version__, **found.summary}, found, rec)


# ---------------------------------------------------------------------------- fit
@dataclass
class Fit:
    """One model's posterior by emcee (``bayesbeam fit``). ``idata`` is None when reopened from a
    folder without its posterior.nc."""

    summary_dict: dict
    idata: object
    result: object = None
    truth: dict = field(default_factory=dict)

    @property
    def converged(self) -> bool:
        return bool(self.summary_dict["converged"])

    def summary(self):
        """A row per parameter: unit, median, 90 % interval, ESS and R-hat."""
        s = self.summary_dict
        return _table(_parameter_rows({**s["parameters"], **{k: v for k, v in s["noise"].items()
                                                             if isinstance(v, dict) and "q50" in v}}), "parameter")

    def plot_corner(self, names: list[str] | None = None):
        """Corner plot of the model parameters, with the truth when the recording has one."""
        idata = _live(self.idata, "plot_corner", "the posterior draws (posterior.nc)", "fit without that file",
                      "run the fit again (its folder's summary.json names the recording and model).")
        return _corner({self.summary_dict["model"]: idata}, names, _units(idata), self.truth,
                       f"posterior of {self.summary_dict['model']}")

    def plot_trace(self):
        from bayesbeam.report.plots import trace_plot

        return trace_plot(_live(self.result, "plot_trace", *FIT_REOPENED))

    def plot_fit(self, channel: int = 0):
        from bayesbeam.report.plots import fit_plot

        return fit_plot(_live(self.result, "plot_fit", *FIT_REOPENED), channel)

    def write(self, folder, overwrite: bool = False) -> list[Path]:
        """posterior.nc, summary.json, corner.png, trace.png, fit.png: what ``bayesbeam fit`` writes."""
        from bayesbeam.report.fit_outputs import write_fit

        return write_fit(_live(self.result, "write", *FIT_REOPENED), _folder(folder, overwrite))


def fit(recording, **options_) -> Fit:
    """Sample one model's posterior (``bayesbeam fit RECORDING --model ...``)."""
    args = options("fit", recording, **options_)
    return run_fit(args, _recording(recording, args))


def run_fit(args, rec: Recording, backend_path=None) -> Fit:
    """:func:`fit` of a parsed namespace (the command line's path too)."""
    from bayesbeam.cli.common import model_spec
    from bayesbeam.cli.fit import fit_config, walker_pool
    from bayesbeam.inference import fit as fit_model

    result = fit_model(rec, model_spec(args.model, args.effect), fit_config(args), pool=walker_pool(args),
                       backend_path=backend_path, resume=getattr(args, "resume", False), log=_log(args))
    return Fit(result.summary, result.idata, result, recording_truths(rec))


# ---------------------------------------------------------------------------- compare
@dataclass
class Comparison:
    """Damping models ranked by evidence and predictive checks (``bayesbeam compare``)."""

    summary_dict: dict
    idata: dict
    results: dict | None = None
    truth: dict = field(default_factory=dict)

    @property
    def best(self) -> str:
        """The model ranked first."""
        return self.summary_dict["ranking"][0]

    def summary(self):
        """A row per model in ranking order: log evidence, its sd, ln B against the best (nats) and
        the posterior probability."""
        models = self.summary_dict["models"]
        return _table([{"model": m, "log Z (nats)": models[m]["log_evidence"], "sd (nats)": models[m]["log_evidence_sd"],
                        "ln B vs best (nats)": models[m]["log_bayes_factor_vs_best"],
                        "probability": models[m]["probability"]} for m in self.summary_dict["ranking"]], "model")

    def parameters(self, model: str | None = None):
        """A row per parameter of ``model`` (default: the best): unit, median, 90 % interval."""
        return _table(_parameter_rows(self.summary_dict["models"][model or self.best]["posterior"]), "parameter")

    def plot_corner(self, models: list[str] | None = None, names: list[str] | None = None):
        """Corner plot of ``models`` (default: the two best) overlaid over their common parameters,
        with a legend, the stated contour levels and the truth when the recording has one."""
        models = models or self.summary_dict["ranking"][:2]
        return _corner({m: self.idata[m] for m in models}, names, _units(self.idata[models[0]]), self.truth,
                       "posteriors of " + ", ".join(models))

    def plot_damping_per_mode(self):
        """Modal damping ratio against frequency: measured and each model's 90 % interval."""
        from bayesbeam.report.comparison import mode_plot, model_colors

        return mode_plot(self.summary_dict, model_colors(self.summary_dict))

    def write(self, folder, overwrite: bool = False) -> list[Path]:
        """comparison.json, report.html, damping_per_mode.png, posteriors/: what ``bayesbeam compare`` writes."""
        from bayesbeam.report.compare_outputs import write_comparison

        results = _live(self.results, "write", "the comparison's fitted models", "comparison",
                        "copy its folder, or run bayesbeam.compare() again.")
        return write_comparison(results, self.summary_dict, _folder(folder, overwrite))


def compare(recording, **options_) -> Comparison:
    """Rank damping models by evidence and predictive checks (``bayesbeam compare RECORDING``)."""
    args = options("compare", recording, **options_)
    return run_compare(args, _recording(recording, args))


def run_compare(args, rec: Recording) -> Comparison:
    """:func:`compare` of a parsed namespace (the command line's path too)."""
    from bayesbeam.cli.common import job_executor
    from bayesbeam.cli.compare import comparison_config, model_list
    from bayesbeam.comparison import compare as compare_models
    from bayesbeam.report.compare_outputs import inference_data

    models = model_list(args.models, args.effect)
    config = comparison_config(args)
    executor = job_executor(args)
    try:
        results, summary = compare_models(rec, models, config, executor, log=_log(args))
    finally:
        executor.close()
    return Comparison(summary, {m: inference_data(r) for m, r in results.items()}, results, recording_truths(rec))


# ---------------------------------------------------------------------------- diagnose
@dataclass
class Diagnosis:
    """Where the best model misses, the physics added, and the fit with it (``bayesbeam diagnose``)."""

    summary_dict: dict
    posteriors: dict | None = None
    result: object = None

    @property
    def idata(self) -> dict:
        """Each model fitted (baseline, candidates, damping re-check) as InferenceData, by name."""
        if self.posteriors is None:
            from bayesbeam.report.compare_outputs import inference_data
            from bayesbeam.report.diagnose_outputs import fitted_models

            self.posteriors = {name: inference_data(r) for name, r in fitted_models(self.result).items()}
        return self.posteriors

    @property
    def best(self) -> str:
        """The final model: the baseline with every effect added."""
        return self.summary_dict["final"]["model"]

    @property
    def unexplained(self) -> bool:
        return bool(self.summary_dict["unexplained"])

    def summary(self):
        """A row per model fitted: the baseline, each candidate (log Bayes factor against the
        model it was added to, whether it was decisive, improved the map and was added, and
        whether its effect was a stand-in as fitted), the final (its effects that are stand-ins
        there, judged on its own posterior)."""
        from bayesbeam.diagnosis import stand_in_words

        s = self.summary_dict
        rows = [{"model": s["baseline"]["model"], "role": "baseline", "log Z (nats)": s["baseline"]["log_evidence"],
                 "RMS std. residual": s["baseline"]["rms_standardized_residual"]}]
        for c in s["candidates"]:
            rows.append({"model": c["model"], "role": f"candidate {c['label']}", "ln B (nats)": c["delta_log_evidence"],
                         "ln B sd (nats)": c["delta_log_evidence_sd"], "decisive": c["decisive"],
                         "map improved": c["map_improved"], "added": c["added"], "stand-in": stand_in_words(c["stand_in"]),
                         "RMS std. residual": c["rms_standardized_residual"]})
        rows.append({"model": s["final"]["model"], "role": "final", "log Z (nats)": s["final"]["log_evidence"],
                     "stand-in": _final_stand_ins(s), "RMS std. residual": s["final"]["rms_standardized_residual"]})
        return _table(rows, "model")

    def parameters(self):
        """A row per parameter of the final model: unit, median, 90 % interval."""
        return _table(_parameter_rows(self.summary_dict["final"]["parameters"]), "parameter")

    def plot_mismatch(self):
        """The mismatch map: standardized residual by time and frequency, baseline against final."""
        from bayesbeam.report.diagnosis import compared_maps, mismatch_map_plot

        result = _live(self.result, "plot_mismatch", "the maps", "diagnosis",
                       "open its report.html, or run bayesbeam.diagnose() again.")
        return mismatch_map_plot(compared_maps(result))

    def write(self, folder, overwrite: bool = False) -> list[Path]:
        """diagnosis.json, report.html, posteriors/: what ``bayesbeam diagnose`` writes."""
        from bayesbeam.report.diagnose_outputs import write_diagnosis

        result = _live(self.result, "write", "the diagnosis's fitted models", "diagnosis",
                       "copy its folder, or run bayesbeam.diagnose() again.")
        return write_diagnosis(result, self.summary_dict, _folder(folder, overwrite))


def _final_stand_ins(summary: dict) -> str | None:
    """The final row's stand-in cell: 'no', or each stand-in effect of the final model with its
    parameter and what rules it out; None for a diagnosis.json without the verdicts."""
    from bayesbeam.diagnosis import stand_in_clause

    if "final_stand_ins" not in summary:
        return None
    verdicts = summary["final_stand_ins"].values()
    return "; ".join(f"{v['label']}: {v['parameter']} {stand_in_clause(v)}" for v in verdicts) or "no"


def diagnose(recording, checkpoint=None, **options_) -> Diagnosis:
    """Locate where the best damping model misses, name and add the missing physics
    (``bayesbeam diagnose RECORDING``). ``checkpoint``: a folder where each comparison, wave of
    optimisations and SMC run is saved as it finishes; with ``resume=True``, a diagnosis killed part-way
    continues from the steps saved there (:mod:`bayesbeam.checkpoint`). The folder is kept."""
    args = options("diagnose", recording, **options_)
    return run_diagnose(args, _recording(recording, args), checkpoint)


def run_diagnose(args, rec: Recording, checkpoint=None) -> Diagnosis:
    """:func:`diagnose` of a parsed namespace (the command line's path too); ``checkpoint``: the
    folder of its saved steps (:mod:`bayesbeam.checkpoint`), read back with ``args.resume``."""
    from bayesbeam.cli.common import UsageError, job_executor, model_spec
    from bayesbeam.cli.diagnose import diagnose_config
    from bayesbeam.diagnosis import diagnose as diagnose_recording

    # with --model, the effects join it; without, each default model the comparison starts from
    model = model_spec(args.model, args.effect) if args.model else None
    effects = () if args.model else tuple(args.effect or ())
    if len(set(effects)) < len(effects):
        raise UsageError(f"--effect {' '.join(effects)}: an effect is given twice. Fix: name each once.")
    config = diagnose_config(args)
    executor = job_executor(args)
    try:
        result = diagnose_recording(rec, model, config, executor, log=_log(args), effects=effects,
                                    from_comparison=args.from_comparison, checkpoint=checkpoint,
                                    resume=args.resume)
    finally:
        executor.close()
    return Diagnosis(result.to_dict(), result=result)


# ---------------------------------------------------------------------------- load
def load(folder):
    """Reopen an output folder of check, fit, compare or diagnose as a :class:`Check`, :class:`Fit`,
    :class:`Comparison` or :class:`Diagnosis` (summary tables, posteriors, corner plots)."""
    folder = Path(folder)
    kinds = {"diagnosis.json": _load_diagnosis, "comparison.json": _load_comparison,
             "summary.json": _load_fit, "check.json": lambda f: Check(_json(f / "check.json"))}
    for name, reader in kinds.items():
        if (folder / name).is_file():
            return reader(folder)
    raise ValueError(f"{folder}: no diagnosis.json, comparison.json, summary.json or check.json. Fix: give a "
                     f"folder written by bayesbeam check, fit, compare or diagnose (their --out).")


def _json(path: Path) -> dict:
    return json.loads(path.read_text())


def _netcdf(path: Path):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        import arviz as az

        return az.from_netcdf(str(path))


def _posteriors(folder: Path) -> dict:
    """The models' InferenceData of a comparison's or a diagnosis's posteriors/ folder, by model name."""
    out = {}
    for path in sorted((folder / "posteriors").glob("*.nc")):
        data = _netcdf(path)
        out[data.attrs.get("model", path.stem.replace("_plus_", "+"))] = data
    return out


def _load_fit(folder: Path) -> Fit:
    """A fit's folder; its posterior draws are None where posterior.nc was not kept (a large one is
    often left out of a repository), and what needs them says so."""
    summary = _json(folder / "summary.json")
    if not {"model", "parameters", "noise"} <= summary.keys():
        raise ValueError(f"{folder / 'summary.json'}: not written by bayesbeam fit (no 'model', 'parameters' "
                         f"and 'noise' keys). Fix: give a folder written by bayesbeam check, fit, compare or "
                         f"diagnose (their --out).")
    posterior = folder / "posterior.nc"
    return Fit(summary, _netcdf(posterior) if posterior.is_file() else None, truth=_truths_of(summary))


def _load_comparison(folder: Path) -> Comparison:
    summary = _json(folder / "comparison.json")
    return Comparison(summary, _posteriors(folder), truth=_truths_of(summary))


def _load_diagnosis(folder: Path) -> Diagnosis:
    return Diagnosis(_json(folder / "diagnosis.json"), _posteriors(folder))


def _truths_of(summary: dict) -> dict:
    """The truth of the recording a summary names (where it still lies), else empty."""
    recording = summary.get("recording")
    return recording_truths(SimpleNamespace(source=recording)) if recording else {}
