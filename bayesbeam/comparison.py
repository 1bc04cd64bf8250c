r"""Which damping mechanism? Evidence, cheap screens and predictive checks for several models.

For each model (a preset or ``+``-joined mechanisms, optionally with effects):

1. **Optimum and discretisation** (:func:`bayesbeam.inference.fit.choose_discretisation`): the
   robust optimum, its Laplace covariance, and the spline grid N the data need.
2. **Evidence** (:mod:`bayesbeam.inference.evidence`): ``repeats`` independent SMC runs from the
   Laplace reference; log Z is their mean, its sd the standard error over repeats. The final
   particles of all repeats are the posterior draws (one "chain" per repeat; R-hat across
   repeats is the convergence check). Repeats that spread by more than
   :data:`EVIDENCE_SD_MAX` are run again from a reference fitted to their posterior particles
   (:func:`settle`). A model whose log posterior is rough at its optimum starts its repeats
   from a reference fitted to a pilot run's particles instead (:func:`piloted`; the pilots run in
   one wave with the other models' first repeats). The repeats
   run in two waves: a model that the first :data:`FIRST_WAVE` repeats already put decisively
   behind the leader (:data:`EARLY_STOP_NATS`, :func:`beaten`) gets no more; its summary says so
   and why. The model with the highest likelihood at its
   optimum, the likely leader, runs all its repeats in the first wave. A caller that decides by
   a decisive log Bayes factor (the diagnosis) names it, ``decisive``: then every model starts
   with the first wave, and one whose every such decision against the others is settled
   (:func:`settled`) gets no more either.
3. **Screens**, each labelled with what it assumes: BIC and the Laplace approximation at the
   optimum, and PSIS leave-future-out over the likelihood's time blocks
   (:mod:`bayesbeam.inference.screens`).
4. **Posterior predictive checks** (:mod:`bayesbeam.checks.ppc`).

Models, and the repeats of each model's evidence, are independent jobs for an executor
(:mod:`bayesbeam.executors`). Posterior model probabilities assume equal prior probabilities.
"""
from __future__ import annotations

import hashlib
import time
from dataclasses import dataclass, field, replace

import numpy as np

from bayesbeam.checkpoint import NOTHING_SAVED
from bayesbeam.checks.ppc import N_REPLICATES, PASS_P_VALUE, mode_table, posterior_predictive_check
from bayesbeam.executors import SerialExecutor
from bayesbeam.inference.evidence import (
    combine_runs,
    laplace_reference,
    matched_reference,
    mean_and_standard_error,
    smc,
)
from bayesbeam.inference.fit import FitConfig, choose_discretisation
from bayesbeam.inference.results import parameter_unit
from bayesbeam.inference.screens import bic, laplace_log_evidence, pointwise_matrix, psis_lfo, psis_loo
from bayesbeam.io import RecordingError
from bayesbeam.model import resolve_model
from bayesbeam.progress import as_progress

#: the paper's three models plus the single mechanisms
DEFAULT_MODELS = ("q1", "q2", "q3", "air", "strain_rate")
#: the damping models of the literature since the paper, each on its own (docs/comparison.md);
#: thermoelastic needs the recording's [material] table (left out without it: :func:`material_left_out`)
LITERATURE_MODELS = ("fractional", "exponential", "thermoelastic", "root_compliance+root_damping")
#: named sets of models that ``--models`` accepts beside model names
MODEL_SETS = {"paper": DEFAULT_MODELS, "literature": LITERATURE_MODELS, "all": DEFAULT_MODELS + LITERATURE_MODELS}
#: Kass & Raftery (1995) on the 2 ln B scale (2, 6, 10), as ln B in nats
KASS_RAFTERY = ((5.0, "very strong"), (3.0, "strong"), (1.0, "positive"), (0.0, "not worth more than a bare mention"))
#: a model's evidence has not settled when its SMC repeats spread by more than this (nats; the
#: settled runs of the shipped studies spread by 0.02-0.18) ...
EVIDENCE_SD_MAX = 1.0
#: ... or its pooled posterior's R-hat over the repeats exceeds this (settled runs: 1.000-1.030)
R_HAT_MAX = 1.05
#: a model's remaining evidence repeats are skipped when it trails the leader by more than this
#: many nats beyond three standard errors of the difference: a log Bayes factor past 5 nats is
#: already "very strong" (Kass & Raftery), so the ranking cannot turn on its remaining repeats
#: (settled repeats spread by 0.02-0.18 nats, see :data:`EVIDENCE_SD_MAX`)
EARLY_STOP_NATS = 20.0
#: evidence repeats per model before any is stopped: two give a standard error
FIRST_WAVE = 2
#: ``CompareConfig.min_moved`` for SMC mutation steps from the acceptance rate: until a particle
#: has moved at least once with this probability (:mod:`bayesbeam.inference.evidence`; PyMC3's
#: SMC, ``p_acc_rate``). Not the default: on paper_q3_hammer at 150 Hz it took q3's stages from 11
#: moves to 6 with the same log Z (-765.21 +- 0.03 against -765.20 +- 0.04), but q2 (three stages
#: from its reference) came out 0.50 nats below the full path's -3353.95 +- 0.08, 6 combined sd;
#: q2's full-path log Z itself was -3354.55 +- 0.09 with slightly different likelihood code, so its
#: repeats understate its spread and the comparison does not settle whether the rule errs low
#: (benchmarks/compare.py --min-moved 0.85)
MIN_MOVED = 0.85
#: seed offset of a rough model's pilot run (:func:`piloted`), apart from its evidence repeats
#: (offsets 0, and 500 for a second pass)
PILOT_OFFSET = 900


