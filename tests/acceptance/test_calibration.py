"""Frequentist calibration of the 90 % posterior intervals over noise draws of recordings the model
did not make.

Cases: the reference simulator's hammer tests of the paper's beam (cases.py; 2 % sensor noise,
force noise 0.5 % of the peak, beam.toml's modulus 7 % above the truth), each the same clean
signal with R = 20 independent noise draws (seeds 1000..1019, fixed by rule; the reference caches
the clean simulation and adds its white noise after the DAQ filter, so a draw costs only its noise):

* q1 (EI, gamma, cdI): 1 s at 512 Hz, a 4 ms pulse, cubic splines at N = 48, the N the automatic
  choice takes on these recordings (test_fit.py asserts it);
* q3 (EI, gamma, a, b): the paper's beam struck by a 1 ms pulse and recorded for 2 s at 1024 Hz
  ("paper_long"), quintic splines (a third of the cubic's intervals for the same in-band
  accuracy, fit.N_LADDERS) at N = 16, the automatic choice on the 1 s record at 1024 Hz. This is
  a choice of experiment, made because q3 on the 1 s record at 512 Hz cannot be calibrated at a
  fixed truth (below);
* q3_rich (EI, gamma, a, b): a long, rich record ("rich": 4 s at 4096 Hz, an 80 N hit of 0.4 ms
  at 0.6 m, 1.5 % sensor and 1 % force noise, gamma 0.2, a 0.03, b 0.2) fitted to 152 Hz, so the
  fit decimates by 10, with quintic splines at N = 16. Here the force noise's marginalisation
  decides the width of the intervals: with the recorded samples' noise grouped onto the nearest
  decimated samples (instead of the principal inputs of signals.force_noise) gamma and b
  covered the truth in 47 and 48 of 60 draws (sd of (median - truth) / posterior sd 1.25 and
  1.30), and on this test's 20 draws b in 13, below the band.

Every case also calibrates the noise sd sigma_accel_tip (truth: the Noise rule applied to the
clean signal): a likelihood whose noise level is wrong shows there first. N is checked on the
first draw as the fit checks it: the optimum's move to the next N of the ladder, estimated by a
Newton step, must stay below 0.1 posterior sd.

Why q3 needs the longer, wider-band record. On the 1 s record at 512 Hz (four modes in band) the
posterior of (a, b) runs along the Kelvin-Voigt limit a b^2 / 2 = const toward b's prior bound:
on seed 1003 the profile log posterior falls only 1.2 when log b is 1.5 below its optimum
(1.0-3.4 x the Laplace sd in other draws). Recorded at 1024 Hz (six modes: the kernel's length
b then shows where the modal damping saturates) but for 1 s, log gamma runs toward gamma = 0:
on seed 1004 its profile falls 2.3 over 3 units below its optimum, because mode 1 (3.7 Hz,
decaying over about 17 s), whose damping gamma mainly sets, is seen for less than four cycles.
Where a posterior reaches so far into its prior, a correct posterior's intervals need not cover a
fixed truth at their nominal rate (the PIT is uniform only averaged over the prior), so such a
test could not tell a wrong likelihood from a right one. Recorded for 2 s at 1024 Hz the same
profiles fall 27 nats (log gamma 1 below, seed 1004) and 580 nats (log b 0.5 below): the
likelihood dominates, and the importance-sampled sd is 0.2-1.7 x the Laplace sd at the truth
(a Laplace sd that is itself unreliable along the damping ridge: below).

The posterior of each draw. emcee per draw does not fit the suite's budget (q3: tau ~ 50-100
steps x 20 walkers x 20 draws), so the posterior is computed by adaptive importance sampling
(importance.py), exact up to Monte Carlo error: three planned stages of multivariate t proposals
(5 degrees of freedom, 250, 250 and 500 draws), the first the Laplace approximation at the truth
moved by one Newton step (kept at the truth when the step lowers the log posterior), 2 x its sd
wide, each later one the weighted moments of all draws so far, 1.3 x wide; every draw weighted
by posterior / mixture of the stages, Pareto-smoothed. While the Pareto k of all draws' weights
is 0.7 or more, further stages of 250 draws follow, each again from the weighted moments of all
draws so far, at most eight. A noise draw is certified when its k is below 0.7, where smoothed
importance sampling is reliable (Vehtari et al. 2024); the coverage and PIT tests count only
certified draws (an uncertified one fails them), and the reliability test lists which draws the
planned stages certified and which the further ones did. Where the proposal starts changes only
the efficiency, not the target. Intervals: weighted 5 % and 95 % quantiles in the sampling
coordinate; the probability integral transform u = weighted P(parameter < truth).

Why a start can fail: the Laplace covariance at the truth (sampler.laplace_covariance: finite
differences with steps of 1e-4 in every sampling coordinate) is unreliable along q3's damping
ridge. The log posterior (about -1600 nats) carries a rounding error of ~1e-6 nats at each
point, ~50-100 in each Hessian entry after the division by 4 step^2, while the curvature of the
(gamma, a, b) ridge is ~200. On seed 1016 one rounding error at the truth itself, shared by the
three diagonal entries, lowers each by ~200: the ridge's curvature comes out 6 instead of 194
(steps of 0.1 posterior sd give 194-205), so the start's sd is about 5 x the posterior's in
gamma and in b, with their correlation -0.996 instead of -0.88. The Newton step with that
covariance moves gamma by 15 posterior sd and lowers the log posterior by 200 nats, so the
proposal starts at the truth, about 10 x the posterior's width along the ridge; the planned
stages' weights hold 2-10 effective draws (k 3.06, 2.96, 2.25), too few (more than 4 x 5 are
needed) to move the proposal. The posterior itself is neither bimodal nor heavy-tailed: started
from the optimum (a polish from the truth, about 1 sd away in gamma and 2 in sigma_accel_tip)
and its Laplace covariance, the planned stages give k -0.19 and 470 effective draws of 1000;
its sd lies within 3 % of the Laplace sd of a Hessian with steps of 0.1 sd there and its mean
within 0.4 sd of the optimum: a nearly Gaussian ridge. With the further stages the accumulated
effective draws exceed 20 after the seventh stage, the proposal moves onto the ridge, and k falls
to 0.15 at the eighth (2250 draws); the other 19 draws have k -0.45..0.24 after the planned
stages.

Acceptance band, per parameter (as tests/inference/test_calibration.py). Coverage count
~ Binomial(20, 0.9) under calibration: P(X <= 13) = 0.0024, so 14 <= X (70-100 %) has a false
alarm of 0.0024 per parameter. Over-coverage is tested by the PIT: u ~ Uniform(0, 1) under
calibration, and the Kolmogorov-Smirnov test of the 20 u's must not reject at level 0.001.
Fourteen parameters (four of q1, five of each q3 case), two tests each: family-wise false alarm
at most 14 x (0.0024 + 0.001) = 4.8 %. Importance-sampling error in u (sd <= 1/(2 sqrt(ESS)) <= 0.05 at
the ESS seen, 108 or more) makes the band slightly conservative, not liberal.

What the band lets through: q3's gamma leans low on these seeds. Its u averages 0.61 over seeds
1000-1059 (3 sd above 0.5 for a mean of 60 uniforms; KS p 0.02-0.04 on twenty or forty of them),
i.e. its posterior sits about 0.3 sd below the truth on average. The lean belongs to these noise
draws: what the model, the priors and the likelihood add to the posterior's location is near zero
(in sd of gamma's posterior, which the force noise makes 1.5 x the noise-free Fisher sd):

* model error: the noise-free recording's likelihood peaks +0.02 sd from the truth, against the
  lean (every parameter within 0.06 Fisher sd: test_q3_bias.py); the reference's discretisation
  does not change that: on 180 elements instead of 120 the same draws' u move by at most 0.06;
* priors: gamma, a and b are log-uniform, flat in the sampling coordinate ln(value); EI's
  log-normal moves the posterior by 2e-6 sd;
* nonlinearity: the optimum departs from its linear response to the noise by -0.02 sd on average;
  on the noise-free recording the importance-sampled posterior is Gaussian (sd 1.00-1.02 x the
  Laplace sd, median within 0.06 sd of the peak);
* force noise (marginalised): with clean sensors its draws move the optimum by -0.01 +- 0.03 sd.

The draws: the optimum's linear response to each draw's noise (a Newton step from the truth, of
mean zero exactly) averages -0.34 sd over seeds 1000-1019, -0.26 +- 0.11 over 1000-1059 and
+0.01 +- 0.03 over 1000-1999, whose Laplace u average 0.61, 0.58 and 0.50; the converged optima of
seeds 5000-5225 average -0.04 +- 0.06 sd (u 0.50).

The 63 jobs run on two worker processes (the suite's budget is two cores).
"""
import numpy as np
import pytest
from scipy import stats

