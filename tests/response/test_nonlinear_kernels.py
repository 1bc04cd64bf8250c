"""The compiled loops of the nonlinear integrator (bayesbeam.response._kernels) and what they solve.

Each kernel is checked against an independent statement of what it computes (a closed-form sum,
scipy's brentq, the defining equation of the implicit drag step); the whole integrator is checked
against independent solutions in tests/response/test_nonlinear.py.
"""
import numpy as np
import pytest
from scipy import optimize, special

from bayesbeam import BeamModel
from bayesbeam.response import _kernels
from bayesbeam.response import nonlinear as nl
from tests.physics.effects.helpers import PAPER_EI
from tests.response.test_nonlinear import ALU_EI, alu_release, hammer


def test_drag_states_equal_the_closed_form_sum():
    """z_{i+1} = E z_i + w_i from z_0 has the closed form E^{i+1} z_0 + sum_{l<=i} E^{i-l} w_l,
    w_l the cubic (and, on the last step, quadratic) combination of the modal forces. Summed
    directly with numpy powers; agreement to 1e-13 of the largest state (rounding of at most 12
    products of factors |E| <= 1)."""
    rng = np.random.default_rng(3)
    S, m = 12, 7
    E = np.exp(complex(-0.05, 0.0) * rng.random(m) + 1j * rng.random(m))
    z0, u = rng.normal(size=m) + 1j * rng.normal(size=m), rng.normal(size=(S + 2, m)) + 1j * rng.normal(size=(S + 2, m))
    cubic, quad = rng.normal(size=(4, m)) + 0j, rng.normal(size=(3, m)) + 0j
    w = [sum(cubic[j] * u[i + j] for j in range(4)) for i in range(S - 1)]
    w.append(sum(quad[j] * u[S - 1 + j] for j in range(3)))
    expected = np.array([E ** (i + 1) * z0 + sum(E ** (i - l) * w[l] for l in range(i + 1)) for i in range(S)])
    out = np.empty((S, m), dtype=complex)
    _kernels.drag_states(z0, u, cubic, quad, E, out)
    assert np.max(np.abs(out - expected)) < 1e-13 * np.max(np.abs(expected))


def test_intra_step_root_agrees_with_brentq():
    """The event root of sign (Re sum amp e^{mu (theta - a)} + const + poly(theta)) against brentq
    on the same function written in numpy, to 1e-9 in theta (the kernel's tolerance), and the
    kernel's derivative against a central difference (1e-6 relative: the difference's O(h^2)
    truncation at h = 1e-5)."""
    rng = np.random.default_rng(5)
    mu = -0.02 * rng.random(9) + 1j * 2.0 * rng.random(9)
    amp = rng.normal(size=9) + 1j * rng.normal(size=9)
    poly = np.array([0.3, -0.2, 0.1, 0.05, -0.01, 0.002])
    a, sign = 0.1, -1.0

    def f(theta):
        return sign * ((np.exp(mu * (theta - a)) @ amp).real + 0.4 + np.polyval(poly[::-1], theta))
    grid = np.linspace(a, 1.0, 200)
    values = np.array([f(t) for t in grid])
    i = int(np.flatnonzero(np.sign(values[:-1]) != np.sign(values[1:]))[0])
    lo, hi = grid[i], grid[i + 1]
    assert values[i] > 0 > values[i + 1]          # the first crossing is downward (seed 5)
    args = (mu, amp, amp * mu, 0.4, poly, a, sign)
    root = _kernels.intra_step_root(*args, lo, hi, values[i], values[i + 1], 1e-9)
    assert abs(root - optimize.brentq(f, lo, hi, xtol=1e-14)) < 1e-9
    v, d = _kernels.intra_step(*args, 0.5)
    assert v == pytest.approx(f(0.5), rel=1e-13)
    assert d == pytest.approx((f(0.5 + 1e-5) - f(0.5 - 1e-5)) / 2e-5, rel=1e-6)


