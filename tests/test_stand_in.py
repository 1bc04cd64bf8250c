"""The stand-in rule of the diagnosis (bayesbeam.diagnosis.stand_in, docs/diagnosis.md) on constructed trials.

An effect whose posterior median lies outside what the stated set-up allows is reported as a
stand-in, not as missing physics found. The allowed ranges are computed here from the set-up's
numbers: a stated sensor mass m gives m exp(+-3 x 0.3) for m_s (three prior sds of log m_s), and
an axial load is bounded by the weight g (rho A (l + length_tolerance) + m_T + mass_tolerance +
stated sensor masses) of everything beyond the clamp.
"""
from dataclasses import replace
from types import SimpleNamespace

import numpy as np
import pytest

from bayesbeam.diagnosis import STAND_IN_WHY, Diagnosis, Trial, _trial_entry, final_stand_ins, paragraph, stand_in
from bayesbeam.io import Sensor, TipBody
from tests.inference import cases

STATED_MASS = 0.006         # kg, the tip accelerometer
SETUP = {"beam": {"length_tolerance": 0.005}, "tip": {"mass_tolerance": 0.002},
         "sensor": [{"mass": STATED_MASS}, {"mass": 0.004}]}
SENSORS = (Sensor("accel_tip", 1.0, "acceleration", "accel_tip"), Sensor("mid", 0.5, "acceleration", "accel_mid"))
#: m_s may lie within STATED_MASS x / exp(3 x 0.3) = 2.4596
SPREAD = np.exp(3 * 0.3)
#: the paper beam (1710 kg/m^3 x 0.597e-3 m^2, l = 1 m + 5 mm) with a 50 g (+ 2 g) tip and sensors
#: of 6 g and 4 g: the most the set-up can weigh, N
WEIGHT = 9.80665 * (1710.0 * 0.597e-3 * 1.005 + 0.05 + 0.002 + 0.006 + 0.004)


def recording(setup_keys=SETUP):
    rec = cases.base_recording(fs=512.0, duration=0.5, sensors=SENSORS, tip=TipBody(0.05, 0.0))
    return replace(rec, setup_keys=setup_keys)


def summary(name: str, median: float, unit: str) -> dict:
    """An effect_parameters entry: only the median and unit matter to the rule."""
    return {name: {"mean": median, "sd": 0.1 * abs(median), "q05": 0.9 * median, "q50": median,
                   "q95": 1.1 * median, "r_hat": 1.0, "unit": unit}}


@pytest.mark.parametrize(("factor", "expected"), [(1.0, False), (SPREAD * 0.99, False), (1 / (SPREAD * 0.99), False),
                                                  (SPREAD * 1.01, True), (1 / (SPREAD * 1.01), True),
                                                  (0.080 / STATED_MASS, True)])
def test_a_sensor_mass_three_prior_sds_from_the_stated_one_is_a_stand_in(factor, expected):
    """1 % inside the 3-sd factor 2.46 either way is a sensor mass; 1 % beyond it, and the real
    record's 80 g on a 6 g accelerometer, stand in for something else."""
    verdict = stand_in("sensor_mass", summary("m_s_accel_tip", STATED_MASS * factor, "kg"), recording())
    assert (verdict is not None) == expected
    if expected:
        assert verdict["parameter"] == "m_s_accel_tip" and verdict["median"] == pytest.approx(STATED_MASS * factor)
        assert verdict["allowed"] == pytest.approx([STATED_MASS / SPREAD, STATED_MASS * SPREAD], rel=1e-12)


def test_without_a_stated_mass_no_sensor_mass_is_a_stand_in():
    """Nothing stated on the tip sensor (where m_s_accel_tip sits): the set-up bounds nothing."""
    unstated = {**SETUP, "sensor": [{}, {"mass": 0.004}]}
    assert stand_in("sensor_mass", summary("m_s_accel_tip", 0.080, "kg"), recording(unstated)) is None


