"""compare()'s verdict, its settling of unsettled evidence, and the named model sets.

The statistical claims (the true model ranks first, its parameters inside their intervals) and the
summary's layout are tested on recordings compare() did not make: tests/acceptance/test_compare.py.
"""
from dataclasses import replace

import numpy as np
import pytest

from bayesbeam.comparison import (
    DEFAULT_MODELS,
    LITERATURE_MODELS,
    expand_model_sets,
    strength,
)

#: Kass & Raftery (1995), Table in section 3.2, on their 2 ln B scale: 0-2 not worth more than a bare
#: mention, 2-6 positive, 6-10 strong, > 10 very strong (written here from the paper, not the package)
KASS_RAFTERY_2LNB = ((2.0, "positive"), (6.0, "strong"), (10.0, "very strong"))


@pytest.mark.parametrize(("two_ln_b", "word"), KASS_RAFTERY_2LNB)
def test_kass_raftery_words_change_at_each_boundary(two_ln_b, word):
    """ln B = (2 ln B) / 2; a band starts at its boundary and a hair below it is the band beneath,
    so swapping any two thresholds, or a threshold 10 % off, fails."""
    below = {2.0: "not worth more than a bare mention", 6.0: "positive", 10.0: "strong"}[two_ln_b]
    assert strength(two_ln_b / 2) == word
    assert strength(two_ln_b / 2 * 1.05) == word
    assert strength(two_ln_b / 2 * 0.95) == below
    assert strength(0.0) == strength(-3.0) == "not worth more than a bare mention"


def test_a_verdict_whose_best_model_fails_its_checks_points_to_the_diagnosis():
    """paper_rootcomp_hammer's case: the winner (q2) fails its checks because a root spring is
    missing; the verdict must not read as a finding about the mechanism, and must say what to run."""
    from bayesbeam.comparison import verdict

    def entry(log_z, p_value):
        return {"mechanisms": ["time_hysteresis"], "effects": [], "probability": 1.0, "log_evidence": log_z,
                "log_evidence_sd": 0.1, "log_bayes_factor_vs_best": log_z + 1225.0,
                "ppc": {"ljung_box": {"p_value": p_value}}}

    failing = verdict(["q2", "q1"], {"q2": entry(-1225.0, 1e-5), "q1": entry(-1586.0, 1e-6)})
    assert "ljung_box" in failing and "not a verdict on the mechanism" in failing and "bayesbeam diagnose" in failing
    passing = verdict(["q2", "q1"], {"q2": entry(-1225.0, 0.4), "q1": entry(-1586.0, 1e-6)})
    assert "checks pass" in passing and "diagnose" not in passing


def test_a_verdict_names_the_models_whose_evidence_has_not_settled():
    """The real record with a sensor mass and an axial load: q3's three first-pass SMC repeats gave
    851.6, 242.0 and 303.3 nats (sd 194) with R-hat 1.10, while the winner's agreed to 0.1. The
    verdict must say that q3's place is not established; settled models (sd <= 1 nat, R-hat <=
    1.05: the shipped studies' runs spread by 0.02-0.18 nats, R-hat <= 1.03) are not named."""
    from bayesbeam.comparison import verdict

    def entry(log_z, sd, r_hat, repeats=None):
        return {"mechanisms": ["air", "strain_rate"], "effects": [], "probability": 1.0, "log_evidence": log_z,
                "log_evidence_sd": sd, "log_bayes_factor_vs_best": log_z - 2947.1,
                "evidence": {"repeats": repeats or [log_z] * 3}, "posterior": {"EI": {"r_hat": r_hat}},
                "ppc": {"ljung_box": {"p_value": 0.5}}}

    models = {"q1": entry(2947.1, 0.05, 1.004), "q2": entry(1915.0, 0.04, 1.000),
              "q3": entry(465.7, 193.8, 1.099, [851.6, 242.0, 303.3])}
    text = verdict(["q1", "q2", "q3"], models)
    assert "Not settled: q3 (repeats 242.0 to 851.6 nats, sd 193.8 nats, R-hat up to 1.10)" in text
    named = text.split("Not settled: ")[1].split(". The SMC")[0]
    assert "q1" not in named and "q2" not in named
    models["q3"] = entry(465.7, 0.3, 1.07)
    assert "Not settled: q3 (R-hat up to 1.07)" in verdict(["q1", "q2", "q3"], models)
    models["q3"] = entry(465.7, 0.3, 1.02)
    assert "Not settled" not in verdict(["q1", "q2", "q3"], models)


def test_evidence_that_has_not_settled_gets_a_second_pass_from_its_posterior_particles(monkeypatch):
    """settle() reruns only the models whose repeats spread by more than EVIDENCE_SD_MAX, as many
    repeats again, from the matched reference; the second pass replaces the first, which is kept
    (and reported under evidence.first_pass)."""
    from types import SimpleNamespace

    import bayesbeam.comparison as cmp
    from bayesbeam.executors import SerialExecutor
    from bayesbeam.inference.evidence import combine_runs

    def run(log_z):
        return SimpleNamespace(log_z=log_z, betas=np.array([0.0, 1.0]), particles=np.zeros((4, 2)),
                               n_evaluations=4, seconds=0.0)

    calls = []
    monkeypatch.setattr(cmp, "matched_reference", lambda priors, evidence: ("matched", evidence.log_z))
    monkeypatch.setattr(cmp, "smc_job", lambda args: calls.append(args) or run(3132.8 + 1e-3 * len(calls)))
    first = {"q1": combine_runs([run(2947.1), run(2947.2), run(2947.0)]),
             "q3": combine_runs([run(851.6), run(242.0), run(303.3)])}
    posteriors = {m: SimpleNamespace(priors=None) for m in first}
    said = []
    config = cmp.CompareConfig(repeats=3, particles=224)
    out = cmp.settle(first, posteriors, config, np.random.SeedSequence(1), SerialExecutor(), said.append)
    assert out["q1"] is first["q1"]
    assert len(calls) == 3 and all(a[1] == ("matched", first["q3"].log_z) and a[3] == 224 for a in calls)
    assert abs(out["q3"].log_z - 3132.8) < 0.01 and out["q3"].first_pass is first["q3"]
    assert out["q3"].as_dict()["first_pass"]["repeats"] == [851.6, 242.0, 303.3]
    assert "q3" in said[0] and "q1" not in said[0]
    assert cmp.settle({"q1": first["q1"]}, posteriors, config, np.random.SeedSequence(1), SerialExecutor(),
                      said.append) == {"q1": first["q1"]}


