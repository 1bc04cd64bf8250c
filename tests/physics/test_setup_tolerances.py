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
#: the sensor_mass effect's mass at each sensor (m_s_<name>): 20 g at the mid-span one
PARAMS = {**cases.TRUTH["q1"], "m_s_accel_mid": 0.02, "m_s_disp_tip": 0.0, "k_theta": 5e3, "F_c": 0.05}


def recording(location=X0, tolerance=None, kind="force"):
    """A cheap paper-beam recording (0.25 s at 512 Hz) with a mid-span accelerometer at
    ``location`` (its mass m_s_accel_mid is the sensor mass) and a tip displacement sensor."""
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
    """length_tolerance and location_tolerance = 0 (or none stated): the same parameter names and
    bit-identical output (the same code path: no offset, the model's own forms, rows and set-up)."""
    values = {**PARAMS, "gamma": 0.12, "a": 0.025, "b": 0.18}
    zeros = {"beam": {"length_tolerance": 0.0}, "sensor": [{"location_tolerance": 0.0}, {}]}
    plain, zero = BeamModel(recording(), spec, 8), BeamModel(replace(recording(), setup_keys=zeros), spec, 8)
    assert zero.parameter_names == plain.parameter_names
    assert not any(n.startswith("dx_") or n == "l" for n in zero.parameter_names)
    params = {n: values[n] for n in plain.parameter_names}
    assert np.array_equal(zero.simulate(params), plain.simulate(params))
    assert zero.placement(zero.values(params))[0] is zero.rows
    assert zero.operators(zero.values(params)) is zero.ops


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


# ---------------------------------------------------------------------------- the free length
STRETCH = 0.013
LENGTH_PARAMS = {**PARAMS, "alpha": 2.0, "beta": 200.0, "a": 0.025, "b": 0.18, "P": 3.0, "c_q": 0.5,
                 "m_s_mid": 0.02, "m_s_tip": 0.0}


def strip(length=cases.ALU_BEAM.length, tolerance=None, kind="force", shift=0.0, location_tolerance=None):
    """The aluminium strip with its 50 g tip block (0.25 s at 1024 Hz), a tip accelerometer and a
    mid-span displacement sensor at 0.3 m, struck at 0.375 m: each sensor and the hammer ``shift``
    further from the clamp, the beam ``length`` long."""
    sensors = (Sensor("mid", 0.3 + shift, "displacement", "mid"), Sensor("tip", length, "acceleration", "tip"))
    rec = cases.base_recording(fs=1024.0, duration=0.25, beam=replace(cases.ALU_BEAM, length=length),
                               sensors=sensors, tip=cases.ALU_TIP, pulse_width=0.001)
    rec = replace(rec, excitation=replace(rec.excitation, location=0.375 + shift))
    if kind == "release":
        rec = replace(rec, excitation=Excitation("release", tip_load=1.0), force=None)
    keys = {} if tolerance is None else {"beam": {"length_tolerance": tolerance}}
    if location_tolerance is not None:
        keys["sensor"] = [{"location_tolerance": location_tolerance}, {}]
    return replace(rec, setup_keys=keys)


def length_pair(spec, kind="force"):
    """(model fitting l, at l0 + STRETCH; model of the strip stated STRETCH longer with sensors and
    hammer kept at their distance from the free end; the shared parameters)."""
    l0 = cases.ALU_BEAM.length
    fitted = BeamModel(strip(tolerance=0.02, kind=kind), spec, 8)
    stretched = BeamModel(strip(length=l0 + STRETCH, kind=kind, shift=STRETCH), spec, 8)
    params = {"EI": cases.ALU_BEAM.nominal_EI, **{n: LENGTH_PARAMS[n] for n in stretched.parameter_names[1:]}}
    return fitted, stretched, params


@pytest.mark.parametrize("spec, kind", [
    ("q1", "force"), ("q1", "release"), ("q2", "force"), ("q3", "force"), ("q1+axial_load", "force"),
    ("q1+root_compliance+sensor_mass", "force"), ("q1+dry_friction", "force"), ("q1+quadratic_drag", "force"),
])
def test_a_fitted_length_is_the_beam_of_that_length(spec, kind):
    """simulate at l = l0 + 13 mm equals the model of the strip stated 13 mm longer, its sensors
    and hammer 13 mm further from the clamp (the same distance from the free end; the sensor's
    own mass at the moved mid-span sensor). Every mechanism and effect that reads the forms is
    here: M0 (air), K0 (strain rate, the memory of q2), G0 (axial load), the root's slope row
    (root spring), the basis's quadrature in x (the kernel of width b of q3, the drag's Gauss
    points), the tip row (friction, the release). The stretched forms are the stated ones
    scaled (M0 s, G0/s, K0/s^3), equal to forms integrated at the new length to 7e-16. The
    stretched model takes its undamped modes from (K0, M) once, the fitted one solves them on
    every call (its M and K change with l): two exact paths whose rounding the lightly damped
    resonances amplify (for one and the same model the two differ by 1.9e-9 of the tip's peak in
    the release). Hence 1e-7 of each channel's peak (observed at most 2.9e-9); what the test
    guards against is far larger: the hammer left where it was stated moves the response by
    percents, G0 unscaled moves the modes by 0.2 % (P is 8 % of the buckling load here)."""
    fitted, stretched, params = length_pair(spec, kind)
    l0 = cases.ALU_BEAM.length
    y_fit = fitted.simulate({**params, "l": l0 + STRETCH})
    y_stretched = stretched.simulate(params)
    scale = np.abs(y_stretched).max(axis=0)
    assert np.all(np.abs(y_fit - y_stretched).max(axis=0) <= 1e-7 * scale)
    # and the length matters: 13 mm lower the strip's modes by about 5 %
    assert np.abs(fitted.simulate({**params, "l": l0}) - y_stretched).max(axis=0)[1] > 0.05 * scale[1]


