"""Benchmark: ``diagnose`` without ``--model``, fitting its baseline models (the baseline path)
against reading them from a comparison of the recording already run (``--from-comparison``).

    python benchmarks/from_comparison.py [--processes P] [--fs HZ] [--duration S] [--max-frequency HZ]
                                         [--k-theta N_M_PER_RAD]

on a two-sensor hammer test made by the independent reference simulator (tests/reference): the
paper's beam (beam.toml's modulus 7 % above the truth), q3 damping (gamma 0.2, a 0.03, b 0.2), a
Gaussian hammer pulse at 0.6 m, accelerometers at the tip and at mid-span, 4 s at 4096 Hz, 1.5 %
sensor and 1 % force noise (tests/acceptance/cases.py's "rich" setting with a second sensor),
fitted to 150 Hz. First ``compare`` of the five default models runs twice, on the full path
(benchmarks/compare.py's baseline: cubic splines, every repeat, three accepted SMC moves per
particle) and with the defaults, whose folder is written (what the user has already done); then,
in the same process with the same seeds, the diagnosis that compares the default models itself,
and the one that reads them from that folder. Printed: each wall time, the savings and the
ratios, and whether the two rankings and the two diagnoses agree (baseline, its log evidence,
added effects, final model, unexplained).
``--k-theta`` conceals a root spring of that stiffness in the recording (the diagnosis then has
an effect to find, fit and re-check the damping models with; its result is kept as
``from_comparison_root_spring``).
Targets on two cores: the comparison in 120 s, the diagnosis from it in 300 s.
"""
from __future__ import annotations

import argparse
import os
import platform
import sys
import tempfile
import time

import tables  # benchmarks/tables.py: the script's folder is first on sys.path
from compare import full_path  # benchmarks/compare.py

from bayesbeam.comparison import DEFAULT_MODELS, CompareConfig, compare
from bayesbeam.diagnosis import DiagnoseConfig, diagnose
from bayesbeam.executors import LocalExecutor, SerialExecutor
from bayesbeam.inference.fit import FitConfig
from bayesbeam.io import Sensor
from bayesbeam.report.compare_outputs import write_comparison
from tests.acceptance import cases as ac
from tests.reference import record

#: wall-time targets on two cores (s): the comparison, and the diagnosis that reads it
TARGET_SECONDS = {"compare": 120.0, "diagnose": 300.0}


def two_sensor_hammer(fs: float, duration: float, k_theta: float = 0.0):
    """The reference simulator's q3 hammer test of the paper beam, read at the tip and at mid-span;
    with a root spring of ``k_theta`` (N m/rad) when it is above 0."""
    s = ac._setting("rich")
    beam = s["beam"]
    sensors = (Sensor("accel_tip", beam.length, "acceleration", "accel_tip"),
               Sensor("accel_mid", 0.5 * beam.length, "acceleration", "accel_mid"))
    return record(ac._nominal(beam), ac.DAMPING["rich"]["q3"], EI=beam.nominal_EI, excitation=s["excitation"],
                  fs=fs, duration=duration, sensors=sensors, noise=s["noise"], seed=1, numerics=s["numerics"],
                  effects={"k_theta": k_theta} if k_theta > 0 else None)


def executor(processes: int):
    return SerialExecutor() if processes == 1 else LocalExecutor(processes)


def timed(job, processes: int):
    """(job(executor)'s result, wall time in s)."""
    pool = executor(processes)
    started = time.perf_counter()
    try:
        result = job(pool)
    finally:
        pool.close()
    return result, time.perf_counter() - started


def parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--processes", type=int, default=2, help="worker processes (1: serial, in this process)")
    parser.add_argument("--fs", type=float, default=4096.0, help="sampling rate of the recording (Hz)")
    parser.add_argument("--duration", type=float, default=4.0, help="length of the recording (s)")
    parser.add_argument("--max-frequency", type=float, default=150.0, help="top of the fitted band (Hz)")
    parser.add_argument("--k-theta", type=float, default=0.0, help="a root spring concealed in the recording (N m/rad; "
                                                                   "0: none)")
    parser.add_argument("--tables", action="store_true", help="only re-render README.md's block from "
                                                              "benchmarks/results/from_comparison.json")
    return parser