@dataclass
class CompareConfig:
    """Settings of a comparison: the fit settings (window, band, priors, N) and the evidence runs.

    repeats: independent SMC runs per model (>= 2: their spread is the evidence's uncertainty);
    particles: SMC particles per run (default max(128, 32 x parameters)); replicates: posterior
    predictive replicates per model; seed: master seed of everything random; early_stop: the
    margin (nats) of :func:`beaten` past which a model's remaining repeats are skipped (None: every
    model gets all its repeats); min_moved: None (three accepted SMC moves per particle on
    average per stage) or the probability of :data:`MIN_MOVED`'s rule.
    """

    fit: FitConfig = field(default_factory=FitConfig)
    repeats: int = 3
    particles: int | None = None
    replicates: int = N_REPLICATES
    seed: int = 1
    early_stop: float | None = EARLY_STOP_NATS
    min_moved: float | None = None

    def __post_init__(self):
        if self.repeats < 2:
            raise ValueError(f"repeats = {self.repeats}: need at least 2 independent evidence runs "
                             f"to state the evidence's uncertainty")


@dataclass
class ModelResult:
    """Everything the comparison learned about one model."""

    name: str
    problem: object
    optimum: object
    discretisation: dict
    evidence: object
    check: object
    screens: dict
    pointwise: np.ndarray
    stopped: str | None = None      # why its evidence repeats were stopped early (:func:`beaten`)

    @property
    def draws(self) -> np.ndarray:
        """Posterior draws (repeats, particles, ndim) in sampling coordinates."""
        return self.evidence.samples

    def values(self) -> np.ndarray:
        """Posterior draws as physical values, (repeats, particles, ndim)."""
        priors = self.problem.posterior.priors
        draws = self.draws
        return np.stack([p.to_value(draws[..., i]) for i, p in enumerate(priors)], axis=-1)


# ---------------------------------------------------------------------------- jobs
def optimise_job(args):
    """Job 1: (problem, optimum, discretisation record) of one model."""
    rec, model, config, seed, start = args
    return choose_discretisation(rec, model, config.fit, np.random.default_rng(seed), start=start)


def polish_job(args):
    """Job 1, local: :func:`optimise_job` from its start alone, without the global search."""
    rec, model, config, seed, start = args
    return choose_discretisation(rec, model, config.fit, np.random.default_rng(seed), start=start, search=False)


def smc_job(args):
    """Job 2: one SMC run of one model's posterior."""
    posterior, reference, seed, particles, min_moved = args
    return smc(posterior.terms, reference, np.random.default_rng(seed), n_particles=particles, min_moved=min_moved)


def optimise_models(rec, models, config, executor, log=None, starts: dict | None = None, skip=()) -> dict:
    """model -> what :func:`optimise_job` returns, for ``models`` but those in ``skip``, in
    parallel on ``executor``, under an "optimising" bar of ``log`` (none when nothing is left to
    optimise). A model's seed follows its place in ``models`` (``config.seed``), so it is
    optimised the same whether or not others are skipped, here or in :func:`compare`.
    ``starts``: model -> parameter values to optimise from as well."""
    seeds = np.random.SeedSequence(config.seed).spawn(3)[0]
    todo = [(i, m) for i, m in enumerate(models) if m not in skip]
    if not todo:
        return {}
    jobs = [(rec, m, config, _seed(seeds, i), (starts or {}).get(m)) for i, m in todo]
    with as_progress(log).stage("optimising", len(jobs), "model") as bar:
        return dict(zip([m for _, m in todo], executor.map(optimise_job, jobs, bar=bar)))


def check_job(args):
    """Job 3: posterior predictive checks and the screens' pointwise terms of one model."""
    posterior, draws, seed, replicates = args
    rng = np.random.default_rng(seed)
    return posterior_predictive_check(posterior, draws, rng, replicates), pointwise_matrix(posterior, draws, rng)


# ---------------------------------------------------------------------------- the comparison
def expand_model_sets(names) -> list[str]:
    """Model names with each named set of :data:`MODEL_SETS` replaced by its models, repeats dropped.

    >>> expand_model_sets(["literature", "q2", "fractional"])
    ['fractional', 'exponential', 'thermoelastic', 'root_compliance+root_damping', 'q2']
    """
    return list(dict.fromkeys(m for name in names for m in MODEL_SETS.get(name, (name,))))


