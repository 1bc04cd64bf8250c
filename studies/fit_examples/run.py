"""Posteriors of the shipped examples and the real record: run the fits and write the tables.

    OPENBLAS_NUM_THREADS=1 python studies/fit_examples/run.py [NAME ...]   # rerun, then the tables
    python studies/fit_examples/run.py --tables                           # only the tables

Each fit is the ``bayesbeam fit`` command a user would type. The tables of this folder's README
come from each ``summary.json`` and, for the simulated examples, the example's ``truth.json``.
"""
from __future__ import annotations

import json
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))

import study  # the studies' shared runner, next to this folder

OUT = "studies/fit_examples"
COMMANDS = {
    "alu_q1_release": ["fit", "data/examples/alu_q1_release", "--model", "q1", "--stop", "1.5", "--max-frequency",
                       "100", "--max-steps", "8000", "--overwrite", "--out", f"{OUT}/alu_q1_release"],
    "paper_q3_hammer": ["fit", "data/examples/paper_q3_hammer", "--model", "q3", "--max-frequency", "150",
                        "--overwrite", "--out", f"{OUT}/paper_q3_hammer"],
    "paper_rootcomp_hammer": ["fit", "data/examples/paper_rootcomp_hammer", "--model", "q1", "--effect",
                              "root_compliance", "--max-frequency", "150", "--overwrite",
                              "--out", f"{OUT}/paper_rootcomp_hammer"],
    "real_steel_q1": ["fit", "data/real/ds4-cantilever-freedecay/recording", "--model", "q1", "--start", "1.12",
                      "--stop", "5.12", "--max-frequency", "150", "--overwrite", "--out", f"{OUT}/real_steel_q1"],
}


def table(name: str) -> str:
    summary = json.loads((HERE / name / "summary.json").read_text())
    quantities = {**summary["parameters"], **{k: v for k, v in summary["noise"].items() if k.startswith("sigma_")}}
    # summary["effects"] lists every effect of the fitted model, whether --effect or --model named it
    return study.estimates_table(quantities, summary["effects"], study.ROOT / COMMANDS[name][1])


def run_facts(name: str) -> str:
    """The discretisation and the chains of one fit in a sentence, from its summary.json."""
    summary = json.loads((HERE / name / "summary.json").read_text())
    check, run = summary["discretisation_check"], summary["convergence"]
    degree = {3: "cubic", 5: "quintic"}.get(check.get("degree"), f"degree {check.get('degree')}")
    verdict = ("" if check["passed"] else
               f", above the {check['tolerance_sd']:g} tolerance, and the summary says so")
    chains = (f"converged (longer than 50 tau = {50 * summary['tau']:.0f} steps, tau stable)" if summary["converged"]
              else f"not converged ({run['reason']})")
    ess = [q["ess"] for q in summary["parameters"].values()]
    r_hat = max(q["r_hat"] for q in summary["parameters"].values())
    return (f"N = {check['n_intervals']} {degree} spline intervals, chosen automatically (the check against "
            f"N = {check['refined_n_intervals']} moves the optimum by {check['max_shift_sd']:.2g} posterior "
            f"sd{verdict}); {run['n_walkers']} walkers, {run['n_steps']} steps, {chains}, ESS "
            f"{min(ess):.0f}-{max(ess):.0f}, R-hat at most {r_hat:.3f} (`convergence.seconds` {run['seconds']:.0f}).")


def blocks() -> dict[Path, dict[str, str]]:
    return {HERE / "README.md": {**{f"fit-{name}": table(name) for name in COMMANDS},
                                 **{f"facts-{name}": run_facts(name) for name in COMMANDS}}}


if __name__ == "__main__":
    sys.exit(study.main(__doc__.splitlines()[0], COMMANDS, blocks))
