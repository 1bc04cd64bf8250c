"""``bayesbeam diagnose``: what the best damping model misses, which physics explains it, and the fit with it."""
from __future__ import annotations

from bayesbeam.checkpoint import remove
from bayesbeam.cli.common import (
    UsageError,
    add_effect_option,
    add_models_option,
    add_out_options,
    output_folder,
)
from bayesbeam.cli.compare import add_evidence_options, comparison_config, model_list
from bayesbeam.io import load_recording
from bayesbeam.report.diagnosis import lead, next_steps

HELP = "locate where the best damping model misses a recording, name and add the missing physics"


def add_arguments(p) -> None:
    p.add_argument("recording", help="recording directory (beam.toml + recording.csv)")
    p.add_argument("--model", help="baseline damping model, a preset or '+'-joined mechanisms (default: the best "
                                   "of --models by evidence, from a comparison run first)")
    # the damping models of the baseline comparison and of the damping re-check (not with --model)
    add_models_option(p, None)
    add_effect_option(p)
    p.add_argument("--from-comparison", metavar="DIR",
                   help="reuse the fits of a comparison of this recording already run (bayesbeam compare --out DIR, "
                        "same fit options) instead of fitting the baseline models again (default: fit them)")
    p.add_argument("--candidates", type=int, default=2, metavar="N", help="augmented models fitted per round")
    p.add_argument("--rounds", type=int, default=2, metavar="N", help="effects added at most")
    p.add_argument("--map-replicates", type=int, default=40, metavar="N", help="replicates of the mismatch map")
    add_evidence_options(p)
    add_out_options(p, "diagnosis.json, report.html, posteriors/; checkpoint/ while it runs",
                    resume="continue a diagnosis killed part-way: the comparisons, optimisations and SMC runs saved "
                           "in OUT/checkpoint/ are read back, the rest run")


def diagnose_config(args):
    from bayesbeam.diagnosis import DiagnoseConfig

    for option, value in (("--candidates", args.candidates), ("--rounds", args.rounds),
                          ("--map-replicates", args.map_replicates)):
        if value < 1:
            raise UsageError(f"{option} = {value}: must be at least 1")
    return DiagnoseConfig(comparison_config(args), candidates=args.candidates, rounds=args.rounds,
                          replicates=args.map_replicates, models=damping_models(args))


def damping_models(args) -> tuple[str, ...]:
    """The damping models ``--models`` names (sets expanded, names checked); compare's default
    without it. Refused beside ``--model``, which names the one baseline."""
    from bayesbeam.comparison import DEFAULT_MODELS

    if args.models is None:
        return DEFAULT_MODELS
    if args.model:
        raise UsageError(f"--model {args.model} and --models {args.models} together: --model names the one "
                         "baseline, --models the damping models compared to choose it. Fix: give one of them.")
    return tuple(model_list(args.models))


def run(args) -> int:
    from bayesbeam.api import run_diagnose
    from bayesbeam.report.diagnose_outputs import write_diagnosis

    out = output_folder(args)
    checkpoint = out / "checkpoint"
    result = run_diagnose(args, load_recording(args.recording), checkpoint).result
    summary = result.to_dict()
    paths = write_diagnosis(result, summary, out)
    remove(checkpoint)                  # the outputs are in place: nothing is left to resume
    print(f"baseline {summary['baseline']['model']}: log Z {summary['baseline']['log_evidence']:.1f}, "
          f"RMS standardized residual {summary['baseline']['rms_standardized_residual']:.2f}")
    print(f"added: {', '.join(a + (' (stand-in)' if a in summary['stand_ins'] else '') for a in summary['added']) or 'nothing'}"
          f"; unexplained: {summary['unexplained']}")
    print(f"final {summary['final']['model']}: log Z {summary['final']['log_evidence']:.1f}, "
          f"RMS standardized residual {summary['final']['rms_standardized_residual']:.2f}")
    print()
    print(" ".join(lead(summary)))
    steps = next_steps(summary)
    if steps:
        print("\nWhat to check next:\n" + "\n".join(f"  {i}. {s}" for i, s in enumerate(steps, 1)))
    print()
    print("In detail: " + summary["summary"])
    for model, why in summary.get("left_out", {}).items():
        print(f"left out {model}: {why}")
    print(f"wrote {', '.join(p.name for p in paths[-2:])} and posteriors/ in {out}")
    return 0
