"""The real steel cantilever's free decay: run the comparisons and diagnoses, write the tables.

    OPENBLAS_NUM_THREADS=1 python studies/real_steel_cantilever/run.py [NAME ...]   # rerun, then the tables
    python studies/real_steel_cantilever/run.py --tables                           # only the tables

Every run is the ``bayesbeam`` command a user would type on
``data/real/ds4-cantilever-freedecay/recording``, on the free decay from 1.12 s to 5.12 s below
150 Hz. The tables of this folder's README come from ``compare/comparison.json`` (the damping
models alone) and ``compare_structure/comparison.json`` (each with a sensor mass and an axial
load standing in for the structural mismatch).
"""
from __future__ import annotations

import json
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))

import study  # the studies' shared runner, next to this folder

RECORDING = "data/real/ds4-cantilever-freedecay/recording"
OUT = "studies/real_steel_cantilever"
WINDOW = ["--start", "1.12", "--stop", "5.12", "--max-frequency", "150"]
COMMANDS = {
    "compare": ["compare", RECORDING, *WINDOW, "--overwrite", "--out", f"{OUT}/compare"],
    "diagnose_q1": ["diagnose", RECORDING, "--model", "q1", *WINDOW, "--n-intervals", "16", "--executor", "serial",
                    "--overwrite", "--out", f"{OUT}/diagnose_q1"],
    "compare_structure": ["compare", RECORDING, "--effect", "sensor_mass", "--effect", "axial_load", *WINDOW,
                          "--n-intervals", "16", "--overwrite", "--out", f"{OUT}/compare_structure"],
    "diagnose": ["diagnose", RECORDING, *WINDOW, "--n-intervals", "16", "--overwrite", "--out", f"{OUT}/diagnose"],
}
#: comparisons whose ranking table the README shows
COMPARISONS = ("compare", "compare_structure")


def blocks() -> dict[Path, dict[str, str]]:
    from bayesbeam.report.comparison import ranking_markdown

    return {HERE / "README.md": {f"real-steel-{name}": ranking_markdown(json.loads((HERE / name / "comparison.json")
                                                                                   .read_text()))
                                 for name in COMPARISONS}}


if __name__ == "__main__":
    sys.exit(study.main(__doc__.splitlines()[0], COMMANDS, blocks))
