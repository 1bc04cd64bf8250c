"""The buffered chain file holds what emcee's own HDF5 backend holds, and a run killed between
writes resumes to the uninterrupted chain.

A 3-dimensional Gaussian target, 8 walkers, emcee's default move, fixed seeds: equality is exact
(the same draws written by another route), not a tolerance.
"""
import emcee
import numpy as np
import pytest

from bayesbeam.inference import backend as buffered
from bayesbeam.inference.backend import BufferedHDFBackend

WALKERS, NDIM = 8, 3


def _log_prob(x):
    return -0.5 * float(x @ x)


def _sampler(backend):
    sampler = emcee.EnsembleSampler(WALKERS, NDIM, _log_prob, backend=backend)
    sampler.random_state = np.random.RandomState(7).get_state()
    return sampler


def _start():
    return np.random.default_rng(3).standard_normal((WALKERS, NDIM))


def _contents(path):
    """(iteration, chain, log probabilities, acceptance counts, random state) as emcee's own reader finds them."""
    saved = emcee.backends.HDFBackend(str(path), read_only=True)
    return saved.iteration, saved.get_chain(), saved.get_log_prob(), saved.accepted, saved.random_state


def _run(backend, steps, start=None):
    backend.reset(WALKERS, NDIM)
    _sampler(backend).run_mcmc(_start() if start is None else start, steps)


@pytest.mark.parametrize("steps", [1, buffered.FLUSH_STEPS, 123])
def test_the_file_is_emcee_s_own(tmp_path, steps):
    """Chain, log probabilities, acceptance counts, iteration and the last step's random state are
    emcee's HDFBackend's, for a run shorter than one write, exactly one, and not a multiple."""
    plain, mine = tmp_path / "plain.h5", tmp_path / "buffered.h5"
    _run(emcee.backends.HDFBackend(str(plain)), steps)
    backend = BufferedHDFBackend(str(mine))
    _run(backend, steps)
    assert backend.iteration == steps                    # a read writes what is buffered first
    (n0, chain0, lp0, acc0, state0), (n1, chain1, lp1, acc1, state1) = _contents(plain), _contents(mine)
    assert n0 == n1 == steps
    np.testing.assert_array_equal(chain1, chain0)
    np.testing.assert_array_equal(lp1, lp0)
    np.testing.assert_array_equal(acc1, acc0)
    assert len(state1) == len(state0) and all(np.array_equal(a, b) for a, b in zip(state0, state1))


def test_a_run_killed_between_writes_resumes_to_the_uninterrupted_chain(tmp_path):
    """Killed 25 steps past a write (the buffer lost with the process), the file holds the written
    steps and their last random state; resumed, the run ends with the uninterrupted chain."""
    whole = BufferedHDFBackend(str(tmp_path / "whole.h5"))
    _run(whole, 120)
    _, reference, reference_lp, *_ = _contents(tmp_path / "whole.h5")

    path = tmp_path / "killed.h5"
    killed = BufferedHDFBackend(str(path))
    _run(killed, buffered.FLUSH_STEPS + 25)
    killed._pending.clear()             # the process dies: what was not written is gone
    n, *_ = _contents(path)
    assert n == buffered.FLUSH_STEPS

    resumed = BufferedHDFBackend(str(path))
    sampler = emcee.EnsembleSampler(WALKERS, NDIM, _log_prob, backend=resumed)
    sampler.run_mcmc(None, 120 - resumed.iteration)      # None: from the file's last state
    _, chain, lp, *_ = _contents(path)
    np.testing.assert_array_equal(chain, reference)
    np.testing.assert_array_equal(lp, reference_lp)


def test_a_slow_step_is_written_within_the_time_limit(tmp_path, monkeypatch):
    """With FLUSH_SECONDS = 0 every step is written as it is taken: nothing waits in memory."""
    monkeypatch.setattr(buffered, "FLUSH_SECONDS", 0.0)
    backend = BufferedHDFBackend(str(tmp_path / "slow.h5"))
    _run(backend, 3)
    assert not backend._pending and _contents(tmp_path / "slow.h5")[0] == 3
