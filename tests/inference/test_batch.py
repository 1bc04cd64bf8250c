"""Batched likelihood evaluation against the single-set path it must reproduce.

``LogPosterior.terms_batch`` evaluates many parameter sets together (one inverse FFT per batch, the
force noise's latent columns projected by ``BandProjection.project_shifted`` instead of built as
shifted copies and transformed one by one, stacked solves). The single-set path
(``LogPosterior.terms``) is the reference: the two compute the same numbers by different routes, so
they agree to rounding. The tolerance, 1e-10 relative, is the one the batched path is held to; the
routes differ by 1e-15 to 1e-11 (an FFT of a block against the edge sums of its neighbours, a
Cholesky against an LU solve), far above any sampler's resolution of a log posterior.
"""
from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from bayesbeam.inference.evidence import laplace_reference, smc
from bayesbeam.inference.fit import FitConfig, prepare
from bayesbeam.inference.likelihood import BandProjection, Likelihood
from bayesbeam.inference.posterior import BATCH_VARIABLE, LogPosterior
from bayesbeam.inference.priors import Prior
from bayesbeam.inference.sampler import Optimum, laplace_covariance, run_emcee
from bayesbeam.io import Excitation, Recording, TipBody, load_recording
from bayesbeam.model import BeamModel
from tests.inference import cases

RELEASE = Path(__file__).resolve().parents[2] / "data" / "examples" / "alu_q1_release"
#: relative agreement of the batched and single-set log likelihoods (module docstring)
RTOL = 1e-10
#: the effects' values: a root spring of 200 EI/l, a 10 g sensor, a 0.2 ms delay
EFFECT_VALUES = {"k_theta": 200 * cases.EI_TRUE, "m_s": 0.01, "tau": 2e-4}


def noisy_force(model_name: str, seed: int = 4):
    """The cheap force case (512 Hz for 1 s, N = 6) with 1 % noise on its force channel, so the
    likelihood marginalises the response the force noise drives."""
    rec, clean = cases.clean_response(model_name)
    rng = np.random.default_rng(seed)
    return replace(rec.with_signals(clean + 0.02 * np.std(clean) * rng.standard_normal(clean.shape)),
                   force=rec.force + 0.2 * rng.standard_normal(rec.n_samples))


def spread(post: LogPosterior, centre: dict, n: int, seed: int) -> np.ndarray:
    """n parameter vectors scattered 2 % about ``centre`` (physical values of the model's
    parameters), the noise profiled at the centre: a sampler's cloud."""
    noise = post.likelihood.profile_noise(centre)
    rng = np.random.default_rng(seed)
    return np.array([post.coordinates({**{k: v * (1 + 0.02 * rng.standard_normal()) for k, v in centre.items()},
                                       **noise}) for _ in range(n)])


def assert_batch_matches_loop(post: LogPosterior, thetas: np.ndarray, finite=None) -> None:
    """terms_batch and log_prob_batch equal terms and __call__ set by set; ``finite``: which sets
    have a finite log likelihood (default all: a batch of -inf would match trivially)."""
    log_prior, log_lik = post.terms_batch(thetas)
    single = np.array([post.terms(t) for t in thetas])
    expected = np.ones(len(thetas), bool) if finite is None else np.asarray(finite)
    np.testing.assert_array_equal(np.isfinite(single[:, 1]), expected)
    np.testing.assert_array_equal(log_prior, single[:, 0])
    np.testing.assert_array_equal(np.isfinite(log_lik), expected)
    np.testing.assert_allclose(log_lik[expected], single[expected, 1], rtol=RTOL, atol=0)
    np.testing.assert_allclose(post.log_prob_batch(thetas), [post(t) for t in thetas], rtol=RTOL, atol=0)


@pytest.mark.parametrize("model_name", ["q1", "q2", "q3", "q2+root_compliance+measurement_delay", "q3+sensor_mass"])
def test_batched_likelihood_with_force_noise_matches_single_sets(model_name):
    """Measured force with noise (latent columns marginalised): the paper's three models, q2 with a
    root spring (the low-rank form) and a delayed response, q3 with a sensor mass; 12 sets in
    chunks of 5."""
    mechanisms = model_name.split("+")[0]
    rec = noisy_force(mechanisms)
    post = prepare(rec, model_name, FitConfig(n_intervals=6), 6).posterior
    assert post.likelihood.force_noise is not None and post.likelihood.model.batches
    post.likelihood.batch_size = 5                       # chunks: 5 + 5 + 2
    centre = {name: {**EFFECT_VALUES, **cases.TRUTH[mechanisms]}[name] for name in post.model_names}
    assert_batch_matches_loop(post, spread(post, centre, 12, seed=1))


