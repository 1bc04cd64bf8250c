"""Spatial hysteresis: dissipation, the Kelvin-Voigt limit, and the assembly (exact in the kernel's
width) against the dense Gauss-rule bracket form on a rule that resolves the kernel."""
import math

import numpy as np
import pytest
from scipy import integrate

from bayesbeam.physics.assembly import BeamOperators
from bayesbeam.physics.basis import SplineBasis
from bayesbeam.physics.mechanisms.spatial_hysteresis import SpatialHysteresis, kernel

MECH = SpatialHysteresis()


@pytest.mark.parametrize("n, degree, b", [(16, 3, 0.01), (16, 3, 0.064), (16, 3, 0.3), (16, 3, 2.0),
                                          (8, 5, 0.0015)])
def test_dissipation_is_non_negative_for_random_velocity_fields(n, degree, b):
    ops = BeamOperators(SplineBasis(1.0, n, degree=degree), rho_a=1.0)
    d = MECH.damping(ops, {"a": 1.0, "b": b})
    assert np.allclose(d, d.T, rtol=0, atol=1e-14 * np.abs(d).max())
    v = np.random.default_rng(0).standard_normal((ops.size, 500))
    power = np.einsum("ik,ij,jk->k", v, d, v)
    assert np.all(power >= -1e-12 * np.abs(d).max() * ops.size)


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


def dense_bracket_form(basis, a, b, points=None):
    """D = G^T [diag(w * Hw) - W H W] G on the full Gauss rule, ``points`` per interval (default: a
    rule that resolves the kernel, about 2.5 points per width b across an interval's middle)."""
    points = points or int(np.ceil(2.5 * basis.h / b)) + 20
    x, w = basis.quadrature(points)
    g = basis.evaluate(x, 1)
    h = kernel(x, x, a, b)
    d = g.T @ (np.diag(w * (h @ w)) - w[:, None] * h * w[None, :]) @ g
    return 0.5 * (d + d.T)


@pytest.mark.parametrize("length, n, root, degree", [(1.0, 16, "clamped", 3), (0.73, 12, "pinned", 3),
                                                     (1.0, 2, "clamped", 3), (1.0, 3, "pinned", 3),
                                                     (1.0, 32, "clamped", 3), (1.0, 8, "clamped", 5),
                                                     (1.0, 16, "clamped", 5), (1.3, 5, "pinned", 5)])
@pytest.mark.parametrize("b", [0.0015, 0.01, 0.064362, 0.18, 1.0, 50.0])
def test_assembly_matches_the_dense_bracket_form_on_a_resolving_rule(length, n, root, degree, b):
    """The double integral two ways: the module's (exact Legendre moments of the normal density
    against the stored polynomials F_k(s)) and the plain Gauss rule on both variables with enough
    points per interval to resolve the kernel. Measured: at most 7e-14 of max |D| (the
    reference's own rule converges super-exponentially once its spacing is below b/3; with 100
    points per interval instead of 200 it errs by 5e-5 at N = 8, b = 1.5 mm); bound 1e-12. A
    kernel narrower than a fixed rule's spacing (b = 1.5 mm on the quintic N = 8, 48 points per
    interval) came out 31 % low: the case this guards."""
    basis = SplineBasis(length, n, root, degree=degree)
    ops = BeamOperators(basis, rho_a=1.0)
    for a in (1.0, 0.025):
        d = MECH.damping(ops, {"a": a, "b": b})
        ref = dense_bracket_form(basis, a, b)
        assert d.shape == (basis.size, basis.size)
        assert np.array_equal(d, d.T)
        assert np.abs(d - ref).max() <= 1e-12 * np.abs(ref).max()