@pytest.mark.parametrize("c_q, newton", [(5.0, False), (1e5, True)])
def test_drag_nodes_satisfy_the_implicit_equation(c_q, newton):
    """At every node the drag force is the law at the velocity it produces: g = -c_q |v| v at
    the Gauss points, to DRAG_RTOL of the largest force (the fixed-point sweep stops when a sweep
    changes g by less; Newton's method stops on a step that small, after which its residual is
    far smaller). c_q = 1e5 on the aluminium strip is too stiff for the sweeps: it runs the
    one-node Newton fallback, asserted to have been used."""
    rec = alu_release(duration=0.02)
    model = BeamModel(rec, "air", 4, effects="quadratic_drag")
    calls = []
    original = nl._Drag._newton

    def counted(self, *args):
        calls.append(1)
        return original(self, *args)
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(nl._Drag, "_newton", counted)
        sol = nl.integrate(model, {"EI": ALU_EI, "gamma": 0.0, "c_q": c_q}, record=True)
    v, g = sol.record["v_gauss"], sol.record["g_gauss"]
    assert bool(calls) == newton
    assert np.max(np.abs(g - (-c_q * np.abs(v) * v))) <= 1.01 * nl.DRAG_RTOL * np.max(np.abs(g))


def test_reads_of_the_held_response_equal_its_inverse_fft():
    """The held-minus-free forced response and its rate at 23 nodes across the integration, read
    from the dt/2 table by the 32-tap windowed sinc (Plant.coarse, _kernels.kaiser_read;
    documented error ~1e-8 of the peak, measured 2.4e-8: bound 1e-7) and summed over the bins
    (_kernels.spectrum_read; rounding amplified by the window's e^{sigma t}, measured 2.5e-11:
    bound 1e-9), against the zero-padded inverse FFT at the nodes (Plant.fine), relative to each
    channel's peak."""
    model = BeamModel(hammer(), "q1", 8, effects="dry_friction")
    made = []

    class Kept(nl._Friction):
        def __init__(self, *args):
            super().__init__(*args)
            made.append(self)
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(nl, "_Friction", Kept)
        nl.integrate(model, {"EI": PAPER_EI, "gamma": 0.2, "cdI": 1e-4, "F_c": 0.05})
    friction = made[0]
    plant = friction.p
    (spectrum, s, table), timing = friction._diff()
    at_nodes = plant.fine(np.hstack([spectrum, plant.s_in[:, None] * spectrum]))
    nodes = np.linspace(0, plant.n_nodes - 1, 23).astype(int)
    peak = np.max(np.abs(at_nodes), axis=0)
    tabulated = np.array([_kernels.kaiser_read(table, timing[3], timing[4], plant.tau[k]) for k in nodes])
    summed = np.array([_kernels.spectrum_read(spectrum, s, timing[5], plant.tau[k]) for k in nodes])
    assert np.max(np.abs(tabulated - at_nodes[nodes]) / peak) < 1e-7
    assert np.max(np.abs(summed - at_nodes[nodes]) / peak) < 1e-9


def test_bessel_i0_equals_scipy():
    """The Kaiser window's I0 (power series) against scipy.special.i0 on [0, 16], the window's
    whole range: 1e-14 relative (a few roundings per term of a positive series)."""
    x = np.linspace(0.0, 16.0, 97)
    ours = np.array([_kernels.bessel_i0(v) for v in x])
    np.testing.assert_allclose(ours, special.i0(x), rtol=1e-14, atol=0)


def test_step_interpolants_and_moments_are_exact_for_polynomials():
    """The 6-point Lagrange row and the per-step polynomial reproduce a quintic exactly, and the
    accumulated mean and 12 x first moment of a force linear on [a, b] equal their integrals
    (numpy's polynomial integration): all to 1e-12 relative (rounding)."""
    nodes = np.arange(10.0)
    quintic = np.polynomial.Polynomial([0.3, -1.0, 0.5, 0.2, -0.05, 0.01])
    table = np.stack([quintic(nodes), 2.0 * quintic(nodes)], axis=1)
    for k, theta in ((0, 0.3), (4, 0.7), (8, 0.25)):
        expected = quintic(k + theta)
        assert np.allclose(_kernels.lagrange_row(table, k, theta, nl._LAGRANGE), [expected, 2 * expected],
                           rtol=1e-12, atol=0)
        coef = _kernels.step_poly(table[:, 0], k, nl._SHIFTED)
        assert np.polynomial.Polynomial(coef)(theta) == pytest.approx(expected, rel=1e-12)
    c0, c1 = np.zeros(1), np.zeros(1)
    a, b, g_a, g_b = 0.2, 0.9, 1.5, -0.5
    force = np.polynomial.Polynomial.fit([a, b], [g_a, g_b], 1).convert()
    _kernels.accumulate(c0, c1, 0, a, b, g_a, g_b)
    mean = force.integ()
    moment = (12.0 * force * np.polynomial.Polynomial([-0.5, 1.0])).integ()
    assert c0[0] == pytest.approx(mean(b) - mean(a), rel=1e-12)
    assert c1[0] == pytest.approx(moment(b) - moment(a), rel=1e-12)
