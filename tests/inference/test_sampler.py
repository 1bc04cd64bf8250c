"""The optimiser (``sampler.find_optimum``): its global search with missing-physics effects, where
it starts on the N ladder, its polish, the EI rescan of a given start (``fit.local_starts``), and
the Laplace covariance at a constraint; and what ``run_emcee`` tells its user while it runs and
when it stops unconverged."""
import importlib
import io
from pathlib import Path

import numpy as np
import pytest

from bayesbeam.inference.fit import N_LADDERS, START_PHASE, FitConfig, local_starts, prepare, starting_rung
from bayesbeam.inference.priors import Prior
from bayesbeam.inference.sampler import (
    Optimum,
    _Counter,
    _nelder_mead,
    _neutral_start,
    _search_scale,
    _simplex_edges,
    find_optimum,
    laplace_covariance,
    laplace_covariance_and_roughness,
    newton_shift,
    run_emcee,
    unconverged_reason,
)
from bayesbeam.io import load_recording
from bayesbeam.progress import Progress
from tests.inference import cases
from tests.reference import Hammer, Noise, record
from tests.reference.recordings import PAPER_DAMPING

EXAMPLES = Path(__file__).resolve().parents[2] / "data" / "examples"


def test_effects_start_where_they_vanish():
    """P at 0 (inside its uniform prior), k_theta at the stiff end of its prior, the damping at its
    prior median."""
    rec, _ = cases.simulated("air", seed=1)
    post = prepare(rec, "air", FitConfig(n_intervals=6, effects=("axial_load", "root_compliance")), 6).posterior
    x0 = dict(zip(post.model_names, _neutral_start(post)))
    priors = dict(zip(post.names, post.priors))
    assert x0["P"] == 0.0
    assert x0["k_theta"] == pytest.approx(priors["k_theta"].bounds()[1])
    assert x0["gamma"] == pytest.approx(priors["gamma"].median())


@pytest.mark.slow
def test_global_search_finds_a_tension():
    """A reference hammer test (tests.reference: the paper's beam, q1 at the acceptance damping, a
    4 ms pulse at 0.75 m, 1 s at 512 Hz, sensor noise 2 % of the RMS, force noise 0.5 % of the
    peak) with a tension raising mode 1 by about 2 % (P = 0.25 of the buckling load), fitted
    undecimated at N = 8 (quintic). Started from the prior medians (P = 4.75 buckling loads) the
    search ended at EI 31.6 N m^2 (29 % low) and P = 658 N, thousands of sd away; from the
    vanishing effect it must find the truth: every parameter within 4 posterior sd (the Laplace sd
    at the optimum; 4 sd leaves room for the reference's discretisation, whose share is below
    0.1 % of the noise; measured when written: |z| <= 0.56)."""
    beam = cases.PAPER_BEAM
    p_cr = np.pi**2 * beam.nominal_EI / (4 * beam.length**2)
    damping = PAPER_DAMPING["q1"]
    truth = {"EI": beam.nominal_EI, **damping, "P": 0.25 * p_cr}
    rec = record(beam, damping, excitation=Hammer(0.75, peak=20.0, width=0.004, t0=0.04), fs=512.0, duration=1.0,
                 effects={"P": truth["P"]}, noise=Noise(sensor=0.02, force=0.005), seed=7)
    post = prepare(rec, "q1", FitConfig(n_intervals=8, degree=5, effects=("axial_load",)), 8).posterior
    best = find_optimum(post, np.random.default_rng(1))
    k = len(post.model_names)
    x_true = np.array([p.to_coordinate(truth[n]) for p, n in zip(post.priors[:k], post.model_names)])
    z = (best.theta[:k] - x_true) / np.sqrt(np.diag(best.covariance)[:k])
    assert np.all(np.abs(z) < 4), dict(zip(post.model_names, np.round(z, 2)))


