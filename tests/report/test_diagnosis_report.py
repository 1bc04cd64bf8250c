"""The diagnosis report: one self-contained HTML file with the maps before and after, the per-mode
table, the decisions and the added effect's posterior, whose every figure loads in a browser; and
the layout of diagnosis.json, written beside it.

Plumbing: the shared cheap BeamModel-made diagnoses (tests/diagnosis_cases.py) feed it, a
concealed root spring (found and added) and a null recording (nothing flagged, nothing fitted);
diagnoses on data the model did not make are tests/acceptance/test_diagnose.py's. Headless Chromium renders each
report and the report's own script counts the images that decoded.
"""
import html
import json
import re
import shutil
import subprocess

import pytest

from bayesbeam.comparison import strength
from bayesbeam.diagnosis import DECISIVE, effect_parameters
from bayesbeam.report.diagnosis import SECTIONS, lead, write_report
from tests.diagnosis_cases import diagnosed


#: the root spring's diagnosis takes a minute (its rounds of fits): every test of its report is slow
@pytest.fixture(scope="module", params=[pytest.param("root_compliance", marks=pytest.mark.slow), None],
                ids=["root_compliance", "null"])
def report(request, tmp_path_factory):
    """(path of the report, its HTML, the Diagnosis)."""
    d = diagnosed(request.param)
    path = write_report(d, d.to_dict(), tmp_path_factory.mktemp("diagnosis") / "report.html")
    return path, path.read_text(encoding="utf-8"), d


def section(text, anchor) -> str:
    """The HTML of one section: from its heading to the next one's."""
    start = text.index(f'<h2 id="{anchor}">')
    end = text.find("<h2 ", start + 1)
    return text[start:] if end < 0 else text[start:end]


def body_rows(table_html) -> list[str]:
    body = table_html[table_html.index("<tbody>"):table_html.index("</tbody>")]
    return re.findall(r"<tr[^>]*>(.*?)</tr>", body)


def alts(text) -> list[str]:
    return re.findall(r'<img alt="([^"]*)"', text)


def test_report_is_one_self_contained_file(report):
    path, text, _ = report
    assert [p.name for p in path.parent.iterdir()] == ["report.html"]      # no temporary file left
    # nothing fetched from elsewhere: no scheme or protocol-relative address in src, href or CSS url()
    assert not re.search(r"""(?:src|href)\s*=\s*["']?\s*(?:[a-z][a-z0-9+.-]*:)?//""", text, re.IGNORECASE)
    assert not re.search(r"url\(", text) and "<link" not in text
    sources = re.findall(r'<img [^>]*src="([^"]*)"', text)
    assert sources and all(s.startswith("data:image/png;base64,") for s in sources)


def test_every_section_and_the_plain_paragraph_are_in_the_report(report):
    """The summary leads with the three plain sentences; the diagnosis's full paragraph, with the
    solver's reasons for what was not fitted, is in the candidates section."""
    _, text, d = report
    for anchor, title in SECTIONS:
        assert f'<h2 id="{anchor}">{title}</h2>' in text
    assert f'<p class="verdict">{html.escape(" ".join(lead(d.to_dict())))}</p>' in section(text, "summary")
    paragraph_html = html.escape(d.to_dict()["summary"])
    assert paragraph_html in section(text, "candidates") and paragraph_html not in section(text, "summary")
    header = text[:text.index("<nav>")]
    assert f"<td>{d.final.name}</td>" in header.replace(' class="text"', "")
    assert ("root_compliance" in header) == bool(d.added)