def compare(rec, models=DEFAULT_MODELS, config: CompareConfig | None = None, executor=None,
            log=None, starts: dict | None = None, rivals: dict | None = None,
            optimised: dict | None = None, checkpoint=NOTHING_SAVED,
            decisive: tuple[float, float] | None = None) -> tuple[dict, dict]:
    """Compare ``models`` (names, or named sets of :data:`MODEL_SETS`) on ``rec``: ``(results, summary)``.

    ``results`` maps each model to its :class:`ModelResult`; ``summary`` is the JSON-ready
    comparison (see :func:`summarise`). ``log``: a :class:`~bayesbeam.progress.Progress` (notes
    and a bar per stage: optimising, evidence, predictive checks), a callable taking a line of
    text, or None. ``starts``: model -> parameter values to optimise from as well (see
    :func:`~bayesbeam.inference.fit.choose_discretisation`). ``rivals``: model -> Evidence of
    models fitted before, not refitted and not in the results, that may lead when :func:`beaten`
    decides which repeats to skip. ``optimised``: model -> what :func:`optimise_job` returned for
    it (with this ``config``), not optimised again. ``checkpoint``: where each SMC run is saved
    as it finishes and read back from on a resumed run (:meth:`bayesbeam.checkpoint.Checkpoint.map`).
    ``decisive``: (nats, standard errors): the caller calls one model decisively above another
    when its log Bayes factor exceeds the nats by that many standard errors; with early
    stopping on, a model's remaining repeats are skipped once no such decision about it can
    change (:func:`settled`).
    """
    config = config or CompareConfig()
    executor = executor or SerialExecutor()
    models, left_out = material_left_out(rec, expand_model_sets(models))
    seeds = np.random.SeedSequence(config.seed).spawn(3)
    started = time.perf_counter()
    progress = as_progress(log)
    progress(f"comparing {len(models)} models: {', '.join(models)}")
    for model, why in left_out.items():
        progress(f"left out {model}: {why}")
    optimised = {**(optimised or {}), **optimise_models(rec, models, config, executor, progress, starts,
                                                         skip=optimised or {})}
    stage1 = [optimised[m] for m in models]
    posteriors = {m: problem.posterior for m, (problem, _, _) in zip(models, stage1)}
    evidences, stopped = model_evidence(dict(zip(models, stage1)), config, seeds[1], executor, progress, rivals,
                                        checkpoint, decisive)
    with progress.stage("predictive checks", len(models), "model") as bar:
        checks = executor.map(check_job, [(posteriors[m], evidences[m].samples.reshape(-1, posteriors[m].ndim),
                                           _seed(seeds[2], i), config.replicates) for i, m in enumerate(models)],
                              bar=bar)
    results = {}
    for (model, (problem, optimum, record)), (check, pointwise) in zip(zip(models, stage1), checks):
        screens = {"bic": bic(problem.posterior, optimum),
                   "laplace": laplace_log_evidence(optimum),
                   "psis_lfo": psis_lfo(pointwise), "psis_loo": psis_loo(pointwise)}
        results[model] = ModelResult(model, problem, optimum, record, evidences[model], check, screens,
                                     pointwise, stopped.get(model))
    summary = summarise(rec, results, time.perf_counter() - started, config.fit)
    if left_out:
        summary.update(left_out=left_out, verdict=f"{summary['verdict']} {left_out_words(left_out)}")
    return results, summary


def material_left_out(rec, models) -> tuple[list[str], dict[str, str]]:
    """``models`` without those that need the ``[material]`` table ``rec``'s beam.toml lacks
    (thermoelastic damping), and why each was left out (with how to add the table). When every
    model needs it, all are kept, and the model refuses the recording (a RecordingError naming
    the keys to add). A [material] table that is present is never a reason to leave one out: its
    faults are refused where it is read."""
    if "material" in rec.extra:
        return list(models), {}
    reasons = {m: why for m in models if (why := _material_missing(rec, m))}
    if len(reasons) == len(models):
        return list(models), {}
    return [m for m in models if m not in reasons], reasons


def _material_missing(rec, spec: str) -> str | None:
    """Why ``spec`` cannot be built without a [material] table, or None."""
    for component in (c for group in resolve_model(spec) for c in group):
        try:
            component.bind(rec)
        except RecordingError as exc:
            if exc.where == "[material]":
                return (f"beam.toml has no [material] table, from whose thermal constants {component.name} "
                        f"damping is computed. Fix: {exc.fix}")
    return None


def left_out_words(left_out: dict) -> str:
    """The sentence of the verdict (and the diagnosis) naming the models left out and why."""
    return " ".join(f"{m} was left out: {why}" for m, why in left_out.items())


def _stops_early(config: CompareConfig, rivals: dict | None) -> bool:
    """Whether :func:`_evidence` may stop a model's repeats after the first wave."""
    return rivals is not None and config.early_stop is not None and config.repeats > FIRST_WAVE


def _first_wave(jobs, config: CompareConfig, rivals: dict | None = None, ceilings: dict | None = None,
                decisive: tuple[float, float] | None = None) -> dict:
    """model -> the repeats :func:`_evidence` runs first (its arguments): :data:`FIRST_WAVE` of
    them when it may stop early (all of them for the likely leader when ``decisive`` is None),
    else all."""
    early = _stops_early(config, rivals)
    first = FIRST_WAVE if early else config.repeats
    favourite = (max(jobs, key=lambda m: ceilings.get(m, -np.inf))
                 if early and ceilings and decisive is None else None)
    return {m: range(config.repeats if m == favourite else first) for m in jobs}


