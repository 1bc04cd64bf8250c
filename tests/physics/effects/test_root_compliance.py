"""root_compliance: a rotational spring at the clamp, against the analytic beam solution.

Truth, derived here: with u = A cosh(bx) + B sinh(bx) + C cos(bx) + D sin(bx) (l = 1, EI = rho A = 1,
omega^2 = b^4), the conditions u(0) = 0, EI u''(0) = k_theta u'(0), u''(1) = u'''(1) = 0 give a
4x4 determinant in b; kappa = k_theta l / EI.
"""
import numpy as np
import pytest
from scipy import linalg, optimize

from bayesbeam import BeamModel
from bayesbeam.physics.assembly import BeamOperators
from bayesbeam.physics.basis import SplineBasis
from bayesbeam.physics.effects import REGISTRY, Setup
from tests.physics.effects.helpers import PAPER_EI, recording

EFFECT = REGISTRY["root_compliance"]
SETUP = Setup((1.0,))


def spring_root_determinant(b: float, kappa: float) -> float:
    ch, sh, c, s = np.cosh(b), np.sinh(b), np.cos(b), np.sin(b)
    rows = np.array([
        [1.0, 0.0, 1.0, 0.0],                        # u(0) = 0
        [b, -kappa, -b, -kappa],                     # (u''(0) - kappa u'(0)) / b
        np.array([ch, sh, -c, -s]) / ch,             # u''(1) / b^2
        np.array([sh, ch, s, -c]) / ch,              # u'''(1) / b^3
    ])
    return np.linalg.det(rows)


def analytic_roots(kappa: float, count: int) -> np.ndarray:
    """The first ``count`` positive roots b of the determinant (sign changes on a fine grid)."""
    grid = np.linspace(0.05, count * np.pi + 2, 4000)
    vals = np.array([spring_root_determinant(b, kappa) for b in grid])
    idx = np.flatnonzero(np.sign(vals[:-1]) != np.sign(vals[1:]))
    roots = [optimize.brentq(spring_root_determinant, grid[i], grid[i + 1], args=(kappa,), xtol=1e-14)
             for i in idx]
    return np.array(roots[:count])


def galerkin_roots(kappa: float, n_intervals: int = 32, count: int = 6) -> np.ndarray:
    ops = BeamOperators(SplineBasis(1.0, n_intervals, "pinned"), rho_a=1.0)
    K = ops.K0 + EFFECT.stiffness(ops, {"k_theta": kappa}, SETUP)
    omega2 = linalg.eigh(K, ops.M, eigvals_only=True)
    return omega2[:count] ** 0.25


@pytest.mark.parametrize("kappa", [0.5, 5.0, 80.0])
def test_frequencies_match_the_characteristic_equation(kappa):
    """First 6 frequencies (b^2) within 3e-4 at N = 32.

    The only error is the cubic-spline discretisation, O(h^4): below 2e-4 for mode 6 at
    N = 32 in the clamped case (tests/physics/test_assembly.py); 3e-4 allows the extra root
    freedom. Frequency is proportional to b^2.
    """
    exact = analytic_roots(kappa, 6)
    np.testing.assert_allclose(galerkin_roots(kappa) ** 2, exact**2, rtol=3e-4)


def test_clamped_limit_as_the_spring_stiffens():
    """As k_theta grows the frequencies tend to the clamped beam's, with error O(EI/(k_theta l)).

    Galerkin against Galerkin at the same N (the spring only penalises the root slope), so the
    difference is the spring's compliance alone: below 2/kappa relative, and it shrinks 10x
    per decade.
    """
    ops = BeamOperators(SplineBasis(1.0, 24), rho_a=1.0)
    clamped = linalg.eigh(ops.K0, ops.M, eigvals_only=True)[:6] ** 0.25
    errors = []
    for kappa in (1e4, 1e5, 1e6):
        err = np.max(np.abs(galerkin_roots(kappa, 24) / clamped - 1))
        assert err < 2.0 / kappa
        errors.append(err)
    assert errors[0] / errors[1] > 8 and errors[1] / errors[2] > 8


@pytest.mark.parametrize("k_theta", [50.0, 3500.0])
def test_static_tip_deflection(k_theta):
    """u(l) = P l^3/(3 EI) + P l^2/k_theta exactly (to round-off, rtol 1e-10).

    The exact deflection is a cubic with u(0) = 0, which lies in the (pinned-root) spline
    space, so the Galerkin solution is exact.
    """
    P, EI, l = 2.5, PAPER_EI, 1.0
    ops = BeamOperators(SplineBasis(l, 8, "pinned"), rho_a=1.0)
    K = EI * ops.K0 + EFFECT.stiffness(ops, {"k_theta": k_theta}, SETUP)
    tip = ops.tip_value @ np.linalg.solve(K, ops.tip_value * P)
    np.testing.assert_allclose(tip, P * l**3 / (3 * EI) + P * l**2 / k_theta, rtol=1e-10)


def test_model_uses_a_pinned_basis_and_matches_the_analytic_frequencies():
    """Through BeamModel (undamped q1): the root condition switches and the spring is added."""
    rec = recording()
    model = BeamModel(rec, "q1", 32, effects="root_compliance")
    assert model.ops.basis.root == "pinned"
    kappa = 3500.0 / PAPER_EI
    freqs = model.natural_frequencies({"EI": PAPER_EI, "gamma": 0.0, "cdI": 0.0, "k_theta": 3500.0}, 4)
    b = analytic_roots(kappa, 4)
    exact = b**2 * np.sqrt(PAPER_EI / rec.beam.rho_a) / (2 * np.pi)
    np.testing.assert_allclose(freqs, exact, rtol=3e-4)


def test_non_positive_spring_is_refused():
    with pytest.raises(ValueError, match="k_theta"):
        EFFECT.check({"k_theta": 0.0})