def test_a_start_from_a_nested_optimum_gets_its_EI_rescanned():
    """A reference hammer test of the aluminium strip (cases.ALU_BEAM, 50 g tip; q1 damping; a
    1 ms pulse at 0.375 m; 1 s at 512 Hz, sensor noise 2 % of the RMS, force noise 0.5 % of the
    peak) whose clamp is a root spring k_theta = 650 N m/rad, fitted up to 150 Hz (modes 1-3) at
    N = 8 (quintic). q1 without the spring lowers EI (3.77 N m^2, 4 % low) to put mode 1 in place;
    a polish of q1 + root_compliance from there with k_theta = 650 returns to a rigid root
    (k_theta 7.9e5 N m/rad, 141 nats below the truth's basin). The local starts must include
    that start with EI re-determined, and the best polish from them must land on the truth:
    every parameter within 4 posterior sd (the Laplace sd at that optimum; 4 sd leaves room for
    the reference's discretisation; measured when written: |z| <= 0.91)."""
    truth = {"EI": cases.ALU_BEAM.nominal_EI, "gamma": 0.18, "cdI": 5.5e-6, "k_theta": 650.0}
    rec = record(cases.ALU_BEAM, {"gamma": truth["gamma"], "cdI": truth["cdI"]}, tip=cases.ALU_TIP,
                 excitation=Hammer(0.375, peak=5.0, width=0.001, t0=0.02), fs=512.0, duration=1.0,
                 effects={"k_theta": truth["k_theta"]}, noise=Noise(sensor=0.02, force=0.005), seed=3)
    nested = prepare(rec, "q1", FitConfig(n_intervals=8, degree=5, max_frequency=150.0), 8).posterior
    found = nested.split(find_optimum(nested, np.random.default_rng(1)).theta)[0]
    probe = {**{n: found[n] for n in nested.model_names}, "k_theta": truth["k_theta"]}
    post = prepare(rec, "q1", FitConfig(n_intervals=8, degree=5, max_frequency=150.0,
                                        effects=("root_compliance",)), 8).posterior
    optima = [find_optimum(post, np.random.default_rng(1), start=s) for s in local_starts(post, probe)]
    best = max(optima, key=lambda o: o.log_posterior)
    k = len(post.model_names)
    x_true = np.array([p.to_coordinate(truth[n]) for p, n in zip(post.priors[:k], post.model_names)])
    z = (best.theta[:k] - x_true) / np.sqrt(np.diag(best.covariance)[:k])
    assert np.all(np.abs(z) < 4), dict(zip(post.model_names, np.round(z, 2)))


def test_the_global_search_follows_a_root_spring_along_its_EI_ridge():
    """The shipped example made by the reference simulator with q1 damping and a root spring of
    3500 N m/rad (data/examples/paper_rootcomp_hammer), up to 150 Hz at N = 12 (quintic): q1 with
    the root spring and the root dashpot, searched globally, must reach the optimum of the model
    without the dashpot, which it contains as c_theta goes to its prior's floor: its log posterior
    at least that one's plus the floor's log prior density, less 0.05 nats (the polish stops at
    1e-4 nats; what is left is the dashpot's floor, 4e-5 N m s/rad: measured 4e-4 nats). The
    search starts the spring rigid and keeps EI within 0.5 % of the rigid root's EI, 4.4 % below
    the truth's; without the polish from the ridge it ends on a rigid clamp whose dashpot
    carries the damping, 1200 nats lower."""
    rec = load_recording(EXAMPLES / "paper_rootcomp_hammer")
    config = FitConfig(max_frequency=150.0)
    nested = prepare(rec, "q1+root_compliance", config, 12).posterior
    truth = {"EI": 43.952, "gamma": 0.3, "cdI": 7e-5, "k_theta": 3500.0}
    reference = find_optimum(nested, np.random.default_rng(1), start=truth)
    post = prepare(rec, "q1+root_compliance+root_damping", config, 12).posterior
    best = find_optimum(post, np.random.default_rng(1))
    c_theta = dict(zip(post.names, post.priors))["c_theta"]
    floor = c_theta.log_density(c_theta.bounds()[0])
    assert best.log_posterior >= reference.log_posterior + floor - 0.05, (best.log_posterior, reference.log_posterior)


