"""attachment: a body on a spring and dashpot at x_a, its own degree of freedom.

Truth, derived here (l = 1, EI = rho A = 1 scaled out: s~ = s sqrt(rho A l^4 / EI), b^4 = -s~^2):
seen from the beam the body is a point load -Z(s) u(x_a), Z = m_a s^2 (k_a + c_a s) / (m_a s^2 +
c_a s + k_a), i.e. the interior point mass of tests/physics/effects/test_sensor_mass.py with the
frequency-dependent mass ratio mu(s~) = mu_a (kappa + g s~) / (mu_a s~^2 + g s~ + kappa), where
mu_a = m_a / (rho A l), kappa = k_a l^3 / EI, g = c_a l / sqrt(EI rho A). The point-mass determinant
is linear in mu (one row holds it): det = D_0 + mu D_1, so the body's frequency equation, cleared of
its pole, is D_0 (mu_a s~^2 + g s~ + kappa) + mu_a (kappa + g s~) D_1 = 0.
"""
import numpy as np
import pytest
from scipy import linalg, optimize

from bayesbeam import BeamModel
from bayesbeam.physics.effects import REGISTRY
from bayesbeam.physics.effects.attachment import link_constants
from tests.physics.effects.helpers import PAPER_BEAM, PAPER_EI, recording
from tests.physics.effects.test_sensor_mass import point_mass_determinant, roots
from tests.reference import BeamCase
from tests.reference.system import full_blocks, matrices

RHO_A = PAPER_BEAM.rho_a
#: time scale sqrt(rho A l^4 / EI) of the paper's beam (s): s~ = s T
T = np.sqrt(RHO_A / PAPER_EI)
#: the body of the tests: 5 % of the beam's mass, its own mode between beam modes 2 and 3
#: (b_a = 6: kappa = mu_a b_a^4), at a grid point of N = 32 and between grid points
MU_A, KAPPA = 0.05, 0.05 * 6.0**4


def body(mu_a=MU_A, kappa=KAPPA, g=0.0, x_a=0.5) -> dict:
    """The fitted parameters (f_a, m_a, zeta_a, x_a) of the dimensionless body on the paper's beam
    (l = 1 m): k_a = kappa EI / l^3, c_a = g sqrt(EI rho A) / l."""
    m_a, k_a, c_a = mu_a * RHO_A, kappa * PAPER_EI, g * np.sqrt(PAPER_EI * RHO_A)
    omega_a = np.sqrt(k_a / m_a)
    return {"f_a": omega_a / (2 * np.pi), "m_a": m_a, "zeta_a": c_a / (2 * m_a * omega_a), "x_a": x_a}


def body_determinant(s, mu_a, kappa, g, a):
    """The body's frequency equation at s~ (complex), cleared of its pole (module docstring)."""
    b = np.sqrt(-1j * s)                      # b^4 = -s~^2, real and positive on s~ = i omega~
    d0 = point_mass_determinant(b, 0.0, a)
    d1 = point_mass_determinant(b, 1.0, a) - d0
    return d0 * (mu_a * s**2 + g * s + kappa) + mu_a * (kappa + g * s) * d1


def model(n_intervals=32, **kw):
    return BeamModel(recording(**kw), "air", n_intervals, effects="attachment")


def test_parameters_and_the_extended_system():
    """Four parameters; the body is one more degree of freedom, and none where m_a = 0 (no body) or
    f_a = 0 (a body hanging free of the beam)."""
    m = model()
    assert m.parameter_names == ("EI", "gamma", "f_a", "m_a", "zeta_a", "x_a")
    n = m.ops.size
    assert m.system({"EI": PAPER_EI, "gamma": 0.1, **body()}).size == n + 1
    assert m.system({"EI": PAPER_EI, "gamma": 0.1, **body(), "m_a": 0.0}).size == n
    assert m.system({"EI": PAPER_EI, "gamma": 0.1, **body(), "f_a": 0.0}).size == n


@pytest.mark.parametrize("x_a", [0.5, 0.8125])
def test_undamped_frequencies_match_the_exact_equation(x_a):
    """The first 6 frequencies, the body's own mode among them, within 3e-4 of the exact equation's
    roots at N = 32: the Galerkin error of a point load inside the span (test_sensor_mass.py's bound)."""
    exact_b = roots(lambda b, *a: body_determinant(1j * b**2, *a).real, 6, MU_A, KAPPA, 0.0, x_a)
    freqs = model().natural_frequencies({"EI": PAPER_EI, "gamma": 0.0, **body(x_a=x_a)}, 6)
    np.testing.assert_allclose(freqs, exact_b**2 / T / (2 * np.pi), rtol=3e-4)


