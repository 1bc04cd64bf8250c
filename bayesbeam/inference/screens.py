r"""Cheap model screens beside the evidence, each with what it assumes.

* **BIC** (Schwarz 1978): :math:`\log Z \approx \log L(\hat\theta) - \tfrac{k}{2}\log n`, with k
  parameters (noise included) and n band coordinates. Assumes many independent observations, a
  unimodal posterior dominated by the likelihood, and ignores the prior: a rough screen.
* **Laplace** at the optimum: :math:`\log Z \approx \log p(\hat\theta, y) +
  \tfrac12\log\det(2\pi\Sigma)` (Σ the Laplace covariance). Assumes a Gaussian posterior in the
  sampling coordinates; wrong for a parameter piled against its prior bound.
* **PSIS-LFO** (Bürkner, Gabry & Vehtari 2020): expected log predictive density of each time
  block given only the blocks before it (1-step-ahead), from the full posterior by Pareto-smoothed
  importance sampling without refits, starting after ``min_blocks`` blocks. Steps whose Pareto k
  exceeds 0.7 are unreliable and counted (the paper refits there; this screen does not).
* **PSIS-LOO** (Vehtari, Gelman & Gabry 2017) over the same blocks: leave-one-block-out. On a
  time series it is optimistic: the left-out block is predicted from blocks on both sides of it,
  which a forecast never has; reported for comparison only.

The blocks are those of the likelihood (:class:`~bayesbeam.inference.likelihood.BandProjection`),
conditionally independent given the parameters, so the pointwise terms are exact.
"""
from __future__ import annotations

import warnings

import numpy as np
from scipy import special

#: at most this many posterior draws get pointwise terms
MAX_DRAWS = 400
#: Pareto k above which an importance-sampling step is unreliable
PARETO_K_LIMIT = 0.7


def bic(posterior, optimum) -> dict:
    lik = posterior.likelihood
    n = lik.z_data.size
    k = posterior.ndim
    log_l = posterior.log_likelihood(optimum.theta)
    return {"log_evidence": float(log_l - 0.5 * k * np.log(n)), "bic": float(-2 * log_l + k * np.log(n)),
            "assumes": "many independent observations, likelihood-dominated unimodal posterior; ignores the prior"}


def laplace_log_evidence(optimum) -> dict:
    sign, logdet = np.linalg.slogdet(2 * np.pi * optimum.covariance)
    value = float(optimum.log_posterior + 0.5 * logdet) if sign > 0 else None
    return {"log_evidence": value,
            "assumes": "a Gaussian posterior in the sampling coordinates around the optimum"}


def pointwise_matrix(posterior, draws, rng) -> np.ndarray:
    """Per-block log-likelihood (S, blocks) at up to :data:`MAX_DRAWS` of the draws (n, ndim)."""
    pick = draws[rng.choice(len(draws), size=min(MAX_DRAWS, len(draws)), replace=False)]
    rows = []
    for theta in pick:
        params, noise = posterior.split(theta)
        try:
            rows.append(posterior.likelihood.pointwise(params, noise))
        except (ValueError, np.linalg.LinAlgError):
            continue
    return np.array(rows)


def _psis_log_weights(log_ratios):
    import arviz as az

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        lw, k = az.psislw(np.asarray(log_ratios, float))
    return np.asarray(lw), float(k)


def psis_lfo(pointwise: np.ndarray, min_blocks: int | None = None) -> dict:
    """1-step-ahead PSIS-LFO elpd over blocks (see module docstring)."""
    n_blocks = pointwise.shape[1]
    start = min_blocks if min_blocks is not None else max(1, n_blocks // 4)
    elpd, bad = 0.0, 0
    for i in range(start, n_blocks):
        lw, k = _psis_log_weights(-pointwise[:, i:].sum(axis=1))
        bad += k > PARETO_K_LIMIT
        elpd += float(special.logsumexp(lw + pointwise[:, i]))
    return {"elpd": elpd, "predicted_blocks": n_blocks - start, "unreliable_steps": int(bad),
            "assumes": "blocks predicted from earlier blocks only; importance sampling from the full "
                       "posterior without refits (steps with Pareto k > 0.7 counted as unreliable)"}


def psis_loo(pointwise: np.ndarray) -> dict:
    """Leave-one-block-out elpd by PSIS (optimistic on a time series: see module docstring)."""
    elpd, bad = 0.0, 0
    for i in range(pointwise.shape[1]):
        lw, k = _psis_log_weights(-pointwise[:, i])
        bad += k > PARETO_K_LIMIT
        elpd += float(special.logsumexp(lw + pointwise[:, i]))
    return {"elpd": elpd, "unreliable_blocks": int(bad),
            "assumes": "exchangeable blocks: optimistic on a time series, where a left-out block is "
                       "predicted from its neighbours on both sides"}
