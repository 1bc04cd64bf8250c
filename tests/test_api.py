"""The Python interface (``bayesbeam.api``, importable from ``bayesbeam``): options parsed as the
command line parses them, result objects, ``.write`` writing what the command writes, ``load``
reopening it. Plumbing on a cheap reference recording (1 s at 256 Hz, N = 6, two SMC repeats):
what the comparison finds is tested elsewhere (tests/acceptance)."""
import json
from pathlib import Path

import matplotlib.pyplot as plt
import pytest

import bayesbeam
from bayesbeam.api import UNWRITTEN, options
from bayesbeam.cli import build_parser, main
from bayesbeam.io import write_recording
from tests.acceptance import cases as ac

CHEAP = {"models": ["air", "q1"], "n_intervals": 6, "repeats": 2, "replicates": 10, "executor": "serial"}
CHEAP_ARGV = ["--models", "air,q1", "--n-intervals", "6", "--repeats", "2", "--replicates", "10", "--executor", "serial"]


@pytest.fixture(scope="module")
def recording(tmp_path_factory):
    rec, _ = ac.hammer("q1", seed=3, fs=256.0)
    return str(write_recording(rec, tmp_path_factory.mktemp("recs") / "hit"))


def _cli_namespace(argv):
    args = vars(build_parser().parse_args(argv))
    return {k: v for k, v in args.items() if k not in ("func", "command")}


@pytest.mark.parametrize("command", ["fit", "compare", "diagnose"])
def test_defaults_are_the_command_lines(recording, command):
    """Every option's default is the command's: one parser defines both."""
    assert vars(options(command, recording)) == _cli_namespace([command, recording, "--out", UNWRITTEN])


def test_keywords_are_the_flags(recording):
    """Keyword names are the flags' (dashes as underscores), lists join with commas, a repeatable
    option takes a list or one value, a switch takes True, progress=False is --quiet."""
    got = options("compare", recording, max_frequency=150, models=["q1", "air"], effect="root_compliance",
                  no_force_noise=True, progress=False, seed=7)
    want = _cli_namespace(["compare", recording, "--max-frequency", "150", "--models", "q1,air", "--effect",
                           "root_compliance", "--no-force-noise", "--quiet", "--seed", "7", "--out", UNWRITTEN])
    assert vars(got) == want
    assert options("fit", recording, effect=["root_compliance", "sensor_mass"]).effect == ["root_compliance", "sensor_mass"]


def test_unknown_and_bad_options_raise_instead_of_exiting(recording):
    with pytest.raises(TypeError, match="no option 'max_freq'.*max_frequency"):
        options("compare", recording, max_freq=150)
    with pytest.raises(ValueError, match="--particles.*must be at least 1"):
        options("compare", recording, particles=0)
    with pytest.raises(ValueError, match="wet_towel"):
        bayesbeam.compare(recording, models=["q1", "wet_towel"])


def test_the_package_exports_the_functions_and_keeps_its_modules():
    """bayesbeam.compare and bayesbeam.diagnose are the functions; the modules that do the work are
    bayesbeam.comparison and bayesbeam.diagnosis, and importing them does not rebind the names."""
    from bayesbeam import comparison, diagnosis

    assert callable(bayesbeam.compare) and callable(bayesbeam.diagnose) and callable(bayesbeam.fit)
    assert hasattr(comparison, "CompareConfig") and hasattr(diagnosis, "DiagnoseConfig")
    assert callable(bayesbeam.compare) and bayesbeam.compare is not comparison


def test_check_summary_write_and_load(recording, tmp_path):
    found = bayesbeam.check(recording)
    table = found.summary()
    assert list(table.index) == ["accel_tip"] and table.loc["accel_tip", "unit"] == "m/s^2"
    written = found.write(tmp_path / "check")
    assert sorted(p.name for p in written) == ["check.json", "quicklook.png"]
    assert bayesbeam.load(tmp_path / "check").summary().equals(table)
    assert "accel_tip" in found.report()
    plt.close(found.plot_quicklook())


