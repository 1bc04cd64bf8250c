"""Benchmark: wall time of ``bayesbeam compare`` with the five default models, both cores.

    python benchmarks/compare.py [--max-frequency HZ] [--repeats R]

on ``data/examples/paper_q3_hammer`` (4 s at 2048 Hz, the paper's beam, q3 damping). Target:
under 15 minutes on 2 cores. The baseline, measured in the same run, is one model's
jobs (q1) run serially in this process: the printed parallel efficiency is
(5 x that model's serial time) / (2 x the comparison's wall time), ~1 when both cores are busy
all the time and the five models cost about the same.
"""
from __future__ import annotations

import argparse
import os
import platform
import sys
import time
from pathlib import Path

import tables  # benchmarks/tables.py: the script's folder is first on sys.path

from bayesbeam.compare import DEFAULT_MODELS, CompareConfig, compare
from bayesbeam.executors import LocalExecutor, SerialExecutor
from bayesbeam.inference.fit import FitConfig
from bayesbeam.io import load_recording

EXAMPLE = Path(__file__).resolve().parents[1] / "data" / "examples" / "paper_q3_hammer"
TARGET_SECONDS = 15 * 60


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--max-frequency", type=float, default=None,
                        help="top of the fitted band (Hz; default 0.38 fs as in compare)")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--tables", action="store_true", help="only re-render README.md's block from benchmarks/results/compare.json")
    args = parser.parse_args(argv)
    rec = load_recording(EXAMPLE)
    config = CompareConfig(FitConfig(max_frequency=args.max_frequency), repeats=args.repeats)
    print(f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores, load {os.getloadavg()}")
    print(f"recording {EXAMPLE.name}: {rec.n_samples} samples at {rec.fs:g} Hz; band "
          f"{args.max_frequency or 0.38 * rec.fs:g} Hz; {args.repeats} SMC repeats per model")

    started = time.perf_counter()
    compare(rec, ["q1"], config, SerialExecutor())
    baseline = time.perf_counter() - started
    print(f"baseline: q1 alone, serially in one process: {baseline:.1f} s")

    executor = LocalExecutor(2)
    started = time.perf_counter()
    try:
        _, summary = compare(rec, DEFAULT_MODELS, config, executor)
    finally:
        executor.close()
    wall = time.perf_counter() - started
    print(f"compare, {len(DEFAULT_MODELS)} models on 2 processes: {wall:.1f} s "
          f"= {wall / TARGET_SECONDS:.2f} x the 15-minute target")
    print(f"parallel efficiency vs the baseline: {len(DEFAULT_MODELS) * baseline / (2 * wall):.2f}")
    print(f"ranking {summary['ranking']}; load at the end {os.getloadavg()}")
    tables.record(baseline_seconds=baseline, wall_seconds=wall, target_seconds=TARGET_SECONDS,
                  parallel_efficiency=len(DEFAULT_MODELS) * baseline / (2 * wall), ranking=summary["ranking"])

    return 0


if __name__ == "__main__":
    sys.exit(tables.run("compare", main))
