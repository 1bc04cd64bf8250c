"""Parallel sampling through a process pool: same posterior, posterior shipped once per worker.

emcee's pool only maps the log posterior over the proposals; the stretch moves and the accept /
reject draws are made in the parent from the sampler's own random state. So a run with a pool
must give the *identical* chain to a run without one, given the same random state: that is
what is asserted (bit for bit), not mere statistical agreement.
"""
import gc
import multiprocessing
import multiprocessing.pool
import os

import numpy as np
import pytest

from bayesbeam.inference import FitConfig, fit
from bayesbeam.inference.fit import prepare
from bayesbeam.inference.posterior import BATCH_VARIABLE
from bayesbeam.inference.sampler import (
    find_optimum,
    local_pool,
    run_emcee,
    worker_log_prob,
)
from tests.inference import cases


@pytest.fixture(scope="module")
def problem(air_case):
    rec, _ = air_case
    prob = prepare(rec, "air", FitConfig(n_intervals=6), 6)
    return prob, find_optimum(prob.posterior, np.random.default_rng(1))


def test_pool_ships_the_posterior_once_per_worker_and_changes_nothing(problem, tmp_path, monkeypatch):
    """A LogPosterior subclass logs each pickling: the pool's initializer sends it to each of the
    2 workers exactly once (2 picklings in this process, 1 unpickling in each worker) and 100
    steps x 12 walkers of sampling add none; emcee is handed worker_log_prob (a module-level
    function, pickled by reference) rather than the posterior. The chains equal the serial run's
    exactly."""
    import emcee

    from bayesbeam.inference import sampler as sampler_module

    handed = []

    class Recorder(emcee.EnsembleSampler):
        def __init__(self, nwalkers, ndim, log_prob_fn, *args, **kwargs):
            handed.append(log_prob_fn)
            super().__init__(nwalkers, ndim, log_prob_fn, *args, **kwargs)

    monkeypatch.setattr(sampler_module.emcee, "EnsembleSampler", Recorder)
    # the serial run calls the posterior once per walker, as each worker does: the chains are then
    # bit-identical (the batched serial path agrees to rounding: tests/inference/test_batch.py)
    monkeypatch.setenv(BATCH_VARIABLE, "0")
    prob, opt = problem
    log = tmp_path / "pickles.log"
    post = prob.posterior
    counting = cases.CountingLogPosterior(prob.likelihood, dict(zip(post.names, post.priors)), log)
    theta = opt.theta
    assert counting(theta) == post(theta)

    serial = run_emcee(counting, opt, np.random.default_rng(9), n_walkers=12, max_steps=100, chunk=50)
    assert not log.exists()       # no pickling without a pool

    pool = local_pool(counting, 2)
    try:
        parallel = run_emcee(counting, opt, np.random.default_rng(9), n_walkers=12, max_steps=100, chunk=50,
                             pool=pool)
        # the workers hold the posterior: worker_log_prob (what emcee maps) evaluates it there
        assert pool.map(worker_log_prob, [theta, theta]) == [post(theta)] * 2
    finally:
        pool.close()
        pool.join()
    events = [line.split() for line in log.read_text().splitlines()]
    pickled = [pid for what, pid in events if what == "pickle"]
    unpickled = [pid for what, pid in events if what == "unpickle"]
    assert pickled == [str(os.getpid())] * 2
    assert len(unpickled) == 2 and len(set(unpickled)) == 2 and str(os.getpid()) not in unpickled
    assert handed == [counting, worker_log_prob]
    np.testing.assert_array_equal(parallel.samples, serial.samples)
    np.testing.assert_array_equal(parallel.log_prob, serial.log_prob)
    assert parallel.acceptance == serial.acceptance


def _pools():
    """Live multiprocessing Pool objects (type() rather than isinstance(): gc also lists weak proxies)."""
    return [o for o in gc.get_objects() if issubclass(type(o), multiprocessing.pool.Pool)]


@pytest.fixture(scope="module")
def pooled_fit(air_case):
    """fit(..., pool=2), and the worker processes and pools it left alive (terminated here)."""
    rec, sd = air_case
    before = {id(o) for o in _pools()}
    children = set(multiprocessing.active_children())
    result = fit(rec, "air", FitConfig(n_intervals=6, walkers=12, max_steps=300, seed=4), pool=2)
    left_children = [p for p in multiprocessing.active_children() if p not in children]
    left_pools = [o for o in _pools() if id(o) not in before]
    yield result, sd, left_children, left_pools
    for p in left_pools:
        p.terminate()
        p.join()


@pytest.mark.slow
def test_fit_with_two_local_processes_gives_a_valid_posterior(pooled_fit):
    """Plumbing: a finite log posterior at every stored draw, a sane acceptance and one finite
    value per parameter and draw (whether intervals cover the truth is asserted on reference
    recordings: tests/acceptance/test_fit.py and test_calibration.py)."""
    result, _, _, _ = pooled_fit
    assert np.all(np.isfinite(result.chains.log_prob))
    assert 0.1 < result.chains.acceptance < 0.9
    values = result.values()
    assert values.shape[-1] == len(result.problem.posterior.names) and np.all(np.isfinite(values))


@pytest.mark.slow
def test_fit_with_an_int_pool_leaves_no_worker_processes(pooled_fit):
    """fit creates the pool and drops it on return; CPython then collects it at once and its
    finaliser terminates the workers (fit never calls close()/terminate() itself)."""
    _, _, left_children, left_pools = pooled_fit
    assert left_children == [] and left_pools == []


def test_same_rng_gives_the_same_chain_whatever_numpys_global_state(problem):
    prob, opt = problem
    runs = []
    for global_seed in (1, 2):
        np.random.seed(global_seed)
        runs.append(run_emcee(prob.posterior, opt, np.random.default_rng(9), n_walkers=8, max_steps=20,
                              chunk=10).samples)
    np.testing.assert_array_equal(runs[0], runs[1])