def test_the_body_adds_its_own_mode_and_lowers_the_modes_below_it_raises_those_above():
    """The body (alone at 37.7 Hz, between beam modes 2 and 3) adds a mode there: below it the body
    moves with the beam and adds mass (modes 1-2 lower), above it the link yields and adds
    stiffness (the rest higher or, at a node of x_a, unmoved: mode 3 has one near mid-span)."""
    m = model()
    bare = m.natural_frequencies({"EI": PAPER_EI, "gamma": 0.0, **body(), "m_a": 0.0}, 5)
    loaded = m.natural_frequencies({"EI": PAPER_EI, "gamma": 0.0, **body()}, 6)
    body_hz = 6.0**2 / T / (2 * np.pi)
    assert np.all(loaded[:2] < bare[:2] * (1 - 1e-3))
    assert bare[1] < body_hz < loaded[2] < bare[2]
    assert np.all(loaded[3:] >= bare[2:5])


@pytest.mark.parametrize("kappa, body_index", [(KAPPA, 2), (MU_A * 0.5**4, 0)])
def test_the_bodys_own_mode_is_named_and_the_beams_modes_numbered_without_it(kappa, body_index):
    """The mode the body's mass carries (alone at b_a = 6, between beam modes 2 and 3; at b_a = 0.5,
    below mode 1) is named as the body's; the beam's modes keep their numbers 1, 2, 3, ... as
    without the body (m_a = 0: every mode the beam's)."""
    v = {"EI": PAPER_EI, "gamma": 0.0, **body(kappa=kappa)}
    labels = model().mode_labels(v)[:6]
    expected = [f"mode {k}" for k in range(1, 6)]
    expected.insert(body_index, "the attached body's own mode")
    assert labels == expected
    assert model().mode_labels({**v, "m_a": 0.0})[:6] == [f"mode {k}" for k in range(1, 7)]


def test_damped_poles_match_the_exact_equation():
    """Poles with a lossy link (damping ratio 5 % of the body alone): each of the first 5 found by
    the secant method on the exact equation from the Galerkin pole. Frequencies within 3e-4 (as
    above); the decay rates -Re p within 2 %: the Galerkin error in a rate is the same relative error
    in a mode shape's value at x_a, squared, and a c_a 10 % off moves them 10 %."""
    g = 2 * 0.05 * np.sqrt(KAPPA * MU_A)
    poles = model().poles({"EI": PAPER_EI, "gamma": 0.0, **body(g=g)})[:5] * T
    exact = np.array([optimize.newton(body_determinant, p, args=(MU_A, KAPPA, g, 0.5), tol=1e-13) for p in poles])
    np.testing.assert_allclose(np.abs(poles), np.abs(exact), rtol=3e-4)
    np.testing.assert_allclose(poles.real, exact.real, rtol=2e-2)
    assert np.argmax(-exact.real / np.abs(exact)) == 2        # the body's own mode is damped most


def test_a_stiff_link_carries_the_body_as_a_point_mass():
    """k_a -> infinity: the sensor_mass equation's frequencies. At kappa = 1e9 the body's own mode
    lies at b = 380 and the first 5 modes move by (omega / omega_a)^2 ~ 1e-6: within 1e-5."""
    exact_b = roots(point_mass_determinant, 5, MU_A, 0.8125)
    freqs = model().natural_frequencies({"EI": PAPER_EI, "gamma": 0.0, **body(kappa=1e9, x_a=0.8125)}, 5)
    np.testing.assert_allclose(freqs, exact_b**2 / T / (2 * np.pi), rtol=3e-4)
    m = model()
    rigid = BeamModel(recording(sensors=((0.8125, "acceleration"),)), "air", 32, effects="sensor_mass")
    np.testing.assert_allclose(freqs, rigid.natural_frequencies({"EI": PAPER_EI, "gamma": 0.0, "m_s": MU_A * RHO_A}, 5),
                               rtol=1e-5)
    assert m.system({"EI": PAPER_EI, "gamma": 0.0, **body(kappa=1e9)}).size == m.ops.size + 1


