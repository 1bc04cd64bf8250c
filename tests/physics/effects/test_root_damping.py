"""root_damping: a rotational dashpot at a compliant clamp, against the analytic beam solution.

Truth, derived here: the root condition EI u''(0) = (k_theta + c_theta s) u'(0) is the spring's
with a complex, frequency-dependent stiffness, so the pole s of the damped beam is a root of the
spring-root determinant of tests/physics/effects/test_root_compliance.py at kappa = (k_theta +
c_theta s) l / EI and b^4 = -rho A s^2 l^4 / EI (a complex root, found by the secant method from
the model's pole).
"""
import numpy as np
import pytest

from bayesbeam import BeamModel
from tests.physics.effects.helpers import PAPER_EI, recording, transfer_error
from tests.physics.effects.test_root_compliance import spring_root_determinant

REC = recording("force")
MODEL = BeamModel(REC, "root_compliance+root_damping", 32)


def analytic_pole(start: complex, k_theta: float, c_theta: float) -> complex:
    """The root of the determinant nearest ``start`` (l = 1 m)."""
    def det(s):
        b = (-REC.beam.rho_a * s**2 / PAPER_EI) ** 0.25
        return spring_root_determinant(b, (k_theta + c_theta * s) / PAPER_EI)

    s0, s1 = start, start * (1 + 1e-6)
    f0, f1 = det(s0), det(s1)
    for _ in range(50):
        s0, f0, s1 = s1, f1, s1 - f1 * (s1 - s0) / (f1 - f0)
        f1 = det(s1)
        if abs(s1 - s0) < 1e-14 * abs(s1):
            return s1
    raise AssertionError("secant iteration did not converge")


@pytest.mark.parametrize("k_theta", [5.0, 500.0, 5e4])
@pytest.mark.parametrize("c_theta", [0.01, 0.5])
def test_poles_match_the_characteristic_equation(k_theta, c_theta):
    """Modes 1-4 at N = 32, from a soft clamp (k l/EI = 0.1) to a nearly rigid one (1100), with
    damping ratios from 1e-8 to 18 %: poles within 2e-5 and damping ratios within 1e-4 relative.
    The only error is the cubic-spline discretisation, O(h^4) (root_compliance's frequencies:
    3e-4 at mode 6); measured at most 1e-5 and 3e-5. A dashpot of the wrong size (c/2) or on the
    wrong slope moves the damping by 50 % or more."""
    values = {"EI": PAPER_EI, "k_theta": k_theta, "c_theta": c_theta}
    poles = MODEL.poles(values)[:4]
    exact = np.array([analytic_pole(p, k_theta, c_theta) for p in poles])
    np.testing.assert_allclose(poles, exact, rtol=2e-5)
    zeta, zeta_exact = -poles.real / np.abs(poles), -exact.real / np.abs(exact)
    np.testing.assert_allclose(zeta, zeta_exact, rtol=1e-4)


def test_vanishing_dashpot_is_the_elastic_root():
    """c_theta -> 0 is the root spring alone: at c_theta = 0 the same poles to rounding (1e-12),
    and the damping is linear in a small c_theta (zeta(2c)/zeta(c) = 2 within 1e-6: the next
    term is O(zeta), 1e-7 here)."""
    elastic = BeamModel(REC, "root_compliance", 32).poles({"EI": PAPER_EI, "k_theta": 50.0})[:5]
    np.testing.assert_allclose(MODEL.poles({"EI": PAPER_EI, "k_theta": 50.0, "c_theta": 0.0})[:5], elastic,
                               rtol=1e-12)
    zeta = [MODEL.modal_damping_ratios({"EI": PAPER_EI, "k_theta": 50.0, "c_theta": c}, 5) for c in (1e-5, 2e-5)]
    np.testing.assert_allclose(zeta[1] / zeta[0], 2.0, rtol=1e-6)


def test_refused_without_the_root_spring():
    with pytest.raises(ValueError, match="root_damping needs root_compliance"):
        BeamModel(REC, "root_damping", 8)
    with pytest.raises(ValueError, match="use air\\+strain_rate\\+root_damping\\+root_compliance"):
        BeamModel(REC, "q1+root_damping", 8)


@pytest.mark.parametrize("spec, extra", [("root_compliance+root_damping", {}),
                                         ("q2+root_compliance+root_damping", {"alpha": 1.0, "beta": 5.0})])
