"""The right catalogue effect ranks first, before anything is fitted, and none on a null recording.

Recordings and fits are test_discrepancy's: q1 fitted (quintic N = 8) without the effect to the
independent reference simulator's recording with it (tests/diagnosis_cases.py: paper beam, 2 %
sensor noise, clean force, fixed seeds). Concealed effects at moderate magnitude: a root spring
lowering mode 1 by 1.9 %, a 10 g sensor at the tip, a 0.5 ms delay, a 5 N tension (mode 1 +2 %)
and 50 mN of tip friction (15 mN, 2.4 % of the signal's RMS, is not seen here: Delta chi2 6.7 even
on data of the fitted model's own, at N = 16).

Tolerances. Ranked first and "supported": Delta chi2 above the F(1, 19) quantile at 0.01 / 6
candidates, 13.4. The true effects' Delta chi2 here are 43-4130; the runner-up's at most 3 (a
third of the winner's at most) except for the root spring, whose runner-up, a compressive axial
load (which also lowers the low modes most), is supported too (ratio 1.3-3.6 over seeds 3-6; the
spring first in all four): for it only the order is asserted.

The screen's parameter estimate (a feature-space least squares with the baseline re-adjusted by
Gauss-Newton, not the fit of the augmented model, which comes later) is asked to be within a
factor 1.5 of the truth (1.2 for the delay, which enters linearly): a screen that names the
effect and its size is what is needed to choose which augmented models to fit. It holds for the
delay (0.499 ms) and the tension (5.01 N). It does not for the root spring (24 300 N m/rad against
4428), the sensor mass (2.4 g against 10 g) and the friction (16 mN against 50 mN), on these
recordings and on data made by the fitted model itself at N = 16 alike: the grid search runs on
the signature before the baseline's re-adjustment, whose size (gamma moved by a factor ~50 for the
sensor mass) the refinement between the grid minimum's neighbours cannot recover. Those three are
strict expected failures, so that a fix shows.
"""
from functools import cache

import numpy as np
import pytest

from bayesbeam.checks.discrepancy import locate
from bayesbeam.checks.signatures import rank_effects
from bayesbeam.inference.fit import prepare
from bayesbeam.inference.sampler import find_optimum
from tests.checks.test_discrepancy import REPLICATES, fitted, recording
from tests.diagnosis_cases import CONCEALED, FIT, N_INTERVALS

#: case -> allowed factor between the screen's estimate and the truth
FACTOR = {"root_compliance": 1.5, "sensor_mass": 1.5, "measurement_delay": 1.2, "axial_load": 1.5,
          "dry_friction": 1.5}
#: the screen's estimate misses by more (module docstring)
MISSED_SIZE = pytest.mark.xfail(strict=True, reason="the signature screen's estimate of k_theta, m_s and F_c "
                                                    "is 3-5.5 x off on data the model did not make")


@cache
def ranking(case):
    post, draws, mismatch = fitted(case)
    return rank_effects(post, draws, mismatch)


def truth(case) -> float:
    (value,) = CONCEALED[case].values()
    return value


@pytest.mark.parametrize("case", list(FACTOR))
def test_concealed_effect_ranks_first(case):
    result = ranking(case)
    best = result.candidates[0]
    print(f"{case}: {[(c.effect, round(c.delta_chi2, 1)) for c in result.candidates]}; "
          f"{best.parameter} = {best.value:.4g} (90 %: {best.interval_90}), truth {truth(case)}")
    assert best.effect == case and best.supported and best.within_prior
    assert result.best is best
    if case != "root_compliance":
        assert best.delta_chi2 > 3 * result.candidates[1].delta_chi2


@pytest.mark.parametrize("case", [pytest.param(c, marks=[] if c in ("measurement_delay", "axial_load") else MISSED_SIZE)
                                  for c in FACTOR])
def test_the_screen_sizes_the_effect(case):
    best = next(c for c in ranking(case).candidates if c.effect == case)
    assert 1 / FACTOR[case] < best.value / truth(case) < FACTOR[case], best.value


def test_null_recording_names_no_effect():
    """Level: each candidate at 0.01 / 6 (Bonferroni; family-wise 0.01); the projected mismatch's
    test at 0.01 (p = 0.52 here)."""
    result = ranking("null")
    assert result.p_value >= 0.01
    assert result.best is None and not any(c.supported for c in result.candidates)
    assert "no effect is needed" in " ".join(result.notes)


def test_reasoning_states_what_a_person_can_check():
    """The sentence names the effect's physics, its own frequency shifts, observed against
    predicted features, the share of the mismatch explained, the parameter against its prior, and
    what the runner-up predicts at the same feature."""
    best = ranking("root_compliance").candidates[0]
    text = best.reasoning
    for part in ("lowers every mode", "on its own (EI fixed) it shifts modes 1-4 by", "observed",
                 "predicted", "of the mismatch", "k_theta =", "inside the prior", "supported",
                 "The next candidate"):
        assert part in text, part
    assert np.all(np.array(best.frequency_shift_pct[:4]) < 0)


def test_effects_the_model_cannot_take_are_left_out_with_the_reason():
    """Time hysteresis has no finite state space, so the nonlinear effects cannot be integrated
    with it: the ranking leaves them out and says why instead of failing."""
    post = prepare(recording("null"), "q2", FIT, N_INTERVALS).posterior
    optimum = find_optimum(post, np.random.default_rng(1), scan_points=81, de_iterations=15)
    draws = np.random.default_rng(1).multivariate_normal(optimum.theta, optimum.covariance, 200)
    result = rank_effects(post, draws, locate(post, draws, np.random.default_rng(2), REPLICATES))
    assert {c.effect for c in result.candidates} == {"root_compliance", "sensor_mass", "axial_load",
                                                     "measurement_delay"}
    notes = " ".join(result.notes)
    for name in ("quadratic_drag", "dry_friction"):
        assert f"{name} not ranked: {name} cannot be combined with a memory mechanism" in notes