def test_summary_leads_with_what_was_missing_the_evidence_and_the_improvement(report):
    """Three sentences, each checked against the Diagnosis object itself (not diagnosis.json's
    text): the added effect and its estimate (effect_parameters of the trial, 4 significant digits
    as shown), the log Bayes factor and its Kass & Raftery strength, and the RMS standardized
    residual before and after (2 decimals as shown); for the null recording, that nothing was
    missing, nothing weighed and the fit unchanged."""
    _, _, d = report
    missing, evidence, improvement = lead(d.to_dict())
    before, after = d.baseline_mismatch.rms_standardized_residual, d.final_mismatch.rms_standardized_residual
    if d.added:
        trial = next(t for t in d.trials if t.added)
        q = effect_parameters(trial)["k_theta"]
        assert trial.effect in missing and "rotational spring at the clamp" in missing
        assert f"k_theta = {q['mean']:.4g} N m/rad" in missing and d.baseline.name in missing
        assert f"{trial.log_bayes_factor:.1f} +- {trial.log_bayes_factor_sd:.1f} nats" in evidence
        assert evidence.startswith(f"The evidence is {strength(trial.log_bayes_factor)} for {trial.effect}")
        assert f"from {before:.2f} to {after:.2f}" in improvement and d.final.name in improvement
        assert f"from {d.baseline.evidence.log_z:.1f} to {d.final.evidence.log_z:.1f}" in improvement
    else:
        assert not d.trials and "Nothing the damping model q1 leaves out shows above the noise" in missing
        assert "no evidence to weigh" in evidence
        assert improvement.startswith("The fit is unchanged") and f"{before:.2f}" in improvement


def test_maps_before_and_after_only_when_an_effect_was_added(report):
    _, text, d = report
    maps = [a for a in alts(section(text, "map")) if a.startswith("mismatch map")]
    if d.added:
        assert maps == ["mismatch map before (q1) and after (q1+root_compliance)"]
        assert "Regions of the after map (q1+root_compliance)" in text
    else:
        assert maps == ["mismatch map before (q1)"]
        assert "Nothing was added" in section(text, "map") and "Regions of the after map" not in text
    assert "phase error against frequency" in alts(section(text, "map"))


def test_per_mode_table_has_a_row_per_mode_of_each_map_and_highlights_the_flags(report):
    _, text, d = report
    maps = [d.baseline_mismatch] + ([d.final_mismatch] if d.added else [])
    rows = body_rows(section(text, "modes"))
    assert len(rows) == sum(len(m.modes) for m in maps)
    flagged = [r for r in rows if 'class="bad"' in r]
    assert sum(r.count('class="bad"') for r in rows) == sum(len(row["flags"]) for m in maps for row in m.modes)
    if d.added:       # the root spring shows in the baseline's modes and is gone after
        assert flagged and all(re.search(r'<td class="text">before</td>', r) for r in flagged)
    else:
        assert not flagged


def test_candidates_and_decisions(report):
    _, text, d = report
    part = section(text, "candidates")
    for ranking in d.rankings:
        for c in ranking.candidates:
            assert f'<td class="text">{c.effect}</td><td class="text">{c.parameter}</td>' in part
    assert "Decision rule: an effect is added when its log Bayes factor" in part and "exceeds 5 nats" in part
    if d.trials:
        trials = body_rows(part[part.index("<h3>Augmented fits</h3>"):])
        assert len(trials) == len(d.trials)
        assert "<b>added</b>" in trials[0] and f"{d.trials[0].log_bayes_factor:.1f} &plusmn;" in trials[0]
    else:
        assert "No augmented model was fitted" in part


