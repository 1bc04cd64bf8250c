"""The modified cubic B-spline basis: root conditions, smoothness, completeness."""
import numpy as np
import pytest

from bayesbeam.physics.basis import SplineBasis


@pytest.mark.parametrize("n", [2, 5, 16])
def test_clamped_basis_satisfies_root_conditions(n):
    basis = SplineBasis(0.7, n)
    assert basis.size == n + 1
    # exact zeros: the combination cancels the three root splines exactly in floating point
    assert np.abs(basis.evaluate([0.0])).max() < 1e-15
    assert np.abs(basis.evaluate([0.0], 1)).max() < 1e-12


def test_pinned_basis_adds_one_root_slope():
    basis = SplineBasis(1.0, 8, root="pinned")
    assert basis.size == 10
    assert np.abs(basis.evaluate([0.0])).max() < 1e-15
    slopes = basis.evaluate([0.0], 1)[0]
    assert np.count_nonzero(np.abs(slopes) > 1e-12) == 1


def test_standard_splines_partition_unity():
    basis = SplineBasis(2.0, 7)
    x = np.linspace(0, 2.0, 301)
    np.testing.assert_allclose(basis.standard(x).sum(axis=1), 1.0, atol=1e-14)
    np.testing.assert_allclose(basis.standard(x, 1).sum(axis=1), 0.0, atol=1e-12)


@pytest.mark.parametrize("deriv", [0, 1, 2])
def test_basis_is_c2_across_knots(deriv):
    basis = SplineBasis(1.0, 6)
    knots = np.arange(1, 6) * basis.h
    eps = 1e-9
    left = basis.evaluate(knots - eps, deriv)
    right = basis.evaluate(knots + eps, deriv)
    # the jump over 2*eps is the next derivative (bounded by 6/h^3) times 2*eps
    assert np.abs(left - right).max() < 1e-6


def test_third_derivative_jumps_at_knots():
    # cubic splines are C2, not C3: without jumps they would be global cubics
    basis = SplineBasis(1.0, 6)
    x = basis.h * 3
    jump = basis.evaluate([x - 1e-9], 3) - basis.evaluate([x + 1e-9], 3)
    assert np.abs(jump).max() > 1.0


def test_clamped_space_reproduces_admissible_cubics():
    # x^2 and x^3 satisfy u(0) = u'(0) = 0 and are cubic: the space must contain them exactly
    basis = SplineBasis(1.3, 9)
    x = np.linspace(0, 1.3, 97)
    a = basis.evaluate(x)
    for target in (x**2, x**3, 2 * x**2 - x**3):
        coef, *_ = np.linalg.lstsq(a, target, rcond=None)
        assert np.abs(a @ coef - target).max() < 1e-12


def test_pinned_space_reproduces_linear_root_rotation():
    basis = SplineBasis(1.0, 9, root="pinned")
    x = np.linspace(0, 1.0, 55)
    a = basis.evaluate(x)
    coef, *_ = np.linalg.lstsq(a, 0.3 * x + x**3, rcond=None)
    assert np.abs(a @ coef - (0.3 * x + x**3)).max() < 1e-12


def test_gauss_quadrature_is_exact_for_degree_seven():
    basis = SplineBasis(1.0, 5)
    x, w = basis.quadrature(4)
    assert np.isclose(np.sum(w * x**7), 1 / 8, rtol=1e-14)


def test_refuses_bad_arguments():
    with pytest.raises(ValueError, match="n_intervals"):
        SplineBasis(1.0, 1)
    with pytest.raises(ValueError, match="root"):
        SplineBasis(1.0, 4, root="free")
    with pytest.raises(ValueError, match=r"\[0, 1.0\]"):
        SplineBasis(1.0, 4).evaluate([1.5])
