r"""From a robust optimum to converged emcee chains.

1. **Optimum.** The likelihood of EI is sharply multimodal (0.5% in EI shifts the phase of a
   127 Hz mode by a cycle over 2 s) and the damping surface is narrow and curved. So: EI from
   the data's spectral peaks (:func:`spectral_ei`), refined by a likelihood scan over +-4% in
   steps of 0.025% with the damping at its prior medians and any missing-physics effect where it
   vanishes, then differential evolution over all
   model parameters with EI kept within +-0.5% (the scan's points and each generation's members
   evaluated together, :meth:`LogPosterior.profiled_batch`), then a Nelder-Mead polish, restarted with a
   simplex two Laplace sds wide per coordinate (:func:`_restart`); the noise levels are
   profiled out throughout (:meth:`LogPosterior.profiled`). The restart is for a posterior with
   a flat shoulder: q3's (a, b) ridge ends in a plateau toward the Kelvin-Voigt limit (small b),
   3 nats below the peak on a 1 s record and tens of e-folds of prior volume wide, where a whole
   differential-evolution population can settle and a polish started there stalls on the
   plateau's slope of 0.06 nats per decade of b; a simplex as wide as the Laplace sds there
   (large along the ridge) walks up to the peak. A model with missing-physics effects is
   polished once more from the best point of an EI ridge (:func:`_ridge_start`): each effect
   parameter at a few places across its prior with EI rescanned there, where that moves the
   peaks' EI out of the evolution's window (a compliant root wants a stiffer beam); the higher
   optimum is kept.
2. **Scale.** A finite-difference Hessian of the log posterior at the optimum gives the
   Laplace covariance, which seeds the walkers (a ball of 0.1 x the Laplace sd) and is kept for
   the discretisation check and the cheap evidence screens.
3. **Sampling.** ``emcee.EnsembleSampler`` in chunks; after each chunk the integrated
   autocorrelation time tau of every parameter is estimated (emcee's windowed estimator). The run
   has *converged* when the chain is longer than ``tau_factor`` (50) x max tau and tau changed by
   less than 5% since the previous chunk; it stops at ``max_steps`` otherwise and says so.
   Burn-in: 3 max tau. Thinning: tau/2. Chunks end at multiples of the chunk length, and a run
   resumed from its HDF5 backend (which holds the last step's random state) starts from the saved
   chain's tau at its last such multiple: it ends with the chain an uninterrupted run ends with.

Parallel evaluation goes through any object with a ``map`` (``multiprocessing.Pool``,
``concurrent.futures`` executors, ``mpi4py.futures.MPIPoolExecutor``, schwimmbad pools). The log
posterior is sent to each worker once, by the pool's initializer, and evaluated there through the
module-level :func:`worker_log_prob`: never pickled per call. The walkers of each half-step are
evaluated together (:meth:`LogPosterior.log_prob_batch`, emcee's ``vectorize``): in this process,
or split into one chunk per worker of a ``multiprocessing`` pool or ``concurrent.futures``
executor (:class:`PooledBatch`); ``BAYESBEAM_BATCH=0`` evaluates them one by one.
"""
from __future__ import annotations

import time
from dataclasses import dataclass

import emcee
import numpy as np
from scipy import optimize

from bayesbeam.inference.backend import BufferedHDFBackend
from bayesbeam.inference.posterior import UNEVALUABLE, LogPosterior, batching
from bayesbeam.progress import as_progress

_WORKER_POSTERIOR: LogPosterior | None = None


def init_worker(posterior: LogPosterior) -> None:
    """Pool initializer: keep this worker's copy of the log posterior."""
    global _WORKER_POSTERIOR
    _WORKER_POSTERIOR = posterior


def worker_log_prob(theta) -> float:
    """Evaluate the worker's log posterior (set by :func:`init_worker`)."""
    return _WORKER_POSTERIOR(theta)


def worker_log_prob_batch(thetas) -> np.ndarray:
    """The worker's log posterior at each row of ``thetas``, evaluated together."""
    return _WORKER_POSTERIOR.log_prob_batch(thetas)


class PooledBatch:
    """emcee's vectorized log probability over a pool: the walkers split into one chunk per worker,
    each evaluated together in its worker (:func:`worker_log_prob_batch`)."""

    def __init__(self, pool, workers: int):
        self.pool, self.workers = pool, workers

    def __call__(self, thetas) -> np.ndarray:
        chunks = [c for c in np.array_split(np.asarray(thetas), self.workers) if len(c)]
        return np.concatenate(list(self.pool.map(worker_log_prob_batch, chunks)))


def pool_workers(pool) -> int | None:
    """Workers of a ``multiprocessing`` pool or a ``concurrent.futures`` executor; None for a pool
    that does not say (its walkers are then sent one by one)."""
    return getattr(pool, "_processes", None) or getattr(pool, "_max_workers", None)


def worker_terms(theta) -> tuple[float, float]:
    """(log prior, log likelihood) of the worker's log posterior, for tempered samplers."""
    return _WORKER_POSTERIOR.terms(theta)


