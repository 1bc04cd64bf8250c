"""axial_load: a tensioned (or compressed) cantilever against its exact frequency equation.

Truth, derived here (l = 1, EI = rho A = 1, p = P l^2/EI, omega^2 = w2): the ODE
u'''' - p u'' - w2 u = 0 has the characteristic roots k^2 = (p +- sqrt(p^2 + 4 w2))/2, i.e.
+-alpha and +-i beta with alpha^2 = (p + r)/2, beta^2 = (r - p)/2, r = sqrt(p^2 + 4 w2), so
u = A cosh(alpha x) + B sinh(alpha x) + C cos(beta x) + D sin(beta x). Clamped root
u(0) = u'(0) = 0; free end u''(1) = 0 and zero shear EI u''' - P u' = 0 (the axial force keeps
its direction). With alpha^2 - p = beta^2 and beta^2 + p = alpha^2 the shear row simplifies.
"""
import numpy as np
import pytest
from scipy import linalg, optimize

from bayesbeam import BeamModel
from bayesbeam.physics.assembly import BeamOperators
from bayesbeam.physics.basis import SplineBasis
from bayesbeam.physics.effects import REGISTRY, Setup
from tests.physics.effects.helpers import PAPER_EI, recording

EFFECT = REGISTRY["axial_load"]
SETUP = Setup((1.0,))


def tension_determinant(omega: float, p: float) -> float:
    r = np.sqrt(p * p + 4 * omega * omega)
    al, be = np.sqrt((p + r) / 2), np.sqrt((r - p) / 2)
    ch, sh, c, s = np.cosh(al), np.sinh(al), np.cos(be), np.sin(be)
    rows = np.array([
        [1.0, 0.0, 1.0, 0.0],                                      # u(0)
        [0.0, al, 0.0, be],                                        # u'(0)
        [al**2 * ch, al**2 * sh, -be**2 * c, -be**2 * s],          # u''(1)
        [al * be**2 * sh, al * be**2 * ch, be * al**2 * s, -be * al**2 * c],   # u''' - p u'
    ])
    rows[2:] /= ch
    return np.linalg.det(rows)


def exact_omegas(p: float, count: int = 4) -> np.ndarray:
    grid = np.linspace(0.05, 400.0, 8000)
    vals = np.array([tension_determinant(w, p) for w in grid])
    idx = np.flatnonzero(np.sign(vals[:-1]) != np.sign(vals[1:]))
    return np.array([optimize.brentq(tension_determinant, grid[i], grid[i + 1], args=(p,), xtol=1e-13)
                     for i in idx][:count])


def galerkin_omegas(p: float, n_intervals: int = 32, count: int = 4) -> np.ndarray:
    ops = BeamOperators(SplineBasis(1.0, n_intervals), rho_a=1.0)
    K = ops.K0 + EFFECT.stiffness(ops, {"P": p}, SETUP)
    return np.sqrt(linalg.eigh(K, ops.M, eigvals_only=True)[:count])


def test_zero_tension_determinant_is_the_clamped_free_equation():
    """Check of the derivation: p = 0 gives cos b cosh b = -1 (b^2 = omega)."""
    b = np.sqrt(exact_omegas(0.0, 3))
    np.testing.assert_allclose(np.cos(b) * np.cosh(b), -1.0, atol=1e-9)


@pytest.mark.parametrize("p", [-2.0, 3.0, 20.0, 200.0])
def test_frequencies_match_the_exact_tensioned_cantilever(p):
    """First 4 frequencies within 2e-4 at N = 32 (compression p = -2 to strong tension p = 200).

    The geometric stiffness integrand is a polynomial (exact quadrature); the error is the
    spline discretisation, O(h^4), below 1e-4 for mode 4 of the bare beam at N = 32.
    """
    np.testing.assert_allclose(galerkin_omegas(p), exact_omegas(p), rtol=2e-4)


def test_buckling_load_softens_the_first_mode_to_zero():
    """Just below the Euler load p_cr = pi^2/4 the first frequency is small (sqrt(1 - p/p_cr) law)."""
    p_cr = np.pi**2 / 4
    w = [galerkin_omegas(-f * p_cr, 24, 1)[0] for f in (0.9, 0.99)]
    w0 = galerkin_omegas(0.0, 24, 1)[0]
    assert w[1] < w[0] < w0
    # near buckling omega_1^2 ~ (1 - p/p_cr): the ratio of squares is close to 10
    assert 8 < (w[0] / w[1]) ** 2 < 12


def test_zero_load_reproduces_the_plain_beam():
    rec = recording()
    params = {"EI": PAPER_EI, "gamma": 0.2, "cdI": 1e-4}
    plain = BeamModel(rec, "q1", 16)
    loaded = BeamModel(rec, "q1", 16, effects="axial_load")
    np.testing.assert_array_equal(loaded.system({**params, "P": 0.0}).K, plain.system(params).K)
    np.testing.assert_allclose(loaded.simulate({**params, "P": 0.0}), plain.simulate(params), rtol=0, atol=0)


def test_model_first_frequency_under_tension():
    rec = recording()
    P = 150.0
    freqs = BeamModel(rec, "air", 32, effects="axial_load").natural_frequencies(
        {"EI": PAPER_EI, "gamma": 0.0, "P": P}, 2)
    omega = exact_omegas(P / PAPER_EI, 2) * np.sqrt(PAPER_EI / rec.beam.rho_a)
    np.testing.assert_allclose(freqs, omega / (2 * np.pi), rtol=2e-4)
