"""studies/study.py, the studies' shared runner: what --resume changes in the commands it runs."""
import importlib.util
from pathlib import Path

STUDY = Path(__file__).resolve().parents[2] / "studies" / "study.py"


def _runner():
    spec = importlib.util.spec_from_file_location("study", STUDY)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_resume_continues_diagnoses_and_leaves_the_other_commands_alone():
    study = _runner()
    diagnose = ["diagnose", "rec", "--model", "q1", "--overwrite", "--out", "out/diagnose"]
    compare = ["compare", "rec", "--overwrite", "--out", "out/compare"]
    assert study.resumed(diagnose) == ["diagnose", "rec", "--model", "q1", "--resume", "--out", "out/diagnose"]
    assert study.resumed(compare) == compare