def local_pool(posterior: LogPosterior, processes: int):
    """A process pool whose workers each hold one copy of ``posterior``."""
    import multiprocessing as mp

    return mp.get_context("spawn").Pool(processes, initializer=init_worker, initargs=(posterior,))


# ---------------------------------------------------------------------------- optimum
@dataclass
class Optimum:
    theta: np.ndarray          # full parameter vector, sampling coordinates
    log_posterior: float
    covariance: np.ndarray     # Laplace covariance in sampling coordinates
    n_evaluations: int
    #: per coordinate, whether the log posterior is rough along it there (took the long step of
    #: :func:`difference_steps`); None where not known
    rough: np.ndarray | None = None


def find_optimum(post: LogPosterior, rng: np.random.Generator, *, scan_points: int = 321,
                 de_iterations: int = 40, start: dict | None = None, scale: np.ndarray | None = None,
                 ridges: bool = True, log=None) -> Optimum:
    """Robust maximum a posteriori estimate (see module docstring).

    ``start`` (model parameter values by name) replaces the global stages by a local polish
    from that point, e.g. from the optimum of a coarser discretisation; ``scale`` (model
    coordinates, k x k), a covariance of the posterior near there, e.g. that coarser optimum's
    Laplace covariance, sets the polish's simplex (default: the curvature at the start).
    ``ridges`` False leaves out the global stage's polish from an effect's EI ridge
    (:func:`_ridge_start`), for a caller that polishes from a start of its own in that basin.
    """
    k = len(post.model_names)
    counter = _Counter(post.profiled, post.profiled_batch)
    bounds = [p.bounds() for p in post.priors[:k]]
    if start is not None:
        x0 = _coordinates(post, start)
    else:
        x0 = _neutral_start(post)
        guess, x0[0] = _search_ei(post, counter, x0, scan_points)
        neutral = x0.copy()
        _say(log, f"EI from spectral peaks {np.exp(guess):.5g}, refined by a likelihood scan to "
                  f"{np.exp(x0[0]):.5g} N m^2 ({counter.calls} evaluations)")
    if k > 1 and start is None:
        narrow = [(x0[0] - EI_WINDOW, x0[0] + EI_WINDOW)] + bounds[1:]
        # the population's members are evaluated together (vectorized: x is (k, members))
        de = optimize.differential_evolution(lambda x: -counter.many(x.T), narrow,
                                             x0=np.clip(x0, *np.array(narrow).T), maxiter=de_iterations,
                                             popsize=10, tol=1e-8, polish=False, seed=int(rng.integers(2**31)),
                                             init="sobol", vectorized=True, updating="deferred")
        x0 = de.x
        _say(log, f"differential evolution: log posterior {-de.fun:.6g} ({counter.calls} evaluations)")
    if scale is None:
        scale = _search_scale(counter, x0, bounds)
    full, (cov, rough) = _polished(post, counter, _nelder_mead(counter, x0, _simplex_edges(scale, bounds)))
    if start is None and k > 1:
        x = _restart(counter, full[:k], np.sqrt(np.diag(cov)[:k]), bounds)
        if x is not None:
            full, (cov, rough) = _polished(post, counter, x)
            _say(log, "restarted polish moved the optimum")
    value = post(full)
    ridge = _ridge_start(post, counter, neutral, guess, scan_points) if ridges and start is None and k > 1 else None
    if ridge is not None:
        trial, (trial_cov, trial_rough) = _polished(
            post, counter, _nelder_mead(counter, ridge, _simplex_edges(_search_scale(counter, ridge, bounds), bounds)))
        trial_value = post(trial)
        if trial_value > value:
            full, value, cov, rough = trial, trial_value, trial_cov, trial_rough
            _say(log, "the polish from an effect's EI ridge found a higher optimum")
    _say(log, f"optimum: log posterior {value:.6g} ({counter.calls} evaluations)")
    return Optimum(full, value, cov, counter.calls, rough)


def _nelder_mead(counter, x0, edges) -> np.ndarray:
    """Nelder-Mead maximum of the profiled log posterior from ``x0`` (model coordinates), run in
    the coordinates u of x = x0 + edges @ u: the initial simplex is x0 and x0 plus each column
    of ``edges`` (k x k), and the tolerance on u is a thousandth of an edge.

    Why: the posterior's widths differ by orders of magnitude between coordinates (log EI's sd
    is ~1e-5, a damping term's ~0.1) and along its ridges, and SciPy's default simplex (5 % of
    each coordinate) is thousands of sds wide in EI. The value tolerance, 1e-4 nats, lies above
    the profiled log posterior's rounding noise (~2e-5 nats on a value of ~1e4 at the full band
    of a 4 s record); below it the simplex wanders on the noise. From 1 sd off q3's optimum at
    N = 24 on that band: 1600 evaluations (the cap) with the default simplex and 1e-6 nats, 411
    with the default simplex and 1e-4, 164 with these edges.
    """
    options = {"xatol": 1e-3, "fatol": 1e-4, "maxfev": 400 * len(x0), "adaptive": True,
               "initial_simplex": np.vstack([np.zeros(len(x0)), np.eye(len(x0))])}
    u = optimize.minimize(lambda u: -counter(x0 + edges @ u), np.zeros(len(x0)), method="Nelder-Mead",
                          options=options).x
    return x0 + edges @ u


