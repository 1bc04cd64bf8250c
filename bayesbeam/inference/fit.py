"""One call from a recording to a posterior: ``bayesbeam.fit(rec, "q3") -> FitResult``.

Steps: window and anti-aliased decimation of the recording, the discretisation N (chosen
automatically unless given), priors (defaults overridden by a fit file), the robust optimum,
converged emcee chains, and the results as arviz InferenceData plus a JSON summary.
"""
from __future__ import annotations

import tomllib
from dataclasses import dataclass, field, fields
from pathlib import Path

import numpy as np

from bayesbeam.inference.likelihood import NOISE_MODELS, BandProjection, Likelihood
from bayesbeam.inference.posterior import UNEVALUABLE, LogPosterior
from bayesbeam.inference.priors import Prior, default_priors, noise_prior, prior_from_table
from bayesbeam.inference.sampler import (
    EI_SCAN,
    Chains,
    Optimum,
    find_optimum,
    newton_shift,
    rescan_ei,
    run_emcee,
)
from bayesbeam.io import RecordingError
from bayesbeam.model import BeamModel
from bayesbeam.progress import as_progress
from bayesbeam.response.linear import PASSBAND
from bayesbeam.response.signals import EDGE, decimate, force_noise, release_rest

#: refinement ladders for the automatic choice of N, per spline degree; the quintic's rungs reach
#: the cubic's in-band response accuracy with a third to a fifth of the intervals (benchmarks/basis.py)
N_LADDERS = {3: (16, 24, 32, 48, 64), 5: (8, 12, 16, 24, 32)}
#: refining N must move every parameter's optimum by less than this many posterior sd
SHIFT_TOLERANCE = 0.1
#: ... and change the log posterior at the optimum by less than this many nats: a spline error
#: that shifts the log posterior nearly uniformly moves no optimum but enters log Z whole, and
#: models compared at different N would carry it into ln B. Half a nat keeps it below the
#: evidence estimates' own spread. On paper_rootcomp_hammer q3 at N = 8 passes the shift check
#: (0.08 sd) while its log posterior there lies 7.9 nats above N = 32's, the coarse grid's error
#: acting as the root compliance q3 lacks (tests/inference/test_fit_outputs.py)
LEVEL_TOLERANCE = 0.5
#: the global search runs on the coarsest rung at which no in-band mode's frequency error (against
#: the top rung) turns its phase by more than this many radians over the fitted window
#: (:func:`starting_rung`): the likelihood of EI is multimodal on the scale of a cycle, and a rung
#: that misplaces a mode has other modes. On the full band of paper_q3_hammer (0.38 fs, nine
#: modes, 4 s) the quintic N = 8 misplaces the ninth mode by 37 %, and a search there settled q3
#: on damping ten times the truth that smears the misplaced peaks, a mode no polish up the
#: ladder left; N = 16 turns the ninth mode by 2.6 rad, N = 24 by 0.04 rad
START_PHASE = 1.0
#: default fitting band as a fraction of the sampling rate: below the DAQ passband edge 0.40
DEFAULT_BAND = 0.38
#: records longer than this (after windowing) are decimated by default to keep fits tractable
MAX_DEFAULT_SAMPLES = 2**15
#: fewest samples of the fitted window at the decimated rate: the band below max_frequency then
#: holds about 0.4 x 64 = 25 frequencies of the window's DFT
MIN_FIT_SAMPLES = 64


