"""The modified B-spline basis of degree p: root conditions, smoothness, completeness, the pieces
against scipy's B-splines, and the Galerkin eigenvalues' accuracy and convergence order per degree."""
import csv
from pathlib import Path

import numpy as np
import pytest
from scipy import interpolate

from bayesbeam.physics.basis import SplineBasis, combined_root
from tests.physics.test_assembly import exact_clamped_free, exact_tip_body, galerkin_betas

DEGREES = (3, 4, 5, 7)
TABLE2_CSV = Path(__file__).resolve().parents[2] / "data" / "paper" / "table2_eigenvalues.csv"


def table2() -> np.ndarray:
    """The paper's Table 2 (beta_i l, three decimals) as transcribed in data/paper."""
    with TABLE2_CSV.open() as fh:
        return np.array([float(row["beta_l"]) for row in csv.DictReader(fh)])


@pytest.mark.parametrize("degree", DEGREES)
@pytest.mark.parametrize("n", [2, 5, 16])
def test_clamped_basis_satisfies_root_conditions(n, degree):
    basis = SplineBasis(0.7, n, degree=degree)
    assert basis.size == n + degree - 2
    # round-off only: value and slope of every basis function at the clamp, relative to O(1)
    # values and O(1/h) slopes
    assert np.abs(basis.evaluate([0.0])).max() < 1e-14
    assert np.abs(basis.evaluate([0.0], 1)).max() * basis.h < 1e-13


@pytest.mark.parametrize("degree", DEGREES)
def test_pinned_basis_adds_one_root_slope(degree):
    basis = SplineBasis(1.0, 8, root="pinned", degree=degree)
    assert basis.size == 8 + degree - 1
    assert np.abs(basis.evaluate([0.0])).max() < 1e-14
    slopes = basis.evaluate([0.0], 1)[0]
    assert np.count_nonzero(np.abs(slopes) > 1e-12) == 1


def test_cubic_root_function_is_the_papers_combination():
    """Degree 3: B~_{-1} - B~_0 / 2 + B~_1, exactly (solved in rationals)."""
    c = SplineBasis(1.0, 4).combination
    assert np.array_equal(c[:3, 0], [1.0, -0.5, 1.0])
    assert np.array_equal(c[3:, 1:5], np.eye(4))


@pytest.mark.parametrize("degree", [3, 5, 6])
@pytest.mark.parametrize("deriv", [0, 1, 2, 3])
def test_pieces_match_scipy_bsplines(degree, deriv):
    """Standard splines against scipy.interpolate.BSpline.basis_element on the uniform knots
    (an independent implementation: de Boor's algorithm on the knot vector), between the knots
    and, below the p-th derivative, at both ends (the p-th derivative jumps at a knot, and scipy
    takes the piece to the right of x = l where the basis takes the last interval's).
    Round-off: 1e-12 of the derivative's scale 1/h^deriv."""
    basis = SplineBasis(1.0, 6, degree=degree)
    h = basis.h
    x = (np.arange(156) + 0.37) / 156
    if deriv < degree:
        x = np.concatenate([[0.0, 1.0], x])
    ours = basis.standard(x, deriv)
    for j in range(6 + degree):
        knots = (np.arange(degree + 2) + j - degree) * h          # support [(j - p) h, (j + 1) h]
        ref = interpolate.BSpline.basis_element(knots, extrapolate=False)
        expected = np.nan_to_num(ref.derivative(deriv)(x) if deriv else ref(x))
        assert np.abs(ours[:, j] - expected).max() < 1e-12 / h**deriv, j


@pytest.mark.parametrize("degree", DEGREES)
def test_standard_splines_partition_unity(degree):
    basis = SplineBasis(2.0, 7, degree=degree)
    x = np.linspace(0, 2.0, 301)
    np.testing.assert_allclose(basis.standard(x).sum(axis=1), 1.0, atol=1e-14)
    np.testing.assert_allclose(basis.standard(x, 1).sum(axis=1), 0.0, atol=1e-12)


