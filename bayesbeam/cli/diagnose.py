"""``bayesbeam diagnose``: what the best damping model misses, which physics explains it, and the fit with it."""
from __future__ import annotations

from bayesbeam.cli.common import UsageError
from bayesbeam.cli.compare import add_evidence_options, check_model, comparison_config
from bayesbeam.io import load_recording

HELP = "locate where the best damping model misses a recording, name and add the missing physics"


def add_arguments(p) -> None:
    p.add_argument("recording", help="recording directory (beam.toml + recording.csv)")
    p.add_argument("--model", help="baseline damping model (preset or '+'-joined mechanisms); default: the best "
                                   "of the default models by evidence (runs a comparison first)")
    p.add_argument("--candidates", type=int, default=2, help="augmented models fitted per round (default 2)")
    p.add_argument("--rounds", type=int, default=2, help="effects added at most (default 2)")
    p.add_argument("--map-replicates", type=int, default=40,
                   help="replicates of the mismatch map (default 40)")
    add_evidence_options(p)
    p.add_argument("--out", required=True, help="output directory (diagnosis.json, report.html, posteriors/)")
    p.set_defaults(effect=None)


def diagnose_config(args):
    from bayesbeam.diagnose import DiagnoseConfig

    for option, value in (("--candidates", args.candidates), ("--rounds", args.rounds),
                          ("--map-replicates", args.map_replicates)):
        if value < 1:
            raise UsageError(f"{option} = {value}: must be at least 1")
    return DiagnoseConfig(comparison_config(args), candidates=args.candidates, rounds=args.rounds,
                          replicates=args.map_replicates)


def run(args) -> int:
    from bayesbeam.diagnose import diagnose
    from bayesbeam.executors import get_executor
    from bayesbeam.inference.sampler import stderr_progress
    from bayesbeam.report.diagnose_outputs import write_diagnosis

    rec = load_recording(args.recording)
    if args.model:
        check_model(args.model, "--model")
    config = diagnose_config(args)
    executor = get_executor(args.executor, args.processes)
    try:
        result = diagnose(rec, args.model, config, executor, log=None if args.quiet else stderr_progress)
    finally:
        executor.close()
    summary = result.to_dict()
    paths = write_diagnosis(result, summary, args.out)
    print(f"baseline {summary['baseline']['model']}: log Z {summary['baseline']['log_evidence']:.1f}, "
          f"RMS standardized residual {summary['baseline']['rms_standardized_residual']:.2f}")
    print(f"added: {', '.join(summary['added']) or 'nothing'}; unexplained: {summary['unexplained']}")
    print(f"final {summary['final']['model']}: log Z {summary['final']['log_evidence']:.1f}, "
          f"RMS standardized residual {summary['final']['rms_standardized_residual']:.2f}")
    print()
    print(summary["summary"])
    print(f"wrote {', '.join(p.name for p in paths[-2:])} and posteriors/ in {args.out}")
    return 0