@pytest.mark.slow
def test_models_not_fitted_and_the_damping_recheck_are_shown():
    """Without --model the summary carries the damping re-check and the models left out; both get
    a table in the candidates section (the cheap diagnoses were run with --model: fill them in)."""
    from bayesbeam.report.diagnosis import render

    d = diagnosed("root_compliance")
    summary = d.to_dict()
    assert summary["not_fitted"] == [] and summary["damping_recheck"] is None
    summary["not_fitted"] = [{"round": 1, "model": "q2+axial_load", "reason": "dense solve"},
                             {"round": 0, "model": "q2+root_compliance+axial_load", "reason": "dense solve"}]
    summary["damping_recheck"] = {"effects": ["root_compliance"], "best": "q1+root_compliance",
                                  "previous": "q2+root_compliance", "switched": True,
                                  "models": {"q1+root_compliance": {"log_evidence": -10.0, "log_evidence_sd": 0.1,
                                                                    "probability": 1.0},
                                             "q2+root_compliance": {"log_evidence": -60.0, "log_evidence_sd": 0.1,
                                                                    "probability": 0.0}}}
    text = render(d, summary)
    part = section(text, "candidates")
    # the solver's reason is machinery: in the candidates section, not in the summary
    assert "dense solve" in part and "dense solve" not in section(text, "summary")
    assert "the damping verdict changed from q2+root_compliance to <b>q1+root_compliance</b>" in section(text, "summary")
    rows = body_rows(part[part.index("<h3>Not fitted</h3>"):])
    assert "q2+axial_load" in rows[0] and "re-check" in rows[1]
    recheck = part[part.index("<h3>Damping re-checked with root_compliance</h3>"):]
    assert "Final damping: <b>q1+root_compliance</b> (switched" in recheck
    assert "q1+root_compliance" in body_rows(recheck)[0]
    assert "judged again" not in part            # nothing pruned: no table
    assert "Not decisively behind" not in text      # no tie named
    # a model the evidence cannot rank below the best is named in both places
    summary["damping_recheck"] |= {"tied": ["q3+root_compliance"]}
    tied = render(d, summary)
    words = "Not decisively behind q1+root_compliance: q3+root_compliance; the recording does not decide"
    assert words in section(tied, "summary") and words in section(tied, "candidates")
    # added effects judged again with the new damping: the dropped one is named, the table shows both
    summary["damping_recheck"] |= {"dropped": ["root_damping"], "final": "q1+root_compliance", "pruning": {
        "q1+root_compliance": {"without": "root_damping", "log_bayes_factor": -1.0, "sd": 0.1, "needed": False},
        "q1": {"without": "root_compliance", "log_bayes_factor": 300.0, "sd": 0.1, "needed": True}}}
    text = render(d, summary)
    assert "root_damping no longer earned a place and was dropped" in section(text, "summary")
    pruned = section(text, "candidates")
    pruned = pruned[pruned.index("<h3>Added effects judged again with the new damping model</h3>"):]
    rows = body_rows(pruned)
    assert "root_damping" in rows[0] and "-1.0" in rows[0] and rows[0].endswith("<td>no</td>")
    assert "300.0" in rows[1] and rows[1].endswith("<td>yes</td>")
    # a switched re-check shows the final model's posterior (its effect estimate is no trial's)
    from dataclasses import replace
    from types import SimpleNamespace

    effect = section(render(replace(d, recheck=SimpleNamespace(switched=True)), summary), "effect")
    final = effect[effect.index(f"<h3>Final model {d.final.name} (after the damping re-check)</h3>"):]
    assert [r.split("</td>")[0] for r in body_rows(final)] == [f'<td class="text">{n}' for n in summary["final"]["parameters"]]


def test_added_effect_posterior_names_k_theta(report):
    _, text, d = report
    part = section(text, "effect")
    if not d.added:
        assert "No effect was added." in part and not alts(part)
        return
    assert alts(part) == ["posterior of root_compliance"]
    q = effect_parameters(d.trials[0])["k_theta"]
    row = body_rows(part)[0]
    assert "k_theta" in row and f"{q['q50']:.4g}" in row and f"{q['q05']:.4g} to {q['q95']:.4g}" in row
    screen = d.rankings[0].candidates[0]
    assert screen.effect == "root_compliance" and f"{screen.value:.4g}" in row


