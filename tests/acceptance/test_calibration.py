"""Frequentist calibration of the 90 % posterior intervals over noise draws of recordings the model
did not make.

Case: the reference simulator's hammer test of the paper's beam with q1 damping (cases.py: 1 s at
512 Hz, 2 % sensor noise, force noise 0.5 % of the peak, beam.toml's modulus 7 % above the truth),
the same clean signals with R = 20 independent noise draws (seeds 1000..1019, fixed by rule; the
reference caches the clean simulation, so a draw costs only its noise). Fitted at N = 48, the N
the automatic choice takes on these recordings (test_fit.py asserts the choice and its refinement
check), with the fit's default band and window. Parameters: EI, gamma, cdI and the noise sd
sigma_accel_tip (whose truth is the Noise rule applied to the clean signal): a likelihood whose
noise level is wrong shows there first.

The posterior of each draw. Full emcee per draw does not fit the suite's budget (tau ~ 35 steps
x 16 walkers x 20 draws), so the posterior is computed by importance sampling, exact up to Monte
Carlo error: two stages of multivariate-t proposals (4 degrees of freedom, heavier-tailed than
the posterior; 1.5 x the sd), the first around the Laplace approximation at the optimum
(find_optimum polished from the truth: the global search is test_fit's), the second with the
first's weighted moments, every draw weighted by posterior / mixture of the proposals and
Pareto-smoothed (arviz.psislw). The Pareto k of every draw must stay below 0.7, where smoothed
importance sampling is reliable (Vehtari et al. 2024). For q1 the Laplace approximation alone
would nearly do (the importance-sampled sd is 1.02-1.10 x Laplace's, printed per parameter).
Intervals: weighted 5 % and 95 % quantiles in the sampling coordinate; the probability integral
transform u = weighted P(parameter < truth).

q3 is not calibrated here, for want of an affordable exact posterior: on these 1 s records its
a and b lie on a thin curved ridge (correlation -0.995), where emcee and importance sampling find
them 1.0-3.4 x wider than the Laplace sd (so Laplace intervals would under-cover by construction),
importance sampling stays unreliable (Pareto k up to 1.0 with 1200 draws and 0.77 with 3000), and
emcee needs tau ~ 50-100 steps x 20 walkers per draw. test_fit.py covers q3 with one full fit.

Acceptance band, per parameter (as tests/inference/test_calibration.py). Coverage count
~ Binomial(20, 0.9) under calibration: P(X <= 13) = 0.0024, so 14 <= X (70-100 %) has a false
alarm of 0.0024 per parameter. Over-coverage is tested by the PIT: u ~ Uniform(0, 1) under
calibration, and the Kolmogorov-Smirnov test of the 20 u's must not reject at level 0.001. Four
parameters, two tests each: family-wise false alarm at most 4 x (0.0024 + 0.001) = 1.4 %.
Importance-sampling error in u (sd <= 1/(2 sqrt(ESS)) <= 0.03 at the ESS seen) makes the band
slightly conservative, not liberal.

The 20 fits run on two worker processes (the suite's budget is two cores).
"""
import numpy as np
import pytest
from scipy import stats

from tests.acceptance import cases as ac
from tests.inference.cases import run_in_processes

R = 20
SEEDS = range(1000, 1000 + R)
MODELS = ("q1",)
N_INTERVALS = 48
#: importance sampling: draws of each proposal stage, t degrees of freedom, scale over the sd
STAGES, DOF, SCALE = (300, 700), 4, 1.5
DRAWS = sum(STAGES)
LOWEST_COUNT = 14
MAX_PARETO_K = 0.7


def test_acceptance_band_is_what_the_docstring_says():
    binom = stats.binom(R, 0.9)
    assert binom.cdf(LOWEST_COUNT - 1) == pytest.approx(0.0024, abs=5e-5)
    assert binom.cdf(LOWEST_COUNT) > 0.005          # 14 is the largest bound with < 0.5 % false alarm


def weighted_quantile(x: np.ndarray, weights: np.ndarray, q) -> np.ndarray:
    order = np.argsort(x)
    cdf = np.cumsum(weights[order])
    return np.interp(q, cdf - 0.5 * weights[order], x[order])


