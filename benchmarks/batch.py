"""Benchmark: the log posterior of many parameter sets, evaluated together against one at a time.

    OPENBLAS_NUM_THREADS=1 python benchmarks/batch.py [--sets 64] [--n-intervals 16]

On ``data/examples/paper_q3_hammer`` prepared as ``bayesbeam fit`` prepares it (force noise
marginalised), at ``--max-frequency 150`` (decimated by 5) and at the full default band (0.38 fs),
for q1, q2 and q3 at N = 16: ``LogPosterior.log_prob_batch`` of a cloud of parameter sets (2 %
about the example's truth, noise profiled there: what an emcee half-ensemble or an SMC stage
holds) against ``LogPosterior.__call__`` set by set, the baseline, timed in the same run (best of
3, process CPU time on one thread). The table gives milliseconds per set and the ratio
batched / loop, and the largest relative difference of the two paths' values. Then where the time
goes: the five largest internal times of a cProfile of each path on q3. Last, what a user waits
for: one SMC evidence run per model at 150 Hz (256 particles, from the Laplace reference at an
optimum polished from the truth, the same seed), batched and with ``BAYESBEAM_BATCH=0``: CPU time,
stages, evaluations and log Z of each.
"""
from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse
import cProfile
import json
import platform
import pstats
import sys
import time
from pathlib import Path

import numpy as np
import tables  # benchmarks/tables.py: the script's folder is first on sys.path

from bayesbeam.inference.evidence import laplace_reference, smc
from bayesbeam.inference.fit import FitConfig, prepare
from bayesbeam.inference.posterior import BATCH_VARIABLE
from bayesbeam.inference.sampler import find_optimum
from bayesbeam.io import load_recording

EXAMPLE = Path(__file__).resolve().parents[1] / "data" / "examples" / "paper_q3_hammer"
MODELS = {"q1": {"gamma": 0.12, "cdI": 2e-5}, "q2": {"alpha": 0.05, "beta": 20.0},
          "q3": {"gamma": 0.12, "a": 0.025, "b": 0.18}}
BANDS = {"150 Hz": 150.0, "full (0.38 fs)": None}


def cloud(post, centre: dict, n: int, seed: int) -> np.ndarray:
    noise = post.likelihood.profile_noise(centre)
    rng = np.random.default_rng(seed)
    return np.array([post.coordinates({**{k: v * (1 + 0.02 * rng.standard_normal()) for k, v in centre.items()},
                                       **noise}) for _ in range(n)])


def paths(post, thetas):
    """(the baseline: the log posterior set by set, the batched evaluation) of ``thetas``."""
    return (lambda: [post(t) for t in thetas]), (lambda: post.log_prob_batch(thetas))


def best_time(fn, repeats: int = 3) -> float:
    best = np.inf
    for _ in range(repeats):
        start = time.process_time()
        fn()
        best = min(best, time.process_time() - start)
    return best


def top_entries(fn, count: int = 5) -> list[str]:
    profile = cProfile.Profile()
    profile.enable()
    fn()
    profile.disable()
    stats = pstats.Stats(profile)
    rows = sorted(stats.stats.items(), key=lambda item: -item[1][2])[:count]
    return [f"{100 * tottime / stats.total_tt:5.1f} %  {name} ({Path(path).name}:{line})"
            for (path, line, name), (_, _, tottime, _, _) in rows]


def evidence_runs(rec, ei: float, n_intervals: int) -> dict[str, float]:
    """One SMC run per model at 150 Hz, batched and set by set (same seed): CPU-time ratios."""
    print(f"\none SMC evidence run at 150 Hz, N = {n_intervals}, 256 particles (CPU s)")
    print(f"{'model':<6}{'loop':>8}{'batched':>9}{'ratio':>7}{'stages':>8}{'evaluations':>13}   log Z (loop, batched)")
    ratios = {}
    for model, damping in MODELS.items():
        post = prepare(rec, model, FitConfig(max_frequency=150.0), n_intervals).posterior
        optimum = find_optimum(post, np.random.default_rng(1), start={"EI": ei, **damping})
        reference = laplace_reference(post.priors, optimum.theta, optimum.covariance)
        runs, seconds = {}, {}
        for flag in ("0", "1"):
            os.environ[BATCH_VARIABLE] = flag
            start = time.process_time()
            runs[flag] = smc(post.terms, reference, np.random.default_rng(5), n_particles=256)
            seconds[flag] = time.process_time() - start
        os.environ.pop(BATCH_VARIABLE)
        ratios[model] = seconds["1"] / seconds["0"]
        loop, batched = runs["0"], runs["1"]
        print(f"{model:<6}{seconds['0']:8.1f}{seconds['1']:9.1f}{ratios[model]:7.2f}{len(batched.betas) - 1:8d}"
              f"{batched.n_evaluations:13d}   {loop.log_z:.4f}, {batched.log_z:.4f}")
    return ratios


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sets", type=int, default=64)
    parser.add_argument("--n-intervals", type=int, default=16)
    parser.add_argument("--tables", action="store_true", help="only re-render README.md's block from benchmarks/results/batch.json")
    args = parser.parse_args(argv)
    print(f"bayesbeam batch benchmark; {platform.processor() or platform.machine()}, {os.cpu_count()} cores; "
          f"load at start {tuple(round(x, 2) for x in os.getloadavg())}")
    rec = load_recording(EXAMPLE)
    ei = json.loads((EXAMPLE / "truth.json").read_text())["beam_true"]["EI"]
    print(f"{args.sets} parameter sets per model, N = {args.n_intervals}; ms per set (CPU, best of 3)\n")
    print(f"{'band':<16}{'model':<6}{'loop':>9}{'batched':>9}{'ratio':>7}{'max rel diff':>14}")
    ratios, profiles = {}, {}
    for band_name, band in BANDS.items():
        for model, damping in MODELS.items():
            post = prepare(rec, model, FitConfig(max_frequency=band), args.n_intervals).posterior
            thetas = cloud(post, {"EI": ei, **damping}, args.sets, seed=1)
            one_by_one, together = paths(post, thetas)
            single = np.array(one_by_one())
            diff = float(np.max(np.abs(together() - single) / np.abs(single)))
            loop, batched = (best_time(f) / args.sets for f in (one_by_one, together))
            ratios[f"{model} {band_name}"] = batched / loop
            print(f"{band_name:<16}{model:<6}{1e3 * loop:9.3f}{1e3 * batched:9.3f}{batched / loop:7.2f}{diff:14.1e}")
            if model == "q3":
                profiles[band_name] = (top_entries(one_by_one), top_entries(together))
    for band_name, (loop_top, batch_top) in profiles.items():
        print(f"\nq3, {band_name}: largest internal times, one set at a time")
        print("\n".join(f"   {row}" for row in loop_top))
        print("  batched")
        print("\n".join(f"   {row}" for row in batch_top))
    smc_ratios = evidence_runs(rec, ei, args.n_intervals)
    print(f"\nload at end {tuple(round(x, 2) for x in os.getloadavg())}")
    tables.record(sets=args.sets, n_intervals=args.n_intervals, ratio_batched_over_loop=ratios,
                  smc_ratio_batched_over_loop=smc_ratios)
    return 0


if __name__ == "__main__":
    sys.exit(tables.run("batch", main))
