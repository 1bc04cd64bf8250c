"""Benchmark: ERA in the posterior predictive check, leading singular triplets against the full SVD.

    OPENBLAS_NUM_THREADS=1 python benchmarks/ppc.py          # one to two minutes on one core

``posterior_predictive_check`` identifies the modes of every replicated recording (100 per
model) and of the measured one by ERA at order 2 m + 8 (m = the model's modes below 0.9 of the
band's top). ERA needs only that many leading singular triplets of the Hankel matrix;
``era_modes(..., truncated=True)`` computes just those from the Gram matrix
(:func:`bayesbeam.modal.era.hankel_svd` with ``rank``), ``truncated=False`` takes the full SVD,
the baseline, timed in the same run.

On ``data/examples/paper_q3_hammer`` at ``--max-frequency 150`` (decimated by 5), q3 at N = 16,
draws from the Laplace approximation at the optimum. Table 1: ``era_modes`` on the measured
decay and on 20 replicates (CPU ms per call, best of 3, one thread), the largest relative
differences of the identified frequencies and damping ratios from the full SVD (numpy's gesdd),
of the truncated path and of the full SVD by LAPACK's gesvd (the baseline's own round-off scale),
and whether both paths find the same modes. Table 2: one ``posterior_predictive_check`` (100 replicates, the same
seed) with each path: CPU seconds, the largest difference of any p-value, and the five largest
internal times of a cProfile of each. Table 3: the measured frequencies and damping ratios of
the committed comparisons (``measured_frequency_hz`` / ``measured_damping_ratio`` of every model's
mode table), recomputed on each study's recording with its window and band and the model's
committed mode frequencies, by both paths: the largest relative difference from the committed
numbers.
"""
from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse
import contextlib
import json
import platform
import sys
import time
from pathlib import Path

import numpy as np
import scipy.linalg
import tables  # benchmarks/tables.py: the script's folder is first on sys.path
from batch import best_time, top_entries  # benchmarks/batch.py's CPU timer and profile summary

from bayesbeam.checks.ppc import decay_start, era_modes, modes_in_band, posterior_predictive_check
from bayesbeam.inference.fit import FitConfig, prepare
from bayesbeam.inference.sampler import find_optimum
from bayesbeam.io import load_recording

ROOT = Path(__file__).resolve().parents[1]
EXAMPLE = ROOT / "data" / "examples" / "paper_q3_hammer"
#: committed comparisons whose measured modes table 3 recomputes, and the settings they were run with
STUDIES = {
    "model_comparison/paper_q3_hammer": FitConfig(max_frequency=150.0),
    "model_comparison/alu_q1_release": FitConfig(max_frequency=150.0),
    "model_comparison/paper_rootcomp_hammer": FitConfig(max_frequency=150.0),
    **{f"real_steel_cantilever/{name}": FitConfig(start=1.12, stop=5.12, max_frequency=150.0)
       for name in ("compare", "compare_n24", "compare_clamp", "compare_structure")},
}
PATHS = {"full SVD": False, "truncated": True}


def relative_difference(a: np.ndarray, b: np.ndarray) -> float:
    """Largest |a - b| / |b| where both are finite (0 if none are)."""
    ok = np.isfinite(a) & np.isfinite(b)
    return float(np.max(np.abs(a[ok] - b[ok]) / np.abs(b[ok]), initial=0.0))


def same_modes(a: np.ndarray, b: np.ndarray) -> bool:
    return bool(np.array_equal(np.isfinite(a), np.isfinite(b)))


def replicates(post, draws, rng, count: int) -> list[np.ndarray]:
    lik = post.likelihood
    out = []
    for theta in draws[:count]:
        params, noise = post.split(theta)
        clean = lik.predict(params, noise)
        out.append(clean + lik.draw_noise(noise, clean.shape, rng))
    return out


@contextlib.contextmanager
def gesvd_full_svd():
    """The full-SVD path through LAPACK's gesvd instead of numpy's gesdd: how much the baseline's
    own answers move with the SVD algorithm, the scale the truncated path's differences are read on."""
    numpy_svd = np.linalg.svd
    np.linalg.svd = lambda a, full_matrices=True: scipy.linalg.svd(a, full_matrices=full_matrices,
                                                                    lapack_driver="gesvd")
    try:
        yield
    finally:
        np.linalg.svd = numpy_svd


def era_table(post, draws) -> dict:
    """Table 1: era_modes on the measured decay and 20 replicates, both paths."""
    lik = post.likelihood
    rec, proj = lik.model.recording, lik.projection
    start = decay_start(rec, proj)
    f_model = modes_in_band(lik.model, post, draws, proj.max_frequency)
    signals = [rec.signals, *replicates(post, draws, np.random.default_rng(3), 20)]
    results = {label: np.array([era_modes(y, rec.dt, start, proj.i1, f_model, flag) for y in signals])
               for label, flag in PATHS.items()}
    ms = {label: 1e3 * best_time(lambda flag=flag: [era_modes(y, rec.dt, start, proj.i1, f_model, flag)
                                                     for y in signals]) / len(signals)
          for label, flag in PATHS.items()}
    with gesvd_full_svd():
        gesvd = np.array([era_modes(y, rec.dt, start, proj.i1, f_model, False) for y in signals])
    full, fast = results["full SVD"], results["truncated"]
    print(f"Table 1: era_modes on the measured decay and 20 replicates ({proj.i1 - start} samples, "
          f"order {2 * len(f_model) + 8}), CPU ms per call, best of 3")
    print(f"{'full SVD':>10}{'truncated':>11}{'ratio':>8}   max rel diff f, zeta from the full SVD (gesdd):"
          f" truncated, full by gesvd; same modes")
    diff_f, diff_z = relative_difference(fast[..., 0], full[..., 0]), relative_difference(fast[..., 1], full[..., 1])
    print(f"{ms['full SVD']:10.2f}{ms['truncated']:11.2f}{ms['truncated'] / ms['full SVD']:8.3f}"
          f"   {diff_f:.1e}, {diff_z:.1e}; {relative_difference(gesvd[..., 0], full[..., 0]):.1e}, "
          f"{relative_difference(gesvd[..., 1], full[..., 1]):.1e}; {same_modes(fast, full)}")
    return {"era_ms": ms, "era_max_rel_diff_frequency": diff_f, "era_max_rel_diff_damping": diff_z}