def _simplex_edges(covariance, bounds) -> np.ndarray:
    """Edges two posterior sds long along the principal axes of ``covariance`` (k x k), each at
    most an eighth of the narrowest prior support it crosses."""
    widths = np.array([high - low for low, high in bounds])
    eigenvalues, axes = np.linalg.eigh(0.5 * (covariance + covariance.T))
    edges = axes * (2 * np.sqrt(np.clip(eigenvalues, 0.0, None)))
    reach = np.abs(edges) / (widths[:, None] / 8)
    return edges / np.maximum(reach.max(axis=0), 1.0)


def _search_scale(counter, x, bounds) -> np.ndarray:
    """A covariance to shape the polish's simplex when none is known: the inverse curvature of the
    profiled log posterior along each coordinate at ``x`` (an eighth of the prior's width where it
    is not curved downward there: a start away from the peak)."""
    fallback = (np.array([high - low for low, high in bounds]) / 8) ** 2
    curvature = _axis_curvatures(counter, x, 1e-4)
    with np.errstate(divide="ignore"):
        variance = 1.0 / curvature
    bent = np.isfinite(curvature) & (curvature > 0)
    return np.diag(np.where(bent, np.minimum(variance, fallback), fallback))


def _axis_curvatures(f, x, step, f0: float | None = None) -> np.ndarray:
    """-d^2 f / dx_i^2 along each coordinate at ``x`` by central differences of ``step`` (one for
    all coordinates or one each; ``f0`` = f(x) if known)."""
    f0 = f(x) if f0 is None else f0
    steps = np.broadcast_to(np.asarray(step, dtype=float), (len(x),))
    e = np.diag(steps)
    return np.array([-(f(x + e[i]) - 2 * f0 + f(x - e[i])) / steps[i] ** 2 for i in range(len(x))])


#: a restarted polish counts as a move when it gains this much log posterior
RESTART_GAIN = 1e-3
#: and is restarted again at most this many times
RESTARTS = 3


def _restart(counter, x, sd, bounds) -> np.ndarray | None:
    """Model coordinates a Nelder-Mead restarted from ``x`` with a simplex of two Laplace sds
    ``sd`` per coordinate (at most an eighth of its prior's width) reaches, restarted again
    while it gains :data:`RESTART_GAIN`; None when the first restart gains nothing."""
    widths = np.array([high - low for low, high in bounds])
    step = np.minimum(np.nan_to_num(2 * sd, nan=np.inf), widths / 8)
    best, value, moved = x, counter(x), False
    for _ in range(RESTARTS):
        trial = _nelder_mead(counter, best, np.diag(step))
        gained = counter(trial)
        if not gained > value + RESTART_GAIN:
            break
        best, value, moved = trial, gained, True
    return best if moved else None


def _polished(post: LogPosterior, counter, x) -> tuple[np.ndarray, tuple[np.ndarray, np.ndarray]]:
    """(full coordinates at model coordinates ``x`` with the noise profiled, (Laplace covariance,
    rough coordinates): :func:`laplace_covariance_and_roughness`)."""
    k = len(post.model_names)
    full = post.with_profiled_noise(x)
    if full is None:
        raise ValueError(f"the optimiser ended where model {post.likelihood.model.name} cannot be evaluated "
                         f"({post.values(np.concatenate([x, [p.median() for p in post.priors[k:]]]))}); "
                         f"narrow the priors or give the fit window and band explicitly")
    if any(n.startswith("phi_") for n in post.names):
        full = _polish_all(post, full, counter)
    return full, laplace_covariance_and_roughness(post, full)


def _neutral_start(post: LogPosterior) -> np.ndarray:
    """Model coordinates to start the global search from: each prior's median, except that every
    missing-physics effect starts where it vanishes (``Effect.absent``, clipped into the prior's
    support). The EI scan and the differential evolution's EI window are set at this point, so an
    effect's prior median (a tension of several buckling loads, say) would put EI where that
    effect and EI together fit the peaks, far from the data's EI."""
    absent = {n: v for e in post.likelihood.model.effects for n, v in e.absent.items()}
    x0 = []
    for name, prior in zip(post.model_names, post.priors):
        if name in absent:
            with np.errstate(divide="ignore"):
                x0.append(float(np.clip(prior.to_coordinate(absent[name]), *prior.bounds())))
        else:
            x0.append(prior.median())
    return np.array(x0)


