"""Early stop of evidence repeats: a model decisively behind the leader after its first repeats gets
no more; the leader, the ranking and every other model's runs are those of the full comparison.

Tolerances. The runs of models that are not stopped must be bit-identical to the full path's
(each repeat has its own seed, whatever else ran). Stopping only drops runs, so a stopped
model's log Z is the mean of its first repeats: the test checks it is that mean exactly.
"""
from dataclasses import replace
from types import SimpleNamespace

import numpy as np
import pytest

import bayesbeam.comparison as cmp
from bayesbeam.comparison import CompareConfig, beaten, compare
from bayesbeam.executors import SerialExecutor
from bayesbeam.inference.evidence import combine_runs
from bayesbeam.inference.fit import FitConfig
from tests.acceptance import cases as ac

#: a stand-in run's particles' log likelihood lies this far above its log Z (the Occam factor)
OCCAM = 5.0


def run(log_z):
    return SimpleNamespace(log_z=log_z, betas=np.array([0.0, 1.0]), particles=np.zeros((4, 2)),
                           log_likelihood=np.full(4, log_z + OCCAM), n_evaluations=4, seconds=0.0)


def fake_smc(args):
    """An SMC run whose log Z is the model's value plus a seed-dependent scatter of sd ``spread``."""
    post, _, seed, *_ = args
    return run(post.log_z + post.spread * np.random.default_rng(seed).standard_normal())


def evidences(jobs, config, monkeypatch, rivals=None, ceilings=None):
    monkeypatch.setattr(cmp, "smc_job", fake_smc)
    return cmp._evidence(jobs, config, np.random.SeedSequence(4), SerialExecutor(), rivals, None, ceilings)


def jobs_for(values, spread=0.1):
    return {m: (i, SimpleNamespace(ndim=2, log_z=v, spread=spread), None, 0) for i, (m, v) in enumerate(values.items())}


def test_a_model_far_behind_is_stopped_and_the_ranking_and_other_runs_are_unchanged(monkeypatch):
    """q3 leads q1 by 300 nats and air by 3000: both are stopped after two of three repeats;
    q3 keeps all three, its runs and every log Z are those of the full path's first repeats."""
    jobs = jobs_for({"q1": -1100.0, "q3": -765.0, "air": -3750.0})
    config = CompareConfig(repeats=3)
    full, none = evidences(jobs, CompareConfig(repeats=3, early_stop=None), monkeypatch, rivals={})
    early, stopped = evidences(jobs, config, monkeypatch, rivals={})
    assert none == {}
    assert sorted(stopped) == ["air", "q1"] and "behind q3" in stopped["q1"] and "2 of 3 repeats" in stopped["air"]
    assert [r.log_z for r in early["q3"].runs] == [r.log_z for r in full["q3"].runs]
    for m in ("q1", "air"):
        assert [r.log_z for r in early[m].runs] == [r.log_z for r in full[m].runs[:2]]
    assert sorted(early, key=lambda m: early[m].log_z) == sorted(full, key=lambda m: full[m].log_z)


def test_models_within_the_margin_keep_all_their_repeats(monkeypatch):
    """15 nats behind, less than the 20-nat margin: nobody is stopped, both keep three repeats."""
    out, stopped = evidences(jobs_for({"q1": -780.0, "q3": -765.0}), CompareConfig(repeats=3), monkeypatch,
                             rivals={})
    assert stopped == {} and all(len(e.runs) == 3 for e in out.values())


def test_the_margin_counts_beyond_three_standard_errors():
    """22 nats behind with an sd of 0.9 nats each (settled): 22 - 3 x 1.27 = 18.2 < 20, not stopped;
    the same 22 nats with sd 0.1 each: 22 - 0.4 > 20, stopped."""
    wide = {"q3": combine_runs([run(-764.1), run(-765.9)]), "q1": combine_runs([run(-786.1), run(-787.9)])}
    assert beaten(wide, 20.0, 3) == {}
    narrow = {"q3": combine_runs([run(-764.9), run(-765.1)]), "q1": combine_runs([run(-786.9), run(-787.1)])}
    assert list(beaten(narrow, 20.0, 3)) == ["q1"]