@dataclass
class FitConfig:
    """Everything that shapes a fit besides the recording and the model.

    start, stop: fitted window (s; default: the whole record, from ``start`` for a free decay);
    max_frequency: top of the fitted band (Hz; default 0.38 fs, lowered for records longer than
    32768 samples); n_intervals: spline intervals N or None for automatic; degree: the splines'
    polynomial degree (3 or 5, see :data:`N_LADDERS`); noise: "white" or
    "ar1"; block: samples per likelihood block (default: up to 16 blocks of >= 256 samples
    covering the window); walkers, max_steps,
    tau_factor: emcee settings; seed; effects: missing-physics effects to add; force_window: the
    impact window on a measured force (None: on); force_noise: marginalise the response driven by
    the noise of the windowed force samples (on by default; it does nothing for a clean force
    channel, and needs the window); priors: overrides.
    """

    start: float | None = None
    stop: float | None = None
    max_frequency: float | None = None
    n_intervals: int | None = None
    degree: int = 5
    noise: str = "white"
    block: int | None = None
    walkers: int | None = None
    max_steps: int = 20000
    tau_factor: float = 50.0
    seed: int = 1
    effects: tuple[str, ...] = ()
    force_window: bool | None = None
    force_noise: bool = True
    priors: dict[str, Prior] = field(default_factory=dict)

    def __post_init__(self):
        if self.noise not in NOISE_MODELS:
            raise ValueError(f"noise = {self.noise!r}: expected one of {NOISE_MODELS}")
        if self.degree not in N_LADDERS:
            raise ValueError(f"degree = {self.degree!r}: expected one of {sorted(N_LADDERS)} (spline degrees "
                             "with a refinement ladder for the automatic choice of N). Fix: set degree "
                             "(under [fit] in a fit file) to one of these")
        self.effects = tuple(self.effects)


def load_fit_config(path, **overrides) -> FitConfig:
    """A FitConfig from a TOML fit file (``[fit]`` settings, ``[prior.NAME]`` tables)."""
    path = Path(path)
    try:
        doc = tomllib.loads(path.read_text())
    except FileNotFoundError:
        raise ValueError(f"{path}: fit file not found. Fix: check the path given to --config") from None
    except tomllib.TOMLDecodeError as exc:
        raise ValueError(f"{path}: {exc}. Fix: correct the TOML syntax there") from None
    tables = sorted(set(doc) - {"fit", "prior"})
    if tables:
        raise ValueError(f"{path}: unknown table(s) {tables}. Fix: use [fit] for settings and "
                         f"[prior.NAME] for priors")
    settings = dict(doc.get("fit", {}))
    known = {f.name for f in fields(FitConfig)} - {"priors"}
    unknown = sorted(set(settings) - known)
    if unknown:
        raise ValueError(f"{path}: [fit] has unknown key(s) {unknown}. Fix: use only {sorted(known)}")
    priors = {name: prior_from_table(name, table, str(path)) for name, table in doc.get("prior", {}).items()}
    settings.update({k: v for k, v in overrides.items() if v is not None})
    return FitConfig(priors=priors, **settings)


@dataclass
class Problem:
    """A recording prepared for one model: the (decimated) model, its likelihood and posterior."""

    model: BeamModel
    likelihood: Likelihood
    posterior: LogPosterior
    decimation: int


#: the radices of numpy's FFT (pocketfft): a length with no other prime factor is transformed
#: without Bluestein's algorithm, which costs several times as much
FFT_RADICES = (2, 3, 5, 7, 11)


def fast_length(n: int) -> int:
    """The largest length <= n whose prime factors are all in :data:`FFT_RADICES`.

    >>> fast_length(302), fast_length(1511), fast_length(256)
    (300, 1500, 256)
    """
    def smooth(m: int) -> bool:
        for p in FFT_RADICES:
            while m % p == 0:
                m //= p
        return m == 1

    return next(m for m in range(n, 0, -1) if smooth(m))