@pytest.mark.parametrize(("load", "expected"), [(22.0, True), (0.99 * WEIGHT, False), (-0.99 * WEIGHT, False),
                                                (1.01 * WEIGHT, True), (-1.01 * WEIGHT, True)])
def test_an_axial_load_beyond_the_weight_of_the_set_up_is_a_stand_in(load, expected):
    """The bound is 10.67 N here: the real record's 22 N tension is beyond it, a P 1 % inside it
    either way is not."""
    verdict = stand_in("axial_load", summary("P", load, "N"), recording())
    assert (verdict is not None) == expected
    if expected:
        assert verdict["allowed"] == pytest.approx([-WEIGHT, WEIGHT], rel=1e-12)


@pytest.mark.parametrize(("corner", "expected"), [(9.9, False), (10.1, True)])
def test_a_coupling_corner_above_ten_hertz_is_a_stand_in(corner, expected):
    """No IEPE sensor or DAQ coupling has a corner above 10 Hz: 1 % on either side of it."""
    verdict = stand_in("high_pass", summary("f_hp", corner, "Hz"), recording())
    assert (verdict is not None) == expected
    if expected:
        assert verdict["allowed"] == [0.0, 10.0] and "AC-coupling corner" in verdict["why"]


@pytest.mark.parametrize(("gain", "tolerance", "expected"), [(0.099, None, False), (-0.101, None, True),
                                                             (0.24, 0.05, False), (0.26, 0.05, True)])
def test_a_gain_beyond_five_calibration_tolerances_is_a_stand_in(gain, tolerance, expected):
    """g_mid against 5 x the mid sensor's gain_tolerance, 0.02 where not stated: 0.1, or 0.25 with
    0.05 stated (the bound at 1-4 % on either side; the tip sensor's gain stays at 0)."""
    stated = [dict(SETUP["sensor"][0]), {"mass": 0.004, **({"gain_tolerance": tolerance} if tolerance else {})}]
    rec = recording({**SETUP, "sensor": stated})
    parameters = {**summary("g_accel_tip", 0.0, "-"), **summary("g_mid", gain, "-")}
    verdict = stand_in("channel_gain", parameters, rec)
    assert (verdict is not None) == expected
    if expected:
        assert verdict["parameter"] == "g_mid" and verdict["allowed"] == pytest.approx([-5 * (tolerance or 0.02),
                                                                                       5 * (tolerance or 0.02)])


def test_an_effect_the_set_up_does_not_bound_is_never_a_stand_in():
    assert stand_in("root_compliance", summary("k_theta", 1e9, "N m/rad"), recording()) is None


# ---------------------------------------------------------------------------- in diagnosis.json and the summary
def _map(rms):
    return SimpleNamespace(rms_standardized_residual=rms, spectrogram=SimpleNamespace(significant=np.zeros(3, bool)),
                           modes=[], phase={}, regions=[], noise={})


def _result(name, log_z, rec, effect=None, median=None):
    """A fitted model: 2 SMC repeats x 50 draws of its effect's parameter about ``median``."""
    parameters = () if effect is None else {"sensor_mass": ("m_s_accel_tip",), "root_compliance": ("k_theta",)}[effect]
    draws = median * np.exp(0.01 * np.random.default_rng(0).standard_normal((2, 50, 1))) if effect else None
    model = SimpleNamespace(recording=rec, units={"m_s_accel_tip": "kg", "k_theta": "N m/rad"},
                            effects=[SimpleNamespace(name=effect, parameters=parameters)] if effect else [])
    return SimpleNamespace(name=name, evidence=SimpleNamespace(log_z=log_z, log_z_sd=0.1),
                           problem=SimpleNamespace(model=model, posterior=SimpleNamespace(names=parameters)),
                           values=lambda: draws)


