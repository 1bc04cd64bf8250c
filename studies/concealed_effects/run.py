"""Run ``bayesbeam diagnose`` blind on every recording of the study and tabulate the results.

    OPENBLAS_NUM_THREADS=1 python studies/concealed_effects/run.py            # resume: skips done ones
    OPENBLAS_NUM_THREADS=1 python studies/concealed_effects/run.py --tables   # only rebuild results.md's tables

Each recording (``recordings/<beam>_<effect>/``, made by ``generate.py``) is diagnosed by exactly
the command a user would type, told only the damping model that generated it, never the effect:

    bayesbeam diagnose recordings/<name> --model <q1|q3> --max-frequency 150 --executor serial
                       --out out/<name>

The second set's (``recordings/ref_*``, made by ``generate_reference.py``) is told neither: it
chooses its baseline from q1 and q3 and re-checks the damping with what it adds
(``--models q1,q3`` in place of ``--model``).

Recordings run two at a time (one per core). The tables of ``results.md`` (its marker blocks,
:mod:`bayesbeam.report.markdown`) are written from the diagnosis.json files and each recording's
truth.json, so every number in them can be rebuilt.
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

HERE = Path(__file__).resolve().parent
RECORDINGS, OUT = HERE / "recordings", HERE / "out"
#: top of the fitted band: modes 1-4 of the paper beam, 1-3 of the aluminium strip
MAX_FREQUENCY = 150.0

#: recordings of the second set (generate_reference.py): physics around the beam, made by tests.reference
REFERENCE_PREFIX = "ref_"
#: the damping models the second set's diagnoses choose from and re-check (the truth is q1)
RECHECK_MODELS = "q1,q3"


def command(name: str, truth: dict) -> list[str]:
    models = ["--models", RECHECK_MODELS] if name.startswith(REFERENCE_PREFIX) else ["--model", truth["damping_model"]]
    return ["diagnose", str(RECORDINGS / name), *models, "--max-frequency", str(MAX_FREQUENCY), "--executor",
            "serial", "--quiet", "--overwrite", "--out", str(OUT / name)]


def damping(model: str) -> str:
    """The damping part of a model's name ('q1+attachment' -> 'q1')."""
    from bayesbeam.physics.effects import REGISTRY

    return "+".join(part for part in model.split("+") if part not in REGISTRY)


def run_one(name: str) -> tuple[str, float, int]:
    """Diagnose one recording in this process; (name, seconds, exit status)."""
    import contextlib
    import io

    from bayesbeam.cli import main

    truth = json.loads((RECORDINGS / name / "truth.json").read_text())
    started = time.perf_counter()
    try:
        with contextlib.redirect_stdout(io.StringIO()):
            status = main(command(name, truth))
    except Exception as exc:  # noqa: BLE001 - one failed recording must not stop the study: say which and why
        print(f"{name}: {type(exc).__name__}: {exc}", file=sys.stderr, flush=True)
        status = 1
    return name, time.perf_counter() - started, status


def pending(force: bool) -> list[str]:
    names = sorted(p.name for p in RECORDINGS.iterdir() if (p / "truth.json").exists())
    return [n for n in names if force or not (OUT / n / "diagnosis.json").exists()]


# ---------------------------------------------------------------------------- tables
def rows() -> list[dict]:
    """One row per diagnosed recording: truth, what was found, estimates, evidence, residuals. A
    recording may conceal several effects (a clamp's spring and dashpot), each of several parameters."""
    out = []
    for truth_path in sorted(RECORDINGS.glob("*/truth.json")):
        name = truth_path.parent.name
        result = OUT / name / "diagnosis.json"
        if not result.exists():
            continue
        truth, d = json.loads(truth_path.read_text()), json.loads(result.read_text())
        effects = truth["effect"].split("+") if truth["effect"] else []
        added = [c for c in d["candidates"] if c["added"] and c["effect"] in effects]
        # the final model's posterior where it holds the parameter: an effect added in round 1 is
        # refitted beside a partner added later (a root spring beside the root dashpot)
        final = d["final"]["parameters"]
        fitted = {p: final.get(p, q) for c in added for p, q in c["parameters"].items()}
        estimates = {p: fitted.get(p) for p in truth["effect_parameters"]}
        out.append({"name": name, "beam": truth["beam"], "model": truth["damping_model"], "effect": truth["effect"],
                    "effects": effects, "truth": truth["effect_parameters"], "added": d["added"],
                    "named": sorted(d["added"]) == sorted(effects), "estimates": estimates,
                    "covered": bool(added) and all(q is None or q["q05"] <= truth["effect_parameters"][p] <= q["q95"]
                                                   for p, q in estimates.items()),
                    "lnB": [(c["effect"], c["delta_log_evidence"], c["delta_log_evidence_sd"]) for c in added],
                    "tried": [(c["effect"], c["delta_log_evidence"]) for c in d["candidates"]],
                    "refused": [c for c in d["candidates"] if not c["added"]],
                    "rms": (d["baseline"]["rms_standardized_residual"], d["final"]["rms_standardized_residual"]),
                    "flags": (d["baseline"]["flags"], d["final"]["flags"]), "unexplained": d["unexplained"],
                    "damping": (damping(d["baseline"]["model"]), damping(d["final"]["model"])),
                    "seconds": d["seconds"]})
    return out


