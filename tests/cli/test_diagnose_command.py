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