def _evidence(jobs: dict, config: CompareConfig, seeds, executor, rivals: dict | None = None,
              say=None, ceilings: dict | None = None, bar=None, checkpoint=NOTHING_SAVED,
              decisive: tuple[float, float] | None = None, done: dict | None = None) -> tuple[dict, dict]:
    """(Evidence per model, why each stopped model was stopped): ``config.repeats`` SMC runs per
    model, combined. ``jobs`` maps a model to (its index, its posterior, the reference, a seed
    offset); a run's seed is ``(index * 1000 + offset + repeat)``, so a repeat's run is the same
    whether or not others were skipped (``bar`` advances per run). With ``rivals`` (model -> Evidence of models fitted
    before; None: no early stop) and ``config.early_stop`` set, the first :data:`FIRST_WAVE`
    repeats run first and the models :func:`beaten` (with ``ceilings``) then get no more. The
    model with the highest ceiling, the likely leader, runs all its repeats in the first wave: a
    leader is never stopped, and its last repeat would otherwise run alone while the other
    workers wait. With ``decisive`` (see :func:`compare`), the models :func:`settled` get no
    more either, and the likely leader too starts with the first wave (it is usually settled).
    ``done``: model -> runs of its first repeats already run (:func:`piloted`), not run again."""
    early = _stops_early(config, rivals)
    done = done or {}
    plan = _first_wave(jobs, config, rivals, ceilings, decisive)
    new = _runs(jobs, {m: range(len(done.get(m, ())), plan[m].stop) for m in jobs}, config, seeds, executor, bar,
                checkpoint)
    runs = {m: list(done.get(m, ())) + new[m] for m in jobs}
    stopped = {}
    if early:
        # the highest log likelihood seen, at the optimum or on any particle: an optimum left in a
        # poor mode must not make a ceiling lower than what the runs found
        seen = {m: max([(ceilings or {}).get(m, -np.inf)] + [float(np.max(r.log_likelihood)) for r in rs])
                for m, rs in runs.items()}
        so_far = {**rivals, **{m: combine_runs(r) for m, r in runs.items()}}
        stopped = beaten(so_far, config.early_stop, config.repeats, set(jobs), seen)
        if decisive is not None:
            stopped.update(settled(so_far, decisive, config.repeats, set(jobs) - set(stopped), set(stopped)))
        for m, why in stopped.items():
            if say:
                say(f"evidence of {m} {why}")
        left = {m: range(len(runs[m]), config.repeats) for m in jobs if m not in stopped}
        if bar is not None:
            bar.retotal(bar.done + sum(len(r) for r in left.values()))
        more = _runs(jobs, left, config, seeds, executor, bar, checkpoint)
        runs = {m: r + more.get(m, []) for m, r in runs.items()}
    return {m: combine_runs(r) for m, r in runs.items()}, stopped


def model_evidence(optimised: dict, config: CompareConfig, seeds, executor, progress, rivals: dict | None = None,
                   checkpoint=NOTHING_SAVED, decisive: tuple[float, float] | None = None) -> tuple[dict, dict]:
    """(model -> Evidence, model -> why its repeats were stopped) of the models of ``optimised``
    (model -> (problem, optimum, record), as :func:`optimise_job` returns them; see :func:`compare`
    for the rest): the SMC runs from each optimum's Laplace reference, or from a pilot's particles
    where the optimum is rough (:func:`piloted`), stopped early (:func:`_evidence`), and a second
    pass where they have not settled (:func:`settle`). ``progress``: a Progress."""
    posteriors = {m: problem.posterior for m, (problem, _, _) in optimised.items()}
    jobs = {m: (i, posteriors[m], laplace_reference(posteriors[m].priors, optimum.theta, optimum.covariance), 0)
            for i, (m, (_, optimum, _)) in enumerate(optimised.items())}
    rough = [m for m, (_, optimum, _) in optimised.items() if rough_where_centred(optimum, jobs[m][2])]
    ceilings = _ceilings(posteriors, list(optimised.values()))
    plan = _first_wave(jobs, config, rivals or {}, ceilings, decisive)
    jobs, pilots, done = piloted(jobs, rough, config, seeds, executor, progress, checkpoint,
                                 alongside={m: plan[m] for m in jobs if m not in rough})
    with progress.stage("evidence (SMC)", len(jobs) * config.repeats - sum(map(len, done.values())), "run") as bar:
        evidences, stopped = _evidence(jobs, config, seeds, executor, rivals or {}, progress, ceilings, bar,
                                       checkpoint, decisive, done)
    evidences = {m: replace(e, pilot=pilots[m]) if m in pilots else e for m, e in evidences.items()}
    return settle(evidences, posteriors, config, seeds, executor, progress, skip=set(stopped),
                  checkpoint=checkpoint), stopped


def rough_where_centred(optimum, reference) -> bool:
    """Whether the log posterior is rough at ``optimum`` along a coordinate its Laplace
    ``reference`` centres there (one the data determine: the Student-t's, or an edge band's); the
    roughness of a coordinate the reference leaves to its prior does not matter to it."""
    if optimum.rough is None:
        return False
    centred = reference.tight.copy()
    centred[list(reference.bands)] = True
    return bool(np.any(np.asarray(optimum.rough) & centred))


def piloted(jobs: dict, rough: list, config: CompareConfig, seeds, executor, log=None,
            checkpoint=NOTHING_SAVED, alongside: dict | None = None) -> tuple[dict, dict, dict]:
    """(``jobs`` with each ``rough`` model's reference replaced by one fitted to a pilot run's
    particles, model -> its pilot SMCRun, model -> the runs of ``alongside``). ``jobs``: model ->
    (index, posterior, reference, seed offset), as :func:`_evidence` takes them; ``rough``: the
    models whose optimum is rough (:func:`rough_where_centred`); ``alongside``: model (not rough)
    -> repeats to run in the same wave, after the pilots (the first wave of the others: a wave of
    a few long pilots would leave workers idle).

    A rough optimum is one of many sharp local maxima (stick-slip friction on a long record), and
    SMC from a reference centred on it errs low: its moves, at acceptance 0.1-0.2, do not carry the
    particles to the higher maxima around it before the last stage. It errs by different amounts
    per model: on the 8 s friction release of benchmarks/nonlinear_long.py, by enough to rank the
    air, q1 and q3 hosts, which runs from a reference fitted to their particles (:func:`settle`'s
    second pass) find tied. Each rough model therefore runs one
    pilot first, from the Laplace reference, under the cheaper :data:`MIN_MOVED` rule (its
    log Z is not used), and its evidence runs start from the pilot's particles
    (:func:`~bayesbeam.inference.evidence.matched_reference`).
    """
    if not rough:
        return jobs, {}, {}
    progress = as_progress(log)
    progress(f"rough likelihood at the optimum of {', '.join(rough)}: a pilot SMC run each, whose particles "
             f"centre the reference of its evidence runs")
    pilot_tasks = _smc_tasks({m: (*jobs[m][:3], PILOT_OFFSET) for m in rough}, {m: range(1) for m in rough},
                             replace(config, min_moved=MIN_MOVED), seeds)
    other_tasks = _smc_tasks(jobs, alongside or {}, config, seeds)
    with progress.stage("evidence, pilot runs" + (" and the others' first runs" if other_tasks else ""),
                        len(pilot_tasks) + len(other_tasks), "run") as bar:
        runs = _run_tasks(pilot_tasks + other_tasks, executor, bar, checkpoint)
    pilots = {m: run for (m, _), run in zip(pilot_tasks, runs)}
    matched = {m: (i, post, matched_reference(post.priors, combine_runs([pilots[m]])), offset)
               for m, (i, post, _, offset) in jobs.items() if m in pilots}
    return {**jobs, **matched}, pilots, _by_model(other_tasks, runs[len(pilot_tasks):], alongside or {})


