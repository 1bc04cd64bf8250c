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


def blind_chain() -> str:
    """The blind diagnosis of paper_rootcomp_hammer step by step, from its diagnosis.json."""
    d = json.loads((HERE / "paper_rootcomp_hammer" / "diagnose" / "diagnosis.json").read_text())
    base, final = d["baseline"], d["final"]
    steps = [(f"compares the five default damping models (the table above again): {base['model']} wins, RMS "
              f"standardized residual {base['rms_standardized_residual']:.2f}, {base['flags']} flags;")]
    for round_ in sorted({c["round"] for c in d["candidates"]}):
        tried = [f"{c['effect']} ln B {c['delta_log_evidence']:.1f} "
                 f"({'added' if c['added'] or c.get('dropped') else 'refused'})"
                 for c in d["candidates"] if c["round"] == round_]
        left = [n["model"] for n in d["not_fitted"] if n["round"] == round_]
        steps.append(f"round {round_}: fitted {', '.join(tried)}"
                     + (f"; not fitted: {', '.join(left)} (a solve per frequency, `not_fitted`)" if left else "") + ";")
    recheck = d["damping_recheck"]
    if recheck:
        models = recheck["models"]
        previous = models[recheck["previous"]]["log_evidence"]
        others = ", ".join(f"{m} {models[m]['log_evidence'] - previous:+.1f}" for m in sorted(
            models, key=lambda m: -models[m]["log_evidence"]) if m != recheck["previous"])
        steps.append(f"**the damping re-check**, every default damping model with {' and '.join(recheck['effects'])}, "
                     f"in nats against {recheck['previous']}: {others}; "
                     + (f"switched to {recheck['best']};" if recheck["switched"] else "kept;")
                     + (f" not decisively behind {recheck['best']}: {', '.join(recheck['tied'])};"
                        if recheck.get("tied") else ""))
        for spec, v in recheck.get("pruning", {}).items():
            steps.append(f"without {v['without']} ({spec}): ln B of keeping it {v['log_bayes_factor']:.1f} nats, "
                         f"{'needed' if v['needed'] else 'not needed: dropped'};")
    steps.append(f"final model **{final['model']}**: RMS {final['rms_standardized_residual']:.2f}, {final['flags']} "
                 f"flags, {'a region unexplained' if d['unexplained'] else 'nothing unexplained'}, log Z "
                 f"{base['log_evidence']:.1f} -> {final['log_evidence']:.1f} (`seconds` {d['seconds']:.0f}).")
    return "\n".join(f"{i}. {step}" for i, step in enumerate(steps, 1))


def final_estimates() -> str:
    """The blind chain's final model's posterior against the example's truth."""
    from bayesbeam.model import resolve_model

    d = json.loads((HERE / "paper_rootcomp_hammer" / "diagnose" / "diagnosis.json").read_text())
    effects = [e.name for e in resolve_model(d["final"]["model"])[1]]
    return study.estimates_table(d["final"]["parameters"], effects,
                                 study.ROOT / "data" / "examples" / "paper_rootcomp_hammer")


def facts(name: str) -> str:
    """The ranking's head, the best model's checks and discretisation, and the run's time, in a
    sentence, from the example's comparison.json."""
    c = comparison(name)
    best, second = c["ranking"][:2]
    b = c["models"][best]
    check = b["discretisation_check"]
    p_values = [v["p_value"] for v in b["ppc"].values() if v["p_value"] is not None]
    return (f"{best} is ranked first, {-c['models'][second]['log_bayes_factor_vs_best']:.1f} nats ahead of "
            f"{second} (posterior probability {b['probability']:.2f}); its smallest posterior predictive p-value "
            f"is {min(p_values):.2g}; the discretisation check moves its optimum by {check['max_shift_sd']:.2g} "
            f"posterior sd from N = {check['n_intervals']} to {check['refined_n_intervals']} "
            f"({'passed' if check['passed'] else 'failed'}); `seconds` {c['seconds']:.0f} in comparison.json.")


def best_estimates(name: str) -> str:
    """The best model's posterior against the example's truth."""
    c = comparison(name)
    return study.estimates_table(c["models"][c["best"]]["posterior"], c["models"][c["best"]]["effects"],
                                 study.ROOT / "data" / "examples" / name)


def blocks() -> dict[Path, dict[str, str]]:
    from bayesbeam.report.comparison import ranking_markdown

    return {HERE / "README.md": {**{f"comparison-{name}": ranking_markdown(comparison(name)) for name in EXAMPLES},
                                 **{f"facts-{name}": facts(name) for name in EXAMPLES},
                                 **{f"estimates-{name}": best_estimates(name) for name in EXAMPLES[:2]},
                                 "blind-chain": blind_chain(), "blind-chain-estimates": final_estimates()},
            study.ROOT / "README.md": {"first-run": first_run()}}


if __name__ == "__main__":
    sys.exit(study.main(__doc__.splitlines()[0], COMMANDS, blocks))
