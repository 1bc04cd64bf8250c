"""Benchmark: wall time of ``bayesbeam diagnose`` on a 4 s, 2048 Hz recording, both cores.

    python benchmarks/diagnose.py [--model q1] [--max-frequency HZ]

on ``data/examples/paper_rootcomp_hammer`` (the paper's beam, q1 damping, a root spring
k_theta = 3500 N m/rad concealed). Target: under 20 minutes on 2 cores. Without
``--model`` the baseline is chosen by a comparison of the five default models first, as the
command does without ``--model``. The baseline measured in the same run is one fit of the
baseline damping model alone (optimum, discretisation, 3 SMC repeats, predictive checks) in this
process: the ratio says how many such fits the whole diagnosis costs.
"""
from __future__ import annotations

import argparse
import os
import platform
import sys
import time
from pathlib import Path

import tables  # benchmarks/tables.py: the script's folder is first on sys.path

from bayesbeam.compare import CompareConfig, compare
from bayesbeam.diagnose import DiagnoseConfig, diagnose
from bayesbeam.executors import LocalExecutor, SerialExecutor
from bayesbeam.inference.fit import FitConfig
from bayesbeam.io import load_recording

EXAMPLE = Path(__file__).resolve().parents[1] / "data" / "examples" / "paper_rootcomp_hammer"
TARGET_SECONDS = 20 * 60


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--model", default=None, help="baseline model (default: chosen by a comparison)")
    parser.add_argument("--max-frequency", type=float, default=150.0, help="top of the fitted band (Hz)")
    parser.add_argument("--tables", action="store_true", help="only re-render README.md's block from benchmarks/results/diagnose.json")
    args = parser.parse_args(argv)
    rec = load_recording(EXAMPLE)
    config = DiagnoseConfig(CompareConfig(FitConfig(max_frequency=args.max_frequency)))
    print(f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores, load {os.getloadavg()}")
    print(f"recording {EXAMPLE.name}: {rec.n_samples} samples at {rec.fs:g} Hz "
          f"({rec.n_samples / rec.fs:g} s); band {args.max_frequency:g} Hz")

    started = time.perf_counter()
    compare(rec, [args.model or "q1"], config.compare, SerialExecutor())
    baseline = time.perf_counter() - started
    print(f"baseline: one fit of {args.model or 'q1'} alone, serially: {baseline:.1f} s")

    executor = LocalExecutor(2)
    started = time.perf_counter()
    try:
        result = diagnose(rec, args.model, config, executor)
    finally:
        executor.close()
    wall = time.perf_counter() - started
    summary = result.to_dict()
    print(f"diagnose ({'--model ' + args.model if args.model else 'baseline by comparison'}) on 2 processes: "
          f"{wall:.1f} s = {wall / TARGET_SECONDS:.2f} x the 20-minute target = {wall / baseline:.1f} x the baseline fit")
    print(f"baseline {summary['baseline']['model']}, added {summary['added'] or 'nothing'}, "
          f"unexplained {summary['unexplained']}; load at the end {os.getloadavg()}")
    tables.record(baseline_seconds=baseline, wall_seconds=wall, target_seconds=TARGET_SECONDS,
                  baseline_model=summary["baseline"]["model"], added=summary["added"],
                  unexplained=summary["unexplained"])

    return 0


if __name__ == "__main__":
    sys.exit(tables.run("diagnose", main))