def check_table(post, draws) -> dict:
    """Table 2: one posterior predictive check (100 replicates) with each path, the same seed."""
    checks, seconds = {}, {}
    for label, flag in PATHS.items():
        start = time.process_time()
        checks[label] = posterior_predictive_check(post, draws, np.random.default_rng(2), truncated_era=flag)
        seconds[label] = time.process_time() - start
    p = {label: np.array([v["p_value"] if v["p_value"] is not None else np.nan
                          for v in check.statistics.values()]) for label, check in checks.items()}
    diff_p = float(np.nanmax(np.abs(p["truncated"] - p["full SVD"]), initial=0.0))
    modes = {label: np.stack([check.modes["rep_f"], check.modes["rep_zeta"]], axis=-1)
             for label, check in checks.items()}
    print("\nTable 2: one posterior_predictive_check, 100 replicates, CPU s")
    print(f"{'full SVD':>10}{'truncated':>11}{'ratio':>8}{'max |diff p|':>14}{'max rel diff f, zeta':>23}")
    diff_modes = relative_difference(modes["truncated"], modes["full SVD"])
    print(f"{seconds['full SVD']:10.2f}{seconds['truncated']:11.2f}{seconds['truncated'] / seconds['full SVD']:8.3f}"
          f"{diff_p:14.1e}{diff_modes:23.1e}")
    for label, flag in PATHS.items():
        print(f"\n{label}: largest internal times of one check")
        entries = top_entries(lambda flag=flag: posterior_predictive_check(post, draws, np.random.default_rng(2),
                                                                           truncated_era=flag))
        print("\n".join(f"   {row}" for row in entries))
    return {"check_seconds": seconds, "check_max_abs_diff_p": diff_p, "check_max_rel_diff_modes": diff_modes}


def committed_modes(summary: dict) -> list[tuple[np.ndarray, np.ndarray]]:
    """Per model: its mode frequencies and the committed measured (f, zeta) per mode, NaN where None."""
    out = []
    for model in summary["models"].values():
        rows = model.get("modes") or []
        f_model = np.array([row["model_frequency_hz"] for row in rows])
        measured = np.array([[np.nan if row[k] is None else row[k]
                              for k in ("measured_frequency_hz", "measured_damping_ratio")] for row in rows])
        out.append((f_model, measured.reshape(-1, 2)))
    return out


def study_table() -> dict:
    """Table 3: the committed comparisons' measured modes, recomputed by both paths."""
    print("\nTable 3: measured modes of the committed comparisons, recomputed; max relative difference from "
          "the committed numbers")
    print(f"{'comparison':<42}{'values':>7}{'full SVD':>11}{'truncated':>11}{'same modes':>12}")
    worst = {label: 0.0 for label in PATHS}
    for name, config in STUDIES.items():
        summary = json.loads((ROOT / "studies" / name / "comparison.json").read_text())
        problem = prepare(load_recording(ROOT / summary["recording"]), "q1", config, 8)
        rec, proj = problem.model.recording, problem.likelihood.projection
        start = decay_start(rec, proj)
        diffs, same, count = {label: 0.0 for label in PATHS}, True, 0
        for f_model, measured in committed_modes(summary):
            count += 2 * len(f_model)
            for label, flag in PATHS.items():
                found = era_modes(rec.signals, rec.dt, start, proj.i1, f_model, flag)
                diffs[label] = max(diffs[label], relative_difference(found, measured))
                same &= same_modes(found, measured)
        for label in PATHS:
            worst[label] = max(worst[label], diffs[label])
        print(f"{name:<42}{count:7d}{diffs['full SVD']:11.1e}{diffs['truncated']:11.1e}{same!s:>12}")
    return {"studies_max_rel_diff": worst}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--tables", action="store_true", help="only re-render README.md's block from benchmarks/results/ppc.json")
    parser.parse_args(argv)
    print(f"bayesbeam ppc benchmark; {platform.processor() or platform.machine()}, {os.cpu_count()} cores; "
          f"load at start {tuple(round(x, 2) for x in os.getloadavg())}")
    post = prepare(load_recording(EXAMPLE), "q3", FitConfig(max_frequency=150.0), 16).posterior
    optimum = find_optimum(post, np.random.default_rng(1))
    draws = np.random.default_rng(1).multivariate_normal(optimum.theta, optimum.covariance, 400)
    print("paper_q3_hammer, q3, N = 16, 150 Hz; draws: Laplace at the optimum\n")
    measured = {**era_table(post, draws), **check_table(post, draws), **study_table()}
    print(f"\nload at end {tuple(round(x, 2) for x in os.getloadavg())}")
    tables.record(**measured)
    return 0


if __name__ == "__main__":
    sys.exit(tables.run("ppc", main))