def _ceilings(posteriors: dict, stage1) -> dict:
    """Each model's log likelihood at its optimum: with the highest of its SMC particles', the
    ceiling of its log evidence (:func:`beaten`)."""
    return {m: optimum_log_likelihood(posteriors[m], optimum) for m, (_, optimum, _) in zip(posteriors, stage1)}


def optimum_log_likelihood(posterior, optimum) -> float:
    """The log likelihood at ``optimum``: its log posterior less the log prior (no second evaluation)."""
    return optimum.log_posterior - posterior.log_prior(optimum.theta)


def _runs(jobs: dict, repeats: dict, config: CompareConfig, seeds, executor, bar=None,
          checkpoint=NOTHING_SAVED) -> dict:
    """The SMC runs of each model's ``repeats`` (model -> repeat indices) for the models of
    ``jobs`` (see :func:`_evidence`), in one wave (:func:`_run_tasks`)."""
    tasks = _smc_tasks(jobs, repeats, config, seeds)
    return _by_model(tasks, _run_tasks(tasks, executor, bar, checkpoint), repeats)


def _smc_tasks(jobs: dict, repeats: dict, config: CompareConfig, seeds) -> list[tuple[str, tuple]]:
    """(model, :func:`smc_job`'s arguments) of each model's ``repeats``, those of the model with the most first."""
    tasks = []
    for m in sorted(repeats, key=lambda m: -len(repeats[m])):
        i, post, reference, offset = jobs[m]
        particles = config.particles or max(128, 32 * post.ndim)
        tasks += [(m, (post, reference, _seed(seeds, i * 1000 + offset + r), particles, config.min_moved))
                  for r in repeats[m]]
    return tasks


def _run_tasks(tasks: list, executor, bar=None, checkpoint=NOTHING_SAVED) -> list:
    """The SMC runs of ``tasks`` (:func:`_smc_tasks`), in order, in one map of ``executor``; each a
    step of ``checkpoint`` named by the model, its seed, the particles and the reference density."""
    def inputs(k):
        model, (_, reference, seed, particles, min_moved) = tasks[k]
        return {"model": model, "seed": seed, "particles": particles, "min_moved": min_moved,
                "reference": _reference_key(reference)}
    return checkpoint.map(executor, smc_job, [args for _, args in tasks], inputs, bar=bar) if tasks else []


def _by_model(tasks: list, runs: list, models) -> dict:
    """model -> its runs among ``runs`` (those of ``tasks``, in order), for each of ``models``."""
    return {m: [run for (owner, _), run in zip(tasks, runs) if owner == m] for m in models}


def _reference_key(reference) -> dict:
    """What tells one SMC reference density from another (:class:`~bayesbeam.inference.evidence.Reference`)."""
    tight = reference.tight.any()
    return {"tight": reference.tight, "bands": {str(i): band for i, band in reference.bands.items()},
            "df": reference.df, "mean": reference.mean if tight else None, "chol": reference.chol if tight else None}


def beaten(evidences: dict, margin: float, repeats: int, candidates=None, ceilings: dict | None = None) -> dict:
    """Models of ``candidates`` (default all) whose remaining evidence repeats cannot change the
    ranking, each with the reason: model -> text.

    A model is beaten when it trails the leader (the highest log Z of ``evidences``) by more than
    ``margin`` nats beyond three standard errors of the difference, and it is settled (sd at most
    :data:`EVIDENCE_SD_MAX`). An unsettled run errs low, so an unsettled model's log Z is not held
    against it; its ceiling is (``ceilings``: model -> the highest log likelihood found, at its
    optimum or on its SMC particles): log Z = log E_prior[L] <= log max L, and the highest value
    found stands for max L up to the prior's pull (a small fraction of a nat for the default
    priors, inside the margin) when the optimiser or the runs found the likelihood's mode. It is
    beaten when that ceiling trails the leader's log Z by the margin beyond three of the leader's
    standard errors. An unsettled leader counts with its lowest run (its runs err low, so its log
    Z lies above it), and its own standard error, which is large, widens every margin.
    """
    leader = max(evidences, key=lambda m: evidences[m].log_z)
    top = evidences[leader]
    floor = _floor(top)
    out = {}
    for m, e in evidences.items():
        if m == leader or (candidates is not None and m not in candidates):
            continue
        if e.log_z_sd <= EVIDENCE_SD_MAX:
            behind, sd = floor - e.log_z, float(np.hypot(top.log_z_sd, e.log_z_sd))
            if behind - 3 * sd > margin:
                out[m] = (f"stopped after {len(e.runs)} of {repeats} repeats: {behind:.1f} +- {sd:.1f} nats behind "
                          f"{leader}, more than {margin:g} nats beyond three standard errors, so its remaining "
                          f"repeats could not change the ranking")
        elif m in (ceilings or {}) and ceiling_gap(top, ceilings[m]) > margin:
            out[m] = (f"stopped after {len(e.runs)} of {repeats} repeats, unsettled: even the highest log likelihood "
                      f"found for it, which bounds its log evidence from above, is {floor - ceilings[m]:.1f} nats below "
                      f"{leader}'s log evidence, more than {margin:g} nats beyond three standard errors")
    return out


