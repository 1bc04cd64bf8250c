"""Galerkin forms against analytic truth: the paper's Table 2 and the tip-body frequency equation."""
import numpy as np
import pytest
from scipy import linalg, optimize

from bayesbeam.physics.assembly import BeamOperators
from bayesbeam.physics.basis import SplineBasis

#: the paper's Table 2: clamped-free eigenvalues beta_i l, printed to three decimals
TABLE2 = np.array([1.875, 4.694, 7.855, 10.996, 14.137, 17.279, 20.420, 23.562, 26.704])


def exact_clamped_free(n):
    """Roots of cos b cosh b = -1, written as cos b + 1/cosh b = 0 (well scaled)."""
    f = lambda b: np.cos(b) + 1 / np.cosh(b)  # noqa: E731
    return np.array([optimize.brentq(f, (m - 0.5) * np.pi - 1, (m - 0.5) * np.pi + 1)
                     for m in range(1, n + 1)])


def galerkin_betas(n_intervals, length=1.0, rho_a=1.0, EI=1.0, m_T=0.0, J=0.0):
    ops = BeamOperators(SplineBasis(length, n_intervals), rho_a, m_T, J)
    omega2 = linalg.eigh(EI * ops.K0, ops.M, eigvals_only=True)
    return (omega2 * rho_a / EI) ** 0.25 * length


def test_frequencies_match_table2():
    """First 9 natural frequencies within 0.1% of Table 2 at N = 32.

    Frequency scales as beta^2. Table 2's rounding (0.0005) is at most 5e-4 relative in
    frequency, the N = 32 discretisation error at most 4e-4 (mode 9): 0.1% covers both.
    """
    beta = galerkin_betas(32)[:9]
    assert np.max(np.abs((beta / TABLE2) ** 2 - 1)) < 1e-3


def test_frequencies_converge_at_fourth_order():
    """Cubic splines on a fourth-order operator: eigenvalue error O(h^4) (Strang & Fix)."""
    exact = exact_clamped_free(9)
    errors = [np.abs(galerkin_betas(n)[:9] ** 4 / exact**4 - 1) for n in (16, 32, 64)]
    order = np.log2(errors[0][4:] / errors[1][4:]), np.log2(errors[1][4:] / errors[2][4:])
    # modes 5-9 are in the asymptotic range; the observed order lies in [3.8, 4.6]
    assert np.all((np.concatenate(order) > 3.8) & (np.concatenate(order) < 4.6)), order


def tip_body_determinant(b, mu, j):
    """Frequency determinant of a clamped-free beam with tip mass and rotary inertia.

    u = A (cosh - cos) + B (sinh - sin) in beta x; at x = l (l = 1, EI = rho_a = 1,
    omega^2 = b^4): u'' = J omega^2 u', u''' = -m_T omega^2 u (the paper's eqs. 4-5).
    mu = m_T/(rho_a l), j = J/(rho_a l^3).
    """
    ch, sh, c, s = np.cosh(b), np.sinh(b), np.cos(b), np.sin(b)
    u = np.array([ch - c, sh - s])
    du = b * np.array([sh + s, ch - c])
    d2u = b**2 * np.array([ch + c, sh + s])
    d3u = b**3 * np.array([sh - s, ch + c])
    w2 = b**4
    rows = np.array([d2u - j * w2 * du, d3u + mu * w2 * u]) / np.cosh(b)
    return np.linalg.det(rows)


def exact_tip_body(n, mu, j):
    grid = np.linspace(0.3, (n + 1.5) * np.pi, 20000)
    vals = np.array([tip_body_determinant(b, mu, j) for b in grid])
    idx = np.flatnonzero(np.sign(vals[:-1]) != np.sign(vals[1:]))
    roots = [optimize.brentq(tip_body_determinant, grid[i], grid[i + 1], args=(mu, j)) for i in idx]
    return np.array(roots[:n])


@pytest.mark.parametrize("mu, j", [(0.0, 0.0), (0.25, 0.0), (0.25, 0.002), (1.0, 0.01)])
def test_tip_body_frequencies_match_characteristic_equation(mu, j):
    """With m_T and J, the first 8 frequencies agree with the analytic roots to 0.05% at N = 32."""
    beta = galerkin_betas(32, m_T=mu, J=j)[:8]
    exact = exact_tip_body(8, mu, j)
    assert np.max(np.abs((beta / exact) ** 2 - 1)) < 5e-4


def test_mass_matrix_integrates_total_mass():
    # sum_ij over the constant function 1 is not in the clamped space, so check the beam mass
    # through x^2 (in the space): integral of x^4 from 0 to l, times rho_a
    ops = BeamOperators(SplineBasis(0.8, 6), rho_a=2.5, m_T=0.3, J=0.01)
    x = np.linspace(0, 0.8, 41)
    coef, *_ = np.linalg.lstsq(ops.rows(x), x**2, rcond=None)
    expected = 2.5 * 0.8**5 / 5 + 0.3 * 0.8**4 + 0.01 * (2 * 0.8) ** 2
    assert np.isclose(coef @ ops.M @ coef, expected, rtol=1e-12)


def test_stiffness_form_is_exact_for_cubics():
    ops = BeamOperators(SplineBasis(1.0, 5), rho_a=1.0)
    x = np.linspace(0, 1, 31)
    coef, *_ = np.linalg.lstsq(ops.rows(x), x**3, rcond=None)
    # (x^3)'' = 6x: integral of 36 x^2 over [0, 1] = 12
    assert np.isclose(coef @ ops.K0 @ coef, 12.0, rtol=1e-12)
