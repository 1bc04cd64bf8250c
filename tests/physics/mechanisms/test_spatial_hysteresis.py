"""Spatial hysteresis: dissipation, quadrature convergence, the Kelvin-Voigt limit, and the fast
block-Toeplitz assembly against the dense bracket form it regroups."""
import math

import numpy as np
import pytest
from scipy import integrate

from bayesbeam.physics.assembly import BeamOperators
from bayesbeam.physics.basis import SplineBasis
from bayesbeam.physics.mechanisms.spatial_hysteresis import SpatialHysteresis, _slope_rows, kernel, points_per_interval

MECH = SpatialHysteresis()


@pytest.mark.parametrize("b", [0.01, 0.064, 0.3, 2.0])
def test_dissipation_is_non_negative_for_random_velocity_fields(b):
    ops = BeamOperators(SplineBasis(1.0, 16), rho_a=1.0)
    d = MECH.damping(ops, {"a": 1.0, "b": b})
    assert np.allclose(d, d.T, rtol=0, atol=1e-14 * np.abs(d).max())
    v = np.random.default_rng(0).standard_normal((ops.size, 500))
    power = np.einsum("ik,ij,jk->k", v, d, v)
    assert np.all(power >= -1e-12 * np.abs(d).max() * ops.size)


@pytest.mark.parametrize("b", [0.008, 0.05, 0.18, 1.0])
def test_quadrature_is_converged(b):
    """Doubling the Gauss points per interval changes D by less than 1e-8 relative."""
    ops = BeamOperators(SplineBasis(1.0, 16), rho_a=1.0)
    d = MECH.damping(ops, {"a": 1.0, "b": b})
    x, w, g = _slope_rows(ops.basis, 2 * points_per_interval(ops.basis.h, b))
    h = kernel(x, x, 1.0, b)
    d2 = g.T @ (np.diag(w * (h @ w)) - w[:, None] * h * w[None, :]) @ g
    assert np.abs(d - d2).max() < 1e-8 * np.abs(d).max()


def paper_kernel(x, xi, a, b):
    """The paper's eq. (14), written out here: h = a / (b sqrt(2 pi)) exp(-(x - xi)^2 / (2 b^2))."""
    return a / (b * math.sqrt(2 * math.pi)) * math.exp(-((x - xi) ** 2) / (2 * b * b))


@pytest.mark.parametrize("b", [0.15, 0.04])
def test_double_integral_matches_independent_quadrature(b):
    """d(v, v) of one smooth field from the paper's own form, by scipy dblquad: the damping force
    -d/dx int h(x, xi) (v'(x) - v'(xi)) dxi, integrated by parts against v (the boundary term is
    the free end's damping moment), gives int v'(x) int h(x, xi) (v'(x) - v'(xi)) dxi dx, here
    not symmetrised and with the kernel written from eq. (14), not the module's. dblquad's own
    error estimates stay below 3e-10 of the value; measured agreement 1e-13 (b = 0.15 m) and
    3e-13 (b = 0.04 m); bound 1e-9. A kernel normalised as a/(b sqrt(pi)) exp(-d^2/b^2) is 44-49 %
    off."""
    a, l = 0.7, 1.0
    ops = BeamOperators(SplineBasis(l, 12), rho_a=1.0)
    x = np.linspace(0, l, 60)
    coef, *_ = np.linalg.lstsq(ops.rows(x), x**2 * (3 - x), rcond=None)  # exactly in the space

    def slope(y):
        return 6 * y - 3 * y**2

    def integrand(xi, y):
        return slope(y) * paper_kernel(y, xi, a, b) * (slope(y) - slope(xi))

    # the kernel's width splits the inner integral at xi = y, where it peaks
    ref = sum(integrate.dblquad(integrand, 0, l, lo, hi, epsabs=1e-13, epsrel=1e-11)[0]
              for lo, hi in ((lambda y: 0.0, lambda y: y), (lambda y: y, lambda y: l)))
    assert np.isclose(coef @ MECH.damping(ops, {"a": a, "b": b}) @ coef, ref, rtol=1e-9, atol=0)


def test_small_b_limit_is_kelvin_voigt():
    """For b -> 0 and a field whose curvature lives away from the ends, d(v, v) -> a b^2/2 int v''^2.

    The next term of the Taylor expansion is O(b^2) relative (the fourth moment a*3b^4 against
    a*b^2), so halving b must cut the relative error about fourfold.
    """
    l = 1.0
    ops = BeamOperators(SplineBasis(l, 128), rho_a=1.0)
    x = np.linspace(0, l, 2000)
    bump = np.where((x > 0.3) & (x < 0.7), np.sin(np.pi * (x - 0.3) / 0.4) ** 4, 0.0)
    coef, *_ = np.linalg.lstsq(ops.rows(x), bump, rcond=None)
    kv = coef @ ops.K0 @ coef
    errors = []
    for b in (0.01, 0.005):
        d = MECH.damping(ops, {"a": 1.0, "b": b})
        errors.append(abs(coef @ d @ coef / (0.5 * b**2 * kv) - 1))
    # measured: 1.5e-2 at b = 0.01 and 3.8e-3 at b = 0.005 for this bump (width 0.4 m)
    assert errors[1] < 5e-3
    assert 3.5 < errors[0] / errors[1] < 4.5, errors


