r"""Model evidence log Z by sequential Monte Carlo along a tempered path, with emcee moves.

The evidence of a model is :math:`Z = \int L(\theta)\,\pi(\theta)\,d\theta`. It is reached from
a normalised reference density :math:`q` (known :math:`Z_0 = 1`) through the path

.. math:: f_\beta(\theta) = q(\theta)^{1-\beta}\,\bigl[L(\theta)\,\pi(\theta)\bigr]^{\beta},
          \qquad 0 = \beta_0 < \beta_1 < \dots < \beta_T = 1,

and :math:`Z = \prod_t Z_{\beta_t}/Z_{\beta_{t-1}}`, each ratio estimated by the mean incremental
weight :math:`w_i = \exp\{(\beta_t - \beta_{t-1})\,[\log L + \log\pi - \log q](\theta_i)\}` of
particles distributed as :math:`f_{\beta_{t-1}}` (Del Moral, Doucet & Jasra 2006). With
:math:`q = \pi` this is the transitional MCMC of Ching & Chen (2007), tempering the likelihood
alone. Each next :math:`\beta` is chosen by bisection so that the effective sample size of the
incremental weights is ``target_ess`` x the particle count (Ching & Chen's rule); particles are
then resampled (systematic) and moved by emcee's differential-evolution ensemble move (which
uses the particle cloud itself as proposal scale) on :math:`f_{\beta_t}`
until each has had ``min_accepted`` accepted moves on average, or, with ``min_moved`` set, until
a particle has moved at least once with probability ``min_moved`` at the stage's acceptance rate
a, 1 - (1 - a)^steps, and at least :data:`MIN_MOVE_STEPS` (the rule of PyMC3's SMC, its
``p_acc_rate``): at a = 0.3 and ``min_moved`` = 0.85, 6 steps where three accepted moves take 10.
The DE step
(emcee's :math:`2.38/\sqrt{2\,n_\mathrm{dim}}` times a factor) shrinks after a stage whose mean acceptance falls
below :data:`LOW_ACCEPTANCE` (:func:`next_scale`): on a curved or rough posterior the step,
sized by differences across the whole particle cloud, overshoots, acceptance decays from stage to
stage and three accepted moves take dozens of steps. A posterior on which acceptance stays above
it is moved exactly as at the fixed step. The last stage ends at
:math:`\beta = 1` with a resample and a move, so the particles are posterior draws.

The estimate of :math:`Z` is unbiased; :math:`\log Z` is biased low by about half its variance.
Its uncertainty is measured, not modelled: :func:`evidence` runs independent repeats (different
seeds, fresh reference draws) and reports the mean of :math:`\log Z` with the standard error
sd / sqrt(repeats). The repeats are independent jobs, so they parallelise across processes or a
cluster. Within a run, a :class:`~bayesbeam.inference.posterior.LogPosterior`'s particles are
evaluated together (the first draws, then each half of the ensemble per move:
:func:`batched_terms`).

The reference. :math:`q = \pi` is exact but needs many stages when the posterior is narrow
against the prior. :func:`laplace_reference` builds a tighter one from the optimum: a
multivariate Student-t (4 degrees of freedom, scale 1.5 x the Laplace covariance) over the
parameters the data determine, the prior itself over those they do not (a damping term the
data do not need is flat down to its lower prior bound, which no Gaussian describes), and over a
determined parameter whose optimum lies against its prior's edge a band from that edge mixed
with the prior (:data:`BAND_SDS`). SMC
corrects any mismatch; a good reference only makes it cheaper.
"""
from __future__ import annotations

import time
from dataclasses import dataclass

import emcee
import numpy as np
from scipy import special

from bayesbeam.inference.posterior import LogPosterior, batching