from bayesbeam.inference.screens import PARETO_K_LIMIT as MAX_PARETO_K
from tests.acceptance import cases as ac
from tests.acceptance.importance import adaptive_importance
from tests.inference.cases import run_in_processes

R = 20
SEEDS = range(1000, 1000 + R)
#: case -> (model, test set-up of cases.py, spline degree, N, fitted band in Hz or None for the
#: default); the longest first
CASES = {"q3_rich": ("q3", "rich", 5, 16, 152.0), "q3": ("q3", "paper_long", 5, 16, None),
         "q1": ("q1", "paper", 3, 48, None)}
#: draws of each importance-sampling stage
STAGES = (250, 250, 500)
#: at most this many further stages of 250 draws while a draw's Pareto k is 0.7 or more
MORE_STAGES = 8
LOWEST_COUNT = 14


def test_acceptance_band_is_what_the_docstring_says():
    binom = stats.binom(R, 0.9)
    assert binom.cdf(LOWEST_COUNT - 1) == pytest.approx(0.0024, abs=5e-5)
    assert binom.cdf(LOWEST_COUNT) > 0.005          # 14 is the largest bound with < 0.5 % false alarm


def _banana(x: np.ndarray, bend: float) -> float:
    """log density of y = (x1, x2 - bend (x1^2 - 1), x3, x4) ~ N(0, I): x1 ~ N(0, 1) exactly."""
    y = np.array([x[0], x[1] - bend * (x[0] ** 2 - 1), *x[2:]])
    return float(-0.5 * y @ y)