def test_refuses_zero_width():
    with pytest.raises(ValueError, match="b"):
        MECH.check({"a": 1.0, "b": 0.0})


def dense_bracket_form(basis, a, b):
    """D = G^T [diag(w * Hw) - W H W] G on the full (N p) x (N p) kernel (the module doc's formula)."""
    x, w, g = _slope_rows(basis, points_per_interval(basis.h, b))
    h = kernel(x, x, a, b)
    d = g.T @ (np.diag(w * (h @ w)) - w[:, None] * h * w[None, :]) @ g
    return 0.5 * (d + d.T)


@pytest.mark.parametrize("length, n, root", [(1.0, 16, "clamped"), (0.73, 12, "pinned"),
                                             (1.0, 2, "clamped"), (1.0, 3, "pinned"),
                                             (1.0, 32, "clamped")])
@pytest.mark.parametrize("b", [0.01, 0.064362, 0.18, 1.0, 50.0])
def test_fast_assembly_matches_the_dense_bracket_form(length, n, root, b):
    """Same sums regrouped: equal to round-off.

    Measured: at most 1.7e-15 of max |D| for N >= 12, 2.5e-14 at N = 2, b = 0.01 m, where the
    bracket form itself loses digits (diag(w Hw) and W H W share the self-terms h(x_q, x_q),
    which cancel; against extended precision it errs by 7e-12 at N = 2, b = 0.005 m, the fast
    assembly by 7e-15). The bound 1e-13 is round-off for these cases, not a tolerance on the
    physics.
    """
    basis = SplineBasis(length, n, root)
    ops = BeamOperators(basis, rho_a=1.0)
    for a in (1.0, 0.025):
        d = MECH.damping(ops, {"a": a, "b": b})
        ref = dense_bracket_form(basis, a, b)
        assert d.shape == (basis.size, basis.size)
        assert np.array_equal(d, d.T)
        assert np.abs(d - ref).max() <= 1e-13 * np.abs(ref).max()


@pytest.mark.parametrize("n, b", [(8, 0.003), (16, 0.002), (32, 0.01), (12, 0.02)])
def test_the_blocks_skipped_for_a_narrow_kernel_hold_nothing(monkeypatch, n, b):
    """A narrow kernel's far offsets (every value below exp(-UNDERFLOW) = 4e-18 of its peak) are
    left out: D equals the assembly of every offset to 1e-14 of max |D| (measured 1.4e-15: the
    sums taken in another order; the blocks left out are 4e-18 of it at most; a threshold of
    exp(-20) fails it), and some offsets were left out in each case."""
    from bayesbeam.physics.mechanisms import spatial_hysteresis as module

    basis = SplineBasis(1.3, n, degree=5)
    assembly = module._assembly(basis, points_per_interval(basis.h, b))
    assert np.searchsorted(assembly.closest, 2 * b * b * module.UNDERFLOW) < n
    skipped = assembly.unit_matrix(b)
    monkeypatch.setattr(module, "UNDERFLOW", np.inf)
    full = assembly.unit_matrix(b)
    assert np.abs(skipped - full).max() <= 1e-14 * np.abs(full).max()


def test_damping_is_linear_in_a_and_repeatable():
    """The cached (a, b)-independent part is not modified by a call."""
    ops = BeamOperators(SplineBasis(1.0, 16), rho_a=1.0)
    d1 = MECH.damping(ops, {"a": 1.0, "b": 0.18})
    MECH.damping(ops, {"a": 3.0, "b": 0.02})                 # another Gauss rule, same basis
    d2 = MECH.damping(ops, {"a": 0.025, "b": 0.18})
    assert np.allclose(d2, 0.025 * d1, rtol=1e-15, atol=0)
    assert np.array_equal(MECH.damping(ops, {"a": 1.0, "b": 0.18}), d1)


@pytest.mark.parametrize("h, b", [(0.0625, 0.18), (0.0625, 0.005), (1.0, 1e-300), (0.5, 0.0357),
                                  (0.1, 0.3), (0.1, 1e300), (0.05, 0.0035714285714285718)])
def test_points_per_interval_is_the_clipped_formula(h, b):
    with np.errstate(over="ignore"):
        expected = int(np.clip(np.ceil(3.0 * h / b) + 6, 6, 48))
    assert points_per_interval(h, b) == expected


@pytest.mark.parametrize("b", [1e-300, 1e-160, 1e150, 1e200, np.inf])
def test_extreme_widths_give_finite_matrices(b):
    """b*b under- or overflows; the cached distances must not turn into 0 * inf = nan."""
    basis = SplineBasis(1.0, 16)
    ops = BeamOperators(basis, rho_a=1.0)
    d = MECH.damping(ops, {"a": 1.0, "b": b})
    assert np.all(np.isfinite(d))
    with np.errstate(over="ignore", under="ignore", divide="ignore", invalid="ignore"):
        ref = dense_bracket_form(basis, 1.0, b)
    assert np.abs(d - ref).max() <= 1e-13 * np.abs(ref).max()
