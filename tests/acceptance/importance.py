"""Adaptive importance sampling of a posterior, certified by the Pareto k of its weights.

Stages of multivariate-t proposals: the first around a given mean and covariance (a Laplace
approximation), each later one with the weighted mean and covariance of all draws so far; after
the planned stages, further ones (up to a cap) while the Pareto k is 0.7 or more, for a start far
from the target's shape. Every draw is weighted by density / mixture of all stages' proposals
(the balance heuristic: unbiased for any mixture that covers the target) and the weights are
Pareto-smoothed (arviz.psislw, as bayesbeam's PSIS-LOO smooths them). The Pareto k of the final
weights estimates the tail of their distribution: below 0.7 the smoothed estimates are reliable,
above it they are not (Vehtari et al. 2024, "Pareto smoothed importance sampling", JMLR 25).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import stats

from bayesbeam.inference.screens import PARETO_K_LIMIT, _psis_log_weights


@dataclass
class Weighted:
    """Draws (n, d) with normalised Pareto-smoothed weights, their Pareto k and each stage's."""

    draws: np.ndarray
    weights: np.ndarray
    pareto_k: float
    stage_k: list

    @property
    def ess(self) -> float:
        """Effective sample size 1 / sum w^2."""
        return float(1.0 / np.sum(self.weights**2))

    def quantile(self, i: int, q) -> np.ndarray:
        """Weighted quantiles of coordinate i (the weighted CDF interpolated at mid-steps)."""
        order = np.argsort(self.draws[:, i])
        w = self.weights[order]
        return np.interp(q, np.cumsum(w) - 0.5 * w, self.draws[order, i])

    def below(self, i: int, value: float) -> float:
        """Weighted share of draws with coordinate i below value: the PIT of value."""
        return float(np.sum(self.weights[self.draws[:, i] < value]))

    def sd(self) -> np.ndarray:
        """Weighted sd of each coordinate."""
        return np.sqrt(self.weights @ (self.draws - self.weights @ self.draws) ** 2)


def smoothed(log_ratio: np.ndarray) -> tuple[np.ndarray, float]:
    """(normalised Pareto-smoothed weights, Pareto k) of log importance ratios (-inf allowed)."""
    finite = np.where(np.isfinite(log_ratio), log_ratio, -np.inf)
    log_w, k = _psis_log_weights(finite - np.max(finite))
    w = np.exp(log_w - np.max(log_w))
    return w / w.sum(), k


def adaptive_importance(log_density, mean: np.ndarray, covariance: np.ndarray, stages, rng, *,
                        df: float = 5.0, first_widen: float = 2.0, widen: float = 1.3, more: int = 0,
                        more_size: int = 250, k_limit: float = PARETO_K_LIMIT) -> Weighted:
    """Weighted draws of ``log_density`` (a function of one point) in ``stages`` (draws per stage),
    then at most ``more`` further stages of ``more_size`` draws while the Pareto k of all draws'
    weights is ``k_limit`` or more.

    The first proposal is the t (``df`` degrees of freedom) of ``mean`` and ``covariance`` with
    scale ``first_widen`` x its sd; each later one the t of the weighted draws so far, ``widen``
    x their sd (heavier-tailed and wider than the target: importance sampling fails when the
    proposal's tails are the lighter). A stage whose weights hold fewer effective draws than
    4 x the dimension keeps its proposal (too few to estimate a covariance). The further stages
    are for a start far from the target: each moves the proposal toward the mass found so far,
    and the weights of all draws are judged again.
    """
    # proposals live in coordinates scaled by the first sd: a covariance whose variances span ten
    # decades (EI's and a damping's logarithms) is otherwise judged singular by scipy's t
    scale = np.sqrt(np.diag(covariance))
    proposal = stats.multivariate_t(mean / scale, first_widen**2 * covariance / np.outer(scale, scale), df=df,
                                    seed=rng)
    proposals, sizes, z, log_p, stage_k = [], [], np.empty((0, mean.size)), np.empty(0), []
    for size in [*stages, *[more_size] * more]:
        if len(stage_k) >= len(stages) and stage_k[-1] < k_limit:
            break
        proposals.append(proposal)
        sizes.append(size)
        new = np.atleast_2d(proposal.rvs(size))
        z = np.concatenate([z, new])
        log_p = np.concatenate([log_p, [log_density(zi * scale) for zi in new]])
        mixture = np.logaddexp.reduce([np.log(n / len(z)) + q.logpdf(z) for n, q in zip(sizes, proposals)], axis=0)
        w, k = smoothed(log_p - mixture)
        stage_k.append(k)
        if 1.0 / np.sum(w**2) > 4 * mean.size:
            try:
                proposal = stats.multivariate_t(w @ z, widen**2 * np.cov(z.T, aweights=w), df=df, seed=rng)
            except (np.linalg.LinAlgError, ValueError):
                pass            # the weighted draws span fewer dimensions: keep the proposal
    return Weighted(z * scale, w, stage_k[-1], stage_k)
