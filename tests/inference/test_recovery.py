"""Known parameters come back: one cheap simulated recording per model of the paper, fitted with
``bayesbeam.inference.fit``, and the truth lies inside the posterior's central 99 % interval.

Cases (cases.py): the paper's beam, Gaussian force pulse at 0.75 m, tip accelerometer, 512 Hz for
1 s, simulated at N = 6 and fitted at N = 6, 2 % white noise. True values: q1 gamma = 0.3,
cdI = 7e-5; q2 alpha = 2, beta = 200; q3 gamma = 0.12, a = 0.025, b = 0.18; EI = 44.28.

Statistical bound. A calibrated 99 % interval misses with probability 1 %; the 10 model parameters
(3 + 3 + 4; the noise sd is covered by test_calibration) make a family-wise false-alarm probability
of at most 10 % by Bonferroni, less in practice because the parameters of one fit are correlated.
The seeds (11, 12, 13 for q1, q2, q3) were fixed by rule before the first run and not searched.
The 90 % intervals are printed for information only (a 90 % interval misses 10 % of the time).

Chains: 12 walkers x 1000 steps from the optimum. That is 25-30 tau for q1 and q2 but only ~13 for
q3, whose a and b are strongly correlated (for small b spatial hysteresis acts like Kelvin-Voigt
with cdI = a b^2 / 2): its R-hat reaches ~1.35 and its summary says "not converged". The test
checks that the truth is covered, which such a chain still does; convergence is test_fit_outputs'.

The three fits run on two worker processes (the suite's budget is two cores).
"""
import pytest

from tests.inference import cases

RUNS = {"q3": (13, 12, 1000), "q1": (11, 12, 1000), "q2": (12, 12, 1000)}   # seed, walkers, steps


@pytest.fixture(scope="module")
def fits():
    order = list(RUNS)                       # the longest (q3) first: it runs alone on one worker
    results = cases.run_in_processes(cases.fit_case, [(m, *RUNS[m]) for m in order])
    return dict(zip(order, results))


@pytest.mark.parametrize("model", ["q1", "q2", "q3"])
def test_truth_inside_the_99_percent_interval(fits, model):
    r = fits[model]
    summary = r["summary"]
    lines = [(f"{model}: {r['seconds']:.0f} s, {summary['convergence']['n_steps']} steps, "
              f"max tau {summary['tau']:.0f}, acceptance {summary['acceptance']:.2f}")]
    misses = []
    for name in summary["parameters"]:
        q005, q05, q95, q995 = r["quantiles"][name]
        truth = r["truth"][name]
        lines.append(f"  {name:6s} truth {truth:.5g}  90% [{q05:.5g}, {q95:.5g}]  99% [{q005:.5g}, {q995:.5g}]"
                     f"  P(< truth) = {r['pit'][name]:.3f}  r_hat {summary['parameters'][name]['r_hat']:.3f}")
        if not q005 < truth < q995:
            misses.append(name)
    print("\n".join(lines))
    assert set(summary["parameters"]) == set(cases.TRUTH[model])
    assert not misses, "\n".join(lines)
