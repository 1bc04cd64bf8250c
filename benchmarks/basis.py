#!/usr/bin/env python
"""Spline degree benchmark: degrees of freedom and time per simulate at equal accuracy, cubic
against quintic B-splines.

    python benchmarks/basis.py            # about a minute on one core
    python benchmarks/basis.py --wall     # wall time instead of process CPU time

Table 1, accuracy per degree of freedom: the fewest degrees of freedom (N + p - 2) at which
every natural frequency below a band's top errs by less than 1e-3 and 1e-4 (relative), against
the analytic roots of the clamped-free frequency equation with the tip body
(:func:`bayesbeam.modal.eigen.tip_body_betas`), for the paper's beam (no tip body) and the
aluminium strip of ``data/examples/alu_q1_release`` (tip block).

Table 2, cost at equal accuracy: ``model.simulate`` on ``data/examples/paper_q3_hammer`` (4 s at
2048 Hz) for q1, q2 and q3 at the parameters of benchmarks/forward.py. The in-band error is
||P(y_N - y_ref)|| / ||P y_ref|| with P the projection onto the band below 0.38 fs (the default
fitting band) and y_ref the quintic at N = 64, whose own distance from N = 48 is printed. Times
are the best of 7 batches of about 50 ms, one thread. Table 3 picks, for each target error,
the cheapest N of each degree that meets it and the ratio cubic/quintic of their times, all
measured in this run.
"""
import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_var] = "1"          # one core, before numpy is imported

import argparse
import time
from pathlib import Path

import numpy as np

from bayesbeam import BeamModel, load_recording
from bayesbeam.modal.eigen import tip_body_betas
from bayesbeam.physics.assembly import BeamOperators
from bayesbeam.physics.basis import SplineBasis
from bayesbeam.response.system import undamped_modes

EXAMPLES = Path(__file__).resolve().parents[1] / "data" / "examples"
DEGREES = (3, 5)
TOLERANCES = (1e-3, 1e-4)
#: spline intervals tried per degree in table 2
GRIDS = {3: (16, 24, 32, 48, 64, 96, 128, 160), 5: (8, 12, 16, 20, 24, 32)}
REFERENCE = (5, 64)
CHECK = (5, 48)
TARGETS = (1e-2, 1e-3)
PARAMS = {
    "q1": {"EI": 44.28, "gamma": 0.12, "cdI": 2e-5},
    "q2": {"EI": 44.28, "alpha": 0.05, "beta": 20.0},
    "q3": {"EI": 44.28, "gamma": 0.12, "a": 0.025, "b": 0.18},
}
BAND = 0.38


# ----------------------------------------------------------------------------- table 1
def exact_frequencies(rec, n_modes: int) -> np.ndarray:
    """Natural frequencies (Hz) of the continuous beam with the recording's tip body."""
    beam, tip = rec.beam, rec.tip
    betas = tip_body_betas(n_modes, rho_a=beam.rho_a, length=beam.length, m_T=tip.mass, J=tip.rotary_inertia)
    return (betas / beam.length) ** 2 * np.sqrt(beam.nominal_EI / beam.rho_a) / (2 * np.pi)


def galerkin_frequencies(rec, n_intervals: int, degree: int) -> np.ndarray:
    beam, tip = rec.beam, rec.tip
    ops = BeamOperators(SplineBasis(beam.length, n_intervals, degree=degree), beam.rho_a,
                        tip.mass, tip.rotary_inertia)
    lam, _ = undamped_modes(beam.nominal_EI * ops.K0, ops.M)
    return np.sqrt(lam) / (2 * np.pi)


def dofs_needed(rec, exact: np.ndarray, degree: int, tol: float) -> int | None:
    """Fewest degrees of freedom at which every frequency in ``exact`` errs by less than ``tol``."""
    for n in range(2, 200):
        f = galerkin_frequencies(rec, n, degree)
        if f.size >= exact.size and np.max(np.abs(f[:exact.size] / exact - 1)) < tol:
            return n + degree - 2
    return None


