"""The force channel's noise left inside the impact window (``response.signals.force_noise``)."""
from dataclasses import replace

import numpy as np
import pytest

from bayesbeam.response.signals import decimate, force_noise, impact_window
from tests.inference import cases

FS, DURATION = 2048.0, 4.0
SIGMA_F = 0.2          # N, 1 % of the 20 N pulse


def noisy_force_recording(seed=0, sigma=SIGMA_F):
    rec = cases.base_recording(fs=FS, duration=DURATION)
    rng = np.random.default_rng(seed)
    return replace(rec, force=rec.force + sigma * rng.standard_normal(rec.n_samples))


def test_noise_sd_is_measured_outside_the_window():
    """8000 quiet samples: the MAD estimate of sigma has a relative sd of about 1.7 / sqrt(2 n)
    = 1.3 %; 5 % is four of those."""
    noise = force_noise(noisy_force_recording())
    assert noise.sd == pytest.approx(SIGMA_F, rel=0.05)


def test_full_rate_variances_are_the_window_squared():
    """At the recorded rate the kept noise is w_j e_j exactly: variance sigma^2 w_j^2, only where w > 0."""
    rec = noisy_force_recording()
    noise = force_noise(rec)
    window = impact_window(rec.force)
    np.testing.assert_array_equal(noise.index, np.flatnonzero(window > 0))
    np.testing.assert_allclose(noise.variance, noise.sd**2 * window[noise.index] ** 2, rtol=1e-12)


@pytest.mark.parametrize("factor", [2, 5])
def test_decimated_variances_match_the_in_band_noise(factor):
    """Monte Carlo: 400 draws of the windowed noise, decimated as a fit does it (``decimate``).

    The claim of ``force_noise`` is that independent samples of variance s_k^2 have the in-band
    spectral density of the decimated noise: E |DFT(u)(f)|^2 = sum_k s_k^2 for every f below the
    passband edge. The estimate averages 400 draws x the in-band bins (which are nearly
    independent), so its relative sd is under 1 %; 4 % covers it and the edge of the mean-w^2
    rule at the window's ends. The rule's sum is checked exactly too (sum s_k^2 = sigma^2
    sum w^2 / D^2).
    """
    rec = noisy_force_recording()
    window = impact_window(rec.force)
    noise = force_noise(rec, factor)
    assert np.sum(noise.variance) == pytest.approx(noise.sd**2 * np.sum(window**2) / factor**2, rel=1e-12)
    rng = np.random.default_rng(1)
    draws = noise.sd * rng.standard_normal((400, rec.n_samples))
    u = np.stack([decimate(replace(rec, force=e), factor, force_window=False).force for e in draws * window])
    spectrum = np.abs(np.fft.rfft(u, axis=1)) ** 2
    freq = np.fft.rfftfreq(u.shape[1], factor / FS)
    in_band = freq < 0.38 * FS / factor
    assert np.mean(spectrum[:, in_band]) == pytest.approx(np.sum(noise.variance), rel=0.04)


def test_no_noise_to_model():
    """A clean force channel, a release test, a free decay: nothing to marginalise."""
    clean = cases.base_recording(fs=FS, duration=DURATION)
    assert force_noise(clean) is None
    release = replace(clean, excitation=replace(clean.excitation, kind="release", tip_load=1.0, location=None, column=None), force=None)
    assert force_noise(release) is None