def agree(a, b) -> bool:
    """Two diagnoses (diagnosis.json's content) agree: baseline and its log evidence, added effects,
    final model and the verdict on what is unexplained."""
    return (a["baseline"]["model"] == b["baseline"]["model"] and a["baseline"]["log_evidence"] == b["baseline"]["log_evidence"]
            and a["added"] == b["added"] and a["final"]["model"] == b["final"]["model"]
            and a["unexplained"] == b["unexplained"])


def main(argv=None) -> int:
    args = parser().parse_args(argv)
    started = time.perf_counter()
    rec = two_sensor_hammer(args.fs, args.duration, args.k_theta)
    config = DiagnoseConfig(CompareConfig(FitConfig(max_frequency=args.max_frequency)))
    print(f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores, load {os.getloadavg()}")
    print(f"reference q3 hammer test, accelerometers at tip and mid-span: {rec.n_samples} samples at {rec.fs:g} Hz "
          f"({rec.n_samples / rec.fs:g} s, made in {time.perf_counter() - started:.0f} s); band {args.max_frequency:g} Hz; "
          f"{f'root spring {args.k_theta:g} N m/rad concealed; ' if args.k_theta > 0 else ''}"
          f"{args.processes} process(es)")
    (_, full_path_summary), full_compare_wall = timed(lambda pool: compare(rec, DEFAULT_MODELS, full_path(config.compare), pool),
                                         args.processes)
    print(f"compare, five default models, full path: {full_compare_wall:.1f} s; ranking {full_path_summary['ranking']}")
    (results, summary), compare_wall = timed(lambda pool: compare(rec, DEFAULT_MODELS, config.compare, pool), args.processes)
    folder = tempfile.mkdtemp(prefix="from_comparison_")
    write_comparison(results, summary, folder)
    print(f"compare, five default models: {compare_wall:.1f} s; ranking {summary['ranking']}; "
          f"ratio {full_compare_wall / compare_wall:.2f}; target {TARGET_SECONDS['compare']:.0f} s")
    outcomes = {}
    for name, source in (("fitting the baseline", None), ("--from-comparison", folder)):
        d, wall = timed(lambda pool, source=source: diagnose(rec, None, config, pool, from_comparison=source),
                        args.processes)
        outcomes[name] = (d.to_dict(), wall)
        s = outcomes[name][0]
        print(f"diagnose, {name}: {wall:.1f} s; baseline {s['baseline']['model']} (log Z {s['baseline']['log_evidence']:.2f}), "
              f"added {s['added'] or 'nothing'}, final {s['final']['model']}, unexplained {s['unexplained']}; "
              f"load {os.getloadavg()}")
    (full, full_wall), (reused, reused_wall) = outcomes.values()
    same = agree(full, reused)
    print(f"saving {full_wall - reused_wall:.1f} s ({(full_wall - reused_wall) / full_wall:.0%} of the diagnosis; "
          f"the comparison alone took {compare_wall:.1f} s); ratio {full_wall / reused_wall:.2f}; "
          f"diagnoses {'agree' if same else 'DIFFER'}; target {TARGET_SECONDS['diagnose']:.0f} s")
    tables.record(compare_seconds=compare_wall, baseline_seconds=full_wall, current_seconds=reused_wall,
                  wall_ratio=full_wall / reused_wall, saving_seconds=full_wall - reused_wall, diagnoses_agree=same,
                  target_seconds=TARGET_SECONDS["diagnose"], compare_baseline_seconds=full_compare_wall,
                  compare_current_seconds=compare_wall, compare_wall_ratio=full_compare_wall / compare_wall,
                  compare_target_seconds=TARGET_SECONDS["compare"],
                  compare_rankings_agree=full_path_summary["ranking"] == summary["ranking"])
    return 0


if __name__ == "__main__":
    sys.exit(tables.run("from_comparison_root_spring" if "--k-theta" in sys.argv else "from_comparison", main))
