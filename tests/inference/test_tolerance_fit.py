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
