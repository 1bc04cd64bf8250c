"""What the studies' scripts share: run their ``bayesbeam`` commands, then render their tables.

A study script lists the commands that produce its committed outputs (``COMMANDS``: name ->
arguments of the ``bayesbeam`` command line) and renders the tables of its markdown from those
outputs (``blocks()``: {markdown file: {block name: body}}, :mod:`bayesbeam.report.markdown`).
``--tables`` renders without running anything; a test re-renders every block from the committed
JSON and fails when the markdown has drifted.
"""
from __future__ import annotations

import argparse
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
    parser.add_argument("names", nargs="*", metavar="NAME", help=f"run only these ({', '.join(commands)}; default: all)")
    args = parser.parse_args(argv)
    unknown = [n for n in args.names if n not in commands]
    if unknown:
        parser.error(f"unknown name(s) {', '.join(unknown)}: choose from {', '.join(commands)}")
    if not args.tables:
        for name in args.names or list(commands):
            status = run(commands[name])
            if status != 0:
                print(f"{name}: bayesbeam exited with status {status}; tables not written", file=sys.stderr)
                return status
    from bayesbeam.report.markdown import write_files

    for path in write_files(blocks()):
        print(f"wrote {path.relative_to(ROOT)}")
    return 0


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