def spectral_ei(post: LogPosterior, x0: np.ndarray, bounds) -> float:
    """log EI that lines the model's natural frequencies up with the data's spectral peaks.

    All stiffness scales with EI, so the natural frequencies scale with sqrt(EI): the factor c
    maximising sum_m log A(c f_m) over the model's in-band modes f_m (A: amplitude spectrum of
    the fitted window, summed over channels normalised to unit RMS) gives EI = EI(x0) c^2. It
    needs no simulation and is not fooled by the phase of high modes, which makes the
    likelihood of EI multimodal on a scale of 0.1%.
    """
    lik = post.likelihood
    rec, proj = lik.model.recording, lik.projection
    seg = rec.signals[proj.i0 : proj.i1]
    seg = (seg - seg.mean(axis=0)) / np.maximum(seg.std(axis=0), np.finfo(float).tiny)
    n_fft = 4 * len(seg)
    amp = np.abs(np.fft.rfft(seg * np.hanning(len(seg))[:, None], n_fft, axis=0)).sum(axis=1)
    freq = np.fft.rfftfreq(n_fft, rec.dt)
    params, _ = post.split(np.concatenate([x0, [p.median() for p in post.priors[len(x0):]]]))
    f_model = lik.model.natural_frequencies(params)
    lo, hi = np.exp(0.5 * (np.array(bounds) - x0[0]))
    scales = np.exp(np.linspace(np.log(lo), np.log(hi), 8001))
    floor = 1e-9 * amp.max()
    best, best_score = 1.0, -np.inf
    for c in scales:
        f = c * f_model
        f = f[(f > 2 * freq[1]) & (f < proj.max_frequency)]
        if f.size == 0:
            continue
        score = np.mean(np.log(np.interp(f, freq, amp) + floor))
        if score > best_score:
            best, best_score = c, score
    return float(x0[0] + 2 * np.log(best))


#: half-width of the likelihood scan of log EI around the spectral-peak estimate
EI_SCAN = 0.04
#: half-width of the differential evolution's window in log EI, around the scan's best
EI_WINDOW = 0.005
#: positions across an effect parameter's prior support (fractions of its sampling coordinate's
#: range) at which :func:`_ridge_start` looks for the EI that parameter trades with
RIDGE_POSITIONS = (0.1, 0.3, 0.5, 0.7, 0.9)


def _ridge_start(post: LogPosterior, counter, neutral: np.ndarray, guess: float, scan_points: int):
    """Model coordinates of the best point (by its log posterior) among those where one effect
    parameter sits at one of :data:`RIDGE_POSITIONS` of its prior, the others where the global
    search started (``neutral``), and EI is re-determined by the likelihood scan; only settings
    whose spectral-peak EI lies outside the differential evolution's window around ``guess`` (the
    spectral EI at ``neutral``) count. None when no effect parameter moves EI that far.

    Why: the search starts every effect where it vanishes and keeps EI within +-EI_WINDOW of the
    EI the peaks give there; an effect that softens the beam (a root spring, a base, a sensor
    mass) trades with EI along a ridge the window cuts. On paper_rootcomp_hammer (k_theta
    3500 N m/rad, EI 4.4 % above the rigid root's) q1 + root spring + root dashpot settled on a
    rigid clamp with a dashpot of 115 N m s/rad carrying the damping, 1200 nats below the
    optimum a start on the ridge reaches.
    """
    ei_bounds = post.priors[0].bounds()
    effect_parameters = {p for e in post.likelihood.model.effects for p in e.parameters}
    best, best_value = None, -np.inf
    for i, name in enumerate(post.model_names[1:], start=1):
        if name not in effect_parameters:
            continue
        low, high = post.priors[i].bounds()
        for fraction in RIDGE_POSITIONS:
            x = neutral.copy()
            x[i] = low + fraction * (high - low)
            try:
                ridge_guess = spectral_ei(post, x, ei_bounds)
            except UNEVALUABLE:
                continue
            if abs(ridge_guess - guess) <= EI_WINDOW:
                continue
            x[0] = _scan_ei(counter, x, ridge_guess, EI_SCAN, scan_points)
            value = counter(x)
            if value > best_value:
                best, best_value = x, value
    return best


def _search_ei(post: LogPosterior, counter, x0: np.ndarray, scan_points: int) -> tuple[float, float]:
    """(spectral-peak estimate of log EI (:func:`spectral_ei`), the best log EI of a likelihood
    scan of ``scan_points`` points over +-:data:`EI_SCAN` around it), the other model coordinates
    held at ``x0``."""
    guess = spectral_ei(post, x0, post.priors[0].bounds())
    return guess, _scan_ei(counter, x0, guess, EI_SCAN, scan_points)


def rescan_ei(post: LogPosterior, start: dict, scan_points: int = 321) -> dict:
    """``start`` (model parameter values by name) with EI re-determined by the global search's
    one-dimensional EI search (:func:`_search_ei`) with every other parameter held at its value.

    A start assembled from another model's optimum (a nested model's, extended by an effect's
    value) carries the EI that model needed, and where an effect and EI trade off in the first
    mode's frequency while the higher modes tell them apart, that EI lies in the other model's
    basin. On the aluminium strip of studies/concealed_effects whose clamp is a root spring
    (k_theta = 636 N m/rad), q1 without it lowers EI to absorb the compliant root; polished from
    there with the screened k_theta, q1 + root_compliance returns to a rigid root (ln B = -4
    against q1), and from the EI re-determined here it finds k_theta = 635 N m/rad (ln B = 1806).
    """
    x0 = _coordinates(post, start)
    _, ei = _search_ei(post, _Counter(post.profiled, post.profiled_batch), x0, scan_points)
    return {**start, post.model_names[0]: float(post.priors[0].to_value(ei))}