#: a decision counts as settled when its margin lies at least this far from the decisive line ...
SETTLED_NATS = 1.0
#: ... and holds whatever the remaining repeats give within this many run sds of the mean (:func:`settled`)
SETTLED_SDS = 3.0
#: how a reason of :func:`settled` ends (the verdict tells these stops from :func:`beaten`'s)
SETTLED_WORDS = "could not change a decision"


def settled(evidences: dict, decisive: tuple[float, float], repeats: int, candidates=None, beaten_=()) -> dict:
    """Models of ``candidates`` (default all) whose remaining evidence repeats cannot change any
    decision ``ln B - k sd > nats`` (``decisive`` = (nats, k)) between them and another model of
    ``evidences`` (those of ``beaten_`` left aside: far behind, their decisions are made), each
    with the reason. A leader whose every rival is beaten has no decision left to change; a model
    whose own runs have not settled is never settled (its second pass, :func:`settle`, is due).

    A pair's decision is settled when both models' runs are settled (sd at most
    :data:`EVIDENCE_SD_MAX`), its margin ``|ln B| - k sd - nats`` lies :data:`SETTLED_NATS` or more
    from zero, and keeps its sign when either model, or both, run their remaining repeats at
    their mean or :data:`SETTLED_SDS` run sds either side of it. Why that: the sd of two runs
    comes from one degree of freedom, and two runs that agree by chance leave the k sd term
    small; a third run moves a mean of two by a third of its distance and raises that term by
    about k times as much again. The run sd is the larger of the model's own and the pooled one
    of the models compared (their runs come from the same sampler on the same record).
    """
    out = {}
    others = [m for m in evidences if m not in beaten_]
    spread = pooled_run_sd([evidences[m] for m in others])
    for m in others:
        if candidates is not None and m not in candidates:
            continue
        margins = [_decision_margin(evidences[m], evidences[k], decisive, repeats, spread) for k in others if k != m]
        if evidences[m].log_z_sd <= EVIDENCE_SD_MAX and all(margin is not None for margin in margins):
            nearest = min(margins, default=np.inf)
            out[m] = (f"stopped after {len(evidences[m].runs)} of {repeats} repeats: " + (
                f"every decision against the other models (ln B above {decisive[0]:g} nats by {decisive[1]:g} "
                f"standard errors) lies {nearest:.1f} nats or more from its line and stays on its side whatever "
                f"the remaining repeats give within {SETTLED_SDS:g} run sds" if margins else
                "every other model is far behind it") + f", so its remaining repeats {SETTLED_WORDS}")
    return out


def pooled_run_sd(evidences) -> float:
    """The sd of one SMC run's log Z pooled over the settled ``evidences`` of two runs or more (0 if none)."""
    variances = [e.log_z_sd**2 * len(e.runs) for e in evidences if len(e.runs) > 1 and e.log_z_sd <= EVIDENCE_SD_MAX]
    return float(np.sqrt(np.mean(variances))) if variances else 0.0


def _decision_margin(a, b, decisive: tuple[float, float], repeats: int, spread: float) -> float | None:
    """|margin| of the decision between evidences ``a`` and ``b`` (:func:`settled`), or None when it
    is not settled."""
    if not (a.log_z_sd <= EVIDENCE_SD_MAX and b.log_z_sd <= EVIDENCE_SD_MAX):
        return None
    za, zb = [r.log_z for r in a.runs], [r.log_z for r in b.runs]
    margin = _margin(za, zb, decisive)
    if abs(margin) < SETTLED_NATS:
        return None
    if any((_margin(x, y, decisive) > 0) != (margin > 0)
           for x in _with_remaining(za, repeats, spread) for y in _with_remaining(zb, repeats, spread)):
        return None
    return abs(margin)


def decision_margin(log_bayes_factor: float, sd: float, decisive: tuple[float, float]) -> float:
    """ln B - k sd - nats (``decisive`` = (nats, k)): positive when a log Bayes factor of standard
    error ``sd`` is decisive under the caller's rule."""
    nats, sds = decisive
    return log_bayes_factor - sds * sd - nats


def _margin(za: list, zb: list, decisive: tuple[float, float]) -> float:
    """:func:`decision_margin` of |ln B| between two models' run log Zs, each combined as
    :func:`~bayesbeam.inference.evidence.combine_runs` combines runs."""
    (mean_a, se_a), (mean_b, se_b) = mean_and_standard_error(za), mean_and_standard_error(zb)
    return decision_margin(abs(mean_a - mean_b), float(np.hypot(se_a, se_b)), decisive)


def _with_remaining(z: list, repeats: int, spread: float) -> list[list]:
    """``z`` as it is, and with its remaining repeats each at its mean or :data:`SETTLED_SDS` run sds
    (the larger of ``spread`` and its own) either side of it."""
    left = repeats - len(z)
    if left <= 0:
        return [z]
    sd = max(spread, float(np.std(z, ddof=1)))
    return [z] + [z + [float(np.mean(z)) + t * SETTLED_SDS * sd] * left for t in (-1.0, 0.0, 1.0)]


def _floor(top) -> float:
    """The log Z a leader counts with: its own when settled, else its lowest run (its runs err low)."""
    return top.log_z if top.log_z_sd <= EVIDENCE_SD_MAX else min(run.log_z for run in top.runs)


