"""Priors that know the beam and its stated set-up (bayesbeam.inference.priors, docs/inference.md).

The scales are computed here from the beam's numbers, not read from the module: the cantilever's
buckling load pi^2 EI / (4 l^2), checked against the Galerkin forms' own buckling eigenvalue; the
root-spring scale EI/l; the beam's mass rho A l. The stated sensor mass reaches the prior through
the fit's own preparation (``prepare``), as a fit of a recording with that beam.toml builds it.
"""
from dataclasses import replace

import numpy as np
import pytest
from scipy.linalg import eigh

from bayesbeam.inference.fit import FitConfig, prepare
from bayesbeam.inference.priors import default_priors
from bayesbeam.io import RecordingError, Sensor
from bayesbeam.physics.assembly import BeamOperators
from bayesbeam.physics.basis import SplineBasis
from tests.inference import cases

#: the tip accelerometer of the issue's real record: 6 g, stated on the first (tip) sensor
STATED_MASS = 0.006


def recording(setup_keys=None, beam=cases.PAPER_BEAM, sensors=None):
    """A cheap force recording (paper beam, 0.5 s at 512 Hz) with the given set-up keys; its
    signals are seeded noise (a prior's noise scale needs a channel RMS, the fit is not run)."""
    rec = cases.base_recording(fs=512.0, duration=0.5, beam=beam, sensors=sensors)
    noise = np.random.default_rng(1).standard_normal(rec.signals.shape)
    return replace(rec.with_signals(noise), setup_keys=setup_keys or {})


def m_s_prior(rec, name="m_s"):
    """The prior of the sensor mass ``name`` as ``prepare`` builds it for a fit of q1 + sensor_mass."""
    post = prepare(rec, "q1+sensor_mass", FitConfig(), n_intervals=6).posterior
    return dict(zip(post.names, post.priors))[name]


def test_a_stated_sensor_mass_centres_the_fits_m_s_prior():
    """mass = 0.006 on the tip sensor: m_s is log-normal with median 6 g (exact: it is the stated
    number) and sd(log) 0.3, the documented width; its prior median in kg is 6 g to rounding."""
    prior = m_s_prior(recording({"sensor": [{"mass": STATED_MASS}]}))
    assert (prior.kind, prior.a, prior.b) == ("lognormal", STATED_MASS, 0.3)
    assert float(prior.to_value(prior.median())) == pytest.approx(STATED_MASS, rel=1e-12)


def test_without_a_stated_mass_m_s_scales_with_the_beams_mass():
    """No mass stated, a stated mass of 0 (a non-contact sensor: no lognormal can centre on it),
    or a mass stated only on another sensor: log-uniform over
    [1e-4, 0.2] x rho A l, the beam's mass computed here (1710 x 0.597e-3 x 1 kg)."""
    rho_a_l = 1710.0 * 0.597e-3 * 1.0
    second = Sensor("mid", 0.5, "acceleration", "accel_mid")
    tip = Sensor("accel_tip", 1.0, "acceleration", "accel_tip")
    for rec, name in ((recording(), "m_s"), (recording({"sensor": [{"mass": 0.0}]}), "m_s"),
                      (recording({"sensor": [{}, {"mass": STATED_MASS}]}, sensors=(tip, second)), "m_s_accel_tip")):
        prior = m_s_prior(rec, name)
        assert prior.kind == "loguniform"
        assert (prior.a, prior.b) == pytest.approx((1e-4 * rho_a_l, 0.2 * rho_a_l), rel=1e-12)


def buckling_load(beam, n_intervals=16) -> float:
    """The Galerkin cantilever's buckling load: the least P with EI K0 - P G0 singular."""
    ops = BeamOperators(SplineBasis(beam.length, n_intervals), rho_a=beam.rho_a)
    return float(eigh(beam.nominal_EI * ops.K0, ops.G0, eigvals_only=True)[0])