def diagnosis(effect, median, final_median=None):
    """A diagnosis that added ``effect`` about ``median``; with ``final_median``, its final model
    (the same spec fitted again, as after a damping re-check) holds it about that value instead."""
    rec = recording()
    base = _result("q1", 100.0, rec)
    trial = Trial(1, effect, _result(f"q1+{effect}", 400.0, rec, effect, median), _map(1.0), 300.0, 0.2,
                  decisive=True, improved=True, added=True)
    final = trial.result if final_median is None else _result(f"q1+{effect}", 410.0, rec, effect, final_median)
    return Diagnosis(base, _map(2.0), [], [trial], final, trial.mismatch, None, 1.0)


def test_a_stand_in_is_marked_in_its_entry_and_named_as_such_in_the_summary():
    d = diagnosis("sensor_mass", 0.080)
    entry = _trial_entry(d.trials[0], None)
    assert entry["added"] and entry["stand_in"]["parameter"] == "m_s_accel_tip"
    assert entry["stand_in"]["median"] == pytest.approx(0.080, rel=0.01)   # 100 draws of sd(log) 0.01
    text = paragraph(d, [entry], final_stand_ins(d))
    assert "Stand-in, not a finding: sensor_mass's m_s_accel_tip" in text
    assert "a structural mismatch the catalogue cannot name" in text
    assert "Missing physics found" not in text and "No missing physics the set-up allows was found" in text


def test_an_effect_within_the_set_up_is_a_finding():
    d = diagnosis("sensor_mass", 0.0065)
    entry = _trial_entry(d.trials[0], None)
    assert entry["stand_in"] is None
    text = paragraph(d, [entry], final_stand_ins(d))
    assert "Missing physics found: sensor_mass at accel_tip." in text and "Stand-in" not in text


@pytest.mark.parametrize(("median", "words", "not_words"), [
    (0.080, "Not a finding: sensor_mass at accel_tip is a stand-in", "left out of this recording"),
    (0.0065, "What the damping model q1 left out of this recording: point mass", "Not a finding")])
def test_the_reports_lead_keeps_a_stand_in_apart_from_the_findings(median, words, not_words):
    from bayesbeam.report.diagnosis import lead

    d = diagnosis("sensor_mass", median)
    entry = _trial_entry(d.trials[0], None)
    model = {"rms_standardized_residual": 1.0, "flags": 0, "log_evidence": 400.0}
    summary = {"baseline": {**model, "model": "q1"}, "unexplained": False, "candidates": [entry],
               "final": {**model, "model": "q1+sensor_mass", "parameters": entry["parameters"]},
               "final_stand_ins": final_stand_ins(d)}
    missing = lead(summary)[0]
    assert words in missing and not_words not in missing


@pytest.mark.parametrize(("trial_median", "final_median"), [(0.080, 0.0065), (0.0065, 0.080)])
def test_the_verdict_is_the_final_models_and_a_change_from_the_trials_is_said(trial_median, final_median):
    """A sensor mass 80 g (a stand-in on a stated 6 g sensor) as fitted in its round and 6.5 g in
    the final model is a finding, and the other way round a stand-in: the verdict is the final
    posterior's, the trial's stays in its entry, and the paragraph says the verdict moved."""
    d = diagnosis("sensor_mass", trial_median, final_median)
    entry = _trial_entry(d.trials[0], None)
    verdicts = final_stand_ins(d)
    assert (entry["stand_in"] is not None) == (trial_median > 0.01)
    assert ("sensor_mass" in verdicts) == (final_median > 0.01)
    text = paragraph(d, [entry], verdicts)
    if final_median > 0.01:
        assert verdicts["sensor_mass"]["median"] == pytest.approx(final_median, rel=0.01)
        assert "Stand-in, not a finding: sensor_mass's m_s_accel_tip = 0.08" in text
        assert "As fitted in round 1, sensor_mass lay within what the set-up allows" in text
    else:
        assert "Missing physics found: sensor_mass at accel_tip." in text and "Stand-in, not a finding" not in text
        assert "As fitted in round 1, sensor_mass was a stand-in (m_s_accel_tip = 0.08" in text


