"""studies/notebook/reopen_a_diagnosis.ipynb runs from top to bottom in a fresh kernel (nbclient),
in its own folder as a user opens it, and shows what it says it shows."""
from pathlib import Path

import nbclient
import nbformat

NOTEBOOK = Path(__file__).resolve().parents[2] / "studies" / "notebook" / "reopen_a_diagnosis.ipynb"


def _text(cell) -> str:
    return "".join(str(o.get("text", "")) + str(o.get("data", {}).get("text/plain", "")) for o in cell.outputs)


def test_the_notebook_runs_and_shows_the_diagnosis():
    """Every cell runs (nbclient raises on the first error); the diagnosis cell names the final
    model the committed diagnosis.json holds, the parameter table has k_theta in N m/rad, and the
    two plot cells each draw a figure."""
    import json

    notebook = nbformat.read(NOTEBOOK, as_version=4)
    nbclient.NotebookClient(notebook, timeout=120, kernel_name="python3",
                            resources={"metadata": {"path": str(NOTEBOOK.parent)}}).execute()
    cells = [c for c in notebook.cells if c.cell_type == "code"]
    summary = json.loads((NOTEBOOK.parents[1] / "model_comparison/paper_rootcomp_hammer/diagnose/diagnosis.json").read_text())
    assert any(_text(c).startswith(summary["final"]["model"] + " | unexplained") for c in cells)
    assert any("k_theta" in _text(c) and "N m/rad" in _text(c) for c in cells)
    figures = [c for c in cells if any("image/png" in o.get("data", {}) for o in c.outputs)]
    assert len(figures) >= 3