def test_adaptive_importance_recovers_a_known_banana():
    """From a misplaced, too narrow start, the stages recover a curved 4-d target's known marginals:
    P(x1 < 1) = Phi(1) and E[x2] = 0 (var 1 + 2 bend^2). Tolerance 4 Monte Carlo sd (sd of a
    weighted share <= 0.5 / sqrt(ESS), of a weighted mean sd / sqrt(ESS))."""
    bend = 0.4
    result = adaptive_importance(lambda x: _banana(x, bend), np.full(4, 0.5), 0.3 * np.eye(4), STAGES,
                                 np.random.default_rng(0))
    assert result.pareto_k < MAX_PARETO_K
    assert result.below(0, 1.0) == pytest.approx(stats.norm.cdf(1.0), abs=4 * 0.5 / np.sqrt(result.ess))
    sd_x2 = np.sqrt(1 + 2 * bend**2)
    assert result.weights @ result.draws[:, 1] == pytest.approx(0.0, abs=4 * sd_x2 / np.sqrt(result.ess))


def test_further_stages_certify_a_start_too_wide_along_a_ridge():
    """A start like q3's Laplace approximation where it fails (module docstring): centred on the
    target but 50 x its variance along a direction of correlation 0.996 between x1 and x2. The
    planned stages leave k > 0.7 (with this start and seed their weights hold 7-16 effective
    draws, too few to move the proposal); the further stages bring k below 0.7 and recover the
    marginals of the banana test, to the same 4 Monte Carlo sd."""
    bend = 0.4
    start = np.eye(4)
    start[:2, :2] = 50.0 * np.array([[1.0, 0.996], [0.996, 1.0]])
    planned = adaptive_importance(lambda x: _banana(x, bend), np.zeros(4), start, STAGES, np.random.default_rng(0))
    result = adaptive_importance(lambda x: _banana(x, bend), np.zeros(4), start, STAGES, np.random.default_rng(0),
                                 more=MORE_STAGES)
    assert planned.pareto_k > MAX_PARETO_K
    assert result.pareto_k < MAX_PARETO_K
    assert result.below(0, 1.0) == pytest.approx(stats.norm.cdf(1.0), abs=4 * 0.5 / np.sqrt(result.ess))
    sd_x2 = np.sqrt(1 + 2 * bend**2)
    assert result.weights @ result.draws[:, 1] == pytest.approx(0.0, abs=4 * sd_x2 / np.sqrt(result.ess))


