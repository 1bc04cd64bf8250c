"""``bayesbeam compare``: rank damping models of one recording by evidence and predictive checks."""
from __future__ import annotations

from bayesbeam.cli.common import UsageError
from bayesbeam.cli.fit import fit_config
from bayesbeam.io import load_recording

HELP = "rank damping models of a recording by evidence and posterior predictive checks"


def add_arguments(p) -> None:
    from bayesbeam.compare import DEFAULT_MODELS

    p.add_argument("recording", help="recording directory (beam.toml + recording.csv)")
    add_comparison_options(p, DEFAULT_MODELS)
    p.add_argument("--out", required=True, help="output directory (comparison.json, report.html, posteriors/)")


def add_comparison_options(p, default_models) -> None:
    """Options shared with ``bayesbeam batch``."""
    p.add_argument("--models", default=",".join(default_models),
                   help=f"comma-separated presets or '+'-joined mechanisms, or a named set: paper, literature, "
                        f"all (default {','.join(default_models)})")
    p.add_argument("--effect", action="append", metavar="EFFECT", help="add a missing-physics effect to every model")
    add_evidence_options(p)


def add_evidence_options(p) -> None:
    """Fit window, band and evidence options (shared with ``bayesbeam diagnose``)."""
    p.add_argument("--config", help="fit file (TOML): [fit] settings and [prior.NAME] tables")
    p.add_argument("--n-intervals", type=int, help="fix the spline intervals N (default: automatic)")
    p.add_argument("--start", type=float, help="start of the fitted window (s)")
    p.add_argument("--stop", type=float, help="end of the fitted window (s)")
    p.add_argument("--max-frequency", type=float, help="top of the fitted band (Hz; default 0.38 fs)")
    p.add_argument("--noise", choices=["white", "ar1"], help="noise model per channel (default white)")
    p.add_argument("--no-force-noise", action="store_true",
                   help="do not marginalise the response driven by the force channel's noise inside the impact window")
    p.add_argument("--repeats", type=int, default=3, help="independent SMC evidence runs per model (default 3)")
    p.add_argument("--particles", type=int, help="SMC particles per run (default max(128, 32 x parameters))")
    p.add_argument("--replicates", type=int, default=100, help="posterior predictive replicates (default 100)")
    p.add_argument("--seed", type=int, default=1, help="random seed (default 1)")
    p.add_argument("--executor", default="local",
                   help="'local' processes (default), 'serial', or a Dask scheduler address tcp://host:8786")
    p.add_argument("--processes", type=int, help="local worker processes (default: all cores)")
    p.add_argument("--quiet", action="store_true", help="no progress lines on stderr")
    # fit()'s options that compare does not use, so fit_config() reads the same namespace
    p.set_defaults(walkers=None, max_steps=None)


def comparison_config(args):
    from bayesbeam.compare import CompareConfig

    fit = fit_config(args)
    try:
        return CompareConfig(fit=fit, repeats=args.repeats, particles=args.particles,
                             replicates=args.replicates, seed=args.seed)
    except ValueError as exc:
        raise UsageError(f"--repeats: {exc}") from None


def model_list(text: str, option: str = "--models") -> list[str]:
    """Model names from a comma-separated list, each checked (presets, mechanisms, effects)."""
    from bayesbeam.compare import expand_model_sets

    models = expand_model_sets(m.strip() for m in text.split(",") if m.strip())
    if not models:
        raise UsageError(f"{option} is empty: give e.g. {option} q1,q2,q3")
    for m in models:
        check_model(m, option)
    return models


def check_model(spec: str, option: str) -> None:
    """UsageError naming ``option`` unless ``spec`` names known mechanisms (and effects)."""
    from bayesbeam.model import resolve_model

    try:
        resolve_model(spec)
    except ValueError as exc:
        raise UsageError(f"{option} {spec}: {exc}") from None


def run(args) -> int:
    from bayesbeam.compare import compare
    from bayesbeam.executors import get_executor
    from bayesbeam.inference.sampler import stderr_progress
    from bayesbeam.report.compare_outputs import write_comparison

    rec = load_recording(args.recording)
    models = model_list(args.models)
    config = comparison_config(args)
    executor = get_executor(args.executor, args.processes)
    try:
        results, summary = compare(rec, models, config, executor, log=None if args.quiet else stderr_progress)
    finally:
        executor.close()
    paths = write_comparison(results, summary, args.out)
    print(format_ranking(summary))
    print(f"wrote {', '.join(p.name for p in paths[-2:])} and posteriors/ in {args.out}")
    return 0


def format_ranking(summary: dict) -> str:
    lines = [f"{'model':<24} {'log Z':>12} {'sd':>6} {'ln B vs best':>13} {'probability':>12}"]
    for m in summary["ranking"]:
        s = summary["models"][m]
        lines.append(f"{m:<24} {s['log_evidence']:>12.2f} {s['log_evidence_sd']:>6.2f} "
                     f"{s['log_bayes_factor_vs_best']:>13.2f} {s['probability']:>12.4f}")
    return "\n".join(lines + ["", summary["verdict"]])
