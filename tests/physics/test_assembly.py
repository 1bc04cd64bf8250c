"""Galerkin forms against analytic truth (the tip-body frequency equation, exact integrals) and the
damping mechanisms at degree 5 against closed forms and the converged cubic.

The analytic eigenvalue helpers also serve tests/physics/test_basis.py (Table 2 and the
convergence order per degree) and the mechanism tests."""
import numpy as np
from scipy import linalg, optimize

from bayesbeam.physics.assembly import BeamOperators
from bayesbeam.physics.basis import SplineBasis
from bayesbeam.physics.mechanisms import REGISTRY
from bayesbeam.response.system import SecondOrderSystem


def exact_clamped_free(n):
    """Roots of cos b cosh b = -1, written as cos b + 1/cosh b = 0 (well scaled)."""
    f = lambda b: np.cos(b) + 1 / np.cosh(b)
    return np.array([optimize.brentq(f, (m - 0.5) * np.pi - 1, (m - 0.5) * np.pi + 1)
                     for m in range(1, n + 1)])


def galerkin_betas(n_intervals, length=1.0, rho_a=1.0, EI=1.0, m_T=0.0, J=0.0, degree=3):
    """Dimensionless eigenvalues beta_i l of the degree-``degree`` Galerkin beam, lowest first."""
    ops = BeamOperators(SplineBasis(length, n_intervals, degree=degree), rho_a, m_T, J)
    omega2 = linalg.eigh(EI * ops.K0, ops.M, eigvals_only=True)
    return (omega2 * rho_a / EI) ** 0.25 * length


def tip_body_determinant(b, mu, j):
    """Frequency determinant of a clamped-free beam with tip mass and rotary inertia.

    Shapes cosh - cos and (sinh - sin) - (cosh - cos) in beta x; the free-end conditions at
    x = l (l = 1, EI = rho_a = 1, omega^2 = b^4; the paper's eqs. 4-5) are
    u_xx = J omega^2 u_x and u_xxx = -m_T omega^2 u, with mu = m_T/(rho_a l), j = J/(rho_a l^3).
    The second shape's hyperbolic parts cancel to -e^(-x): with the first divided by cosh b both
    columns stay O(1) and the roots come out to b = 45 (with sinh - sin itself the two columns
    agree to e^(-2b), and rounding made spurious roots beyond b = 30).
    """
    ch, sh, c, s, em = np.cosh(b), np.sinh(b), np.cos(b), np.sin(b), np.exp(-b)
    u = np.array([(ch - c) / ch, c - s - em])
    du = b * np.array([(sh + s) / ch, em - c - s])
    d2u = b**2 * np.array([(ch + c) / ch, s - c - em])
    d3u = b**3 * np.array([(sh - s) / ch, c + s + em])
    w2 = b**4
    moment, shear = d2u - j * w2 * du, d3u + mu * w2 * u        # the two rows, columns first
    return moment[0] * shear[1] - moment[1] * shear[0]


def exact_tip_body(n, mu, j):
    """The first n roots b = beta l of :func:`tip_body_determinant`: sign changes on a fine grid
    (spacing under 3e-3 for n <= 16, the roots are about pi apart), refined by brentq."""
    grid = np.linspace(0.3, (n + 1.5) * np.pi, 20000)
    vals = tip_body_determinant(grid, mu, j)
    idx = np.flatnonzero(np.sign(vals[:-1]) != np.sign(vals[1:]))
    roots = [optimize.brentq(tip_body_determinant, grid[i], grid[i + 1], args=(mu, j)) for i in idx]
    return np.array(roots[:n])


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


def test_mass_and_stiffness_forms_are_exact_for_quintics():
    """x^5 is in the quintic clamped space and the p + 1 = 6 point Gauss rule integrates the forms
    exactly: int_0^1 x^10 = 1/11 and int_0^1 (20 x^3)^2 = 400/7, to round-off."""
    ops = BeamOperators(SplineBasis(1.0, 5, degree=5), rho_a=1.0)
    x = np.linspace(0, 1, 41)
    coef, *_ = np.linalg.lstsq(ops.rows(x), x**5, rcond=None)
    assert np.isclose(coef @ ops.M0 @ coef, 1 / 11, rtol=1e-12)
    assert np.isclose(coef @ ops.K0 @ coef, 400 / 7, rtol=1e-12)