# ---------------------------------------------------------------------------- an effect given with the baseline
def given(median):
    """A diagnosis of ``q1+sensor_mass`` given by the user: nothing added, m_s about ``median``."""
    rec = recording()
    base = _result("q1+sensor_mass", 100.0, rec, "sensor_mass", median)
    return Diagnosis(base, _map(1.0), [], [], base, _map(1.0), None, 1.0)


@pytest.mark.parametrize(("median", "expected"), [(0.080, True), (0.0065, False)])
def test_an_effect_given_with_the_baseline_is_judged_by_the_same_rule(median, expected):
    """The set-up bounds a sensor mass the user named as it bounds one the diagnosis adds: 80 g on
    a stated 6 g accelerometer is a stand-in whether or not the catalogue search put it there."""
    from bayesbeam.report.diagnosis import lead

    d = given(median)
    verdicts = final_stand_ins(d)
    assert ("sensor_mass" in verdicts) == expected
    text = paragraph(d, [], verdicts)
    assert ("Stand-in, not a finding: sensor_mass's m_s_accel_tip" in text) == expected
    model = {"rms_standardized_residual": 1.0, "flags": 0, "log_evidence": 100.0}
    summary = {"baseline": {**model, "model": "q1+sensor_mass"}, "unexplained": False, "candidates": [],
               "final": {**model, "model": "q1+sensor_mass"}, "final_stand_ins": verdicts}
    assert ("Not a finding: sensor_mass at accel_tip is a stand-in" in lead(summary)[0]) == expected


def _base(f_b: float, m_b: float) -> dict:
    return {**summary("f_b", f_b, "Hz"), **summary("m_b", m_b, "kg"), **summary("zeta_b", 0.02, "-")}


@pytest.mark.parametrize(("f_b", "mass_factor", "expected"), [(40.0, 2.0, None), (0.99, 2.0, None), (1.01, 2.0, "f_b"),
                                                               (40.0, 0.99e4, None), (40.0, 1.01e4, "m_b")])
def test_a_base_far_above_the_band_or_far_heavier_than_the_beam_is_a_stand_in(f_b, mass_factor, expected):
    """The recording samples at 512 Hz: a base resonance 1 % inside ten times the Nyquist frequency
    (f_b given here as a fraction of 2560 Hz where below 2) is a support, 1 % beyond it a stand-in;
    so is a base 1 % over 1e4 times the mass beyond the clamp (rho A l + m_T), not one 1 % under."""
    rec = recording()
    frequency = f_b * 10 * 256.0 if f_b < 2 else f_b
    mass = mass_factor * (rec.beam.rho_a * rec.beam.length + rec.tip.mass)
    verdict = stand_in("base_support", _base(frequency, mass), rec)
    assert (verdict and verdict["parameter"]) == expected


@pytest.mark.parametrize(("f_a", "expected"), [(45.0, None), (0.99, None), (1.01, "f_a")])
def test_an_attached_body_whose_mode_lies_far_above_the_band_is_a_stand_in(f_a, expected):
    """At 512 Hz a body's own mode 1 % inside ten times the Nyquist frequency (f_a given as a
    fraction of 2560 Hz where below 2) is an attachment, 1 % beyond it a stand-in (a point mass)."""
    rec = recording()
    frequency = f_a * 10 * 256.0 if f_a < 2 else f_a
    parameters = {**summary("f_a", frequency, "Hz"), **summary("m_a", 0.03, "kg"), **summary("zeta_a", 0.02, "-"),
                  **summary("x_a", 0.6, "m")}
    verdict = stand_in("attachment", parameters, rec)
    assert (verdict and verdict["parameter"]) == expected


def test_a_base_the_data_do_not_need_is_no_stand_in():
    """Unneeded, f_b's posterior reaches the prior's top, where the effect vanishes (1e4 f_1): its
    upper 5 % point within a factor 2 of that is no stand-in, however far above the band the median."""
    from bayesbeam.physics.effects.base_support import ABSENT_RATIO, fundamental

    rec = recording()
    top = ABSENT_RATIO * fundamental(rec.beam)
    assert stand_in("base_support", _base(0.5 * top / 1.1, 3.0), rec) is None           # q95 = 1.1 q50
    assert stand_in("base_support", _base(0.4 * top / 1.1, 3.0), rec)["parameter"] == "f_b"