@pytest.mark.parametrize("degree", DEGREES)
def test_splines_are_smooth_to_degree_minus_one_across_knots(degree):
    """Derivatives 0 .. p-1 continuous at the knots, the p-th jumps (else global polynomials).

    The jump over 2 eps of a continuous d-th derivative is the next derivative times 2 eps; a
    standard spline's (d+1)-th derivative is a (d+1)-fold difference of values <= 1 over h^(d+1),
    at most (2/h)^(d+1): bound 4 eps (2/h)^(d+1)."""
    basis = SplineBasis(1.0, 6, degree=degree)
    knots = np.arange(1, 6) * basis.h
    eps = 1e-9
    for deriv in range(degree):
        jump = basis.standard(knots - eps, deriv) - basis.standard(knots + eps, deriv)
        assert np.abs(jump).max() < 4 * eps * (2 / basis.h) ** (deriv + 1), deriv
    top = basis.standard(knots - eps, degree) - basis.standard(knots + eps, degree)
    assert np.abs(top).max() > 1.0


@pytest.mark.parametrize("degree", DEGREES)
def test_clamped_space_reproduces_admissible_polynomials(degree):
    """x^2 .. x^p vanish with their slope at 0 and have degree <= p: the space contains them."""
    basis = SplineBasis(1.3, 9, degree=degree)
    x = np.linspace(0, 1.3, 97)
    a = basis.evaluate(x)
    for k in range(2, degree + 1):
        coef, *_ = np.linalg.lstsq(a, x**k, rcond=None)
        assert np.abs(a @ coef - x**k).max() < 1e-11, k


@pytest.mark.parametrize("degree", [3, 5])
def test_pinned_space_reproduces_linear_root_rotation(degree):
    basis = SplineBasis(1.0, 9, root="pinned", degree=degree)
    x = np.linspace(0, 1.0, 55)
    a = basis.evaluate(x)
    coef, *_ = np.linalg.lstsq(a, 0.3 * x + x**3, rcond=None)
    assert np.abs(a @ coef - (0.3 * x + x**3)).max() < 1e-11


@pytest.mark.parametrize("degree", DEGREES)
@pytest.mark.parametrize("root, size, value_free, slope_free",
                         [("sliding", 1, True, False), ("free", 2, True, True)])
def test_sliding_and_free_roots_add_the_root_value(degree, root, size, value_free, slope_free):
    """The sliding basis is the clamped one plus one function of value 1 and slope 0 at the root;
    the free basis adds the pinned basis's slope function too (N + p functions, the whole spline
    space). Round-off bounds as for the clamped root: 1e-14 of O(1) values, 1e-13 of O(1/h) slopes."""
    basis = SplineBasis(1.0, 8, root=root, degree=degree)
    assert basis.size == 8 + degree - 2 + size
    clamped = SplineBasis(1.0, 8, degree=degree).size
    values, slopes = basis.evaluate([0.0])[0], basis.evaluate([0.0], 1)[0] * basis.h
    assert np.abs(values[:clamped]).max() < 1e-14 and np.abs(slopes[:clamped]).max() < 1e-13
    assert values[-1] == pytest.approx(1.0, abs=1e-14) and abs(slopes[-1]) < 1e-13
    if slope_free:
        assert abs(values[-2]) < 1e-14 and abs(slopes[-2]) > 1e-3
    assert np.linalg.matrix_rank(basis.combination) == basis.size


@pytest.mark.parametrize("degree", [3, 5, 7])
@pytest.mark.parametrize("root, poly", [("sliding", lambda x: 0.7 + x**2 - 0.4 * x**3),
                                        ("free", lambda x: 0.7 - 0.3 * x + x**2 - 0.4 * x**3)])
def test_sliding_and_free_spaces_reproduce_polynomials_with_their_root_values(degree, root, poly):
    """Completeness: a cubic with a root value (and, free, a root slope) lies in the space, so least
    squares reproduces it to round-off (1e-11 as for the clamped space); without the value-free
    function it could not (the clamped space misses the constant by its full size)."""
    basis = SplineBasis(1.0, 9, root=root, degree=degree)
    x = np.linspace(0, 1.0, 97)
    a = basis.evaluate(x)
    coef, *_ = np.linalg.lstsq(a, poly(x), rcond=None)
    assert np.abs(a @ coef - poly(x)).max() < 1e-11
    clamped = SplineBasis(1.0, 9, degree=degree).evaluate(x)
    coef, *_ = np.linalg.lstsq(clamped, poly(x), rcond=None)
    assert np.abs(clamped @ coef - poly(x)).max() > 0.1


def test_roots_combine_by_what_they_free():
    assert combined_root([]) == "clamped"
    assert combined_root(["pinned", "pinned"]) == "pinned"
    assert combined_root(["sliding"]) == "sliding"
    assert combined_root(["pinned", "sliding"]) == "free"