def test_pareto_k_flags_a_proposal_with_lighter_tails_than_the_target():
    """One stage of a nearly Gaussian proposal (a t with 30 degrees of freedom) for a Cauchy-tailed
    target (a t with 1): the weights w ~ r^29 at radius r, whose tail P(w > t) ~ t^(-30/29) has
    k = 29/30; k must say so (> 0.7). k-hat is an estimate from the draws: with 4000 it ranged
    0.88-1.34 over seeds 0-11 (with 1000, 0.46-1.06: the tail is then too rarely drawn)."""
    target = stats.multivariate_t(np.zeros(3), np.eye(3), df=1)
    result = adaptive_importance(target.logpdf, np.zeros(3), np.eye(3), (4000,), np.random.default_rng(0),
                                 df=30.0, first_widen=1.0)
    assert result.pareto_k > MAX_PARETO_K


def _posterior(case: str, seed: int, n_intervals: int | None = None):
    """(log posterior, truth with the noise sd) of one noise draw of ``case``."""
    from bayesbeam.inference import FitConfig
    from bayesbeam.inference.fit import prepare

    model, setting, degree, n, band = CASES[case]
    n = n_intervals or n
    rec, truth = ac.hammer(model, setting, seed=seed)
    problem = prepare(rec, model, FitConfig(n_intervals=n, degree=degree, max_frequency=band), n)
    # white noise keeps its density in the band: its sd at fs / D is 1 / sqrt(D) of the recorded one
    noise_sd = ac.true_noise_sd(model, setting)[0] / np.sqrt(problem.decimation)
    return problem.posterior, {**truth, "sigma_accel_tip": noise_sd}


def importance_posterior(case: str, seed: int) -> dict:
    """The posterior of one noise draw by adaptive importance sampling (module docstring);
    module-level: runs in a worker process."""
    import time

    from bayesbeam.inference.sampler import laplace_covariance, newton_shift

    started, cpu = time.perf_counter(), time.process_time()
    post, truth = _posterior(case, seed)
    truth_z = post.coordinates(truth)
    covariance = laplace_covariance(post, truth_z)
    centre = truth_z + newton_shift(post, truth_z, covariance)
    if not post(centre) > post(truth_z):
        centre = truth_z
    result = adaptive_importance(post, centre, covariance, STAGES, np.random.default_rng(seed), more=MORE_STAGES)
    return {
        "seed": seed, "names": post.names, "pareto_k": result.pareto_k, "stage_k": result.stage_k,
        "ess": result.ess, "n_draws": len(result.draws),
        "interval": {n: result.quantile(i, [0.05, 0.95]).tolist() for i, n in enumerate(post.names)},
        "truth_z": dict(zip(post.names, truth_z.tolist())),
        "pit": {n: result.below(i, truth_z[i]) for i, n in enumerate(post.names)},
        "sd_over_laplace": dict(zip(post.names, (result.sd() / np.sqrt(np.diag(covariance))).tolist())),
        "seconds": time.perf_counter() - started, "cpu_seconds": time.process_time() - cpu,
    }


def refinement_shift(case: str, seed: int) -> dict:
    """The fit's discretisation check on one draw: the optimum's move to the next N of the ladder
    (Newton estimate), in posterior sd, per model parameter."""
    from bayesbeam.inference.fit import N_LADDERS
    from bayesbeam.inference.sampler import find_optimum, newton_shift

    _, _, degree, n, _ = CASES[case]
    post, truth = _posterior(case, seed)
    optimum = find_optimum(post, np.random.default_rng(seed), start=truth)
    finer, _ = _posterior(case, seed, N_LADDERS[degree][N_LADDERS[degree].index(n) + 1])
    k = len(post.model_names)
    moved = newton_shift(finer, optimum.theta, optimum.covariance)[:k]
    return dict(zip(post.model_names, (np.abs(moved) / np.sqrt(np.diag(optimum.covariance)[:k])).tolist()))


def job(kind: str, case: str, seed: int):
    return (importance_posterior if kind == "draw" else refinement_shift)(case, seed)