def test_every_figure_loads_in_headless_chromium(report, tmp_path):
    path, text, _ = report
    chromium = shutil.which("chromium")
    if chromium is None:
        pytest.fail("Chromium is not installed; install it with `apt-get install chromium` "
                    "(.ci/run installs it from Debian's packages)")
    command = [chromium, "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
               "--disable-background-networking", "--disable-component-update", "--disable-sync",
               f"--user-data-dir={tmp_path / 'profile'}", "--virtual-time-budget=10000", "--dump-dom",
               path.resolve().as_uri()]
    dom = subprocess.run(command, capture_output=True, text=True, timeout=120, check=True).stdout
    n = text.count("<img ")
    assert n >= 2         # the map and the phase figure at least
    assert f'data-figures-loaded="{n}/{n}"' in dom


def text_of(html_text) -> str:
    """What a reader sees: tags dropped, entities decoded."""
    return html.unescape(re.sub(r"<[^>]+>", " ", html_text))


def test_a_stand_in_leads_the_summary_with_its_estimate_and_what_the_set_up_allows():
    """An added axial load at P = 104 N where the set-up allows +-1.483 N: the report's first
    sentence says it is a stand-in, with the parameter, its estimate and the allowed range; a
    stand-in given with the baseline leads the same way. The verdict is the final model's
    (final_stand_ins): an added effect that was a stand-in as fitted in its round but is not one
    in the final model is a finding."""
    from bayesbeam.report.diagnosis import _summary_section
    from tests.report.summaries import unexplained_summary

    summary = unexplained_summary()
    first = lead(summary)[0]
    assert first.startswith("Not a finding: axial_load is a stand-in")
    assert "P = 104.2 N (posterior median)" in first and "-1.483 to 1.483 N the set-up allows" in first
    shown = text_of(_summary_section(summary))
    assert shown.index("axial_load is a stand-in") < shown.index("The evidence is")
    given = unexplained_summary() | {"candidates": [], "added": []}
    assert lead(given)[0] == first
    moved = unexplained_summary() | {"stand_ins": [], "final_stand_ins": {}}
    assert moved["candidates"][0]["stand_in"] and "stand-in" not in " ".join(lead(moved))
    assert lead(moved)[0].startswith("What the damping model q1 left out of this recording")


@pytest.mark.parametrize("share, shown", [(0.36, "the misfit is 36 % of the signal the model puts there"),
                                          (3.56, "the misfit is 3.6 x the signal the model puts there")])
def test_a_misfit_share_reads_as_a_percentage_below_one_and_a_multiple_above(share, shown):
    """misfit_share is unbounded (the misfit over the signal the model puts in the region): 0.36
    reads '36 %', 3.56 reads '3.6 x', never '356 %', in the rendered Unexplained table."""
    from bayesbeam.report.diagnosis import _summary_section
    from tests.report.summaries import region, unexplained_summary

    summary = unexplained_summary(regions=[region("mode 2 is 2% low", share, mode=2)])
    text = text_of(_summary_section(summary))
    assert shown in text
    assert "356" not in text and "channel's signal" not in text


#: per rule of NEXT_STEPS: (the final map's mode rows, the unexplained regions, words of its cause)
RULES = {
    "modes_low": ([("frequency", -2.0, 0.0), ("frequency", -1.0, 0.0)], [1, 2], "compliant clamp or a mass"),
    "modes_high": ([("frequency", 2.0, 0.0), ("frequency", 1.0, 0.0)], [1, 2], "stiffer or lighter"),
    "mode_low": ([("frequency", -2.0, 0.0), ("frequency", 1.0, 0.0)], [1], ("near that mode's antinode, or a "
                                                                           "resonance of the support")),
    "mode_high": ([("frequency", 2.0, 0.0), ("frequency", -1.0, 0.0)], [1], "a constraint near that mode's antinode"),
    "damping_high": ([("damping", 0.0, 30.0)], [1], "a contact or rubbing"),
    "damping_low": ([("damping", 0.0, -30.0)], [1], "damping model's law"),
    "amplitude": ([("amplitude", 0.0, 0.0)], [1], "sensitivity or position"),
    "decay_shape": ([("curvature", 0.0, 0.0)], [1], "depends on amplitude"),
    "line_persistent": ([], [("residual line at 50 Hz, away from every model mode; its amplitude keeps 95%; it does "
                             "not decay (95% kept), but neither would the beam")], "electrical pickup"),
    "line_decaying": ([], [("residual line at 87 Hz, away from every model mode; it decays (9% kept over the "
                           "window)")], "a mode the model lacks"),
    "band_top": ([], [("residual at 143.9 Hz, at the model's mode 3 (143.6 Hz) near the top of the band, where the "
                      "per-mode statistics are not computed")], "--max-frequency"),
    "delay": ([], ["the measured response lags the model by 1.2 +- 0.1 ms at the excitation"], "timing offset"),
    "force": ([], ["the force-noise latent terms carry 3 x the variance the force channel's noise allows"],
              "double hit"),
    "other": ([], ["something no rule knows"], "something no rule knows"),
}


