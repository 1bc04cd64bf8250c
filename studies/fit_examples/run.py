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


def truth_values(recording: Path) -> dict | None:
    """The true parameter values of a simulated example (its truth.json), None for a real record.

    EI, the damping parameters and each concealed effect's value; an effect's value is stored
    under the effect's name, so it is returned under that name (``parameter_truth`` maps it).
    """
    path = recording / "truth.json"
    if not path.exists():
        return None
    truth = json.loads(path.read_text())
    return {"EI": truth["beam_true"]["EI"], **truth["damping"], **truth.get("effect_parameters", {})}


def parameter_truth(name: str, truth: dict, effect_parameters: dict[str, str]) -> float | None:
    """The true value of parameter ``name``: by its own name, or by its effect's (k_theta -> root_compliance)."""
    if name in truth:
        return truth[name]
    return truth.get(effect_parameters.get(name))


def table(name: str) -> str:
    from bayesbeam.physics.effects import resolve
    from bayesbeam.report.markdown import markdown_table, median_and_interval, significant

    summary = json.loads((HERE / name / "summary.json").read_text())
    truth = truth_values(study.ROOT / COMMANDS[name][1])
    # summary["effects"] lists every effect of the fitted model, whether --effect or --model named it
    effects = {p: e.name for e in resolve(summary["effects"]) for p in e.parameters}
    quantities = {**summary["parameters"], **{k: v for k, v in summary["noise"].items() if k.startswith("sigma_")}}
    rows = []
    for parameter, q in quantities.items():
        row = [f"{parameter} ({q['unit']})" if q["unit"] else parameter, median_and_interval(q)]
        if truth is not None:
            value = parameter_truth(parameter, truth, effects)
            row += ["n/a", "n/a"] if value is None else [significant(value, 5),
                                                         "yes" if q["q05"] <= value <= q["q95"] else "no"]
        rows.append(row)
    head = ["parameter", "posterior median [90% interval]"] + (["truth", "truth inside"] if truth is not None else [])
    return markdown_table(head, rows)


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