def test_a_choice_of_discretisation_from_a_start_alone_runs_no_global_search(monkeypatch, air_case):
    """choose_discretisation(search=False), as comparison.polish_job runs it: every optimisation
    starts from the start (the EI rescan's and the ladder's polishes), none is a global search;
    without a start it refuses."""
    from bayesbeam.comparison import CompareConfig, polish_job

    fit = importlib.import_module("bayesbeam.inference.fit")     # the package's `fit` names the function
    starts, real = [], fit.find_optimum

    def spy(post, rng, **options):
        starts.append(options.get("start"))
        return real(post, rng, **options)

    monkeypatch.setattr(fit, "find_optimum", spy)
    rec, _ = air_case
    config = FitConfig(n_intervals=6)
    start = {"EI": cases.EI_TRUE, "gamma": cases.TRUTH["air"]["gamma"]}
    polish_job((rec, "air", CompareConfig(config), 1, start))
    assert starts and all(s is not None for s in starts)
    starts.clear()
    fit.choose_discretisation(rec, "air", config, np.random.default_rng(1), start=start)
    assert starts[0] is None                             # the default: the global search first
    with pytest.raises(ValueError, match="needs a start"):
        fit.choose_discretisation(rec, "air", config, np.random.default_rng(1), search=False)


@pytest.mark.parametrize("shifts, last_n, stalled", [
    ((0.3, 0.2, 0.25, 0.1), 12, True),           # 16 -> 24 moves no less than 12 -> 16: roughness, 12 kept
    ((0.3, 0.2, 0.2, 0.1), 12, True),            # ... also when it moves exactly as much
    ((0.3, 0.2, 0.15, 0.12, 0.11), 32, False),   # shrinking: climbs to the ladder's top
    ((0.3, 0.05), 12, False),                    # passes at 12
])
def test_the_ladder_stops_where_the_shift_stops_shrinking(monkeypatch, shifts, last_n, stalled):
    """choose_discretisation with the quintic ladder (8, 12, ...) and each rung's check's largest
    shift scripted: it climbs while the check fails and the shift shrinks; at the first rung
    whose shift is no smaller than the rung's below it stops, ``stalled``, and returns the rung
    below (the finer one was no closer to the limit) with that rung's check and the stalled
    check's shift."""
    script = dict(zip(N_LADDERS[5], shifts))
    chosen, record = _scripted_ladder(monkeypatch, {n: (shift, 0.0) for n, shift in script.items()})
    assert chosen.model.n_intervals == record["n_intervals"] == last_n
    assert record["stalled"] is stalled
    assert record["max_shift_sd"] == script[last_n]
    if stalled:
        assert record["finer_max_shift_sd"] == script[N_LADDERS[5][N_LADDERS[5].index(last_n) + 1]]


def _scripted_ladder(monkeypatch, script: dict):
    """choose_discretisation's (problem, record) with the quintic ladder and each rung's check
    scripted as N -> (largest shift in sd, level change in nats), passed by the package's rule."""
    from types import SimpleNamespace

    fit = importlib.import_module("bayesbeam.inference.fit")

    def problem(n):
        return SimpleNamespace(model=SimpleNamespace(n_intervals=n, degree=5), posterior=_FlatPosterior())

    def check(coarse, finer, optimum, config, log=None):
        shift, level = script[coarse.model.n_intervals]
        return {"n_intervals": coarse.model.n_intervals, "max_shift_sd": shift, "level_change_nats": level,
                "passed": shift < fit.SHIFT_TOLERANCE and abs(level) < fit.LEVEL_TOLERANCE}, np.zeros(1)

    optimum = SimpleNamespace(theta=np.zeros(1), covariance=np.eye(1), log_posterior=0.0)
    monkeypatch.setattr(fit, "prepare", lambda rec, model, config, n: problem(n))
    monkeypatch.setattr(fit, "starting_rung", lambda *args: 8)
    monkeypatch.setattr(fit, "find_optimum", lambda *args, **options: optimum)
    monkeypatch.setattr(fit, "_refinement_check", check)
    chosen, _, record = fit.choose_discretisation(None, "q1", FitConfig(), np.random.default_rng(1))
    return chosen, record