# ---------------------------------------------------------------------------- mains pickup
def mains_record(case: str):
    """Reference-simulator records (tests/checks/test_mains_signature.py): "mains" with a 50 Hz line
    20 dB above the noise floor, "null" with none, "mode" with only a decaying 50 Hz mode."""
    from tests.checks.test_mains_signature import recording as reference_recording

    return reference_recording(case)


@pytest.mark.parametrize(("case", "median", "expected"), [("mains", None, False), ("null", None, True),
                                                          ("mode", None, True), ("mains", 60.0, True)])
def test_mains_pickup_without_a_persistent_line_at_its_harmonics_is_a_stand_in(case, median, expected):
    """A persistent 50 Hz line (bayesbeam check finds it) makes a fitted mains_lines at the nominal
    f_mains (50 Hz: not sampled, so absent from the posterior summary) pickup; no line, or only a
    mode at 50 Hz that decays, or f_mains = 60 Hz (harmonics 60, 120, 180 Hz) against the 50 Hz
    line, makes it a stand-in: its sinusoids absorb a mode or a transient."""
    parameters = {} if median is None else summary("f_mains", median, "Hz")
    verdict = stand_in("mains_lines", parameters, mains_record(case))
    assert (verdict is not None) == expected
    if expected:
        assert verdict == {"parameter": "f_mains", "median": median or 50.0, "allowed": None, "unit": "Hz",
                           "why": STAND_IN_WHY["mains_lines"]}


def _mains_diagnosis(rec):
    """q1 + mains_lines added to ``rec``: nothing sampled of the effect (f_mains fixed at 50 Hz)."""
    effect = SimpleNamespace(name="mains_lines", parameters=("f_mains",), defaults={"f_mains": 50.0},
                             units={"f_mains": "Hz"})
    result = SimpleNamespace(name="q1+mains_lines", evidence=SimpleNamespace(log_z=400.0, log_z_sd=0.1),
                             problem=SimpleNamespace(model=SimpleNamespace(recording=rec, units={}, effects=[effect]),
                                                     posterior=SimpleNamespace(names=())),
                             values=lambda: np.zeros((2, 50, 0)))
    trial = Trial(1, "mains_lines", result, _map(1.0), 300.0, 0.2, decisive=True, improved=True, added=True)
    return Diagnosis(_result("q1", 100.0, rec), _map(2.0), [], [trial], result, trial.mismatch, None, 1.0)


@pytest.mark.parametrize(("case", "words"), [
    ("null", ("Stand-in, not a finding: mains_lines's f_mains = 50 Hz (fixed) has no persistent line at any of its "
              "harmonics in the record")),
    ("mains", "Missing physics found: mains_lines.")])
def test_added_mains_pickup_is_reported_with_its_fixed_frequency(case, words):
    """diagnosis.json's entry and the summary of an added mains_lines, whose f_mains is not sampled:
    no posterior parameters, the fixed value in words, and the stand-in verdict of the record."""
    from bayesbeam.report.diagnosis import lead

    d = _mains_diagnosis(mains_record(case))
    entry = _trial_entry(d.trials[0], None)
    assert entry["parameters"] == {} and (entry["stand_in"] is not None) == (case == "null")
    text = paragraph(d, [entry], final_stand_ins(d))
    assert "f_mains = 50 Hz (fixed): added" in text and words in text
    model = {"rms_standardized_residual": 1.0, "flags": 0, "log_evidence": 400.0}
    report = {"baseline": {**model, "model": "q1"}, "unexplained": False, "candidates": [entry],
              "final": {**model, "model": "q1+mains_lines", "parameters": {}}, "final_stand_ins": final_stand_ins(d)}
    first = lead(report)[0]
    assert ("mains_lines is a stand-in" in first) == (case == "null") and ", ." not in first


