"""bayesbeam compare and batch: outputs, refusals, and a resumable campaign on a Dask cluster."""
import csv
import json

import pytest

from bayesbeam.cli import main
from bayesbeam.io import write_recording
from tests.acceptance import cases as ac

CHEAP = ["--models", "air,q1", "--n-intervals", "6", "--repeats", "2", "--replicates", "10", "--quiet"]


@pytest.fixture(scope="module")
def recordings(tmp_path_factory):
    root = tmp_path_factory.mktemp("recs")
    paths = []
    for name, seed in (("hit_a", 3), ("hit_b", 4)):
        rec, _ = ac.hammer("q1", seed=seed, fs=256.0)                # tests.reference: 1 s at 256 Hz
        paths.append(write_recording(rec, root / name))
    return [str(p) for p in paths]


@pytest.mark.slow
def test_compare_writes_json_report_and_posteriors(recordings, tmp_path, capsys):
    import arviz as az

    out = tmp_path / "cmp"
    assert main(["compare", recordings[0], *CHEAP, "--executor", "serial", "--out", str(out)]) == 0
    summary = json.loads((out / "comparison.json").read_text())
    assert summary["best"] == "q1" and summary["ranking"] == ["q1", "air"]
    assert (out / "report.html").stat().st_size > 10000 and (out / "damping_per_mode.png").exists()
    idata = az.from_netcdf(out / "posteriors" / "q1.nc")
    assert idata.posterior.sizes["chain"] == 2 and "cdI" in idata.posterior
    captured = capsys.readouterr()
    assert "q1" in captured.out and "log Z" in captured.out
    assert captured.err == ""                    # --quiet: no notes, no bars


@pytest.mark.parametrize("argv, message", [
    (["--models", "q1,wet_towel"], "wet_towel"),
    (["--models", "air,q1", "--repeats", "1"], "at least 2"),
    (["--models", "q2", "--effect", "quadratic_drag"], "nonlinear effect cannot carry a memory mechanism"),
])
def test_bad_input_exits_2_naming_it(recordings, tmp_path, capsys, argv, message):
    assert main(["compare", recordings[0], *argv, "--out", str(tmp_path / "x")]) == 2
    assert message in capsys.readouterr().err


@pytest.mark.slow
def test_batch_on_a_dask_cluster_writes_one_table_and_resumes(recordings, tmp_path, capsys):
    import distributed  # a dependency of bayesbeam itself: missing fails, never skips
    out = tmp_path / "campaign"
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, dashboard_address=None) as cluster:
        argv = ["batch", *recordings, *CHEAP, "--executor", cluster.scheduler_address, "--out", str(out)]
        assert main(argv) == 0
        rows = list(csv.DictReader((out / "batch.csv").open()))
        assert len(rows) == 4 and {r["model"] for r in rows} == {"air", "q1"}
        assert all(r["best"] == str(r["model"] == "q1") for r in rows)
        first = (out / "hit_a" / "comparison.json").stat().st_mtime_ns
        table = json.loads((out / "batch.json").read_text())
        assert main(argv) == 2                                      # a written campaign is not rerun silently
        assert "--overwrite or --resume" in capsys.readouterr().err
        assert main([*argv, "--resume"]) == 0                       # again: everything is resumed
        assert (out / "hit_a" / "comparison.json").stat().st_mtime_ns == first
        assert json.loads((out / "batch.json").read_text()) == table


def test_compare_all_without_a_material_table_compares_the_rest_and_says_why(recordings, tmp_path, capsys):
    """`--models q1,thermoelastic` on a recording without [material] fits q1 and says, in the
    terminal, comparison.json and the report, that thermoelastic was left out and how to add the
    table (docs/format.md). plumbing: the reference recording only needs to load and fit cheaply."""
    out = tmp_path / "cmp"
    argv = ["compare", recordings[0], "--models", "q1,thermoelastic", *CHEAP[2:], "--executor", "serial"]
    assert main([*argv, "--out", str(out)]) == 0
    summary = json.loads((out / "comparison.json").read_text())
    assert summary["ranking"] == ["q1"] and list(summary["left_out"]) == ["thermoelastic"]
    why = summary["left_out"]["thermoelastic"]
    assert "no [material] table" in why and "docs/format.md" in why
    assert f"thermoelastic was left out: {why}" in capsys.readouterr().out
    assert "left out: thermoelastic" in (out / "report.html").read_text()
