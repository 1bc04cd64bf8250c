"""Exponential relaxation (Biot): modal poles against the closed-form cubic, causality, the viscous
limit, and the time response against an internal-variable integration in the time domain."""
import numpy as np
import pytest

from bayesbeam.physics.mechanisms import Exponential
from bayesbeam.physics.mechanisms.exponential import exponential_transform
from tests.galerkin_reference import modal
from tests.physics.mechanisms.hereditary_checks import (
    EI,
    PAPER_EI,
    PulseCase,
    bare_model,
    damping_ratio,
    kramers_kronig_real,
    modes_and_poles,
    oscillatory_root,
    relative_rms,
    single_pole_response,
)

MODEL = bare_model("exponential")


@pytest.mark.parametrize("c_e, mu", [(1e-3, 200.0), (1e-3, 2000.0), (5e-3, 50.0)])
def test_poles_are_the_roots_of_the_cubic(c_e, mu):
    """Proportional case, exactly: (s + mu)(s^2 + w_m^2 (1 + c mu s/(s + mu))), c = c_e/EI, is
    s^3 + mu s^2 + w_m^2 (1 + c mu) s + w_m^2 mu (Adhikari & Woodhouse's closed form). Its complex
    root (numpy's companion matrix) against the model's Newton-iterated pole (1e-13 relative
    step): 1e-10 (measured < 2e-15). mu spans below, inside and above the modes (3.7-220 Hz), so
    the damping ratio rises with the mode, peaks or falls, as the loss factor
    c mu^2 w / (mu^2 + w^2 + c mu w^2) says: zeta = eta/2 to first order in eta, checked on the same
    poles within 2 eta relative (measured up to 0.48 eta; a wrong factor errs by 100 %)."""
    values = {"EI": PAPER_EI, "c_e": c_e, "mu": mu}
    lam, poles = modes_and_poles(MODEL, values)
    c = c_e / PAPER_EI
    expected = [oscillatory_root([1.0, mu, w2 * (1 + c * mu), w2 * mu], w2) for w2 in lam]
    np.testing.assert_allclose(poles, expected, rtol=1e-10)
    w = np.abs(poles)
    eta = c * mu**2 * w / (mu**2 + w**2 + c * mu * w**2)
    assert np.all(np.abs(damping_ratio(poles) / (eta / 2) - 1) <= 2 * eta)


def test_kernel_transform_obeys_kramers_kronig():
    """Causality: the kernel c_e mu e^{-mu t} acting on the curvature rate has the transform
    K(s) = G(s)/s = -c_e mu/(s + mu), vanishing as w -> inf. Its real part at i w0 from the
    Hilbert transform of its imaginary part alone (QUADPACK, 1e-10 relative) matches to 1e-8
    (measured < 2e-15); the time-reversed kernel (Im K flipped) gives the opposite sign."""
    kernel = lambda w: complex(exponential_transform(1j * w, 1e-3, 300.0)) / (1j * w)
    for w0 in (3.0, 150.0, 2000.0):
        exact = kernel(w0).real
        assert kramers_kronig_real(lambda w: kernel(w).imag, w0) == pytest.approx(exact, rel=1e-8)
        assert kramers_kronig_real(lambda w: -kernel(w).imag, w0) == pytest.approx(-exact, rel=1e-8)


def test_short_memory_limit_is_viscous():
    """mu -> inf is strain rate with cdI = c_e: mu s/(s + mu) = s (1 - s/mu + ...), so at
    mu = 1e9 1/s the damping term moves by |p|/mu < 1e-6 (|p| < 1e3 rad/s); bound 1e-6 on the
    poles. At mu = 300 1/s the poles move by more than 1e-4, so the comparison is not empty."""
    c_e = 1e-3
    kv = bare_model("strain_rate").poles({"EI": PAPER_EI, "cdI": c_e})[:5]
    np.testing.assert_allclose(MODEL.poles({"EI": PAPER_EI, "c_e": c_e, "mu": 1e9})[:5], kv, rtol=1e-6)
    slow = MODEL.poles({"EI": PAPER_EI, "c_e": c_e, "mu": 300.0})[:5]
    assert np.max(np.abs(slow - kv) / np.abs(kv)) > 1e-4


def test_refuses_a_zero_rate():
    with pytest.raises(ValueError, match="mu"):
        Exponential().check({"c_e": 1.0, "mu": 0.0})


def test_time_response_matches_internal_variable_integration():
    """force_response (frequency domain, G(s) = -c_e mu s/(s + mu)) against the exact time
    stepping of the internal-variable form (hereditary_checks.single_pole_response) on the pulse
    case (hereditary_checks.PulseCase), c_e = 5e-3 N m^2 s, mu = 300 1/s: 1e-7 relative RMS, the FFT solver's wrap-around and round-off
    level (e^-18 = 1.5e-8, amplified by the exponential window; measured 4.4e-9). The memory
    changes the response by 1.4 % (1.4e5 times the bound)."""
    case = PulseCase()
    c_e, mu = 5e-3, 300.0
    y = case.fft_response(Exponential().relaxation({"c_e": c_e, "mu": mu}))
    mod = modal(case.ops.M, EI * case.ops.K0, case.load, K_h=case.ops.K0)
    ref = single_pole_response(mod, c_e * mu, mu, case.force, case.t) @ mod.out(case.ops.tip_value)[0]
    assert relative_rms(ref - y, y) < 1e-7
    assert relative_rms(case.fft_response(Exponential().relaxation({"c_e": 0.0, "mu": mu})) - y, y) > 0.01