def test_length_and_offset_together_place_the_sensor_and_its_mass():
    """l and dx_mid both fitted, with the sensor's own mass at the mid-span sensor: the sensor
    sits at its stated 0.3 m + (l - l0) + dx. Against the strip stated that long with the sensor
    there, solving its modes on every call as the fitted model must (the mass moves with l and
    dx): the same forms to 7e-16, so 1e-7 of the peak as above (observed 5e-10)."""
    l0, dx = cases.ALU_BEAM.length, -0.004
    fitted = BeamModel(strip(tolerance=0.02, location_tolerance=0.01), "q1+sensor_mass", 8)
    stretched = strip(length=l0 + STRETCH, shift=STRETCH)
    mid, tip = stretched.sensors
    moved = BeamModel(replace(stretched, sensors=(replace(mid, location=0.3 + STRETCH + dx), tip)),
                      "q1+sensor_mass", 8)
    moved.__dict__["_departures"] = None
    params = {"EI": cases.ALU_BEAM.nominal_EI, "gamma": 0.18, "cdI": 2e-5, "m_s_mid": 0.02, "m_s_tip": 0.0}
    assert fitted.parameter_names == ("EI", "gamma", "cdI", "m_s_mid", "m_s_tip", "l", "dx_mid")
    y_fit = fitted.simulate({**params, "l": l0 + STRETCH, "dx_mid": dx})
    y_moved = moved.simulate(params)
    assert np.all(np.abs(y_fit - y_moved).max(axis=0) <= 1e-7 * np.abs(y_moved).max(axis=0))


@pytest.mark.parametrize("kind", ["force", "release"])
def test_batched_sets_place_the_beam_as_single_ones(kind):
    """The likelihood's batched path (several parameter sets, one inverse FFT) at two lengths:
    each set equals its own simulate; the same transfer functions, so 1e-10 of the peak, the
    batched path's own bound (observed 0)."""
    fitted, _, params = length_pair("q1", kind)
    sets = [{**params, "l": length} for length in (cases.ALU_BEAM.length + STRETCH, cases.ALU_BEAM.length)]
    batch = fitted.simulate_batch(sets)
    for k, values in enumerate(sets):
        single = fitted.simulate(values)
        assert np.abs(batch[:, k] - single).max() <= 1e-10 * np.abs(single).max()


def test_the_stretched_beams_frequencies_are_the_analytic_cantilevers():
    """The undamped strip with its tip block at l = l0 + 13 mm (quintic splines, N = 16): the
    first three natural frequencies against the roots of the clamped-free-with-tip-body
    characteristic equation at that length (bayesbeam.modal.eigen). The Galerkin frequencies lie
    above the exact ones by the discretisation error (observed 6e-13, 8e-12, 7e-10 for modes
    1-3): 1e-8 holds with a margin of 14 and fails for a length off by 3e-9 m (a frequency moves
    by 2 dl / l)."""
    from bayesbeam.modal.eigen import natural_frequencies_hz

    l0, beam, tip = cases.ALU_BEAM.length, cases.ALU_BEAM, cases.ALU_TIP
    model = BeamModel(strip(tolerance=0.02), "air", 16, degree=5)
    length = l0 + STRETCH
    exact = natural_frequencies_hz(3, EI=beam.nominal_EI, rho_a=beam.rho_a, length=length, m_T=tip.mass,
                                   J=tip.rotary_inertia)
    galerkin = model.natural_frequencies({"EI": beam.nominal_EI, "gamma": 0.0, "l": length}, 3)
    assert np.all(np.abs(galerkin / exact - 1) <= 1e-8)


def test_a_length_that_moves_a_sensor_off_the_beam_is_refused():
    """A sensor stated 5 mm from the clamp keeps its distance from the free end: 10 mm shorter,
    it would sit before the clamp."""
    rec = strip(tolerance=0.02)
    rec = replace(rec, sensors=(replace(rec.sensors[0], location=0.005), rec.sensors[1]))
    model = BeamModel(rec, "q1", 8)
    params = {"EI": 3.9, "gamma": 0.18, "cdI": 2e-5}
    model.values({**params, "l": 0.5})
    with pytest.raises(ValueError, match="l = 0.49 m put sensor 'mid'.*off the beam"):
        model.values({**params, "l": 0.49})
