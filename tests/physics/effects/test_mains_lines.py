"""mains_lines: mains pickup on the response channels, marginalised in the likelihood."""
from dataclasses import replace
from functools import cache

import numpy as np
import pytest

from bayesbeam import BeamModel
from bayesbeam.checks.ppc import PASS_P_VALUE, posterior_predictive_check
from bayesbeam.inference.fit import FitConfig, prepare
from bayesbeam.inference.sampler import find_optimum
from bayesbeam.inference.screens import laplace_log_evidence
from bayesbeam.io import RecordingError, load_recording, write_recording
from bayesbeam.physics.effects import REGISTRY
from bayesbeam.physics.effects.mains_lines import harmonics_in_band, nominal_mains
from tests.acceptance import cases as acceptance
from tests.physics.effects.helpers import PAPER_EI, recording
from tests.reference import record
from tests.reference.daq import mains_pickup
from tests.reference.recordings import NOISE

Q1 = {"EI": PAPER_EI, "gamma": 0.2, "cdI": 1e-4}


def test_columns_are_the_cos_and_sin_of_each_harmonic_in_the_band_on_each_channel():
    """Harmonics k f_mains <= max_frequency (50, 100, 150 Hz below 160 Hz); column (c, k, cos/sin)
    is cos / sin(2 pi k f (t - t_0)) on channel c and 0 on the other (to rounding of the phase,
    1e-12)."""
    rec = recording(fs=512.0, duration=0.25, sensors=((1.0, "acceleration"), (0.5, "acceleration")), t0=0.3)
    effect = REGISTRY["mains_lines"].bind(rec)
    np.testing.assert_array_equal(harmonics_in_band(50.0, 160.0), [50.0, 100.0, 150.0])
    np.testing.assert_array_equal(harmonics_in_band(50.0, 150.0), [50.0, 100.0, 150.0])
    cols = effect.latent_columns(rec.time, {"f_mains": 50.0}, 2, 160.0)
    assert cols.shape == (rec.n_samples, 2, 12)
    t = rec.time - rec.time[0]
    expected = np.column_stack([np.cos(2 * np.pi * f * t) for f in (50, 100, 150)]
                               + [np.sin(2 * np.pi * f * t) for f in (50, 100, 150)])
    np.testing.assert_allclose(cols[:, 0, :6], expected, atol=1e-12)
    np.testing.assert_allclose(cols[:, 1, 6:], expected, atol=1e-12)
    assert not cols[:, 0, 6:].any() and not cols[:, 1, :6].any()


def test_the_simulated_response_is_unchanged_and_f_mains_is_not_sampled():
    """The pickup is not beam motion: the model's signals are the plain model's to the bit, and
    f_mains is a fixed default (no sampled parameter)."""
    rec = recording(fs=512.0, duration=0.5)
    model = BeamModel(rec, "q1", 8, effects="mains_lines")
    assert model.parameter_names == ("EI", "gamma", "cdI")
    np.testing.assert_array_equal(model.simulate(Q1), BeamModel(rec, "q1", 8).simulate(Q1))
    with pytest.raises(ValueError, match="f_mains = 0.0 Hz is not physical"):
        model.simulate({**Q1, "f_mains": 0.0})


def _with_lines(rec, f_mains, amplitude):
    return rec.with_signals(rec.signals + mains_pickup(rec.time, f_mains, [amplitude] * 3, [0.3, 1.1, 2.0])[:, None])


def test_the_nominal_mains_frequency_stated_found_or_50():
    """[setup] mains_hz where stated; else 60 Hz when the record's persistent lines are at 60 Hz's
    harmonics, 50 Hz at 50 Hz's; else 50 Hz (a clean record, and one whose only peaks are decaying
    modes)."""
    rec = _reference()
    sd = NOISE.sensor * np.sqrt(np.mean(rec.signals**2))
    assert nominal_mains(rec) == 50.0
    assert nominal_mains(_with_lines(rec, 60.0, 3 * sd)) == 60.0
    assert nominal_mains(_with_lines(rec, 50.0, 3 * sd)) == 50.0
    stated = replace(_with_lines(rec, 50.0, 3 * sd), setup_keys={"setup": {"mains_hz": 60.0}})
    assert nominal_mains(stated) == 60.0
    assert BeamModel(stated, "q1", 8, effects="mains_lines").values(Q1)["f_mains"] == 60.0


