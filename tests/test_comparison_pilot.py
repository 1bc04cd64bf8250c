"""Pilot runs of models whose optimum is rough (comparison.piloted, comparison.model_evidence): one
SMC run from the Laplace reference under the MIN_MOVED rule, whose particles centre the reference
of the model's evidence runs; smooth models are run exactly as without pilots.

Tolerances. Stand-in runs (no likelihood) make the wiring exact: which runs ran, with which seed
and rule, is compared for equality. The reference's centre is checked on 20000 of its draws against
the pilot's particle mean (sd 0.1 per coordinate: standard error of the mean under 0.002, checked
to 0.01), against the Laplace reference's centre 1.0 and 2.0 away.
"""
from types import SimpleNamespace

import numpy as np
import pytest

import bayesbeam.comparison as cmp
from bayesbeam.comparison import MIN_MOVED, PILOT_OFFSET, CompareConfig
from bayesbeam.executors import SerialExecutor
from bayesbeam.inference.evidence import laplace_reference
from bayesbeam.inference.priors import Prior
from bayesbeam.progress import as_progress

PRIORS = [Prior("uniform", -10.0, 10.0)] * 2
#: where a stand-in posterior's pilot particles lie, and the optimum its Laplace reference is centred on
CENTRE, OPTIMUM = np.array([1.0, 2.0]), np.zeros(2)


class StandIn:
    """A model's posterior as the evidence step sees it: priors, a dimension, a log prior, and
    the log Z and particle centre its stand-in SMC runs report."""

    ndim = 2
    priors = PRIORS

    def __init__(self, log_z):
        self.log_z = log_z

    def log_prior(self, _theta):
        return 0.0


def recording_smc(calls):
    def smc_job(args):
        post, reference, seed, particles, min_moved = args
        calls.append((post, reference, seed, min_moved))
        rng = np.random.default_rng(seed)
        return SimpleNamespace(log_z=post.log_z + 0.1 * rng.standard_normal(), betas=np.array([0.0, 0.5, 1.0]),
                               particles=CENTRE + 0.1 * rng.standard_normal((particles, 2)),
                               log_likelihood=np.full(particles, post.log_z + 5.0), n_evaluations=particles,
                               seconds=0.0)
    return smc_job


def optimised(rough: dict, sds=(0.1, 0.1)) -> dict:
    """model -> (problem, optimum, record) with the optimum at OPTIMUM, Laplace sds ``sds``, rough
    along coordinate 0 where given True."""
    return {m: (SimpleNamespace(posterior=StandIn(-100.0 - i)),
                SimpleNamespace(theta=OPTIMUM, covariance=np.diag(np.square(sds)), log_posterior=-90.0 - i,
                                rough=np.array([r, False])), {})
            for i, (m, r) in enumerate(rough.items())}


def test_a_rough_model_runs_one_pilot_and_its_runs_start_from_the_pilots_particles(monkeypatch):
    calls = []
    monkeypatch.setattr(cmp, "smc_job", recording_smc(calls))
    smooth_post, rough_post = StandIn(-100.0), StandIn(-101.0)
    laplace = laplace_reference(PRIORS, OPTIMUM, 0.01 * np.eye(2))
    jobs = {"smooth": (0, smooth_post, laplace, 0), "rough": (1, rough_post, laplace, 0)}
    seeds = np.random.SeedSequence(4)
    out, pilots, alongside = cmp.piloted(jobs, ["rough"], CompareConfig(), seeds, SerialExecutor())
    assert alongside == {}
    assert out["smooth"] is jobs["smooth"]
    assert list(pilots) == ["rough"]
    assert [(post, reference, seed, rule) for post, reference, seed, rule in calls] == \
        [(rough_post, laplace, cmp._seed(seeds, 1000 + PILOT_OFFSET), MIN_MOVED)]
    draws = out["rough"][2].sample(np.random.default_rng(0), 20000)
    np.testing.assert_allclose(draws.mean(axis=0), pilots["rough"].particles.mean(axis=0), atol=0.01)
    assert out["rough"][:2] == (1, rough_post) and out["rough"][3] == 0