def _coordinates(post: LogPosterior, values: dict) -> np.ndarray:
    """Model coordinates of parameter ``values`` (by name; extra names ignored)."""
    return np.array([post.priors[i].to_coordinate(values[n]) for i, n in enumerate(post.model_names)])


def _scan_ei(counter, x0, centre, half_width, n) -> float:
    """Best log EI on a uniform grid of n points in centre +- half_width (other coordinates fixed),
    the points evaluated together."""
    grid = np.linspace(centre - half_width, centre + half_width, n)
    points = np.repeat(x0[None], n, axis=0)
    points[:, 0] = grid
    return float(grid[int(np.argmax(counter.many(points)))])


def _polish_all(post, theta, counter):
    """Nelder-Mead on every coordinate, noise included: needed for AR(1) noise only (the white
    noise sd profiled so far is already its exact conditional optimum)."""
    res = optimize.minimize(lambda x: -post(x), theta, method="Nelder-Mead",
                            options={"xatol": 1e-8, "fatol": 1e-7, "maxfev": 300 * len(theta), "adaptive": True})
    counter.calls += res.nfev
    return res.x if res.fun <= -post(theta) else theta


def newton_shift(post: LogPosterior, theta: np.ndarray, covariance: np.ndarray, step: float = 1e-4):
    """One Newton step of log p from theta with a given covariance (= -Hessian^-1): the optimum's shift.

    Used to compare discretisations: the optimum of a finer model, started from the coarse
    optimum, moves by about covariance @ gradient when the move is small (the regime that matters).
    A coordinate within one step of its prior's edge (an optimum against the edge: a tip sensor's
    offset at the tip, a delay at 0) is held there, as the finer optimum is while the likelihood
    pushes against the edge: its shift is 0 and the others move by the Newton step with it fixed
    (the conditional covariance). So is one whose log posterior a step away is -inf on one side
    only: an optimum against a constraint inside the priors' box (q2's memory term taking nearly
    all the static stiffness, :func:`laplace_covariance`). Not finite on both sides: inf.
    The gradient's central differences take ``step``, or on a rough coordinate the long step of
    :func:`difference_steps`.
    """
    d = len(theta)
    held = _near_edge(post, theta, step)
    steps = difference_steps(post, theta, step)
    grad = np.zeros(d)
    for i in np.flatnonzero(~held):
        e = np.zeros(d)
        e[i] = steps[i]
        up, down = post(theta + e), post(theta - e)
        if np.isfinite(up) != np.isfinite(down):
            held[i] = True
        elif not np.isfinite(up):
            return np.full(d, np.inf)
        else:
            grad[i] = (up - down) / (2 * steps[i])
    if not held.any():
        return covariance @ grad
    free = ~held
    cross = covariance[np.ix_(free, held)]
    conditional = covariance[np.ix_(free, free)] - cross @ np.linalg.solve(covariance[np.ix_(held, held)], cross.T)
    shift = np.zeros(d)
    shift[free] = conditional @ grad[free]
    return shift


def _near_edge(post: LogPosterior, theta: np.ndarray, margin: float) -> np.ndarray:
    """Which coordinates lie within ``margin`` of an edge of their prior's support (log-normal
    priors have none)."""
    low, high = _support(post)
    return (theta - low < margin) | (high - theta < margin)


def _support(post: LogPosterior) -> tuple[np.ndarray, np.ndarray]:
    """The priors' supports in sampling coordinates, (-inf, inf) for the log-normal ones."""
    bounded = [p.bounds() if p.kind != "lognormal" else (-np.inf, np.inf) for p in post.priors]
    return np.array([b[0] for b in bounded]), np.array([b[1] for b in bounded])


def laplace_covariance(post: LogPosterior, theta: np.ndarray, step: float = 1e-4) -> np.ndarray:
    """Inverse of the negative finite-difference Hessian of log p at theta (sampling coordinates).

    The differences reach two steps. A coordinate within three steps of its prior's edge (an
    optimum against the edge) is moved three steps inside first, so that no difference steps out
    of the support (two would leave the farthest point on the edge, and rounding outside it): the
    curvature there is the edge's to O(step). So is one whose log posterior two steps away is
    -inf on one side only (:func:`_off_constraint`): an optimum against a constraint inside the
    priors' box, such as time hysteresis's memory term taking nearly all the static stiffness EI
    provides (q2 on data it does not describe). A rough coordinate (:func:`difference_steps`)
    takes its long step instead of ``step``. Falls back to a diagonal built from the
    curvature along each axis (or 1e-3^2) where the Hessian is not negative definite.
    """
    return laplace_covariance_and_roughness(post, theta, step)[0]


