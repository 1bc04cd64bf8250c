"""Model comparison on the shipped examples: run the comparisons and write the tables.

    OPENBLAS_NUM_THREADS=1 python studies/model_comparison/run.py [NAME ...]   # rerun, then the tables
    python studies/model_comparison/run.py --tables                           # only the tables

Each comparison is the ``bayesbeam compare`` command a user would type (seed 1, three SMC
repeats per model, the default predictive replicates); the blind chain of paper_rootcomp_hammer
is ``bayesbeam diagnose`` without ``--model``. The tables of this folder's README come from each
``comparison.json``, and the README's first-run block from paper_q3_hammer's, printed by the
same code as ``bayesbeam compare`` prints it.
"""
from __future__ import annotations

import json
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))

import study  # the studies' shared runner, next to this folder

OUT = "studies/model_comparison"
BAND = ["--max-frequency", "150"]
COMMANDS = {
    "paper_q3_hammer": ["compare", "data/examples/paper_q3_hammer", *BAND, "--overwrite",
                        "--out", f"{OUT}/paper_q3_hammer"],
    "alu_q1_release": ["compare", "data/examples/alu_q1_release", *BAND, "--overwrite",
                       "--out", f"{OUT}/alu_q1_release"],
    "paper_rootcomp_hammer": ["compare", "data/examples/paper_rootcomp_hammer", *BAND, "--overwrite",
                              "--out", f"{OUT}/paper_rootcomp_hammer"],
    "paper_rootcomp_hammer_diagnose": ["diagnose", "data/examples/paper_rootcomp_hammer", *BAND, "--overwrite",
                                       "--out", f"{OUT}/paper_rootcomp_hammer/diagnose"],
}
#: examples whose ranking table the README shows, in its order
EXAMPLES = ("paper_q3_hammer", "alu_q1_release", "paper_rootcomp_hammer")


def comparison(name: str) -> dict:
    return json.loads((HERE / name / "comparison.json").read_text())


def first_run() -> str:
    """What ``bayesbeam compare data/examples/paper_q3_hammer --max-frequency 150`` prints, from
    the committed comparison.json: the ranking and the verdict."""
    from bayesbeam.cli.compare import format_ranking

    return "```text\n" + format_ranking(comparison("paper_q3_hammer")) + "\n```"


def blocks() -> dict[Path, dict[str, str]]:
    from bayesbeam.report.comparison import ranking_markdown

    return {HERE / "README.md": {f"comparison-{name}": ranking_markdown(comparison(name)) for name in EXAMPLES},
            study.ROOT / "README.md": {"first-run": first_run()}}


if __name__ == "__main__":
    sys.exit(study.main(__doc__.splitlines()[0], COMMANDS, blocks))