def table_accuracy_per_dof():
    print("Table 1: degrees of freedom for every mode below the band's top within the tolerance")
    print(f"{'beam':<26}{'band (Hz)':>10}{'modes':>7}" + "".join(
        f"{f'p={p} {tol:g}':>13}" for tol in TOLERANCES for p in DEGREES))
    for name, label in (("paper_q3_hammer", "paper beam, no tip body"), ("alu_q1_release", "alu strip, tip block")):
        rec = load_recording(EXAMPLES / name)
        every = exact_frequencies(rec, 30)
        for top in (150.0, 400.0, BAND * 2048, BAND * 4096):
            exact = every[every < top]
            cells = [dofs_needed(rec, exact, p, tol) for tol in TOLERANCES for p in DEGREES]
            print(f"{label:<26}{top:>10.0f}{exact.size:>7}" + "".join(f"{c if c else '>200':>13}" for c in cells))
    print()


# ----------------------------------------------------------------------------- tables 2, 3
def timer(wall: bool):
    return time.perf_counter if wall else time.process_time


def ms_per_call(fn, clock) -> float:
    fn()
    best = np.inf
    for _ in range(7):
        start, calls = clock(), 0
        while clock() - start < 0.05:
            fn()
            calls += 1
        best = min(best, (clock() - start) / calls)
    return 1e3 * best


def in_band(rec):
    keep = np.fft.rfftfreq(rec.n_samples, rec.dt) < BAND * rec.fs

    def project(y):
        spec = np.fft.rfft(y, axis=0)
        spec[~keep] = 0
        return np.fft.irfft(spec, rec.n_samples, axis=0)

    return project


def table_cost(wall: bool):
    rec = load_recording(EXAMPLES / "paper_q3_hammer")
    project, clock = in_band(rec), timer(wall)
    print(f"Table 2: in-band error and {'wall' if wall else 'CPU'} ms per simulate on paper_q3_hammer "
          f"(reference: degree {REFERENCE[0]}, N = {REFERENCE[1]})")
    print(f"{'model':<6}{'degree':>7}{'N':>5}{'dofs':>6}{'error':>11}{'ms':>9}")
    rows = []
    for model_name, params in PARAMS.items():
        ref = project(BeamModel(rec, model_name, REFERENCE[1], degree=REFERENCE[0]).simulate(params))
        norm = np.linalg.norm(ref)
        check = project(BeamModel(rec, model_name, CHECK[1], degree=CHECK[0]).simulate(params))
        print(f"{model_name:<6} reference moves by {np.linalg.norm(check - ref) / norm:.1e} from "
              f"degree {CHECK[0]}, N = {CHECK[1]}")
        for degree in DEGREES:
            for n in GRIDS[degree]:
                model = BeamModel(rec, model_name, n, degree=degree)
                error = np.linalg.norm(project(model.simulate(params)) - ref) / norm
                ms = ms_per_call(lambda m=model, p=params: m.simulate(p), clock)
                rows.append((model_name, degree, n, model.ops.size, error, ms))
                print(f"{model_name:<6}{degree:>7}{n:>5}{model.ops.size:>6}{error:>11.2e}{ms:>9.3f}")
    print()
    print("Table 3: the cheapest N per degree within the target in-band error, and the time ratio")
    print(f"{'model':<6}{'target':>8}{'cubic N':>9}{'ms':>8}{'quintic N':>11}{'ms':>8}{'cubic/quintic':>15}")
    for model_name in PARAMS:
        for target in TARGETS:
            best = {}
            for degree in DEGREES:
                ok = [r for r in rows if r[0] == model_name and r[1] == degree and r[4] < target]
                best[degree] = min(ok, key=lambda r: r[5]) if ok else None
            cubic, quintic = best[3], best[5]
            cells = [f"{r[2]:>d}" if r else f">{GRIDS[d][-1]}" for d, r in ((3, cubic), (5, quintic))]
            times = [f"{r[5]:.3f}" if r else "-" for r in (cubic, quintic)]
            ratio = f"{cubic[5] / quintic[5]:.1f}" if cubic and quintic else "-"
            print(f"{model_name:<6}{target:>8g}{cells[0]:>9}{times[0]:>8}{cells[1]:>11}{times[1]:>8}{ratio:>15}")


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--wall", action="store_true", help="wall time instead of process CPU time")
    parser.add_argument("--tables", action="store_true",
                        help="only re-render README.md's block from benchmarks/results/basis.json")
    args = parser.parse_args(argv)
    print(f"load average {os.getloadavg()[0]:.1f}")
    table_accuracy_per_dof()
    table_cost(args.wall)
    print(f"load average {os.getloadavg()[0]:.1f}")
    return 0


if __name__ == "__main__":
    import sys

    import tables

    sys.exit(tables.run("basis", main))