def ceiling_gap(top, ceiling: float) -> float:
    """How far a model whose highest log likelihood found is ``ceiling`` (which bounds its log
    evidence from above) lies below the evidence ``top``, less three of top's standard errors
    (:func:`beaten`'s rule for an unsettled model)."""
    return _floor(top) - 3 * top.log_z_sd - ceiling


def settle(evidences: dict, posteriors: dict, config: CompareConfig, seeds, executor, log, skip=(),
           checkpoint=NOTHING_SAVED) -> dict:
    """A second evidence pass for every model (but those of ``skip``, stopped as beaten) whose
    repeats spread by more than :data:`EVIDENCE_SD_MAX`, from a reference fitted to its first
    pass's posterior particles (:func:`~bayesbeam.inference.evidence.matched_reference`; why
    there), as many repeats again; it replaces the first, which stays in ``Evidence.first_pass``.
    Others are returned as they are.
    """
    retry = [m for m, e in evidences.items() if e.log_z_sd > EVIDENCE_SD_MAX and m not in skip]
    if not retry:
        return evidences
    progress = as_progress(log)
    progress(f"evidence not settled for {', '.join(retry)}: a second pass from its posterior particles")
    index = {m: i for i, m in enumerate(evidences)}
    with progress.stage("evidence, second pass", len(retry) * config.repeats, "run") as bar:
        second, _ = _evidence({m: (index[m], posteriors[m], matched_reference(posteriors[m].priors, evidences[m]), 500)
                               for m in retry}, config, seeds, executor, bar=bar, checkpoint=checkpoint)
    return {m: replace(second[m], first_pass=e) if m in second else e for m, e in evidences.items()}


def _seed(seq, i) -> int:
    return int(np.random.default_rng([*seq.generate_state(2), i]).integers(2**31))


# ---------------------------------------------------------------------------- summary
def summarise(rec, results: dict, seconds: float, fit: FitConfig | None = None) -> dict:
    """comparison.json: ranking by log evidence, probabilities, posteriors, checks, verdict, each
    model's optimum, and what a later diagnosis needs to reuse the comparison
    (:mod:`bayesbeam.saved_comparison`): the recording's :func:`fingerprint` and, given the ``fit`` settings,
    the resolved :func:`fit_settings`."""
    log_z = {m: r.evidence.log_z for m, r in results.items()}
    ranking, prob = ranked(log_z)
    best = ranking[0]
    models = {}
    for m, p in zip(ranking, prob):
        r = results[m]
        model = r.problem.model
        models[m] = {
            "mechanisms": [k.name for k in model.mechanisms], "effects": [e.name for e in model.effects],
            "log_evidence": r.evidence.log_z, "log_evidence_sd": r.evidence.log_z_sd,
            "probability": float(p), "log_bayes_factor_vs_best": float(log_z[m] - log_z[best]),
            "evidence": {**{k: v for k, v in r.evidence.as_dict().items() if k not in ("log_evidence", "log_evidence_sd")},
                         **({"stopped_early": r.stopped} if r.stopped else {})},
            "posterior": posterior_summary(r),
            "ppc": {k: {"p_value": v["p_value"], "observed": v["observed"]} for k, v in r.check.statistics.items()},
            "modes": mode_table(r.check),
            "screens": r.screens,
            "n_intervals": model.n_intervals, "discretisation_check": r.discretisation,
            "optimum": optimum_entry(r.optimum),
        }
    settings = {} if fit is None else {"fit": fit_settings(fit, next(iter(results.values())).problem)}
    return {"recording": str(rec.source) if rec.source else None, "fingerprint": fingerprint(rec), **settings,
            "best": best, "ranking": ranking, "models": models, "verdict": verdict(ranking, models),
            "seconds": round(seconds, 1)}


def ranked(log_z: dict) -> tuple[list, np.ndarray]:
    """Models by log evidence (``log_z``: model -> log Z), highest first, and their posterior
    probabilities (equal prior probabilities)."""
    ranking = sorted(log_z, key=log_z.get, reverse=True)
    z = np.array([log_z[m] for m in ranking])
    prob = np.exp(z - z.max())
    return ranking, prob / prob.sum()


def optimum_entry(optimum) -> dict:
    """A model's optimum in comparison.json: the full parameter vector and its Laplace covariance in
    sampling coordinates (the posterior's ``names`` order), the log posterior there, evaluations."""
    return {"theta": np.asarray(optimum.theta).tolist(), "log_posterior": float(optimum.log_posterior),
            "covariance": np.asarray(optimum.covariance).tolist(), "n_evaluations": int(optimum.n_evaluations)}


def fingerprint(rec) -> dict:
    """What identifies a recording: the SHA-256 of its samples (time, signals, force) and of its
    description (beam, tip body, excitation, sensors, set-up keys), and its sample count."""
    digest = hashlib.sha256(repr((rec.beam, rec.tip, rec.excitation, rec.sensors, rec.setup_keys)).encode())
    for array in (rec.time, rec.signals, rec.force):
        if array is not None:
            digest.update(np.ascontiguousarray(array, dtype=np.float64).tobytes())
    return {"sha256": digest.hexdigest(), "samples": len(rec.time)}


def fit_settings(fit: FitConfig, problem) -> dict:
    """The settings that shape every model's likelihood besides the model itself, resolved on a
    prepared ``problem`` (the band's top in Hz, the fitted window and blocks in samples of the
    decimated record): what two fits must share for one's results to stand in for the other's."""
    projection = problem.likelihood.projection
    return {"max_frequency": float(projection.max_frequency), "decimation": int(problem.decimation),
            "window_samples": [int(projection.i0), int(projection.i1)], "block": int(projection.block),
            "noise": fit.noise, "degree": fit.degree, "n_intervals": fit.n_intervals,
            "force_window": fit.force_window, "force_noise": fit.force_noise, "effects": list(fit.effects),
            "priors": {name: [p.kind, p.a, p.b] for name, p in sorted(fit.priors.items())}}


