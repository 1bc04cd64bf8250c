"""sensor_mass: a point mass at each sensor, against the analytic beam with a point mass.

Truth, derived here (l = 1, EI = rho A = 1, omega^2 = b^4, mu = m_s / (rho A l)): on each side of
the mass u = A cosh + B sinh + C cos + D sin in b x; clamped root; u, u', u'' continuous at the
mass and EI [u''']_-^+ = m_s omega^2 u (the mass's inertia is a point load); free end
u'' = u''' = 0. At the tip this is the classical tip-mass equation
EI u'''(l) = -m_s omega^2 u(l).
"""
from dataclasses import replace

import numpy as np
import pytest
from scipy import linalg, optimize

from bayesbeam import BeamModel
from bayesbeam.physics.assembly import BeamOperators
from bayesbeam.physics.basis import SplineBasis
from bayesbeam.physics.effects import REGISTRY, Setup
from tests.physics.effects.helpers import PAPER_BEAM, PAPER_EI, recording

EFFECT = REGISTRY["sensor_mass"]


def _values(b, x):
    """Rows of u, u', u'', u''' (each divided by b^k) of the four functions at b x."""
    ch, sh, c, s = np.cosh(b * x), np.sinh(b * x), np.cos(b * x), np.sin(b * x)
    return np.array([[ch, sh, c, s], [sh, ch, -s, c], [ch, sh, -c, -s], [sh, ch, s, -c]])


def tip_mass_determinant(b: float, mu: float) -> float:
    """Clamped root (A = -C, B = -D): u = A (ch - c) + B (sh - s); free end with the tip mass."""
    v = _values(b, 1.0)
    clamp = np.array([[1.0, 0.0], [0.0, 1.0], [-1.0, 0.0], [0.0, -1.0]])   # (A, B) -> (A, B, C, D)
    moment = v[2] @ clamp
    shear = v[3] @ clamp + mu * b * (v[0] @ clamp)        # u''' + mu b^4 u = 0, divided by b^3
    return np.linalg.det(np.array([moment, shear]) / np.cosh(b))


def point_mass_determinant(b: float, mu: float, a: float) -> float:
    """Mass at x = a inside the span: 8 unknowns (4 per segment, local coordinates)."""
    rows = np.zeros((8, 8), dtype=np.result_type(b, float))
    v0, va, v2 = _values(b, 0.0), _values(b, a), _values(b, 1.0 - a)
    rows[0, :4], rows[1, :4] = v0[0], v0[1]                  # clamped root
    for k in range(3):                                       # u, u', u'' continuous
        rows[2 + k, :4], rows[2 + k, 4:] = va[k], -v0[k]
    rows[5, :4] = -va[3] - mu * b * va[0]                    # u2''' - u1''' = mu b^4 u, / b^3
    rows[5, 4:] = v0[3]
    rows[6, 4:], rows[7, 4:] = v2[2], v2[3]                  # free end
    return np.linalg.det(rows / np.cosh(b)) if b != 0 else np.nan


def roots(fun, count, *args):
    grid = np.linspace(0.3, count * np.pi + 2, 3000)
    vals = np.array([fun(b, *args) for b in grid])
    idx = np.flatnonzero(np.sign(vals[:-1]) != np.sign(vals[1:]))
    return np.array([optimize.brentq(fun, grid[i], grid[i + 1], args=args, xtol=1e-14)
                     for i in idx][:count])


def galerkin_roots(mu: float, location: float, n_intervals: int = 32, count: int = 5):
    ops = BeamOperators(SplineBasis(1.0, n_intervals), rho_a=1.0)
    M = ops.M + EFFECT.mass(ops, {"m_s": mu}, Setup((location,)))
    return linalg.eigh(ops.K0, M, eigvals_only=True)[:count] ** 0.25


@pytest.mark.parametrize("mu", [0.02, 0.3, 2.0])
def test_sensor_at_the_tip_matches_the_tip_mass_equation(mu):
    """First 5 frequencies within 3e-4 at N = 32 (spline error only, as for the bare beam)."""
    exact = roots(tip_mass_determinant, 5, mu)
    np.testing.assert_allclose(galerkin_roots(mu, 1.0) ** 2, exact**2, rtol=3e-4)


def test_the_two_determinants_agree_at_the_tip():
    """Consistency of the derivation: the interior-mass equation with a -> l is the tip-mass one."""
    a = roots(tip_mass_determinant, 4, 0.3)
    b = roots(point_mass_determinant, 4, 0.3, 1.0 - 1e-9)
    np.testing.assert_allclose(a, b, rtol=1e-7)


@pytest.mark.parametrize("location", [0.5, 0.8125])
def test_sensor_inside_the_span(location):
    """A mass inside the span (at a grid point and between grid points): same 3e-4 bound.

    Between grid points the mass puts a jump of u''' inside an interval, where the cubic
    spline cannot follow it: the error is then O(h^2) in that interval's contribution, still
    below 3e-4 at N = 32 for these masses.
    """
    exact = roots(point_mass_determinant, 5, 0.2, location)
    np.testing.assert_allclose(galerkin_roots(0.2, location) ** 2, exact**2, rtol=3e-4)