def test_without_a_rough_model_no_pilot_runs_and_the_evidence_runs_are_unchanged(monkeypatch):
    calls = []
    monkeypatch.setattr(cmp, "smc_job", recording_smc(calls))
    evidences, _ = cmp.model_evidence(optimised({"q1": False, "q3": False}), CompareConfig(early_stop=None),
                                      np.random.SeedSequence(4), SerialExecutor(), as_progress(None))
    assert len(calls) == 6 and all(rule is None for *_, rule in calls)
    assert all(e.pilot is None and "pilot" not in e.as_dict() for e in evidences.values())


def test_the_evidence_of_a_rough_model_records_its_pilot_and_smooth_runs_stay_as_they_were(monkeypatch):
    smooth_calls, calls = [], []
    monkeypatch.setattr(cmp, "smc_job", recording_smc(smooth_calls))
    plain, _ = cmp.model_evidence(optimised({"q1": False, "q3": False}), CompareConfig(early_stop=None),
                                  np.random.SeedSequence(4), SerialExecutor(), as_progress(None))
    monkeypatch.setattr(cmp, "smc_job", recording_smc(calls))
    fits = optimised({"q1": False, "q3": True})
    evidences, _ = cmp.model_evidence(fits, CompareConfig(early_stop=None), np.random.SeedSequence(4),
                                      SerialExecutor(), as_progress(None))
    assert len(calls) == 7 and calls[0][0] is fits["q3"][0].posterior and calls[0][3] == MIN_MOVED
    assert evidences["q3"].pilot is not None and evidences["q1"].pilot is None
    assert evidences["q3"].as_dict()["pilot"]["log_evidence"] == evidences["q3"].pilot.log_z
    assert [r.log_z for r in evidences["q1"].runs] == [r.log_z for r in plain["q1"].runs]
    assert [r.log_z for r in evidences["q3"].runs] == [r.log_z for r in plain["q3"].runs]
    for model, centre in (("q1", OPTIMUM), ("q3", CENTRE)):
        references = [reference for post, reference, _, rule in calls[1:] if post is fits[model][0].posterior]
        assert len(references) == 3
        for reference in references:
            np.testing.assert_allclose(reference.sample(np.random.default_rng(0), 20000).mean(axis=0), centre,
                                       atol=0.01)


class Waves(SerialExecutor):
    """A serial executor that records each map's jobs: (posterior, min_moved rule) per SMC run."""

    def __init__(self):
        self.waves = []

    def map(self, fn, *iterables, bar=None, done=None):
        self.waves.append([(job[0], job[4]) for job in iterables[0]])
        return super().map(fn, *iterables, bar=bar, done=done)


@pytest.mark.parametrize(("early_stop", "decisive", "first"), [(None, None, 3), (cmp.EARLY_STOP_NATS, (5.0, 3.0), 2)])
def test_the_smooth_models_first_runs_share_the_pilots_wave(monkeypatch, early_stop, decisive, first):
    """The pilot runs first, then in the same map the smooth model's first wave (all its repeats
    without early stopping; :data:`~bayesbeam.comparison.FIRST_WAVE` with it and a decisive rule);
    the rough model's repeats follow, and every run is the one run without the sharing."""
    calls = []
    monkeypatch.setattr(cmp, "smc_job", recording_smc(calls))
    fits = optimised({"q1": False, "q3": True})
    q1, q3 = fits["q1"][0].posterior, fits["q3"][0].posterior
    executor = Waves()
    evidences, _ = cmp.model_evidence(fits, CompareConfig(early_stop=early_stop), np.random.SeedSequence(4),
                                      executor, as_progress(None), decisive=decisive)
    assert executor.waves[0] == [(q3, MIN_MOVED)] + [(q1, None)] * first
    assert executor.waves[1] == [(q3, None)] * len(executor.waves[1]) and executor.waves[1]
    ran = [(id(post), seed) for post, _, seed, rule in calls if rule is None]
    seeds = np.random.SeedSequence(4)
    assert sorted(ran) == sorted((id(fits[m][0].posterior), cmp._seed(seeds, i * 1000 + r))
                                 for i, m in enumerate(fits) for r in range(len(evidences[m].runs)))


