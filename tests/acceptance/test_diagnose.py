"""The diagnosis names what is missing, and only that, on recordings it did not make.

Recordings of the independent reference simulator (``tests.acceptance.cases``: the paper's beam,
q1 damping, 1 s at 512 Hz, 2 % sensor and 0.5 % force noise, the beam.toml's modulus 7 % above
the truth), diagnosed blind against q1 (the baseline named) with N chosen automatically on
quintic splines (as in ``tests/acceptance/test_compare.py``), 2 SMC repeats and 20 map replicates:

* a concealed root spring (k_theta = 100 EI/l, mode 1 1.9 % low), a 0.5 ms delay of the response
  channels and a 10 g sensor at the tip must each be named, added alone, with the truth inside
  its 99 % interval, and leave nothing unexplained;
* on null recordings (a tip accelerometer; the same with a displacement channel at mid-span)
  nothing may be fitted or added and nothing may be left unexplained.
"""
from functools import cache

import numpy as np
import pytest

from bayesbeam.comparison import CompareConfig
from bayesbeam.diagnosis import DECISIVE, DiagnoseConfig, diagnose, flags
from bayesbeam.inference.fit import FitConfig
from tests.acceptance import cases

pytestmark = pytest.mark.slow  # minutes of fits: left out of the fast subset (docs/testing.md)

CONFIG = DiagnoseConfig(CompareConfig(FitConfig(n_intervals=None, degree=5), repeats=2, replicates=20),
                        replicates=20)
#: the map's RMS standardized residual of a right model is 1 up to its own scatter: ~390 band
#: coordinates per channel (sd of the mean square sqrt(2/390) = 0.07) over a floor estimated from
#: the same cells, exactly 1 when no cell is flagged; 0.1 is 1.4 sd
RMS_TOLERANCE = 0.1
#: the concealed effects' parameters (the reference's names are the catalogue's)
PARAMETER = {"root_compliance": "k_theta", "measurement_delay": "tau", "sensor_mass": "m_s"}


@cache
def _diagnosed(effect, displacement, executor):
    return diagnose(cases.hammer("q1", effect=effect, displacement=displacement)[0], "q1", CONFIG, executor)


#: the effects whose diagnoses run in the long tier (docs/testing.md); the nulls' run in the default
#: suite, beside tests/test_diagnosis.py's free decay (an axial load named, added and covered)
LONG_EFFECTS = ("measurement_delay", "root_compliance", "sensor_mass")


@pytest.mark.parametrize("effect", [pytest.param(e, marks=pytest.mark.long) if e in LONG_EFFECTS else e
                                    for e in sorted(cases.EFFECTS)])
def test_a_concealed_effect_is_named_added_and_its_truth_covered(executor, effect):
    """Added alone by the decision rule (ln B > 5 by 3 sd, map improved), the truth inside the
    added parameter's 99 % interval: with three effects a 90 % interval would miss one of them by
    chance 27 % of the time, a 99 % one 3 % (the delay's tau, 0.461 ms with 90 % interval
    0.420-0.495, sits 1.7 sd from its truth of 0.5 ms)."""
    d = _diagnosed(effect, False, executor)
    name = PARAMETER[effect]
    truth = cases.hammer("q1", effect=effect)[1][name]
    assert d.added == [effect] and not d.unexplained, d.to_dict()["summary"]
    trial = next(t for t in d.trials if t.added)
    assert trial.log_bayes_factor - 3 * trial.log_bayes_factor_sd > DECISIVE
    draws = trial.result.values()[..., trial.result.problem.posterior.names.index(name)]
    interval = np.quantile(draws, [0.005, 0.995])
    assert interval[0] <= truth <= interval[1], (interval, truth)
    summary = d.to_dict()
    # the baseline's map flags the effect; the augmented model's map is clean and at the noise
    assert flags(d.baseline_mismatch) > 0 and flags(d.final_mismatch) == 0
    assert abs(d.final_mismatch.rms_standardized_residual - 1) < RMS_TOLERANCE
    assert summary["final"]["model"] == f"q1+{effect}"
    assert summary["final"]["log_evidence"] > summary["baseline"]["log_evidence"]
    # the last round found nothing left: its screen scanned the pickup line alone
    assert "not scanned" in d.rankings[-1].notes[-1]


@pytest.mark.parametrize("displacement", [False, True], ids=["tip_accelerometer", "with_displacement"])
def test_nothing_is_fitted_added_or_left_unexplained_on_a_null_recording(executor, displacement):
    """Neither a statistical flag nor a practically significant region: the baseline's map is clean
    (so no candidate is fitted), and the latent force stays within the force channel's noise."""
    d = _diagnosed(None, displacement, executor)
    assert d.added == [] and d.trials == [] and not d.unexplained, d.to_dict()["summary"]
    # nothing to explain in round 1: the beam effects' signatures are not scanned
    assert len(d.rankings) == 1 and [c.effect for c in d.rankings[0].candidates] == ["mains_lines"]
    assert d.negligible() == [] and flags(d.baseline_mismatch) == 0
    assert abs(d.baseline_mismatch.rms_standardized_residual - 1) < RMS_TOLERANCE
    assert not d.baseline_mismatch.phase["force"]["significant"]


@pytest.mark.long
def test_a_delay_absorbed_by_the_latent_force_is_flagged_there(executor):
    """The 0.5 ms delay: the force-noise latent terms absorb it (a shifted force), so the map's
    only flag is the latent force, read as a lag of the response behind the measured force; once
    the delay is modelled, the latent force is back within the force's noise."""
    d = _diagnosed("measurement_delay", False, executor)
    force = d.baseline_mismatch.phase["force"]
    assert force["significant"] and force["delay_s"] > 0, force
    (region,) = [r for r in d.baseline_mismatch.regions if "latent" in r["note"]]
    assert region["practically_significant"] and "lags it by" in region["note"]
    assert not d.final_mismatch.phase["force"]["significant"]