def adaptive_importance_draws(post, optimum, rng) -> tuple[np.ndarray, np.ndarray]:
    """(draws, log posterior / proposal) from stages of multivariate-t proposals: the first around
    the Laplace approximation, each later one with the weighted mean and covariance of all draws so
    far; every draw is weighted against the mixture of all stages (the balance heuristic)."""
    proposals, draws, log_post = [], np.empty((0, post.ndim)), np.empty(0)
    proposal = stats.multivariate_t(optimum.theta, SCALE**2 * optimum.covariance, df=DOF, seed=rng)
    for size in STAGES:
        proposals.append(proposal)
        x = proposal.rvs(size)
        draws, log_post = np.concatenate([draws, x]), np.concatenate([log_post, [post(xi) for xi in x]])
        shares = np.array(STAGES[: len(proposals)]) / len(draws)
        mixture = np.logaddexp.reduce([np.log(f) + q.logpdf(draws) for f, q in zip(shares, proposals)], axis=0)
        log_ratio = log_post - mixture
        w = np.exp(log_ratio - np.max(log_ratio))
        if w.sum() ** 2 / np.sum(w**2) < 2 * post.ndim:
            continue                # a few draws hold all the weight: no covariance, keep the proposal
        try:
            proposal = stats.multivariate_t(w @ draws / w.sum(), SCALE**2 * np.cov(draws.T, aweights=w),
                                            df=DOF, seed=rng)
        except np.linalg.LinAlgError:
            pass                    # the weighted draws span fewer dimensions: keep the proposal
    return draws, log_ratio


def importance_posterior(model: str, seed: int) -> dict:
    """The posterior of one noise draw by Pareto-smoothed importance sampling around the Laplace
    approximation (module docstring); module-level: runs in a worker process."""
    import time

    import arviz as az

    from bayesbeam.inference import FitConfig
    from bayesbeam.inference.fit import prepare
    from bayesbeam.inference.sampler import find_optimum

    started = time.perf_counter()
    rec, truth = ac.hammer(model, seed=seed)
    truth = {**truth, "sigma_accel_tip": ac.true_noise_sd(model)[0]}
    post = prepare(rec, model, FitConfig(n_intervals=N_INTERVALS), N_INTERVALS).posterior
    rng = np.random.default_rng(seed)
    optimum = find_optimum(post, rng, start={n: truth[n] for n in post.model_names})
    draws, log_ratio = adaptive_importance_draws(post, optimum, rng)
    log_w, pareto_k = az.psislw(log_ratio - np.max(log_ratio))
    w = np.exp(log_w - np.max(log_w))
    w /= w.sum()
    truth_z = post.coordinates(truth)
    return {
        "names": post.names, "truth": truth, "pareto_k": float(pareto_k), "ess": float(1 / np.sum(w**2)),
        "interval": {n: weighted_quantile(draws[:, i], w, [0.05, 0.95]) .tolist() for i, n in enumerate(post.names)},
        "truth_z": dict(zip(post.names, truth_z.tolist())),
        "pit": {n: float(np.sum(w[draws[:, i] < truth_z[i]])) for i, n in enumerate(post.names)},
        "sd_over_laplace": dict(zip(post.names, (np.sqrt(w @ (draws - w @ draws) ** 2)
                                                 / np.sqrt(np.diag(optimum.covariance))).tolist())),
        "seconds": time.perf_counter() - started,
    }


@pytest.fixture(scope="module")
def replications():
    jobs = [(m, s) for m in MODELS for s in SEEDS]
    results = run_in_processes(importance_posterior, jobs)
    return {m: [r for (jm, _), r in zip(jobs, results) if jm == m] for m in MODELS}


def _report(model: str, reps: list) -> tuple[str, dict, dict]:
    names = reps[0]["names"]
    inside = {n: sum(lo < r["truth_z"][n] < hi for r in reps for lo, hi in [r["interval"][n]]) for n in names}
    ks = {n: stats.kstest([r["pit"][n] for r in reps], "uniform").pvalue for n in names}
    lines = [(f"{model}: {R} draws, {np.mean([r['seconds'] for r in reps]):.1f} s each (one worker), "
             f"Pareto k <= {max(r['pareto_k'] for r in reps):.2f}, ESS >= {min(r['ess'] for r in reps):.0f} "
             f"of {DRAWS}")]
    for n in names:
        ratio = np.median([r["sd_over_laplace"][n] for r in reps])
        lines.append(f"  {n:16s} coverage {inside[n]}/{R}   PIT KS p = {ks[n]:.3f}   sd / Laplace sd (median) "
                     f"{ratio:.2f}   u = {np.round(sorted(r['pit'][n] for r in reps), 2).tolist()}")
    return "\n".join(lines), inside, ks


@pytest.mark.parametrize("model", MODELS)
def test_importance_sampling_is_reliable(replications, model):
    report, _, _ = _report(model, replications[model])
    assert all(r["pareto_k"] < MAX_PARETO_K for r in replications[model]), report


@pytest.mark.parametrize("model", MODELS)
def test_90_percent_intervals_cover_the_truth_at_the_nominal_rate(replications, model):
    report, inside, ks = _report(model, replications[model])
    print(report)
    for n in inside:
        assert inside[n] >= LOWEST_COUNT, report
        assert ks[n] > 0.001, report
