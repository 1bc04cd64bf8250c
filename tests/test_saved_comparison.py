"""A comparison read back for a diagnosis (bayesbeam/saved_comparison.py): what it rebuilds, and
the folders it refuses before anything is fitted.

Plumbing on the cheap BeamModel-made case of tests/diagnosis_cases.py (a q1 comparison, 2 SMC
repeats, fixed N = 6): what is read back must equal what compare returned, whatever the data.
That a diagnosis from the folder decides as one that fits its baseline is tests/test_diagnosis.py's.
"""
import json
from dataclasses import replace

import numpy as np
import pytest

from bayesbeam.comparison import compare
from bayesbeam.diagnosis import diagnose
from bayesbeam.io import RecordingError
from bayesbeam.report.compare_outputs import write_comparison
from bayesbeam.saved_comparison import SavedComparison
from tests.diagnosis_cases import CONFIG, recording

#: particles are stored as physical values and taken back to sampling coordinates (log for the
#: log-scale priors): exp then log loses a few ulp of a coordinate of order 1-30
ROUNDING = 1e-13


@pytest.fixture(scope="module")
def saved(tmp_path_factory):
    """(recording, compare's results of q1, the comparison's folder)."""
    rec = recording(None)
    results, summary = compare(rec, ["q1"], CONFIG.compare)
    folder = tmp_path_factory.mktemp("comparison")
    write_comparison(results, summary, folder)
    return rec, results, folder


def test_a_model_is_read_back_as_compare_returned_it(saved):
    rec, results, folder = saved
    fitted, read = results["q1"], SavedComparison(folder, rec, CONFIG.compare.fit).results(["q1"])["q1"]
    # JSON writes a float's shortest repr, which reads back to the same float: exact
    assert read.evidence.log_z == fitted.evidence.log_z and read.evidence.log_z_sd == fitted.evidence.log_z_sd
    assert [r.log_z for r in read.evidence.runs] == [r.log_z for r in fitted.evidence.runs]
    assert np.array_equal(read.optimum.theta, fitted.optimum.theta)
    assert np.array_equal(read.optimum.covariance, fitted.optimum.covariance)
    assert read.problem.model.n_intervals == fitted.problem.model.n_intervals
    assert read.problem.posterior.names == fitted.problem.posterior.names
    np.testing.assert_allclose(read.draws, fitted.draws, rtol=ROUNDING, atol=ROUNDING)
    assert np.array_equal(read.evidence.runs[1].log_likelihood, fitted.evidence.runs[1].log_likelihood)


def _refusal(rec, folder, config=CONFIG, model=None):
    with pytest.raises(RecordingError) as caught:
        diagnose(rec, model, config, from_comparison=folder)
    return str(caught.value)


def test_a_folder_without_a_comparison_is_refused(saved, tmp_path):
    rec, _, _ = saved
    message = _refusal(rec, tmp_path)
    assert message.startswith(f"{tmp_path / 'comparison.json'}: file: not found") and "Fix: give the --out folder" in message


def test_a_comparison_json_without_what_a_diagnosis_needs_is_refused(saved, tmp_path):
    rec, _, folder = saved
    document = json.loads((folder / "comparison.json").read_text())
    (tmp_path / "comparison.json").write_text(json.dumps({k: v for k, v in document.items() if k != "fit"}))
    message = _refusal(rec, tmp_path)
    assert '"fit": missing' in message and "Fix: run bayesbeam compare on the recording again" in message


def test_a_comparison_of_another_recording_is_refused(saved):
    """The other recording has the same length, sensors and description: only the samples differ
    (another noise seed), so a check of the sample count alone would pass it."""
    rec, _, folder = saved
    other = recording(None, seed=4)
    assert len(other.time) == len(rec.time) and other.sensors == rec.sensors
    message = _refusal(other, folder)
    assert f'{folder / "comparison.json"}: "fingerprint": the comparison was made from another recording' in message
    assert "Fix: give the folder of a comparison of this recording" in message


def test_a_comparison_with_another_band_is_refused(saved):
    rec, _, folder = saved
    band = replace(CONFIG, compare=replace(CONFIG.compare, fit=replace(CONFIG.compare.fit, max_frequency=100.0)))
    message = _refusal(rec, folder, band)
    assert '"fit".max_frequency: the comparison used ' in message and ", this diagnosis 100.0" in message
    assert "Fix: give the diagnosis the comparison's --max-frequency" in message


def test_a_comparison_with_another_noise_model_is_refused(saved):
    rec, _, folder = saved
    ar1 = replace(CONFIG, compare=replace(CONFIG.compare, fit=replace(CONFIG.compare.fit, noise="ar1")))
    message = _refusal(rec, folder, ar1)
    assert '"fit".noise: the comparison used white, this diagnosis ar1' in message and "--noise" in message


def test_a_comparison_that_lacks_a_baseline_model_is_refused(saved):
    """Without --model the diagnosis needs every default damping model; this comparison has q1 only."""
    rec, _, folder = saved
    message = _refusal(rec, folder)
    assert '"models": has no q2, q3, air, strain_rate (it holds q1)' in message
    assert "Fix: compare them on this recording (bayesbeam compare --models q1,q2,q3,air,strain_rate)" in message


def test_a_named_model_is_read_when_the_comparison_has_it_and_fitted_when_not(saved, monkeypatch):
    """--model with --from-comparison: the comparison's q1 is used; q2, which it lacks, is fitted."""
    from importlib import import_module

    rec, results, folder = saved
    dg = import_module("bayesbeam.diagnosis")    # the module: the package's name "diagnose" may be the function
    fitted = []
    monkeypatch.setattr(dg, "compare", lambda rec, models, *a, **k: (fitted.append(list(models)), ({}, {}))[1])
    read, summary = dg.baseline_fits(rec, ["q1"], True, CONFIG, None, None, folder)
    assert not fitted and read["q1"].evidence.log_z == results["q1"].evidence.log_z and summary["best"] == "q1"
    dg.baseline_fits(rec, ["q2"], True, CONFIG, None, None, folder)
    assert fitted == [["q2"]]
