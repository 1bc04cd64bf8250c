"""The log posterior in sampling coordinates, safe to call from any sampler or worker process.

The parameter vector theta holds, in order, the model's parameters (EI, then each mechanism's and
effect's) and the noise parameters (``sigma_<sensor>``, and ``phi_<sensor>`` for AR(1) noise),
each in its prior's sampling coordinate (the logarithm for log-scale priors). Non-physical
values, an unstable model or a failed linear solve give -inf; nothing raises inside a sampler.
"""
from __future__ import annotations

import os

import numpy as np

from bayesbeam.inference.likelihood import Likelihood
from bayesbeam.inference.priors import Prior

#: environment variable that, set to "0", makes the samplers evaluate parameter sets one at a
#: time instead of in batches (:meth:`LogPosterior.terms_batch`): the benchmarks' baseline
BATCH_VARIABLE = "BAYESBEAM_BATCH"


#: what a likelihood raises where the model cannot be evaluated (an unstable system, a singular
#: solve): the posterior is -inf there
UNEVALUABLE = (ValueError, np.linalg.LinAlgError, FloatingPointError, ZeroDivisionError)


def batching() -> bool:
    """Whether the samplers evaluate their parameter sets in batches (see :data:`BATCH_VARIABLE`)."""
    return os.environ.get(BATCH_VARIABLE, "1") != "0"


