"""Frequentist calibration of emcee's 90 % posterior intervals over noise draws of recordings the
model did not make.

Case: model "air" (parameters EI, gamma and the noise sd sigma) on the independent reference
simulator's hammer test of the paper's beam (tests/diagnosis_cases.py: 4 ms pulse at 0.75 m, tip
accelerometer, 512 Hz for 1 s, 2 % sensor noise, a clean force channel; beam.toml's modulus 7 %
above the truth, so the EI prior is centred off it), fitted with quintic splines at N = 8 (their
error on this recording is 0.016 noise sd RMS, a chi2 of 0.13 over the record, which can move the
posterior by at most sqrt(0.13) = 0.36 of its sd in any direction, and less within the fitted
band). The same clean signals with R = 20 independent noise draws (seeds 1000..1019, fixed by
rule; the reference caches the clean simulation), each sampled by the stages of
``bayesbeam.inference.fit`` (prepare, find_optimum with shortened global stages, run_emcee; the
InferenceData and the discretisation check, which do not change the posterior, are skipped) with
12 walkers and 400 steps: tau ~ 20-30 steps, so ~150 effective draws per fit. The intervals are numpy quantiles 0.05
and 0.95 of the draws, as in the summary. The data are informative (the priors are nearly flat
over the likelihood), so by Bernstein-von Mises the posterior's 90 % interval should cover the
fixed truth 90 % of the time. This is the suite's calibration of emcee itself (its chains, burn-in
and quantiles); tests/acceptance/test_calibration.py calibrates q1 on the same simulator by
importance sampling.

Acceptance band, per parameter. The coverage count is Binomial(20, 0.9) under calibration:
P(X <= 13) = 0.0024, P(X <= 14) = 0.0113, P(X = 20) = 0.1216. So the band is 14 <= X <= 20
(70-100 %): false-alarm probability 0.0024 per parameter, at most 0.0072 for the three. An upper
bound is useless with R = 20 (even 20/20 happens 12 % of the time; "at most 97 %" would fail
calibrated intervals one run in eight), so over-coverage (intervals too wide) is tested instead by
the probability integral transform: u = P(parameter < truth | data) is Uniform(0, 1) under
calibration; the Kolmogorov-Smirnov test of the 20 u's must not reject at level 0.001 (false
alarm 0.001 per parameter, 0.003 for three). Family-wise false-alarm probability of this file:
at most 0.0072 + 0.003 ~ 1 %. MCMC error in u (sd <= 0.035 with ~200 effective draws) and in the
interval ends makes the band slightly conservative, not liberal. (Measured: see the printed
report, run with -s.)

The 20 fits run on two worker processes (the suite's budget is two cores).
"""
import numpy as np
import pytest
from scipy import stats

from tests.inference import cases

R = 20
SEEDS = range(1000, 1000 + R)
WALKERS, STEPS = 12, 400
LOWEST_COUNT = 14
MODEL = "air"


def test_acceptance_band_is_what_the_docstring_says():
    binom = stats.binom(R, 0.9)
    assert binom.cdf(LOWEST_COUNT - 1) == pytest.approx(0.0024, abs=5e-5)
    assert binom.cdf(LOWEST_COUNT) > 0.005          # 14 is the largest bound with < 0.5 % false alarm
    assert binom.pmf(R) == pytest.approx(0.1216, abs=5e-5)


def sample_reference(seed: int, walkers: int, steps: int) -> dict:
    """One noise draw's posterior by fit's own stages (module-level: a spawned worker runs it).

    Returns {"truth", "quantiles", "pit", "tau", "seconds"} as tests/inference/cases.sample_case;
    the noise sd's truth is the reference's rule applied to the clean signal."""
    import time

    from bayesbeam.inference.fit import prepare
    from bayesbeam.inference.sampler import find_optimum, run_emcee
    from tests.diagnosis_cases import FIT, N_INTERVALS, SENSOR_NOISE, reference, rms

    started = time.perf_counter()
    rec, clean = reference(seed=seed, model=MODEL)
    rng = np.random.default_rng(seed)
    post = prepare(rec, MODEL, FIT, N_INTERVALS).posterior
    # emcee's start only: the shortened global stages (81 EI scan points, 15 differential-evolution
    # iterations, as tests/checks/test_discrepancy.py) reach the default's optimum to 1e-7 here at half the cost
    optimum = find_optimum(post, rng, scan_points=81, de_iterations=15)
    chains = run_emcee(post, optimum, rng, n_walkers=walkers, max_steps=steps)
    values = np.stack([p.to_value(chains.samples[..., i]) for i, p in enumerate(post.priors)], axis=-1)
    out = cases._posterior_report(post, values, MODEL, SENSOR_NOISE.sensor * rms(clean.signals), (0.05, 0.95))
    out.update(tau=chains.tau.tolist(), seconds=time.perf_counter() - started)
    return out


@pytest.fixture(scope="module")
def replications():
    return cases.run_in_processes(sample_reference, [(seed, WALKERS, STEPS) for seed in SEEDS])


@pytest.mark.slow
def test_90_percent_intervals_cover_the_truth_at_the_nominal_rate(replications):
    names = ["EI", "gamma", "sigma_accel_tip"]
    inside = {n: 0 for n in names}
    pits = {n: [] for n in names}
    for r in replications:
        for n in names:
            q05, q95 = r["quantiles"][n]
            inside[n] += q05 < r["truth"][n] < q95
            pits[n].append(r["pit"][n])
    seconds = [r["seconds"] for r in replications]
    tau = max(max(r["tau"]) for r in replications)
    report = [f"{R} fits, {np.mean(seconds):.1f} s each (one worker), largest tau {tau:.0f} steps"]
    for n in names:
        p = stats.kstest(pits[n], "uniform").pvalue
        report.append(f"  {n:16s} coverage {inside[n]}/{R} = {inside[n] / R:.0%}   PIT KS p = {p:.3f}   "
                      f"u = {np.round(sorted(pits[n]), 2).tolist()}")
    print("\n".join(report))
    for n in names:
        assert inside[n] >= LOWEST_COUNT, "\n".join(report)
        assert stats.kstest(pits[n], "uniform").pvalue > 0.001, "\n".join(report)
