"""``bayesbeam compare``: rank damping models of one recording by evidence and predictive checks."""
from __future__ import annotations

from bayesbeam.cli.common import (
    UsageError,
    add_effect_option,
    add_models_option,
    add_out_options,
    add_run_options,
    model_spec,
    output_folder,
    positive_int,
)
from bayesbeam.cli.fit import add_fit_options, fit_config
from bayesbeam.io import load_recording

HELP = "rank damping models of a recording by evidence and posterior predictive checks"


def add_arguments(p) -> None:
    p.add_argument("recording", help="recording directory (beam.toml + recording.csv)")
    add_comparison_options(p)
    add_out_options(p, "comparison.json, report.html, posteriors/")


def add_comparison_options(p) -> None:
    """Options shared with ``bayesbeam batch``."""
    from bayesbeam.comparison import DEFAULT_MODELS

    add_models_option(p, ",".join(DEFAULT_MODELS))
    add_effect_option(p)
    add_evidence_options(p)


def add_evidence_options(p) -> None:
    """The fit options and the evidence runs' (shared with ``bayesbeam diagnose``)."""
    add_fit_options(p)
    p.add_argument("--repeats", type=int, default=3, metavar="N", help="independent SMC evidence runs per model")
    p.add_argument("--particles", type=positive_int, metavar="N", help="SMC particles per run (default: max(128, 32 x parameters))")
    p.add_argument("--replicates", type=positive_int, default=100, metavar="N", help="posterior predictive replicates")
    add_run_options(p)
    # fit()'s options that compare does not use, so fit_config() reads the same namespace
    p.set_defaults(walkers=None, max_steps=None)


def comparison_config(args):
    from bayesbeam.comparison import CompareConfig

    fit = fit_config(args)
    try:
        return CompareConfig(fit=fit, repeats=args.repeats, particles=args.particles,
                             replicates=args.replicates, seed=fit.seed)
    except ValueError as exc:
        raise UsageError(f"--repeats: {exc}") from None


def model_list(text: str, effects=None, option: str = "--models") -> list[str]:
    """Model names from a comma-separated list, each with the ``--effect`` names joined in and checked."""
    from bayesbeam.comparison import expand_model_sets

    models = expand_model_sets(m.strip() for m in text.split(",") if m.strip())
    if not models:
        raise UsageError(f"{option} is empty: give e.g. {option} q1,q2,q3")
    return [model_spec(m, effects, option) for m in models]


def run(args) -> int:
    from bayesbeam.api import run_compare
    from bayesbeam.report.compare_outputs import write_comparison

    out = output_folder(args)
    comparison = run_compare(args, load_recording(args.recording))
    summary = comparison.summary_dict
    paths = write_comparison(comparison.results, summary, out)
    print(format_ranking(summary))
    print(f"wrote {', '.join(p.name for p in paths[-2:])} and posteriors/ in {out}")
    return 0


def format_ranking(summary: dict) -> str:
    lines = [f"{'model':<24} {'log Z':>12} {'sd':>6} {'ln B vs best':>13} {'probability':>12}"]
    for m in summary["ranking"]:
        s = summary["models"][m]
        lines.append(f"{m:<24} {s['log_evidence']:>12.2f} {s['log_evidence_sd']:>6.2f} "
                     f"{s['log_bayes_factor_vs_best']:>13.2f} {s['probability']:>12.4f}")
    return "\n".join(lines + ["", summary["verdict"]])