def prepare(rec, mechanisms, config: FitConfig, n_intervals: int) -> Problem:
    """Window, decimate, and build the model, likelihood and posterior at N = n_intervals."""
    _check_channels(rec)
    factor, f_max = _band(rec, config)
    # a hit near the start: the decimating low-pass spreads its force back before the record,
    # and the model must be driven by that part too (signals.decimate)
    lead = EDGE if factor > 1 and rec.excitation.kind == "force" else 0
    data = decimate(rec, factor, force_window=config.force_window, lead=lead, rest=release_rest(rec))
    model = BeamModel.from_recording(data, mechanisms, n_intervals, force_window=False,
                                     effects=config.effects, degree=config.degree)
    i0, i1 = _window(data, config, edge=EDGE if factor > 1 else 0, first=rec.time[0])
    _check_length(rec, i1 - i0, factor, f_max)
    # default: up to 16 blocks of at least 256 samples that cover the window but for its last
    # samples: each block the longest whose FFT needs no prime factor above 11 (a block of 302 =
    # 2 x 151 takes numpy's FFT ten times as long as one of 300); the samples left over, under
    # 4 % of the window, are the end of the record; an explicit block longer than the window is refused
    n_blocks = int(np.clip((i1 - i0) // 256, 1, 16))
    block = config.block or fast_length((i1 - i0) // n_blocks)
    projection = BandProjection(data.fs, i0, i1, block, f_max)
    noise_in_force = (force_noise(rec, factor, lead) if config.force_noise and config.force_window is not False
                      else None)
    likelihood = Likelihood(model, projection, config.noise, noise_in_force)
    priors = default_priors(rec.beam, model.parameter_names, likelihood.channel_rms, rec.setup)
    for name in likelihood.noise_names:
        if name.startswith("phi_"):
            priors[name] = noise_prior("phi")
    unknown = sorted(set(config.priors) - set(priors))
    if unknown:
        raise ValueError(f"prior given for {unknown}, which model {model.name} does not have; "
                         f"its parameters: {list(priors)}")
    priors.update(config.priors)
    return Problem(model, likelihood, LogPosterior(likelihood, priors), factor)


def _band(rec, config: FitConfig) -> tuple[int, float]:
    """(decimation factor, top of the fitted band in Hz)."""
    t0 = config.start if config.start is not None else rec.time[0]
    t1 = config.stop if config.stop is not None else rec.time[-1]
    n_window = int((t1 - t0) * rec.fs) + 1
    f_max = config.max_frequency
    if f_max is None:
        f_max = DEFAULT_BAND * rec.fs
        if n_window > MAX_DEFAULT_SAMPLES:
            f_max = DEFAULT_BAND * rec.fs / int(np.ceil(n_window / MAX_DEFAULT_SAMPLES))
    if not 0 < f_max <= DEFAULT_BAND * rec.fs:
        raise ValueError(f"max_frequency = {f_max} Hz: must be positive and at most {DEFAULT_BAND} fs = "
                         f"{DEFAULT_BAND * rec.fs:.6g} Hz (the DAQ's passband ends at 0.40 fs)")
    factor = max(1, int(np.floor(PASSBAND * rec.fs / f_max)))
    return factor, f_max


def _check_length(rec, n_fitted: int, factor: int, f_max: float) -> None:
    """Refuse a record too short for the requested band (RecordingError naming the flags to change)."""
    if n_fitted >= MIN_FIT_SAMPLES:
        return
    edge = EDGE if factor > 1 else 0
    needed = (MIN_FIT_SAMPLES + edge) * factor / rec.fs
    raise RecordingError(
        rec.source or "recording", "the fitted window",
        f"{rec.n_samples} samples at {rec.fs:.6g} Hz leave {max(n_fitted, 0)} samples to fit below "
        f"{f_max:.6g} Hz (decimated by {factor}, less the last {edge} that the low-pass disturbs); "
        f"at least {MIN_FIT_SAMPLES} are needed",
        f"fit a window of at least {needed:.3g} s (--start/--stop, or a longer record), or raise --max-frequency",
    )


def _window(data, config: FitConfig, edge: int, first: float) -> tuple[int, int]:
    """(i0, i1) of the fitted samples of ``data``; by default from ``first`` (s), the recording's
    start (a decimated record's lead before it is not fitted)."""
    time = data.time
    start = config.start if config.start is not None else first
    if data.excitation.kind == "free_decay":
        start = max(start, data.excitation.start)
    stop = config.stop if config.stop is not None else time[-1]
    if not (first <= start < stop and start < time[-1]):
        raise ValueError(f"fit window start = {start} s, stop = {stop} s: need "
                         f"{first} <= start < stop <= {time[-1]} s")
    i0 = int(np.searchsorted(time, start))
    i1 = min(int(np.searchsorted(time, stop, side="right")), data.n_samples - edge)
    return i0, i1


def _check_channels(rec):
    if rec.n_samples < 2 or not len(rec.sensors):
        raise ValueError(f"{rec.source}: the recording has no sensor channel to fit")


# ---------------------------------------------------------------------------- the fit
@dataclass
class FitResult:
    """A fitted posterior: the problem, optimum, chains, InferenceData and summary."""

    recording: object
    model_spec: str
    problem: Problem
    optimum: Optimum
    chains: Chains
    discretisation: dict
    config: FitConfig
    idata: object = None
    summary: dict = field(default_factory=dict)

    @property
    def converged(self) -> bool:
        return self.chains.converged

    def values(self) -> np.ndarray:
        """Posterior samples as physical values: (n_walkers, n_draws, ndim)."""
        post = self.problem.posterior
        out = np.empty_like(self.chains.samples)
        for i, p in enumerate(post.priors):
            out[..., i] = p.to_value(self.chains.samples[..., i])
        return out


def fit(rec, model="q1", config: FitConfig | None = None, *, pool=None, backend_path=None,
        resume: bool = False, log=None) -> FitResult:
    """Sample the posterior of ``model``'s parameters given ``rec``.

    ``model``: a preset (``"q1"``, ``"q2"``, ``"q3"``), ``+``-joined mechanisms or a list.
    ``pool``: any object with ``map`` whose workers ran :func:`~bayesbeam.inference.sampler.init_worker`
    (see :func:`~bayesbeam.inference.sampler.local_pool`). ``log``: a
    :class:`~bayesbeam.progress.Progress` (notes, and a bar for the chains with the time left), a
    callable taking a line of text, or None (silent).
    """
    from bayesbeam.inference.results import build_inference_data, build_summary

    config = config or FitConfig()
    rng = np.random.default_rng(config.seed)
    problem, optimum, discretisation = choose_discretisation(rec, model, config, rng, log)
    owned = isinstance(pool, int) or hasattr(pool, "factory")
    pool = _pool_for(pool, problem.posterior) if pool is not None else None
    try:
        chains = run_emcee(problem.posterior, optimum, rng, n_walkers=config.walkers,
                           max_steps=config.max_steps, tau_factor=config.tau_factor, pool=pool,
                           backend_path=backend_path, resume=resume, progress=log)
    finally:
        if owned and pool is not None:
            (pool.shutdown if hasattr(pool, "shutdown") else pool.close)()
    if not chains.converged:
        as_progress(log)(f"chains NOT converged: {chains.reason}")
    result = FitResult(rec, model if isinstance(model, str) else "+".join(model), problem, optimum,
                       chains, discretisation, config)
    result.idata = build_inference_data(result, rng)
    result.summary = build_summary(result)
    return result


def _pool_for(pool, posterior):
    """A ready pool; an int (that many local processes); or an object with ``factory(posterior)``."""
    if isinstance(pool, int):
        from bayesbeam.inference.sampler import local_pool

        return local_pool(posterior, pool) if pool > 1 else None
    if hasattr(pool, "factory"):
        return pool.factory(posterior)
    return pool


def choose_discretisation(rec, model, config: FitConfig, rng, log=None, start: dict | None = None,
                          search: bool = True):
    """(problem, optimum, record) at the N the data need; see :data:`SHIFT_TOLERANCE` and
    :data:`LEVEL_TOLERANCE`.

    ``start`` (parameter values by name, e.g. a nested model's optimum extended by an effect's
    value) adds local optimisations to the global one: from ``start``, and from ``start`` with EI
    re-determined by the global search's EI search with every other parameter held there
    (:func:`~bayesbeam.inference.sampler.rescan_ei`: the start's EI is the other model's, and
    can sit in the wrong basin of EI's trade-off with the start's effect); the highest optimum
    is kept. ``search`` False (with a ``start``) leaves the global search out: the local
    optimisations alone, for a model whose global search has already run.

    The global search runs at the coarsest N that places every in-band mode
    (:func:`starting_rung`). The optimum at N is compared with the optimum at the next finer N, estimated by one Newton
    step of the finer model's log posterior from the coarse optimum (exact to second order in the
    shift, which is small exactly when the check passes). While the check fails, the Newton
    estimate, polished by a local optimisation, moves up the ladder (:data:`N_LADDERS`, per degree). With
    ``config.n_intervals`` set, that N is used and the check is still recorded, so a user can
    see whether the fixed N is adequate; at the top of the ladder a failed check is reported as
    such (``passed: false``), never hidden.

    The climb also stops, failed and marked ``stalled``, when a rung's error (:func:`_excess`: its
    shift or its level change, whichever is the larger multiple of its tolerance) is no smaller
    than the rung's below: spline error shrinks as N grows (as N^-6 and faster for a quintic's
    frequencies), so an error that does not is not the discretisation's. A likelihood with many
    sharp local maxima (stick-slip friction on a long record) moves its optimum by a few tenths
    of an sd, or by tens of sd, at every rung, and climbing would only make every later
    evaluation dearer. The rung below is then returned, with its own check and the stalled
    check's largest shift (``finer_max_shift_sd``): the finer rung was no closer to the limit,
    and the coarser one costs less per evaluation.
    """
    ladder = N_LADDERS[config.degree]
    problem = prepare(rec, model, config, config.n_intervals or starting_rung(rec, model, config, log))
    if not (search or start):
        raise ValueError("choose_discretisation: a local optimisation alone (search=False) needs a start")
    optimum = find_optimum(problem.posterior, rng, log=log, ridges=start is None) if search else None
    for point in local_starts(problem.posterior, start):
        local = find_optimum(problem.posterior, rng, start=point, log=log)
        optimum = local if optimum is None or local.log_posterior > optimum.log_posterior else optimum
    below = None                        # the rung below: (problem, optimum, its check's record)
    while True:
        n = problem.model.n_intervals
        finer_n = ladder[ladder.index(n) + 1] if n in ladder[:-1] else int(1.5 * n)
        finer = prepare(rec, model, config, finer_n)
        record, moved = _refinement_check(problem, finer, optimum, config, log)
        record["stalled"] = False
        if below is not None and not record["passed"] and _excess(record) >= _excess(below[2]):
            if log:
                log(f"N = {n} moved the optimum no less than N = {below[0].model.n_intervals} did: not the "
                    f"discretisation's error; N = {below[0].model.n_intervals} kept")
            finer_shift = record["max_shift_sd"]
            problem, optimum, record = below
            record.update(stalled=True, finer_max_shift_sd=finer_shift)
            break
        if record["passed"] or config.n_intervals or finer_n > ladder[-1]:
            break
        below = (problem, optimum, record)
        theta = optimum.theta + np.where(np.isfinite(moved), moved, 0.0)
        # a failed check can mean a long Newton step: keep it only where the finer model is better
        if not finer.posterior(theta) > finer.posterior(optimum.theta):
            theta = optimum.theta
        # polished at every rung: EI's likelihood is too narrow and curved for Newton steps to be
        # carried up the ladder, and a check from a point that is not the optimum measures that
        # point's error, not the discretisation's
        problem = finer
        k = len(problem.posterior.model_names)
        optimum = find_optimum(problem.posterior, rng, start=problem.posterior.split(theta)[0],
                               scale=optimum.covariance[:k, :k], log=log)
    return problem, optimum, record


def local_starts(post: LogPosterior, start: dict | None, scan_points: int = 321) -> list[dict]:
    """The points :func:`choose_discretisation` polishes from besides its global search: none
    without ``start``; else ``start`` and ``start`` with EI rescanned (:func:`rescan_ei`), the
    latter left out when its log EI lies within one scan step of the start's (the same basin:
    EI's likelihood is multimodal on a 0.1 % scale, the step is 0.025 %)."""
    if start is None:
        return []
    rescanned = rescan_ei(post, start, scan_points)
    ei = post.priors[0]
    moved = abs(ei.to_coordinate(rescanned[post.model_names[0]]) - ei.to_coordinate(start[post.model_names[0]]))
    return [start, rescanned] if moved > 2 * EI_SCAN / (scan_points - 1) else [start]


def starting_rung(rec, model, config: FitConfig, log=None) -> int:
    """The coarsest N of the ladder at which every in-band natural frequency f_m lies so close to
    the ladder top's that its error turns the mode's phase by at most :data:`START_PHASE` over the
    fitted window T: 2 pi f_m |error_m| T (taken at the priors' medians: every stiffness scales
    with EI, so the relative errors hardly depend on where). The ladder's first rung when the
    model cannot be evaluated at the medians."""
    ladder = N_LADDERS[config.degree]
    finest = prepare(rec, model, config, ladder[-1])
    projection = finest.likelihood.projection
    window = projection.n_blocks * projection.block / finest.model.recording.fs
    try:
        top = _in_band_frequencies(finest)
        for n in ladder[:-1]:
            f = _in_band_frequencies(prepare(rec, model, config, n), len(top))
            phase = 2 * np.pi * window * np.abs(f - top[:f.size])
            if f.size == top.size and np.all(phase <= START_PHASE):
                return n
            if log:
                log(f"N = {n} turns an in-band mode's phase by {phase.max():.2g} rad over the window: "
                    f"the global search starts finer")
    except UNEVALUABLE:
        return ladder[0]
    return ladder[-1]


def _in_band_frequencies(problem: Problem, n_modes: int | None = None) -> np.ndarray:
    """Undamped natural frequencies (Hz) at the priors' medians: those below the fitted band's
    top, or the lowest ``n_modes``."""
    post = problem.posterior
    params, _ = post.split(np.array([p.median() for p in post.priors]))
    f = np.sqrt(np.abs(problem.model.system(params).undamped[0])) / (2 * np.pi)
    return f[:n_modes] if n_modes is not None else f[f < problem.likelihood.projection.max_frequency]


def _refinement_check(problem: Problem, finer: Problem, optimum: Optimum, config: FitConfig, log=None):
    """(the check's record, the Newton estimate of the optimum's move from N to the finer N)."""
    k = len(problem.posterior.model_names)
    n, finer_n = problem.model.n_intervals, finer.model.n_intervals
    moved = newton_shift(finer.posterior, optimum.theta, optimum.covariance)
    shift = np.abs(moved[:k]) / np.sqrt(np.diag(optimum.covariance)[:k])
    # at the coarse optimum: the finer optimum's level differs by half the Newton step's quadratic
    # form, under 0.01 k nats while every shift is under the tolerance
    level = float(finer.posterior(optimum.theta)) - optimum.log_posterior
    record = {"n_intervals": n, "refined_n_intervals": finer_n, "degree": problem.model.degree,
              "tolerance_sd": SHIFT_TOLERANCE,
              "max_shift_sd": float(np.max(shift)),
              "shift_sd": dict(zip(problem.posterior.model_names, map(float, shift))),
              "level_change_nats": level, "level_tolerance_nats": LEVEL_TOLERANCE,
              "passed": bool(np.max(shift) < SHIFT_TOLERANCE and abs(level) < LEVEL_TOLERANCE),
              "automatic": not config.n_intervals}
    if log:
        log(f"N = {n} vs {finer_n}: largest optimum shift {np.max(shift):.3g} posterior sd, "
            f"log posterior at the optimum {level:+.3g} nats")
    return record, moved


def _excess(record: dict) -> float:
    """A check's error as the larger multiple of its tolerance: the largest shift against
    :data:`SHIFT_TOLERANCE`, the level change against :data:`LEVEL_TOLERANCE` (it passes below 1)."""
    return max(record["max_shift_sd"] / SHIFT_TOLERANCE, abs(record["level_change_nats"]) / LEVEL_TOLERANCE)
