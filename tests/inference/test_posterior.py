"""LogPosterior: prior + likelihood in sampling coordinates, -inf (never an exception) where the
model cannot be evaluated."""
import warnings

import numpy as np
import pytest
from scipy import stats

from bayesbeam.inference import FitConfig
from bayesbeam.inference.fit import prepare
from bayesbeam.physics.mechanisms.time_hysteresis import static_relaxation
from tests.inference import cases
from tests.inference.test_likelihood import dft_rows


@pytest.fixture(scope="module")
def q2_problem():
    rec, sd = cases.simulated("q2", seed=3)
    return prepare(rec, "q2", FitConfig(n_intervals=6), 6), sd


def test_names_order_and_coordinates(q2_problem):
    problem, sd = q2_problem
    post = problem.posterior
    assert post.names == ("EI", "alpha", "beta", "sigma_accel_tip") and post.ndim == 4
    values = {**cases.TRUTH["q2"], "sigma_accel_tip": sd}
    theta = post.coordinates(values)
    np.testing.assert_allclose(theta, np.log([values[n] for n in post.names]), rtol=1e-14)
    assert post.values(theta) == pytest.approx(values, rel=1e-13)
    params, noise = post.split(theta)
    assert set(params) == {"EI", "alpha", "beta"} and set(noise) == {"sigma_accel_tip"}


def test_relaxed_stiffness_below_zero_is_minus_infinity(q2_problem):
    """Time hysteresis with G(0) = alpha sqrt(pi/beta) > EI: the relaxed stiffness is negative.

    alpha = 0.5 EI_0 and beta = 0.01 1/s lie inside the default priors (finite log prior), so the
    -inf must come from the model check, not from the prior; no exception, no warning.
    """
    problem, sd = q2_problem
    post = problem.posterior
    bad = {"EI": cases.EI_TRUE, "alpha": 0.5 * cases.EI_TRUE, "beta": 0.01, "sigma_accel_tip": sd}
    assert static_relaxation(bad["alpha"], bad["beta"]) > bad["EI"]
    theta = post.coordinates(bad)
    assert np.isfinite(post.log_prior(theta))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert post.log_likelihood(theta) == -np.inf
        assert post(theta) == -np.inf
    # the boundary is the model's: just inside it (G(0) = 0.9 EI) the value is finite
    ok = dict(bad, alpha=0.9 * cases.EI_TRUE / np.sqrt(np.pi / 0.01))
    assert np.isfinite(post(post.coordinates(ok)))


@pytest.mark.parametrize("position", [0, 1, 2, 3])
@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf, 1e6])
def test_non_finite_or_absurd_coordinates_are_minus_infinity(q2_problem, position, bad):
    """NaN or +-inf in any coordinate (or a coordinate far outside the support) gives -inf, never raises.

    1e6 in log coordinates is exp(1e6): overflow to inf; warnings from that overflow are allowed.
    """
    problem, sd = q2_problem
    post = problem.posterior
    theta = post.coordinates({**cases.TRUTH["q2"], "sigma_accel_tip": sd})
    theta[position] = bad
    with np.errstate(all="ignore"), warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        assert post(theta) == -np.inf


def test_value_is_log_prior_plus_log_likelihood(q2_problem):
    """At a point off the truth, post(theta) = independent log prior + independent log likelihood.

    Prior: scipy's densities in the sampling coordinates (EI: N(log EI_0, 0.25); alpha, beta,
    sigma: uniform in log over the default supports). Likelihood: N(0, sigma^2) terms of the
    explicit-DFT coordinates of data minus model. Relative 1e-10.

    The model is simulated at post.values(theta), the values after the exp(log(.)) round trip:
    the forward solver's exponential window (decay e^-18 over the padding) amplifies round-off by
    up to e^18 = 7e7 at the end of the record, so parameters one ulp apart give responses 1e-9
    apart (relative), which would blur a 1e-10 comparison.
    """
    problem, sd = q2_problem
    post, lik = problem.posterior, problem.likelihood
    values = {"EI": 44.3, "alpha": 2.1, "beta": 180.0, "sigma_accel_tip": 1.1 * sd}
    theta = post.coordinates(values)
    ei0 = cases.PAPER_BEAM.nominal_EI
    rms = lik.channel_rms["accel_tip"]
    log_prior = (stats.norm(np.log(ei0), 0.25).logpdf(theta[0])
                 - np.log(np.log(ei0 / (1e-6 * ei0)))      # alpha: log-uniform [1e-6 EI_0, EI_0]
                 - np.log(np.log(1e4 / 1e-2))              # beta: log-uniform [1e-2, 1e4]
                 - np.log(np.log(10 * rms / (1e-6 * rms))))  # sigma: log-uniform [1e-6, 10] x RMS
    rec = lik.model.recording
    proj = lik.projection
    q = dft_rows(rec.n_samples, proj.i0, proj.block, proj.n_blocks, proj.n_bins)
    model_signal = lik.model.simulate(post.split(theta)[0])
    log_lik = np.sum(stats.norm.logpdf(q @ (rec.signals - model_signal)[:, 0], scale=values["sigma_accel_tip"]))
    assert post.log_prior(theta) == pytest.approx(log_prior, rel=1e-12)
    assert post.log_likelihood(theta) == pytest.approx(log_lik, rel=1e-10)
    assert post(theta) == pytest.approx(log_prior + log_lik, rel=1e-10)


def test_profiled_noise_is_the_conditional_optimum(q2_problem):
    """with_profiled_noise sets sigma to the RMS band residual, which maximises the posterior over
    sigma (log-uniform prior: flat in log sigma): moving sigma by +-1 % lowers it."""
    problem, _ = q2_problem
    post, lik = problem.posterior, problem.likelihood
    model_theta = np.log([44.3, 2.1, 180.0])
    full = post.with_profiled_noise(model_theta)
    rms = np.sqrt(np.mean(lik.residual(post.split(full)[0]) ** 2))
    assert np.exp(full[-1]) == pytest.approx(rms, rel=1e-12)
    assert post.profiled(model_theta) == pytest.approx(post(full), rel=1e-14)
    for shift in (np.log(1.01), -np.log(1.01)):
        assert post(full + np.array([0, 0, 0, shift])) < post(full)
    bad = np.log([44.3, 0.5 * cases.EI_TRUE, 0.01])      # negative relaxed stiffness
    assert post.with_profiled_noise(bad) is None and post.profiled(bad) == -np.inf