def _estimate(q: dict | None) -> str:
    return f"{q['mean']:.4g} [{q['q05']:.4g}, {q['q95']:.4g}] {q['unit']}" if q else "-"


def effect_table(found: list[dict]) -> str:
    head = ("| recording | effect (truth) | added | estimate, mean [90 %] | truth inside | ln B (sd) | "
            "RMS std. residual before -> after | flags before -> after | damping (truth): first -> final | s |\n|"
            + "---|" * 10)
    lines = [head]
    for r in found:
        truth = "; ".join(f"{p} = {v:.4g}" for p, v in r["truth"].items())
        est = "; ".join(f"{p} {_estimate(q)}" if len(r["estimates"]) > 1 else _estimate(q)
                        for p, q in r["estimates"].items())
        lnb = "; ".join(f"{b:.1f} ({sd:.1f})" for _, b, sd in r["lnB"]) or "-"
        lines.append(f"| {r['name']} | {r['effect']} {truth} | {', '.join(r['added']) or 'nothing'} | {est} | "
                     f"{'yes' if r['covered'] else 'NO'} | {lnb} | {r['rms'][0]:.2f} -> {r['rms'][1]:.2f} | "
                     f"{r['flags'][0]} -> {r['flags'][1]} | {_damping(r)} | {r['seconds']:.0f} |")
    return "\n".join(lines)


def _damping(r: dict) -> str:
    """The damping model the diagnosis started from and ended with, and the truth's."""
    return f"({r['model']}) {r['damping'][0]} -> {r['damping'][1]}"


def null_table(nulls: list[dict]) -> str:
    lines = [("| recording | added | candidates tried (ln B) | RMS std. residual | flags | unexplained | "
              "damping (truth): first -> final | s |"), "|" + "---|" * 8]
    for r in nulls:
        tried = ", ".join(f"{e} ({b:.1f})" for e, b in r["tried"]) or "none (nothing flagged)"
        lines.append(f"| {r['name']} | {', '.join(r['added']) or 'nothing'} | {tried} | {r['rms'][0]:.2f} | "
                     f"{r['flags'][0]} | {r['unexplained']} | {_damping(r)} | {r['seconds']:.0f} |")
    return "\n".join(lines)


def refused_table(all_rows: list[dict]) -> str:
    """Every candidate fitted and not added, with the two conditions of the decision rule."""
    lines = ["| recording | candidate | ln B (sd) | decisive | map improved | RMS std. residual | flags |",
             "|" + "---|" * 7]
    for r in all_rows:
        for c in r["refused"]:
            lines.append(f"| {r['name']} | {c['effect']} | {c['delta_log_evidence']:.1f} "
                         f"({c['delta_log_evidence_sd']:.1f}) | {'yes' if c['decisive'] else 'no'} | "
                         f"{'yes' if c['map_improved'] else 'no'} | {c['rms_standardized_residual']:.2f} | "
                         f"{c['flags']} |")
    return "\n".join(lines)


RESULTS = HERE / "results.md"


def blocks() -> dict[Path, dict[str, str]]:
    """The generated blocks of results.md, from out/*/diagnosis.json and recordings/*/truth.json:
    the catalogue set's (``concealed-*``) and the reference set's (``reference-*``)."""
    all_rows = rows()
    sets = {"concealed": [r for r in all_rows if not r["name"].startswith(REFERENCE_PREFIX)],
            "reference": [r for r in all_rows if r["name"].startswith(REFERENCE_PREFIX)]}
    out = {}
    for key, chosen in sets.items():
        found = [r for r in chosen if r["effect"]]
        nulls = [r for r in chosen if not r["effect"]]
        named = sum(r["named"] for r in found)
        covered = sum(r["covered"] for r in found)
        alarms = sum(bool(r["added"]) for r in nulls)
        right = sum(r["damping"][1] == r["model"] for r in chosen)
        out |= {f"{key}-score": (f"**Named correctly (exactly the concealed effects added): {named} of {len(found)}. "
                                 f"Truth inside the 90 % interval: {covered} of {len(found)}. "
                                 f"False alarms (an effect added to a null recording): {alarms} of {len(nulls)}. "
                                 f"Final damping model the truth's: {right} of {len(chosen)}.**"),
                f"{key}-effects": effect_table(found), f"{key}-nulls": null_table(nulls),
                f"{key}-refused": refused_table(chosen)}
    return {RESULTS: out}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--force", action="store_true", help="rerun recordings already diagnosed")
    parser.add_argument("--tables", action="store_true", help="only rebuild results.md's tables (no diagnosis)")
    parser.add_argument("--processes", type=int, default=2, help="recordings diagnosed at once (default 2)")
    parser.add_argument("names", nargs="*", help="only these recordings")
    args = parser.parse_args(argv)
    if not args.tables:
        todo = pending(args.force)
        todo = [n for n in args.names if n in todo] if args.names else todo      # in the order given
        print(f"diagnosing {len(todo)} recording(s): {', '.join(todo)}", flush=True)
        with ProcessPoolExecutor(args.processes) as pool:
            for name, seconds, status in pool.map(run_one, todo):
                print(f"{name}: exit {status}, {seconds:.0f} s", flush=True)
    from bayesbeam.report.markdown import write_files

    print(f"wrote {', '.join(str(p) for p in write_files(blocks()))}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