def test_a_heavy_body_is_a_spring_to_ground():
    """m_a -> infinity: the body stays put and the link is a spring k_a from x_a to ground. At
    mu_a = 1e6 the body's own mode is at b = (kappa / mu_a)^(1/4) = 0.17 and the beam's modes see
    the spring to (omega_a / omega)^2 ~ 1e-3 of its stiffness: within 1e-4 of K + k_a r r^T."""
    m = model()
    v = {"EI": PAPER_EI, "gamma": 0.0, **body(mu_a=1e6)}
    freqs = m.natural_frequencies(v, 6)[1:]                 # the first is the body's own
    ops = m.ops
    r = ops.rows([0.5])[0]
    k_a = link_constants(v)["k_a"]
    lam = linalg.eigh(PAPER_EI * ops.K0 + k_a * np.outer(r, r), ops.M, eigvals_only=True)[:5]
    np.testing.assert_allclose(freqs, np.sqrt(lam) / (2 * np.pi), rtol=1e-4)


@pytest.mark.parametrize(("mechanisms", "damping"), [("air", {"gamma": 0.3}), ("q2", {"alpha": 2.0, "beta": 1e3})])
def test_the_transfer_function_is_the_beams_with_the_bodys_dynamic_stiffness(mechanisms, damping):
    """The extended system's transfer from the hammer to the tip equals the beam's alone with the
    point impedance Z(s) r r^T (the Schur complement of the body's row), to rounding (1e-9); with
    time hysteresis too, whose memory acts on the beam's strain alone (its matrix padded)."""
    m = BeamModel(recording(), mechanisms, 16, effects="attachment")
    v = {"EI": PAPER_EI, **damping, **body(g=0.05)}
    system = m.system(v)
    bare = BeamModel(recording(), mechanisms, 16).system({"EI": PAPER_EI, **damping})
    r, tip, load = m.ops.rows([0.5, 1.0, 0.75])
    s = 1j * 2 * np.pi * np.array([3.0, 17.0, 61.0, 140.0])
    m_a, k_a, c_a = link_constants(v).values()
    z = m_a * s**2 * (k_a + c_a * s) / (m_a * s**2 + c_a * s + k_a)
    beam_only = [tip @ np.linalg.solve(zb + zk * np.outer(r, r), load) for zb, zk in zip(bare.dynamic_stiffness(s), z)]
    h = system.transfer(s, np.pad(tip, (0, 1))[None, :], np.pad(load, (0, 1))[:, None])[:, 0, 0]
    np.testing.assert_allclose(h, beam_only, rtol=1e-9)


def test_a_release_rests_as_the_bare_beam():
    """At rest no force passes the link: a release's static tip deflection is the bare beam's
    P l^3 / (3 EI) before the release (the cubic spline holds the cubic static shape exactly; the
    band-limited release rings ahead of t = 0 by far less than 1e-6 of the offset 0.1 s before it)."""
    rec = recording("release", tip_load=2.0, sensors=((1.0, "displacement"),), t0=-0.1)
    m = BeamModel(rec, "air", 8, effects="attachment")
    y = m.simulate({"EI": PAPER_EI, "gamma": 0.5, **body()})
    assert abs(y[0, 0] - 2.0 / (3 * PAPER_EI)) < 1e-6 * 2.0 / (3 * PAPER_EI)


def test_the_reference_simulator_agrees():
    """The Hermite finite elements of tests/reference (60 elements, the body as its own dof there
    too) give the same damped poles: within 1e-4 in frequency (both discretisations converged to
    that level for the first 5 modes) and 2 % in decay rate (the body's link dominates them)."""
    v = body(g=2 * 0.05 * np.sqrt(KAPPA * MU_A), x_a=0.8125)
    case = BeamCase(1.0, RHO_A, PAPER_EI, effects={**link_constants(v), "x_a": v["x_a"]})
    lam = full_blocks(case, matrices(case, 60), 0.75).poles()
    lam = lam[lam.imag > 0][:5]
    ours = model().poles({"EI": PAPER_EI, "gamma": 0.0, **v})[:5]
    np.testing.assert_allclose(np.abs(ours), np.abs(lam), rtol=1e-4)
    np.testing.assert_allclose(ours.real, lam.real, rtol=2e-2)


def test_the_effect_is_registered_and_refuses_the_nonlinear_integrator():
    assert REGISTRY["attachment"].extends
    with pytest.raises(ValueError, match="attached body"):
        BeamModel(recording(), "air", 8, effects=["attachment", "quadratic_drag"])
