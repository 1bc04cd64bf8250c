"""channel_gain: each response channel reads (1 + g) times the motion, the force channel as recorded."""
from dataclasses import replace

import numpy as np
import pytest

from bayesbeam import BeamModel
from bayesbeam.inference.fit import FitConfig, prepare
from bayesbeam.inference.priors import default_priors
from bayesbeam.inference.sampler import find_optimum
from bayesbeam.io import Excitation
from tests.acceptance import cases as acceptance
from tests.physics.effects.helpers import PAPER_EI, recording
from tests.reference import Release, record
from tests.reference.recordings import NOISE

Q1 = {"EI": PAPER_EI, "gamma": 0.2, "cdI": 1e-4}
TWO = ((1.0, "acceleration"), (0.6, "displacement"))


@pytest.mark.parametrize("kind", ["force", "release"])
def test_each_channel_is_scaled_by_its_own_gain(kind):
    """g_s0 = +3 %, g_s1 = -2 %: each channel is (1 + g) times the same model at g = 0, a
    release's static deflection included (1e-8 of each channel's peak: one multiplication of the
    spectrum, whose rounding the inverse transform's exponential window e^{sigma t} amplifies up to
    the solver's floor, 1e-8, in the last samples; observed 1.6e-9); the force channel is the
    model's without the effect."""
    rec = recording(kind, fs=1024.0, duration=0.5, sensors=TWO)
    model, plain = BeamModel(rec, "q1", 8, effects="channel_gain"), BeamModel(rec, "q1", 8)
    assert model.parameter_names[-2:] == ("g_s0", "g_s1")
    y, y0 = model.simulate({**Q1, "g_s0": 0.03, "g_s1": -0.02}), model.simulate({**Q1, "g_s0": 0.0, "g_s1": 0.0})
    assert np.all(np.max(np.abs(y - y0 * [1.03, 0.98]), axis=0) < 1e-8 * np.max(np.abs(y0), axis=0))
    if kind == "force":
        np.testing.assert_array_equal(model.force, plain.force)


def test_a_gain_that_flips_the_channel_is_refused():
    """1 + g must stay positive; g = 0 is the model without the effect, to the bit."""
    rec = recording(fs=1024.0, duration=0.5)
    model = BeamModel(rec, "q1", 8, effects="channel_gain")
    with pytest.raises(ValueError, match="g = -1.0 is not physical"):
        model.simulate({**Q1, "g": -1.0})
    np.testing.assert_array_equal(model.simulate({**Q1, "g": 0.0}), BeamModel(rec, "q1", 8).simulate(Q1))


def test_the_default_prior_and_a_stated_tolerance():
    """g_<s> is normal about 0 with sd 0.02 by default, and the sensor's gain_tolerance where stated."""
    rec = recording(fs=1024.0, duration=0.5, sensors=TWO)
    rec = replace(rec, setup_keys={"sensor": [{}, {"gain_tolerance": 0.05}]})
    priors = default_priors(rec.beam, ["g_s0", "g_s1"], {}, rec.setup)
    assert [(p.kind, p.a, p.b) for p in priors.values()] == [("normal", 0.0, 0.02), ("normal", 0.0, 0.05)]
    assert priors["g_s0"].log_density(0.0) == pytest.approx(-np.log(0.02 * np.sqrt(2 * np.pi)), rel=1e-12)


def _reference(**kwargs):
    setting = acceptance._setting("paper")
    return record(acceptance._nominal(setting["beam"]), acceptance.DAMPING["paper"]["q1"],
                  EI=setting["beam"].nominal_EI, fs=setting["fs"], duration=1.0, noise=NOISE, seed=3,
                  **{"excitation": setting["excitation"], **kwargs})


