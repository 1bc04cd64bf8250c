"""The mismatch map locates what a fitted model leaves out, and flags nothing when nothing is missing.

Recordings: the independent reference simulator's (tests/diagnosis_cases.py: paper beam, q1
damping, 4 ms hammer pulse at 0.75 m, tip accelerometer, 1 s at 512 Hz, 2 % sensor noise, clean
force channel), with a catalogue effect the fitted model (q1, no effect, quintic N = 8) lacks: a
root spring k_theta = 4428 N m/rad (= 100 EI/l: mode 1 1.9 % low), a 0.5 ms measurement delay,
and, on a more damped beam (cdI = 1e-3 N m^2 s, so that the beam decays within the record), mains
pickup: a 50 Hz sine of amplitude equal to the noise sd (2 % of the signal RMS: invisible in the
time history). Draws come from the Laplace approximation at the optimum, as in test_ppc.

False alarms: the map's family-wise level is ALPHA = 0.01 (split over cells, per-mode tests and
the delay), so the null recording passes with probability about 0.99; the seeds are fixed, so the
outcome is reproducible. The effects stand far above the thresholds, so a flag is not a borderline
outcome of the seed: the root spring's cells have p down to 7e-18 against Holm's ~1.7e-5 (196
cells), the delay is 64 sd from zero, the mains line's cell power is 61 against ~12.
"""
import dataclasses
import json
from functools import cache

import numpy as np

from bayesbeam.checks.discrepancy import ALPHA, PRACTICAL_SHARE, Setting, decay_rates, holm, locate
from bayesbeam.inference.fit import prepare
from bayesbeam.inference.likelihood import BandProjection
from bayesbeam.inference.sampler import find_optimum
from tests.diagnosis_cases import CONCEALED, FIT, N_INTERVALS, SENSOR_NOISE, reference, rms

#: the cases: a concealed effect's name (tests/diagnosis_cases.py), "null" or "mains"
CASES = ("null", *CONCEALED, "mains")
#: the mains case's damping: the beam decays within the record, the line does not
MAINS_DAMPING = (("cdI", 1e-3),)
#: replicates per map: enough for the replicates' sd to within ~16 % (1/sqrt(2 (S-1)))
REPLICATES = 20


def recording(case: str):
    """The case's recording (reference simulator); mains: plus a 50 Hz line of the noise's sd."""
    if case != "mains":
        return reference(tuple(CONCEALED.get(case, {}).items()))[0]
    noisy = reference(damping=MAINS_DAMPING)[0]
    return noisy.with_signals(noisy.signals + mains_amplitude() * np.sin(2 * np.pi * 50.0 * noisy.time + 0.3)[:, None])


def mains_amplitude() -> float:
    """The mains line's amplitude: the sensor noise's sd, 2 % of the clean signal's RMS."""
    return SENSOR_NOISE.sensor * rms(reference(damping=MAINS_DAMPING)[1].signals)


@cache
def fitted(case: str):
    """(posterior, draws, mismatch) of q1 fitted to the case (shared with test_signatures).

    The optimum's global stages are shortened (81 EI scan points, 15 differential-evolution
    iterations; test_ppc uses the defaults 321 and 40), as the diagnosis's screens are cheap.
    """
    return fit_and_locate(recording(case))


def fit_and_locate(rec):
    """(posterior, draws, mismatch) of q1 fitted to ``rec`` as :func:`fitted` describes."""
    post = prepare(rec, "q1", FIT, N_INTERVALS).posterior
    optimum = find_optimum(post, np.random.default_rng(1), scan_points=81, de_iterations=15)
    draws = np.random.default_rng(1).multivariate_normal(optimum.theta, optimum.covariance, 200)
    return post, draws, locate(post, draws, np.random.default_rng(2), REPLICATES)


def test_null_recording_flags_nothing():
    """Nothing flagged at family-wise level 0.01; the RMS standardized residual is 1 within 0.15
    (its sd is ~0.04 over the ~780 coordinates: 4 sd)."""
    mis = fitted("null")[2]
    assert mis.regions == []
    assert not mis.spectrogram.significant.any()
    assert all(row["flags"] == [] for row in mis.modes)
    assert not mis.phase["significant"]
    assert abs(mis.rms_standardized_residual - 1) < 0.15
    assert abs(mis.noise["accel_tip"]["inflation"] - 1) < 0.15
    summary = json.loads(json.dumps(mis.to_dict()))
    assert summary["alpha"] == ALPHA and summary["mismatch"] == []


