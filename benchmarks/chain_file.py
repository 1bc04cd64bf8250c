"""Benchmark: emcee's chain file written step by step, or a block of steps at a time.

    OPENBLAS_NUM_THREADS=1 python benchmarks/chain_file.py      # two to three minutes on one core

``bayesbeam fit`` keeps its chain in an HDF5 file (``chains.h5``, which ``--resume`` continues).
emcee's ``HDFBackend``, the baseline, writes each step as it is taken and opens the file three
times to do it; :class:`bayesbeam.inference.backend.BufferedHDFBackend` writes
``FLUSH_STEPS`` steps at a time and before every read. The fit is test_resume.py's, a cheap model
whose likelihood costs about a millisecond: ``data/examples/paper_q3_hammer`` up to 0.5 s, air
damping, below 60 Hz, N = 8, 8 walkers, from the optimum polished from the example's truth.
``run_emcee`` takes :data:`STEPS` steps (convergence never declared, so every path runs them all)
with no file (emcee's memory backend: what sampling itself costs), with emcee's file and with the
buffered one, the same seed and start; CPU seconds (one thread, the best of :data:`REPEATS` runs
of each, interleaved), and whether the two files' chains and log probabilities are identical.
"""
from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse
import json
import platform
import sys
import tempfile
import time
from pathlib import Path

import emcee
import numpy as np
import tables  # benchmarks/tables.py: the script's folder is first on sys.path

from bayesbeam.inference import sampler
from bayesbeam.inference.backend import FLUSH_STEPS
from bayesbeam.inference.fit import FitConfig, prepare
from bayesbeam.inference.sampler import find_optimum, run_emcee
from bayesbeam.io import load_recording

ROOT = Path(__file__).resolve().parents[1]
EXAMPLE = ROOT / "data" / "examples" / "paper_q3_hammer"
#: steps per run
STEPS = 1000
WALKERS = 8
#: runs of each path, the fastest kept
REPEATS = 3


class StepByStep(emcee.backends.HDFBackend):
    """emcee's own backend, with the ``flush`` run_emcee calls at the end (nothing is buffered)."""

    def flush(self) -> None:
        pass


def timed_run(post, optimum, path: Path | None, steps: int | None = None) -> float:
    """CPU seconds of run_emcee for ``steps`` (default STEPS) steps, writing to ``path`` (None: no file)."""
    start = time.process_time()
    run_emcee(post, optimum, np.random.default_rng(5), n_walkers=WALKERS, max_steps=steps or STEPS,
              tau_factor=1e9, backend_path=path)
    return time.process_time() - start


def chain(path: Path):
    """(chain, log probabilities) as emcee's own reader finds them in the file."""
    saved = emcee.backends.HDFBackend(str(path), read_only=True)
    return saved.get_chain(), saved.get_log_prob()


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--tables", action="store_true",
                        help="only re-render README.md's block from benchmarks/results/chain_file.json")
    parser.parse_args(argv)
    print(f"bayesbeam chain-file benchmark; {platform.processor() or platform.machine()}, {os.cpu_count()} cores; "
          f"load at start {tuple(round(x, 2) for x in os.getloadavg())}")
    truth = json.loads((EXAMPLE / "truth.json").read_text())
    post = prepare(load_recording(EXAMPLE), "air", FitConfig(stop=0.5, max_frequency=60.0), 8).posterior
    optimum = find_optimum(post, np.random.default_rng(1),
                           start={"EI": truth["beam_true"]["EI"], "gamma": truth["damping"]["gamma"]})
    folder = Path(tempfile.mkdtemp())
    timed_run(post, optimum, None, STEPS // 10)     # first calls' one-off costs, timed by no path
    runs = {"no file": [], "emcee HDFBackend": [], "buffered": []}
    for _ in range(REPEATS):                        # interleaved: a slow spell of the machine hits all three
        runs["no file"].append(timed_run(post, optimum, None))
        buffered = sampler.BufferedHDFBackend
        sampler.BufferedHDFBackend = StepByStep       # the baseline: emcee's backend in the same call
        try:
            runs["emcee HDFBackend"].append(timed_run(post, optimum, folder / "step_by_step.h5"))
        finally:
            sampler.BufferedHDFBackend = buffered
        runs["buffered"].append(timed_run(post, optimum, folder / "buffered.h5"))
    seconds = {path: min(times) for path, times in runs.items()}
    (c0, lp0), (c1, lp1) = chain(folder / "step_by_step.h5"), chain(folder / "buffered.h5")
    identical = bool(np.array_equal(c0, c1) and np.array_equal(lp0, lp1) and len(c0) == STEPS)
    print(f"\n{STEPS} steps of {WALKERS} walkers, air at N = 8, 0.5 s below 60 Hz; CPU s, one thread, best of "
          f"{REPEATS}; buffered: {FLUSH_STEPS} steps per write")
    print(f"{'no file':>10}{'emcee HDFBackend':>18}{'buffered':>10}{'ratio':>8}   chains identical")
    ratio = seconds["buffered"] / seconds["emcee HDFBackend"]
    print(f"{seconds['no file']:10.2f}{seconds['emcee HDFBackend']:18.2f}{seconds['buffered']:10.2f}{ratio:8.3f}"
          f"   {identical}")
    print(f"\nload at end {tuple(round(x, 2) for x in os.getloadavg())}")
    tables.record(seconds=seconds, ratio=ratio, chains_identical=identical)
    return 0 if identical else 1


if __name__ == "__main__":
    sys.exit(tables.run("chain_file", main))