TWO_SENSORS = ((1.0, "acceleration"), (0.5, "acceleration"))     # s0 at the tip, s1 at mid-span


def _with_masses(rec, masses):
    """``rec`` with beam.toml's [[sensor]] mass stated per sensor (None: not stated)."""
    return replace(rec, setup_keys={"sensor": [{} if m is None else {"mass": m} for m in masses]})


def _exact_hz(rec, fun, count, *args):
    """The analytic frequencies (Hz) at the paper's EI of ``fun``'s roots b (l = 1)."""
    return roots(fun, count, *args) ** 2 * np.sqrt(PAPER_EI / rec.beam.rho_a) / (2 * np.pi)


def test_a_single_sensor_keeps_the_name_m_s():
    """One sensor: the parameter is m_s, as in every study output written so far."""
    assert BeamModel(recording(), "air", 8, effects="sensor_mass").parameter_names == ("EI", "gamma", "m_s")


@pytest.mark.parametrize(("masses", "fun", "args"), [
    ({"m_s_s0": 0.05, "m_s_s1": 0.0}, tip_mass_determinant, (0.05 / PAPER_BEAM.rho_a,)),
    ({"m_s_s0": 0.0, "m_s_s1": 0.2 * PAPER_BEAM.rho_a}, point_mass_determinant, (0.2, 0.5))])
def test_the_model_puts_each_sensors_mass_at_that_sensor(masses, fun, args):
    """Two sensors: m_s_<name> per sensor, each at its own sensor (first 4 modes within 3e-4 of the
    analytic tip-mass or interior-mass equation: the Galerkin error at N = 32, as above)."""
    rec = recording(sensors=TWO_SENSORS)
    model = BeamModel(rec, "air", 32, effects="sensor_mass")
    assert model.parameter_names == ("EI", "gamma", "m_s_s0", "m_s_s1")
    freqs = model.natural_frequencies({"EI": PAPER_EI, "gamma": 0.0, **masses}, 4)
    np.testing.assert_allclose(freqs, _exact_hz(rec, fun, 4, *args), rtol=3e-4)


def test_a_stated_mass_enters_a_model_without_the_effect():
    """mass stated on the mid-span sensor: q1 alone carries it (interior-mass equation, 3e-4)."""
    rec = _with_masses(recording(sensors=TWO_SENSORS), [None, 0.2 * PAPER_BEAM.rho_a])
    freqs = BeamModel(rec, "air", 32).natural_frequencies({"EI": PAPER_EI, "gamma": 0.0}, 4)
    np.testing.assert_allclose(freqs, _exact_hz(rec, point_mass_determinant, 4, 0.2, 0.5), rtol=3e-4)


def test_a_fitted_mass_replaces_the_stated_one():
    """Stated 0.1 rho A l at mid-span, fitted 0.2 rho A l: the model holds 0.2 there, not 0.3; and
    at the stated value the effect adds nothing (the model without it, to rounding: 1e-12)."""
    rec = _with_masses(recording(sensors=TWO_SENSORS), [None, 0.1 * PAPER_BEAM.rho_a])
    model = BeamModel(rec, "air", 32, effects="sensor_mass")
    assert model.effects[0].absent == {"m_s_s0": 0.0, "m_s_s1": 0.1 * PAPER_BEAM.rho_a}
    fitted = {"EI": PAPER_EI, "gamma": 0.0, "m_s_s0": 0.0, "m_s_s1": 0.2 * PAPER_BEAM.rho_a}
    np.testing.assert_allclose(model.natural_frequencies(fitted, 4),
                               _exact_hz(rec, point_mass_determinant, 4, 0.2, 0.5), rtol=3e-4)
    bare = BeamModel(rec, "air", 32).natural_frequencies({"EI": PAPER_EI, "gamma": 0.0}, 6)
    at_stated = model.natural_frequencies({**fitted, **model.effects[0].absent}, 6)
    np.testing.assert_allclose(at_stated, bare, rtol=1e-12)


def test_the_masses_follow_the_sensors_names_not_their_order():
    """The same set-up with the [[sensor]] tables in the other order: the same frequencies to
    rounding (1e-12) for the same named masses, stated or fitted."""
    first = _with_masses(recording(sensors=TWO_SENSORS), [0.01, None])
    swapped = replace(first, sensors=first.sensors[::-1], signals=first.signals[:, ::-1],
                      setup_keys={"sensor": [{}, {"mass": 0.01}]})
    params = {"EI": PAPER_EI, "gamma": 0.0, "m_s_s0": 0.012, "m_s_s1": 0.03}
    for effects in (None, "sensor_mass"):
        a, b = (BeamModel(r, "air", 16, effects=effects) for r in (first, swapped))
        own = {k: v for k, v in params.items() if k in a.parameter_names}
        np.testing.assert_allclose(a.natural_frequencies(own, 6), b.natural_frequencies(own, 6), rtol=1e-12)
