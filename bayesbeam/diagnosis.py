r"""What is the best damping model missing? Locate, name, model and show (the diagnosis).

1. **Baseline.** The named model (``model="q3"``), or the best of the damping models
   (``DiagnoseConfig.models``, default :data:`bayesbeam.comparison.DEFAULT_MODELS`; those that
   need a ``[material]`` table the recording lacks are left out and reported,
   :func:`bayesbeam.comparison.material_left_out`) by evidence, fitted by :func:`bayesbeam.comparison.compare`
   (optimum, discretisation, SMC evidence, posterior draws), or read back from a comparison of the
   recording already run (``from_comparison``, :mod:`bayesbeam.saved_comparison`).
2. **Locate** (:func:`bayesbeam.checks.discrepancy.locate`): where the residual stands above the
   noise floor, per mode, and the delay.
3. **Name** (:func:`bayesbeam.checks.signatures.rank_effects`): each catalogue effect's signature
   against the mismatch, ranked before anything expensive is fitted.
4. **Model.** The supported candidates (at least the top-ranked one, at most
   ``candidates``), and drag or friction when a mode's decay is bent (damping that falls or rises
   as the vibration decays; :func:`amplitude_dependence`), are added to the current model one at
   a time and fitted like it (own discretisation check, SMC evidence from repeated runs). Drag
   or friction that the current damping model cannot carry (a memory mechanism) is fitted with
   each damping model of the first comparison that can, the best of them its trial (:func:`_hosted`;
   a host whose optimum trails another's is optimised again from that one's values,
   :func:`_optimised`). A
   candidate is **added** when

   * its log Bayes factor against the current model exceeds :data:`DECISIVE` = 5 nats
     (2 ln B > 10, "very strong" on Kass & Raftery's 1995 scale: odds above 150 : 1, so that the
     extra parameter's Occam penalty, already inside the evidence, is beaten by a clear margin
     and a handful of null recordings cannot produce one by chance) by more than three standard
     errors of the estimate, **and**
   * the mismatch map improves: neither the RMS standardized residual nor the number of flags
     (significant spectrogram cells, per-mode flags, a delay) gets worse, and one of them gets
     better (:func:`improved`). Evidence alone could prefer a model that is better on average but
     wrong where it matters.

   Of several candidates that pass, the one with the largest log Bayes factor is added. A
   candidate decisively behind the current model or another candidate after its first SMC
   repeats gets no more (:func:`bayesbeam.comparison.beaten`); its evidence is the mean of those.
5. **Repeat once** (``rounds = 2``) from the augmented model for a second effect.
6. **Re-check the damping.** When the baseline was chosen by evidence and effects were added, the
   damping models of step 1 are compared again, each with the added effects: the first comparison
   could not see the missing physics, and a damping model that imitates part of it can win there
   (a root spring made q2 beat the true q1 by 361 nats on ``paper_rootcomp_hammer``). The final
   model becomes another damping model + effects only when that model's log evidence beats it by
   the same decisive margin as an effect needs (a damping model decisively behind it after its
   first repeats gets no more). After a switch the added effects are judged again with the new
   damping model, and one it does not need is dropped (:func:`prune_added`).
7. **Stand-ins.** An effect whose posterior median lies outside what the recording's stated
   set-up allows (:func:`stand_in`) is reported as a stand-in, "a structural mismatch the
   catalogue cannot name", not as missing physics found: the fit uses its freedom for something
   else. It is added like any effect (it does improve the fit), and diagnosis.json says which.
   The verdict is the final model's (:func:`final_stand_ins`): an added effect's posterior moves
   as later effects and the damping re-check change the model around it; an effect given with
   the baseline is judged by the same rule.
8. **Show.** Whatever beam physics the final model still misses (map regions not labelled as
   pickup) is reported as ``unexplained``, with where it is, when its misfit is also practically
   significant: at least :data:`~bayesbeam.checks.discrepancy.PRACTICAL_SHARE` (1 %) of the
   channel's signal (:mod:`bayesbeam.checks.discrepancy`, section (e)). Smaller statistically
   significant regions are listed as negligible.

Nothing is fitted when the baseline's map flags nothing, its signature mismatch is
insignificant and no pickup line (``mains_lines``) is supported: there is nothing to explain, and
``added`` is empty. A supported pickup line is fitted like any candidate although the map labels it
"not beam physics": the evidence and the map decide whether it is added.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field, replace

import numpy as np

from bayesbeam.checkpoint import NOTHING_SAVED, Checkpoint
from bayesbeam.checks.discrepancy import ALPHA, PRACTICAL_SHARE, Mismatch, locate, share_words
from bayesbeam.checks.signatures import PLACES, rank_effects
from bayesbeam.checks.survey import survey
from bayesbeam.comparison import (
    DEFAULT_MODELS,
    EARLY_STOP_NATS,
    CompareConfig,
    ceiling_gap,
    compare,
    decision_margin,
    expand_model_sets,
    fingerprint,
    left_out_words,
    material_left_out,
    optimise_models,
    optimum_log_likelihood,
    polish_job,
    posterior_summary,
)
from bayesbeam.comparison import summarise as summarise_comparison
from bayesbeam.executors import SerialExecutor
from bayesbeam.inference.priors import (
    SENSOR_MASS_SIGMA,
    default_priors,
    stated_gain_tolerances,
    stated_sensor_masses,
)
from bayesbeam.inference.screens import laplace_log_evidence
from bayesbeam.model import BeamModel, join_model, resolve_model, split_model
from bayesbeam.physics.effects import REGISTRY as EFFECTS
from bayesbeam.physics.effects.mains_lines import nominal_mains
from bayesbeam.progress import as_progress
from bayesbeam.saved_comparison import SavedComparison

#: decisive log Bayes factor (nats) for adding an effect; see the module docstring
DECISIVE = 5.0
#: and by this many standard errors of the evidence difference
DECISIVE_SD = 3.0
#: prior sds of log m_s a sensor mass's posterior median may lie from the stated mass (:func:`stand_in`)
STAND_IN_SDS = 3.0
#: standard gravity, m/s^2
GRAVITY = 9.80665
#: a fitted AC-coupling corner above this (Hz) is no sensor's or DAQ's (:func:`stand_in`)
HIGH_PASS_LIMIT = 10.0
#: stated calibration tolerances a fitted channel gain may lie from 0 (:func:`stand_in`)
GAIN_STAND_IN_TOLERANCES = 5.0
#: a support resonance, or an attached body's own mode, above this many times the Nyquist frequency
#: fs/2 is none (:func:`stand_in`)
RESONANCE_LIMIT = 10.0
#: a base heavier than this many times the mass beyond the clamp (rho A l + m_T) is none (:func:`stand_in`)
BASE_MASS_LIMIT = 1e4


@dataclass
class DiagnoseConfig:
    """Settings of a diagnosis.

    compare: fit and evidence settings of every model fitted (baseline and augmented);
    candidates: augmented models fitted per round; rounds: effects added at most;
    replicates: replicates of the mismatch map (see :func:`bayesbeam.checks.discrepancy.locate`);
    models: the damping models the baseline is chosen from and the damping re-check compares
    (names or named sets of :data:`bayesbeam.comparison.MODEL_SETS`); catalogue: the effects
    the screen ranks (names of :data:`bayesbeam.physics.effects.REGISTRY`; None: all of them).
    """

    compare: CompareConfig = field(default_factory=CompareConfig)
    candidates: int = 2
    rounds: int = 2
    replicates: int = 40
    models: tuple = DEFAULT_MODELS
    catalogue: tuple | None = None


@dataclass
class Trial:
    """One augmented model: the effect tried, its fit, its map and the decision."""

    round: int
    effect: str
    result: object                  # bayesbeam.comparison.ModelResult
    mismatch: Mismatch
    log_bayes_factor: float         # against the model it was added to
    log_bayes_factor_sd: float
    decisive: bool
    improved: bool
    added: bool = False             # added in its round
    dropped: bool = False           # and dropped after the damping re-check (:func:`prune_added`)


@dataclass(frozen=True)
class NotFitted:
    """A model the diagnosis would have fitted but did not, and why."""

    round: int                      # 0 for the damping re-check
    model: str
    reason: str


@dataclass
class DampingRecheck:
    """The damping models compared again, each with the effects the diagnosis added."""

    effects: tuple                  # the added effects, in order
    summary: dict                   # compare's summary of the damping models + effects
    results: dict                   # model -> ModelResult (the diagnosis's own final model among them)
    previous: str                   # the final model before the re-check
    switched: bool                  # another damping model is now decisively better
    not_fitted: list = field(default_factory=list)  # NotFitted (round 0): damping models left out
    dropped: tuple = ()             # added effects the switched damping model does not need (:func:`prune_added`)
    final: str | None = None        # the final model after :func:`prune_added` (None: not switched)
    pruning: dict = field(default_factory=dict)     # reduced model -> effect left out, ln B of keeping it, sd, needed
    tied: tuple = ()                # the other models not decisively behind the best: the evidence cannot rank them

    @property
    def best(self) -> str:
        return self.summary["best"]


@dataclass
class Diagnosis:
    """A diagnosis: the baseline, the maps, the rankings, the trials and the final model."""

    baseline: object                # ModelResult
    baseline_mismatch: Mismatch
    rankings: list                  # one Ranking per round that ranked
    trials: list
    final: object                   # ModelResult
    final_mismatch: Mismatch
    comparison: dict | None         # compare's summary when the baseline was chosen by evidence
    seconds: float
    recheck: DampingRecheck | None = None   # the damping models again, with the added effects
    not_fitted: list = field(default_factory=list)   # NotFitted: models left out, with the reason
    left_out: dict = field(default_factory=dict)     # damping model -> why none of its fits was tried

    @property
    def added(self) -> list[str]:
        """The effects in the final model that the diagnosis added."""
        return [t.effect for t in self.trials if t.added and not t.dropped]

    def remaining(self) -> list[dict]:
        """Map regions of the final model that are beam physics (not labelled pickup/non-decaying)
        and practically significant (their misfit reaches
        :data:`~bayesbeam.checks.discrepancy.PRACTICAL_SHARE` of the channel's signal)."""
        return [r for r in beam_regions(self.final_mismatch) if r["practically_significant"]]

    def negligible(self) -> list[dict]:
        """Beam-physics regions of the final model that are statistically significant but carry
        less than :data:`~bayesbeam.checks.discrepancy.PRACTICAL_SHARE` of the channel's signal."""
        return [r for r in beam_regions(self.final_mismatch) if not r["practically_significant"]]

    @property
    def unexplained(self) -> bool:
        """The final model still misses beam physics somewhere (see :meth:`remaining`)."""
        return bool(self.remaining())

    def chain(self) -> list[tuple[object, Mismatch]]:
        """(ModelResult, Mismatch) of the baseline, then of the model after each added effect:
        round r ranked, and augmented, entry r - 1. (The damping re-check, when it switched the
        damping model, is not a round: see :attr:`recheck`.)"""
        return [(self.baseline, self.baseline_mismatch)] + [(t.result, t.mismatch) for t in self.trials if t.added]

    def signature(self, trial: Trial):
        """The signature screen's candidate for the trial's effect in its round, or None."""
        return next((c for c in self.rankings[trial.round - 1].candidates if c.effect == trial.effect), None)

    def to_dict(self) -> dict:
        """diagnosis.json (its summary keys, then the maps, rankings and decisions in full)."""
        return summarise(self)


# ---------------------------------------------------------------------------- the diagnosis
def diagnose(rec, model: str | None = None, config: DiagnoseConfig | None = None, executor=None,
             log=None, effects: tuple = (), from_comparison=None, checkpoint=None, resume: bool = False) -> Diagnosis:
    """Diagnose ``rec`` against ``model`` (None: the best of ``config.models`` by evidence).

    ``effects``: effects known to be present, joined to ``model`` or to each model of
    ``config.models`` that can carry them (:func:`combinable`); the catalogue search adds to them.
    ``from_comparison``: the folder of a comparison of ``rec`` with the same fit settings
    (``bayesbeam compare --out``), whose fits of the baseline models are reused
    (:func:`baseline_fits`). ``checkpoint``: a folder where each comparison, each wave of
    optimisations and each SMC run is saved as it finishes (:class:`~bayesbeam.checkpoint.Checkpoint`); with
    ``resume``, those found there (from a killed diagnosis of the same recording with the same
    settings) are read back instead of run.
    """
    config = config or DiagnoseConfig()
    say = log or (lambda _text: None)
    started = time.perf_counter()
    rng = np.random.default_rng(config.compare.seed)
    effects = tuple(effects)
    damping, left_out = material_left_out(rec, expand_model_sets(config.models))
    config = replace(config, models=tuple(damping))
    saved = NOTHING_SAVED if checkpoint is None else Checkpoint(
        checkpoint, {"recording": fingerprint(rec), "model": model, "effects": list(effects),
                     "from_comparison": None if from_comparison is None else str(from_comparison),
                     "settings": repr(config)}, resume, say)
    models = ([join_model(model, effects)] if model
              else [s for s in (join_model(m, effects) for m in damping) if combinable(s)])
    results, summary = baseline_fits(rec, models, model is not None, config, executor, log, from_comparison, saved)
    current = results[summary["best"]]
    mismatch = _locate(current, rng, config)
    baseline, baseline_map = current, mismatch
    say(f"baseline {current.name}: RMS standardized residual {mismatch.rms_standardized_residual:.2f}, "
        f"{len(mismatch.regions)} mismatch region(s)")
    rankings, trials, not_fitted, last_added = [], [], [], None
    spare = {}                      # hosted fits not chosen as their effect's trial: model -> ModelResult
    ceilings = {}                   # hosts not sampled: model -> its optimum's log likelihood
    first = first_fits(results, damping, effects)
    for round_ in range(1, config.rounds + 1):
        ranking = rank_effects(current.problem.posterior, _draws(current), mismatch, config.catalogue, executor,
                               quiet=not beam_regions(mismatch))
        rankings.append(ranking)
        if ranking.nothing_left:
            say("nothing left to explain: no beam-physics region flagged, projected mismatch insignificant")
            break
        partners = partner_effects(last_added) if last_added else set()
        chosen, unfitted = _fittable(rec, current, _candidates(ranking, mismatch, config.candidates,
                                                                  rec.excitation.kind == "free_decay", partners, rec),
                                     round_)
        not_fitted += unfitted
        for n in unfitted:
            say(f"round {round_}: not fitting {n.model}: {n.reason}")
        hosted = _hosted(rec, current, mismatch, ranking, first, config.catalogue)
        if not chosen and not hosted:
            break
        say(f"round {round_}: fitting {', '.join([current.name + '+' + c.effect for c in chosen] + list(hosted))}")
        fitted, hosted, unsampled = _fit_augmented(rec, current, chosen, config, executor, log, hosted, saved)
        for spec, (ceiling, why) in unsampled.items():
            not_fitted.append(NotFitted(round_, spec, why))
            ceilings[spec] = ceiling
        best_hosted = _best_hosted(hosted, fitted[len(chosen):])
        spare.update({r.name: r for r in fitted[len(chosen):] if r not in best_hosted.values()})
        round_trials = [_trial(round_, e, current, mismatch, f, rng, config)
                        for e, f in [*zip((c.effect for c in chosen), fitted), *best_hosted.items()]]
        trials += round_trials
        winners = [t for t in round_trials if t.decisive and t.improved]
        if not winners:
            say(f"round {round_}: no candidate passes (decisive evidence and an improved map)")
            break
        best = max(winners, key=lambda t: t.log_bayes_factor)
        best.added, last_added = True, best.effect
        current, mismatch = best.result, best.mismatch
        say(f"added {label(best.effect, effect_parameters(best), rec)}: ln B = {best.log_bayes_factor:.1f} +- {best.log_bayes_factor_sd:.1f}, "
            f"RMS standardized residual {mismatch.rms_standardized_residual:.2f}")
    recheck = None
    added = tuple(t.effect for t in trials if t.added)
    if model is None and added:
        recheck = recheck_damping(rec, current, effects + added, config, executor, log, first=first, fitted=spare,
                                  ceilings=ceilings, checkpoint=saved)
        not_fitted += recheck.not_fitted
        if recheck.switched:
            current = prune_added(rec, recheck, effects, added, first, config, executor, log, saved)
            for t in trials:
                t.dropped = t.effect in recheck.dropped
            mismatch = _locate(current, rng, config)
    if saved.read_back:
        say(f"resumed: {saved.read_back} step(s) read back from {checkpoint}")
    return Diagnosis(baseline, baseline_map, rankings, trials, current, mismatch, None if model else summary,
                     time.perf_counter() - started, recheck, not_fitted, {} if model else left_out)


def first_fits(results: dict, damping: list, effects: tuple) -> dict:
    """The first comparison's fits, damping model name -> ModelResult (of the model + the given ``effects``)."""
    return {m: results[join_model(m, effects)] for m in damping if join_model(m, effects) in results}


def baseline_fits(rec, models: list, named: bool, config: DiagnoseConfig, executor, log,
                  folder=None, checkpoint=NOTHING_SAVED) -> tuple[dict, dict]:
    """compare's (results, summary) of the baseline ``models`` (``named``: the one model given).

    With a comparison ``folder`` (:class:`~bayesbeam.saved_comparison.SavedComparison`) they are
    read back from it instead of fitted: the folder must be a comparison of ``rec`` with the
    diagnosis's fit settings and hold every model of ``models``; a named model it lacks is fitted
    (through ``checkpoint``, :func:`compared`).
    """
    say = log or (lambda _text: None)
    saved = None if folder is None else SavedComparison(folder, rec, config.compare.fit)
    if saved is None or (named and models[0] not in saved.models):
        say(f"baseline: {'fitting ' + models[0] if named else 'comparing ' + ', '.join(models)}"
            + ("" if saved is None else f" (not in {folder})"))
        return compared(checkpoint, rec, models, config.compare, executor, log)
    results = saved.results(models)
    say(f"baseline: {', '.join(models)} read from the comparison in {folder}")
    return results, saved.summary(models)


def recheck_damping(rec, current, effects: tuple, config: DiagnoseConfig, executor, log,
                    first: dict | None = None, fitted: dict | None = None, ceilings: dict | None = None,
                    checkpoint=NOTHING_SAVED) -> DampingRecheck:
    """Compare the damping models ``config.models`` + ``effects`` (those that can carry them) with ``current``.

    ``current`` (a damping model + the effects, already fitted) is not refitted. The switch needs
    ln B > :data:`DECISIVE` by :data:`DECISIVE_SD` standard errors, the rule that added the effects.
    ``first``: the first comparison's fits (damping model name -> ModelResult). Each damping model
    is optimised from its global search and, as well, from its own first optimum with the effects'
    (and the shared parameters') values of ``current`` (:func:`_recheck_start`): the global
    search alone can miss the optimum of a model twice as wide as the one it found first.
    ``fitted``: models fitted before with the same effects (model -> ModelResult: the hosts of a
    nonlinear effect, :func:`_hosted`), taken as they are. ``ceilings``: models optimised before
    but not sampled (model -> its optimum's log likelihood, :func:`unsampled_hosts`): one whose
    ceiling trails ``current``'s log evidence by :data:`~bayesbeam.comparison.EARLY_STOP_NATS`
    beyond three of its standard errors cannot be the better model, and is not fitted again.
    """
    say = log or (lambda _text: None)
    known = _optimum_values(current)
    specs = {join_model(m, effects): m for m in config.models}
    others, left_out = _leave_out_slow(rec, {s: known for s in specs if s != current.name and combinable(s)}, 0)
    below = {s: why for s in others if s in (ceilings or {}) and (why := _below(ceilings[s], current))}
    others = [s for s in others if s not in below]
    left_out += [NotFitted(0, s, why) for s, why in below.items()]
    reused = {s: fitted[s] for s in others if s in (fitted or {})}
    to_fit = [s for s in others if s not in reused]
    say(f"re-checking the damping with {', '.join(effects)}: {', '.join(others)}"
        + (f" ({', '.join(reused)} fitted before)" if reused else ""))
    started = time.perf_counter()
    starts = {s: _recheck_start(first[specs[s]], current) for s in to_fit if first and specs[s] in first}
    results = compared(checkpoint, rec, to_fit, config.compare, executor, log, starts=starts,
                       rivals={current.name: current.evidence})[0] if to_fit else {}
    results.update(reused)
    results[current.name] = current
    summary = summarise_comparison(rec, results, time.perf_counter() - started)
    best = results[summary["best"]]
    lbf, sd, switched = decisively_above(best, current)
    tied = tuple(m for m, r in results.items() if r is not best and not decisively_above(best, r)[2])
    say(f"damping re-check: best {best.name}" + (f", {lbf:.1f} +- {sd:.1f} nats above {current.name}: switched"
                                                 if switched else f"; {current.name} kept")
        + (f"; not decisively behind the best: {', '.join(tied)}" if tied else ""))
    return DampingRecheck(effects, summary, results, current.name, switched, left_out, tied=tied)


def decisively_above(upper, lower) -> tuple[float, float, bool]:
    """(ln B, its sd, decisive) of the fitted model ``upper`` against ``lower``: decisive when
    ln B exceeds :data:`DECISIVE` by :data:`DECISIVE_SD` standard errors (the rule that adds an effect)."""
    lbf = float(upper.evidence.log_z - lower.evidence.log_z)
    sd = float(np.hypot(upper.evidence.log_z_sd, lower.evidence.log_z_sd))
    return lbf, sd, bool(decision_margin(lbf, sd, (DECISIVE, DECISIVE_SD)) > 0)


def prune_added(rec, recheck: DampingRecheck, given: tuple, added: tuple, first: dict, config: DiagnoseConfig,
                executor, log, checkpoint=NOTHING_SAVED):
    """The final model after the re-check switched the damping: the added effects judged again.

    Each effect was added by a decisive log Bayes factor against the damping model of the first
    comparison; part of what it explained there can be that model's wrong damping (a root
    dashpot makes up for q2's on a beam with q1's). So, by backward elimination, each added
    effect that no other one requires is left out in turn (the models fitted together, each from
    the full model's optimum, which nests it; the bare damping model is the first comparison's
    fit): while some effect's removal costs less than the decisive margin (ln B <=
    :data:`DECISIVE` by :data:`DECISIVE_SD` standard errors), the one whose removal leaves the
    highest evidence is dropped. Given effects stay. Returns the final ModelResult and records ``recheck.dropped``
    and ``recheck.pruning`` (reduced model -> the effect left out, ln B of keeping it, its sd),
    ``recheck.final`` and the reduced fits in ``recheck.results``.
    """
    say = log or (lambda _text: None)
    damping = next(m for m in config.models if join_model(m, recheck.effects) == recheck.best)
    final, kept = recheck.results[recheck.best], list(added)
    while kept:
        reduced = {spec: left for left in kept
                   if combinable(spec := join_model(damping, given + tuple(e for e in kept if e != left)))}
        if not reduced:                 # no effect can go alone (the others need it)
            break
        fitted = {first[damping].name: first[damping]} if damping in first else {}
        to_fit = [spec for spec in reduced if spec not in fitted]
        say(f"judging {', '.join(kept)} again with {damping}: {', '.join(reduced)}")
        if to_fit:
            known = _optimum_values(final)
            results, _ = compared(checkpoint, rec, to_fit, config.compare, executor, log,
                                  starts={s: known for s in to_fit}, rivals={final.name: final.evidence})
            fitted.update(results)
            recheck.results.update(results)
        costs = {}
        for spec, left in reduced.items():
            lbf, sd, needed = decisively_above(final, fitted[spec])
            recheck.pruning[spec] = {"without": left, "log_bayes_factor": lbf, "sd": sd, "needed": needed}
            if not needed:
                costs[spec] = lbf
        if not costs:
            break
        spec = min(costs, key=costs.get)
        say(f"dropped {reduced[spec]}: with {damping} it is not needed (ln B {costs[spec]:.1f} nats)")
        kept.remove(reduced[spec])
        recheck.dropped += (reduced[spec],)
        final = fitted[spec]
    recheck.final = final.name
    return final


def compared(checkpoint, rec, models, config, executor, log, starts=None, rivals=None, optimised=None):
    """:func:`~bayesbeam.comparison.compare`'s (results, summary), a step of ``checkpoint``
    (:mod:`bayesbeam.checkpoint`) named by the models, their starts, the rivals' log evidence and
    the log posterior of each optimum given; its SMC runs are steps of their own, saved as each
    finishes. The comparison knows the diagnosis decides by :data:`DECISIVE`: a model's remaining
    evidence repeats are skipped once none of those decisions about it can change
    (:func:`~bayesbeam.comparison.settled`)."""
    inputs = {"models": list(models), "starts": starts or {},
              "rivals": {m: [e.log_z, e.log_z_sd] for m, e in (rivals or {}).items()},
              "optimised": {m: o[1].log_posterior for m, o in (optimised or {}).items()}}
    return checkpoint.step("compare", inputs, lambda: compare(rec, models, config, executor, log, starts=starts,
                                                              rivals=rivals, optimised=optimised,
                                                              checkpoint=checkpoint, decisive=(DECISIVE, DECISIVE_SD)))


def _below(ceiling: float, current) -> str | None:
    """Why a model whose highest log likelihood found is ``ceiling`` cannot beat ``current`` (its
    log evidence, at most that ceiling, trails current's by EARLY_STOP_NATS beyond three of
    current's standard errors: :func:`~bayesbeam.comparison.ceiling_gap`), or None."""
    behind = ceiling_gap(current.evidence, ceiling)
    if behind <= EARLY_STOP_NATS:
        return None
    return (f"its optimum's log likelihood, which bounds its log evidence from above, lies {behind:.1f} nats "
            f"below {current.name}'s log evidence (less three standard errors)")


def too_slow(rec, spec: str, known: dict) -> str | None:
    """Why ``spec`` is not fitted, or None: a memory mechanism beside non-modal damping or beside
    an added stiffness of full rank (such as q2 + axial_load) has no modal form, and its transfer
    function needs an elimination of Z(s) per frequency (the ``banded`` form: 11 ms per simulation
    of a 4 s paper record at N = 48, seven times q2's, benchmarks/effects.py; the ``dense`` one
    where Z has no narrow band: 207 ms at N = 32), so its fits would take most of a diagnosis's
    time. A free decay's likelihood needs only the poles under the stopband and their mode shapes
    (its whole likelihood 1.7-2.5 x q2's on the real record for q2 + axial_load, table 1c
    there), so nothing is left out there. Judged at ``known`` values and the default priors'
    medians for the rest (the form does not depend on N; N = 6 here)."""
    if rec.excitation.kind == "free_decay":
        return None
    model = BeamModel(rec, spec, 6)
    try:
        form = model.system(known_or_median(model, known)).form
    except ValueError:              # not physical at these values: let the fit find out
        return None
    if form not in ("banded", "dense"):
        return None
    cost = "five to seven times its base model's" if form == "banded" else "80 to 180 times its base model's"
    return ("its memory mechanism sits beside non-modal damping or a full-rank added stiffness, so its "
            f"transfer function needs a solve of Z(s) per frequency ({cost} per likelihood): "
            "fit it explicitly if it matters")


def built(rec, spec: str) -> BeamModel | None:
    """``spec``'s model for ``rec`` (N = 6), or None where it cannot be built (:func:`combinable`,
    and what the model refuses for the recording: a nonlinear effect on a free decay)."""
    if not combinable(spec):
        return None
    try:
        return BeamModel(rec, spec, 6)
    except ValueError:
        return None


def known_or_median(model: BeamModel, known: dict) -> dict:
    """Values of every parameter of ``model``: ``known``'s where it has one, else the default prior's median."""
    rec = model.recording
    priors = default_priors(rec.beam, model.parameter_names, {}, rec.setup)
    return {n: known[n] if n in known else float(priors[n].to_value(priors[n].median())) for n in model.parameter_names}


def _leave_out_slow(rec, specs: dict, round_: int) -> tuple[list[str], list[NotFitted]]:
    """The models of ``specs`` (model -> values to judge it at, see :func:`too_slow`) that can be
    fitted, and a NotFitted for each of the rest."""
    left_out = [NotFitted(round_, spec, why) for spec, values in specs.items() if (why := too_slow(rec, spec, values))]
    slow = {n.model for n in left_out}
    return [spec for spec in specs if spec not in slow], left_out


def _fittable(rec, current, candidates: list, round_: int) -> tuple[list, list]:
    """The candidates whose augmented model can be fitted, and a NotFitted for each of the rest."""
    kept, left_out = _leave_out_slow(rec, {f"{current.name}+{c.effect}": _probe_values(current, c)
                                           for c in candidates}, round_)
    return [c for c in candidates if f"{current.name}+{c.effect}" in kept], left_out


def _optimum_values(result) -> dict:
    """The fitted model's parameters (by name) at its optimum, without the set-up's nuisances."""
    values = _values_at(result.problem, result.optimum)
    return {n: v for n, v in values.items() if n in result.problem.posterior.model_names}


def _recheck_start(damping, current) -> dict:
    """Values to optimise ``damping`` + the effects of ``current`` from: ``damping``'s own optimum
    (a first-comparison fit) for its mechanisms' parameters, ``current``'s for the rest (EI, the
    set-up's nuisances and the effects, which ``current`` fitted together)."""
    return {**_optimum_values(damping), **_optimum_values(current)}


def _probe_values(current, candidate) -> dict:
    """The current model's optimum with the candidate's screened value (None: left to its prior) and
    the effect's other parameters where the screen held them (the other sensors' stated masses)."""
    known = {**getattr(candidate, "others", {}), **_optimum_values(current)}
    return known if candidate.value is None else {**known, candidate.parameter: candidate.value}


def combinable(spec: str) -> bool:
    """Whether the mechanisms and effects of ``spec`` go together: a nonlinear effect cannot carry a
    memory mechanism (the nonlinear integrator needs a state-space model), and every component
    needs what it requires beside it (a root dashpot the root spring)."""
    mechanisms, effects = resolve_model(spec)
    names = {c.name for c in (*mechanisms, *effects)}
    return (not (any(not e.linear for e in effects) and any(m.hereditary for m in mechanisms))
            and all(set(c.requires) <= names for c in (*mechanisms, *effects)))


def _locate(result, rng, config: DiagnoseConfig) -> Mismatch:
    return locate(result.problem.posterior, _draws(result), rng, config.replicates)


def _draws(result) -> np.ndarray:
    return result.draws.reshape(-1, result.problem.posterior.ndim)


#: the sign of a mode's decay-curvature error -> the catalogue effect that bends the decay that way
DECAY_SHAPE = {1: "quadratic_drag",      # damping falls as the vibration decays
               -1: "dry_friction"}       # damping rises as the vibration decays


def partner_effects(added: str) -> set[str]:
    """The catalogue effects that need ``added`` beside them (their ``requires``): the root dashpot
    of a root spring. They could not be fitted before it was added, and the screen, linearised about
    their absence, can rank them low while the partner stands in for them (a root spring fitted
    alone to a clamp with losses lands several of its own sds off): the round after ``added`` fits
    them whatever their rank."""
    return {name for name, effect in EFFECTS.items() if added in effect.requires}


#: effects the screen cannot reliably tell apart, so that where one is fitted the other is too: an
#: attached body and a support resonance each add a mode of their own, and the screen, holding their
#: masses at the priors' medians, ranks either above the other on the other's recording (a body at
#: 0.625 l above a 5 kg base at 80 Hz, studies/concealed_effects; a body within 0.4 % of a 2 kg
#: base's Delta chi2, tests/checks/test_signatures.py): their fits' evidence decides
RIVALS = {"attachment": {"base_support"}, "base_support": {"attachment"}}
#: a body the screen places at a sensor (within the places' spacing l/PLACES, its resolution) is
#: first tried as that sensor's mass: riding there on a stiff link it is that mass, the simpler
#: model, and beside a wrong damping model its link's damping can stand in for the model's error
#: (a 5 g mid-span sensor's concealed mass, screened as a body at 0.3125 m, fitted beside air
#: damping as a 4.6 g body on a link damped 29 %, ln B 652.5 against the sensor mass's 559.9;
#: tests/acceptance/test_sensor_order.py). The body stays a candidate of the next round.
AT_SENSOR = ("attachment", "sensor_mass")


def _rivals(chosen: list) -> set[str]:
    """The effects fitted beside ``chosen`` as their rivals (:data:`RIVALS`)."""
    return {r for c in chosen for r in RIVALS.get(c.effect, ())}


def _at_sensor(candidate, rec) -> bool:
    """Whether the screen places ``candidate`` (a placed effect's) within l/PLACES of a sensor of ``rec``."""
    near = rec.beam.length / PLACES
    return any(abs(x - s.location) <= near for x in candidate.place.values() for s in rec.sensors)


def _sensor_mass_first(chosen: list, ranked: list, rec) -> list:
    """``chosen`` with a body placed at a sensor replaced by the supported sensor mass (:data:`AT_SENSOR`)."""
    body, mass = (next((c for c in ranked if c.effect == e and c.supported), None) for e in AT_SENSOR)
    if rec is None or body not in chosen or mass is None or not _at_sensor(body, rec):
        return chosen
    return [c for c in chosen if c is not body] + ([mass] if mass not in chosen else [])


def _candidates(ranking, mismatch: Mismatch, n: int, free_decay: bool = False, partners=(), rec=None) -> list:
    """The supported candidates in ranking order (at least the top one, at most ``n``), the
    ``partners`` of the effect added last (:func:`partner_effects`), and the effect the decay
    shapes point to (:func:`amplitude_dependence`). On a free decay with none
    supported, every ranked candidate: there the screen has no excitation time (no phases) and
    fits the initial state freely (little left in the amplitudes), beside a memory baseline it
    projected a sensor mass and an axial load worth 1800 nats to nothing (the real record,
    studies/real_steel_cantilever), and a free decay's fits take seconds.

    Only drag and friction make the damping depend on amplitude, so a bent decay is direct
    evidence for one of them. Their signature screen is linearised about zero, and at realistic
    sizes they are far from linear (10 % of the response's RMS of tip friction more than doubles
    mode 1's damping): the screen can miss them, so the decay shape adds them.

    A body placed at one of ``rec``'s sensors is tried as that sensor's mass first
    (:data:`AT_SENSOR`), and a supported rival of a chosen candidate (:data:`RIVALS`) is fitted
    beside it.

    The screen ranks a sensor's mass per sensor, but fitting ``sensor_mass`` fits every sensor's
    mass (:mod:`bayesbeam.physics.effects.sensor_mass`), so an effect is fitted once, with its
    best-ranked candidate's value as a start.
    """
    ranked = _first_per_effect(ranking.candidates)
    supported = [c for c in ranked if c.supported]
    chosen = supported[:n] or (ranked if free_decay else ranked[:1])
    chosen = _sensor_mass_first(chosen, ranked, rec)
    rivals = _rivals(chosen)
    chosen += [c for c in supported if c.effect in rivals and c not in chosen]
    shapes = amplitude_dependence(mismatch) | input_shift(mismatch) | set(partners)
    return chosen + [c for c in ranked if c.effect in shapes and c not in chosen]


def _first_per_effect(candidates) -> list:
    """The candidates in ranking order, each effect once (its best-ranked sensor's, for a sensor mass)."""
    seen = set()
    return [c for c in candidates if not (c.effect in seen or seen.add(c.effect))]


def input_shift(mismatch: Mismatch) -> set[str]:
    """A measurement delay when the force-noise latent terms carry more than the force channel's
    measured noise allows (:func:`bayesbeam.checks.discrepancy.latent_force`).

    Those terms let the fitted force move within its noise; a delay between the force and the
    response channels is, for a linear beam, the same as a shifted force, so they absorb it: on
    the reference simulator's paper beam a 0.5 ms delay left the q1 map with no flagged cell and
    no delay (the prediction includes the latent force), only latent samples of up to 6 sigma
    (chi2 264 on 50 samples, p = 8e-31). The signature screen, whose features are measured
    against that prediction, cannot see it.
    """
    return {"measurement_delay"} if (mismatch.phase.get("force") or {}).get("significant") else set()


def amplitude_dependence(mismatch: Mismatch) -> set[str]:
    """Drag and/or friction when some mode's decay curvature differs from the model's replicates
    at level ALPHA / (number of modes), two-sided.

    This is a *screen* for what to fit, not a finding: it is looser than the map's own flag (which
    shares ALPHA / 3 with every per-mode statistic, ALPHA / 60 a test for four modes), because a
    candidate fitted in vain costs only time, while the decision to add one still needs decisive
    evidence and an improved map. On the paper beam a drag that bent mode 3's decay by 4 sd
    (p = 3e-4) missed the map's flag (1.7e-4) and was fitted a round late, after a root spring that
    imitated part of it.
    """
    level = ALPHA / max(len(mismatch.modes), 1)
    found = set()
    for row in mismatch.modes:
        p, error = row["p_values"].get("curvature"), row.get("curvature_error_per_s")
        if p is not None and p < level and error:
            found.add(DECAY_SHAPE[int(np.sign(error))])
    return found


def _hosted(rec, current, mismatch: Mismatch, ranking, first: dict, catalogue=None) -> dict[str, tuple[str, dict]]:
    """The nonlinear effects of ``catalogue`` (None: all) that the decay shapes point to
    (:func:`amplitude_dependence`) and ``current``'s damping cannot carry (a memory mechanism: the
    nonlinear integrator needs a state-space model), each with ``current``'s effects hosted by
    every damping model of the ``first`` comparison (damping model -> ModelResult) that can carry
    it (none on a free decay, which no nonlinear model simulates): model spec -> (effect, values
    to start from: the host's optimum, ``current``'s for the parameters they share, the effect's
    prior medians), the best host by the first comparison's evidence first.

    Friction makes a memory mechanism win the first comparison (time hysteresis 48 nats above the
    true q1 on an 8 s friction release, benchmarks/nonlinear_long.py), and the screen cannot rank
    friction beside it: without a host the decay's bend, the direct evidence for friction, would
    never be fitted. That comparison, misled by the friction, cannot say which host is right, so
    every host is fitted, together (:func:`_best_hosted` takes the best as the effect's trial, its
    log Bayes factor against ``current``; adding it changes the damping model with it; a host's
    optimisation is repeated from the best host's values where it trails, :func:`_optimised`),
    and the damping re-check reuses the other hosts' fits when nothing else was added.
    """
    effects = split_model(current.name)[1]
    ranked = {c.effect for c in ranking.candidates} | set(effects)
    hosted = {}
    for effect in sorted((amplitude_dependence(mismatch) & set(catalogue or EFFECTS)) - ranked):
        if combinable(join_model(current.name, [effect])):
            continue
        for host in sorted(first, key=lambda m: -first[m].evidence.log_z):
            spec = join_model(host, effects + (effect,))
            if (model := built(rec, spec)) is not None:
                hosted[spec] = (effect, known_or_median(model, _recheck_start(first[host], current)))
    return hosted


def _best_hosted(hosted: dict, results: list) -> dict:
    """effect -> the ModelResult of its best host by evidence (``results``: the fits of ``hosted``'s models, in order)."""
    best = {}
    for (effect, _), result in zip(hosted.values(), results):
        if effect not in best or result.evidence.log_z > best[effect].evidence.log_z:
            best[effect] = result
    return best


def _fit_augmented(rec, current, candidates, config: DiagnoseConfig, executor, log,
                   hosted=None, checkpoint=NOTHING_SAVED) -> tuple[list, dict, dict]:
    """(ModelResults of ``current + effect`` for each candidate, then of each host sampled, in
    one comparison (parallel over models), from :func:`_optimised`; the hosts sampled, as
    ``hosted`` (:func:`_hosted`); the hosts not sampled, :func:`unsampled_hosts`).

    Each candidate is optimised from its global search and, as well, from the current model's
    optimum with the effect at the signature's value: the augmented model nests the current one,
    so its optimum must be at least as high, and a global search alone can end in a worse mode.
    That start's EI is the current model's, which may have absorbed the effect (a rigid root on a
    softer beam stands in for a compliant root in the first mode), so EI is also re-determined
    there with the effect and every other parameter held, and polished from as well
    (:func:`~bayesbeam.inference.fit.local_starts`); the highest optimum is kept.
    """
    specs = [f"{current.name}+{c.effect}" for c in candidates]
    starts = {s: _probe_values(current, c) for s, c in zip(specs, candidates) if c.value is not None}
    hosted = hosted or {}
    optima = checkpoint.step("optimise", {"models": specs, "starts": starts, "hosted": hosted},
                             lambda: _optimised(rec, specs, starts, hosted, config, executor, log))
    unsampled = unsampled_hosts({s: effect for s, (effect, _) in hosted.items()},
                                {s: _at_optimum(optima[s])[1] for s in hosted},
                                {s: laplace_log_evidence(optima[s][1])["log_evidence"] for s in hosted})
    hosted = {s: h for s, h in hosted.items() if s not in unsampled}
    for spec, (_, why) in unsampled.items():
        as_progress(log)(f"not sampling {spec}: {why}")
    results, _ = compared(checkpoint, rec, specs + list(hosted), config.compare, executor, log,
                          rivals={current.name: current.evidence},
                          optimised={s: optima[s] for s in specs + list(hosted)})
    return [results[s] for s in specs + list(hosted)], hosted, unsampled


def _optimised(rec, specs: list, starts: dict, hosted: dict, config: DiagnoseConfig, executor, log) -> dict:
    """The optimisations (spec -> what :func:`~bayesbeam.comparison.optimise_job` returns) of the
    candidates' models ``specs`` (from ``starts`` as well, where given) and of the models of
    ``hosted`` (:func:`_hosted`, each from its start), all in one parallel wave; then, where a
    host's optimum trails the best host of its effect (:func:`cross_starts`), that host again
    from the best host's values, by local optimisations alone (its global search has run):
    the higher optimum is kept.

    The hosts share EI, gamma and the effect's parameters, and on a long record the friction
    likelihood has many sharp modes (along F_c alone, the others held, local maxima a few tenths
    of a percent apart with dips of tens of nats between them), so an optimisation from a host's
    own start can end in a poor one. On the 8 s friction release (benchmarks/nonlinear_long.py)
    q1+dry_friction's ended 993 nats below q3+dry_friction's, although q1 is the truth and q3
    adds spatial hysteresis to q1's air damping; its SMC, from that optimum, stayed there, and q3
    became the damping model.
    """
    executor = executor or SerialExecutor()
    progress = as_progress(log)
    models = specs + list(hosted)
    optima = optimise_models(rec, models, config.compare, executor, progress,
                             {**starts, **{s: start for s, (_, start) in hosted.items()}})
    again = cross_starts({s: effect for s, (effect, _) in hosted.items()}, {s: _at_optimum(optima[s]) for s in hosted})
    seeds = np.random.SeedSequence([config.compare.seed, len(models)]).generate_state(len(again))
    jobs = [(rec, s, config.compare, int(seed), start) for seed, (s, (start, _, _)) in zip(seeds, again.items())]
    for (spec, (_, source, behind)), redone in zip(again.items(), executor.map(polish_job, jobs)):
        if redone[1].log_posterior > optima[spec][1].log_posterior:
            optima[spec] = redone
        now = _at_optimum(optima[spec])[1] - _at_optimum(optima[source])[1]
        progress(f"{spec}: its optimum's log likelihood {behind:.1f} nats below {source}'s; optimised again "
                 f"from that host's values: {abs(now):.1f} nats {'above' if now > 0 else 'below'}")
    return optima


def unsampled_hosts(effect_of: dict, ceilings: dict, laplace: dict) -> dict[str, tuple[float, str]]:
    """The hosts of a nonlinear effect left unsampled (no SMC): spec -> (its ceiling, why).

    ``effect_of``: spec -> the effect it hosts; ``ceilings``: spec -> its optimum's log likelihood
    (after :func:`_optimised`'s cross starts); ``laplace``: spec -> the Laplace estimate of its log
    evidence at that optimum (None where its covariance is not positive definite). A host's log
    evidence is at most the highest log likelihood it reaches, which its optimum stands for; the
    leading host of the effect (the highest Laplace estimate, capped at its own ceiling, which
    bounds it) is sampled, and a host whose ceiling trails that estimate by more than
    :data:`~bayesbeam.comparison.EARLY_STOP_NATS` cannot be the effect's best host, and is not.

    On the 8 s friction release (benchmarks/nonlinear_long.py), after the cross starts, the strain
    rate host's optimum lay 3103 nats below the air host's (3062 below its Laplace estimate) and is
    not sampled; the air, q1 and q3 hosts' optima lay within 17 nats of each other, and each is:
    on one tip displacement channel the damping law of the modes above the first barely shows.
    """
    out = {}
    for effect in dict.fromkeys(effect_of.values()):
        group = [s for s in effect_of if effect_of[s] == effect]
        estimates = {s: min(laplace[s], ceilings[s]) for s in group if laplace[s] is not None}
        if not estimates:
            continue
        leader = max(estimates, key=estimates.get)
        for spec in group:
            behind = estimates[leader] - ceilings[spec]
            if spec != leader and behind > EARLY_STOP_NATS:
                why = (f"its optimum's log likelihood, which bounds its log evidence from above, lies {behind:.1f} "
                       f"nats below the Laplace estimate of {leader}'s log evidence, so it cannot be {effect}'s best host")
                out[spec] = (ceilings[spec], why)
    return out


def _at_optimum(optimised) -> tuple[dict, float]:
    """(parameter values by name, log likelihood) at the optimum of what
    :func:`~bayesbeam.comparison.optimise_job` returned."""
    problem, optimum, _ = optimised
    return _values_at(problem, optimum), optimum_log_likelihood(problem.posterior, optimum)


def _values_at(problem, optimum) -> dict:
    """Every parameter's value by name (the set-up's nuisances too) at ``problem``'s ``optimum``."""
    return problem.posterior.split(optimum.theta)[0]


def cross_starts(effect_of: dict, optima: dict) -> dict:
    """The hosts to optimise again (:func:`_optimised`): spec -> (values to start from, the
    best host it takes them from, how many nats its optimum's log likelihood trails that host's).

    ``effect_of``: spec -> the nonlinear effect it hosts; ``optima``: spec -> (its optimum's
    parameter values by name, its log likelihood there). A host trailing the best host of its
    effect by more than :data:`DECISIVE` nats starts from its own values with the best host's
    put in for every parameter they share."""
    again = {}
    for effect in dict.fromkeys(effect_of.values()):     # in order: each redo's seed follows its place
        group = [s for s in effect_of if effect_of[s] == effect]
        best = max(group, key=lambda s: optima[s][1])
        for spec in group:
            behind = optima[best][1] - optima[spec][1]
            if behind > DECISIVE:
                own = optima[spec][0]
                again[spec] = ({**own, **{n: v for n, v in optima[best][0].items() if n in own}}, best, behind)
    return again


def _trial(round_, effect, current, mismatch, result, rng, config) -> Trial:
    new_map = _locate(result, rng, config)
    lbf, sd, decisive = decisively_above(result, current)
    return Trial(round_, effect, result, new_map, lbf, sd, decisive=decisive, improved=improved(mismatch, new_map))


def beam_regions(mismatch: Mismatch) -> list[dict]:
    """Regions of the map that may be beam physics (a line that does not decay with the beam is not)."""
    return [r for r in mismatch.regions if r.get("beam_physics", True) is not False]


def flags(mismatch: Mismatch) -> int:
    """Significant spectrogram cells + per-mode flags + a significant delay + a latent force
    beyond the force channel's noise."""
    return (int(mismatch.spectrogram.significant.sum()) + sum(len(m["flags"]) for m in mismatch.modes)
            + int(bool(mismatch.phase.get("significant"))) + int(bool(input_shift(mismatch))))


#: RMS standardized residuals closer than this (relative) are equal: a map with no flagged cell
#: takes its noise floor from all cells, so its RMS is 1 up to rounding (1 - 1e-16 against 1.0)
RMS_EQUAL = 1e-9


def improved(before: Mismatch, after: Mismatch) -> bool:
    """The map improves: neither the RMS standardized residual nor the flags get worse, and at
    least one gets better.

    Fewer flags at an equal RMS count: per-mode flags leave the spectrogram's cells unflagged, and
    with no flagged cell both maps' RMS is 1 by construction (the floor is the mean over all
    cells), so only the flags can tell the maps apart.
    """
    rms_before, rms_after = before.rms_standardized_residual, after.rms_standardized_residual
    equal = abs(rms_after - rms_before) <= RMS_EQUAL * rms_before
    rms_better = rms_after < rms_before and not equal
    flags_before, flags_after = flags(before), flags(after)
    return flags_after <= flags_before and (equal or rms_better) and (flags_after < flags_before or rms_better)


# ---------------------------------------------------------------------------- diagnosis.json
def summarise(d: Diagnosis) -> dict:
    """diagnosis.json: its summary keys first, then the maps, rankings and decision rule in full."""
    base, final = d.baseline, d.final
    rec = base.problem.model.recording
    candidates = [_trial_entry(t, d.signature(t)) for t in d.trials]
    final_verdicts = final_stand_ins(d)
    return {
        "recording": str(rec.source) if rec.source else None,
        "baseline": _model_entry(base, d.baseline_mismatch),
        "mismatch": d.baseline_mismatch.regions,
        "candidates": candidates,
        "added": d.added,
        "added_labels": [c["label"] for c in candidates if c["added"]],
        "stand_ins": list(final_verdicts),
        "final_stand_ins": final_verdicts,
        "unexplained": d.unexplained,
        "unexplained_regions": d.remaining(),
        "negligible_regions": d.negligible(),
        "not_beam_physics": [r for r in d.final_mismatch.regions if r.get("beam_physics") is False],
        "final": {**_model_entry(final, d.final_mismatch), "mismatch": d.final_mismatch.regions,
                  "parameters": posterior_summary(final)},
        "summary": paragraph(d, candidates, final_verdicts),
        "rankings": [{"round": i + 1, "chi2": r.chi2, "dof": r.dof, "p_value": r.p_value, "notes": r.notes,
                      "candidates": [c.to_dict() for c in r.candidates]} for i, r in enumerate(d.rankings)],
        "maps": {"baseline": d.baseline_mismatch.to_dict(), "final": d.final_mismatch.to_dict()},
        "decision_rule": {"log_bayes_factor_above": DECISIVE, "by_standard_errors": DECISIVE_SD,
                          "map_must_improve": "neither the RMS standardized residual nor the flags get worse, one gets better",
                          "alpha": ALPHA, "unexplained_needs_misfit_share": PRACTICAL_SHARE},
        "baseline_comparison": None if d.comparison is None else _evidence_table(d.comparison),
        "not_fitted": [{"round": n.round, "model": n.model, "reason": n.reason} for n in d.not_fitted],
        "left_out": d.left_out,
        "damping_recheck": None if d.recheck is None else {
            "effects": list(d.recheck.effects), "best": d.recheck.best, "previous": d.recheck.previous,
            "switched": d.recheck.switched, "tied": list(d.recheck.tied), "models": _evidence_table(d.recheck.summary),
            "dropped": list(d.recheck.dropped), "pruning": d.recheck.pruning, "final": d.recheck.final},
        "seconds": round(d.seconds, 1),
    }


def _evidence_table(comparison: dict) -> dict:
    return {m: {"log_evidence": v["log_evidence"], "log_evidence_sd": v["log_evidence_sd"],
                "probability": v["probability"]} for m, v in comparison["models"].items()}


def _model_entry(result, mismatch: Mismatch) -> dict:
    return {"model": result.name, "log_evidence": result.evidence.log_z,
            "log_evidence_sd": result.evidence.log_z_sd,
            "rms_standardized_residual": mismatch.rms_standardized_residual, "flags": flags(mismatch),
            "n_intervals": result.problem.model.n_intervals}


def effect_parameters(trial: Trial) -> dict:
    """Posterior summary of the added effect's own parameters."""
    return _own_parameters(trial.result, trial.effect)


def _own_parameters(result, effect_name: str) -> dict:
    """Posterior summary of the parameters of ``result``'s effect ``effect_name``."""
    effect = next(e for e in result.problem.model.effects if e.name == effect_name)
    return {k: v for k, v in posterior_summary(result).items() if k in effect.parameters}


def mass_sensor(parameters: dict, rec) -> str | None:
    """Which sensor carries the mass a fitted ``sensor_mass`` found: the one whose posterior median
    mass (``parameters``: the effect's :func:`effect_parameters`) exceeds what beam.toml states on
    it (0 where nothing is stated) the most; None without such parameters."""
    stated = stated_sensor_masses(rec.setup)
    sensors = dict(zip(stated, (s.name for s in rec.sensors)))
    excess = {sensors[p]: q["q50"] - (stated[p] or 0.0) for p, q in parameters.items() if p in sensors}
    return max(excess, key=excess.get) if excess else None


def label(effect: str, parameters: dict, rec) -> str:
    """An added effect in words: its name, and for a sensor mass on a recording of several sensors
    where it sits ('sensor_mass at mid')."""
    sensor = mass_sensor(parameters, rec) if effect == "sensor_mass" and len(rec.sensors) > 1 else None
    return effect if sensor is None else f"{effect} at {sensor}"


def final_stand_ins(d: Diagnosis) -> dict[str, dict]:
    """effect -> its stand-in verdict (:func:`stand_in`, with the effect's ``label``) for every
    effect of the final model that is a stand-in there, added or given with the baseline
    (``effects=``, ``--effect``), judged on the final model's posterior.

    Not on the trial's: an effect's posterior moves as the effects added after it and the damping
    re-check change the model around it (a body tuned to a mode in its round may settle elsewhere
    beside a base added later). Each trial's own verdict stays in its entry
    (``candidates[i].stand_in``)."""
    rec = d.baseline.problem.model.recording
    names = [e.name for e in d.final.problem.model.effects]
    bands = unresolved_bands(d.final) if "attachment" in names else None
    verdicts = {}
    for name in names:
        parameters = _own_parameters(d.final, name)
        if verdict := stand_in(name, parameters, rec, bands):
            verdicts[name] = {**verdict, "label": label(name, parameters, rec)}
    return verdicts


def allowed_by_setup(effect: str, rec) -> dict[str, tuple[float, float]]:
    """Per parameter of ``effect``, the range (SI units) the recording's stated set-up allows it;
    empty where the set-up bounds nothing. See :func:`stand_in` for the rule and its reasons."""
    setup = rec.setup
    if effect == "sensor_mass":
        spread = float(np.exp(STAND_IN_SDS * SENSOR_MASS_SIGMA))
        return {name: (mass / spread, mass * spread) for name, mass in stated_sensor_masses(setup).items()
                if mass is not None}
    if effect == "axial_load":
        weight = GRAVITY * (rec.beam.rho_a * (rec.beam.length + setup.length_tolerance) + rec.tip.mass
                            + setup.tip_mass_tolerance + setup.stated_mass)
        return {"P": (-weight, weight)}
    if effect == "high_pass":
        return {"f_hp": (0.0, HIGH_PASS_LIMIT)}
    if effect == "channel_gain":
        return {name: (-GAIN_STAND_IN_TOLERANCES * tol, GAIN_STAND_IN_TOLERANCES * tol)
                for name, tol in stated_gain_tolerances(setup).items()}
    if effect == "attachment":
        return {"f_a": (0.0, RESONANCE_LIMIT / (2 * rec.dt))}
    if effect == "base_support":
        return {"f_b": (0.0, RESONANCE_LIMIT / (2 * rec.dt)),
                "m_b": (0.0, BASE_MASS_LIMIT * (rec.beam.rho_a * rec.beam.length + rec.tip.mass))}
    return {}


def _not_needed(effect: str, name: str, summary: dict, rec) -> bool:
    """Whether a base's f_b posterior reaches up to where the effect vanishes (its upper 5 % point
    within a factor 2 of ``absent``): the data need no base, which is no stand-in."""
    if (effect, name) != ("base_support", "f_b"):
        return False
    return summary["q95"] >= 0.5 * EFFECTS[effect].bind(rec).absent[name]


#: why a fitted measurement-chain effect is a stand-in (see :func:`stand_in`)
STAND_IN_WHY = {
    "high_pass": f"above {HIGH_PASS_LIMIT:g} Hz, far above any IEPE sensor's or DAQ's AC-coupling corner",
    "channel_gain": f"more than {GAIN_STAND_IN_TOLERANCES:g} times the sensor's stated calibration tolerance",
    "base_support": (f"a base resonance above {RESONANCE_LIMIT:g} times the Nyquist frequency acts in the band only "
                     f"as a translational root compliance, or a base over {BASE_MASS_LIMIT:g} times the mass beyond "
                     "the clamp barely couples to the beam"),
    "attachment": (f"a body whose own mode lies above {RESONANCE_LIMIT:g} times the Nyquist frequency rides with the "
                   "beam as a point mass at x_a: it stands in for a mass the set-up misstates (a sensor's, the tip "
                   "body's) or another effect that lowers the modes in that pattern"),
    "tuned_attachment": ("a body tuned that close to a beam mode adds a second mode the record cannot separate from "
                         "it: the pair acts as one mode whose frequency and envelope the fit adjusts, which a beam "
                         "mode misplaced by the model or any second mode there (the beam's other bending plane, "
                         "torsion, the clamp or the bench) gives as well"),
    "mains_lines": ("the record shows no line at a harmonic of f_mains that keeps its amplitude over the record "
                    "(bayesbeam check's mains-line test), so its sinusoids absorb a mode or a transient, not pickup"),
}


def stand_in(effect: str, parameters: dict, rec, bands=None) -> dict | None:
    """Whether a fitted ``effect`` is a stand-in: its posterior median lies outside what the set-up
    of ``rec`` allows. ``parameters``: the effect's :func:`effect_parameters` (q50 and unit per
    parameter); ``bands``: for ``attachment``, the fitted beam's unresolved band about each mode
    without the body (:func:`unresolved_bands`; None: not judged against them). Returns None, or the parameter,
    its median, the allowed range (or, for a body tuned to a mode, the band it lies within and
    that mode's number) and why (SI units).

    The rule, per effect (others have no set-up bound and are never stand-ins):

    * ``sensor_mass``, per sensor that states its own mass m: the median of its fitted mass (m_s,
      or m_s_<s> among several sensors) lies more than :data:`STAND_IN_SDS` = 3 prior sds of log m_s
      (:data:`~bayesbeam.inference.priors.SENSOR_MASS_SIGMA`) from m, outside m / 2.46 to
      2.46 m. That prior already allows for the mounting, the cable and a sensor that is not a
      point; three sds beyond it the fitted "mass" is not the sensor's. (A stated mass of 0, a
      non-contact sensor, allows none.) Three sds lie inside the 4 sds the optimiser searches,
      so a posterior pushed there can show it.
    * ``axial_load``: abs(median P) exceeds the weight of everything beyond the clamp,
      g (rho A (l + length_tolerance) + m_T + mass_tolerance + the stated sensor masses). A
      cantilever's tip is free, so by statics the axial force at any section is the axial share
      of the body forces beyond it: at most that weight, reached when the beam hangs (tension)
      or stands (compression) vertically. A larger P is no tension or compression this set-up
      can hold; it stands in for whatever shifts the modes in a geometric stiffness's proportions.
    * ``high_pass``: median f_hp above :data:`HIGH_PASS_LIMIT` = 10 Hz. IEPE sensors' corners lie
      below about 0.5 Hz and DAQs' AC couplings below about 3.4 Hz; a corner above 10 Hz stands in
      for a loss and phase lead of the lowest mode that some other cause gives.
    * ``channel_gain``, per sensor: abs(median g) above :data:`GAIN_STAND_IN_TOLERANCES` = 5 times the
      sensor's ``gain_tolerance`` (0.02 where not stated). A calibration five of its own
      uncertainties off is not a calibration error; the gain stands in for an amplitude mismatch of
      the channel (a sensor off its stated place, a wrong mode shape there).
    * ``attachment``: median f_a above :data:`RESONANCE_LIMIT` = 10 times the Nyquist frequency.
      A body's effect on the band depends on its own mode only while that mode lies near or in it;
      ten times above everything the recording resolves, the link is rigid and the body a point
      mass at x_a, the sensor_mass's pattern at a place no sensor states: a mass the set-up
      misstates, or whatever lowers the modes by phi_m(x_a)^2, not an attached resonator.
      Nor is a body whose median f_a lies within a beam mode's unresolved band f_m +- w_m, where
      w_m = max(zeta_m f_m, 1/T) (``bands``: the fitted beam's modes without the body, at the
      posterior medians, and T the fitted window's length). A second mode that close to mode m is
      inside its half-power band or completes less than one beat against it over the window: the
      record shows one mode whose frequency, decay and envelope the pair adjusts, which a beam mode
      the model misplaces gives as well as any second mode there (the beam's other bending plane,
      torsion, a mode of the clamp or the bench), so the response cannot tell an attached body
      from them, and the fit finds the pair, not a body.
    * ``base_support``: median f_b above :data:`RESONANCE_LIMIT` = 10 times the Nyquist
      frequency fs/2, or median m_b above :data:`BASE_MASS_LIMIT` = 1e4 times the mass beyond the
      clamp, rho A l + m_T. A base resonance ten times above all the recording resolves shows in the
      band only as a translational compliance of the root, lowering mode m by about
      (f_m/f_b)^2 L_m^2/(2 m_b), the high modes most: the pattern of the shear deformation and rotary
      inertia an Euler-Bernoulli beam leaves out, or of a stiffness that varies along the span, and
      only k_b = m_b (2 pi f_b)^2 is seen, not a stand's mass and mode. (When f_b's upper 5 % point
      reaches within a factor 2 of where the effect vanishes, 1e4 f_1, the data need no base: no
      stand-in.) A base 1e4 times the beam's mass couples to mode m by L_m^2/m_b < 1e-4: it can add
      only a resonance of its own that hardly moves the beam, a peak that something else gives (the
      default prior stops at 100 beam masses; a [prior.m_b] reaching further can show it).
    """
    if effect == "mains_lines":
        return _pickup_stand_in(parameters, rec)
    if effect == "attachment" and bands is not None and (tuned := _tuned_mode(parameters["f_a"]["q50"], bands)):
        mode, band = tuned
        return {"parameter": "f_a", "median": parameters["f_a"]["q50"], "allowed": None, "within": band,
                "mode": mode, "unit": parameters["f_a"]["unit"], "why": STAND_IN_WHY["tuned_attachment"]}
    for name, (low, high) in allowed_by_setup(effect, rec).items():
        if name not in parameters or _not_needed(effect, name, parameters[name], rec):
            continue
        median = parameters[name]["q50"]
        if not low <= median <= high:
            why = (f"more than {STAND_IN_SDS:g} prior sds of log m_s from the stated sensor mass "
                   f"{stated_sensor_masses(rec.setup)[name]:.4g} kg" if effect == "sensor_mass" else
                   STAND_IN_WHY.get(effect, "beyond the weight of beam, tip body and stated sensors, the largest "
                                    "axial force a cantilever with a free tip carries"))
            return {"parameter": name, "median": median, "allowed": [low, high], "unit": parameters[name]["unit"],
                    "why": why}
    return None


def _tuned_mode(f_a: float, bands) -> tuple[int, list[float]] | None:
    """(mode number from 1, its band [low, high] in Hz) of the first of ``bands`` (one per mode,
    lowest first) that holds ``f_a``, or None."""
    for number, (low, high) in enumerate(bands, start=1):
        if low <= f_a <= high:
            return number, [low, high]
    return None


def unresolved_bands(result) -> list[tuple[float, float]]:
    """Per mode of ``result``'s beam without its attached body (:func:`modes_without_body`), the
    band f_m +- w_m (Hz) in which a second mode cannot be told from it: w_m = max(zeta_m f_m, 1/T),
    the half-power half-width or the resolution of the fitted window of length T, whichever is wider."""
    projection = result.problem.likelihood.projection
    resolution = projection.fs / (projection.n_blocks * projection.block)     # 1/T of the samples analysed
    return [(frequency - (width := max(zeta * frequency, resolution)), frequency + width)
            for frequency, zeta in modes_without_body(result)]


def modes_without_body(result) -> list[tuple[float, float]]:
    """(natural frequency Hz, damping ratio) of each mode of ``result``'s model with its attached
    body taken off (m_a = 0, which removes the body's degree of freedom), every other parameter at
    its posterior median, lowest first. The model must have an ``attachment``."""
    model = result.problem.model
    post = result.problem.posterior
    values = post.split(np.median(_draws(result), axis=0))[0]
    poles = model.poles({**{n: v for n, v in values.items() if n in post.model_names}, "m_a": 0.0})
    return [(float(abs(p) / (2 * np.pi)), float(-p.real / abs(p))) for p in poles]


def _pickup_stand_in(parameters: dict, rec) -> dict | None:
    """:func:`stand_in`'s rule for ``mains_lines``: a stand-in unless some response channel of ``rec``
    shows a persistent line (:func:`bayesbeam.checks.survey.mains_lines`) within two bins of a harmonic
    of its f_mains: the median of a sampled one, else the nominal one the fit held fixed."""
    f_mains = parameters["f_mains"]["q50"] if "f_mains" in parameters else nominal_mains(rec)
    tolerance = 2 * rec.fs / rec.n_samples
    lines = [line["peak_hz"] for channel in survey(rec).summary["channels"] for line in channel["mains_lines"]]
    if any(round(f / f_mains) >= 1 and abs(f - round(f / f_mains) * f_mains) <= tolerance for f in lines):
        return None
    return {"parameter": "f_mains", "median": float(f_mains), "allowed": None, "unit": "Hz",
            "why": STAND_IN_WHY["mains_lines"]}


def trial_stand_in(t: Trial, parameters: dict) -> dict | None:
    """:func:`stand_in`'s verdict on the effect of trial ``t`` (``parameters``: its :func:`effect_parameters`)."""
    bands = unresolved_bands(t.result) if t.effect == "attachment" else None
    return stand_in(t.effect, parameters, t.result.problem.model.recording, bands)


def _trial_entry(t: Trial, signature) -> dict:
    parameters = effect_parameters(t)
    rec = t.result.problem.model.recording
    sensor = mass_sensor(parameters, rec) if t.effect == "sensor_mass" else None
    return {"effect": t.effect, "sensor": sensor, "label": label(t.effect, parameters, rec),
            "round": t.round, "model": t.result.name,
            "delta_log_evidence": t.log_bayes_factor, "delta_log_evidence_sd": t.log_bayes_factor_sd,
            "parameters": parameters, "stand_in": trial_stand_in(t, parameters),
            "rms_standardized_residual": t.mismatch.rms_standardized_residual, "flags": flags(t.mismatch),
            "noise": t.mismatch.noise,
            "decisive": t.decisive, "map_improved": t.improved, "added": t.added and not t.dropped,
            "dropped": t.dropped,
            "signature": None if signature is None else signature.to_dict()}


def paragraph(d: Diagnosis, candidates: list[dict], stand_ins: dict[str, dict]) -> str:
    """What was missing, the evidence, how much the fit improved: in plain words.

    ``candidates``: each trial's diagnosis.json entry (its ``parameters`` and ``stand_in``), in the
    order of ``d.trials``; ``stand_ins``: the final model's verdicts, :func:`final_stand_ins`.
    """
    base, bmap, fmap = d.baseline.name, d.baseline_mismatch, d.final_mismatch
    text = [(f"Baseline {base}: RMS standardized residual {bmap.rms_standardized_residual:.2f} "
             f"(1 when the model explains everything but noise), {flags(bmap)} flag(s) in the mismatch map.")]
    if d.left_out:
        text.append(left_out_words(d.left_out))
    lines = [r for r in fmap.regions if r.get("beam_physics") is False]
    if lines:
        text.append("Not beam physics (not fitted): " + "; ".join(
            f"{r['band_hz'][0]:.4g}-{r['band_hz'][1]:.4g} Hz on {r['sensor']}: {r['note']}" for r in lines) + ".")
    if not beam_regions(bmap) and not d.trials:
        text.append("Nothing the damping model leaves out shows above the noise: no effect was added.")
        text += [_stand_in_sentence(effect, verdict) for effect, verdict in stand_ins.items()]
        return " ".join(text)
    rec = d.baseline.problem.model.recording
    parameters = [c["parameters"] for c in candidates]
    verdicts = [c["stand_in"] for c in candidates]
    for t, summary in zip(d.trials, parameters):
        params = _estimates(summary) or _fixed_words(t)
        verdict = ("added, then dropped after the damping re-check" if t.dropped else
                   "added" if t.added else "not added: " + _refusal(t, d.trials))
        against = d.chain()[t.round - 1][0].name
        hosted = ("" if t.result.name == join_model(against, [t.effect]) else
                  f" (fitted as {t.result.name}: {against}'s memory mechanism cannot carry it)")
        text.append(f"Round {t.round}, {label(t.effect, summary, rec)}{hosted}: log Bayes factor {t.log_bayes_factor:.1f} +- "
                    f"{t.log_bayes_factor_sd:.2g} nats against {against}, RMS standardized residual "
                    f"{t.mismatch.rms_standardized_residual:.2f}, {flags(t.mismatch)} flag(s); {params}: {verdict}.")
    kept = [(t, summary, verdict) for t, summary, verdict in zip(d.trials, parameters, verdicts)
            if t.added and not t.dropped]
    found = [label(t.effect, summary, rec) for t, summary, _ in kept if t.effect not in stand_ins]
    if d.added:
        text.append(("Missing physics found: " + " and ".join(found) if found else
                     "No missing physics the set-up allows was found") + ". The fit improved from RMS "
                    f"{bmap.rms_standardized_residual:.2f} to {fmap.rms_standardized_residual:.2f}, log evidence "
                    f"from {d.baseline.evidence.log_z:.1f} to {d.final.evidence.log_z:.1f}.")
    else:
        text.append("No catalogue effect explains the mismatch.")
    text += [_stand_in_sentence(effect, verdict) for effect, verdict in stand_ins.items()]
    text += [_changed_verdict_sentence(t, verdict, stand_ins.get(t.effect)) for t, _, verdict in kept
             if bool(verdict) != (t.effect in stand_ins)]
    if d.not_fitted:
        text.append("Not fitted: " + "; ".join(f"{n.model} ({n.reason})" for n in d.not_fitted) + ".")
    if d.recheck is not None:
        text.append(_recheck_sentence(d.recheck))
    if d.unexplained:
        text.append("Unexplained: " + "; ".join(
            f"{r['band_hz'][0]:.4g}-{r['band_hz'][1]:.4g} Hz, {r['time_s'][0]:.3g}-{r['time_s'][1]:.3g} s on "
            f"{r['sensor']} ({r['note']}; {share_words(r['misfit_share'])})"
            for r in d.remaining()) + ".")
    if d.negligible():
        text.append(f"{len(d.negligible())} region(s) stand statistically above the noise but carry less than "
                    f"{PRACTICAL_SHARE:.0%} of their channel's signal: too small to be a finding.")
    return " ".join(text)


def _changed_verdict_sentence(t: Trial, trial_verdict: dict | None, final_verdict: dict | None) -> str:
    """Why an added effect's verdict in the final model is not its trial's: its posterior moved."""
    if trial_verdict:
        return (f"As fitted in round {t.round}, {t.effect} was a stand-in ({trial_verdict['parameter']} = "
                f"{trial_verdict['median']:.4g} {trial_verdict['unit']} {stand_in_clause(trial_verdict)}); in the "
                f"final model its posterior lies within what the set-up allows.")
    return (f"As fitted in round {t.round}, {t.effect} lay within what the set-up allows; in the final model "
            f"its {final_verdict['parameter']} moved outside it (above).")


def _stand_in_sentence(effect: str, verdict: dict) -> str:
    return (f"Stand-in, not a finding: {effect}'s {verdict['parameter']} = {verdict['median']:.4g} {verdict['unit']} "
            f"{stand_in_clause(verdict)} ({verdict['why']}): {effect} stands in for a structural mismatch the "
            f"catalogue cannot name.")


def stand_in_words(verdict: dict | None) -> str:
    """A stand-in verdict in a table's cell: 'no', or 'yes: ' with its parameter and what rules
    the median out (:func:`stand_in_clause`)."""
    return "no" if verdict is None else f"yes: {verdict['parameter']} {stand_in_clause(verdict)}"


def stand_in_clause(verdict: dict) -> str:
    """What rules a stand-in's value out, in words: inside a beam mode's unresolved band (a tuned
    body), outside the range the set-up allows, or (no range: mains pickup) no persistent line at
    its harmonics."""
    if "within" in verdict:
        low, high = verdict["within"]
        return (f"(posterior median) lies within beam mode {verdict['mode']}'s unresolved band, "
                f"{low:.6g} to {high:.6g} {verdict['unit']} (its half-power band or the fitted window's "
                "resolution 1/T, whichever is wider)")
    if verdict["allowed"] is None:
        return "(fixed) has no persistent line at any of its harmonics in the record"
    low, high = verdict["allowed"]
    return (f"(posterior median) lies outside the {low:.4g} to {high:.4g} {verdict['unit']} the set-up allows")


def _estimates(summary: dict) -> str:
    """Posterior summaries (name -> q05, q50, q95, unit) in words: 'k_theta = 3473 N m/rad (90 %: ...)',
    the median as every table of the package gives it (a skewed posterior's mean is not)."""
    return ", ".join(f"{k} = {v['q50']:.4g} {v['unit']} (90 %: {v['q05']:.4g} to {v['q95']:.4g})"
                     for k, v in summary.items())


def _fixed_words(trial: Trial) -> str:
    """The added effect's parameters the fit held fixed (mains pickup's f_mains), in words."""
    effect = next(e for e in trial.result.problem.model.effects if e.name == trial.effect)
    return ", ".join(f"{k} = {v:.4g} {effect.units[k]} (fixed)" for k, v in effect.defaults.items())


def _refusal(trial: Trial, trials: list) -> str:
    """Why a fitted candidate was not added, in words."""
    if not trial.decisive:
        return "the evidence is not decisive"
    if not trial.improved:
        return "the mismatch map does not improve"
    winner = next(t for t in trials if t.round == trial.round and t.added)
    return f"it passes, but {winner.effect} has the larger log Bayes factor ({winner.log_bayes_factor:.1f} nats)"


def _recheck_sentence(r: DampingRecheck) -> str:
    models = r.summary["models"]
    best, previous = models[r.best], models[r.previous]
    head = f"With {' and '.join(r.effects)} modelled, the damping models were compared again: "
    if r.switched:
        final = r.results[r.final or r.best]
        names = {p for e in final.problem.model.effects for p in e.parameters}
        effect_estimates = _estimates({k: v for k, v in posterior_summary(final).items() if k in names})
        return (head + f"{r.best} is preferred over {r.previous} by {best['log_evidence'] - previous['log_evidence']:.1f} "
                f"nats (decisive), so the damping verdict changes to {r.best}: the first comparison was misled "
                f"by the missing physics." + _tie_sentence(r) + _pruning_sentence(r) + f" In {final.name}: {effect_estimates}.")
    if r.best == r.previous:
        return head + f"{r.previous} stays the best (posterior probability {previous['probability']:.3f})." + _tie_sentence(r)
    return (head + f"{r.best} scores {best['log_evidence'] - previous['log_evidence']:.1f} nats above {r.previous}, "
            f"not decisive: {r.previous} is kept.")


def _tie_sentence(r: DampingRecheck) -> str:
    """The models the evidence does not rank decisively below the best (:attr:`DampingRecheck.tied`), in words."""
    models = r.summary["models"]
    if not r.tied:
        return ""
    behind = " and ".join(f"{m} ({models[r.best]['log_evidence'] - models[m]['log_evidence']:.1f} nats behind)"
                          for m in r.tied)
    text = (f" {behind} {'is' if len(r.tied) == 1 else 'are'} not decisively behind {r.best}: the recording does "
            f"not decide between {'its' if len(r.tied) == 1 else 'their'} damping and {r.best}'s.")
    if r.switched:
        text += f" Of these, {r.best} is taken for its higher log evidence, an order the SMC estimates' noise could reverse."
    return text


def _pruning_sentence(r: DampingRecheck) -> str:
    """The added effects judged again with the new damping model (:func:`prune_added`), in words."""
    if not r.pruning:
        return ""
    judged = "; ".join(f"without {v['without']} ({spec}) {'costs' if v['log_bayes_factor'] > 0 else 'gains'} "
                       f"{abs(v['log_bayes_factor']):.1f} +- {v['sd']:.1f} nats: {'needed' if v['needed'] else 'not needed'}"
                       for spec, v in r.pruning.items())
    dropped = (f" Dropped: {' and '.join(r.dropped)}, which only made up for the first damping model."
               if r.dropped else " Every added effect stays.")
    return f" Each added effect judged again with the new damping model: {judged}.{dropped}"