class LogPosterior:
    """log p(theta | recording) up to a constant, theta in sampling coordinates."""

    def __init__(self, likelihood: Likelihood, priors: dict[str, Prior]):
        self.likelihood = likelihood
        self.model_names = likelihood.model.parameter_names
        self.names = self.model_names + likelihood.noise_names
        missing = [n for n in self.names if n not in priors]
        if missing:
            raise ValueError(f"no prior given for {missing}")
        self.priors = [priors[n] for n in self.names]

    @property
    def ndim(self) -> int:
        return len(self.names)

    def values(self, theta) -> dict[str, float]:
        """Physical values of theta, by name."""
        return {n: float(p.to_value(z)) for n, p, z in zip(self.names, self.priors, theta)}

    def split(self, theta) -> tuple[dict, dict]:
        """(model parameters, noise parameters) as physical values."""
        v = self.values(theta)
        return {n: v[n] for n in self.model_names}, {n: v[n] for n in self.likelihood.noise_names}

    def coordinates(self, values: dict) -> np.ndarray:
        """theta from physical values."""
        return np.array([p.to_coordinate(values[n]) for n, p in zip(self.names, self.priors)])

    def log_prior(self, theta) -> float:
        return float(sum(p.log_density(z) for p, z in zip(self.priors, theta)))

    def log_likelihood(self, theta) -> float:
        """The likelihood alone (-inf where the model cannot be evaluated)."""
        params, noise = self.split(theta)
        try:
            value = self.likelihood.log_likelihood(params, noise)
        except UNEVALUABLE:
            return -np.inf
        return value if np.isfinite(value) else -np.inf

    def terms(self, theta) -> tuple[float, float]:
        """(log prior, log likelihood) at theta; the likelihood is not evaluated off the prior's support."""
        lp = self.log_prior(theta)
        return (lp, self.log_likelihood(theta)) if np.isfinite(lp) else (-np.inf, -np.inf)

    def __call__(self, theta) -> float:
        return float(sum(self.terms(theta)))

    def terms_batch(self, thetas) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`terms` at each row of ``thetas`` (P, ndim): (log priors (P,), log likelihoods (P,)).

        The likelihoods on the prior's support are evaluated together
        (:meth:`Likelihood.log_likelihoods`). When that fails as a whole (some set's model cannot
        be evaluated), the sets are evaluated one by one, so each gets the value :meth:`terms`
        gives it.
        """
        thetas = np.atleast_2d(np.asarray(thetas, dtype=float))
        log_prior = np.array([self.log_prior(t) for t in thetas], dtype=float)
        supported = np.isfinite(log_prior)
        log_prior[~supported] = -np.inf
        log_lik = np.full(len(thetas), -np.inf)
        if np.any(supported):
            log_lik[supported] = self._log_likelihoods(thetas[supported])
        return log_prior, log_lik

    def log_prob_batch(self, thetas) -> np.ndarray:
        """The log posterior at each row of ``thetas`` (P, ndim): (P,) (emcee's ``vectorize``)."""
        return np.sum(self.terms_batch(thetas), axis=0)

    def _log_likelihoods(self, thetas: np.ndarray) -> np.ndarray:
        params, noises = zip(*(self.split(t) for t in thetas))
        try:
            values = self.likelihood.log_likelihoods(params, noises)
        except UNEVALUABLE:
            return np.array([self.log_likelihood(t) for t in thetas])
        return np.where(np.isfinite(values), values, -np.inf)

    def profiled(self, model_theta) -> float:
        """log posterior with each channel's noise sd at its conditional optimum (RMS residual).

        Used by the optimiser: fewer dimensions and no poorly scaled noise coordinate.
        """
        with self.likelihood.reusing():          # one model evaluation for the profile and the value
            full = self.with_profiled_noise(model_theta)
            return -np.inf if full is None else self(full)

    def profiled_batch(self, model_thetas) -> np.ndarray:
        """:meth:`profiled` at each row of ``model_thetas`` (P, k). Where the likelihood allows
        (:attr:`Likelihood.profiles_in_batches`) and batching is on, the sets on the prior's
        support are evaluated together, one model evaluation each for the profile and the value
        (:meth:`Likelihood.profiled_log_likelihoods`); a batch that fails as a whole is evaluated
        set by set, as :meth:`terms_batch` does."""
        model_thetas = np.atleast_2d(np.asarray(model_thetas, dtype=float))
        if not (self.likelihood.profiles_in_batches and batching()):
            return np.array([self.profiled(x) for x in model_thetas], dtype=float)
        k = len(self.model_names)
        model_prior = np.array([sum(p.log_density(z) for p, z in zip(self.priors[:k], x)) for x in model_thetas])
        out = np.full(len(model_thetas), -np.inf)
        supported = np.flatnonzero(np.isfinite(model_prior))
        if supported.size == 0:
            return out
        params = [self.split(np.concatenate([x, [p.median() for p in self.priors[k:]]]))[0]
                  for x in model_thetas[supported]]
        try:
            variances, log_lik = self.likelihood.profiled_log_likelihoods(params, self._clipped_variances)
        except UNEVALUABLE:
            out[supported] = [self.profiled(x) for x in model_thetas[supported]]
            return out
        noise_prior = np.array([sum(p.log_density(z) for p, z in zip(self.priors[k:], row))
                                for row in self._noise_coordinates(variances)])
        out[supported] = np.where(np.isfinite(log_lik), model_prior[supported] + noise_prior + log_lik, -np.inf)
        return out

    def _noise_coordinates(self, variances: np.ndarray) -> np.ndarray:
        """The noise sds' sampling coordinates (P, c) from variances (P, c), clipped into their
        priors' support as :meth:`with_profiled_noise` clips them."""
        k = len(self.model_names)
        return np.stack([np.clip(p.to_coordinate(np.sqrt(variances[:, i])), *p.bounds())
                         for i, p in enumerate(self.priors[k:])], axis=1)

    def _clipped_variances(self, variances: np.ndarray) -> np.ndarray:
        """Variances (P, c) with their sds clipped into the noise priors' support."""
        k = len(self.model_names)
        coords = self._noise_coordinates(variances)
        return np.stack([p.to_value(coords[:, i]) ** 2 for i, p in enumerate(self.priors[k:])], axis=1)

    def with_profiled_noise(self, model_theta):
        """theta with the noise at its conditional optimum (:meth:`Likelihood.profile_noise`),
        clipped to its prior's support, or None."""
        k = len(self.model_names)
        trial = np.concatenate([model_theta, [p.median() for p in self.priors[k:]]])
        params, _ = self.split(trial)
        try:
            noise = self.likelihood.profile_noise(params)
        except (ValueError, np.linalg.LinAlgError, FloatingPointError):
            return None
        # clipped into the prior's support: far from the optimum the RMS residual can exceed a
        # narrow noise prior, and -inf there would leave the optimiser without a gradient
        coords = [np.clip(p.to_coordinate(noise[n]), *p.bounds())
                  for n, p in zip(self.names[k:], self.priors[k:])]
        return np.concatenate([model_theta, coords])