@pytest.fixture(scope="module")
def replications():
    jobs = [("draw", c, s) for c in CASES for s in SEEDS] + [("check", c, SEEDS[0]) for c in CASES]
    results = dict(zip(jobs, run_in_processes(job, jobs)))
    return {c: {"draws": [results["draw", c, s] for s in SEEDS], "shift": results["check", c, SEEDS[0]]}
            for c in CASES}


def _report(case: str, reps: list) -> tuple[str, dict, dict]:
    names = reps[0]["names"]
    inside = {n: sum(lo < r["truth_z"][n] < hi for r in reps for lo, hi in [r["interval"][n]]) for n in names}
    ks = {n: stats.kstest([r["pit"][n] for r in reps], "uniform").pvalue for n in names}
    lines = [(f"{case}: {R} draws, {np.mean([r['seconds'] for r in reps]):.1f} s each (one worker; "
              f"{np.mean([r['cpu_seconds'] for r in reps]):.1f} s of CPU), Pareto k "
              f"{min(r['pareto_k'] for r in reps):.2f}..{max(r['pareto_k'] for r in reps):.2f}, "
              f"ESS >= {min(r['ess'] for r in reps):.0f}")]
    for n in names:
        ratio = np.percentile([r["sd_over_laplace"][n] for r in reps], [0, 50, 100])
        lines.append(f"  {n:16s} coverage {inside[n]}/{R}   PIT KS p = {ks[n]:.3f}   sd / Laplace sd at the truth "
                     f"{ratio[0]:.2f}..{ratio[2]:.2f} (median {ratio[1]:.2f})   "
                     f"u = {np.round(sorted(r['pit'][n] for r in reps), 2).tolist()}")
    return "\n".join(lines), inside, ks


@pytest.mark.slow
@pytest.mark.long
@pytest.mark.parametrize("case", CASES)
def test_discretisation_passes_the_fits_refinement_check(replications, case):
    from bayesbeam.inference.fit import SHIFT_TOLERANCE

    shift = replications[case]["shift"]
    print(f"{case}: optimum's move to the next N, in posterior sd: {shift}")
    assert max(shift.values()) < SHIFT_TOLERANCE, shift


def _certification(case: str, reps: list) -> tuple[str, list]:
    """(which stage certified each draw, the seeds of the draws no stage certified)."""
    def line(r):
        return f"{r['seed']}: {len(r['stage_k'])} stages, {r['n_draws']} draws, k {r['pareto_k']:.2f}"

    planned = [r["seed"] for r in reps if len(r["stage_k"]) == len(STAGES) and r["pareto_k"] < MAX_PARETO_K]
    further = [line(r) for r in reps if len(r["stage_k"]) > len(STAGES) and r["pareto_k"] < MAX_PARETO_K]
    uncertified = [r["seed"] for r in reps if not r["pareto_k"] < MAX_PARETO_K]
    text = (f"{case}: certified by Pareto k < {MAX_PARETO_K} after the {len(STAGES)} planned stages: "
            f"{len(planned)} draws; after further stages: {further or 'none'}; not certified: "
            f"{[line(r) for r in reps if r['seed'] in uncertified] or 'none'}")
    return text, uncertified


@pytest.mark.slow
@pytest.mark.long
@pytest.mark.parametrize("case", CASES)
def test_importance_sampling_is_reliable(replications, case):
    """Every draw's weights have Pareto k < 0.7 (after the planned or the further stages)."""
    reps = replications[case]["draws"]
    certified, uncertified = _certification(case, reps)
    print(certified)
    assert not uncertified, certified + "\n" + _report(case, reps)[0]


@pytest.mark.slow
@pytest.mark.long
@pytest.mark.parametrize("case", CASES)
def test_90_percent_intervals_cover_the_truth_at_the_nominal_rate(replications, case):
    """Counts only certified draws: one whose weights are not certified fails the test."""
    certified, uncertified = _certification(case, replications[case]["draws"])
    assert not uncertified, certified
    report, inside, ks = _report(case, replications[case]["draws"])
    print(report)
    for n in inside:
        assert inside[n] >= LOWEST_COUNT, report
        assert ks[n] > 0.001, report
