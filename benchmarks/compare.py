"""Benchmark: ``compare`` of the five default models on two processes, current settings against
the full path (every repeat of every model, three accepted SMC moves per particle).

    python benchmarks/compare.py [--max-frequency HZ] [--repeats R]

on ``data/examples/paper_q3_hammer`` (4 s at 2048 Hz, the paper's beam, q3 damping). Both paths run
in the same process one after the other, with the same seeds: the **baseline** with
``early_stop=None, min_moved=None``, then the defaults (repeats of decisively beaten models
skipped, :func:`bayesbeam.comparison.beaten`) or, with ``--min-moved P``, the defaults with SMC
mutation steps from the acceptance rate (:data:`bayesbeam.comparison.MIN_MOVED`). Printed: wall time
and SMC likelihood evaluations of each
and their ratios (evaluations do not depend on the machine's load, wall time does), each model's
log evidence under both with the difference in combined standard errors, and whether the
rankings agree. The optimisation and the checks are the same on both paths.
Targets: 20 s at 150 Hz, 120 s at the default band (0.38 fs), on two cores.
"""
from __future__ import annotations

import argparse
import os
import platform
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np
import tables  # benchmarks/tables.py: the script's folder is first on sys.path

from bayesbeam.comparison import DEFAULT_MODELS, CompareConfig, compare
from bayesbeam.executors import LocalExecutor
from bayesbeam.inference.fit import FitConfig
from bayesbeam.io import load_recording

EXAMPLE = Path(__file__).resolve().parents[1] / "data" / "examples" / "paper_q3_hammer"
#: wall-time targets on two cores (s): at 150 Hz, and at the default band
TARGET_SECONDS = {150.0: 20.0, None: 120.0}


def timed_compare(rec, config: CompareConfig) -> tuple[dict, float]:
    """(compare's summary, wall time in s) of the default models on two local processes."""
    executor = LocalExecutor(2)
    started = time.perf_counter()
    try:
        _, summary = compare(rec, DEFAULT_MODELS, config, executor)
    finally:
        executor.close()
    return summary, time.perf_counter() - started


def smc_evaluations(summary: dict) -> int:
    """Likelihood evaluations of every SMC run of the comparison, second passes included."""
    def count(evidence):
        return evidence["evaluations"] + (count(evidence["first_pass"]) if "first_pass" in evidence else 0)

    return sum(count(m["evidence"]) for m in summary["models"].values())


def runs(summary: dict) -> int:
    return sum(len(m["evidence"]["repeats"]) for m in summary["models"].values())


def model_table(base: dict, new: dict) -> list[str]:
    head = f"{'model':12s} {'N':>3s} {'baseline log Z':>18s} {'N':>3s} {'current log Z':>18s} {'diff/sd':>8s}"
    lines = [head + "  stopped early"]
    for m in base["ranking"]:
        b, n = base["models"][m], new["models"][m]
        sd = np.hypot(b["log_evidence_sd"], n["log_evidence_sd"])
        stopped = n["evidence"].get("stopped_early", "")
        lines.append(f"{m:12s} {b['n_intervals']:3d} {b['log_evidence']:10.2f} +- {b['log_evidence_sd']:4.2f} "
                     f"{n['n_intervals']:3d} {n['log_evidence']:10.2f} +- {n['log_evidence_sd']:4.2f} "
                     f"{(n['log_evidence'] - b['log_evidence']) / sd:8.2f}  {stopped.split(':')[0]}")
    return lines


def full_path(current: CompareConfig) -> CompareConfig:
    """The baseline of ``current``: cubic splines, every repeat of every model, three accepted SMC
    moves per particle."""
    return replace(current, fit=replace(current.fit, degree=3), early_stop=None, min_moved=None)


def configs(args) -> tuple[CompareConfig, CompareConfig]:
    """(baseline, current) comparison settings of the parsed command line."""
    current = CompareConfig(FitConfig(max_frequency=args.max_frequency, degree=args.degree or FitConfig.degree),
                            repeats=args.repeats)
    if args.min_moved is not None:
        current = replace(current, min_moved=args.min_moved)
    return full_path(current), current


def parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--max-frequency", type=float, default=None,
                        help="top of the fitted band (Hz; default 0.38 fs as in compare)")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--degree", type=int, default=None,
                        help="the current path's spline degree (default: FitConfig's; the baseline keeps cubics)")
    parser.add_argument("--min-moved", type=float, default=None,
                        help="the current path's CompareConfig.min_moved (default: compare's default)")
    parser.add_argument("--tables", action="store_true", help="only re-render README.md's block from benchmarks/results/compare.json")
    return parser


def main(argv=None) -> int:
    args = parser().parse_args(argv)
    rec = load_recording(EXAMPLE)
    baseline, current = configs(args)
    print(f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores, load {os.getloadavg()}")
    print(f"recording {EXAMPLE.name}: {rec.n_samples} samples at {rec.fs:g} Hz; band "
          f"{args.max_frequency or 0.38 * rec.fs:g} Hz; {args.repeats} SMC repeats per model; 2 processes")

    base, base_wall = timed_compare(rec, baseline)
    print(f"baseline (cubic splines, every repeat, three accepted moves per particle): {base_wall:.1f} s, "
          f"{smc_evaluations(base)} SMC evaluations in {runs(base)} runs; load {os.getloadavg()}")
    new, new_wall = timed_compare(rec, current)
    print(f"current (degree {current.fit.degree}, early stop at {current.early_stop:g} nats, min_moved "
          f"{current.min_moved}): {new_wall:.1f} s, "
          f"{smc_evaluations(new)} SMC evaluations in {runs(new)} runs; load {os.getloadavg()}")
    evaluation_ratio = smc_evaluations(base) / smc_evaluations(new)
    print(f"ratio baseline / current: wall time {base_wall / new_wall:.2f}, SMC evaluations {evaluation_ratio:.2f}")
    target = TARGET_SECONDS.get(args.max_frequency)
    if target:
        print(f"current wall time = {new_wall / target:.2f} x the {target:g} s target")
    print("\n".join(model_table(base, new)))
    same = base["ranking"] == new["ranking"]
    print(f"rankings {'agree' if same else 'DIFFER'}: baseline {base['ranking']}, current {new['ranking']}")
    tables.record(baseline_seconds=base_wall, current_seconds=new_wall, wall_ratio=base_wall / new_wall,
                  baseline_smc_evaluations=smc_evaluations(base), current_smc_evaluations=smc_evaluations(new),
                  evaluation_ratio=evaluation_ratio, target_seconds=target, ranking=new["ranking"],
                  rankings_agree=same)
    return 0


if __name__ == "__main__":
    # the default band is kept apart from the 150 Hz run: both have a block in README.md
    sys.exit(tables.run("compare" if "--max-frequency" in sys.argv else "compare_full", main))