@pytest.mark.parametrize("script, last_n, stalled", [
    ({8: (0.08, 7.9), 12: (0.01, 0.2)}, 12, False),             # level off at 8: climbs, passes at 12
    ({8: (0.08, -2.0), 12: (0.01, -0.6), 16: (0.01, 0.1)}, 16, False),   # either sign; shrinking
    ({8: (0.05, 2.0), 12: (0.01, 2.5)}, 8, True),               # the level change grows: roughness
    ({8: (0.3, 0.1), 12: (0.05, 1.0), 16: (0.01, 0.1)}, 16, False),  # 3 x the shift tolerance, then 2 x the level's
    ({8: (0.3, 0.1), 12: (0.05, 2.0), 16: (0.01, 0.1)}, 8, True),  # 4 x the level's is no smaller than 3 x
])
def test_the_ladder_climbs_until_the_level_settles_too(monkeypatch, script, last_n, stalled):
    """A rung passes only when the finer grid moves the optimum by under SHIFT_TOLERANCE sd and the
    log posterior there by under LEVEL_TOLERANCE nats; the stall rule compares the larger of the
    two errors, each in multiples of its tolerance, with the rung's below."""
    chosen, record = _scripted_ladder(monkeypatch, script)
    assert chosen.model.n_intervals == record["n_intervals"] == last_n
    assert record["stalled"] is stalled and record["passed"] is not stalled


def test_a_refinement_check_fails_on_a_level_change_alone(monkeypatch):
    """The finer model's log posterior at the coarse optimum, a constant 0.6 nats above it with the
    optimum unmoved: the shift passes, the check fails on the level; 0.4 nats passes."""
    from types import SimpleNamespace

    fit = importlib.import_module("bayesbeam.inference.fit")
    monkeypatch.setattr(fit, "newton_shift", lambda post, theta, covariance: np.zeros(1))
    coarse = SimpleNamespace(model=SimpleNamespace(n_intervals=8, degree=5), posterior=_FlatPosterior())
    optimum = SimpleNamespace(theta=np.zeros(1), covariance=np.eye(1), log_posterior=-3.0)
    for offset, passed in ((0.6, False), (-0.6, False), (0.4, True)):
        finer = SimpleNamespace(model=SimpleNamespace(n_intervals=12, degree=5),
                                posterior=lambda theta, offset=offset: -3.0 + offset)
        record, _ = fit._refinement_check(coarse, finer, optimum, FitConfig())
        assert record["max_shift_sd"] == 0.0 and record["passed"] is passed
        assert record["level_change_nats"] == pytest.approx(offset) and record["level_tolerance_nats"] == 0.5


class _FlatPosterior:
    """A one-parameter posterior, flat: what choose_discretisation asks of a problem's posterior."""

    model_names = ("EI",)

    def __call__(self, theta):
        return 0.0

    def split(self, theta):
        return {"EI": theta[0]}, {}


class GaussianPosterior:
    """A stand-in log posterior: a correlated Gaussian (mean, cov) in three coordinates with
    uniform priors on [-10, 10], -inf below ``floor`` in the first coordinate (a constraint inside
    the priors' box, as q2's stability bound is)."""

    def __init__(self, mean, cov, floor=-np.inf):
        self.mean, self.cov, self.floor = np.asarray(mean, float), np.asarray(cov, float), floor
        self.priors = [Prior("uniform", -10.0, 10.0)] * len(self.mean)

    def __call__(self, theta):
        if theta[0] < self.floor:
            return -np.inf
        r = np.asarray(theta) - self.mean
        return float(-0.5 * r @ np.linalg.solve(self.cov, r))