def test_a_free_decay_cannot_see_its_only_channels_gain():
    """A reference release re-read as a free decay from 0.05 s: the amplitudes are the unknown
    state's, so one channel's gain scales the free-decay basis by 1 + g (to rounding) and leaves the
    marginal likelihood unchanged (1e-9 relative: the marginal scales each column by its own RMS):
    the posterior of g is its prior, and nothing is discovered."""
    rec = _reference(excitation=Release(1.0))
    rec = replace(rec, excitation=Excitation("free_decay", start=0.05))
    post = prepare(rec, "q1", FitConfig(degree=5, n_intervals=8, effects=("channel_gain",)), 8).posterior
    theta = post.coordinates({**Q1, "g": 0.0, "sigma_accel_tip": 0.5})
    i = post.names.index("g")
    model = post.likelihood.model
    basis = [model.free_decay_basis(post.split(theta)[0]), None]
    logs = []
    for g in (-0.05, 0.0, 0.05):
        theta[i] = g
        logs.append(post.log_likelihood(theta))
    basis[1] = model.free_decay_basis(post.split(theta)[0])
    np.testing.assert_allclose(basis[1], 1.05 * basis[0], rtol=1e-12, atol=1e-12 * np.max(np.abs(basis[0])))
    assert np.ptp(logs) < 1e-9 * abs(logs[1])


@pytest.mark.parametrize("force_scale", [1.0, 1.03])
def test_a_force_record_reads_the_ratio_of_the_two_calibrations(force_scale):
    """A reference hammer test (paper beam, q1, 2 % sensor and 0.5 % force noise) whose force channel
    reads 1.00 or 1.03 times the true force: the fitted g is the ratio of the calibrations,
    1/force_scale - 1 (0, or -2.9 %), inside its 99 % interval (+-2.58 sd of the Laplace
    covariance; one noise draw), so a true calibration is no false discovery and a force channel's
    error is read as the response channel's: 0 lies outside the interval then. The data narrow the
    prior (sd 0.02) at least fourfold (observed sd 0.0042)."""
    rec = _reference()
    rec = replace(rec, force=rec.force * force_scale)
    post = prepare(rec, "q1", FitConfig(degree=5, n_intervals=8, effects=("channel_gain",)), 8).posterior
    optimum = find_optimum(post, np.random.default_rng(1))
    i = post.names.index("g")
    g, sd = post.values(optimum.theta)["g"], float(np.sqrt(optimum.covariance[i, i]))
    assert abs(g - (1 / force_scale - 1)) <= 2.58 * sd
    assert sd < 0.25 * 0.02
    assert (abs(g) > 2.58 * sd) == (force_scale != 1.0)


def test_the_gain_scales_a_nonlinear_models_whole_response():
    """With quadratic drag (c_q = 2 N s^2/m^3) the drag's part of the response passes the chain too:
    the whole output is (1 + g) times the one at g = 0, to the solver's 1.5e-8 wrap-around floor
    (the drag's force history does not depend on the gain: the beam moves the same)."""
    rec = recording(fs=512.0, duration=0.5)
    model = BeamModel(rec, "q1", 8, effects="channel_gain+quadratic_drag")
    y0 = model.simulate({**Q1, "g": 0.0, "c_q": 2.0})
    y = model.simulate({**Q1, "g": 0.04, "c_q": 2.0})
    linear = BeamModel(rec, "q1", 8).simulate(Q1)
    assert np.max(np.abs(y0 - linear)) > 1e-4 * np.max(np.abs(y0))     # the drag's part is there
    assert np.max(np.abs(y - 1.04 * y0)) < 1.5e-8 * np.max(np.abs(y0))


def test_a_normal_prior_from_a_fit_file():
    """[prior.g] kind = "normal" (mean, sd): sampled in the value, support +-4 sd; sd <= 0 refused."""
    from bayesbeam.inference.priors import Prior, prior_from_table
    prior = prior_from_table("g", {"kind": "normal", "mean": 0.01, "sd": 0.05})
    assert prior == Prior("normal", 0.01, 0.05) and not prior.log_scale
    assert prior.bounds() == pytest.approx((-0.19, 0.21), rel=1e-12) and prior.median() == pytest.approx(0.01)
    with pytest.raises(ValueError, match="sd > 0"):
        Prior("normal", 0.0, 0.0)