@pytest.mark.parametrize("kind", list(RULES))
def test_each_next_step_rule_names_its_cause_for_its_region(kind):
    """Each rule of NEXT_STEPS, from a region of its kind: the one step given is that rule's, with
    its physical cause and where (the mode and its frequency, or the line's frequency). A shift of
    one sign at every flagged mode is one global step, not a step per mode."""
    from bayesbeam.report.diagnosis import NEXT_STEPS, next_steps
    from tests.report.summaries import mode_row, region, unexplained_summary

    rows, where, cause = RULES[kind]
    modes = [mode_row(i + 1, 10.0 * (i + 1), [flag_], f_err, z_err) for i, (flag_, f_err, z_err) in enumerate(rows)]
    regions = [region("finding", 0.5, mode=w, band=(9.0, 11.0)) if isinstance(w, int) else
               region(w, 0.5, peak=87.0) for w in where]
    steps = next_steps(unexplained_summary(regions, modes))
    place = ("mode 1 (10 Hz) and mode 2 (20 Hz)" if kind.startswith("modes_") else
             "mode 1 (10 Hz)" if rows else "87 Hz")
    expected = NEXT_STEPS[kind].format(where=place, sensors="accel_tip", note=where[0])
    assert steps == [expected[0].upper() + expected[1:]]
    assert cause in steps[0]
    assert set(RULES) == set(NEXT_STEPS)                       # every rule is tested here


BODY = "the attached body's own mode"


def test_a_next_step_names_the_beams_mode_by_its_number_beside_a_bodys_own_mode():
    """The final model's second mode is the beam's first when a body's own mode lies below it: the
    step names "mode 1 (6.6 Hz)", never the model's index; a flagged body mode is named as such."""
    from bayesbeam.report.diagnosis import next_steps
    from tests.report.summaries import mode_row, region, unexplained_summary

    modes = [mode_row(1, 0.9, ["damping"], 0.0, 40.0, label=BODY), mode_row(2, 6.6, ["frequency"], 2.0),
             mode_row(3, 41.0, ["frequency"], -1.0)]
    modes[1]["label"], modes[2]["label"] = "mode 1", "mode 2"
    steps = next_steps(unexplained_summary([region("finding", 0.5, mode=k) for k in (1, 2)], modes))
    assert any(step.startswith(f"The damping of {BODY} (0.9 Hz)") for step in steps)
    assert any("mode 1 (6.6 Hz)" in step for step in steps) and not any("mode 2 (6.6" in step for step in steps)