#: sds spanning five decades (log EI's ~1e-5 to a damping term's ~0.1) and a correlation of 0.9
#: between the last two
SDS = np.array([1e-5, 1e-2, 0.3])
CORRELATION = np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.9], [0.0, 0.9, 1.0]])
COV = CORRELATION * np.outer(SDS, SDS)


def test_the_polish_converges_on_a_posterior_whose_widths_span_decades():
    """From 3 sd off in every coordinate, a Nelder-Mead polish shaped by a covariance (here one
    twice too wide along every axis) reaches the peak to 0.05 sd in each coordinate (its value
    tolerance 1e-4 nats allows 0.014 sd along any one direction) in under 600 evaluations (the
    cap is 1200)."""
    post = GaussianPosterior([3.8, -2.0, -1.7], COV)
    counter = _Counter(post)
    x0 = post.mean + 3 * SDS
    bounds = [p.bounds() for p in post.priors]
    x = _nelder_mead(counter, x0, _simplex_edges(4 * COV, bounds))
    assert np.all(np.abs(x - post.mean) / SDS < 0.05), (x - post.mean) / SDS
    assert counter.calls < 600, counter.calls


def test_the_polish_without_a_covariance_takes_its_scale_from_the_curvature():
    """The covariance the global search's polish starts from: the inverse curvature along each
    coordinate (the conditional variances sd^2 (1 - rho^2) here), to 1 % (finite differences of
    a quadratic are exact up to rounding)."""
    post = GaussianPosterior([3.8, -2.0, -1.7], COV)
    scale = _search_scale(_Counter(post), post.mean + SDS, [p.bounds() for p in post.priors])
    conditional = 1.0 / np.diag(np.linalg.inv(COV))
    np.testing.assert_allclose(np.diag(scale), conditional, rtol=0.01)


def test_laplace_covariance_at_a_constraint_steps_off_it():
    """An optimum against a constraint inside the priors' box (-inf a step below it): the Hessian
    is taken three steps inside, where it is the Gaussian's (to 1 %), not the diagonal fallback of
    1e-6 that a non-finite Hessian gave."""
    sds = np.array([1e-3, 1e-2, 0.3])
    cov = CORRELATION * np.outer(sds, sds)
    post = GaussianPosterior([0.5, -2.0, -1.7], cov, floor=0.5 - 5e-5)
    np.testing.assert_allclose(laplace_covariance(post, post.mean), cov, rtol=0.01, atol=1e-3 * np.min(sds) ** 2)


class RoughGaussianPosterior(GaussianPosterior):
    """:class:`GaussianPosterior` plus a ripple of ``amplitude`` nats with a period of about a
    hundredth of each sd (sd / 137.036: no finite-difference step spans whole periods): the many
    sharp local maxima of a stick-slip likelihood on a long record, at the optimum one of them."""

    def __init__(self, mean, cov, amplitude):
        super().__init__(mean, cov)
        self.amplitude, self.scale = amplitude, np.sqrt(np.diag(self.cov)) / 137.036

    def __call__(self, theta):
        ripple = np.sum(np.cos(2 * np.pi * (np.asarray(theta) - self.mean) / self.scale) - 1)
        return super().__call__(theta) + self.amplitude * float(ripple)