@pytest.fixture(scope="module")
def comparison(recording):
    return bayesbeam.compare(recording, progress=False, **CHEAP)


@pytest.mark.slow
def test_comparison_object(comparison):
    assert comparison.best == "q1"
    table = comparison.summary()
    assert list(table.index) == ["q1", "air"] and "ln B vs best (nats)" in table.columns
    assert table.loc["q1", "ln B vs best (nats)"] == 0.0
    params = comparison.parameters()
    assert params.loc["EI", "unit"] == "N m^2" and params.loc["sigma_accel_tip", "unit"] == "m/s^2"
    posterior = comparison.idata["q1"].posterior
    assert posterior["cdI"].attrs["units"] == "N m^2 s" and "strain_rate" in posterior["cdI"].attrs["description"]
    assert posterior["sigma_accel_tip"].attrs["units"] == "m/s^2"
    corner = comparison.plot_corner()
    assert [t.get_text() for t in corner.legends[0].get_texts()] == ["q1", "air"]
    plt.close(corner)
    plt.close(comparison.plot_damping_per_mode())


@pytest.mark.slow
def test_write_is_what_the_command_writes_and_load_reopens_it(comparison, recording, tmp_path):
    """Same seed, serial: the command's comparison.json holds the same ranking and evidences."""
    api_files = comparison.write(tmp_path / "api")
    assert main(["compare", recording, *CHEAP_ARGV, "--quiet", "--out", str(tmp_path / "cli")]) == 0
    listing = sorted(p.relative_to(tmp_path / "cli").as_posix() for p in (tmp_path / "cli").rglob("*") if p.is_file())
    assert sorted(p.relative_to(tmp_path / "api").as_posix() for p in api_files) == listing
    api_json, cli_json = (json.loads((tmp_path / d / "comparison.json").read_text()) for d in ("api", "cli"))
    assert api_json["ranking"] == cli_json["ranking"]
    for m in api_json["ranking"]:
        assert api_json["models"][m]["log_evidence"] == cli_json["models"][m]["log_evidence"]
    reopened = bayesbeam.load(tmp_path / "api")
    assert reopened.best == comparison.best and reopened.summary().equals(comparison.summary())
    assert reopened.idata["q1"].posterior["EI"].attrs["units"] == "N m^2"
    plt.close(reopened.plot_corner(["q1"]))
    with pytest.raises(ValueError, match="Fix"):
        reopened.write(tmp_path / "again")
    with pytest.raises(ValueError, match="not empty"):
        comparison.write(tmp_path / "api")


@pytest.mark.slow
def test_fit_object(recording, tmp_path):
    result = bayesbeam.fit(recording, model="air", n_intervals=6, walkers=8, max_steps=60, progress=False,
                           executor="serial")
    table = result.summary()
    assert list(table.index) == ["EI", "gamma", "sigma_accel_tip"] and table.loc["gamma", "unit"] == "N s/m^2"
    assert result.idata.posterior["gamma"].attrs["units"] == "N s/m^2"
    names = sorted(p.name for p in result.write(tmp_path / "fit"))
    assert names == ["corner.png", "fit.png", "posterior.nc", "summary.json", "trace.png"]
    reopened = bayesbeam.load(tmp_path / "fit")
    assert reopened.summary().equals(table)
    plt.close(reopened.plot_corner())
    with pytest.raises(ValueError, match="reopened"):
        reopened.plot_trace()


ROOT = Path(__file__).parents[1]
#: a diagnosis the model-comparison study wrote (its posteriors are committed: see .gitignore)
DIAGNOSIS = ROOT / "studies/model_comparison/paper_rootcomp_hammer/diagnose"


