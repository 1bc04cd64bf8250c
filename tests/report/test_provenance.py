"""Provenance of output JSON: the bayesbeam version and the git commit of the checkout.

The commit is checked against git itself, run separately in a throw-away repository laid out
like a checkout of the package (a ``bayesbeam`` folder at its top level), so the expected value
is not computed by the code under test. Everything is exact string equality: there is no
tolerance to choose.
"""
import json
import subprocess

import pytest

import bayesbeam
from bayesbeam.io import provenance as prov
from bayesbeam.report.compare_outputs import write_json as write_json_of_reports


def git(directory, *args) -> str:
    return subprocess.run(["git", "-C", str(directory), "-c", "user.name=test", "-c", "user.email=test@example.org",
                           *args], capture_output=True, text=True, check=True).stdout.strip()


@pytest.fixture
def checkout(tmp_path):
    """A one-commit repository with a package folder at its top level; (top, package folder)."""
    top = tmp_path / "clone"
    package = top / "bayesbeam"
    package.mkdir(parents=True)
    (package / "__init__.py").write_text("x = 1\n")
    git(top, "init", "-q")
    git(top, "add", ".")
    git(top, "commit", "-q", "-m", "one")
    return top, package


def test_commit_of_a_clean_checkout_is_git_head(checkout):
    top, package = checkout
    assert prov.git_commit(package) == git(top, "rev-parse", "HEAD")


def test_changed_tracked_file_marks_the_commit_dirty_but_an_untracked_output_does_not(checkout):
    top, package = checkout
    (top / "comparison.json").write_text("{}\n")                  # a run's own output, untracked
    assert prov.git_commit(package) == git(top, "rev-parse", "HEAD")
    (package / "__init__.py").write_text("x = 2\n")
    assert prov.git_commit(package) == git(top, "rev-parse", "HEAD") + "-dirty"


def test_not_a_checkout_gives_none(tmp_path, checkout):
    lone = tmp_path / "site-packages" / "bayesbeam"
    lone.mkdir(parents=True)
    assert prov.git_commit(lone) is None
    # installed inside some other project's repository: that repository's commit is not ours
    top, _ = checkout
    nested = top / "venv" / "site-packages" / "bayesbeam"
    nested.mkdir(parents=True)
    assert prov.git_commit(nested) is None


def test_without_git_the_commit_is_none_and_nothing_fails(checkout, monkeypatch):
    _, package = checkout
    monkeypatch.setenv("PATH", "")
    assert prov.git_commit(package) is None


def test_every_json_output_carries_version_and_commit(tmp_path):
    """The writer the reports, the CLI and the modal outputs share appends the provenance and
    leaves the caller's document unchanged; the commit is this checkout's (or None outside one)."""
    document = {"best": "q3", "seconds": 1.5}
    path = write_json_of_reports(document, tmp_path / "comparison.json")
    written = json.loads(path.read_text())
    assert written == {**document, "provenance": {"bayesbeam_version": bayesbeam.__version__,
                                                  "git_commit": prov.git_commit()}}
    assert "provenance" not in document
    assert [p.name for p in tmp_path.iterdir()] == ["comparison.json"]     # no temporary file left


def test_a_non_object_document_is_refused_by_name(tmp_path):
    with pytest.raises(TypeError, match="rows.json"):
        prov.write_json([1, 2], tmp_path / "rows.json")