def test_laplace_covariance_sees_through_a_rough_likelihood():
    """Ripples of 0.5 nats a hundredth of an sd apart (at the optimum, on a ripple's crest) over
    the Gaussian of sds 1e-5, 1e-2 and 0.3 with a correlation of 0.9: steps searched to a drop of
    LAPLACE_DROP = 20 nats (about six sds) see the Gaussian, each sd to 10 % and the correlation
    to 0.02 (the ripple adds at most 3 x 0.5 nats to second differences over four steps' squares:
    under 2 % of the curvature at six sds, amplified up to 1 / (1 - 0.9^2) = 5.3 by the
    correlated pair; observed 5.4 %). Over the fixed step of 1e-4 the ripple's own curvature (its
    (2 pi / (sd / 100))^2 x 0.5 nats is 2e8 x the Gaussian's) would set every sd small by orders of magnitude."""
    post = RoughGaussianPosterior([3.8, -2.0, -1.7], COV, amplitude=0.5)
    cov = laplace_covariance(post, post.mean)
    sds = np.sqrt(np.diag(cov))
    np.testing.assert_allclose(sds, SDS, rtol=0.1)
    assert abs(cov[1, 2] / (sds[1] * sds[2]) - 0.9) < 0.02


def test_an_optimum_on_ripples_is_rough_and_a_smooth_one_is_not():
    """The ripples of 0.5 nats a hundredth of an sd apart make the optimum rough along the
    coordinates of sd 1e-2 and 0.3 (their curvature over the fixed step of 1e-4 is the ripple's,
    orders of magnitude above the Gaussian's), not along the one of sd 1e-5, which the fixed step
    already oversteps by ten sds; the Gaussian alone is smooth, and its covariance is then
    exactly :func:`laplace_covariance`'s."""
    rough = RoughGaussianPosterior([3.8, -2.0, -1.7], COV, amplitude=0.5)
    assert laplace_covariance_and_roughness(rough, rough.mean)[1].tolist() == [False, True, True]
    smooth = GaussianPosterior([3.8, -2.0, -1.7], COV)
    cov, flagged = laplace_covariance_and_roughness(smooth, smooth.mean)
    assert flagged.tolist() == [False, False, False]
    np.testing.assert_array_equal(cov, laplace_covariance(smooth, smooth.mean))


def test_the_refinement_step_sees_through_a_rough_likelihood():
    """The finer model's Gaussian peak half an sd from the coarse optimum in each coordinate, with
    ripples of 0.2 nats (:class:`RoughGaussianPosterior`): one Newton step finds the move to 0.1
    sd (SHIFT_TOLERANCE) in each coordinate, its gradient's differences taken over about six
    conditional sds (ripple error about 0.2 / 6 sd). Over a fixed step of 1e-4 the ripple's
    slope would make the 0.3-sd coordinate move by hundreds of sds."""
    coarse = np.array([3.8, -2.0, -1.7])
    finer = RoughGaussianPosterior(coarse + 0.5 * SDS, COV, amplitude=0.2)
    shift = newton_shift(finer, coarse, COV)
    assert np.all(np.abs(shift - 0.5 * SDS) / SDS < 0.1), (shift - 0.5 * SDS) / SDS


def test_the_refinement_step_holds_a_coordinate_against_a_constraint():
    """The coarse optimum sits against a constraint (-inf half a step below it in the first
    coordinate); the finer model's peak lies elsewhere. The Newton step holds the constrained
    coordinate (shift 0) and moves the others to the finer Gaussian's conditional peak given it,
    which for a Gaussian one Newton step reaches exactly (to 1e-6 of each sd: central
    differences of a quadratic err by rounding only), where the plain step had no finite gradient
    and reported an infinite shift. -inf on both sides stays inf: no step can be taken."""
    sds = np.array([1e-3, 1e-2, 0.3])
    cov = CORRELATION * np.outer(sds, sds)
    coarse = np.array([0.5, -2.0, -1.7])
    finer = GaussianPosterior(coarse + [2e-4, 3e-3, -0.05], cov, floor=0.5 - 5e-5)
    shift = newton_shift(finer, coarse, cov)
    held, free = [0], [1, 2]
    conditional_peak = finer.mean[free] + cov[np.ix_(free, held)] @ np.linalg.solve(
        cov[np.ix_(held, held)], coarse[held] - finer.mean[held])
    assert shift[0] == 0.0
    np.testing.assert_allclose(shift[free], conditional_peak - coarse[free], rtol=0, atol=1e-6 * sds[free].min())
    walled = GaussianPosterior(finer.mean, cov, floor=np.inf)
    assert np.all(np.isinf(newton_shift(walled, coarse, cov)))


