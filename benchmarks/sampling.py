"""Benchmark: posterior sampling speed for q3 on a 4 s, 2048 Hz recording.

    OPENBLAS_NUM_THREADS=1 python benchmarks/sampling.py [--n-intervals 64] [--quick]

On ``data/examples/paper_q3_hammer`` prepared as ``bayesbeam fit --model q3 --max-frequency
150`` prepares it (decimated by 5, force noise marginalised; N = 64, the automatic choice there):

1. log posterior evaluations per second in one process (best of 5 batches of ~1 s);
2. wall time to ESS >= 1000 for every parameter, with emcee on two local worker processes and,
   as the baseline measured in the same run, in this process alone (same seed, walkers and
   start). ESS is the summary's (``sampler.effective_sample_size`` after
   ``sampler.burn_in``: n_walkers (n_steps - burn) / tau, burn = min(3 max tau, n_steps / 2)),
   checked every 100 steps.

The optimum is found once, by a local polish from the example's truth (the global search is not
what is timed), and both runs start from the same ball around it. ``--quick`` stops at ESS 200
and extrapolates the wall time linearly in ESS (a chain's ESS grows linearly with its length
once it is several tau long), which is said in the output. Target: under 5 minutes with both
cores.
"""
from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse
import json
import platform
import sys
import time
from pathlib import Path

import emcee
import numpy as np
import tables  # benchmarks/tables.py: the script's folder is first on sys.path

from bayesbeam.inference.fit import FitConfig, prepare
from bayesbeam.inference.sampler import (
    burn_in,
    effective_sample_size,
    find_optimum,
    initial_ball,
    local_pool,
    worker_log_prob,
)
from bayesbeam.io import load_recording

EXAMPLE = Path(__file__).resolve().parents[1] / "data" / "examples" / "paper_q3_hammer"
TARGET_SECONDS = 5 * 60
CHECK_EVERY = 100


def evaluations_per_second(post, theta) -> float:
    """Best of 5 batches, each long enough (~1 s) for the clock to be negligible."""
    post(theta)
    start = time.perf_counter()
    post(theta)
    per_call = time.perf_counter() - start
    batch = max(1, int(1.0 / per_call))
    best = np.inf
    for _ in range(5):
        start = time.perf_counter()
        for _ in range(batch):
            post(theta)
        best = min(best, (time.perf_counter() - start) / batch)
    return 1.0 / best


def cost_split(post, theta, calls: int = 100) -> None:
    """Print where one evaluation's time goes (cProfile over ``calls`` evaluations): the share of
    the largest internal times and the Python function calls per evaluation, one parameter set at
    a time (benchmarks/batch.py times batches of sets against this)."""
    import cProfile
    import pstats

    profile = cProfile.Profile()
    profile.enable()
    for _ in range(calls):
        post(theta)
    profile.disable()
    stats = pstats.Stats(profile)
    total = stats.total_tt
    print(f"   per evaluation: {stats.total_calls / calls:.0f} Python-level calls; largest internal times:")
    rows = sorted(stats.stats.items(), key=lambda item: -item[1][2])[:5]
    for (path, line, name), (_, _, tottime, _, _) in rows:
        print(f"   {100 * tottime / total:5.1f} %  {name} ({Path(path).name}:{line})")


def time_to_ess(post, ball, seed: int, target_ess: float, pool=None) -> tuple[float, int, float]:
    """(wall seconds, steps, smallest ESS) of an emcee run continued until every parameter's ESS
    reaches ``target_ess`` (checked every CHECK_EVERY steps)."""
    n_walkers = len(ball)
    sampler = emcee.EnsembleSampler(n_walkers, post.ndim, worker_log_prob if pool else post, pool=pool)
    sampler.random_state = np.random.RandomState(seed).get_state()
    state, started = ball, time.perf_counter()
    while True:
        state = sampler.run_mcmc(state, CHECK_EVERY, progress=False)
        tau = sampler.get_autocorr_time(tol=0)
        if not np.all(np.isfinite(tau)):
            continue
        burn = burn_in(np.max(tau), sampler.iteration)
        ess = float(np.min(effective_sample_size(tau, n_walkers, sampler.iteration, burn)))
        if ess >= target_ess:
            return time.perf_counter() - started, sampler.iteration, ess


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n-intervals", type=int, default=64)
    parser.add_argument("--quick", action="store_true", help="stop at ESS 200 and extrapolate to 1000")
    parser.add_argument("--tables", action="store_true", help="only re-render README.md's block from benchmarks/results/sampling.json")
    args = parser.parse_args(argv)
    target = 200.0 if args.quick else 1000.0
    print(f"bayesbeam sampling benchmark; {platform.processor() or platform.machine()}, {os.cpu_count()} cores; "
          f"load at start {tuple(round(x, 2) for x in os.getloadavg())}")
    rec = load_recording(EXAMPLE)
    truth = json.loads((EXAMPLE / "truth.json").read_text())
    problem = prepare(rec, "q3", FitConfig(max_frequency=150.0), args.n_intervals)
    post = problem.posterior
    print(f"recording {EXAMPLE.name}: {rec.n_samples} samples at {rec.fs:g} Hz, decimated by "
          f"{problem.decimation}; q3 at N = {args.n_intervals}, band 150 Hz; parameters {list(post.names)}")
    optimum = find_optimum(post, np.random.default_rng(1), start={"EI": truth["beam_true"]["EI"], **truth["damping"]})
    rate = evaluations_per_second(post, optimum.theta)
    print(f"1. log posterior evaluations: {rate:.0f} per second in one process ({1e3 / rate:.2f} ms each)")
    cost_split(post, optimum.theta)

    n_walkers = max(4 * post.ndim, 16)
    ball = initial_ball(post, optimum, n_walkers, np.random.default_rng(2))
    pool = local_pool(post, 2)
    try:
        two = time_to_ess(post, ball, 3, target, pool)
    finally:
        pool.close()
    one = time_to_ess(post, ball, 3, target)
    scale = 1000.0 / target
    label = "extrapolated from ESS 200 (x5)" if args.quick else "measured"
    print(f"2. wall time to ESS >= 1000 for every parameter ({n_walkers} walkers; {label}):")
    for name, (seconds, steps, ess) in (("2 processes", two), ("1 process", one)):
        print(f"   {name:>11}: {scale * seconds:7.1f} s ({steps} steps, smallest ESS {ess:.0f} when stopped)")
    print(f"   ratio 1 process / 2 processes: {one[0] / two[0]:.2f}; with 2 processes "
          f"{scale * two[0] / TARGET_SECONDS:.2f} x the 5-minute target")
    print(f"load at end {tuple(round(x, 2) for x in os.getloadavg())}")
    tables.record(evaluations_per_second=rate, walkers=n_walkers, target_ess=1000.0, stopped_at_ess=target,
                  extrapolated=bool(args.quick), target_seconds=TARGET_SECONDS,
                  **{f"seconds_to_ess_1000_{key}": scale * seconds for key, (seconds, _, _) in
                     (("2_processes", two), ("1_process", one))})
    return 0


if __name__ == "__main__":
    sys.exit(tables.run("sampling", main))