def test_a_diagnosis_adds_pickup_the_map_calls_not_beam_physics_and_it_is_no_stand_in():
    """test_discrepancy's "mains" record (a 50 Hz line of the noise sd on a beam that decays within
    the record, so the map labels the line "not beam physics" and flags nothing else): the screen
    supports mains_lines, the diagnosis fits q1+mains_lines with f_mains fixed (nothing of it
    sampled) and adds it by the decisive rule (ln B 34 nats against 5 + 3 sd), and the record's
    persistent line makes it pickup, not a stand-in."""
    from dataclasses import replace as changed

    from bayesbeam.diagnosis import diagnose
    from tests.checks.test_discrepancy import recording as discrepancy_recording
    from tests.diagnosis_cases import REFERENCE_CONFIG

    d = diagnose(discrepancy_recording("mains"), model="q1", config=changed(REFERENCE_CONFIG, catalogue=("mains_lines",)))
    assert not [r for r in d.baseline_mismatch.regions if r["beam_physics"]]
    assert d.added == ["mains_lines"]
    entry = d.to_dict()["candidates"][0]
    assert entry["parameters"] == {} and entry["stand_in"] is None and entry["signature"]["supported"]
    assert "f_mains = 50 Hz (fixed): added" in d.to_dict()["summary"]


# ---------------------------------------------------------------------------- a body tuned to a beam mode
#: the fitted beam's modes without the body: (frequency Hz, damping ratio), lowest first
MODES = [(3.6, 0.004), (22.6, 0.002), (63.3, 0.003)]
#: their unresolved bands (Hz) over a long window, where each is the half-power band f_m (1 +- zeta_m)
BANDS = [(f * (1 - zeta), f * (1 + zeta)) for f, zeta in MODES]


def _body(f_a: float) -> dict:
    return {**summary("f_a", f_a, "Hz"), **summary("m_a", 0.008, "kg"), **summary("zeta_a", 0.002, "-"),
            **summary("x_a", 0.06, "m")}


@pytest.mark.parametrize(("f_a", "expected"), [(22.6 * (1 + 0.99 * 0.002), 2), (22.6 * (1 - 0.99 * 0.002), 2),
                                               (22.6 * (1 + 1.01 * 0.002), None), (3.6 * (1 - 0.99 * 0.004), 1),
                                               (3.6 * (1 + 1.01 * 0.004), None), (45.0, None)])
def test_a_body_tuned_within_a_modes_band_is_a_stand_in(f_a, expected):
    """1 % inside a mode's band either side is a tuned body, which the response cannot tell from a
    second mode there; 1 % beyond it, or between modes, a body."""
    verdict = stand_in("attachment", _body(f_a), recording(), BANDS)
    assert (verdict and verdict["mode"]) == expected
    if expected:
        assert verdict["parameter"] == "f_a" and verdict["allowed"] is None
        assert verdict["within"] == list(BANDS[expected - 1])
        assert f"within beam mode {expected}'s unresolved band" in paragraph_words(verdict)


def paragraph_words(verdict: dict) -> str:
    from bayesbeam.diagnosis import _stand_in_sentence

    return _stand_in_sentence("attachment", verdict)


def test_without_the_bands_a_tuned_body_is_judged_by_its_own_frequency_alone():
    """The bands are what the tuned rule needs: without them only the far-above rule applies."""
    assert stand_in("attachment", _body(22.6), recording()) is None
    assert stand_in("attachment", _body(22.6), recording(), BANDS)["mode"] == 2


@pytest.mark.parametrize(("seconds", "widths"), [(100.0, [3.6 * 0.004, 22.6 * 0.002, 63.3 * 0.003]),
                                                 (4.0, [0.25, 0.25, 0.25]), (10.0, [0.1, 0.1, 63.3 * 0.003])])