#: effective sample size kept at each tempering step, as a fraction of the particles
TARGET_ESS = 0.5
#: mean accepted moves per particle in each mutation phase
MIN_ACCEPTED = 3
#: cap on mutation steps per tempering stage
MAX_MOVE_STEPS = 60
#: fewest mutation steps per stage under the ``min_moved`` rule
MIN_MOVE_STEPS = 2
#: a stage whose mean acceptance falls below this shrinks the next stage's DE step (:func:`next_scale`)
LOW_ACCEPTANCE = 0.15
#: the smallest DE step, as a fraction of emcee's 2.38 / sqrt(2 ndim)
MIN_SCALE = 0.1
#: Student-t degrees of freedom and scale inflation of the Laplace reference
REFERENCE_DF = 4.0
REFERENCE_SCALE = 1.5
#: a parameter counts as determined by the data when its Laplace sd is below this fraction of
#: its prior sd (both in sampling coordinates) and it lies this many Laplace sd inside its support
DETERMINED_FRACTION = 0.25
DETERMINED_MARGIN = 3.0
#: a determined parameter whose optimum lies against an edge of its prior gets, instead of its
#: prior, a band this many Laplace sds wide from that edge inward (at most the prior's width),
#: mixed defensively with its prior: the band takes this share of the reference's mass and the
#: prior the rest, so the reference keeps the prior's support and a particle beyond the band
#: costs at most log(1 / 0.1) = 2.3 nats of weight. Laplace sds at an edge understate the
#: posterior's width there (q2's alpha on paper_q3_hammer at 150 Hz: 23 x), hence the width;
#: there, with two seeds each, the prior as reference (14 e-folds against a posterior of 0.011)
#: took 11 tempering stages and this band 6-7, with log Z 3.4-5.6 nats higher (the runs from the
#: prior erred low)
BAND_SDS = 50.0
BAND_WEIGHT = 0.9


# ---------------------------------------------------------------------------- reference densities
class Reference:
    r"""A normalised density q over theta: a Student-t over ``tight`` coordinates, and over each of
    the rest its prior, or for a coordinate of ``bands`` (index -> (low, high)) the defensive
    mixture of a uniform density on that interval (weight :data:`BAND_WEIGHT`) and its prior.

    ``mean``/``cov`` (sampling coordinates, all dimensions; only the ``tight`` block is used),
    ``priors``: one :class:`~bayesbeam.inference.priors.Prior` per dimension, ``tight``: boolean
    mask. With no tight coordinate and no band, q is the prior.
    """

    def __init__(self, priors, tight=None, mean=None, cov=None, df: float = REFERENCE_DF, bands=None):
        self.priors = list(priors)
        d = len(self.priors)
        self.tight = np.zeros(d, bool) if tight is None else np.asarray(tight, bool)
        self.bands = dict(bands or {})
        self.df = df
        if self.tight.any():
            idx = np.flatnonzero(self.tight)
            self.mean = np.asarray(mean, float)[idx]
            self.chol = np.linalg.cholesky(np.asarray(cov, float)[np.ix_(idx, idx)])
            k = len(idx)
            self._log_norm = (special.gammaln(0.5 * (df + k)) - special.gammaln(0.5 * df)
                              - 0.5 * k * np.log(df * np.pi) - np.sum(np.log(np.diag(self.chol))))

    @property
    def ndim(self) -> int:
        return len(self.priors)

    def sample(self, rng: np.random.Generator, n: int) -> np.ndarray:
        out = np.empty((n, self.ndim))
        for i, p in enumerate(self.priors):
            if not self.tight[i]:
                out[:, i] = p.draw(rng, n)
            if i in self.bands:
                in_band = rng.random(n) < BAND_WEIGHT
                out[in_band, i] = rng.uniform(*self.bands[i], in_band.sum())
        if self.tight.any():
            z = rng.standard_normal((n, len(self.mean)))
            scale = np.sqrt(self.df / rng.chisquare(self.df, n))
            out[:, self.tight] = self.mean + scale[:, None] * (z @ self.chol.T)
        return out

    def log_density(self, theta: np.ndarray) -> np.ndarray:
        theta = np.atleast_2d(theta)
        out = np.zeros(len(theta))
        for i, p in enumerate(self.priors):
            if not self.tight[i]:
                prior = np.array([p.log_density(z) for z in theta[:, i]])
                out += prior if i not in self.bands else self._band_mixture(i, theta[:, i], prior)
        if self.tight.any():
            k = len(self.mean)
            r = np.linalg.solve(self.chol, (theta[:, self.tight] - self.mean).T)
            out += self._log_norm - 0.5 * (self.df + k) * np.log1p(np.sum(r * r, axis=0) / self.df)
        return out

    def _band_mixture(self, i: int, z: np.ndarray, log_prior: np.ndarray) -> np.ndarray:
        """log(w U(z; band) + (1 - w) prior(z)) of coordinate i."""
        low, high = self.bands[i]
        with np.errstate(divide="ignore"):
            uniform = np.where((z >= low) & (z <= high), -np.log(high - low), -np.inf)
            return np.logaddexp(np.log(BAND_WEIGHT) + uniform, np.log1p(-BAND_WEIGHT) + log_prior)