@pytest.mark.parametrize("degree", [3, 5])
def test_default_gauss_rule_is_exact_for_degree_2p_plus_1(degree):
    """p + 1 points per interval: exact for the mass form's degree 2p and one more."""
    basis = SplineBasis(1.0, 5, degree=degree)
    x, w = basis.quadrature()
    assert w.size == 5 * (degree + 1)
    assert np.isclose(np.sum(w * x ** (2 * degree + 1)), 1 / (2 * degree + 2), rtol=1e-14)


def test_refuses_bad_arguments():
    with pytest.raises(ValueError, match="n_intervals"):
        SplineBasis(1.0, 1)
    with pytest.raises(ValueError, match="root"):
        SplineBasis(1.0, 4, root="hinged")
    with pytest.raises(ValueError, match=r"\[0, 1.0\]"):
        SplineBasis(1.0, 4).evaluate([1.5])
    with pytest.raises(ValueError, match="degree"):
        SplineBasis(1.0, 4, degree=2)
    with pytest.raises(ValueError, match="derivative order 4"):
        SplineBasis(1.0, 4).evaluate([0.5], 4)


# ----------------------------------------------------------------------- Galerkin eigenvalues
@pytest.mark.parametrize("degree, n", [(3, 32), (5, 16)])
def test_frequencies_match_table2(degree, n):
    """First 9 natural frequencies within 0.1 % of Table 2 (read from data/paper).

    Frequency scales as beta^2. Table 2's rounding (0.0005) is at most 5e-4 relative in
    frequency; the discretisation's frequency error is at most 4e-4 (cubic, N = 32, mode 9) and
    1.4e-4 (quintic, N = 16: 19 degrees of freedom against 33): 0.1 % covers both.
    """
    beta = galerkin_betas(n, degree=degree)[:9]
    assert np.max(np.abs((beta / table2()) ** 2 - 1)) < 1e-3


@pytest.mark.parametrize("degree, grids, order", [(3, (16, 32, 64), 4), (5, (12, 18, 27), 8)])
def test_eigenvalues_converge_at_order_2p_minus_2(degree, grids, order):
    """A degree-p Galerkin method for the fourth-order beam operator: eigenvalue errors
    O(h^(2(p-1))) (Strang & Fix): h^4 for cubics, h^8 for quintics.

    Modes 5-9, all errors above 5e-9 (the round-off floor is 1e-10). The observed order between
    successive grids (ratio r) approaches 2(p-1) from above, its excess shrinking like h^2
    (measured: cubic 4.05-4.59 then 4.05-4.17; quintic 9.2-11.0 then 8.6-9.7), so the order
    extrapolated as q2 + (q2 - q1)/(r^2 - 1) must be within 0.8 of 2(p-1) (measured 4.00-4.03
    and 8.1-8.7): a method of order 2(p-1) +- 2 fails this.
    """
    modes = slice(4, 9)
    exact = exact_clamped_free(9)[modes] ** 4
    errors = np.array([np.abs(galerkin_betas(n, degree=degree)[modes] ** 4 / exact - 1) for n in grids])
    assert errors.min() > 5e-9
    ratio = grids[1] / grids[0]
    assert grids[2] / grids[1] == ratio
    q1, q2 = np.log(errors[:-1] / errors[1:]) / np.log(ratio)
    assert np.all(np.concatenate([q1, q2]) > order - 0.2), (q1, q2)
    extrapolated = q2 + (q2 - q1) / (ratio**2 - 1)
    assert np.all(np.abs(extrapolated - order) < 0.8), extrapolated


@pytest.mark.parametrize("degree, n, tol", [(3, 32, 5e-4), (5, 16, 1e-4), (5, 24, 2e-6)])
@pytest.mark.parametrize("mu, j", [(0.25, 0.002), (1.0, 0.01)])
def test_tip_body_frequencies_match_characteristic_equation(degree, n, tol, mu, j):
    """With m_T and J, the first 9 frequencies against the analytic roots of the tip-body
    frequency equation. Bounds: the measured discretisation errors (cubic N = 32: 2.3e-4,
    quintic N = 16: 3.8e-5, N = 24: 7.3e-7) with a factor of at least 2 to spare. The quintic at
    N = 24 has 26 degrees of freedom, the cubic at N = 32 has 33 and errs 300 times more."""
    beta = galerkin_betas(n, m_T=mu, J=j, degree=degree)[:9]
    assert np.max(np.abs((beta / exact_tip_body(9, mu, j)) ** 2 - 1)) < tol