def test_unsettled_models_are_not_stopped_by_their_log_z_and_an_unsettled_leader_counts_with_its_lowest_run():
    """An unsettled model without a ceiling keeps its repeats. An unsettled leader (runs -700 and
    -720, sd 10) stops a model whose settled log Z lies beyond its lowest run by the margin and
    three combined standard errors (-2000: 1280 nats), not one 40 nats below its mean (-750:
    30 - 3 x 10 < 20)."""
    settled = combine_runs([run(-765.0), run(-765.1)])
    far = combine_runs([run(-2000.0), run(-2000.1)])
    unsettled = combine_runs([run(-1500.0), run(-1510.0)])           # sd 5 nats > EVIDENCE_SD_MAX
    assert beaten({"q3": settled, "air": far, "q2": unsettled}, 20.0, 3) == {"air": beaten(
        {"q3": settled, "air": far}, 20.0, 3)["air"]}
    wild_leader = combine_runs([run(-700.0), run(-720.0)])
    near = combine_runs([run(-750.0), run(-750.1)])
    stopped = beaten({"q3": wild_leader, "air": far, "q1": near}, 20.0, 3)
    assert list(stopped) == ["air"] and "1280.0" in stopped["air"]


def test_an_unsettled_model_is_stopped_only_when_its_likelihood_ceiling_is_beaten():
    """An unsettled model's log Z errs low, so it is held against its ceiling, the log likelihood at
    its optimum (log Z <= log max L): q2 at -1500 +- 5 with a ceiling of -1480 is stopped behind a
    settled leader at -765; with a ceiling of -775 (10 nats short of the leader, inside the
    20-nat margin) it is not, however low its runs. Behind an unsettled leader (runs -700 and -720,
    sd 10) the ceiling is held against its lowest run and three of its standard errors: -1480 is
    stopped (730 nats), -760 is not (10 nats)."""
    settled = combine_runs([run(-765.0), run(-765.1)])
    unsettled = combine_runs([run(-1500.0), run(-1510.0)])
    stopped = beaten({"q3": settled, "q2": unsettled}, 20.0, 3, ceilings={"q2": -1480.0})
    assert list(stopped) == ["q2"] and "unsettled" in stopped["q2"] and "715.0 nats below q3" in stopped["q2"]
    assert beaten({"q3": settled, "q2": unsettled}, 20.0, 3, ceilings={"q2": -775.0}) == {}
    wild_leader = combine_runs([run(-700.0), run(-720.0)])
    assert list(beaten({"q3": wild_leader, "q2": unsettled}, 20.0, 3, ceilings={"q2": -1480.0})) == ["q2"]
    assert beaten({"q3": wild_leader, "q2": unsettled}, 20.0, 3, ceilings={"q2": -760.0}) == {}


def test_a_rival_fitted_before_can_lead_but_is_never_stopped_or_returned(monkeypatch):
    """The diagnosis passes the current model's evidence: an augmented model 40 nats below it is
    stopped; the rival itself is not a job and is not returned."""
    current = combine_runs([run(-765.0), run(-765.1), run(-764.9)])
    out, stopped = evidences(jobs_for({"q3+sensor_mass": -805.0}), CompareConfig(repeats=3), monkeypatch,
                             rivals={"q3": current})
    assert list(out) == ["q3+sensor_mass"] and list(stopped) == ["q3+sensor_mass"]
    assert len(out["q3+sensor_mass"].runs) == 2


@pytest.fixture(scope="module")
def real_comparisons():
    """air and q1 compared on a reference q1 hammer test (tests.reference; 1 s at 256 Hz), with and
    without early stop."""
    rec, _ = ac.hammer("q1", seed=3, fs=256.0)
    base = CompareConfig(FitConfig(n_intervals=6), repeats=3, replicates=10)
    return [compare(rec, ["air", "q1"], replace(base, early_stop=stop))[1]
            for stop in (None, cmp.EARLY_STOP_NATS)]


@pytest.mark.slow
def test_on_a_real_comparison_the_leader_keeps_its_repeats_and_the_verdict_says_who_was_stopped(real_comparisons):
    """air trails q1 by hundreds of nats on a q1 recording: it is stopped after two repeats, the
    verdict says so, and q1's evidence and the ranking equal the full comparison's exactly."""
    full, early = real_comparisons
    assert early["ranking"] == full["ranking"] == ["q1", "air"]
    assert early["models"]["q1"]["log_evidence"] == full["models"]["q1"]["log_evidence"]
    assert "stopped_early" not in full["models"]["air"]["evidence"]
    assert "stopped after 2 of 3 repeats" in early["models"]["air"]["evidence"]["stopped_early"]
    assert early["models"]["air"]["evidence"]["repeats"] == full["models"]["air"]["evidence"]["repeats"][:2]
    assert "stopped early for air" in early["verdict"] and "stopped early" not in full["verdict"]