def test_batched_likelihood_of_a_clean_force_and_ar1_noise_matches_single_sets():
    """Clean force channel (no latent terms) and per-set AR(1) noise variances."""
    rec, _ = cases.simulated("q1", seed=3)
    post = prepare(rec, "q1", FitConfig(n_intervals=6, noise="ar1"), 6).posterior
    assert post.likelihood.force_noise is None
    thetas = spread(post, cases.TRUTH["q1"], 6, seed=2)
    thetas[:, -1] = np.linspace(-0.5, 0.5, 6)              # phi_accel_tip
    assert_batch_matches_loop(post, thetas)


def test_batched_likelihood_of_a_release_recording_matches_single_sets():
    """Release of a static tip load (the static offset per set), the shipped aluminium example cut
    to 0.5 s below 60 Hz."""
    rec = load_recording(RELEASE)
    post = prepare(rec, "q1", FitConfig(n_intervals=6, stop=0.5, max_frequency=60.0), 6).posterior
    centre = {"EI": rec.beam.nominal_EI, "gamma": 0.18, "cdI": 2e-5}
    assert_batch_matches_loop(post, spread(post, centre, 6, seed=3))


def test_free_decay_and_a_set_that_cannot_be_evaluated_fall_back_to_single_sets():
    """A free decay loops over single sets (its latent amplitudes need each set's poles), and a
    batch holding a q2 set whose memory removes more stiffness than EI gives (ValueError in the
    batch) is evaluated set by set: that set -inf, the others their single values; a set off the
    prior's support gets -inf for both terms, as :meth:`terms` gives it."""
    fs, n = 256.0, 128
    rec = Recording(cases.PAPER_BEAM, TipBody(), Excitation("free_decay", start=0.0), (cases.SENSOR,),
                    np.arange(n) / fs, np.zeros((n, 1)))
    model = BeamModel.from_recording(rec, "q1", 6)
    amplitudes = np.random.default_rng(5).standard_normal(model.free_decay_basis(cases.TRUTH["q1"]).shape[2])
    clean = model.simulate(cases.TRUTH["q1"], amplitudes)
    decay = Likelihood(BeamModel.from_recording(rec.with_signals(clean + 0.01 * clean.std()), "q1", 6),
                       BandProjection(fs, 0, n, 32, 60.0))
    assert decay.free_decay
    params = [{**cases.TRUTH["q1"], "gamma": g} for g in (0.2, 0.3, 0.4)]
    noises = [{"sigma_accel_tip": 0.01 * clean.std()}] * 3
    np.testing.assert_allclose(decay.log_likelihoods(params, noises),
                               [decay.log_likelihood(p, s) for p, s in zip(params, noises)], rtol=RTOL)

    post = prepare(noisy_force("q2"), "q2", FitConfig(n_intervals=6), 6).posterior
    thetas = spread(post, cases.TRUTH["q2"], 4, seed=4)
    alpha = post.names.index("alpha")
    thetas[1, alpha] = post.priors[alpha].to_coordinate(1e4)     # unstable: G(0) alpha K0 > EI K0
    thetas[2, alpha] = post.priors[alpha].bounds()[1] + 1.0      # off the prior's support
    with pytest.raises(ValueError):
        post.likelihood.log_likelihoods(*zip(*(post.split(t) for t in thetas[:2])))
    assert_batch_matches_loop(post, thetas, finite=[True, False, False, True])
    assert np.isneginf(post.terms_batch(thetas)[0][2])


def test_project_shifted_equals_projecting_the_shifted_copies():
    """project_shifted against project() of the copies built explicitly: unordered, repeated and
    non-contiguous shifts, a window from i0 = 37, two trailing axes. Tolerance 1e-13 of the largest
    coordinate: both are sums of a few hundred terms of O(1) (rounding ~1e-15 of them)."""
    proj = BandProjection(fs=512.0, i0=37, i1=37 + 3 * 128 + 50, block=128, max_frequency=150.0)
    shifts = np.array([9, 3, 14, 3, 30])
    first = proj.i0 - shifts.max() - 2
    rng = np.random.default_rng(6)
    h = rng.standard_normal((proj.i1 - first, 2, 3))
    t = np.arange(proj.i1)
    copies = np.stack([h[t - s - first] for s in shifts], axis=-1)        # (n, 2, 3, K)
    expected = np.moveaxis(proj.project(copies), (0, -1), (-1, 0))         # (K, 2, 3, size)
    got = proj.project_shifted(h, first, shifts)
    np.testing.assert_allclose(got, expected, rtol=0, atol=1e-13 * np.abs(expected).max())
    with pytest.raises(ValueError, match="too few"):
        proj.project_shifted(h[:-60], first, shifts)


