"""Agreement with maintained peers on the same simulated recording.

* Time-domain route: our ERA against pyyeti's ERA (``pyyeti.era.ERA``), same Hankel matrix.
* FRF route: our H1 + rational-fraction fit against sdypy-EMA's LSCF (``sdypy.EMA.Model``)
  on the same H1 estimate.

Our FRF route's damping ratios are also checked against the model's own, with no peer involved.
The peers are declared test dependencies and imported directly: a missing one fails the suite.

The recording (tests/modal/simulated.py) is the shipped paper_q3_hammer set-up with a tip
vibrometer added, simulated under q1 damping (zeta 0.16-1.0 % for modes 1-6).
"""

import contextlib
import io
import warnings

import numpy as np
import pytest
import pyyeti.era
import sdypy.EMA

from bayesbeam.modal.decay import decay_segment
from bayesbeam.modal.era import era, mac
from bayesbeam.modal.frf import h1_estimate, modal_parameters
from bayesbeam.response.signals import impact_window
from tests.modal.simulated import hammer_with_vibrometer, with_noise

ROWS, COLS, ORDER = 150, 2000, 24  # block rows, columns, model order: small enough for pyyeti's full SVD


def test_era_matches_pyyeti_to_round_off():
    rec, *_ = hammer_with_vibrometer()
    noisy = with_noise(rec, seed=0)
    i0, _ = decay_segment(noisy)
    y = noisy.signals[i0 : i0 + ROWS + COLS]
    y = y / np.sqrt(np.mean(y**2, axis=0))
    ours = era(y, rec.dt, order=ORDER, n_rows=ROWS, n_cols=COLS)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        peer = pyyeti.era.ERA(y.T, 1 / rec.dt, svd_tol=ORDER, alpha=ROWS, beta=COLS, auto=True,
                              all_lower_limits=0.0, damp_range=(0.0, 1.0), verbose=False, show_plot=False)
    # Same algorithm, same Hankel matrix (H0[i, j] = y[i + j]), same truncation: every pole
    # we keep must be one of pyyeti's to round-off. The identified poles agree to ~1e-14
    # (f) and ~1e-11 (zeta; a small difference of two numbers): bounds 1e-10, 1e-7.
    assert len(ours.frequencies_hz) >= 6  # 8 of the 9 modes pass the EMAC filter on this 1.1 s segment
    k = [int(np.argmin(np.abs(peer.freqs_hz - f))) for f in ours.frequencies_hz]
    np.testing.assert_allclose(peer.freqs_hz[k], ours.frequencies_hz, rtol=1e-10)
    np.testing.assert_allclose(peer.zeta[k], ours.damping_ratios, rtol=1e-7)
    for j, i in enumerate(k):  # complex mode shapes: the same up to scaling
        assert mac(peer.C_modal[:, 2 * i], ours.mode_shapes[:, j]) == pytest.approx(1.0, abs=1e-9)


def _h1_of_tip_accelerometer(rec):
    force = rec.force * impact_window(rec.force)  # the force the model was driven with
    return h1_estimate(force, rec.signals[:, 0], rec.dt)


def _ours(est, f_true):
    """Our (6, 2) array of f (Hz), zeta: one rational-fraction fit per mode's band of the H1."""
    edges = np.r_[1.0, np.sqrt(f_true[:6] * f_true[1:7])]  # one mode per band
    return np.array([np.ravel(modal_parameters(est, 1, band=(edges[m], edges[m + 1]))) for m in range(6)])


def _lscf(est, ours):
    """sdypy-EMA's LSCF (6, 2) f (Hz), zeta on the same H1, its poles picked nearest to ours."""
    band = (est.frequency_hz >= 1.0) & (est.frequency_hz <= 380.0)  # modes 1-6, one LSCF fit
    freq = est.frequency_hz[band]
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
        peer = sdypy.EMA.Model(frf=est.h1[band][None, :], freq=freq, lower=freq[0], upper=freq[-1],
                               pol_order_high=40, frf_form="accelerance")
        peer.get_poles(show_progress=False)
        peer.select_closest_poles(list(ours[:, 0]), f_window=2)
    return np.column_stack([peer.nat_freq, peer.nat_xi])


def _ours_and_lscf(rec, f_true):
    est = _h1_of_tip_accelerometer(rec)
    ours = _ours(est, f_true)
    return ours, _lscf(est, ours)


def test_frf_route_recovers_the_model_damping_at_realistic_noise():
    """Our own check, no peer involved: 1 % noise on the accelerometer, modes 1-6. Over 20 seeds
    ours stays within 2.7 % of the model's damping ratios; bound 5 %."""
    rec, _, f, zeta = hammer_with_vibrometer()
    ours = _ours(_h1_of_tip_accelerometer(with_noise(rec, seed=0)), f)
    np.testing.assert_allclose(ours[:, 1], zeta[:6], rtol=0.05)


def test_frf_route_matches_sdypy_lscf_on_a_clean_record():
    rec, _, f, _ = hammer_with_vibrometer()
    ours, lscf = _ours_and_lscf(rec, f)
    # Noise-free: only the methods' own biases differ. Against the model, ours is within
    # 4e-5 (f) and 1.9 % (zeta, mode 6), LSCF (order 40) within 1.5e-5 and 0.9 %; the
    # observed differences are 2.5e-5 and 1.7 %. Bounds: 1e-4 and 3 %.
    np.testing.assert_allclose(lscf[:, 0], ours[:, 0], rtol=1e-4)
    np.testing.assert_allclose(lscf[:, 1], ours[:, 1], rtol=0.03)


def test_frf_route_matches_sdypy_lscf_at_realistic_noise():
    rec, _, f, _ = hammer_with_vibrometer()
    ours, lscf = _ours_and_lscf(with_noise(rec, seed=0), f)
    # 1 % noise on the accelerometer. Modes 3-6: over 20 seeds the two differ by at most
    # 1.3e-4 in f and 7.0 % in zeta; bounds 5e-4 and 10 %. Modes 1-2 are left out: with
    # frequency lines 0.25 Hz apart and mode 1's half-power band 0.07 Hz, LSCF scatters by
    # up to 20 % in zeta there (ours against the model: the test above).
    np.testing.assert_allclose(lscf[2:, 0], ours[2:, 0], rtol=5e-4)
    np.testing.assert_allclose(lscf[2:, 1], ours[2:, 1], rtol=0.10)