@pytest.mark.parametrize("beam", [cases.PAPER_BEAM, cases.ALU_BEAM], ids=["paper", "alu"])
def test_the_axial_load_prior_is_a_fraction_of_the_buckling_load(beam):
    """P is uniform over [-0.5, 10] x P_cr, P_cr = pi^2 EI / (4 l^2) from the beam's E, I and l.
    That formula is the model's own buckling load: the cubic Galerkin forms' least buckling
    eigenvalue lies above it by 3.4e-5, 2.1e-6 and 1.3e-7 at N = 4, 8, 16 (h^4 convergence), so
    the bound 1e-6 at N = 16 holds with a margin of 8 and refuses any other end condition's load
    (pi^2 EI / l^2, pinned, is 4 times it)."""
    p_cr = np.pi**2 * beam.modulus * beam.second_moment / (4 * beam.length**2)
    assert buckling_load(beam) == pytest.approx(p_cr, rel=1e-6)
    rec = recording(beam=beam, sensors=(Sensor("accel_tip", beam.length, "acceleration", "accel_tip"),))
    prior = default_priors(rec.beam, ("P",), {}, rec.setup)["P"]
    assert prior.kind == "uniform" and (prior.a, prior.b) == pytest.approx((-0.5 * p_cr, 10 * p_cr), rel=1e-12)


@pytest.mark.parametrize("beam", [cases.PAPER_BEAM, cases.ALU_BEAM], ids=["paper", "alu"])
def test_the_root_spring_prior_is_relative_to_EI_over_l(beam):
    """k_theta is log-uniform over [1, 1e5] x EI/l, from the beam's E, I and l."""
    scale = beam.modulus * beam.second_moment / beam.length
    prior = default_priors(beam, ("k_theta",), {})["k_theta"]
    assert prior.kind == "loguniform" and (prior.a, prior.b) == pytest.approx((scale, 1e5 * scale), rel=1e-12)


def test_a_fit_refuses_a_bad_stated_value_before_anything_is_fitted():
    """A negative sensor mass is carried along at load (FORMAT.md) but stops the fit's
    preparation, naming the key."""
    with pytest.raises(RecordingError, match=r"\[\[sensor\]\] #1 \.mass.*negative.*Fix:"):
        m_s_prior(recording({"sensor": [{"mass": -STATED_MASS}]}))


def test_each_sensors_mass_has_its_own_prior_whatever_the_order():
    """Two sensors, a mass stated on the mid-span one only: m_s_mid is log-normal about it (sd(log)
    0.3), m_s_accel_tip log-uniform over [1e-4, 0.2] rho A l; the same with the tables swapped."""
    rho_a_l = 1710.0 * 0.597e-3 * 1.0
    tip = Sensor("accel_tip", 1.0, "acceleration", "accel_tip")
    mid = Sensor("mid", 0.5, "acceleration", "accel_mid")
    for sensors, keys in (((tip, mid), [{}, {"mass": STATED_MASS}]), ((mid, tip), [{"mass": STATED_MASS}, {}])):
        rec = recording({"sensor": keys}, sensors=sensors)
        stated, free = m_s_prior(rec, "m_s_mid"), m_s_prior(rec, "m_s_accel_tip")
        assert (stated.kind, stated.a, stated.b) == ("lognormal", STATED_MASS, 0.3)
        assert free.kind == "loguniform"
        assert (free.a, free.b) == pytest.approx((1e-4 * rho_a_l, 0.2 * rho_a_l), rel=1e-12)


@pytest.mark.parametrize(("location", "bounds"), [(0.75, (-0.01, 0.01)), (0.995, (-0.01, 0.005))])
def test_the_hammers_offset_is_uniform_over_its_tolerance_cut_to_the_beam(location, bounds):
    """[excitation] location_tolerance = 10 mm: dx_hammer uniform over [-10, 10] mm, cut at the
    free end for a hammer stated 5 mm from it (the paper beam is 1 m long)."""
    rec = recording({"excitation": {"location_tolerance": 0.01}})
    rec = replace(rec, excitation=replace(rec.excitation, location=location))
    post = prepare(rec, "q1", FitConfig(), n_intervals=6).posterior
    assert post.names[: len(post.model_names)][-1] == "dx_hammer"
    prior = dict(zip(post.names, post.priors))["dx_hammer"]
    assert prior.kind == "uniform" and (prior.a, prior.b) == pytest.approx(bounds, rel=1e-12)
