"""A sensor position stated with a tolerance: its prior, and its recovery by a fit on a recording
made by the independent reference simulator (tests.reference: Hermite finite elements, exact
stepping, its own DAQ; nothing of bayesbeam.physics or bayesbeam.response).
"""
from dataclasses import replace

import numpy as np
import pytest

from bayesbeam.inference.fit import FitConfig, prepare
from bayesbeam.inference.sampler import find_optimum
from bayesbeam.io import Sensor
from tests.acceptance import cases as acceptance
from tests.inference import cases
from tests.reference import record
from tests.reference.recordings import NOISE

TOLERANCE = 0.04


def priors_of(rec, spec="q1"):
    """The priors a fit of ``rec`` under ``spec`` builds (``prepare``, as the fit does), by name."""
    post = prepare(rec, spec, FitConfig(), n_intervals=6).posterior
    return dict(zip(post.names, post.priors))


def test_the_set_up_priors_are_uniform_over_the_tolerances():
    """The free length of the paper beam (1 m +- 5 mm): l uniform over [0.995, 1.005] m. A
    mid-span sensor at 0.6 m: dx uniform over [-t, t]; a tip sensor at l = 1 m: over [-t, 0] (it
    cannot sit beyond the free end). Inside the support the density is 1/width, a step past
    either end it is -inf; bounds to rounding (they are the stated numbers)."""
    mid = Sensor("accel_mid", 0.6, "acceleration", "accel_mid")
    tip = Sensor("accel_tip", 1.0, "acceleration", "accel_tip")
    rec = cases.base_recording(fs=512.0, duration=0.5, sensors=(mid, tip))
    rec = replace(rec.with_signals(np.random.default_rng(1).standard_normal(rec.signals.shape)),
                  setup_keys={"beam": {"length_tolerance": 0.005},
                              "sensor": [{"location_tolerance": TOLERANCE}, {"location_tolerance": TOLERANCE}]})
    priors = priors_of(rec)
    expected = {"l": (0.995, 1.005), "dx_accel_mid": (-TOLERANCE, TOLERANCE), "dx_accel_tip": (-TOLERANCE, 0.0)}
    assert list(priors)[3:6] == list(expected)          # after EI, gamma, cdI; before the noise
    for name, (low, high) in expected.items():
        prior = priors[name]
        assert prior.kind == "uniform" and (prior.a, prior.b) == pytest.approx((low, high), rel=1e-15)
        assert prior.log_density(0.5 * (low + high)) == pytest.approx(-np.log(high - low), rel=1e-12)
        assert prior.log_density(low - 1e-6) == -np.inf and prior.log_density(high + 1e-6) == -np.inf


@pytest.mark.slow
def test_a_fit_recovers_a_shifted_sensor_within_its_tolerance():
    """The reference simulator's paper beam (q1, hammer at 0.75 m, 2 % sensor and 0.5 % force
    noise) with its accelerometer truly at 0.62 m; beam.toml states 0.60 m +- 0.04 m, so the true
    offset is +20 mm. The fit's optimum (global search, Laplace covariance; quintic N = 8, which
    the acceptance fits accept for this beam) puts the truth inside its 99 % interval
    (+-2.58 sd: one fixed noise draw, so a correct posterior fails 1 % of seeds) and narrows the
    prior's sd (0.04 x 2 / sqrt 12 = 23 mm) at least tenfold: the data locate the sensor, the
    prior does not. Observed: dx = 20.95 +- 0.95 mm, EI 44.280 (true 44.28 N m^2), 8 s."""
    truth, stated = 0.62, 0.60
    setting = acceptance._setting("paper")
    sensor = Sensor("accel_mid", truth, "acceleration", "accel_mid")
    rec = record(acceptance._nominal(setting["beam"]), acceptance.DAMPING["paper"]["q1"],
                 EI=setting["beam"].nominal_EI, excitation=setting["excitation"], fs=setting["fs"],
                 duration=1.0, sensors=(sensor,), noise=NOISE, seed=3)
    rec = replace(rec, sensors=(replace(sensor, location=stated),),
                  setup_keys={"sensor": [{"location_tolerance": TOLERANCE}]})
    post = prepare(rec, "q1", FitConfig(degree=5, n_intervals=8), 8).posterior
    assert "dx_accel_mid" in post.model_names
    optimum = find_optimum(post, np.random.default_rng(1))
    i = post.names.index("dx_accel_mid")
    dx, sd = post.values(optimum.theta)["dx_accel_mid"], float(np.sqrt(optimum.covariance[i, i]))
    assert abs(dx - (truth - stated)) <= 2.58 * sd
    assert sd <= 0.1 * 2 * TOLERANCE / np.sqrt(12)


def test_an_optimum_against_the_tip_keeps_its_laplace_covariance_and_refinement_check():
    """A tip sensor's offset is uniform over [-t, 0]: a sensor truly at the tip puts the optimum on
    the prior's edge, where central differences step out of the support. The Laplace covariance
    is then taken three steps (3e-4 m) inside: its Hessian's block of the other parameters is the
    Hessian of the model whose beam.toml states the sensor 3e-4 m inside, without the offset (the
    same physics at the same point: 1e-10 of the diagonal scale, observed 4e-14). The refinement
    check's Newton step holds the offset on the edge (shift 0) and moves the others by the step
    with the conditional covariance, which is that same model's inverse Hessian: equal to the
    Newton step of the model without the offset (its gradient at dx = 0 is that model's, bit for
    bit) with that covariance, to 1e-8 relative (observed 6e-14). Reference q1 recording, true
    parameters and noise sd; quintic N = 8 against 12."""
    from bayesbeam.inference.sampler import laplace_covariance, newton_shift

    rec, truth = acceptance.hammer("q1")
    sd, _ = acceptance.true_noise_sd("q1")
    config = FitConfig(degree=5, n_intervals=8)
    values = {**truth, "dx_accel_tip": 0.0, "sigma_accel_tip": sd}

    def posteriors(recording):
        coarse, finer = (prepare(recording, "q1", config, n).posterior for n in (8, 12))
        return coarse, finer, coarse.coordinates({n: values[n] for n in coarse.names})

    post, finer, theta = posteriors(replace(rec, setup_keys={"sensor": [{"location_tolerance": TOLERANCE}]}))
    inside = replace(rec, sensors=(replace(rec.sensors[0], location=rec.sensors[0].location - 3e-4),))
    plain, _, plain_theta = posteriors(inside)
    _, stated_finer, _ = posteriors(rec)
    i = post.names.index("dx_accel_tip")
    free = [k for k in range(post.ndim) if k != i]

    covariance = laplace_covariance(post, theta)
    hessian = -np.linalg.inv(covariance)[np.ix_(free, free)]
    plain_hessian = -np.linalg.inv(laplace_covariance(plain, plain_theta))
    scale = np.sqrt(np.outer(np.diag(plain_hessian), np.diag(plain_hessian)))
    assert np.all(np.abs(hessian - plain_hessian) <= 1e-10 * scale)
    assert 0 < np.sqrt(covariance[i, i]) < TOLERANCE

    shift = newton_shift(finer, theta, covariance)
    plain_shift = newton_shift(stated_finer, theta[free], np.linalg.inv(-hessian))
    assert shift[i] == 0.0
    np.testing.assert_allclose(shift[free], plain_shift, rtol=1e-8)
