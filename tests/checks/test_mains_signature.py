"""Mains pickup's screen: the persistent lines' own chi2 in the baseline's residual, gated by persistence.

Recordings are the independent reference simulator's (tests/diagnosis_cases.py: paper beam, q1
damping, hammer at 0.75 m, tip accelerometer, 1 s at 512 Hz, 2 % sensor noise), fitted as
test_discrepancy fits them (q1, quintic N = 8, Laplace draws, 20 map replicates):

* "mains": plus a 50 Hz line (tests.reference.daq.mains_pickup) LINE_DB = 20 dB above the noise
  floor: its power in its DFT bin of the 512-sample record is 100 times the noise's there,
  A^2 n / 4 = 100 sigma^2, so A = 0.88 sigma (invisible in the time history);
* "loud": the same line 30 dB above the floor, to check the chi2's scale;
* "null": nothing added;
* "mode": no line, but a 30 g body on a spring and dashpot at the tip (49 Hz on its own, damping
  ratio 0.005): the hammer excites a lightly damped mode at 50 Hz that decays within the record.

The fitted band ends at 194.6 Hz: harmonics 50, 100 and 150 Hz on one channel, 6 degrees of freedom.
"""
from functools import cache

import numpy as np
import pytest
from scipy import stats

from bayesbeam.checks.discrepancy import ALPHA
from bayesbeam.checks.signatures import line_chi2, rank_effects
from bayesbeam.physics.effects.mains_lines import MainsLines
from tests.checks.test_discrepancy import REPLICATES, fit_and_locate
from tests.diagnosis_cases import SENSOR_NOISE, reference, rms
from tests.reference.daq import mains_pickup

#: the mains line above the noise floor in its DFT bin (dB)
LINE_DB = 20.0
#: the louder line of the chi2-scale test (dB)
LOUD_DB = 30.0
#: the attached body making the decaying 50 Hz mode: mass (kg), own frequency (Hz), damping ratio
BODY = (0.03, 49.0, 0.005)
#: the mains harmonics in the fitted band (50, 100, 150 Hz) times one channel, two amplitudes each
DOF = 2 * 3 * 1


def noise_sd() -> float:
    """The reference's sensor noise sd: 2 % of the clean signal's RMS."""
    return SENSOR_NOISE.sensor * rms(reference()[1].signals)


def amplitude(db: float) -> float:
    """A 50 Hz line's amplitude whose power in its DFT bin is ``db`` above the noise's: A^2 n / 4 = 10^(db/10) sigma^2."""
    return 2 * noise_sd() * np.sqrt(10 ** (db / 10) / reference()[0].n_samples)


def recording(case: str):
    rec = reference()[0]
    if case in ("mains", "loud"):
        line = mains_pickup(rec.time, 50.0, [amplitude(LINE_DB if case == "mains" else LOUD_DB)], [0.3])
        return rec.with_signals(rec.signals + line[:, None])
    if case == "mode":
        m_a, f_a, zeta = BODY
        k_a = m_a * (2 * np.pi * f_a) ** 2
        return reference((("m_a", m_a), ("k_a", k_a), ("c_a", 2 * zeta * np.sqrt(k_a * m_a)), ("x_a", 1.0)))[0]
    return rec


@cache
def fitted(case: str):
    return fit_and_locate(recording(case))


@cache
def ranking(case: str, catalogue: bool = False):
    """The screen of ``case``: the whole catalogue, or mains_lines alone (its level is then ALPHA
    itself, the least strict Bonferroni level a null record can meet)."""
    return rank_effects(*fitted(case), effects=None if catalogue else ("mains_lines",))


def mains(result):
    return next(c for c in result.candidates if c.effect == "mains_lines")


def ungated_chi2(case: str) -> float:
    """The lines' chi2 with every (harmonic, channel) counted, decaying or not."""
    post, _, mis = fitted(case)
    s, rec = mis.setting, post.likelihood.model.recording
    z = s.projection.project(rec.signals - s.reference) / s.sigma
    return line_chi2(z, waves(s.projection, rec.time), np.ones((3, 1), bool))


def waves(projection, time) -> np.ndarray:
    """Band coordinates of the 50 Hz harmonics' cos and sin columns."""
    return projection.project(MainsLines().latent_columns(time, {"f_mains": 50.0}, 1, projection.max_frequency)[:, 0])


def threshold(level: float) -> float:
    """The chi2 a candidate on DOF degrees of freedom needs to be supported at ``level``."""
    return DOF * float(stats.f.isf(level, DOF, REPLICATES - 1))


