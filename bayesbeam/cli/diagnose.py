"""``bayesbeam diagnose``: what the best damping model misses, which physics explains it, and the fit with it."""
from __future__ import annotations

from bayesbeam.cli.common import (
    UsageError,
    add_effect_option,
    add_out_options,
    job_executor,
    model_spec,
    output_folder,
)
from bayesbeam.cli.compare import add_evidence_options, comparison_config
from bayesbeam.io import load_recording
from bayesbeam.report.diagnosis import lead

HELP = "locate where the best damping model misses a recording, name and add the missing physics"


def add_arguments(p) -> None:
    p.add_argument("recording", help="recording directory (beam.toml + recording.csv)")
    p.add_argument("--model", help="baseline damping model, a preset or '+'-joined mechanisms (default: the best "
                                   "of the default models by evidence, from a comparison run first)")
    add_effect_option(p)
    p.add_argument("--candidates", type=int, default=2, metavar="N", help="augmented models fitted per round")
    p.add_argument("--rounds", type=int, default=2, metavar="N", help="effects added at most")
    p.add_argument("--map-replicates", type=int, default=40, metavar="N", help="replicates of the mismatch map")
    add_evidence_options(p)
    add_out_options(p, "diagnosis.json, report.html, posteriors/")


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
    from bayesbeam.inference.sampler import stderr_progress
    from bayesbeam.report.diagnose_outputs import write_diagnosis

    out = output_folder(args)
    # with --model, the effects join it; without, each default model the comparison starts from
    model = model_spec(args.model, args.effect) if args.model else None
    effects = () if args.model else tuple(args.effect or ())
    if len(set(effects)) < len(effects):
        raise UsageError(f"--effect {' '.join(effects)}: an effect is given twice. Fix: name each once.")
    config = diagnose_config(args)
    rec = load_recording(args.recording)
    executor = job_executor(args)
    try:
        result = diagnose(rec, model, config, executor, log=None if args.quiet else stderr_progress,
                          effects=effects)
    finally:
        executor.close()
    summary = result.to_dict()
    paths = write_diagnosis(result, summary, out)
    print(f"baseline {summary['baseline']['model']}: log Z {summary['baseline']['log_evidence']:.1f}, "
          f"RMS standardized residual {summary['baseline']['rms_standardized_residual']:.2f}")
    print(f"added: {', '.join(summary['added']) or 'nothing'}; unexplained: {summary['unexplained']}")
    print(f"final {summary['final']['model']}: log Z {summary['final']['log_evidence']:.1f}, "
          f"RMS standardized residual {summary['final']['rms_standardized_residual']:.2f}")
    print()
    print(" ".join(lead(summary)))
    print()
    print("In detail: " + summary["summary"])
    print(f"wrote {', '.join(p.name for p in paths[-2:])} and posteriors/ in {out}")
    return 0