def test_the_global_search_starts_where_every_in_band_mode_is_placed():
    """On the shipped 4 s hammer record (paper beam, nine modes below the default band's 778 Hz)
    the search starts at the coarsest rung whose in-band natural frequencies turn no mode's
    phase by more than START_PHASE over the window against the ladder's top rung, measured here
    from the rungs' damped poles at the recording's truth (another eigenproblem than the
    undamped one the rule uses, equal to ~zeta^2): the quintic N = 24 at the full band, where
    N = 16 turns the ninth mode by 2.6 rad; N = 8 at 150 Hz (four modes)."""
    rec = load_recording(EXAMPLES / "paper_q3_hammer")
    truth = {"EI": 44.28, "gamma": 0.12, "a": 0.025, "b": 0.18}
    ladder = N_LADDERS[5]
    for band, expected in ((None, 24), (150.0, 8)):
        config = FitConfig(max_frequency=band)
        assert starting_rung(rec, "q3", config) == expected
        top = prepare(rec, "q3", config, ladder[-1])
        reference = top.model.natural_frequencies(truth)
        reference = reference[reference < top.likelihood.projection.max_frequency]
        assert phase(rec, config, reference, truth, expected) <= START_PHASE
        if expected != ladder[0]:
            assert phase(rec, config, reference, truth, ladder[ladder.index(expected) - 1]) > START_PHASE


def phase(rec, config, reference, truth, n) -> float:
    """The largest phase (rad) over the 4 s record by which rung n's damped natural frequencies
    at ``truth`` miss ``reference``."""
    f = prepare(rec, "q3", config, n).model.natural_frequencies(truth)[:reference.size]
    return float(np.max(2 * np.pi * 4.0 * np.abs(f - reference)))


class _StandardNormal:
    """A 2-d standard normal log density, the cheapest target emcee can be run on."""

    ndim = 2

    def __call__(self, theta):
        return -0.5 * float(np.sum(np.square(theta)))

    def log_prob_batch(self, thetas):
        return -0.5 * np.sum(np.square(thetas), axis=1)


def _run(max_steps, out):
    optimum = Optimum(np.zeros(2), 0.0, np.eye(2), 0)
    return run_emcee(_StandardNormal(), optimum, np.random.default_rng(2), n_walkers=8, max_steps=max_steps,
                     chunk=50, progress=Progress(file=out))


def test_a_chain_cut_short_says_how_many_steps_it_needs():
    """100 steps at tau of a few steps is shorter than 50 tau: the reason names the steps needed
    and the flag; the bar shows the chain's figures."""
    out = io.StringIO()
    chains = _run(100, out)
    assert not chains.converged
    needed = int(50 * np.max(chains.tau))
    assert needed > 100 and f"about {needed} steps are needed; raise --max-steps" in chains.reason
    assert "sampling (emcee)" in out.getvalue() and "max tau" in out.getvalue()


def test_a_converged_chain_ends_its_bar_at_the_steps_taken():
    """The bar's total is re-estimated as 50 x tau: a converged chain closes it full (n/n)."""
    out = io.StringIO()
    chains = _run(20000, out)
    assert chains.converged and chains.n_steps < 20000
    assert f"{chains.n_steps}/{chains.n_steps}" in out.getvalue()


def test_the_other_reasons_name_their_cause():
    tau = np.array([10.0, 20.0])
    assert "still moved 100 %" in unconverged_reason(tau, np.array([10.0, 40.0]), 2000, 50.0)
    assert "no finite autocorrelation time" in unconverged_reason(np.array([np.nan, 1.0]), None, 500, 50.0)
    assert "too few to see it settle" in unconverged_reason(tau, None, 2000, 50.0)