def test_fast_transfer_form_equals_a_direct_solve(spec, extra):
    """The dashpot lies wholly along the root slope, the direction the root spring already departs
    along, so the rank-1 Woodbury form applies (with or without memory; without it the memory model
    would need a band elimination per frequency). Its transfer function against a direct solve of
    Z(s) = s^2 M + s D + K - G(s) K_h per frequency, on the model's grid up to 200 Hz including the
    resonance peaks: 1e-9 of the largest |H| (the rounding of either solve is amplified by 1/zeta at
    the peaks; measured 7e-11 and 8e-11)."""
    model = BeamModel(REC, spec, 16)
    system = model.system({"EI": PAPER_EI, "k_theta": 500.0, "c_theta": 0.05, **extra})
    assert system.form == "low_rank"
    assert transfer_error(model, system, 4) <= 1e-9


def _elastic_and_clamped(m: int, k_theta: float) -> tuple[float, float, float]:
    """(omega_m^2, phi_m'(0)^2, omega_c,m^2) of the beam with a root spring k_theta, from the
    characteristic equation kappa (1 + cos b cosh b) = (EI/l) b (sin b cosh b - cos b sinh b),
    b = beta l (the determinant above, expanded): the elastic mode's b between the pinned-free and
    clamped-free ones, its root slope squared as d lambda / d kappa along the equation, and the
    clamped-free b (1 + cos b cosh b = 0). l = 1 m."""
    from scipy.optimize import brentq

    lam = lambda b: b**4 * PAPER_EI / REC.beam.rho_a
    stiffness = lambda b: PAPER_EI * b * (np.sin(b) * np.cosh(b) - np.cos(b) * np.sinh(b)) / (1 + np.cos(b) * np.cosh(b))
    clamped = brentq(lambda b: 1 + np.cos(b) * np.cosh(b), (m - 0.5) * np.pi - 0.6, (m - 0.5) * np.pi + 0.6)
    lower = (m - 0.75) * np.pi if m > 1 else 1e-3           # above the pinned-free root below it
    elastic = brentq(lambda b: k_theta * (1 + np.cos(b) * np.cosh(b)) - PAPER_EI * b * (
        np.sin(b) * np.cosh(b) - np.cos(b) * np.sinh(b)), lower, clamped - 1e-12)
    h = 1e-6 * elastic
    slope = (lam(elastic + h) - lam(elastic - h)) / (stiffness(elastic + h) - stiffness(elastic - h))
    return lam(elastic), slope, lam(clamped)


@pytest.mark.parametrize("mode", [1, 2, 3])
def test_the_damping_peaks_near_omega_c_theta_equal_k_theta_as_the_closed_form_says(mode):
    """The module docstring's closed form, from the characteristic equation alone (written out
    here), against the model's modal damping ratio (quintic, N = 16) at a stiff clamp
    (k_theta l / EI = 100) over omega_m c_theta / k_theta = 0.01 to 10:
    zeta = g x / (2 (omega_m^2 (1 + x^2) + g x^2)), x = omega_m c_theta phi'(0)^2 / g,
    g = omega_c^2 - omega_m^2. Tolerance 2.5 %: the form drops terms of relative order
    g / omega_m^2 = 4 % here (measured at most 1.9 %, at the ends of the range, where the dashpot's
    own stiffening moves the frequency; the discretisation adds 1e-5). At 0.01 it is the first-order
    c phi'(0)^2 / (2 omega) to 1e-4 (measured 6e-6). The damping rises to its peak near 1 (the
    largest of the ratios at 1, its value g / (4 omega_m^2) to 2 %) and falls fivefold by 10."""
    model = BeamModel(REC, "root_compliance+root_damping", 16, degree=5)
    k_theta = 100 * PAPER_EI
    lam, slope, clamped = _elastic_and_clamped(mode, k_theta)
    gap, omega = clamped - lam, np.sqrt(lam)
    ratios = np.geomspace(0.01, 10, 13)
    c_theta = ratios * k_theta / omega
    zeta = np.array([model.modal_damping_ratios({"EI": PAPER_EI, "k_theta": k_theta, "c_theta": c}, 3)[mode - 1]
                     for c in c_theta])
    x = omega * c_theta * slope / gap
    closed = gap * x / (2 * (lam * (1 + x**2) + gap * x**2))
    np.testing.assert_allclose(zeta, closed, rtol=0.025)
    assert zeta[0] == pytest.approx(c_theta[0] * slope / (2 * omega), rel=1e-4)
    assert np.argmax(zeta) == 8 and zeta[8] == pytest.approx(gap / (4 * lam), rel=0.02)
    assert zeta[-1] < zeta[8] / 4
