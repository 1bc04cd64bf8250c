"""A sensor position stated with a tolerance is a parameter of every model: ``dx_<s>``, the
sensor's offset from its stated location (bayesbeam.model, docs/format.md).

The checks here compare a model whose sensor sits at x0 + dx (the offset fitted) with a model
built from a recording that states the sensor at x0 + dx (no offset): the two evaluate the same
splines at the same point (x0 + dx is formed identically), so they agree to round-off through
every path that uses the sensor: the transfer function, a release's static offset, the
force-sample columns, the free-decay basis, the nonlinear integrator and the sensor's own mass.
"""
from dataclasses import replace

import numpy as np
import pytest

from bayesbeam.io import Excitation, Sensor
from bayesbeam.model import BeamModel
from bayesbeam.physics.assembly import POINT_MATRICES_KEPT, BeamOperators
from bayesbeam.physics.basis import SplineBasis
from tests.inference import cases

X0, TOLERANCE, OFFSET = 0.62, 0.03, 0.021
MID = Sensor("accel_mid", X0, "acceleration", "accel_mid")
TIP = Sensor("disp_tip", 1.0, "displacement", "disp_tip")
PARAMS = {**cases.TRUTH["q1"], "m_s": 0.02, "k_theta": 5e3, "F_c": 0.05}


def recording(location=X0, tolerance=None, kind="force"):
    """A cheap paper-beam recording (0.25 s at 512 Hz) with a mid-span accelerometer at
    ``location`` (listed first: the sensor mass sits there) and a tip displacement sensor."""
    rec = cases.base_recording(fs=512.0, duration=0.25, sensors=(replace(MID, location=location), TIP))
    if kind == "release":
        rec = replace(rec, excitation=Excitation("release", tip_load=1.0), force=None)
    elif kind == "free_decay":
        rec = replace(rec, excitation=Excitation("free_decay", start=0.05), force=None)
    keys = {} if tolerance is None else {"sensor": [{"location_tolerance": tolerance}, {}]}
    return replace(rec, setup_keys=keys)


def pair(spec, kind="force"):
    """(model with dx_accel_mid fitted, at OFFSET; model of the recording that states the sensor
    at X0 + OFFSET; the fitted model's parameters).

    The moved model solves its eigenproblems in full, as the fitted one must when the sensor's
    mass moves with the sensor (its departure from the bare beam then changes with dx); with a
    fixed sensor it would correct cached modes by a rank-r term instead, an exact form of the same
    system that differs by the rounding a resonance amplifies (observed 2.5e-10 of the peak here),
    which is the low-rank form's own test's business, not this one's."""
    fitted = BeamModel(recording(tolerance=TOLERANCE, kind=kind), spec, 8)
    moved = BeamModel(recording(location=X0 + OFFSET, kind=kind), spec, 8)
    moved.__dict__["_departures"] = None
    params = {n: PARAMS[n] for n in moved.parameter_names}
    return fitted, moved, params


@pytest.mark.parametrize("spec", ["q1", "q1+sensor_mass", "q3+root_compliance+sensor_mass"])
def test_a_zero_or_absent_tolerance_changes_nothing(spec):
    """location_tolerance = 0 (or none stated): the same parameter names and bit-identical output
    (the same code path: no offset, the model's own rows and set-up)."""
    values = {**PARAMS, "gamma": 0.12, "a": 0.025, "b": 0.18}
    plain, zero = (BeamModel(recording(tolerance=t), spec, 8) for t in (None, 0.0))
    assert zero.parameter_names == plain.parameter_names
    assert not any(n.startswith("dx_") for n in zero.parameter_names)
    params = {n: values[n] for n in plain.parameter_names}
    assert np.array_equal(zero.simulate(params), plain.simulate(params))
    assert zero.placement(zero.values(params))[0] is zero.rows


def test_a_stated_tolerance_adds_the_sensors_offset_in_metres():
    fitted, moved, _ = pair("q1")
    assert fitted.parameter_names == moved.parameter_names + ("dx_accel_mid",)
    assert fitted.units["dx_accel_mid"] == "m"


@pytest.mark.parametrize("spec, kind", [("q1", "force"), ("q1", "release"), ("q1+sensor_mass", "force"),
                                        ("q1+root_compliance+sensor_mass", "release")])
def test_a_sensor_offset_is_the_sensor_moved(spec, kind):
    """simulate at dx = 21 mm equals the model of the recording that states the sensor 21 mm
    further out (with the sensor's own mass there too): the same rows, matrices and solver, so
    round-off alone, 1e-12 of each channel's largest response (observed 0)."""
    fitted, moved, params = pair(spec, kind)
    y_fit, y_moved = fitted.simulate({**params, "dx_accel_mid": OFFSET}), moved.simulate(params)
    scale = np.abs(y_moved).max(axis=0)
    assert np.all(np.abs(y_fit - y_moved).max(axis=0) <= 1e-12 * scale)
    # and the offset matters: 21 mm moves the mid-span channel by far more than the tolerance
    y_stated = fitted.simulate({**params, "dx_accel_mid": 0.0})
    assert np.abs(y_stated - y_moved)[:, 0].max() > 1e-3 * scale[0]


def test_force_sample_columns_and_free_decay_basis_follow_the_sensor():
    """The likelihood's force-noise columns and a free decay's modal basis: same rows, same
    solver, so agreement to round-off (1e-12 of the largest entry; observed 0)."""
    fitted, moved, params = pair("q1")
    index = np.arange(10, 20)
    for a, b in zip(fitted.simulate_with_impulses({**params, "dx_accel_mid": OFFSET}, index),
                    moved.simulate_with_impulses(params, index)):
        assert np.abs(a - b).max() <= 1e-12 * np.abs(b).max()
    fitted, moved, params = pair("q1", "free_decay")
    a = fitted.free_decay_basis({**params, "dx_accel_mid": OFFSET})
    b = moved.free_decay_basis(params)
    assert np.abs(a - b).max() <= 1e-12 * np.abs(b).max()


def test_the_nonlinear_integrator_reads_the_moved_sensor():
    """Dry friction at the tip (a nonlinear effect): the integrator's output stage uses the
    sensors' rows at the fitted position; one integrator, same inputs: 1e-12 of the peak
    (observed 0)."""
    fitted, moved, params = pair("q1+dry_friction")
    y_fit, y_moved = fitted.simulate({**params, "dx_accel_mid": OFFSET}), moved.simulate(params)
    assert np.abs(y_fit - y_moved).max() <= 1e-12 * np.abs(y_moved).max()


def test_an_offset_off_the_beam_is_refused():
    """The sensor must stay on [0, l]: the mid-span sensor at 0.62 m cannot move out by 0.5 m."""
    fitted, _, params = pair("q1")
    with pytest.raises(ValueError, match="dx_accel_mid.*off the beam"):
        fitted.values({**params, "dx_accel_mid": 0.5})


def test_point_matrices_are_kept_for_the_latest_points_only():
    """A fitted sensor position asks for a new point matrix on every call: the cache keeps the
    last POINT_MATRICES_KEPT points, and a kept one is the matrix r r^T of its point."""
    ops = BeamOperators(SplineBasis(1.0, 8), rho_a=1.0)
    xs = np.linspace(0.1, 0.9, 3 * POINT_MATRICES_KEPT)
    for x in xs:
        ops.point_matrix(float(x))
    assert len(ops._point_matrices) == POINT_MATRICES_KEPT
    r = ops.rows([xs[-1]])[0]
    assert np.array_equal(ops.point_matrix(float(xs[-1])), np.outer(r, r))
