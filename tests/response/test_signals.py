"""The impact window judged against the force channel's noise, pulse by pulse
(``response.signals.find_pulses``, ``impact_window``), and the noise left inside it
(``response.signals.force_noise``)."""
import warnings
from dataclasses import replace

import numpy as np
import pytest

from bayesbeam.response.signals import MAX_LATENT, decimate, find_pulses, force_noise, impact_window
from tests.inference import cases

FS, DURATION = 2048.0, 4.0
SIGMA_F = 0.2          # N, 1 % of the 20 N pulse


def noisy_force_recording(seed=0, sigma=SIGMA_F):
    rec = cases.base_recording(fs=FS, duration=DURATION)
    rng = np.random.default_rng(seed)
    return replace(rec, force=rec.force + sigma * rng.standard_normal(rec.n_samples))


def full_rate_noise(rec, factor=1):
    """force_noise at the recorded rate, where a 4 ms pulse's window exceeds MAX_LATENT samples
    and warns by design (test_many_latent_samples_warn)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        return force_noise(rec, factor)


def test_noise_sd_is_measured_outside_the_window():
    """8000 quiet samples: the MAD estimate of sigma has a relative sd of about 1.7 / sqrt(2 n)
    = 1.3 %; 5 % is four of those."""
    noise = full_rate_noise(noisy_force_recording())
    assert noise.sd == pytest.approx(SIGMA_F, rel=0.05)


def test_full_rate_variances_are_the_window_squared():
    """At the recorded rate the kept noise is w_j e_j exactly: variance sigma^2 w_j^2, only where w > 0."""
    rec = noisy_force_recording()
    noise = full_rate_noise(rec)
    window = impact_window(rec.force)
    np.testing.assert_array_equal(noise.index, np.flatnonzero(window > 0))
    np.testing.assert_allclose(noise.variance, noise.sd**2 * window[noise.index] ** 2, rtol=1e-12)


@pytest.mark.parametrize("factor", [2, 5])
def test_decimated_latent_inputs_carry_the_in_band_covariance(factor):
    """The noise a decimated fit keeps, as ``decimate`` makes it, against the principal inputs.

    ``decimate`` is linear, so the decimated noise is u = L eps with L's columns the decimated
    unit samples (one ``decimate`` call each: the truth, by the path a fit takes) and eps the kept
    noise, independent of variance sigma_f^2 w_j^2. The covariance of u's DTFT (real and imaginary
    parts) at 24 frequencies up to 0.38 fs' is then exact, and so is the one the latent inputs
    imply, sum_k a_k a_k^T with a_k the DTFT of input k (``mixing[:, k]`` / D at the fractional
    ``position``). They agree to 3e-6 of the largest entry (what is left: the DAQ passband's 1e-10
    leak and the principal inputs' 1e-12 tail, amplified by the ill-conditioning of nearby
    frequencies); 1e-4 allows for that. Grouping each recorded sample's noise onto the nearest
    decimated sample instead errs by up to pi f / fs' in phase (1.2 rad at 0.38 fs'): 30 % off.
    """
    rec = noisy_force_recording()
    window = impact_window(rec.force)
    noise = full_rate_noise(rec, factor)
    kept = np.flatnonzero(window > 0)
    unit = np.zeros((kept.size, rec.n_samples))
    unit[np.arange(kept.size), kept] = 1.0
    lead = 64
    decimated = np.stack([decimate(replace(rec, force=u), factor, force_window=False, lead=lead).force
                          for u in unit], axis=1)                       # (n', J): L
    n = np.arange(decimated.shape[0])
    freq = np.linspace(0.02, 0.38, 24) * FS / factor

    def dtft(x, at):
        phase = np.exp(-2j * np.pi * np.outer(freq, at) * factor / FS)
        return np.vstack([(phase @ x).real, (phase @ x).imag])

    truth = dtft(decimated * (noise.sd * window[kept]), n)             # (48, J) x eps / sigma
    position = noise.position + lead                                    # force_noise(..., lead=0)
    implied = dtft(noise.mixing / factor, position)                    # (48, K)
    cov_truth, cov_implied = truth @ truth.T, implied @ implied.T
    scale = np.abs(cov_truth).max()
    assert np.abs(cov_implied - cov_truth).max() < 1e-4 * scale
    assert noise.size < kept.size                      # fewer latent terms than kept samples


def test_no_noise_to_model():
    """A clean force channel, a release test, a free decay: nothing to marginalise."""
    clean = cases.base_recording(fs=FS, duration=DURATION)
    assert force_noise(clean) is None
    release = replace(clean, excitation=replace(clean.excitation, kind="release", tip_load=1.0, location=None, column=None), force=None)
    assert force_noise(release) is None


# ---------------------------------------------------------------- pulses judged against the noise
# A hammer test as a DAQ at 5120 Hz records it for 4 s: a 10 N hard-tip pulse (Gaussian, sd
# 0.5 ms) at 0.1 s and force noise of 0.094 N sd (about 1 % of the peak).
HAMMER_FS, HAMMER_N, HAMMER_T0, HAMMER_SD, HAMMER_PEAK, HAMMER_NOISE = 5120.0, 20480, 0.1, 5e-4, 10.0, 0.094
#: the window's support for one such hit: the pulse above 5 % of its peak spans 2 sd
#: sqrt(2 ln 20) = 2.45 ms, plus PRE + POST + 2 TAPER = 40 samples = 7.8 ms, so 10.3 ms; 12 ms
#: leaves two samples for noise moving a threshold crossing on either side
ONE_HIT_SUPPORT = 0.012


def hammer_force(seed=3, noise=HAMMER_NOISE, hits=((HAMMER_T0, HAMMER_PEAK),)):
    time = np.arange(HAMMER_N) / HAMMER_FS
    force = sum(cases.force_pulse(time, t0=t0, width=HAMMER_SD, peak=peak) for t0, peak in hits)
    return time, force + noise * np.random.default_rng(seed).standard_normal(HAMMER_N)


def support(window):
    """Duration (s) of the samples where the window is open."""
    return np.count_nonzero(window) / HAMMER_FS


def test_noisy_force_channel_gives_a_window_of_a_few_ms():
    """1 % force noise: the window holds the hit and stays a few ms long (ONE_HIT_SUPPORT)."""
    time, force = hammer_force()
    window = impact_window(force)
    assert support(window) <= ONE_HIT_SUPPORT
    assert window[round(HAMMER_T0 * HAMMER_FS)] == 1.0
    assert not window[time > HAMMER_T0 + ONE_HIT_SUPPORT].any()


def test_a_lone_spike_late_in_the_record_does_not_widen_the_window():
    """A single sample 8 noise sd high at 3.73 s (over both the 5 % and the 5 sd thresholds):
    the old rule stretched the window from the impact to it. It is found, called a spike, and
    the window is the one of the record without it, sample for sample (the threshold is 5 % of
    the peak here, which the spike does not move)."""
    _, force = hammer_force()
    late = int(3.73 * HAMMER_FS)
    spiked = force.copy()
    spiked[late] = 8 * HAMMER_NOISE
    pulses = find_pulses(spiked)
    assert [p.start for p in pulses.spikes] == [late]
    assert len(pulses.hits) == 1
    np.testing.assert_array_equal(impact_window(spiked), impact_window(force))


def test_a_double_hit_is_kept_and_reported():
    """A bounce 5 ms after the impact and a second hit 300 ms after it, both pulse-shaped: three
    hits found, each reported within 2 samples of its true time (a Gaussian of sd 2.6 samples
    falls 7 % one sample off its top, more than the 1-2 % noise can lift a neighbour), and the
    window open at each but closed between the bounce and the second hit (not one long span)."""
    truth = ((HAMMER_T0, HAMMER_PEAK), (HAMMER_T0 + 0.005, 4.0), (HAMMER_T0 + 0.300, 3.0))
    time, force = hammer_force(hits=truth)
    pulses = find_pulses(force)
    assert not pulses.spikes
    assert len(pulses.hits) == 3
    found = np.array([p.peak_index for p in pulses.hits])
    np.testing.assert_allclose(found, [t0 * HAMMER_FS for t0, _ in truth], atol=2)
    window = impact_window(force)
    assert all(window[round(t0 * HAMMER_FS)] == 1.0 for t0, _ in truth)
    assert not window[(time > HAMMER_T0 + 0.005 + ONE_HIT_SUPPORT) & (time < HAMMER_T0 + 0.3 - ONE_HIT_SUPPORT)].any()
    assert support(window) <= 3 * ONE_HIT_SUPPORT


def test_threshold_follows_the_noise_when_the_noise_is_strong():
    """Force noise at 3 % of the peak: 5 % of the peak is only 1.7 noise sd, which thousands of
    noise samples pass. The threshold is 5 robust noise sd instead (within the MAD estimate's
    2 % sd at 20 000 samples, checked to 5 %), no spike is called a hit, and the window keeps
    one hit's length."""
    _, force = hammer_force(noise=0.3)
    pulses = find_pulses(force)
    assert pulses.threshold == pytest.approx(5 * 0.3, rel=0.05)
    assert len(pulses.hits) == 1
    assert support(impact_window(force)) <= ONE_HIT_SUPPORT


