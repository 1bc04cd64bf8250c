"""bayesbeam diagnose: its outputs on disk, what it prints, and its refusals."""
import json

import pytest

from bayesbeam.cli import main
from bayesbeam.io import write_recording
from tests.diagnosis_cases import recording

CHEAP = ["--model", "q1", "--n-intervals", "6", "--repeats", "2", "--replicates", "10", "--map-replicates", "20",
         "--executor", "serial", "--quiet"]


@pytest.fixture(scope="module")
def delayed(tmp_path_factory):
    """The cheap recording with a 0.5 ms delay concealed, as a recording directory."""
    return str(write_recording(recording("measurement_delay"), tmp_path_factory.mktemp("recs") / "delayed"))


def test_diagnose_writes_json_report_and_posteriors(delayed, tmp_path, capsys):
    import arviz as az

    out = tmp_path / "diag"
    assert main(["diagnose", delayed, *CHEAP, "--out", str(out)]) == 0
    summary = json.loads((out / "diagnosis.json").read_text())
    assert summary["added"] == ["measurement_delay"] and summary["final"]["model"] == "q1+measurement_delay"
    assert summary["recording"].endswith("delayed")
    assert (out / "report.html").stat().st_size > 10000
    assert sorted(p.name for p in out.iterdir()) == ["diagnosis.json", "posteriors", "report.html"]
    idata = az.from_netcdf(out / "posteriors" / "q1_plus_measurement_delay.nc")
    assert "tau" in idata.posterior
    assert (out / "posteriors" / "q1.nc").exists()
    printed = capsys.readouterr().out
    assert "added: measurement_delay" in printed and "Missing physics found: measurement_delay" in printed


@pytest.mark.parametrize("argv, message", [
    (["--model", "q1+wet_towel"], "--model q1+wet_towel"),
    (["--model", "q1", "--rounds", "0"], "--rounds = 0"),
    (["--model", "q1", "--repeats", "1"], "at least 2"),
])
def test_bad_input_exits_2_naming_it(delayed, tmp_path, capsys, argv, message):
    assert main(["diagnose", delayed, *argv, "--out", str(tmp_path / "x")]) == 2
    assert message in capsys.readouterr().err
    assert not (tmp_path / "x").exists()