@pytest.fixture(scope="module")
def q1_posterior():
    """q1 on the noisy-force case, the truth with the noise profiled, and the Laplace covariance
    there."""
    post = prepare(noisy_force("q1"), "q1", FitConfig(n_intervals=6), 6).posterior
    theta = post.with_profiled_noise(post.coordinates({**cases.TRUTH["q1"], "sigma_accel_tip": 1.0})[:-1])
    return post, theta, laplace_covariance(post, theta)


def test_emcee_vectorized_draws_the_chain_of_one_call_per_walker(q1_posterior, monkeypatch):
    """run_emcee in one process evaluates each half-ensemble together (emcee's vectorize); emcee
    draws the same random numbers either way, and with values equal to rounding every accept
    decision is the same: the chains agree to 1e-12 (rounding carried along 60 steps)."""
    post, theta, cov = q1_posterior
    optimum = Optimum(theta, post(theta), cov, 0)
    chains = {}
    for flag in ("1", "0"):
        monkeypatch.setenv(BATCH_VARIABLE, flag)
        chains[flag] = run_emcee(post, optimum, np.random.default_rng(8), n_walkers=12, max_steps=60, chunk=30)
    np.testing.assert_allclose(chains["1"].samples, chains["0"].samples, rtol=1e-12, atol=0)
    np.testing.assert_allclose(chains["1"].log_prob, chains["0"].log_prob, rtol=1e-12, atol=0)


def test_smc_with_batched_particles_gives_the_run_of_one_call_per_particle(q1_posterior, monkeypatch):
    """SMC evaluates its first draws and each half of the ensemble per move together; the same
    random draws and values equal to rounding give the same stages and log Z (to 1e-9 relative:
    rounding in the weights' log-sum-exp). Laplace reference at the truth, 64 particles."""
    post, theta, cov = q1_posterior
    reference = laplace_reference(post.priors, theta, cov)
    runs = {}
    for flag in ("1", "0"):
        monkeypatch.setenv(BATCH_VARIABLE, flag)
        runs[flag] = smc(post.terms, reference, np.random.default_rng(9), n_particles=64)
    assert len(runs["1"].betas) == len(runs["0"].betas)
    assert runs["1"].log_z == pytest.approx(runs["0"].log_z, rel=1e-9)
    np.testing.assert_allclose(runs["1"].particles, runs["0"].particles, rtol=1e-9)


class _InProcessPool:
    """A pool whose three 'workers' are this process (its map is the builtin one)."""

    _processes = 3

    def __init__(self):
        self.chunks = []

    def map(self, fn, items):
        items = list(items)
        self.chunks.append([len(x) for x in items])
        return list(map(fn, items))


def test_emcee_over_a_pool_evaluates_one_chunk_per_worker(q1_posterior, monkeypatch):
    """With a pool that states its workers, the starting ensemble (12 walkers) goes out as 3 chunks
    of 4 and each half-ensemble as 3 chunks of 2, each evaluated together by the worker's posterior
    (here this process's, as init_worker leaves it); the chain equals one call per walker in this
    process to 1e-12 (rounding)."""
    from bayesbeam.inference import sampler as sampler_module

    post, theta, cov = q1_posterior
    optimum = Optimum(theta, post(theta), cov, 0)
    monkeypatch.setattr(sampler_module, "_WORKER_POSTERIOR", post)
    pool = _InProcessPool()
    pooled = run_emcee(post, optimum, np.random.default_rng(8), n_walkers=12, max_steps=30, chunk=30, pool=pool)
    assert pool.chunks == [[4, 4, 4]] + [[2, 2, 2]] * 60
    monkeypatch.setenv(BATCH_VARIABLE, "0")
    single = run_emcee(post, optimum, np.random.default_rng(8), n_walkers=12, max_steps=30, chunk=30)
    np.testing.assert_allclose(pooled.samples, single.samples, rtol=1e-12, atol=0)