def test_a_modes_band_is_its_half_power_band_or_the_windows_resolution_whichever_is_wider(monkeypatch, seconds, widths):
    """w_m = max(zeta_m f_m, 1/T): over 100 s (resolution 0.01 Hz) every band is the half-power one;
    over 4 s every band is +-0.25 Hz; over 10 s (0.1 Hz) modes 1 and 2 take the resolution and mode
    3 (0.19 Hz) its own. T is the samples the likelihood analyses, its blocks (here 16 of 1/16 T)."""
    import bayesbeam.diagnosis as dg

    fs = 512.0
    block = int(seconds * fs / 16)
    projection = SimpleNamespace(fs=fs, i0=0, i1=16 * block + 7, block=block, n_blocks=16)
    result = SimpleNamespace(problem=SimpleNamespace(likelihood=SimpleNamespace(projection=projection)))
    monkeypatch.setattr(dg, "modes_without_body", lambda r: MODES if r is result else None)
    bands = dg.unresolved_bands(result)
    expected = [(f - w, f + w) for (f, _), w in zip(MODES, widths)]
    assert np.array(bands) == pytest.approx(np.array(expected), rel=1e-12)


def test_on_a_fitted_model_a_body_within_the_windows_resolution_of_mode_1_is_a_stand_in():
    """The real steel record's case: a lightly damped mode 1 (half-power half-width far below 1/T)
    and a body 5 % inside 1/T above it is a stand-in; 5 % beyond 1/T it is not. T here is the
    recording's 2 s at 256 Hz, which the likelihood's 16 blocks of 32 samples cover whole."""
    from bayesbeam.diagnosis import known_or_median, modes_without_body, unresolved_bands
    from bayesbeam.inference.fit import FitConfig, prepare

    rec = cases.simulated("q1", seed=3, fs=256.0, duration=2.0)[0]
    problem = prepare(rec, "q1", FitConfig(n_intervals=6, effects=("attachment",)), 6)
    assert rec.n_samples == 512 == problem.likelihood.projection.n_blocks * problem.likelihood.projection.block
    values = known_or_median(problem.model, {})
    theta = problem.posterior.coordinates({**values, **{n: 1.0 for n in problem.posterior.names if n not in values}})
    result = SimpleNamespace(problem=problem, draws=np.tile(theta, (2, 3, 1)))
    (f_1, zeta_1), *_ = modes_without_body(result)
    assert zeta_1 * f_1 < 0.1 * 0.5                  # the window's resolution sets mode 1's band
    bands = unresolved_bands(result)
    assert stand_in("attachment", _body(f_1 + 0.95 * 0.5), rec, bands)["mode"] == 1
    assert stand_in("attachment", _body(f_1 + 1.05 * 0.5), rec, bands) is None


def test_the_modes_without_the_body_are_the_bare_beams():
    """m_a = 0 takes the body's degree of freedom away: the modes of q1+attachment at m_a = 0 are
    q1's at the same EI, gamma and cdI (to rounding), and differ from the body's model's (by
    percents at the body's mode, 37.8 Hz at the default medians, here between modes 2 and 3)."""
    from bayesbeam.diagnosis import known_or_median, modes_without_body
    from bayesbeam.inference.fit import FitConfig, prepare

    rec = cases.simulated("q1", seed=3, fs=256.0)[0]
    problem = prepare(rec, "q1", FitConfig(n_intervals=6, effects=("attachment",)), 6)
    values = known_or_median(problem.model, {})
    theta = problem.posterior.coordinates({**values, **{n: 1.0 for n in problem.posterior.names if n not in values}})
    result = SimpleNamespace(problem=problem, draws=np.tile(theta, (2, 3, 1)))
    modes = np.array(modes_without_body(result))
    bare = prepare(rec, "q1", FitConfig(n_intervals=6), 6).model.poles({n: values[n] for n in ("EI", "gamma", "cdI")})
    assert modes[:, 0] == pytest.approx(np.abs(bare) / (2 * np.pi), rel=1e-9)
    assert modes[:, 1] == pytest.approx(-bare.real / np.abs(bare), rel=1e-6)
    with_body = problem.model.poles(values)
    assert abs(np.abs(with_body[2]) / np.abs(bare[2]) - 1) > 0.01