@pytest.mark.parametrize("n, b", [(8, 0.003), (16, 0.002), (32, 0.01), (12, 0.02)])
def test_the_offsets_skipped_for_a_narrow_kernel_hold_nothing(monkeypatch, n, b):
    """A narrow kernel's far offsets (every value below exp(-UNDERFLOW) = 4e-18 of its peak) are
    left out: D equals the sum over every offset to 1e-14 of max |D| (the offsets left out add
    4e-18 of it at most), and some offsets were left out in each case."""
    from bayesbeam.physics.mechanisms import spatial_hysteresis as module

    basis = SplineBasis(1.3, n, degree=5)
    moments = module._moments(basis.n_intervals, basis.root, basis.degree)
    assert math.ceil(math.sqrt(2 * module.UNDERFLOW) * b / basis.h) < n
    skipped = moments.unit_matrix(b, basis.h)
    monkeypatch.setattr(module, "UNDERFLOW", 1e6)
    full = moments.unit_matrix(b, basis.h)
    assert np.abs(skipped - full).max() <= 1e-14 * np.abs(full).max()


def test_beams_of_any_length_share_the_grid_polynomials():
    """The stored polynomials are the unit grid's, scaled by 1/h: a free length (a parameter of
    the fit) costs no new precomputation, and D on a beam of length l equals the dense form on
    that beam (the assembly test's bound)."""
    from bayesbeam.physics.mechanisms import spatial_hysteresis as module

    module._moments.cache_clear()
    for length in (0.7093, 0.75, 0.8091):
        basis = SplineBasis(length, 16, degree=3)
        d = MECH.damping(BeamOperators(basis, rho_a=1.0), {"a": 0.3, "b": 0.05})
        ref = dense_bracket_form(basis, 0.3, 0.05)
        assert np.abs(d - ref).max() <= 1e-12 * np.abs(ref).max()
    assert module._moments.cache_info().misses == 1


def test_damping_is_linear_in_a_and_repeatable():
    """The cached (a, b)-independent part is not modified by a call."""
    ops = BeamOperators(SplineBasis(1.0, 16), rho_a=1.0)
    d1 = MECH.damping(ops, {"a": 1.0, "b": 0.18})
    MECH.damping(ops, {"a": 3.0, "b": 0.02})                 # another Gauss rule, same basis
    d2 = MECH.damping(ops, {"a": 0.025, "b": 0.18})
    assert np.allclose(d2, 0.025 * d1, rtol=1e-15, atol=0)
    assert np.array_equal(MECH.damping(ops, {"a": 1.0, "b": 0.18}), d1)


@pytest.mark.parametrize("b", [1e-300, 1e-140, 1e-9])
def test_a_vanishing_width_gives_the_kelvin_voigt_matrix(b):
    """For b far below every length of the grid, D = a b^2/2 K_0 (K_0: int B_i'' B_j'') up to the
    kernel's truncation within a few b of the ends, O(b) relative (1e-6 bounds it with room at
    b = 1e-9 m); b^2 underflows to 0 below 1e-162, and D must be exactly 0 there, not 0 * inf =
    nan."""
    ops = BeamOperators(SplineBasis(1.0, 16), rho_a=1.0)
    d = MECH.damping(ops, {"a": 1.0, "b": b})
    assert np.all(np.isfinite(d))
    if b * b == 0.0:
        assert not d.any()
    else:
        kv = 0.5 * b * b * ops.K0
        assert np.abs(d - kv).max() <= 1e-6 * np.abs(kv).max()


@pytest.mark.parametrize("b", [1e150, 1e200, 1e300, np.inf])
def test_an_unbounded_width_gives_the_flat_kernel(b):
    """For b far beyond l the kernel is the constant a/(b sqrt(2 pi)): D b is the same matrix for
    every such b (to round-off), and b = inf gives 0."""
    ops = BeamOperators(SplineBasis(1.0, 16), rho_a=1.0)
    d = MECH.damping(ops, {"a": 1.0, "b": b})
    assert np.all(np.isfinite(d))
    flat = MECH.damping(ops, {"a": 1.0, "b": 1e100}) * 1e100
    if np.isinf(b):
        assert not d.any()
    else:
        assert np.abs(d * b - flat).max() <= 1e-13 * np.abs(flat).max()