def test_the_profiled_posterior_evaluates_the_model_once_per_point(q1_posterior, monkeypatch):
    """The optimiser's profiled posterior profiles the noise and then evaluates the likelihood at
    the same model parameters: the model's response is computed once for both
    (``Likelihood.reusing``), and a new point anew; outside ``reusing`` nothing is kept (a repeated
    call at one point, as a benchmark makes, simulates again). The value is the one of the two
    evaluations made apart (exactly: the same arrays)."""
    post, theta, _ = q1_posterior
    model = post.likelihood.model
    calls = []
    original = model.simulate_with_impulses
    monkeypatch.setattr(model, "simulate_with_impulses", lambda *a: calls.append(1) or original(*a))
    k = len(post.model_names)
    first = post.profiled(theta[:k])
    assert len(calls) == 1
    full = post.with_profiled_noise(theta[:k])
    assert post(full) == first and len(calls) == 3
    post(full)
    assert len(calls) == 4
    post.profiled(theta[:k] + 1e-3)
    assert len(calls) == 5


def assert_profiled_batch_matches_loop(post: LogPosterior, model_thetas: np.ndarray, finite) -> None:
    """profiled_batch equals profiled set by set, to :data:`RTOL` where finite, -inf where not."""
    single = np.array([post.profiled(x) for x in model_thetas])
    batch = post.profiled_batch(model_thetas)
    np.testing.assert_array_equal(np.isfinite(single), finite)
    np.testing.assert_array_equal(np.isfinite(batch), finite)
    np.testing.assert_allclose(batch[finite], single[finite], rtol=RTOL, atol=0)


@pytest.mark.parametrize("model_name", ["q2", "q3"])
def test_the_profiled_posterior_in_batches_matches_single_sets(model_name):
    """The optimiser's batched profile (noise sd at its conditional optimum, the force noise's
    latent columns marginalised) equals the single-set profile: 9 sets in chunks of 4, the noise
    prior narrowed so that the truth's sd lies below it and a far set's (EI e times the truth)
    above it, both clipped as the single path clips them, one set off the model parameters'
    prior (-inf), and for q2 one that cannot be evaluated (its memory taking more stiffness than
    EI gives: the batch falls back to single sets)."""
    rec = noisy_force(model_name)
    wide = prepare(rec, model_name, FitConfig(n_intervals=6), 6).posterior
    k = len(wide.model_names)
    centre = cases.TRUTH[model_name]
    thetas = spread(wide, centre, 9, seed=6)[:, :k]
    thetas[0] = [p.to_coordinate(centre[n]) for p, n in zip(wide.priors, wide.model_names)]
    thetas[1, 0] += 1.0                                  # EI e times the truth
    sd = [wide.likelihood.profile_noise(wide.split(wide.with_profiled_noise(x))[0])["sigma_accel_tip"]
          for x in thetas[:2]]
    assert sd[1] > 8 * sd[0]
    narrow = {"sigma_accel_tip": Prior("loguniform", 2 * sd[0], sd[1] / 2)}
    post = prepare(rec, model_name, FitConfig(n_intervals=6, priors=narrow), 6).posterior
    assert post.likelihood.profiles_in_batches
    post.likelihood.batch_size = 4
    sigma = post.priors[k]
    assert post.with_profiled_noise(thetas[0])[k] == sigma.bounds()[0]
    assert post.with_profiled_noise(thetas[1])[k] == sigma.bounds()[1]
    thetas[2, 1] = post.priors[1].bounds()[1] + 1.0      # off the prior's support
    finite = np.ones(9, bool)
    finite[2] = False
    if model_name == "q2":
        alpha = post.names.index("alpha")
        thetas[5, alpha] = post.priors[alpha].to_coordinate(1e4)   # unstable
        finite[5] = False
    assert_profiled_batch_matches_loop(post, thetas, finite)


def test_the_profiled_posterior_of_a_clean_force_in_batches_matches_single_sets():
    """Clean force channel (no latent terms): the profile is the RMS residual."""
    rec, _ = cases.simulated("q1", seed=3)
    post = prepare(rec, "q1", FitConfig(n_intervals=6), 6).posterior
    assert post.likelihood.force_noise is None and post.likelihood.profiles_in_batches
    k = len(post.model_names)
    assert_profiled_batch_matches_loop(post, spread(post, cases.TRUTH["q1"], 5, seed=2)[:, :k], np.ones(5, bool))


def test_the_profiled_posterior_falls_back_to_single_sets_for_ar1_noise():
    """AR(1) noise is profiled set by set (its phi is polished separately)."""
    rec, _ = cases.simulated("q1", seed=3)
    post = prepare(rec, "q1", FitConfig(n_intervals=6, noise="ar1"), 6).posterior
    assert not post.likelihood.profiles_in_batches
    k = len(post.model_names)
    assert_profiled_batch_matches_loop(post, spread(post, cases.TRUTH["q1"], 3, seed=2)[:, :k], np.ones(3, bool))