def test_a_ceiling_is_never_below_the_likelihood_its_runs_found(monkeypatch):
    """alu_q1_release's pattern: q3's optimiser stopped in a corner of its prior 1016 nats below
    q1 while its (unsettled) runs found the mode, 7 nats behind. The ceiling is the highest log
    likelihood seen, the runs' particles included, so q3 keeps its repeats; with runs that stay far
    below as well, it is stopped."""
    jobs = {"q1": (0, SimpleNamespace(ndim=2, log_z=8744.0, spread=0.01), None, 0),
            "q3": (1, SimpleNamespace(ndim=2, log_z=8737.0, spread=3.0), None, 0)}
    _, stopped = evidences(jobs, CompareConfig(repeats=3), monkeypatch, rivals={}, ceilings={"q3": 7728.0})
    assert stopped == {}
    jobs["q3"] = (1, SimpleNamespace(ndim=2, log_z=7700.0, spread=3.0), None, 0)
    _, stopped = evidences(jobs, CompareConfig(repeats=3), monkeypatch, rivals={}, ceilings={"q3": 7728.0})
    assert list(stopped) == ["q3"] and "unsettled" in stopped["q3"]


class RecordingExecutor(SerialExecutor):
    """A serial executor that keeps, per ``map`` call, the seeds of the SMC runs it was given."""

    def __init__(self):
        self.waves = []

    def map(self, fn, *iterables, bar=None):
        self.waves.append([args[2] for args in iterables[0]])
        return super().map(fn, *iterables, bar=bar)


def test_the_model_with_the_highest_ceiling_runs_all_its_repeats_in_the_first_wave(monkeypatch):
    """The likely leader (highest likelihood ceiling: q3) runs its three repeats in the first wave,
    first in it; the others two each, and a third only when not stopped (q1, within the margin).
    Every run is the one of the same repeat on the full path (same seeds), so the evidences equal
    the full path's where nothing was stopped."""
    jobs = jobs_for({"q1": -780.0, "q3": -765.0, "air": -3750.0})
    ceilings = {"q1": -770.0, "q3": -755.0, "air": -3740.0}
    executor = RecordingExecutor()
    monkeypatch.setattr(cmp, "smc_job", fake_smc)
    early, stopped = cmp._evidence(jobs, CompareConfig(repeats=3), np.random.SeedSequence(4), executor, {}, None,
                                   ceilings)
    full, _ = evidences(jobs, CompareConfig(repeats=3, early_stop=None), monkeypatch, rivals={})
    assert list(stopped) == ["air"]
    first, second = executor.waves
    q3_seeds = [cmp._seed(np.random.SeedSequence(4), 1000 + r) for r in range(3)]
    assert first[:3] == q3_seeds and len(first) == 3 + 2 + 2
    assert len(second) == 1                                      # q1's third repeat
    for m in ("q1", "q3"):
        assert [r.log_z for r in early[m].runs] == [r.log_z for r in full[m].runs]


#: the diagnosis's decision: ln B above 5 nats by three standard errors
DECISIVE = (5.0, 3.0)


def pair(log_z_a, log_z_b, half_spread=0.0):
    """Two evidences of two runs each, at log_z -+ half_spread (sd of the mean = half_spread)."""
    return {m: combine_runs([run(z - half_spread), run(z + half_spread)]) for m, z in (("q3", log_z_a), ("q1", log_z_b))}


def test_a_decision_is_settled_only_beyond_its_cushion_in_nats():
    """With exact runs (sd 0) the cushion is SETTLED_NATS = 1: q1 6.05 nats behind q3 has margin
    6.05 - 5 = 1.05 (settled: both stop), 5.95 behind has 0.95 (not), 4.05 behind has -0.95 (not),
    3.95 behind -1.05 (settled, tied)."""
    assert sorted(cmp.settled(pair(-765.0, -771.05), DECISIVE, 3)) == ["q1", "q3"]
    assert cmp.settled(pair(-765.0, -770.95), DECISIVE, 3) == {}
    assert cmp.settled(pair(-765.0, -769.05), DECISIVE, 3) == {}
    assert sorted(cmp.settled(pair(-765.0, -768.95), DECISIVE, 3)) == ["q1", "q3"]


def test_a_decision_must_hold_whatever_the_remaining_repeat_gives_within_three_run_sds():
    """q3 and q1 with exact runs and air's runs 1.2 nats apart: the pooled run sd is
    sqrt(0.72 / 3) = 0.49. A third run of each at 3 of those sds towards the other moves the
    difference by 2 x 0.49 and the 3 sd term up by 3 x sqrt(2) x 0.49: the margin falls by
    6.24 x 0.49 = 3.06 nats. q1 8.2 nats behind q3 (margin 3.2) stays decisively behind whatever
    the third runs give: settled; 7.9 behind (margin 2.9) could become tied: not settled."""
    air = combine_runs([run(-799.4), run(-800.6)])
    stopped = cmp.settled({**pair(-765.0, -773.2), "air": air}, DECISIVE, 3)
    assert {"q1", "q3"} <= set(stopped) and "2 of 3 repeats" in stopped["q1"] and "3.2 nats or more" in stopped["q1"]
    assert not {"q1", "q3"} & set(cmp.settled({**pair(-765.0, -772.9), "air": air}, DECISIVE, 3))
    assert {"q1", "q3"} <= set(cmp.settled(pair(-765.0, -772.9), DECISIVE, 3))     # exact runs alone: settled