# ------------------------------------------------------------------ the mechanisms at degree 5
RHO_A, EI = 1710 * 0.597e-3, 2.68e10 * 1.64e-9     # the paper's beam (Table 1, eq. 38), N m^2


def paper_beam_poles(mechanisms, values, n_intervals, degree):
    """Oscillatory poles (rad/s) of the paper's beam without tip body, damped by ``mechanisms``."""
    ops = BeamOperators(SplineBasis(1.0, n_intervals, degree=degree), RHO_A)
    damping, relaxation = np.zeros((ops.size, ops.size)), None
    for name in mechanisms:
        d = REGISTRY[name].damping(ops, values)
        damping = damping if d is None else damping + d
        relaxation = REGISTRY[name].relaxation(values) or relaxation
    k_h = ops.K0 if relaxation else None
    return SecondOrderSystem(ops.M, damping, EI * ops.K0, relaxation, k_h).poles()


def test_q1_at_degree_5_matches_eq26():
    """Air + strain rate, quintic N = 16 (19 dofs): zeta_m = (gamma + cdI beta_m^4) / (2 rhoA
    omega_m), omega_m^2 = EI beta_m^4 / rhoA (eq. 26) for the first 9 modes. The only error is
    the spline error of beta_m^4, measured 1.3e-4 at mode 9 in both zeta and omega: bound 3e-4
    (the cubic needs N = 32, 33 dofs, for 1e-3)."""
    values = {"gamma": 1.7561, "cdI": 2.05e5 * 1.64e-9}
    poles = paper_beam_poles(("air", "strain_rate"), values, 16, degree=5)[:9]
    b4 = exact_clamped_free(9) ** 4
    omega = np.sqrt(EI * b4 / RHO_A)
    zeta = (values["gamma"] + values["cdI"] * b4) / (2 * RHO_A * omega)
    np.testing.assert_allclose(-poles.real / np.abs(poles), zeta, rtol=3e-4)
    np.testing.assert_allclose(np.abs(poles), omega, rtol=3e-4)


def test_time_hysteresis_at_degree_5_matches_the_modal_equation():
    """K_h = K_0: the bare beam's modes decouple the memory, and mode m's pole solves the scalar
    equation s^2 + (EI - G(s)) beta_m^4 / rhoA = 0 with the exact beta_m (solved here by Newton
    from i omega_m, secant slopes). Quintic N = 16: measured 1.3e-4 in |p| and 7e-5 in zeta at
    mode 9, the spline error of beta_m^4: bound 3e-4."""
    values = {"alpha": 0.05, "beta": 20.0, "r": np.inf}
    poles = paper_beam_poles(("time_hysteresis",), values, 16, degree=5)[:9]
    lam = exact_clamped_free(9) ** 4 / RHO_A
    g = REGISTRY["time_hysteresis"].relaxation(values)
    s = 1j * np.sqrt(EI * lam)
    for _ in range(30):
        step = 1e-7 * np.abs(s)
        f = s**2 + (EI - g(s)) * lam
        slope = ((s + step) ** 2 + (EI - g(s + step)) * lam - f) / step
        s = s - f / slope
    np.testing.assert_allclose(np.abs(poles), np.abs(s), rtol=3e-4)
    np.testing.assert_allclose(poles.real / np.abs(poles), s.real / np.abs(s), rtol=3e-4)


def test_spatial_hysteresis_at_degree_5_matches_the_converged_cubic():
    """q3 (air + Gaussian kernel, b = 0.18 m) has no closed form: quintic N = 24 (27 dofs) against
    cubic N = 96 (97 dofs), two bases and two block layouts of the double integral. Each is
    within 3e-6 of the quintic at N = 48 in |p| and zeta (first 9 modes): bound 2e-5."""
    values = {"gamma": 0.12, "a": 0.025, "b": 0.18}
    quintic = paper_beam_poles(("air", "spatial_hysteresis"), values, 24, degree=5)[:9]
    cubic = paper_beam_poles(("air", "spatial_hysteresis"), values, 96, degree=3)[:9]
    np.testing.assert_allclose(np.abs(quintic), np.abs(cubic), rtol=2e-5)
    np.testing.assert_allclose(quintic.real / np.abs(quintic), cubic.real / np.abs(cubic), rtol=2e-5)