def test_root_compliance_is_located_at_the_low_modes():
    """A compliant root changes the low modes most once EI has absorbed its near-uniform shift:
    the regions cover modes 1 and 2 at the tip sensor, and the fitted noise sd is inflated (RMS
    standardized residual 1.46 here)."""
    mis = fitted("root_compliance")[2]
    modes = {r["mode"] for r in mis.regions}
    assert {1, 2} <= modes
    assert all(r["sensor"] == "accel_tip" and r["beam_physics"] for r in mis.regions)
    assert mis.rms_standardized_residual > 1.2
    by_mode = {row["mode"]: row for row in mis.modes}
    assert "amplitude" in by_mode[2]["flags"] and by_mode[2]["amplitude_error_pct"] < 0


def test_delay_is_estimated_within_its_uncertainty():
    """The per-mode phases at the excitation give the delay: 0.5 ms inside +-3 sd of the estimate
    (99.7 % if the sd is right; 0.499 +- 0.008 ms here), with an sd under 0.05 ms (a tenth of the delay)."""
    mis = fitted("measurement_delay")[2]
    phase = mis.phase
    assert phase["significant"]
    assert abs(phase["delay_s"] - 5e-4) < 3 * phase["delay_sd_s"]
    assert phase["delay_sd_s"] < 5e-5
    assert any(r["sensor"] == "all" and "lags the model" in r["note"] for r in mis.regions)


def test_mains_pickup_is_not_beam_physics():
    """A 50 Hz line at the noise sd stands above the noise, does not decay while the beam would
    (42 % kept over the window), and is labelled mains pickup, not beam physics."""
    mis = fitted("mains")[2]
    lines = [r for r in mis.regions if r["mode"] is None]
    assert len(lines) == 1 and len(mis.regions) == 1
    line = lines[0]
    assert line["band_hz"][0] <= 50.0 <= line["band_hz"][1]
    assert not line["beam_physics"] and "mains" in line["note"]


def test_misfit_share_of_a_line_equals_its_energy_share_in_the_region():
    """The mains line's misfit share (docstring (e)) computed here from the time signals by numpy's
    FFT of each of the map's blocks: in the region's bins, the line's energy A^2 L/2 per block (A
    the noise sd sigma, 2 % of the reference's clean signal RMS, as recording("mains") makes it;
    50 Hz falls on a bin of the 256-sample blocks) over the prediction's energy 2|X_k|^2/L plus
    the noise's 2 sigma^2 per bin and block. The line's cells stand ~60 x above the floor, so the
    noise inside them moves the share by about 1/sqrt(60 x 4) of itself; 10 % covers that and the
    fitted floor's own error."""
    mis = fitted("mains")[2]
    (line,) = mis.regions
    s, spec = mis.setting, mis.spectrogram
    L = s.projection.block
    blocks = s.reference[s.projection.window, 0].reshape(-1, L)
    f = np.fft.rfftfreq(L, 1 / s.projection.fs)
    inside = np.abs(f - line["peak_hz"]) < (line["band_hz"][1] - line["band_hz"][0]) / 2
    e_prediction = np.sum(2 * np.abs(np.fft.rfft(blocks, axis=1)[:, inside]) ** 2 / L)
    sigma = mains_amplitude()
    e_line = len(blocks) * L * sigma**2 / 2
    e_noise = len(blocks) * inside.sum() * 2 * sigma**2
    expected = np.sqrt(e_line / (e_prediction + e_noise))
    assert spec.block_duration_s * s.projection.fs == L and line["time_s"] == [0.0, 1.0]
    assert abs(line["misfit_share"] - expected) < 0.1 * expected
    assert line["practically_significant"] == (line["misfit_share"] >= PRACTICAL_SHARE)


def test_the_root_springs_misfit_is_practically_significant():
    """A root spring that shifts the low modes by 1.9 % leaves, after EI absorbed the common
    shift, errors of several percent in amplitude and damping at the modes it flags (mode 2's
    amplitude 5.1 %, mode 3's damping 12 % here): each region's misfit is more than 1 % of what
    the recording holds there."""
    mis = fitted("root_compliance")[2]
    assert mis.regions and all(r["practically_significant"] for r in mis.regions)


def test_decay_curvature_sign():
    """Envelope decay rates at start and end: exponential decay equal within 10 % of the rate (the
    estimator's own bias near the filter's end, about 6 % here, is why the map compares with
    replicates), a straight-line envelope (friction) rising and a 1/(1 + a t) envelope (drag)
    falling by more than 1.5 x."""
    fs, n = 512.0, 1024
    t = np.arange(n) / fs
    proj = BandProjection(fs, 0, n, 512, 190.0)
    setting = Setting(proj, 1 / fs, np.array([20.0]), [(14.0, 26.0)], np.array([0]), np.array([1e-6]), 0, 0.0,
                      np.zeros((n, 1)))
    carrier = np.sin(2 * np.pi * 20.0 * t)
    rates = {name: decay_rates((env * carrier)[:, None], setting)[0]
             for name, env in (("exponential", np.exp(-1.0 * t)), ("friction", 1 - 0.45 * t),
                               ("drag", 1 / (1 + 2.0 * t)))}
    assert abs(rates["exponential"][0] - rates["exponential"][1]) < 0.1 * rates["exponential"][0]
    assert rates["friction"][1] > 1.5 * rates["friction"][0]
    assert rates["drag"][0] > 1.5 * rates["drag"][1]


