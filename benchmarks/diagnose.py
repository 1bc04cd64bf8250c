"""Benchmark: ``diagnose`` on a 4 s, 2048 Hz recording, both cores, current settings against the
full path (every repeat of every model, three accepted SMC moves per particle).

    python benchmarks/diagnose.py [--model q1] [--max-frequency HZ]

on ``data/examples/paper_rootcomp_hammer`` (the paper's beam, q1 damping, a root spring
k_theta = 3500 N m/rad concealed). Without ``--model`` the baseline damping model is chosen by a
comparison of the five default models first, as the command does without ``--model``. The
**baseline** path, run first in the same process with the same seeds, is the diagnosis with
cubic splines and ``early_stop=None, min_moved=None`` (see benchmarks/compare.py); the current
one uses the defaults (quintic splines, early stop). Printed: both wall times, their ratio, and both diagnoses, which must agree: the same added
effects and final effects, and final damping models the re-check could not rank apart (each the
other's or tied with its best, ``damping_recheck.tied``).
Targets: 300 s without ``--model`` on two cores.
"""
from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import time
from dataclasses import replace
from pathlib import Path

import tables  # benchmarks/tables.py: the script's folder is first on sys.path

from bayesbeam.comparison import CompareConfig
from bayesbeam.diagnosis import DiagnoseConfig, diagnose
from bayesbeam.executors import LocalExecutor
from bayesbeam.inference.fit import FitConfig
from bayesbeam.io import load_recording
from bayesbeam.model import split_model

EXAMPLE = Path(__file__).resolve().parents[1] / "data" / "examples" / "paper_rootcomp_hammer"
#: the concealed-effects study's recordings (``--concealed NAME``: 3 s at 1024 Hz, its damping model named)
CONCEALED = Path(__file__).resolve().parents[1] / "studies" / "concealed_effects" / "recordings"
#: wall-time targets on two cores (s): the example without --model, a concealed-effects recording
TARGET_SECONDS = {"example": 300.0, "concealed": 600.0}


def timed_diagnose(rec, model, config: DiagnoseConfig) -> tuple[dict, float]:
    """(diagnosis.json's content, wall time in s) on two local processes. The diagnosis's steps go
    to standard error with the seconds since its start (where the time goes; not in the result)."""
    executor = LocalExecutor(2)
    started = time.perf_counter()

    def log(text: str) -> None:
        print(f"[{time.perf_counter() - started:7.1f} s] {text}", file=sys.stderr, flush=True)

    try:
        result = diagnose(rec, model, config, executor, log=log)
    finally:
        executor.close()
    return result.to_dict(), time.perf_counter() - started


def same_final(one: dict, other: dict) -> bool:
    """Whether two diagnoses (diagnosis.json's content) end with the same effects and a damping model
    each finds in the other's final damping or tied with its re-check's best (``damping_recheck.tied``):
    the evidence does not rank tied damping models, so which of them ends the path is noise."""
    def damping(summary: dict) -> tuple[tuple, tuple, set]:
        mechanisms, effects = split_model(summary["final"]["model"])
        r = summary["damping_recheck"]
        tied = {split_model(m)[0] for m in [*r.get("tied", ()), r["best"]]} if r else set()
        return effects, mechanisms, {mechanisms} | tied

    (effects, final, allowed), (effects_other, final_other, allowed_other) = damping(one), damping(other)
    return effects == effects_other and final in allowed_other and final_other in allowed


def parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--model", default=None, help="baseline model (default: chosen by a comparison)")
    parser.add_argument("--concealed", default=None, metavar="NAME",
                        help="diagnose studies/concealed_effects/recordings/NAME instead, with its truth's damping model")
    parser.add_argument("--max-frequency", type=float, default=150.0, help="top of the fitted band (Hz)")
    parser.add_argument("--tables", action="store_true", help="only re-render README.md's block from benchmarks/results/diagnose.json")
    return parser


def configs(args) -> tuple[DiagnoseConfig, DiagnoseConfig]:
    """(baseline, current) diagnosis settings of the parsed command line."""
    current = DiagnoseConfig(CompareConfig(FitConfig(max_frequency=args.max_frequency)))
    cubic = replace(current.compare.fit, degree=3)
    return replace(current, compare=replace(current.compare, fit=cubic, early_stop=None, min_moved=None)), current


def recording(args):
    """(the recording, the baseline model or None, the target in s) of the parsed command line."""
    if args.concealed is None:
        return load_recording(EXAMPLE), args.model, TARGET_SECONDS["example"]
    path = CONCEALED / args.concealed
    truth = json.loads((path / "truth.json").read_text())
    return load_recording(path), args.model or truth["damping_model"], TARGET_SECONDS["concealed"]


def result_name(concealed: str | None) -> str:
    """The result's name: ``diagnose``, or ``diagnose_NAME`` for the concealed-effects recording NAME."""
    return f"diagnose_{concealed}" if concealed else "diagnose"


def main(argv=None) -> int:
    args = parser().parse_args(argv)
    rec, model, target = recording(args)
    baseline, current = configs(args)
    print(f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores, load {os.getloadavg()}")
    print(f"recording {rec.source.name if rec.source else EXAMPLE.name}: {rec.n_samples} samples at {rec.fs:g} Hz "
          f"({rec.n_samples / rec.fs:g} s); band {args.max_frequency:g} Hz; "
          f"{'--model ' + model if model else 'baseline by comparison'}; 2 processes")
    outcomes = {}
    for name, config in (("baseline", baseline), ("current", current)):
        summary, wall = timed_diagnose(rec, model, config)
        outcomes[name] = (summary, wall)
        print(f"{name}: {wall:.1f} s; baseline {summary['baseline']['model']}, added {summary['added'] or 'nothing'}, "
              f"final {summary['final']['model']}, unexplained {summary['unexplained']}; load {os.getloadavg()}")
    (base, base_wall), (new, new_wall) = outcomes["baseline"], outcomes["current"]
    same = all(base[k] == new[k] for k in ("added", "unexplained")) and same_final(base, new)
    print(f"ratio baseline / current wall time: {base_wall / new_wall:.2f}; current = "
          f"{new_wall / target:.2f} x the {target:g} s target; diagnoses {'agree' if same else 'DIFFER'}")
    tables.record(baseline_seconds=base_wall, current_seconds=new_wall, wall_ratio=base_wall / new_wall,
                  target_seconds=target, final=new["final"]["model"], added=new["added"],
                  unexplained=new["unexplained"], diagnoses_agree=same)
    return 0


if __name__ == "__main__":
    # each concealed-effects recording is kept apart from the example, with a block of its own in README.md
    sys.exit(tables.run(result_name(parser().parse_known_args()[0].concealed), main))
