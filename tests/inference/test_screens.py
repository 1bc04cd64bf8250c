"""The cheap screens against cases with known answers.

PSIS-LOO and PSIS-LFO are checked on a linear-Gaussian model, where the refit each of them avoids
has a closed form: the exact posterior given any subset of blocks, and from it the exact predictive
density of a held-out block. Posterior draws from the full data give non-uniform importance weights
(Pareto k up to about 0.5 on the clean data), so a wrong block, a sign error or an unweighted mean
changes the answer by more than the tolerance.
"""
import numpy as np
from scipy import stats

from bayesbeam.inference.sampler import Optimum
from bayesbeam.inference.screens import PARETO_K_LIMIT, laplace_log_evidence, psis_lfo, psis_loo

# 16 blocks of 8 samples of y = c0 + c1 cos(2 pi t) + N(0, 1) noise; every block sees one whole
# period, so each carries the same information and leaving blocks out changes the posterior's
# spread in proportion (LFO's first step, from 8 of 16 blocks, doubles the variance: k ~ 0.5).
BLOCKS, PER_BLOCK, SIGMA, PRIOR_SD, TRUTH = 16, 8, 1.0, 10.0, np.array([1.0, -2.0])
FIRST_PREDICTED = 8  # LFO predicts blocks 8..15 from those before each
DRAWS = 4000
# PSIS Monte-Carlo error on this case: over 20 independent sets of 4000 draws the elpd scatters by
# 0.033 (LOO) and 0.021 (LFO) nats about the exact value, with a mean offset of 0.008. A tolerance
# of 0.25 nats is over 7 of those sd, and far below what a broken screen is off by: the unweighted
# (in-sample) mean is 1.9 nats high, the importance ratio with its sign flipped 3.5 nats. The
# elpd's usual standard error (5.9 nats for LOO, 3.0 for LFO) is also checked, but is far looser.
TOLERANCE = 0.25


def _design():
    t = (np.arange(PER_BLOCK) + 0.5) / PER_BLOCK
    return np.column_stack([np.ones(PER_BLOCK), np.cos(2 * np.pi * t)])


def _data(seed, outlier_block=None):
    rng = np.random.default_rng(seed)
    y = _design() @ TRUTH + SIGMA * rng.standard_normal((BLOCKS, PER_BLOCK))
    if outlier_block is not None:  # a deliberately bad block: every sample 6 sigma high
        y[outlier_block] += 6 * SIGMA
    return y


def _posterior(y, blocks):
    """Exact Gaussian posterior (mean, covariance) of the coefficients given ``blocks`` of ``y``."""
    x = _design()
    precision = np.eye(2) / PRIOR_SD**2 + len(blocks) * x.T @ x / SIGMA**2
    cov = np.linalg.inv(precision)
    return cov @ (x.T @ y[list(blocks)].sum(axis=0)) / SIGMA**2, cov


def _exact_log_predictive(y, block, given):
    """log p(y_block | y_given): the brute-force refit on ``given``, in closed form."""
    x = _design()
    mean, cov = _posterior(y, given)
    return stats.multivariate_normal(x @ mean, x @ cov @ x.T + SIGMA**2 * np.eye(PER_BLOCK)).logpdf(y[block])


def _pointwise(y, seed):
    """Per-block log-likelihood (draws, blocks) at exact draws from the full-data posterior."""
    mean, cov = _posterior(y, range(BLOCKS))
    theta = np.random.default_rng(seed).multivariate_normal(mean, cov, size=DRAWS)
    residual = y[None] - (theta @ _design().T)[:, None, :]
    return stats.norm(0, SIGMA).logpdf(residual).sum(axis=-1)


def _exact_loo(y):
    return np.array([_exact_log_predictive(y, b, [c for c in range(BLOCKS) if c != b]) for b in range(BLOCKS)])


def _exact_lfo(y):
    return np.array([_exact_log_predictive(y, b, range(b)) for b in range(FIRST_PREDICTED, BLOCKS)])


def _standard_error(terms):
    """The elpd's usual standard error (Vehtari, Gelman & Gabry 2017): sqrt(n var(terms))."""
    return np.sqrt(len(terms) * np.var(terms))


def test_psis_loo_matches_exact_leave_one_block_out_refits():
    y = _data(seed=0)
    pointwise = _pointwise(y, seed=1)
    exact = _exact_loo(y)
    loo = psis_loo(pointwise)
    assert abs(loo["elpd"] - exact.sum()) < _standard_error(exact)
    assert abs(loo["elpd"] - exact.sum()) < TOLERANCE
    assert loo["unreliable_blocks"] == 0
    # the weights matter here: the unweighted posterior mean of each block's likelihood misses
    in_sample = np.log(np.mean(np.exp(pointwise), axis=0)).sum()
    assert in_sample - exact.sum() > 4 * TOLERANCE


def test_psis_lfo_matches_exact_one_step_ahead_refits():
    y = _data(seed=0)
    pointwise = _pointwise(y, seed=1)
    exact = _exact_lfo(y)
    lfo = psis_lfo(pointwise, min_blocks=FIRST_PREDICTED)
    assert lfo["predicted_blocks"] == BLOCKS - FIRST_PREDICTED
    assert abs(lfo["elpd"] - exact.sum()) < _standard_error(exact)
    assert abs(lfo["elpd"] - exact.sum()) < TOLERANCE
    assert lfo["unreliable_steps"] == 0


def test_a_bad_block_is_flagged_by_pareto_k():
    """An outlier block drags the full posterior: leaving it out (LOO), or predicting it from the
    blocks before it (LFO), is then too far from the full posterior for importance sampling, and
    its Pareto k exceeds 0.7 (about 1.6 and 1.3 here, against at most 0.55 for clean blocks and steps)."""
    bad = FIRST_PREDICTED
    pointwise = _pointwise(_data(seed=0, outlier_block=bad), seed=1)
    flagged = [b for b in range(BLOCKS) if psis_loo(pointwise[:, [b]])["unreliable_blocks"]]
    assert flagged == [bad]
    # LFO: the step predicting the bad block is flagged (the counts with and without that step differ)
    with_step = psis_lfo(pointwise, min_blocks=bad)["unreliable_steps"]
    without_step = psis_lfo(pointwise, min_blocks=bad + 1)["unreliable_steps"]
    assert with_step - without_step == 1
    assert PARETO_K_LIMIT == 0.7


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