def test_per_mode_table_puts_each_beam_mode_of_the_maps_together_and_a_bodys_mode_below_them():
    """Rows of the baseline map (beam modes 1, 2) and the final map (body at 0.9 Hz, beam modes 1, 2):
    the body's row first (below beam mode 1), then each beam mode's rows of both maps together."""
    from types import SimpleNamespace

    from bayesbeam.report.diagnosis import MODE_COLUMNS, per_mode_table
    from bayesbeam.report.html import esc
    from tests.report.summaries import mode_row

    def full(row):
        zeros = {k: 0.0 for _, key, sd, _ in MODE_COLUMNS.values() if key for k in (key, sd)}
        return row | zeros | {"p_values": {"curvature": None}, "note": ""}

    before = [full(mode_row(1, 6.5)), full(mode_row(2, 41.0))]
    after = [full(mode_row(1, 0.9, label=BODY)), full(mode_row(2, 6.6)), full(mode_row(3, 41.2))]
    after[1]["label"], after[2]["label"] = "mode 1", "mode 2"
    rows = body_rows(per_mode_table([("before", None, SimpleNamespace(modes=before)),
                                     ("after", None, SimpleNamespace(modes=after))]))
    shown = [re.findall(r"<td[^>]*>([^<]*)</td>", r)[:4] for r in rows]
    assert [cells[:2] for cells in shown] == [[esc(BODY), "after"], ["1", "before"], ["1", "after"],
                                              ["2", "before"], ["2", "after"]]
    assert [cells[3] for cells in shown] == ["0.9", "6.5", "6.6", "41", "41.2"]


def test_no_next_steps_when_nothing_is_unexplained():
    from bayesbeam.report.diagnosis import _summary_section, next_steps
    from tests.report.summaries import unexplained_summary

    summary = unexplained_summary(regions=[])
    assert next_steps(summary) == [] and "What to check next" not in _summary_section(summary)


@pytest.mark.parametrize("r_hat, flagged", [(1.03, False), (1.05, False), (1.0501, True), (1.2, True)])
def test_r_hat_is_flagged_past_compares_limit_and_shown_apart_from_it(r_hat, flagged):
    """The diagnosis report flags a parameter's R-hat exactly when compare.py's R_HAT_MAX (1.05)
    calls it not settled; a flagged value never prints as the limit itself; a narrow interval
    (44.2791 to 44.2803) reads with different ends."""
    from bayesbeam.report.diagnosis import parameter_table

    q = {"unit": "N m^2", "q05": 44.2791, "q50": 44.2797, "q95": 44.2803, "mean": 44.2797, "sd": 4e-4, "r_hat": r_hat}
    row = body_rows(parameter_table({"EI": q}))[0]
    assert ('class="bad"' in row) == flagged
    assert "1.050<" not in row or not flagged
    low, high = re.search(r"<td>([-0-9.e]+) to ([-0-9.e]+)</td>", row).groups()     # the interval's ends differ
    assert low != high


@pytest.mark.slow
def test_diagnosis_json_has_its_summary_layout():
    """plumbing: diagnosis.json's keys, on the root spring's diagnosis whose report the tests above
    render (that the spring is named on data the model did not make is
    tests/acceptance/test_diagnose.py's)."""
    summary = json.loads(json.dumps(diagnosed("root_compliance").to_dict()))
    assert {"baseline", "mismatch", "candidates", "added", "unexplained", "final"} <= set(summary)
    assert {"model", "log_evidence", "rms_standardized_residual"} <= set(summary["baseline"])
    assert {"band_hz", "time_s", "sensor", "note"} <= set(summary["mismatch"][0])
    candidate = summary["candidates"][0]
    assert candidate["effect"] == "root_compliance" and candidate["delta_log_evidence"] > DECISIVE
    assert {"mean", "q05", "q95"} <= set(candidate["parameters"]["k_theta"])
    assert all({"floor_sd", "fitted_sd", "inflation"} <= set(n) for n in candidate["noise"].values())
    assert summary["final"]["model"] == "q1+root_compliance"
    # the final model's whole posterior: after a damping re-check it is not any trial's
    assert {"EI", "gamma", "cdI", "k_theta"} <= set(summary["final"]["parameters"])
    assert summary["final"]["parameters"]["k_theta"] == candidate["parameters"]["k_theta"]