def test_a_diagnosis_folder_reopens():
    """load() of a diagnosis folder: best, a row per model fitted with its verdicts, the final
    parameters with units, the posteriors; the map needs the live run and says so."""
    summary = json.loads((DIAGNOSIS / "diagnosis.json").read_text())
    reopened = bayesbeam.load(DIAGNOSIS)
    assert reopened.best == summary["final"]["model"] and reopened.unexplained == summary["unexplained"]
    table = reopened.summary()
    assert table.iloc[0]["role"] == "baseline" and table.iloc[-1]["role"] == "final"
    assert len(table) == len(summary["candidates"]) + 2
    assert list(table["added"].dropna()) == [c["added"] for c in summary["candidates"]]
    assert reopened.parameters().loc["EI", "unit"] == "N m^2"
    assert summary["baseline"]["model"] in reopened.idata
    with pytest.raises(ValueError, match="report.html"):
        reopened.plot_mismatch()


def test_a_reopened_diagnosis_names_its_stand_ins():
    """The stand-in column: each candidate's verdict as fitted in its round, and the final row's
    effects that are stand-ins in the final model (the real-steel diagnosis: a body tuned inside
    mode 1's band, and a sensor mass past what the set-up allows)."""
    folder = ROOT / "studies/real_steel_cantilever/diagnose"
    summary = json.loads((folder / "diagnosis.json").read_text())
    table = bayesbeam.load(folder).summary()
    candidates = table.iloc[1:-1]["stand-in"]
    assert [cell.startswith("yes: ") for cell in candidates] == [c["stand_in"] is not None for c in summary["candidates"]]
    assert any(cell.startswith("yes: f_a (posterior median) lies within beam mode 1") for cell in candidates)
    final = table.iloc[-1]["stand-in"].split("; ")
    assert [cell.split(":")[0] for cell in final] == [v["label"] for v in summary["final_stand_ins"].values()]
    assert sorted(summary["final_stand_ins"]) == ["attachment", "sensor_mass"]
    assert "m_s (posterior median) lies outside the 0.002358 to 0.01427 kg the set-up allows" in table.iloc[-1]["stand-in"]
    assert bayesbeam.load(DIAGNOSIS).summary().iloc[-1]["stand-in"] == "no"


#: folders with a summary.json of a study's own, not a fit's
STUDY_SUMMARIES = [ROOT / "studies/paper_reproduction"]


def output_folders() -> list[Path]:
    """Every folder under studies/ and data/ that holds what check, fit, compare or diagnose write."""
    names = ("comparison.json", "diagnosis.json", "summary.json", "check.json")
    found = {p.parent for root in ("studies", "data") for n in names for p in (ROOT / root).rglob(n)}
    return sorted(found - set(STUDY_SUMMARIES))


@pytest.mark.parametrize("folder", output_folders(), ids=lambda f: str(f.relative_to(ROOT)))
def test_every_committed_output_folder_reopens(folder):
    """A user reopens any committed study output with bayesbeam.load: its tables must build from the
    JSON the present code reads (a folder written by an older version fails here until rerun)."""
    reopened = bayesbeam.load(folder)
    assert len(reopened.summary()) > 0
    if hasattr(reopened, "parameters"):
        assert "unit" in reopened.parameters().columns


def test_a_fit_folder_without_its_posterior_draws_reopens(tmp_path):
    """A fit's large posterior.nc is often left out of a repository (studies/fit_examples/real_steel_q1):
    its summary still reopens, and the corner plot says what it needs."""
    source = ROOT / "studies/fit_examples/paper_q3_hammer"
    (tmp_path / "summary.json").write_text((source / "summary.json").read_text())
    reopened = bayesbeam.load(tmp_path)
    assert reopened.summary().equals(bayesbeam.load(source).summary()) and reopened.idata is None
    with pytest.raises(ValueError, match=r"posterior\.nc.*Fix"):
        reopened.plot_corner()


def test_load_refuses_a_summary_json_that_is_not_a_fits():
    with pytest.raises(ValueError, match="not written by bayesbeam fit.*Fix"):
        bayesbeam.load(STUDY_SUMMARIES[0])


def test_load_refuses_a_folder_that_is_not_an_output(tmp_path):
    with pytest.raises(ValueError, match="no diagnosis.json.*Fix"):
        bayesbeam.load(tmp_path)
