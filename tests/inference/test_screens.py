"""The cheap screens against cases with known answers."""
import numpy as np
from scipy import stats

from bayesbeam.inference.sampler import Optimum
from bayesbeam.inference.screens import laplace_log_evidence, psis_lfo, psis_loo


def test_laplace_is_exact_for_a_gaussian_posterior():
    """y ~ N(theta, 1), theta ~ N(0, 2^2): log p(theta_hat, y) + 0.5 log det(2 pi Sigma) = log Z exactly."""
    y, prior_var = 1.3, 4.0
    post_var = 1 / (1 + 1 / prior_var)
    mode = post_var * y
    joint = stats.norm(mode, 1).logpdf(y) + stats.norm(0, 2).logpdf(mode)
    optimum = Optimum(np.array([mode]), joint, np.array([[post_var]]), 0)
    exact = stats.norm(0, np.sqrt(1 + prior_var)).logpdf(y)
    assert abs(laplace_log_evidence(optimum)["log_evidence"] - exact) < 1e-12


def test_lfo_and_loo_with_a_point_posterior_are_the_plain_log_likelihood():
    """All draws equal: the importance weights are uniform, so each elpd term is that block's log-likelihood."""
    pointwise = np.tile([-1.0, -2.0, -3.0, -4.0, -5.0, -6.0, -7.0, -8.0], (50, 1))
    lfo = psis_lfo(pointwise, min_blocks=2)
    assert np.isclose(lfo["elpd"], -3 - 4 - 5 - 6 - 7 - 8) and lfo["predicted_blocks"] == 6
    assert np.isclose(psis_loo(pointwise)["elpd"], -36.0)