def test_holm_step_down():
    """Holm at 0.05 over four p-values: thresholds 0.0125, 0.0167, 0.025, 0.05 in order."""
    p = np.array([0.01, 0.04, 0.016, 0.3])
    np.testing.assert_array_equal(holm(p, 0.05), [True, False, True, False])


def test_the_phase_lines_intercept_is_weighted_least_squares():
    """_weighted_intercept (the phase feature's line at t = 0) equals numpy's polyfit, whose
    weights multiply the residuals (so sqrt(w)), to 1e-9 rad on a noisy line sampled far from
    t = 0 (5-6 s: the centred sums keep the intercept exact); ignoring the weights moves it by
    more than 1e-3 rad, so the comparison has power."""
    from bayesbeam.checks.discrepancy import _weighted_intercept

    rng = np.random.default_rng(4)
    t = np.linspace(5.0, 6.0, 300)
    w = rng.uniform(0.01, 1.0, t.size) ** 4
    y = 0.7 - 2.5 * t + 0.05 * rng.standard_normal(t.size)
    expected = np.polyfit(t, y, 1, w=np.sqrt(w))[1]
    assert abs(_weighted_intercept(t, y, w) - expected) < 1e-9
    assert abs(_weighted_intercept(t, y, np.ones_like(w)) - expected) > 1e-3


def test_the_analytic_signal_of_each_band_is_its_channels_tone():
    """_analytic, all bands at once: two channels, each a tone at the centre of its band (20 Hz on
    channel 0, 60 Hz on channel 1), each band also given the other channel. Away from the ends
    (0.25 s) the analytic signal of a tone in its own band is the tone's complex exponential
    times the forward-backward gain |H(f)|^2, 1 at a Butterworth band's geometric centre; the
    tolerance, 3e-2, holds the narrow 16-25 Hz band's ringing from the record's abrupt ends (1.6e-2
    at 0.25 s), and a gain 10 % off fails it. Of the other channel's tone almost nothing is left
    (measured 1e-3; bound 5e-3): the rows follow ``channel``, not the bands' order."""
    from bayesbeam.checks.discrepancy import _analytic

    fs, n = 512.0, 1024
    t = np.arange(n) / fs
    x = np.column_stack([np.cos(2 * np.pi * 20.0 * t), np.cos(2 * np.pi * 60.0 * t)])
    bands, channel = [(16.0, 25.0), (50.0, 72.0), (16.0, 25.0), (50.0, 72.0)], [0, 1, 1, 0]
    out = _analytic(x, bands, channel, fs)
    middle = (t > 0.25) & (t < t[-1] - 0.25)
    for row, f0 in ((0, 20.0), (1, 60.0)):       # each band's geometric centre: |H|^2 = 1 there
        assert np.max(np.abs(out[row, middle] - np.exp(2j * np.pi * f0 * t[middle]))) < 3e-2, row
    assert np.max(np.abs(out[2:, middle])) < 5e-3


def test_an_attached_bodys_own_mode_is_named_in_the_map_and_the_beams_modes_keep_their_numbers():
    """q1 with a light body (1 % of the beam's mass, at 0.9 l, 30 Hz: between beam modes 2 and 3, each
    moved by < 1 %) at the null fit's median: the map's row of the body's mode carries its name and
    the beam's rows their numbers without it, also in the notes (the per-mode statistics are the
    same estimators as for any mode)."""
    post, draws, _ = fitted("null")
    beam, noise = post.split(np.median(draws, axis=0))
    rec = recording("null")
    body = {"f_a": 30.0, "m_a": 0.01 * rec.beam.rho_a * rec.beam.length, "zeta_a": 0.05, "x_a": 0.9 * rec.beam.length}
    with_body = prepare(rec, "q1", dataclasses.replace(FIT, effects=("attachment",)), N_INTERVALS).posterior
    centre = with_body.coordinates({**beam, **body, **noise})
    spread = 1e-9 * np.random.default_rng(3).standard_normal((len(draws), len(centre)))
    mis = locate(with_body, centre + spread, np.random.default_rng(2), REPLICATES)
    labels = [row["label"] for row in mis.modes]
    assert labels[:4] == ["mode 1", "mode 2", "the attached body's own mode", "mode 3"]
    assert all(row["note"].startswith(row["label"]) for row in mis.modes)
