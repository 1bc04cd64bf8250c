"""What the studies' scripts share: run their ``bayesbeam`` commands, then render their tables.

A study script lists the commands that produce its committed outputs (``COMMANDS``: name ->
arguments of the ``bayesbeam`` command line) and renders the tables of its markdown from those
outputs (``blocks()``: {markdown file: {block name: body}}, :mod:`bayesbeam.report.markdown`).
``--tables`` renders without running anything; a test re-renders every block from the committed
JSON and fails when the markdown has drifted. ``--resume`` continues diagnoses that were killed
part-way (``bayesbeam diagnose --resume``).
"""
from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
# Run as a plain script from a checkout: import the bayesbeam next to the studies.
sys.path.insert(0, str(ROOT))


def main(description: str, commands: dict[str, list[str]], blocks, argv=None) -> int:
    """Run the named (default: all) ``commands``, then write ``blocks()``; ``--tables``: only write."""
    parser = argparse.ArgumentParser(description=description)
    parser.add_argument("--tables", action="store_true", help="only re-render the tables from the committed outputs")
    parser.add_argument("--resume", action="store_true",
                        help="continue killed diagnoses: diagnose commands run with --resume instead of --overwrite")
    parser.add_argument("names", nargs="*", metavar="NAME", help=f"run only these ({', '.join(commands)}; default: all)")
    args = parser.parse_args(argv)
    unknown = [n for n in args.names if n not in commands]
    if unknown:
        parser.error(f"unknown name(s) {', '.join(unknown)}: choose from {', '.join(commands)}")
    if not args.tables:
        for name in args.names or list(commands):
            status = run(resumed(commands[name]) if args.resume else commands[name])
            if status != 0:
                print(f"{name}: bayesbeam exited with status {status}; tables not written", file=sys.stderr)
                return status
    from bayesbeam.report.markdown import write_files

    for path in write_files(blocks()):
        print(f"wrote {path.relative_to(ROOT)}")
    return 0


def resumed(arguments: list[str]) -> list[str]:
    """A diagnose command's ``arguments`` with ``--resume`` for ``--overwrite`` (the others as they are):
    it continues from the steps its killed run saved in its --out folder."""
    if arguments[0] != "diagnose":
        return arguments
    return ["--resume" if word == "--overwrite" else word for word in arguments]


def run(arguments: list[str]) -> int:
    """``bayesbeam ARGUMENTS`` in this process, from the repository's top (the paths are relative to it)."""
    import os

    from bayesbeam.cli import main as bayesbeam

    print("bayesbeam " + " ".join(arguments), flush=True)
    here = os.getcwd()
    started = time.perf_counter()
    try:
        os.chdir(ROOT)
        return bayesbeam(arguments)
    finally:
        os.chdir(here)
        print(f"({time.perf_counter() - started:.0f} s)", flush=True)


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


def estimates_table(quantities: dict, effects, recording: Path) -> str:
    """Markdown table of posterior summaries (name -> q05, q50, q95, unit), with the truth and
    whether the 90 % interval holds it when ``recording`` is a simulated example. ``effects``:
    the fitted model's effect names (their parameters' truths are stored under them)."""
    from bayesbeam.physics.effects import resolve
    from bayesbeam.report.markdown import markdown_table, median_and_interval, significant

    truth = truth_values(recording)
    owners = {p: e.name for e in resolve(effects) for p in e.parameters}
    rows = []
    for parameter, q in quantities.items():
        row = [f"{parameter} ({q['unit']})" if q["unit"] else parameter, median_and_interval(q)]
        if truth is not None:
            value = parameter_truth(parameter, truth, owners)
            row += ["n/a", "n/a"] if value is None else [significant(value, 5),
                                                         "yes" if q["q05"] <= value <= q["q95"] else "no"]
        rows.append(row)
    head = ["parameter", "posterior median [90% interval]"] + (["truth", "truth inside"] if truth is not None else [])
    return markdown_table(head, rows)