def laplace_covariance_and_roughness(post: LogPosterior, theta: np.ndarray,
                                     step: float = 1e-4) -> tuple[np.ndarray, np.ndarray]:
    """(:func:`laplace_covariance`, per coordinate whether it took the long step of
    :func:`difference_steps`). Along a coordinate the data determine, that marks an optimum that
    is one of many sharp local maxima, a poor centre for SMC's reference density
    (:func:`bayesbeam.comparison.piloted`); along one they do not, a posterior far from a
    Gaussian over six sds (a damping term flat down to its prior bound)."""
    d = len(theta)
    low, high = _support(post)
    theta = np.where(_near_edge(post, theta, 3 * step), np.clip(theta, low + 3 * step, high - 3 * step), theta)
    theta = _off_constraint(post, theta, 2 * step, 3 * step)
    f0 = post(theta)
    steps = difference_steps(post, theta, step, f0)
    rough = steps != step
    h = _hessian(post, theta, steps)
    if not np.all(np.isfinite(h)):
        return np.eye(d) * 1e-6, rough
    try:
        cov = np.linalg.inv(-h)
        np.linalg.cholesky(cov)
        return cov, rough
    except np.linalg.LinAlgError:
        diag = _axis_curvatures(post, theta, steps, f0)
        return np.diag(np.where(diag > 0, 1.0 / np.maximum(diag, 1e-300), 1e-6)), rough


#: the drop of log p (nats) a rough coordinate's long finite-difference step aims for on average
#: over its two sides: about six posterior sds, exact for a Gaussian posterior
LAPLACE_DROP = 20.0
#: a coordinate is rough when its curvature over the short step differs from that over the long
#: step by more than this many times the latter (a Gaussian's are equal; a quartic term of a
#: smooth posterior changes the long step's by tens of percent at most)
ROUGH_RATIO = 2.0
#: the shortest long step (sampling coordinates): rounding of log p (~2e-5 nats) stays far below
#: the drop over it for any posterior sd the data give
MIN_STEP = 1e-7


def difference_steps(post: LogPosterior, theta: np.ndarray, step: float, f0: float | None = None) -> np.ndarray:
    """Per coordinate, the finite-difference step of :func:`laplace_covariance` and :func:`newton_shift`:
    ``step``, or, on a **rough** coordinate, a step over which log p drops by about
    :data:`LAPLACE_DROP` nats (:func:`_long_step`).

    A stick-slip likelihood on a long record is rough: its simulation error jumps wherever a
    friction event crosses a fine node, so its optimum is one of many sharp local maxima. On the
    8 s friction release of benchmarks/nonlinear_long.py, at the q1+dry_friction host's optimum
    (N = 16), log p drops 4 nats over 1e-6 in log EI and 0.4-1.3 nats over 1e-4 in log gamma,
    where the posterior's curvature gives 0.03: differences over 1e-4 measure the roughness, and
    the SMC run seeded by that covariance settled 5.7 nats low. A coordinate is rough when its
    curvature over ``step`` differs from that over the long step by more than :data:`ROUGH_RATIO`
    times the latter (a ripple's crest makes it larger, its trough or flank smaller or negative);
    elsewhere the long step is not used, so a smooth posterior's covariance and shifts are those of
    the fixed step exactly (at the cost of four more evaluations per coordinate). ``f0`` =
    log p at ``theta`` if known."""
    f0 = post(theta) if f0 is None else f0
    short = _axis_curvatures(post, theta, step, f0)
    steps = np.full(len(theta), float(step))
    for i in np.flatnonzero(np.isfinite(short)):
        # a Gaussian's drop over the first guess, from the curvature over step, is LAPLACE_DROP
        guess = np.sqrt(2 * LAPLACE_DROP / short[i]) if short[i] > 0 else 10 * step
        found = _long_step(post, theta, i, guess, step, f0)
        if found is not None and abs(short[i] - (long := 2 * found[1] / found[0] ** 2)) > ROUGH_RATIO * long:
            steps[i] = found[0]
    return steps


def _long_step(post: LogPosterior, theta: np.ndarray, i: int, guess: float, step: float,
               f0: float) -> tuple[float, float] | None:
    """(step, the mean drop of log p over it on both sides) along coordinate ``i``, the step searched
    from ``guess`` until the drop is within a factor 4 of :data:`LAPLACE_DROP` (rescaled as a
    quadratic's drop would need, grown tenfold where log p does not drop, shrunk fourfold where a
    side is not finite), within [:data:`MIN_STEP`, cap], cap a third of the distance to the prior's
    nearer edge and an eighth of its width (not below ``step``); the last step with a positive
    finite drop, or None."""
    low, high = _support(post)
    cap = max(step, min((high[i] - low[i]) / 8, (theta[i] - low[i]) / 3, (high[i] - theta[i]) / 3))
    h, found = float(np.clip(guess, MIN_STEP, cap)), None
    for _ in range(8):
        e = np.zeros(len(theta))
        e[i] = h
        drop = f0 - 0.5 * (post(theta + e) + post(theta - e))
        if not np.isfinite(drop):
            if found is not None:
                break
            h = max(h / 4, MIN_STEP)
            continue
        if drop > 0:
            found = (h, float(drop))
        wanted = float(np.clip(h * 10 if drop <= 0 else h * np.sqrt(LAPLACE_DROP / drop), MIN_STEP, cap))
        if 0.5 < wanted / h < 2:
            break
        h = wanted
    return found