def laplace_reference(priors, theta, covariance) -> Reference:
    """The reference of the module docstring from an optimum and its Laplace covariance."""
    sd = np.sqrt(np.clip(np.diag(covariance), 0.0, None))
    tight = np.zeros(len(priors), bool)
    bands = {}
    for i, p in enumerate(priors):
        lo, hi = p.bounds()
        prior_sd = p.b if p.kind == "lognormal" else (hi - lo) / np.sqrt(12.0)
        determined = 0 < sd[i] < DETERMINED_FRACTION * prior_sd
        inside = p.kind == "lognormal" or min(theta[i] - lo, hi - theta[i]) > DETERMINED_MARGIN * sd[i]
        tight[i] = determined and inside
        if determined and not inside:
            width = min(BAND_SDS * sd[i], hi - lo)
            bands[i] = (lo, lo + width) if theta[i] - lo < hi - theta[i] else (hi - width, hi)
    cov = np.asarray(covariance)[np.ix_(tight, tight)]
    if tight.any():
        cov = _nearest_positive_definite(cov)
    full = np.zeros_like(covariance)
    full[np.ix_(tight, tight)] = cov * REFERENCE_SCALE**2
    return Reference(priors, tight, theta, full, bands=bands)


def _nearest_positive_definite(cov):
    """cov with eigenvalues floored at 1e-12 of the largest (finite-difference Hessians can be noisy)."""
    w, v = np.linalg.eigh(0.5 * (cov + cov.T))
    w = np.maximum(w, 1e-12 * max(w.max(), 1e-300))
    return (v * w) @ v.T


# ---------------------------------------------------------------------------- the tempered target
class TemperedTarget:
    r"""log f_beta(theta) with (log pi, log L, log q) as emcee blobs; picklable for process pools.

    ``terms``: callable theta -> (log prior, log likelihood), e.g. ``LogPosterior.terms`` or, in
    pool workers, :func:`bayesbeam.inference.sampler.worker_terms`; ``batch``: its batched form
    (:func:`batched_terms`) for :meth:`many`.
    """

    def __init__(self, terms, reference: Reference, beta: float, batch=None):
        self.terms, self.reference, self.beta, self.batch = terms, reference, beta, batch

    def __call__(self, theta):
        log_prior, log_lik = self.terms(theta)
        if not (np.isfinite(log_prior) and np.isfinite(log_lik)):
            return -np.inf, log_prior, log_lik, -np.inf
        log_q = float(self.reference.log_density(theta)[0])
        return (1 - self.beta) * log_q + self.beta * (log_prior + log_lik), log_prior, log_lik, log_q

    def many(self, thetas) -> list[tuple]:
        """What :meth:`__call__` returns, for each row of ``thetas`` (emcee's ``vectorize``)."""
        log_prior, log_lik = self.batch(thetas)
        finite = np.isfinite(log_prior) & np.isfinite(log_lik)
        log_q, log_f = np.full(len(finite), -np.inf), np.full(len(finite), -np.inf)
        log_q[finite] = self.reference.log_density(np.asarray(thetas)[finite])
        log_f[finite] = (1 - self.beta) * log_q[finite] + self.beta * (log_prior + log_lik)[finite]
        return list(zip(log_f, log_prior, log_lik, log_q))


def batched_terms(terms, pool=None):
    """thetas (P, ndim) -> (log priors, log likelihoods) evaluated together, when ``terms`` is a
    :meth:`LogPosterior.terms` evaluated in this process (no ``pool``) and batching is on
    (:func:`~bayesbeam.inference.posterior.batching`); else None (one call per particle)."""
    owner = getattr(terms, "__self__", None)
    if pool is not None or not isinstance(owner, LogPosterior) or terms.__func__ is not LogPosterior.terms:
        return None
    return owner.terms_batch if batching() else None


# ---------------------------------------------------------------------------- one SMC run
@dataclass
class SMCRun:
    """One SMC run: its log Z, the tempering ladder and the final (posterior) particles."""

    log_z: float
    betas: np.ndarray
    particles: np.ndarray          # (n, ndim), sampling coordinates, equally weighted
    log_likelihood: np.ndarray     # (n,)
    log_prior: np.ndarray          # (n,)
    acceptance: np.ndarray         # mean acceptance fraction per stage
    n_evaluations: int
    seconds: float
    scales: np.ndarray | None = None   # the DE step per stage, as a fraction of emcee's (:func:`next_scale`)