def posterior_file_name(model: str) -> str:
    """The stem of a model's posterior NetCDF file (``posteriors/<stem>.nc``)."""
    return model.replace("+", "_plus_")


def posterior_summary(result: ModelResult) -> dict:
    """Per parameter: mean, sd, 5/50/95 % quantiles, unit, and R-hat across the SMC repeats."""
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        import arviz as az
    values = result.values()
    post = result.problem.posterior
    model = result.problem.model
    out = {}
    for i, name in enumerate(post.names):
        x = values[..., i]
        q05, q50, q95 = np.quantile(x, [0.05, 0.5, 0.95])
        out[name] = {"mean": float(x.mean()), "sd": float(x.std(ddof=1)), "q05": float(q05), "q50": float(q50),
                     "q95": float(q95), "r_hat": float(az.rhat(np.asarray(x))), "unit": parameter_unit(name, model)}
    return out


def strength(log_bayes_factor: float) -> str:
    """Kass & Raftery's (1995) words for a Bayes factor, their 2 ln B scale 2, 6, 10 in nats 1, 3, 5."""
    for threshold, word in KASS_RAFTERY:
        if log_bayes_factor >= threshold:
            return word
    return KASS_RAFTERY[-1][1]


def unsettled_evidence(model: dict) -> str | None:
    """Why a model's evidence has not settled (its SMC repeats disagree, :data:`EVIDENCE_SD_MAX`, or
    its pooled posterior's R-hat is high, :data:`R_HAT_MAX`), or None."""
    reasons = []
    if model["log_evidence_sd"] > EVIDENCE_SD_MAX:
        repeats = model.get("evidence", {}).get("repeats")
        spread = f"repeats {min(repeats):.1f} to {max(repeats):.1f} nats, " if repeats else ""
        reasons.append(f"{spread}sd {model['log_evidence_sd']:.1f} nats")
    r_hat = max((v["r_hat"] for v in model.get("posterior", {}).values()), default=1.0)
    if r_hat > R_HAT_MAX:
        reasons.append(f"R-hat up to {r_hat:.2f}")
    return ", ".join(reasons) or None


def described(model_summary) -> str:
    """A model's parts in words, 'air + strain_rate with sensor_mass'; a model of effects alone is
    named by its effects."""
    text = " + ".join(model_summary["mechanisms"])
    effects = ", ".join(model_summary["effects"])
    if not text:
        return effects
    return text + (" with " + effects if effects else "")


def verdict(ranking, models) -> str:
    """A plain-language paragraph: which model, how sure, and whether it fits."""
    best = ranking[0]
    b = models[best]
    mech = described(b)
    text = [(f"The data favour {best} ({mech}): posterior probability {b['probability']:.3f} among the "
             f"{len(ranking)} models compared (equal prior probabilities).")]
    if len(ranking) > 1:
        second = ranking[1]
        lbf = -models[second]["log_bayes_factor_vs_best"]
        sd = np.hypot(b["log_evidence_sd"], models[second]["log_evidence_sd"])
        text.append(f"Against the runner-up {second}, the log Bayes factor is {lbf:.1f} +- {sd:.1f} nats: "
                    f"{strength(lbf)} evidence (Kass & Raftery 1995).")
        if lbf < 3 * sd:
            text.append("That difference is within three standard errors of the evidence estimates: "
                        "more SMC repeats or particles are needed before ranking these two.")
    stopped = {m: why for m in ranking if (why := models[m].get("evidence", {}).get("stopped_early"))}
    behind = [m for m, why in stopped.items() if SETTLED_WORDS not in why]
    decided = [m for m, why in stopped.items() if SETTLED_WORDS in why]
    if behind:
        text.append(f"Evidence repeats stopped early for {', '.join(behind)}: after the first repeats each was "
                    "so far behind the leading model that its remaining repeats could not change the ranking "
                    "(margins under evidence.stopped_early).")
    if decided:
        text.append(f"Evidence repeats stopped early for {', '.join(decided)}: after the first repeats no decisive "
                    "comparison with it could change (margins under evidence.stopped_early).")
    unsettled = [f"{m} ({why})" for m in ranking if (why := unsettled_evidence(models[m]))]
    if unsettled:
        text.append(f"Not settled: {'; '.join(unsettled)}. The SMC runs of such a model disagree, so "
                    "its evidence and its place in the ranking are not established (a run that misses "
                    "the posterior's mode errs low); rerun it with more --particles or --repeats.")
    failed = [k for k, v in b["ppc"].items() if v["p_value"] is not None and v["p_value"] < PASS_P_VALUE]
    if failed:
        text.append(f"But the best model does not reproduce everything in the recording: posterior "
                    f"predictive p < {PASS_P_VALUE:g} for {', '.join(failed)}. Something the models leave out "
                    f"remains (see the per-mode table and residual spectrum), and a damping model "
                    f"can win by imitating part of it: the ranking is not a verdict on the mechanism "
                    f"until that is found. `bayesbeam diagnose` locates it, names the missing physics "
                    f"from its catalogue and compares the damping models again with it.")
    else:
        text.append(f"Its posterior predictive checks pass (every p-value >= {PASS_P_VALUE:g}): the recording looks "
                    "like the model's own replicates.")
    return " ".join(text)
