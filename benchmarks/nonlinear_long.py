#!/usr/bin/env python
"""Benchmark: the stick-slip (dry friction) forward model on a long record, against the linear one.

    OPENBLAS_NUM_THREADS=1 python benchmarks/nonlinear_long.py             # simulations, ~1 minute
    OPENBLAS_NUM_THREADS=1 python benchmarks/nonlinear_long.py --compare   # and one compare (minutes)
    OPENBLAS_NUM_THREADS=1 python benchmarks/nonlinear_long.py --diagnose  # and two blind diagnoses (~40 min)

The record: the independent reference simulator's release of the paper's beam (q1 damping, 1 N
tip load let go at t = 0) with 20 mN of Coulomb friction at the tip, 8 s at 2048 Hz, one tip
displacement channel, 2 % sensor noise. It is prepared as ``bayesbeam compare --max-frequency
150`` prepares it (decimated by 5 to 409.6 Hz; N the fit's starting rung). Timed in the same run
(process CPU time, best of 3 batches of 10 calls, each call at a new EI so that nothing is reused
from the call before, as in a sampler): ``model.simulate`` of q1+dry_friction at the truth's
damping and five values of F_c (from a tip that slides throughout to one held most of the record:
F_c half the 1 N tip load), and of the linear q1 model, the baseline; the ratio
nonlinear / linear is printed, and the friction model's time at :data:`COARSE_SUBSTEPS` fine
steps per sample beside the default's. With ``--compare``: one ``bayesbeam.comparison.compare`` of
q1+dry_friction with the default settings (2 SMC repeats) on a serial executor, its wall time and
the number of simulations it ran. With ``--diagnose``: the blind diagnosis of the record (no
``--model``: the default damping models compared, the whole catalogue screened, the damping
re-checked) on two local processes, against the target of :data:`TARGET_SECONDS` on two idle
cores, and the same diagnosis with the catalogue's nonlinear effects left out, the baseline in
the same run: their ratio is what the nonlinear candidates cost on a record of this length.
"""
from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse
import sys
import time

import _common as c
import tables  # benchmarks/tables.py: puts the working tree first on sys.path
from diagnose import timed_diagnose

from bayesbeam.comparison import CompareConfig, compare
from bayesbeam.diagnosis import DiagnoseConfig
from bayesbeam.inference.fit import FitConfig, prepare, starting_rung
from bayesbeam.io import Sensor
from bayesbeam.physics.effects import REGISTRY
from bayesbeam.response import nonlinear
from tests.acceptance.cases import _nominal
from tests.inference.cases import EI_TRUE, PAPER_BEAM
from tests.reference import Noise, Release, record
from tests.reference.recordings import PAPER_DAMPING

F_C_TRUE = 0.02
#: F_c values timed (N): sliding throughout, the truth's neighbourhood, and half the tip load (F_c
#: equal to the load itself is a tie that round-off decides: from 2 to thousands of sticks as EI
#: moves by 1e-6)
F_C_VALUES = (1e-4, 5e-3, F_C_TRUE, 0.1, 0.5)
BAND = 150.0
#: fine steps per sample timed beside the default (nonlinear.SUBSTEPS): the step whose likelihood
#: jitter stalls the samplers on this record (bayesbeam.response.nonlinear's docstring)
COARSE_SUBSTEPS = 8
#: the blind diagnosis of this record on two idle cores (s)
TARGET_SECONDS = 600.0


def long_release():
    """The 8 s, 2048 Hz friction release of the module docstring (reference simulator)."""
    return record(_nominal(PAPER_BEAM), PAPER_DAMPING["q1"], EI=EI_TRUE, excitation=Release(1.0), fs=2048,
                  duration=8, sensors=(Sensor("disp_tip", 1.0, "displacement", "disp_tip"),),
                  effects={"F_c": F_C_TRUE}, noise=Noise(sensor=0.02), seed=1)


def per_call(simulate, params: dict, number: int = 10, repeat: int = 3) -> float:
    """Best over ``repeat`` batches of the CPU seconds per ``simulate(params)``, each call at a new EI."""
    calls = iter(range(10**6))

    def call():
        simulate({**params, "EI": params["EI"] * (1 + 1e-6 * next(calls))})
    call()
    return c.best_time(call, number, repeat)