def smc(terms, reference: Reference, rng: np.random.Generator, *, n_particles: int = 256,
        target_ess: float = TARGET_ESS, min_accepted: float = MIN_ACCEPTED, pool=None,
        max_stages: int = 200, progress=None, min_moved: float | None = None) -> SMCRun:
    """One adaptive SMC run from ``reference`` to the posterior (see module docstring)."""
    started = time.perf_counter()
    theta = reference.sample(rng, n_particles)
    batch = batched_terms(terms, pool)
    if batch is not None:
        log_prior, log_lik = batch(theta)
    else:
        mapper = pool.map if pool is not None else map
        log_prior, log_lik = (np.array(v, float) for v in zip(*mapper(terms, list(theta))))
    log_q = reference.log_density(theta)
    n_eval = n_particles
    beta, log_z, betas, acceptance, scales = 0.0, 0.0, [0.0], [], [1.0]
    while beta < 1.0:
        if len(betas) > max_stages:
            raise RuntimeError(f"SMC needed more than {max_stages} tempering stages; the reference "
                               f"is far from the posterior")
        gain = np.where(np.isfinite(log_prior + log_lik), log_prior + log_lik - log_q, -np.inf)
        step = _next_step(gain, 1.0 - beta, target_ess)
        log_w = step * gain
        log_z += special.logsumexp(log_w) - np.log(n_particles)
        beta = 1.0 if beta + step >= 1.0 - 1e-12 else beta + step
        betas.append(beta)
        keep = _systematic_resample(log_w, rng)
        theta, log_prior, log_lik, log_q = theta[keep], log_prior[keep], log_lik[keep], log_q[keep]
        theta, log_prior, log_lik, log_q, accepted, used = _move(terms, reference, beta, theta, log_prior,
                                                                 log_lik, log_q, rng, min_accepted, pool,
                                                                 min_moved, scales[-1])
        n_eval += used * n_particles
        acceptance.append(accepted)
        scales.append(next_scale(scales[-1], accepted))
        if progress is not None:
            progress(f"SMC stage {len(betas) - 1}: beta = {beta:.4g}, log Z so far {log_z:.6g}, "
                     f"{used} moves, acceptance {accepted:.2f}")
    return SMCRun(float(log_z), np.array(betas), theta, log_lik, log_prior, np.array(acceptance),
                  n_eval, time.perf_counter() - started, np.array(scales[:-1]))


def next_scale(scale: float, acceptance: float) -> float:
    """The next stage's DE step (a fraction of emcee's 2.38 / sqrt(2 ndim)) after a stage at ``scale``
    whose mean acceptance was ``acceptance``: below :data:`LOW_ACCEPTANCE` times acceptance /
    LOW_ACCEPTANCE (at least a quarter), down to :data:`MIN_SCALE`; otherwise 1.5 x, up to 1."""
    if acceptance < LOW_ACCEPTANCE:
        return max(scale * max(acceptance / LOW_ACCEPTANCE, 0.25), MIN_SCALE)
    return min(1.0, scale * 1.5)


def _next_step(gain, remaining, target_ess) -> float:
    """Largest beta increment whose incremental weights keep ESS >= target_ess x n (bisection)."""
    n = np.sum(np.isfinite(gain))
    if n == 0:
        raise RuntimeError("no particle has a finite posterior: the reference misses the prior's support")

    def ess(step):
        log_w = step * gain
        log_w = log_w - np.max(log_w)
        w = np.exp(log_w)
        return w.sum() ** 2 / np.sum(w * w)

    target = target_ess * len(gain)
    if ess(remaining) >= target:
        return remaining
    lo, hi = 0.0, remaining
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if ess(mid) >= target else (lo, mid)
    return max(lo, 1e-12)


def _systematic_resample(log_w, rng) -> np.ndarray:
    w = np.exp(log_w - special.logsumexp(log_w))
    positions = (rng.random() + np.arange(len(w))) / len(w)
    return np.minimum(np.searchsorted(np.cumsum(w), positions), len(w) - 1)


#: what each particle carries besides its position (the tempered density is rebuilt from these)
BLOBS = [("log_prior", float), ("log_lik", float), ("log_q", float)]


