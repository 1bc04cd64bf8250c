"""Interrupted runs resume: ``fit --resume`` continues the saved chain bit for bit, and ``batch``
rerun on its output directory keeps the recordings it finished.

Each run is a real ``bayesbeam`` process killed (SIGKILL, as a cluster's time limit or a power cut
would) once its output holds enough work, then run again; the uninterrupted reference runs beside
it. Cheap settings throughout: the fit takes the shipped hammer recording cut to 0.5 s, below 60 Hz,
with N = 8 and 8 walkers; the campaign compares one model on two 1 s recordings at 256 Hz.
"""
from __future__ import annotations

import json
import os
import subprocess
import sys
import time
from pathlib import Path

import h5py
import numpy as np
import pytest

from bayesbeam.cli.common import EXIT_NOT_CONVERGED
from bayesbeam.io import write_recording
from tests.inference import cases

DATA = Path(__file__).resolve().parents[1] / "data"
HAMMER = str(DATA / "examples" / "paper_q3_hammer")
FIT = ["--model", "air", "--stop", "0.5", "--max-frequency", "60", "--n-intervals", "8", "--walkers", "8",
       "--seed", "3", "--executor", "serial", "--quiet"]
#: tau_factor 10 instead of 50 lets this short chain reach the convergence rule within the cap, so that
#: the resumed run must reproduce the uninterrupted run's stopping decision as well as its draws
FIT_FILE = "[fit]\ntau_factor = 10\n"
CAP = 3000  # --max-steps: the chain is 10 tau long from ~500 steps on; the tau-stability rule decides
KILL_AFTER = 100  # steps saved before the first run is killed: well before convergence


def _bayesbeam(*args):
    """A ``bayesbeam`` process (--quiet: its few lines of output fit the pipes unread)."""
    env = {**os.environ, "OPENBLAS_NUM_THREADS": "1"}
    return subprocess.Popen([sys.executable, "-m", "bayesbeam.cli", *args], env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def _saved_steps(path: Path) -> int:
    """Steps in emcee's HDF5 backend (0 while the file is missing, or caught mid-write by this
    unlocked read: h5py then raises one of these)."""
    try:
        with h5py.File(path, "r", locking=False) as f:
            return int(f["mcmc"].attrs["iteration"])
    except (OSError, KeyError, ValueError, RuntimeError):
        return 0


def _kill_when(proc, ready, timeout=600.0):
    """SIGKILL ``proc`` as soon as ``ready()`` holds; fail if it exits or times out first."""
    deadline = time.monotonic() + timeout
    while not ready():
        assert proc.poll() is None, f"the run ended before it was interrupted: {proc.communicate()}"
        assert time.monotonic() < deadline, "the run made no progress"
        time.sleep(0.05)
    proc.kill()
    proc.communicate()


def _chain(path: Path):
    with h5py.File(path, "r", locking=False) as f:
        g = f["mcmc"]
        n = int(g.attrs["iteration"])
        return g["chain"][:n], g["log_prob"][:n]


def _finish(proc):
    """(exit status, output) of a run left to end."""
    stdout, stderr = proc.communicate(timeout=900)
    return proc.returncode, stdout + stderr


def _fit(out: Path, config: Path, *extra):
    return _bayesbeam("fit", HAMMER, *FIT, "--config", str(config), "--max-steps", str(CAP), "--out", str(out), *extra)


@pytest.mark.slow
def test_fit_resumes_the_killed_chain_bit_for_bit(tmp_path):
    """Killed after m >= 100 saved steps and resumed, the run keeps those m steps unchanged and ends
    where, and as, an uninterrupted run with the same seed ends: the same n steps, every draw and
    log probability identical (emcee's HDF5 backend holds the random state of the last saved step,
    and convergence is judged at the same chunk boundaries), and the same exit status. Whether
    that status is 0 (converged) or 3 (the --max-steps cap) depends on the numerical libraries'
    rounding (the tau estimate of this short chain wanders by ~5 % between chunks near the
    stability rule); either way the resumed run must take the uninterrupted run's decision."""
    config = tmp_path / "fit.toml"
    config.write_text(FIT_FILE)
    out = tmp_path / "resumed"
    backend = out / "chains.h5"
    whole_run = _fit(tmp_path / "whole", config)
    _kill_when(_fit(out, config), lambda: _saved_steps(backend) >= KILL_AFTER)
    saved, saved_lp = _chain(backend)
    m = len(saved)
    whole_code, text = _finish(whole_run)
    assert whole_code in (0, EXIT_NOT_CONVERGED), text
    whole, whole_lp = _chain(tmp_path / "whole" / "chains.h5")
    n = len(whole)
    assert KILL_AFTER <= m < n

    code, text = _finish(_fit(out, config, "--resume"))
    assert code == whole_code, text
    chain, lp = _chain(backend)
    np.testing.assert_array_equal(chain[:m], saved)
    np.testing.assert_array_equal(lp[:m], saved_lp)
    assert len(chain) == n
    np.testing.assert_array_equal(chain, whole)
    np.testing.assert_array_equal(lp, whole_lp)


BATCH = ["--models", "air", "--n-intervals", "6", "--repeats", "2", "--particles", "64", "--replicates", "10",
         "--seed", "1", "--executor", "serial", "--quiet"]


def _files(folder: Path) -> dict:
    """{relative path: (mtime in ns, bytes)} of every file under ``folder``."""
    return {str(p.relative_to(folder)): (p.stat().st_mtime_ns, p.read_bytes())
            for p in sorted(folder.rglob("*")) if p.is_file()}


@pytest.mark.slow
def test_batch_rerun_keeps_finished_recordings_and_ends_with_the_same_table(tmp_path):
    """Killed while comparing its second recording, the campaign rerun with --resume leaves the
    first recording's outputs untouched (same bytes, same modification times: not recomputed),
    compares the second, and writes the table an uninterrupted campaign writes."""
    recordings = []
    for name, seed in (("hit_a", 3), ("hit_b", 4)):
        rec, _ = cases.simulated("air", seed=seed, fs=256.0)
        recordings.append(str(write_recording(rec, tmp_path / name)))
    whole_run = _bayesbeam("batch", *recordings, *BATCH, "--out", str(tmp_path / "whole"))
    out = tmp_path / "campaign"
    _kill_when(_bayesbeam("batch", *recordings, *BATCH, "--out", str(out)),
               lambda: (out / "hit_a" / "comparison.json").exists())
    assert not (out / "hit_b" / "comparison.json").exists()  # killed mid-campaign
    finished = _files(out / "hit_a")

    code, text = _finish(_bayesbeam("batch", *recordings, *BATCH, "--out", str(out), "--resume"))
    assert code == 0, text
    assert _files(out / "hit_a") == finished
    code, text = _finish(whole_run)
    assert code == 0, text
    assert (out / "batch.csv").read_text() == (tmp_path / "whole" / "batch.csv").read_text()
    resumed, whole = (json.loads((folder / "batch.json").read_text()) for folder in (out, tmp_path / "whole"))
    assert resumed["rows"] == whole["rows"] and resumed["models"] == whole["models"]  # provenance: the code's commit