def test_a_mains_line_ranks_first_and_is_supported():
    """A 20 dB line: mains_lines ranks first among the whole catalogue, supported at the family-wise
    0.01 (Bonferroni over the candidates: chi2 above ~39 on 6 degrees of freedom; it has ~220), with
    f_mains = 50 Hz; every other effect explains at most a tenth as much (2.7 here: a line between
    modes 2 and 3 moves no mode feature)."""
    result = ranking("mains", catalogue=True)
    best = result.candidates[0]
    print([(c.effect, round(c.delta_chi2, 1)) for c in result.candidates])
    assert result.best is best and best.effect == "mains_lines" and best.supported
    assert best.p_value < ALPHA / len(result.candidates)
    assert (best.parameter, best.value, best.unit) == ("f_mains", 50.0, "Hz")
    assert best.delta_chi2 > 10 * result.candidates[1].delta_chi2
    assert "supported" in best.reasoning and "50 Hz on accel_tip" in best.reasoning


def test_a_null_recording_supports_no_mains_pickup():
    """Nothing added: not supported even at ALPHA = 0.01 itself (one candidate), chi2 ~2 on 6 dof."""
    candidate = mains(ranking("null"))
    assert not candidate.supported and candidate.p_value > ALPHA


def test_a_decaying_mode_at_50_hz_is_not_pickup():
    """The body's 50 Hz mode stands in the residual as a line that decays (the map says so): counted,
    its chi2 (~220) would be supported far beyond the 0.01 level (threshold ~24); the persistence gate
    leaves it out, so mains_lines is not supported."""
    mis = fitted("mode")[2]
    assert any(r["mode"] is None and abs(r["peak_hz"] - 50.0) <= 1.0 and "decays" in r["note"] for r in mis.regions)
    assert ungated_chi2("mode") > 3 * threshold(ALPHA)
    candidate = mains(ranking("mode"))
    assert not candidate.supported and candidate.delta_chi2 < threshold(ALPHA)


def test_the_lines_chi2_is_their_energy_over_the_noise_floor():
    """A 30 dB line's chi2 is its energy in the window over the true noise variance, A^2 n / 2 /
    sigma^2 (~2000), plus its own 2 noise degrees of freedom. Tolerance 20 %: the noncentral chi2's
    sd is 4.5 % of it, the map's floor sd is estimated from ~390 coordinates (5 % in sigma^2),
    3 sd of both; whitened by the fitted sd (which absorbs the line) or by sigma sqrt(2) it is 50 % off."""
    mis = fitted("loud")[2]
    window = mis.setting.projection.i1 - mis.setting.projection.i0
    expected = amplitude(LOUD_DB) ** 2 * window / 2 / noise_sd() ** 2 + 2
    candidate = mains(ranking("loud"))
    assert candidate.delta_chi2 == pytest.approx(expected, rel=0.2)


def test_each_line_counts_two_degrees_of_freedom_per_channel():
    """On white noise through the fitted projection, the lines' chi2 (all three harmonics kept)
    averages 2 x 3 x 1 = 6: over 400 draws the mean's sd is sqrt(12/400) = 0.17, tolerance 3 sd. The
    candidate's p-value is that chi2 referred to F(6, S - 1) as every candidate's (S = 20 replicates)."""
    post, _, mis = fitted("null")
    proj, rec = mis.setting.projection, post.likelihood.model.recording
    w = waves(proj, rec.time)
    rng = np.random.default_rng(5)
    draws = [line_chi2(proj.project(rng.standard_normal((rec.n_samples, 1))), w, np.ones((3, 1), bool))
             for _ in range(400)]
    assert abs(np.mean(draws) - DOF) < 3 * np.sqrt(2 * DOF / 400)
    candidate = mains(ranking("null"))
    assert candidate.p_value == pytest.approx(stats.f.sf(candidate.delta_chi2 / DOF, DOF, REPLICATES - 1), rel=1e-9)


def test_lines_are_counted_per_channel():
    """Noise-free band coordinates of two channels, a 50 Hz line of amplitude 1 on the second only:
    counted there, its chi2 is its energy in the window, n / 2 (to 1e-6: exact but for the band
    projection's rounding; 50 Hz falls on a bin, so nothing leaks past the band); counting the
    first channel's 50 Hz instead gives nothing, counting every line the same energy."""
    post, _, mis = fitted("null")
    proj, rec = mis.setting.projection, post.likelihood.model.recording
    line = np.cos(2 * np.pi * 50.0 * (rec.time - rec.time[0]) + 0.4)
    z = proj.project(np.stack([np.zeros_like(line), line], axis=1))
    w = waves(proj, rec.time)
    energy = (proj.i1 - proj.i0) / 2
    first, second = np.zeros((3, 2), bool), np.zeros((3, 2), bool)
    first[0, 0] = second[0, 1] = True
    assert line_chi2(z, w, second) == pytest.approx(energy, rel=1e-6)
    assert line_chi2(z, w, np.ones((3, 2), bool)) == pytest.approx(energy, rel=1e-6)
    assert line_chi2(z, w, first) == pytest.approx(0.0, abs=1e-9 * energy)