def simulations(rec, config: FitConfig) -> None:
    n = starting_rung(rec, "q1", config)
    friction = prepare(rec, "q1", config, n).model
    linear = prepare(rec, "q1", FitConfig(max_frequency=BAND), n).model
    truth = {"EI": EI_TRUE, **PAPER_DAMPING["q1"]}
    base = per_call(linear.simulate, truth)
    print(f"model.simulate at N = {n} ({friction.recording.n_samples} samples at {friction.recording.fs:.6g} Hz):")
    print(f"q1 (linear, baseline): {1e3 * base:.2f} ms")
    print(f"| F_c (N) | stick / slip / reversal events | q1+dry_friction (ms) | ratio to q1 | at U = {COARSE_SUBSTEPS} (ms) |")
    print("|---|---|---|---|---|")
    for F_c in F_C_VALUES:
        params = {**truth, "F_c": F_c}
        events = nonlinear.integrate(friction, params, record=True).record["events"]
        seconds = per_call(friction.simulate, params)
        coarse = per_call(lambda p: nonlinear.integrate(friction, p, substeps=COARSE_SUBSTEPS), params)
        print(f"| {F_c:g} | {events['stick']} / {events['slip']} / {events['reversal']} | {1e3 * seconds:.2f} | "
              f"{seconds / base:.1f} | {1e3 * coarse:.2f} |")
        tables.record(**{f"simulate_ms_F_c_{F_c:g}": 1e3 * seconds, f"simulate_ms_coarse_F_c_{F_c:g}": 1e3 * coarse})
    tables.record(n_intervals=n, linear_simulate_ms=1e3 * base)


def one_compare(rec, config: FitConfig) -> None:
    """One compare of q1+dry_friction (default settings, serial), counting the simulations it runs."""
    count = [0]
    integrate = nonlinear.integrate

    def counted(*args, **kwargs):
        count[0] += 1
        return integrate(*args, **kwargs)
    nonlinear.integrate = counted
    try:
        started = time.perf_counter()
        results, _ = compare(rec, models=("q1+dry_friction",), config=CompareConfig(config, repeats=2))
        seconds = time.perf_counter() - started
    finally:
        nonlinear.integrate = integrate
    print(f"compare {', '.join(results)} (2 SMC repeats, serial): {seconds:.1f} s wall, {count[0]} simulations, "
          f"{1e3 * seconds / max(count[0], 1):.1f} ms per simulation overall")
    tables.record(compare_seconds=seconds, compare_simulations=count[0])


def one_diagnosis(rec) -> None:
    """The blind diagnosis with the whole catalogue, and without its nonlinear effects (the baseline)."""
    linear = tuple(name for name, effect in REGISTRY.items() if effect.linear)
    times = {}
    for name, catalogue in (("linear catalogue (baseline)", linear), ("whole catalogue", None)):
        config = DiagnoseConfig(CompareConfig(FitConfig(max_frequency=BAND)), catalogue=catalogue)
        summary, times[name] = timed_diagnose(rec, None, config)
        print(f"diagnose, {name}: {times[name]:.1f} s wall (2 processes); baseline {summary['baseline']['model']}, "
              f"added {', '.join(summary['added']) or 'nothing'}, final {summary['final']['model']}, unexplained "
              f"{summary['unexplained']}; load {os.getloadavg()}")
    whole, base = times["whole catalogue"], times["linear catalogue (baseline)"]
    print(f"ratio whole / linear catalogue: {whole / base:.2f}; whole = {whole / TARGET_SECONDS:.2f} x the "
          f"{TARGET_SECONDS:g} s target")
    tables.record(diagnose_seconds=whole, diagnose_linear_seconds=base, diagnose_target_seconds=TARGET_SECONDS,
                  diagnose_added=summary["added"], diagnose_final=summary["final"]["model"])


def main(argv: list[str]) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--compare", action="store_true", help="also time one compare of q1+dry_friction")
    parser.add_argument("--diagnose", action="store_true",
                        help="also time the blind diagnosis, with the whole catalogue and with its linear effects")
    args = parser.parse_args(argv)
    print(f"{c.machine()}; load {os.getloadavg()}")
    rec = long_release()
    print(f"record: reference friction release (F_c = {F_C_TRUE} N), {rec.n_samples} samples at {rec.fs:g} Hz; "
          f"band {BAND:g} Hz")
    config = FitConfig(max_frequency=BAND, effects=("dry_friction",))
    simulations(rec, config)
    if args.compare:
        one_compare(rec, FitConfig(max_frequency=BAND))
    if args.diagnose:
        one_diagnosis(rec)
    return 0


if __name__ == "__main__":
    sys.exit(tables.run("nonlinear_long", main))
