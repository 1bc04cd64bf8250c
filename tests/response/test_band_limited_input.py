"""The input convention: recorded samples are band-limited signals (bayesbeam.response.linear).

A simulated impact test of the paper's beam (N = 16, rho A = 1.02087, EI = 44.28, air
gamma = 0.12 and Kelvin-Voigt cdI = 2e-5, force at x_f = 0.75 m, tip accelerometer):

* the beam is struck by a continuous half-sine force, 2.5 samples long (a hammer);
* its exact tip acceleration is computed independently (tests.galerkin_reference: modal matrix
  exponentials during the pulse, closed-form free decay after) on a grid of 32 sub-steps;
* a model DAQ (tests.galerkin_reference.KaiserDAQ: zero-phase Kaiser-windowed sinc, cut-off 0.45 fs,
  flat to 1e-5 below 0.40 fs, -100 dB above 0.50 fs) filters force and acceleration alike, which
  are then sampled for 2 s. The filtered force is integrated exactly (Gauss-Legendre over the
  pulse, where the integrand is smooth); the acceleration minus its force feed-through term
  (which carries the pulse's kinks) is C^1 and its filter integral on the fine grid is accurate
  to ~4e-8 (sub-steps 32 vs 64, measured; see test_reference_is_converged).

``force_response`` on the recorded force must reproduce the recorded acceleration wherever the
samples determine it, i.e. below 0.40 fs. In the DAQ transition band (0.40-0.50 fs) the model's
passband W and the DAQ's response differ by design (a recording does not state the filter's
transition shape), so the full-band error is bounded by the recorded content of that band.
"""
from functools import cache

import numpy as np
import pytest
from scipy import signal

from bayesbeam.physics.mechanisms import Air, StrainRate
from bayesbeam.response.linear import FrequencyGrid, force_response
from bayesbeam.response.system import SecondOrderSystem
from tests.galerkin_reference import (
    EI,
    KaiserDAQ,
    first_order_hold_response,
    half_sine_response,
    modal,
    paper_operators,
)

X_FORCE, PEAK, WIDTH_SAMPLES, START_SAMPLES, DURATION = 0.75, 100.0, 2.5, 64, 2.0
# fs = 2048 Hz (the shipped examples' rate): the beam's 10th mode, 949 Hz = 0.463 fs, rings inside the
# DAQ transition band. fs = 1500 Hz: no mode within 0.40-0.50 fs (modes 8, 9 at 585, 755 Hz).
RATES = (2048.0, 1500.0)


def rms(x):
    return float(np.sqrt(np.mean(np.square(x))))


def in_band(x: np.ndarray, fs: float) -> np.ndarray:
    """The part of x below 0.40 fs: zero-phase Kaiser FIR, flat (1e-6) to 0.37 fs, -120 dB from
    0.40 fs. The last half-length samples (edge effect: x continues past the record) are dropped;
    at the start x is 0 before the record, so no samples are lost there."""
    numtaps, beta = signal.kaiserord(120.0, 2 * 0.03)
    numtaps |= 1
    taps = signal.firwin(numtaps, 0.385 * fs, window=("kaiser", beta), fs=fs)
    half = numtaps // 2
    return np.convolve(x, taps)[half : x.size][: x.size - half]


def out_of_band(x: np.ndarray, fs: float) -> np.ndarray:
    """x minus its in-band part, on the same samples."""
    y = in_band(x, fs)
    return x[: y.size] - y


def _system():
    ops = paper_operators(16)
    D = Air().damping(ops, {"gamma": 0.12}) + StrainRate().damping(ops, {"cdI": 2e-5})
    return ops, D, SecondOrderSystem(ops.M, D, EI * ops.K0)


@cache
def recorded(fs: float, sub: int = 32):
    """The DAQ's samples of the force and of the tip acceleration (exact up to ~4e-8)."""
    ops, D, _ = _system()
    dt, n = 1 / fs, round(DURATION * fs)
    load = ops.rows([X_FORCE])[0]
    mod = modal(ops.M, EI * ops.K0, load, D=D)
    daq = KaiserDAQ(fs)
    t0, width = START_SAMPLES * dt, WIDTH_SAMPLES * dt
    assert t0 > daq.half_length, "the filtered force must start after t = 0"
    half = int(daq.half_length * fs * sub)
    t_fine = dt / sub * np.arange((n - 1) * sub + half + 1)
    _, _, acc_modal, f_fine = half_sine_response(mod, t_fine, t0, width, PEAK,
                                                 round(WIDTH_SAMPLES * sub))
    tip = mod.out(ops.tip_value)[0]
    feed = tip @ mod.p                        # acceleration = feed * f(t) + smooth remainder
    force = daq.sample_half_sine(n, t0, width, PEAK)
    accel = feed * force + daq.sample_fine(acc_modal @ tip - feed * f_fine, sub, n)
    return force, accel


