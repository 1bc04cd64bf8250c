"""What a fit refuses, before any expensive work: each a ValueError that says what and how to fix.
"""
from dataclasses import replace

import numpy as np
import pytest

from bayesbeam.inference import FitConfig, fit
from bayesbeam.inference.fit import prepare
from bayesbeam.inference.priors import Prior

CONFIG = {"n_intervals": 6, "max_steps": 10, "walkers": 8}


def test_unknown_model_name(air_case):
    rec, _ = air_case
    with pytest.raises(ValueError, match=r"unknown damping mechanism\(s\) \['q7'\].*presets: \['q1', 'q2', 'q3'\]"):
        fit(rec, "q7", FitConfig(**CONFIG))
    with pytest.raises(ValueError, match=r"unknown damping mechanism\(s\) \['viscous'\].*'air'"):
        fit(rec, "air+viscous", FitConfig(**CONFIG))


def test_unknown_effect_name(air_case):
    rec, _ = air_case
    with pytest.raises(ValueError, match=r"unknown effect\(s\) \['root_spring'\]; known effects:.*'root_compliance'"):
        fit(rec, "air", FitConfig(**CONFIG, effects=("root_spring",)))


def test_prior_for_a_parameter_the_model_does_not_have(air_case):
    """The message names the parameter, the model and the parameters it does have."""
    rec, _ = air_case
    config = FitConfig(**CONFIG, priors={"cdI": Prior("loguniform", 1e-8, 1e-2)})
    with pytest.raises(ValueError, match=r"prior given for \['cdI'\], which model air does not have; "
                                         r"its parameters: \['EI', 'gamma', 'sigma_accel_tip'\]"):
        fit(rec, "air", config)


@pytest.mark.parametrize("kind, low, high, message", [
    ("uniform", 2.0, 2.0, "uniform prior needs low < high"),
    ("uniform", 3.0, -1.0, "uniform prior needs low < high"),
    ("loguniform", 1.0, 1.0, "loguniform prior needs 0 < low < high"),
    ("loguniform", 0.0, 1.0, "loguniform prior needs 0 < low < high"),
    ("lognormal", 44.0, 0.0, "lognormal prior needs median > 0 and sigma > 0"),
    ("lognormal", -1.0, 0.2, "lognormal prior needs median > 0 and sigma > 0"),
    ("uniform", 0.0, np.inf, "needs finite numbers"),
    ("beta", 1.0, 2.0, "prior kind 'beta' is not one of"),
])
def test_prior_without_support(kind, low, high, message):
    with pytest.raises(ValueError, match=message):
        Prior(kind, low, high)


def test_max_frequency_above_the_passband(air_case):
    """0.38 fs is the top of the fitted band (the DAQ passband ends at 0.40 fs)."""
    rec, _ = air_case
    for f in (0.39 * rec.fs, 0.6 * rec.fs, 0.0, -10.0):
        with pytest.raises(ValueError, match=r"must be positive and at most 0.38 fs = 194.56 Hz"):
            fit(rec, "air", FitConfig(**CONFIG, max_frequency=f))


def test_unknown_noise_model():
    with pytest.raises(ValueError, match=r"noise = 'pink': expected one of \('white', 'ar1'\)"):
        FitConfig(noise="pink")


def test_empty_or_inverted_fit_window(air_case):
    rec, _ = air_case
    for start, stop in ((0.5, 0.4), (0.5, 0.5), (-0.1, 0.5)):
        with pytest.raises(ValueError, match=r"fit window start = .* need 0.0 <= start < stop"):
            fit(rec, "air", FitConfig(**CONFIG, start=start, stop=stop))


def test_fit_window_after_the_end_of_the_record(air_case):
    rec, _ = air_case
    with pytest.raises(ValueError, match="fit window"):
        prepare(rec, "air", FitConfig(n_intervals=6, start=2.0, stop=3.0), 6)


def test_fit_window_shorter_than_one_block(air_case):
    rec, _ = air_case
    with pytest.raises(ValueError, match="shorter than one block"):
        prepare(rec, "air", FitConfig(n_intervals=6, stop=0.2, block=256), 6)


def test_recording_without_sensor_channels(air_case):
    rec, _ = air_case
    empty = replace(rec, sensors=(), signals=np.zeros((rec.n_samples, 0)))
    with pytest.raises(ValueError, match="no sensor channel"):
        fit(empty, "air", FitConfig(**CONFIG))


def test_ar1_coefficient_prior_can_be_overridden(air_case):
    rec, _ = air_case
    config = FitConfig(n_intervals=6, noise="ar1", priors={"phi_accel_tip": Prior("uniform", -0.5, 0.5)})
    post = prepare(rec, "air", config, 6).posterior
    assert dict(zip(post.names, post.priors))["phi_accel_tip"] == Prior("uniform", -0.5, 0.5)


def test_noise_sd_prior_can_be_overridden(air_case):
    """The counterpart that works: sigma_<sensor> overrides are accepted and used."""
    rec, _ = air_case
    config = FitConfig(n_intervals=6, priors={"sigma_accel_tip": Prior("loguniform", 1e-3, 10.0)})
    post = prepare(rec, "air", config, 6).posterior
    assert dict(zip(post.names, post.priors))["sigma_accel_tip"] == Prior("loguniform", 1e-3, 10.0)


def test_spline_degree_needs_a_refinement_ladder(air_case):
    """The automatic choice of N climbs a ladder per spline degree (N_LADDERS): another degree is
    refused when the config is made; a laddered one reaches the model."""
    with pytest.raises(ValueError, match=r"degree = 4: expected one of \[3, 5\]"):
        FitConfig(degree=4)
    rec, _ = air_case
    model = prepare(rec, "air", FitConfig(n_intervals=8, degree=5), 8).model
    assert (model.degree, model.ops.size) == (5, 11)