def test_roughness_counts_only_along_a_coordinate_the_reference_centres_on_the_optimum():
    """Rough along coordinate 0: with its Laplace sd 0.1 (the data determine it, prior sd 5.8) the
    reference centres there and a pilot runs; with sd 10 (left to the prior) none does."""
    for sd, pilots in ((0.1, 1), (10.0, 0)):
        calls = []
        fits = optimised({"q1": True}, sds=(sd, 0.1))
        optimum = fits["q1"][1]
        reference = laplace_reference(PRIORS, optimum.theta, optimum.covariance)
        assert cmp.rough_where_centred(optimum, reference) == bool(pilots)
        with pytest.MonkeyPatch.context() as patch:
            patch.setattr(cmp, "smc_job", recording_smc(calls))
            cmp.model_evidence(fits, CompareConfig(early_stop=None), np.random.SeedSequence(4), SerialExecutor(),
                               as_progress(None))
        assert sum(rule == MIN_MOVED for *_, rule in calls) == pilots and len(calls) == 3 + pilots


class RippledGaussian:
    """A posterior with an analytic evidence and many sharp local maxima: uniform priors on
    [-10, 10]^2 and the likelihood exp(-|r / s|^2 / 2 + A sum_i cos(2 pi r_i / p_i)), r = theta -
    MEAN, ripple periods p = s / 10. Per coordinate the integral of the likelihood is
    s sqrt(2 pi) I0(A) (the Fourier series exp(A cos x) = I0(A) + 2 sum_n I_n(A) cos(n x); the
    Gaussian's transform kills every n >= 1 term, by exp(-(20 pi n)^2 / 2)), so
    log Z = sum_i log(s_i sqrt(2 pi) I0(A)) - log 400."""

    MEAN, SDS, AMPLITUDE = np.array([0.5, -1.0]), np.array([0.02, 0.3]), 1.0
    priors = PRIORS
    ndim = 2

    def terms(self, theta):
        r = np.asarray(theta) - self.MEAN
        ripple = self.AMPLITUDE * np.sum(np.cos(2 * np.pi * r / (self.SDS / 10)))
        return -np.log(400.0), float(-0.5 * np.sum((r / self.SDS) ** 2) + ripple)

    def __call__(self, theta):
        return sum(self.terms(theta))

    def log_z(self):
        from scipy.special import i0
        return float(np.sum(np.log(self.SDS * np.sqrt(2 * np.pi) * i0(self.AMPLITUDE))) - np.log(400.0))


def test_on_a_rippled_posterior_the_piloted_evidence_matches_the_analytic_value():
    """From a ripple crest two sds off the centre, where the finite differences find the optimum
    rough, the pilot's particles centre the reference of three repeats whose mean log Z lies within
    0.3 nats of the analytic value: the runs spread by about 0.15 nats (seeds 7-9), so the mean's
    standard error is about 0.09 and 0.3 nats over three of them, while a 10 % error in I0(A) per
    coordinate moves the truth by 0.19 and in the prior's area (400) by 0.1 each: a test of the
    whole path, not of one constant. (Here SMC from the Laplace reference also lands within 0.3:
    in two dimensions the ripples of 2 nats do not trap its moves, as a long friction record's do.)"""
    from bayesbeam.inference.sampler import laplace_covariance_and_roughness

    post = RippledGaussian()
    crest = post.MEAN + 2 * post.SDS
    covariance, rough = laplace_covariance_and_roughness(post, crest)
    reference = laplace_reference(PRIORS, crest, covariance)
    assert cmp.rough_where_centred(SimpleNamespace(rough=rough), reference)
    jobs, _, _ = cmp.piloted({"rippled": (0, post, reference, 0)}, ["rippled"], CompareConfig(),
                             np.random.SeedSequence(7), SerialExecutor())
    evidences, _ = cmp._evidence(jobs, CompareConfig(early_stop=None), np.random.SeedSequence(7), SerialExecutor())
    assert abs(evidences["rippled"].log_z - post.log_z()) < 0.3, (evidences["rippled"].log_z, post.log_z())


def test_a_determined_coordinate_against_its_prior_edge_counts_as_centred():
    """An optimum 0.05 from the prior's lower edge with a Laplace sd of 0.1 (determined, but not
    three sds inside): the reference gives that coordinate an edge band, not the Student-t, and
    roughness along it still runs a pilot; along the other, left to the prior (sd 10), it does not."""
    optimum = SimpleNamespace(theta=np.array([-9.95, 0.0]), covariance=np.diag([0.01, 100.0]),
                              rough=np.array([True, False]))
    reference = laplace_reference(PRIORS, optimum.theta, optimum.covariance)
    assert list(reference.bands) == [0] and not reference.tight.any()
    assert cmp.rough_where_centred(optimum, reference)
    assert not cmp.rough_where_centred(SimpleNamespace(rough=np.array([False, True])), reference)
