"""The ``bayesbeam`` command line: thin argument parsing over the library.

One module per command, each with ``HELP``, ``add_arguments(parser)`` and ``run(args) -> int``;
adding a command adds its module and one line to :data:`COMMANDS`.

Exit status: 0 on success, 2 for bad input (a message naming the file, key or value and the fix),
3 when sampling stopped before its chains converged.
"""
from __future__ import annotations

import argparse
import importlib
import sys

from bayesbeam import __version__
from bayesbeam.cli.common import EXIT_BAD_INPUT, UsageError
from bayesbeam.io import RecordingError

#: command name -> module under bayesbeam.cli
COMMANDS = {
    "simulate": "simulate",
    "fit": "fit",
    "compare": "compare",
    "diagnose": "diagnose",
    "batch": "batch",
    "ema": "ema",
    "era": "era",
    "import-uff": "import_uff",
}


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="bayesbeam", description=__doc__.splitlines()[0])
    parser.add_argument("--version", action="version", version=f"bayesbeam {__version__}")
    sub = parser.add_subparsers(dest="command", required=True)
    for name, module_name in COMMANDS.items():
        module = importlib.import_module(f"bayesbeam.cli.{module_name}")
        command = sub.add_parser(name, help=module.HELP, description=module.HELP)
        module.add_arguments(command)
        command.set_defaults(func=module.run)
    return parser


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    try:
        return args.func(args)
    except (RecordingError, UsageError, ValueError, FileExistsError) as exc:
        print(f"bayesbeam {args.command}: error: {exc}", file=sys.stderr)
        return EXIT_BAD_INPUT
