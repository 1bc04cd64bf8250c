"""bayesbeam diagnose: its outputs on disk, what it prints, and its refusals."""
import json

import pytest

from bayesbeam.cli import main
from bayesbeam.io import write_recording
from bayesbeam.report.diagnosis import lead
from tests.diagnosis_cases import recording

CHEAP = ["--model", "q1", "--n-intervals", "6", "--repeats", "2", "--replicates", "10", "--map-replicates", "20",
         "--executor", "serial", "--quiet"]


@pytest.fixture(scope="module")
def null(tmp_path_factory):
    """plumbing: the cheap BeamModel-made recording with nothing concealed, as a recording directory
    (diagnoses of concealed effects on data the model did not make are tests/acceptance/test_diagnose.py's)."""
    return str(write_recording(recording(None), tmp_path_factory.mktemp("recs") / "null"))


@pytest.mark.slow
def test_diagnose_writes_json_report_and_posteriors(null, tmp_path, capsys):
    import arviz as az

    out = tmp_path / "diag"
    assert main(["diagnose", null, *CHEAP, "--out", str(out)]) == 0
    summary = json.loads((out / "diagnosis.json").read_text())
    # plumbing only: what the diagnosis finds on the model's own output is no evidence of anything
    # (tests/acceptance/test_diagnose.py: reference recordings); here only that it is written out
    assert isinstance(summary["added"], list) and isinstance(summary["unexplained"], bool)
    assert summary["final"]["model"].split("+")[0] == "q1"
    assert summary["recording"].endswith("null")
    assert (out / "report.html").stat().st_size > 10000
    assert sorted(p.name for p in out.iterdir()) == ["diagnosis.json", "posteriors", "report.html"]
    assert "cdI" in az.from_netcdf(out / "posteriors" / "q1.nc").posterior
    printed = capsys.readouterr().out
    assert "added: " in printed
    # the plain sentences lead, the detailed paragraph follows
    assert printed.index(lead(summary)[0]) < printed.index("In detail: ")


@pytest.mark.parametrize("argv, message", [
    (["--model", "q1+wet_towel"], "--model q1+wet_towel"),
    (["--model", "q1", "--rounds", "0"], "--rounds = 0"),
    (["--model", "q1", "--repeats", "1"], "at least 2"),
])
def test_bad_input_exits_2_naming_it(null, tmp_path, capsys, argv, message):
    assert main(["diagnose", null, *argv, "--out", str(tmp_path / "x")]) == 2
    assert message in capsys.readouterr().err
    assert not (tmp_path / "x").exists()


def test_the_terminal_leads_with_a_stand_in_and_ends_the_lead_with_what_to_check(null, tmp_path, capsys,
                                                                                  monkeypatch):
    """Plumbing of what `bayesbeam diagnose` prints, on a hand-made diagnosis.json (the wording's
    own tests are tests/report/test_diagnosis_report.py's): the added line marks the stand-in, the
    lead's first sentence names it with its estimate and allowed range, and the numbered steps to
    check follow the lead, before the detailed paragraph."""
    import importlib
    from types import SimpleNamespace

    import bayesbeam.report.diagnose_outputs
    from bayesbeam.report.diagnosis import next_steps
    from tests.report.summaries import unexplained_summary

    summary = unexplained_summary()
    # the module, not the package's function of the same name
    monkeypatch.setattr(importlib.import_module("bayesbeam.diagnosis"), "diagnose",
                        lambda *args, **kwargs: SimpleNamespace(to_dict=lambda: summary))
    monkeypatch.setattr(bayesbeam.report.diagnose_outputs, "write_diagnosis", lambda *args: [tmp_path / "x"])
    assert main(["diagnose", null, *CHEAP, "--out", str(tmp_path / "diag")]) == 0
    printed = capsys.readouterr().out
    assert "added: axial_load (stand-in);" in printed
    first = lead(summary)[0]
    assert "P = 104.2 N" in first and "-1.483 to 1.483 N" in first
    steps = next_steps(summary)
    assert len(steps) == 3
    positions = [printed.index(text) for text in
                 (first, "What to check next:", *(f"{i}. {s}" for i, s in enumerate(steps, 1)), "In detail: ")]
    assert positions == sorted(positions)


@pytest.mark.slow
def test_from_comparison_reuses_the_comparisons_fit_of_the_model(null, tmp_path, capsys):
    """plumbing: `compare` then `diagnose --from-comparison` on the same recording directory: the
    diagnosis's baseline is the comparison's q1, its log evidence read back exactly (a float's JSON
    repr reads back to itself), and the comparison is not run again (no "optimising" for q1)."""
    compared, out = tmp_path / "compare", tmp_path / "diag"
    fit = CHEAP[2:8]                            # --n-intervals 6 --repeats 2 --replicates 10
    assert main(["compare", null, "--models", "q1", *fit, "--executor", "serial", "--quiet", "--out", str(compared)]) == 0
    capsys.readouterr()
    assert main(["diagnose", null, *CHEAP[:-1], "--from-comparison", str(compared), "--out", str(out)]) == 0
    saved = json.loads((compared / "comparison.json").read_text())["models"]["q1"]
    baseline = json.loads((out / "diagnosis.json").read_text())["baseline"]
    assert baseline["model"] == "q1" and baseline["log_evidence"] == saved["log_evidence"]
    progress = capsys.readouterr().err
    assert f"baseline: q1 read from the comparison in {compared}" in progress
    assert "optimising 1 models (q1)" not in progress


def test_from_comparison_refuses_a_folder_that_holds_none(null, tmp_path, capsys):
    assert main(["diagnose", null, *CHEAP, "--from-comparison", str(tmp_path), "--out", str(tmp_path / "x")]) == 2
    assert f"{tmp_path / 'comparison.json'}: file: not found" in capsys.readouterr().err
    assert not (tmp_path / "x").exists()


