"""quadratic_drag and dry_friction as effects: interface, force law, quadrature, registry.

Their dynamics (convergence, energy, exact stick-slip, linear limits) are tested with the
integrator in tests/response/test_nonlinear.py.
"""
import numpy as np
import pytest

from bayesbeam import BeamModel
from bayesbeam.physics.assembly import BeamOperators
from bayesbeam.physics.basis import SplineBasis
from bayesbeam.physics.effects import REGISTRY, resolve
from tests.physics.effects.helpers import PAPER_EI, recording

DRAG, FRICTION = REGISTRY["quadratic_drag"], REGISTRY["dry_friction"]


def test_catalogue_entries():
    assert (DRAG.parameters, DRAG.units) == (("c_q",), {"c_q": "N s^2/m^3"})
    assert (FRICTION.parameters, FRICTION.units) == (("F_c",), {"F_c": "N"})
    assert not DRAG.linear and not FRICTION.linear
    assert all(e.linear for e in resolve("root_compliance+sensor_mass+axial_load+measurement_delay"))
    model = BeamModel(recording(), "q1", 8, effects="quadratic_drag")
    assert model.parameter_names == ("EI", "gamma", "cdI", "c_q")
    # nonlinear effects add nothing to the linear system
    p = {"EI": PAPER_EI, "gamma": 0.1, "cdI": 1e-4}
    np.testing.assert_array_equal(model.system({**p, "c_q": 5.0}).K, BeamModel(recording(), "q1", 8).system(p).K)
    for effect, name in ((DRAG, "c_q"), (FRICTION, "F_c")):
        with pytest.raises(ValueError, match="not physical"):
            effect.check({name: -1.0})
        with pytest.raises(ValueError, match="not physical"):
            effect.check({name: np.nan})


def test_drag_force_matches_a_fine_quadrature():
    """f_i = -c_q int |u_t| u_t B_i dx with 4 Gauss points per interval, against 64 points.

    |u_t| u_t is a polynomial except where u_t changes sign (there it is C^1), so the 4-point
    rule is exact on intervals without a sign change and accurate to about 1e-4 of the largest
    entry elsewhere (measured 2.4e-6 on this velocity field with 3 sign changes); bound 2e-4.
    """
    ops = BeamOperators(SplineBasis(1.0, 12), rho_a=1.0)
    x = np.linspace(0, 1, 200)
    shape = np.sin(5.5 * x) * x**2                               # three sign changes
    w_dot = np.linalg.lstsq(ops.rows(x), shape, rcond=None)[0]    # a velocity field in the basis
    f = DRAG.force(ops, {"c_q": 2.0}, w_dot)
    xq, wq = ops.basis.quadrature(64)
    v = ops.rows(xq) @ w_dot
    fine = -2.0 * ((np.abs(v) * v * wq) @ ops.rows(xq))
    assert np.max(np.abs(f - fine)) < 2e-4 * np.max(np.abs(fine))


def test_drag_dissipates_and_scales_quadratically():
    """Power w_t . f = -c_q int |u_t|^3 dx < 0, and f(2 w_t) = 4 f(w_t), f(-w_t) = -f(w_t)."""
    ops = BeamOperators(SplineBasis(1.0, 8), rho_a=1.0)
    rng = np.random.default_rng(1)
    w_dot = rng.standard_normal(ops.size)
    f = DRAG.force(ops, {"c_q": 0.7}, w_dot)
    xq, wq = ops.basis.quadrature(4)
    v = ops.rows(xq) @ w_dot
    np.testing.assert_allclose(w_dot @ f, -0.7 * np.sum(wq * np.abs(v) ** 3), rtol=1e-12)
    assert w_dot @ f < 0
    np.testing.assert_allclose(DRAG.force(ops, {"c_q": 0.7}, 2 * w_dot), 4 * f, rtol=1e-12)
    np.testing.assert_allclose(DRAG.force(ops, {"c_q": 0.7}, -w_dot), -f, rtol=1e-12)


def test_friction_acts_at_the_tip():
    ops = BeamOperators(SplineBasis(1.0, 8), rho_a=1.0)
    np.testing.assert_array_equal(FRICTION.contact_row(ops), ops.tip_value)
    assert FRICTION.bound({"F_c": 0.3}) == 0.3
