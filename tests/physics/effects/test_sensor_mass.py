"""sensor_mass: a point mass at the first sensor, against the analytic beam with a point mass.

Truth, derived here (l = 1, EI = rho A = 1, omega^2 = b^4, mu = m_s / (rho A l)): on each side of
the mass u = A cosh + B sinh + C cos + D sin in b x; clamped root; u, u', u'' continuous at the
mass and EI [u''']_-^+ = m_s omega^2 u (the mass's inertia is a point load); free end
u'' = u''' = 0. At the tip this is the classical tip-mass equation
EI u'''(l) = -m_s omega^2 u(l).
"""
import numpy as np
import pytest
from scipy import linalg, optimize

from bayesbeam import BeamModel
from bayesbeam.physics.assembly import BeamOperators
from bayesbeam.physics.basis import SplineBasis
from bayesbeam.physics.effects import REGISTRY, Setup
from tests.physics.effects.helpers import PAPER_EI, recording

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
    rows = np.zeros((8, 8))
    v0, va, v2 = _values(b, 0.0), _values(b, a), _values(b, 1.0 - a)
    rows[0, :4], rows[1, :4] = v0[0], v0[1]                  # clamped root
    for k in range(3):                                       # u, u', u'' continuous
        rows[2 + k, :4], rows[2 + k, 4:] = va[k], -v0[k]
    rows[5, :4] = -va[3] - mu * b * va[0]                    # u2''' - u1''' = mu b^4 u, / b^3
    rows[5, 4:] = v0[3]
    rows[6, 4:], rows[7, 4:] = v2[2], v2[3]                  # free end
    return np.linalg.det(rows / np.cosh(b)) if b > 0 else np.nan


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


def test_model_puts_the_mass_at_the_first_sensor():
    rec = recording(sensors=((1.0, "acceleration"), (0.5, "acceleration")))
    model = BeamModel(rec, "air", 32, effects="sensor_mass")
    m_s = 0.05
    freqs = model.natural_frequencies({"EI": PAPER_EI, "gamma": 0.0, "m_s": m_s}, 4)
    b = roots(tip_mass_determinant, 4, m_s / rec.beam.rho_a)
    np.testing.assert_allclose(freqs, b**2 * np.sqrt(PAPER_EI / rec.beam.rho_a) / (2 * np.pi), rtol=3e-4)