def test_named_model_sets_expand_and_every_literature_model_simulates():
    """``paper`` is the default set, ``literature`` the newer mechanisms (the root dashpot with its
    spring), ``all`` both; names repeat once. Each literature model builds on a recording with a
    [material] table and simulates finite signals at its default priors' medians."""
    from bayesbeam.inference.priors import default_priors
    from bayesbeam.model import BeamModel
    from tests.physics.effects.helpers import recording

    assert expand_model_sets(["paper"]) == list(DEFAULT_MODELS)
    assert expand_model_sets(["literature", "fractional"]) == list(LITERATURE_MODELS)
    assert expand_model_sets(["all"]) == list(DEFAULT_MODELS + LITERATURE_MODELS)
    rec = replace(recording("force", duration=0.3),
                  extra={"material": {"name": "steel", "temperature": 293.0, "thickness": 2e-3}})
    for spec in LITERATURE_MODELS:
        model = BeamModel(rec, spec, 6)
        priors = default_priors(rec.beam, model.parameter_names, {})
        values = {n: float(p.to_value(p.median())) for n, p in priors.items()}
        assert np.all(np.isfinite(model.simulate(values))), spec


def test_models_that_need_a_missing_material_table_are_left_out_with_the_fix():
    """A recording without [material]: thermoelastic (and only it) leaves ``all`` and
    ``literature``, with the reason and the keys to add; alone it stays, so the model refuses the
    recording; a [material] table present (even one that would be refused) leaves out nothing.
    plumbing: the recording only supplies its beam.toml tables; nothing is fitted."""
    from bayesbeam.comparison import MODEL_SETS, material_left_out
    from tests.physics.effects.helpers import recording

    rec = recording("force", duration=0.3)
    assert "material" not in rec.extra
    kept, left = material_left_out(rec, expand_model_sets(["all"]))
    assert kept == [m for m in MODEL_SETS["all"] if m != "thermoelastic"] and list(left) == ["thermoelastic"]
    assert "beam.toml has no [material] table" in left["thermoelastic"]
    assert "Fix: add a [material] table with" in left["thermoelastic"] and "thickness" in left["thermoelastic"]
    assert material_left_out(rec, ["thermoelastic"]) == (["thermoelastic"], {})
    assert material_left_out(rec, list(LITERATURE_MODELS))[0] == [m for m in LITERATURE_MODELS if m != "thermoelastic"]
    with_table = replace(rec, extra={"material": {"temperature": 293.0}})
    assert material_left_out(with_table, ["q1", "thermoelastic"]) == (["q1", "thermoelastic"], {})


def test_a_model_given_its_optimum_is_not_optimised_again(monkeypatch):
    """compare(optimised=...) takes a model's optimisation as given (the diagnosis optimises the
    hosts of a nonlinear effect itself): optimise_job runs for the other model only, and the given
    optimum is the result's."""
    import bayesbeam.comparison as cmp
    from tests.diagnosis_cases import CONFIG, recording

    rec = recording(None)
    config = CONFIG.compare
    given = cmp.optimise_job((rec, "q1", config, 7, None))
    asked = []
    optimise = cmp.optimise_job
    monkeypatch.setattr(cmp, "optimise_job", lambda args: asked.append(args[1]) or optimise(args))
    results, _ = cmp.compare(rec, ["q1", "air"], config, optimised={"q1": given})
    assert asked == ["air"] and results["q1"].optimum is given[1] and results["q1"].problem is given[0]


def test_a_models_optimisation_seed_follows_its_place_whatever_is_skipped(monkeypatch):
    """optimise_models: each model's seed depends on its place in the list and config.seed only, so
    the diagnosis, optimising a comparison's models before compare (which skips them), gets the
    optimisations compare would have made; distinct places, distinct seeds; starts are passed."""
    import bayesbeam.comparison as cmp
    from bayesbeam.executors import SerialExecutor

    monkeypatch.setattr(cmp, "optimise_job", lambda args: (args[3], args[4]))
    models = ["q1", "air", "q3"]
    config = cmp.CompareConfig()
    every = cmp.optimise_models(None, models, config, SerialExecutor(), starts={"q3": {"EI": 1.0}})
    some = cmp.optimise_models(None, models, config, SerialExecutor(), skip={"q1"})
    other = cmp.optimise_models(None, models, replace(config, seed=config.seed + 1), SerialExecutor())
    assert list(some) == ["air", "q3"] and some["air"] == every["air"] and some["q3"][0] == every["q3"][0]
    assert every["q3"][1] == {"EI": 1.0} and some["q3"][1] is None
    assert len({s for s, _ in every.values()}) == 3 and other["air"][0] != every["air"][0]