def _move(terms, reference, beta, theta, log_prior, log_lik, log_q, rng, min_accepted, pool, min_moved=None,
          scale=1.0):
    """emcee DE moves on f_beta until min_accepted accepted moves per particle on average (or
    the ``min_moved`` rule of the module docstring).

    (Not the snooker or stretch moves: after resampling, particles coincide, and a snooker move
    between coinciding particles divides by zero while a stretch move between them cannot move.)
    """
    n, ndim = theta.shape
    target = TemperedTarget(terms, reference, beta, batched_terms(terms, pool))
    log_f = (1 - beta) * log_q + beta * (log_prior + log_lik)
    blobs = np.array(list(zip(log_prior, log_lik, log_q)), dtype=BLOBS)
    vectorize = target.batch is not None
    sampler = emcee.EnsembleSampler(n, ndim, target.many if vectorize else target, pool=pool,
                                    moves=emcee.moves.DEMove(gamma0=scale * 2.38 / np.sqrt(2 * ndim)),
                                    blobs_dtype=BLOBS, vectorize=vectorize)
    sampler.random_state = np.random.RandomState(int(rng.integers(2**31))).get_state()
    state = emcee.State(theta, log_prob=log_f, blobs=blobs)
    steps = 0
    while steps < MAX_MOVE_STEPS:
        # resampled particles coincide by design (the DE move spreads them); emcee's check of the
        # initial state's condition number would refuse exactly that
        state = sampler.run_mcmc(state, 1, progress=False, skip_initial_state_check=True)
        steps += 1
        if _moved_enough(np.mean(sampler.acceptance_fraction), steps, min_accepted, min_moved):
            break
    b = state.blobs
    return state.coords, np.asarray(b["log_prior"]), np.asarray(b["log_lik"]), np.asarray(b["log_q"]), \
        float(np.mean(sampler.acceptance_fraction)), steps


def _moved_enough(acceptance: float, steps: int, min_accepted: float, min_moved: float | None) -> bool:
    if min_moved is None:
        return acceptance * steps >= min_accepted
    return steps >= MIN_MOVE_STEPS and 1.0 - (1.0 - acceptance) ** steps >= min_moved


# ---------------------------------------------------------------------------- repeated runs
@dataclass
class Evidence:
    """log Z from independent SMC repeats: mean, standard error, and the pooled posterior draws;
    ``first_pass``: the repeats this one replaced, when a first pass had not settled (see
    :func:`matched_reference`); ``pilot``: the run whose particles the repeats' reference was
    fitted to, if any (:func:`bayesbeam.comparison.piloted`)."""

    log_z: float
    log_z_sd: float
    runs: list
    first_pass: Evidence | None = None
    pilot: SMCRun | None = None

    @property
    def samples(self) -> np.ndarray:
        """Posterior draws pooled over repeats: (repeats, n_particles, ndim), sampling coordinates."""
        return np.stack([r.particles for r in self.runs])

    def as_dict(self) -> dict:
        return {"log_evidence": self.log_z, "log_evidence_sd": self.log_z_sd,
                "method": "SMC (adaptive tempering from a reference density, emcee DE moves)",
                "repeats": [r.log_z for r in self.runs],
                "stages": [len(r.betas) - 1 for r in self.runs],
                "evaluations": int(sum(r.n_evaluations for r in self.runs)),
                "seconds": float(sum(r.seconds for r in self.runs)),
                **({} if self.first_pass is None else {"first_pass": self.first_pass.as_dict()}),
                **({} if self.pilot is None else {"pilot": {"log_evidence": self.pilot.log_z,
                                                            "stages": len(self.pilot.betas) - 1,
                                                            "evaluations": int(self.pilot.n_evaluations),
                                                            "seconds": float(self.pilot.seconds)}})}


def matched_reference(priors, evidence: Evidence) -> Reference:
    """The reference of :func:`laplace_reference` at the mean and covariance of an evidence's pooled
    posterior particles instead of an optimum and its Laplace covariance.

    For a second pass when the first has not settled, and after the pilot run of a rough
    posterior (:func:`bayesbeam.comparison.piloted`): SMC corrects a reference's mismatch only as
    far as its moves keep up with the tempered targets. From a reference far from the posterior
    (an optimum off the mode, a Laplace covariance too narrow) a run needs many stages, its
    particles lag, and log Z errs low, by thousands of nats on the real record's q3 with a sensor
    mass and an axial load (studies/real_steel_cantilever/compare_structure: 242-852 nats in 22-24
    stages on the first pass, 3132.8-3133.1 in five from this reference).
    """
    samples = evidence.samples.reshape(-1, evidence.samples.shape[-1])
    return laplace_reference(priors, samples.mean(axis=0), np.cov(samples, rowvar=False))


def combine_runs(runs) -> Evidence:
    """Mean log Z over repeats, with the standard error of that mean (nan for a single run, such as
    a pilot whose particles :func:`matched_reference` fits)."""
    return Evidence(*mean_and_standard_error([r.log_z for r in runs]), list(runs))


def mean_and_standard_error(values) -> tuple[float, float]:
    """(mean of the runs' log Z ``values``, its standard error sd / sqrt(n); nan for one run)."""
    values = np.asarray(values, dtype=float)
    sd = float(np.std(values, ddof=1) / np.sqrt(len(values))) if len(values) > 1 else float("nan")
    return float(np.mean(values)), sd