def test_model_and_models_together_are_refused(null, tmp_path, capsys):
    assert main(["diagnose", null, "--model", "q1", "--models", "q1,q2", "--out", str(tmp_path / "x")]) == 2
    assert "--model q1 and --models q1,q2 together" in capsys.readouterr().err
    assert not (tmp_path / "x").exists()


@pytest.mark.parametrize("models, expected", [
    (None, "paper"), ("literature", "literature"), ("all", "all"), (["q3", "air"], ("q3", "air")),
    ("q1,paper", ("q1", "q2", "q3", "air", "strain_rate")),
])
def test_models_names_the_damping_models_the_diagnosis_compares(null, models, expected):
    """--models as compare spells it: a list or a named set, expanded once; without it compare's
    default set. Parsing only: nothing is fitted."""
    from bayesbeam.api import options
    from bayesbeam.cli.diagnose import diagnose_config
    from bayesbeam.comparison import MODEL_SETS

    config = diagnose_config(options("diagnose", null, models=models))
    assert config.models == (MODEL_SETS[expected] if isinstance(expected, str) else expected)


def test_the_baseline_comparison_leaves_out_thermoelastic_without_a_material_table(null, monkeypatch):
    """`--models q1,thermoelastic` on a recording without [material]: the baseline comparison is
    asked for q1 alone (compare's rule, tests/test_comparison.py). plumbing: baseline_fits records
    its models and stops the run."""
    import bayesbeam
    import bayesbeam.diagnosis as dg

    asked = []

    def stop(rec, models, *args):
        asked.append(models)
        raise InterruptedError

    monkeypatch.setattr(dg, "baseline_fits", stop)
    with pytest.raises(InterruptedError):
        bayesbeam.diagnose(null, models="q1,thermoelastic", effect="sensor_mass", executor="serial", progress=False)
    assert asked == [["q1+sensor_mass"]]


def test_from_comparison_refuses_models_the_comparison_does_not_hold(null, tmp_path, capsys):
    """--from-comparison with --models: every model named must be in the comparison, the error
    names those missing and the fix; nothing is fitted after the comparison (one q1 fit, ~6 s)."""
    compared = tmp_path / "compare"
    fit = CHEAP[2:8]                            # --n-intervals 6 --repeats 2 --replicates 10
    assert main(["compare", null, "--models", "q1", *fit, "--executor", "serial", "--quiet", "--out", str(compared)]) == 0
    capsys.readouterr()
    argv = ["diagnose", null, "--models", "q1,q2,q3", *CHEAP[2:], "--from-comparison", str(compared)]
    assert main([*argv, "--out", str(tmp_path / "diag")]) == 2
    err = capsys.readouterr().err
    assert "has no q2, q3 (it holds q1)" in err and "Fix: " in err
    assert not (tmp_path / "diag").exists()


def test_diagnose_without_a_material_table_says_thermoelastic_was_left_out(null, tmp_path, capsys):
    """`--models q1,thermoelastic` on a recording without [material] diagnoses against q1 and says
    in the terminal, diagnosis.json and the report that thermoelastic was left out and how to add
    the table. plumbing: the cheap BeamModel-made recording, nothing concealed (~15 s)."""
    out = tmp_path / "diag"
    argv = ["diagnose", null, "--models", "q1,thermoelastic", *CHEAP[2:], "--out", str(out)]
    assert main(argv) == 0
    summary = json.loads((out / "diagnosis.json").read_text())
    why = summary["left_out"]["thermoelastic"]
    assert summary["baseline"]["model"] == "q1" and "no [material] table" in why
    assert list(summary["baseline_comparison"]) == ["q1"]
    assert f"thermoelastic was left out: {why}" in summary["summary"]
    assert f"left out thermoelastic: {why}" in capsys.readouterr().out
    assert "Damping models left out" in (out / "report.html").read_text()


@pytest.mark.slow
def test_resume_continues_a_killed_diagnosis_and_refuses_other_settings(null, tmp_path, capsys, monkeypatch):
    """A diagnosis killed after its baseline's comparison (here by the map that follows it) leaves
    that comparison and its SMC runs in OUT/checkpoint/; --resume with another --map-replicates is refused (exit 2)
    naming identity.json, the setting and the fix; with the same options it reads the baseline back
    (q1 not compared again), writes the outputs and removes the checkpoint."""
    import importlib

    dg = importlib.import_module("bayesbeam.diagnosis")
    out = tmp_path / "diag"
    real_locate, real_compare = dg._locate, dg.compare

    def killed(*_args, **_kwargs):
        raise KeyboardInterrupt
    monkeypatch.setattr(dg, "_locate", killed)
    with pytest.raises(KeyboardInterrupt):
        main(["diagnose", null, *CHEAP, "--out", str(out)])
    assert {p.name.split("-")[0] for p in (out / "checkpoint").glob("*.pkl")} == {"compare", "smc_job"}
    monkeypatch.setattr(dg, "_locate", real_locate)
    assert main(["diagnose", null, *CHEAP, "--map-replicates", "10", "--resume", "--out", str(out)]) == 2
    refusal = capsys.readouterr().err
    assert "identity.json" in refusal and '"settings"' in refusal and "--overwrite" in refusal
    compared = []
    monkeypatch.setattr(dg, "compare", lambda rec, models, *a, **k: compared.append(list(models)) or
                        real_compare(rec, models, *a, **k))
    assert main(["diagnose", null, *CHEAP, "--resume", "--out", str(out)]) == 0
    assert ["q1"] not in compared
    assert sorted(p.name for p in out.iterdir()) == ["diagnosis.json", "posteriors", "report.html"]