def hammer_recording(hits):
    _, force = hammer_force(hits=hits)
    rec = cases.base_recording(fs=HAMMER_FS, duration=HAMMER_N / HAMMER_FS)
    return replace(rec, force=force)


def test_many_latent_samples_warn():
    """Three hits kept at the recorded rate: about 3 x 45 latent force-noise samples, over
    MAX_LATENT, and the warning names the count and the hits. Decimated by 10 (as a fit below
    200 Hz would) the same window's noise takes about 20 principal inputs: no such warning."""
    rec = hammer_recording(((HAMMER_T0, HAMMER_PEAK), (HAMMER_T0 + 0.005, 4.0), (HAMMER_T0 + 0.300, 3.0)))
    with pytest.warns(UserWarning) as record:
        noise = force_noise(rec)
    (latent,) = [str(w.message) for w in record if "force window keeps" in str(w.message)]
    assert noise.size > MAX_LATENT and f"takes {noise.size} latent terms" in latent and "3 hit(s)" in latent
    with warnings.catch_warnings(record=True) as record:
        warnings.simplefilter("always")
        assert force_noise(rec, 10).size < MAX_LATENT
    assert not [w for w in record if "force window keeps" in str(w.message)]


def test_hits_and_spikes_are_reported_in_the_run_output():
    """A fit's force_noise says, as a warning the command line prints, that a second hit stays in
    the window (with its time) and that a spike is left out; a single clean hit says nothing."""
    rec = hammer_recording(((HAMMER_T0, HAMMER_PEAK), (HAMMER_T0 + 0.300, 3.0)))
    force = rec.force.copy()
    force[int(3.73 * HAMMER_FS)] = 8 * HAMMER_NOISE
    with pytest.warns(UserWarning) as record:
        force_noise(replace(rec, force=force), 10)
    messages = " ".join(str(w.message) for w in record)
    assert "holds 2 hits" in messages and "0.4 s" in messages
    assert "isolated spike" in messages and "3.73 s" in messages
    with warnings.catch_warnings():
        warnings.simplefilter("error", UserWarning)
        force_noise(hammer_recording(((HAMMER_T0, HAMMER_PEAK),)), 10)