def _hessian(post: LogPosterior, theta: np.ndarray, steps: np.ndarray) -> np.ndarray:
    """The Hessian of log p at theta by central differences of ``steps`` (one per coordinate)
    reaching two steps; its diagonal is the curvature over twice each step."""
    d = len(theta)
    h = np.zeros((d, d))
    e = np.diag(steps)
    for i in range(d):
        for j in range(i, d):
            fpp = post(theta + e[i] + e[j])
            fpm = post(theta + e[i] - e[j])
            fmp = post(theta - e[i] + e[j])
            fmm = post(theta - e[i] - e[j])
            h[i, j] = h[j, i] = (fpp - fpm - fmp + fmm) / (4 * steps[i] * steps[j])
    return h


def _off_constraint(post: LogPosterior, theta: np.ndarray, reach: float, move: float) -> np.ndarray:
    """theta moved by ``move`` along each coordinate whose log posterior ``reach`` away is -inf on
    one side and finite on the other, toward the finite side, one coordinate after another."""
    theta = np.array(theta, dtype=float)
    for i in range(len(theta)):
        e = np.zeros(len(theta))
        e[i] = 1.0
        up, down = np.isfinite(post(theta + reach * e)), np.isfinite(post(theta - reach * e))
        if up != down:
            theta = theta + (move if up else -move) * e
    return theta


#: the optimisers' value where the log posterior is not finite: below any real log posterior, and
#: small enough that SciPy's differential evolution can square it in its convergence test (np.std
#: of a population holding -1e300 overflowed, with a RuntimeWarning)
_NOT_FINITE = -1e150


class _Counter:
    """The optimisers' objective: ``f`` at a point (``batch`` at the rows of an array), counting
    evaluations, with :data:`_NOT_FINITE` for a value that is not finite."""

    def __init__(self, f, batch=None):
        self.f, self.batch, self.calls = f, batch, 0

    def __call__(self, x):
        self.calls += 1
        value = self.f(x)
        return value if np.isfinite(value) else _NOT_FINITE

    def many(self, xs) -> np.ndarray:
        if self.batch is None:
            return np.array([self(x) for x in xs])
        self.calls += len(xs)
        values = self.batch(xs)
        return np.where(np.isfinite(values), values, _NOT_FINITE)


def _say(log, text):
    if log is not None:
        log(text)


# ---------------------------------------------------------------------------- sampling
@dataclass
class Chains:
    """Post-burn-in, thinned samples and the convergence record of one emcee run."""

    samples: np.ndarray        # (n_walkers, n_draws, ndim), sampling coordinates
    log_prob: np.ndarray       # (n_walkers, n_draws)
    tau: np.ndarray            # integrated autocorrelation time per parameter (steps)
    acceptance: float          # mean acceptance fraction
    n_steps: int               # steps taken per walker
    burn: int
    thin: int
    converged: bool
    reason: str
    seconds: float


def run_emcee(post: LogPosterior, optimum: Optimum, rng: np.random.Generator, *, n_walkers: int | None = None,
              max_steps: int = 20000, chunk: int = 250, tau_factor: float = 50.0, pool=None,
              backend_path=None, resume: bool = False, progress=None) -> Chains:
    """Run emcee until converged (see module docstring) or ``max_steps``."""
    ndim = post.ndim
    n_walkers = n_walkers or max(4 * ndim, 16)
    backend = None
    if backend_path is not None:
        backend = BufferedHDFBackend(str(backend_path))
        if not resume:
            backend.reset(n_walkers, ndim)
    # the walkers of each half-step are evaluated together (emcee's vectorize), in this process or in
    # one chunk per worker; emcee draws the same random numbers either way, and the values equal one
    # call per walker's to rounding
    workers = None if pool is None else pool_workers(pool)
    vectorize = batching() and (pool is None or workers is not None)
    if vectorize:
        fn, pool = (post.log_prob_batch if pool is None else PooledBatch(pool, workers)), None
    else:
        fn = worker_log_prob if pool is not None else post
    sampler = emcee.EnsembleSampler(n_walkers, ndim, fn, pool=pool, backend=backend, vectorize=vectorize)
    # emcee draws its moves from a copy of numpy's global state: seed it from rng instead
    sampler.random_state = np.random.RandomState(int(rng.integers(2**31))).get_state()
    state = None if (resume and backend is not None and backend.iteration > 0) else initial_ball(post, optimum, n_walkers, rng)
    if state is None and backend.shape != (n_walkers, ndim):
        raise ValueError(f"--resume: the saved chain has {backend.shape} (walkers, parameters), this fit "
                         f"needs {(n_walkers, ndim)}; rerun without --resume")
    started = time.perf_counter()
    previous_tau = None if state is not None else _tau_at_last_boundary(sampler, chunk)
    converged, reason = False, None
    with as_progress(progress).stage("sampling (emcee)", max_steps, "step") as bar:
        bar.advance(sampler.iteration)
        try:
            while sampler.iteration < max_steps:
                # chunks end at multiples of ``chunk``, so a resumed run judges convergence where an
                # uninterrupted one does (the backend also restores emcee's random state: same draws)
                steps = min(chunk - sampler.iteration % chunk, max_steps - sampler.iteration)
                sampler.run_mcmc(state, steps, progress=False)
                state = None
                tau = sampler.get_autocorr_time(tol=0)
                _report(bar, sampler, tau, tau_factor, max_steps, steps, chunk)
                if previous_tau is not None and np.all(np.isfinite(tau)):
                    stable = np.all(np.abs(tau - previous_tau) < 0.05 * tau)
                    if sampler.iteration > tau_factor * np.max(tau) and stable:
                        converged, reason = True, f"chain longer than {tau_factor:g} tau and tau stable to 5%"
                        bar.retotal(sampler.iteration)
                        break
                previous_tau = tau
        finally:
            if backend is not None:     # an interrupted run keeps every step it took
                backend.flush()
    if not converged:
        reason = unconverged_reason(sampler.get_autocorr_time(tol=0), previous_tau, sampler.iteration, tau_factor)
    tau = sampler.get_autocorr_time(tol=0)
    tau_max = float(np.nanmax(tau)) if np.all(np.isfinite(tau)) else sampler.iteration / 10
    burn = burn_in(tau_max, sampler.iteration)
    thin = max(1, int(tau_max / 2))
    chain = sampler.get_chain(discard=burn, thin=thin)           # (draws, walkers, ndim)
    lp = sampler.get_log_prob(discard=burn, thin=thin)
    return Chains(np.swapaxes(chain, 0, 1), lp.T, tau, float(np.mean(sampler.acceptance_fraction)),
                  sampler.iteration, burn, thin, converged, reason, time.perf_counter() - started)