def test_the_nominal_and_bayesbeam_check_agree_on_a_free_decay_whose_tap_rings_near_the_line():
    """A free decay (10 s at 512 Hz, from 2 s) whose tap rings a 116 Hz mode before its start, and a
    steady line 1.8 bins above 120 Hz (a DAQ's clock against the grid's): over the analysed span
    the line keeps its amplitude and the mode does not reach it, so the nominal is 60 Hz, the
    frequency `bayesbeam check`'s survey reports. Over the whole record, tap included, the line's
    bins would seem to decay; at one bin's tolerance it would not count."""
    from bayesbeam.checks.survey import survey

    rec = recording("free_decay", fs=512.0, duration=10.0)
    t = rec.time
    rng = np.random.default_rng(3)
    tap = np.where(t < 2.0, 50.0 * np.exp(-4.0 * t) * np.sin(2 * np.pi * 116.0 * t), 0.0)
    line = 0.05 * np.cos(2 * np.pi * (120.0 + 1.8 / 8.0) * t)
    rec = replace(rec, signals=(tap + line + 0.002 * rng.standard_normal(t.size))[:, None],
                  excitation=replace(rec.excitation, start=2.0))
    assert nominal_mains(rec) == 60.0
    assert [line["mains_hz"] for line in survey(rec).summary["channels"][0]["mains_lines"]] == [60.0]


def test_setup_mains_hz_is_read_written_back_and_checked(tmp_path):
    """beam.toml's [setup] mains_hz round-trips; a value <= 0 or text is refused naming the key and
    the fix when the set-up is read."""
    rec = replace(recording(fs=512.0, duration=0.5), setup_keys={"setup": {"mains_hz": 60.0}})
    back = load_recording(write_recording(rec, tmp_path / "rec"))
    assert back.setup.mains_hz == 60.0 and back.setup_keys == {"setup": {"mains_hz": 60.0}}
    assert recording(fs=512.0, duration=0.5).setup.mains_hz is None
    for bad in (0.0, -50.0, "50 Hz"):
        with pytest.raises(RecordingError) as info:
            _ = replace(rec, setup_keys={"setup": {"mains_hz": bad}}).setup
        assert info.value.where == "[setup] .mains_hz" and info.value.fix


@cache
def _reference():
    """The paper beam's q1 hammer test by the reference simulator: 1 s at 512 Hz, 2 % sensor noise."""
    setting = acceptance._setting("paper")
    return record(acceptance._nominal(setting["beam"]), acceptance.DAMPING["paper"]["q1"],
                  EI=setting["beam"].nominal_EI, fs=setting["fs"], duration=1.0, noise=NOISE, seed=3,
                  excitation=setting["excitation"])


def _fit(rec, effects=()):
    post = prepare(rec, "q1", FitConfig(degree=5, n_intervals=8, effects=effects), 8).posterior
    optimum = find_optimum(post, np.random.default_rng(1))
    rng = np.random.default_rng(2)
    draws = rng.multivariate_normal(optimum.theta, optimum.covariance, 200)
    return post, optimum, posterior_predictive_check(post, draws, rng, n_replicates=40)


def test_a_50_hz_line_fails_the_check_without_the_effect_and_is_absorbed_with_it():
    """A reference record with pickup at 50, 100 and 150 Hz, each of amplitude 10 x the sensor
    noise sd (20 dB above it): without the effect the residual-spectrum check fails (p < 0.01) and
    the fitted noise sd is inflated more than 3x; with it the check passes (every p-value >= 0.01),
    the noise sd is within 10 % of the true one (one draw of 512 samples: sd of the estimate 3 %),
    and EI, gamma and cdI cover the truth within 3 Laplace sds (one noise draw)."""
    rec = _reference()
    sd = NOISE.sensor * np.sqrt(np.mean(rec.signals**2))
    lined = _with_lines(rec, 50.0, 10 * sd)
    post, optimum, ppc = _fit(lined)
    assert ppc.statistics["residual_spectrum"]["p_value"] < PASS_P_VALUE
    assert post.values(optimum.theta)["sigma_accel_tip"] > 3 * sd
    post, optimum, ppc = _fit(lined, ("mains_lines",))
    assert min(s["p_value"] for s in ppc.statistics.values()) >= PASS_P_VALUE
    values, truth = post.values(optimum.theta), {"EI": acceptance._setting("paper")["beam"].nominal_EI,
                                                 **acceptance.DAMPING["paper"]["q1"]}
    assert abs(values["sigma_accel_tip"] / sd - 1) < 0.1
    sds = np.sqrt(np.diag(optimum.covariance))
    for name, true in truth.items():
        i = post.names.index(name)
        assert abs(post.coordinates({**values, name: true})[i] - optimum.theta[i]) < 3 * sds[i], name


def test_on_a_record_without_a_line_the_effect_lowers_the_evidence():
    """The clean reference record: the Laplace log evidence with the effect is below the one without
    (the six wide-prior amplitudes' Occam factor, observed -54 nats, against a Laplace error of a
    fraction of a nat for this near-Gaussian posterior), so the effect is no discovery on a null
    record."""
    rec = _reference()
    without = laplace_log_evidence(_fit(rec)[1])["log_evidence"]
    with_lines = laplace_log_evidence(_fit(rec, ("mains_lines",))[1])["log_evidence"]
    assert with_lines < without - 5.0
