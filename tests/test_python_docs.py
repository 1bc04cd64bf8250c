"""docs/python.md's code blocks run, in order, in one namespace, as written: in a temporary folder
whose data/ is the repository's (so the files they write land there)."""
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).parents[1]
DOC = ROOT / "docs" / "python.md"


def blocks() -> list[str]:
    return re.findall(r"```python\n(.*?)```", DOC.read_text(), re.DOTALL)


def test_the_tutorial_has_its_steps():
    """check, compare, load and diagnose each appear in a block (the test below runs them)."""
    code = "\n".join(blocks())
    for call in ("bayesbeam.check(", "bayesbeam.compare(", "bayesbeam.load(", "bayesbeam.diagnose("):
        assert call in code, call


@pytest.mark.slow  # a two-model comparison and a diagnosis of the shipped examples
def test_the_tutorial_runs(tmp_path, monkeypatch, capsys):
    (tmp_path / "data").symlink_to(ROOT / "data")
    monkeypatch.chdir(tmp_path)
    namespace = {}
    for i, block in enumerate(blocks()):
        exec(compile(block, f"{DOC}:block {i + 1}", "exec"), namespace)  # noqa: S102 (the documented code, run as written)
    assert namespace["comparison"].best == "q3"
    assert (tmp_path / "docs_q3_compare" / "comparison.json").is_file()
    assert (tmp_path / "docs_q3_corner.png").is_file()
    assert "root_compliance" in namespace["diagnosis"].best
    assert "N s/m^2" in capsys.readouterr().out