def _tau_at_last_boundary(sampler, chunk: int):
    """tau of a resumed chain's steps up to its last multiple of ``chunk``: the estimate an
    uninterrupted run made there last (None before the first chunk ended)."""
    steps = sampler.iteration - sampler.iteration % chunk
    if steps == 0:
        return None
    return emcee.autocorr.integrated_time(sampler.get_chain()[:steps], tol=0)


def burn_in(tau_max: float, n_steps: int) -> int:
    """Steps discarded from the start of a chain: three autocorrelation times, at most half of it."""
    return int(min(3 * tau_max, n_steps // 2))


def effective_sample_size(tau, n_walkers: int, n_steps: int, burn: int):
    """ESS per parameter of an ensemble chain after ``burn``: n_walkers (n_steps - burn) / tau, with
    tau emcee's integrated autocorrelation time (steps)."""
    return n_walkers * (n_steps - burn) / np.asarray(tau, dtype=float)


def initial_ball(post, optimum, n_walkers, rng):
    """Walker starts: the optimum plus 0.1 x the Laplace sd times standard normals, each finite."""
    sd = np.sqrt(np.clip(np.diag(optimum.covariance), 1e-14, None))
    walkers = []
    while len(walkers) < n_walkers:
        trial = optimum.theta + 0.1 * sd * rng.standard_normal(post.ndim)
        if np.isfinite(post(trial)):
            walkers.append(trial)
    return np.array(walkers)


def _report(bar, sampler, tau, tau_factor, max_steps, steps, chunk):
    """Advance the bar by ``steps``; its total becomes the steps the chain will likely need
    (``tau_factor`` x the largest tau so far, at least one chunk more, at most ``max_steps``), so
    its time left means something."""
    bar.advance(steps)
    if np.all(np.isfinite(tau)):
        bar.retotal(min(max_steps, max(sampler.iteration + chunk, int(tau_factor * np.max(tau)) + 1)))
    tau_text = f"{np.nanmax(tau):.1f}" if np.any(np.isfinite(tau)) else "?"
    bar.describe(f"max tau {tau_text}, acceptance {np.mean(sampler.acceptance_fraction):.2f}")


def unconverged_reason(tau, previous_tau, n_steps: int, tau_factor: float) -> str:
    """Why a chain of ``n_steps`` that reached its step limit is not converged, and what to do."""
    if not np.all(np.isfinite(tau)):
        return (f"reached max_steps = {n_steps} with no finite autocorrelation time (walkers stuck: "
                f"acceptance near 0, or a parameter the data do not constrain); check the trace plot and the priors")
    worst = float(np.max(tau))
    if n_steps <= tau_factor * worst:
        return (f"reached max_steps = {n_steps}, shorter than {tau_factor:g} x the largest autocorrelation "
                f"time ({worst:.0f} steps): about {int(tau_factor * worst)} steps are needed; raise --max-steps")
    if previous_tau is None:
        return (f"reached max_steps = {n_steps} after one estimate of the autocorrelation time, too few to "
                f"see it settle; raise --max-steps")
    drift = np.max(np.abs(tau - previous_tau) / tau)
    return (f"reached max_steps = {n_steps}: the chain is {n_steps / worst:.0f} tau long but tau still moved "
            f"{100 * drift:.0f} % in the last chunk (more than 5 %): the walkers are still exploring; "
            f"raise --max-steps or check the trace plot for a second mode")