# ---------------------------------------------------------------------------- a release's held deflection
#: the decimated samples a release's start disturbs without its rest (signals.EDGE)
EDGE_SAMPLES = 128


def _release(time: np.ndarray, quantity: str = "displacement"):
    """A release read by one tip sensor: a static 7.5 mm held until t = 0, then a decaying 23 Hz
    cosine from it (continuous at the release), at 2048 Hz."""
    from bayesbeam.io import Excitation, Recording, Sensor, TipBody

    held = 7.5e-3
    y = np.where(time <= 0, held, held * np.exp(-2.0 * time) * np.cos(2 * np.pi * 23.0 * time))
    sensor = Sensor("tip", cases.PAPER_BEAM.length, quantity, "tip")
    return Recording(beam=cases.PAPER_BEAM, tip=TipBody(), excitation=Excitation("release", tip_load=1.0),
                     sensors=(sensor,), time=time, signals=y[:, None])


def test_a_release_is_decimated_as_if_the_record_had_started_while_the_load_was_held():
    """The record cut at the release, decimated by 5 with its held deflection as ``rest``, equals
    the decimation of the same signal recorded from 1 s before the release, from t = 0 on, to
    1e-6 of the deflection (both low-passes see the held value over the kernel's reach; what
    differs is the far end of the periodic FFT). Padded with zeros instead, the first sample
    misses by 40 % of it."""
    from bayesbeam.response.signals import release_rest

    fs, factor = 2048.0, 5
    before = 410 * factor                                   # about 1 s, on the decimated grid
    longer = _release(np.arange(-before, 4 * 2048) / fs)
    cut = _release(np.arange(0, 4 * 2048) / fs)
    truth = decimate(longer, factor).signals[before // factor:][: 2 * EDGE_SAMPLES, 0]
    rest = release_rest(cut)
    assert rest == pytest.approx([7.5e-3], rel=1e-12)
    assert np.max(np.abs(decimate(cut, factor, rest=rest).signals[: 2 * EDGE_SAMPLES, 0] - truth)) < 1e-6 * 7.5e-3
    assert abs(decimate(cut, factor).signals[0, 0] - truth[0]) > 0.3 * 7.5e-3


def test_only_a_release_recorded_from_its_start_has_a_rest_and_only_its_displacements_are_not_zero():
    from bayesbeam.response.signals import release_rest

    time = np.arange(-10, 100) / 2048.0
    assert release_rest(_release(time))[0] == pytest.approx(7.5e-3, rel=1e-12)
    assert release_rest(_release(time, "acceleration")).tolist() == [0.0]
    assert release_rest(_release(time[20:])) is None                    # recorded from after the release
    assert release_rest(cases.base_recording()) is None                 # a hammer test rests at zero


def test_a_fit_of_a_release_sees_the_reference_simulators_start():
    """End to end, on the independent reference simulator's release of the paper beam (q1, 1 N
    tip load, one tip displacement channel, 1 s at 2048 Hz, no noise) prepared for a fit at 150 Hz
    (decimated by 5): at the truth the model's first 0.05 s match the decimated record within
    1e-4 of the deflection (1.1e-5 at the first sample, 2e-6 after it); padded with zeros, the
    record's first sample missed by 40 %."""
    from bayesbeam.inference.fit import FitConfig, prepare
    from bayesbeam.io import Sensor
    from tests.acceptance.cases import _nominal
    from tests.inference.cases import EI_TRUE, PAPER_BEAM
    from tests.reference import Noise, Release, record
    from tests.reference.recordings import PAPER_DAMPING

    rec = record(_nominal(PAPER_BEAM), PAPER_DAMPING["q1"], EI=EI_TRUE, excitation=Release(1.0), fs=2048,
                 duration=1, sensors=(Sensor("disp_tip", 1.0, "displacement", "disp_tip"),), noise=Noise(sensor=0.0))
    model = prepare(rec, "q1", FitConfig(max_frequency=150.0), 8).model
    y = model.simulate({"EI": EI_TRUE, **PAPER_DAMPING["q1"]})[:, 0]
    start = model.recording.time < 0.05
    data = model.recording.signals[start, 0]
    assert np.max(np.abs(y[start] - data)) < 1e-4 * np.max(np.abs(data))