@cache
def modelled(fs: float):
    """force_response to the recorded force, and the first-order-hold reference."""
    ops, D, system = _system()
    force, _ = recorded(fs)
    dt, n = 1 / fs, force.size
    load = ops.rows([X_FORCE])[0]
    y = force_response(system, FrequencyGrid(n, dt), ops.tip_value[None, :], [2], load, force)
    mod = modal(ops.M, EI * ops.K0, load, D=D)
    _, _, a_hold = first_order_hold_response(mod, force, dt)
    return y[:, 0], a_hold @ mod.out(ops.tip_value)[0]


def test_reference_is_converged():
    """The fine-grid reference with 16 vs 32 sub-steps: 5e-7 relative RMS apart (measured), so
    with its observed order >= 3 the 32-sub-step reference is good to < 1e-7 (32 vs 64 measured
    3.6e-8, not run here to save time). Bound 1.5e-6 (3x)."""
    _, a32 = recorded(2048.0, 32)
    _, a16 = recorded(2048.0, 16)
    assert rms(a16 - a32) / rms(a32) < 1.5e-6


@pytest.mark.parametrize("fs", RATES)
def test_in_band_output_is_exact(fs):
    """Below 0.40 fs the model reproduces the recording: relative RMS error of the in-band parts
    5.2e-7 (2048 Hz) and 1.8e-7 (1500 Hz) measured, bound 2e-6 (about 3x the larger). What is
    left is the DAQ model's own passband ripple (1e-5 peak) and the reference's error."""
    _, accel = recorded(fs)
    y, _ = modelled(fs)
    err = rms(in_band(y - accel, fs)) / rms(in_band(accel, fs))
    assert err < 2e-6, err


def test_full_band_error_without_transition_band_modes():
    """fs = 1500 Hz, no mode between 0.40 and 0.50 fs: full-band relative RMS error 0.16%
    (measured; the hammer's own transition-band content, shaped by W instead of the DAQ's
    Kaiser response), bound 0.5% (3x), under the 1% asked of it."""
    fs = 1500.0
    _, accel = recorded(fs)
    y, _ = modelled(fs)
    assert rms(y - accel) / rms(accel) < 5e-3


def test_full_band_error_is_the_transition_band():
    """fs = 2048 Hz: the 10th mode (949 Hz = 0.463 fs) rings in the DAQ transition band, where the
    model's W (0.04 at 949 Hz) and this DAQ (0.19) differ by design. The full-band error is then
    1.4% (measured; 1% does not hold at this rate), and it is all transition-band
    content: its out-of-band part is > 99% of it (in RMS) and it does not exceed the recorded
    transition-band content (3.2%), which is all |W - L| <= 1 allows."""
    fs = 2048.0
    _, accel = recorded(fs)
    y, _ = modelled(fs)
    err = y - accel
    err_out = out_of_band(err, fs)
    assert rms(err_out) > 0.99 * rms(err[: err_out.size])
    assert rms(err) < rms(out_of_band(accel, fs))
    assert rms(err) / rms(accel) < 0.02  # 1.40% measured


@pytest.mark.parametrize("fs", RATES)
def test_first_order_hold_is_wrong(fs):
    """Joining the force samples with straight lines misses the hammer's spectrum by
    sinc^2(f/fs): the exact response to that interpolant is off by 17-18% in band (measured,
    both rates) and 18-22% full band. Assert > 3%: the convention is not a detail."""
    _, accel = recorded(fs)
    _, a_hold = modelled(fs)
    assert rms(in_band(a_hold - accel, fs)) / rms(in_band(accel, fs)) > 0.03
    assert rms(a_hold - accel) / rms(accel) > 0.03


@pytest.mark.parametrize("n, tau", [(8192, 1.46484e-4), (8192, 5e-3), (1000, 3.3e-4), (7, 1e-3)])
def test_delay_factor_equals_the_exponential_on_every_bin(n, tau):
    """FrequencyGrid.delay(tau) vs exp(-s tau) computed per bin: |difference| < 1e-13.

    Both are within a few ulp of the exact factor (|e^{-s tau}| <= 1); the phase s tau reaches
    pi fs tau = 32 rad at the largest delay of the prior (5 ms at 2048 Hz), whose argument rounding
    (32 eps = 7e-15) both share. A wrong power or bin order would be off by O(1).
    """
    grid = FrequencyGrid(n, 1 / 2048)
    expected = np.exp(-grid.s * tau)
    assert grid.delay(tau).shape == expected.shape
    assert np.max(np.abs(grid.delay(tau) - expected)) < 1e-13