def test_unsettled_runs_settle_no_decision_and_beaten_models_are_left_aside():
    """A model whose runs spread by more than EVIDENCE_SD_MAX settles no decision with it, so
    nobody stops while it counts; left aside as beaten, it does not hold the others back."""
    evidences = {**pair(-765.0, -780.0), "air": combine_runs([run(-790.0), run(-796.0)])}
    assert cmp.settled(evidences, DECISIVE, 3) == {}
    assert sorted(cmp.settled(evidences, DECISIVE, 3, {"q1", "q3"}, {"air"})) == ["q1", "q3"]


def test_with_a_decisive_rule_settled_models_run_the_first_wave_only(monkeypatch):
    """The diagnosis's rule on three models: q1 2 nats behind q3 (tied, settled) and air 15 behind
    (inside the 20-nat early stop, but decisively behind: settled) all stop after two repeats,
    the likely leader q3 too; with q1 5.5 behind (its decision against q3 on the line) q1 and q3
    run their third repeats and air, settled against both, does not. The runs that ran are those
    of the full path."""
    ceilings = {"q1": -760.0, "q3": -755.0, "air": -770.0}
    monkeypatch.setattr(cmp, "smc_job", fake_smc)
    full, _ = evidences(jobs_for({"q1": -770.5, "q3": -765.0, "air": -780.0}),
                        CompareConfig(repeats=3, early_stop=None), monkeypatch, rivals={})
    for q1, more in ((-767.0, []), (-770.5, ["q1", "q3"])):
        executor = RecordingExecutor()
        out, stopped = cmp._evidence(jobs_for({"q1": q1, "q3": -765.0, "air": -780.0}), CompareConfig(repeats=3),
                                     np.random.SeedSequence(4), executor, {}, None, ceilings, decisive=DECISIVE)
        assert len(executor.waves[0]) == 6
        assert sorted(m for m, e in out.items() if len(e.runs) == 3) == more
        assert sorted(stopped) == sorted({"q1", "q3", "air"} - set(more))
    assert [r.log_z for r in out["q3"].runs] == [r.log_z for r in full["q3"].runs]
    assert [r.log_z for r in out["air"].runs] == [r.log_z for r in full["air"].runs[:2]]


def test_a_leader_with_every_rival_beaten_is_settled_unless_its_own_runs_spread():
    """The baseline comparison's pattern: every other model beaten, the leader has no decision left
    and stops after two repeats, in parallel with the others; a leader whose runs spread by more
    than EVIDENCE_SD_MAX is not (its second pass is due)."""
    far = combine_runs([run(-2000.0), run(-2000.1)])
    stopped = cmp.settled({"q3": combine_runs([run(-765.0), run(-765.1)]), "air": far}, DECISIVE, 3, {"q3"}, {"air"})
    assert list(stopped) == ["q3"] and "far behind" in stopped["q3"]
    assert cmp.settled({"q3": combine_runs([run(-765.0), run(-768.0)]), "air": far}, DECISIVE, 3, {"q3"}, {"air"}) == {}


def test_the_verdict_tells_a_settled_stop_from_a_model_far_behind():
    """A model stopped because it is far behind is said to be so; one stopped because its decisions
    are settled (a tied runner-up, or the leader) is not said to be behind."""
    from bayesbeam.comparison import verdict

    behind = beaten({"q3": combine_runs([run(-765.0), run(-765.1)]), "air": combine_runs([run(-2000.0), run(-2000.1)])},
                    20.0, 3)["air"]
    tied = cmp.settled(pair(-765.0, -767.0), DECISIVE, 3)["q1"]

    def entry(log_z, why):
        return {"mechanisms": ["air"], "effects": [], "probability": 0.5, "log_evidence": log_z, "log_evidence_sd": 0.1,
                "log_bayes_factor_vs_best": log_z + 765.0, "ppc": {},
                "evidence": {"repeats": [log_z] * 2, "stopped_early": why}}

    text = verdict(["q3", "q1", "air"], {"q3": entry(-765.0, None), "q1": entry(-767.0, tied), "air": entry(-2000.0, behind)})
    assert "stopped early for air: after the first repeats each was so far behind" in text
    assert "stopped early for q1: after the first repeats no decisive comparison with it could change" in text
