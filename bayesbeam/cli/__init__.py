"""The ``bayesbeam`` command line: which damping mechanism is in a cantilever beam, from a recording.

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
from bayesbeam.cli.common import EXIT_BAD_INPUT, HelpFormatter, UsageError
from bayesbeam.io import RecordingError

DESCRIPTION = """\
Which damping mechanism is in this beam? From a recording of a cantilever (hammer impact, release
or free decay: beam.toml + recording.csv), bayesbeam ranks damping models by Bayesian evidence and
predictive checks (compare), samples one model's parameters (fit), and locates and names physics
the best model misses (diagnose). Parameters use the paper's names in SI units."""

EXAMPLES = """\
examples:
  # which damping model explains this hammer test? (ranks q1, q2, q3, air, strain_rate)
  bayesbeam compare data/examples/paper_q3_hammer --max-frequency 150 --out out/compare

  # what does the best model miss? locate the misfit, name the effect, fit it
  bayesbeam diagnose data/examples/paper_rootcomp_hammer --model q1 --max-frequency 150 --out out/diagnose

  # the posterior of q1 with a rotational spring at the clamp (bayesbeam models lists the effects)
  bayesbeam fit data/examples/paper_rootcomp_hammer --model q1 --effect root_compliance --max-frequency 150 \\
      --out out/fit

Each command's options and their defaults: bayesbeam COMMAND --help."""

#: command name -> module under bayesbeam.cli
COMMANDS = {
    "check": "check",
    "simulate": "simulate",
    "fit": "fit",
    "compare": "compare",
    "diagnose": "diagnose",
    "batch": "batch",
    "ema": "ema",
    "era": "era",
    "import": "import_",
    "models": "models",
}


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="bayesbeam", description=DESCRIPTION, epilog=EXAMPLES,
                                     formatter_class=HelpFormatter)
    parser.add_argument("--version", action="version", version=f"bayesbeam {__version__}")
    sub = parser.add_subparsers(dest="command", required=True)
    for name, module_name in COMMANDS.items():
        module = importlib.import_module(f"bayesbeam.cli.{module_name}")
        command = sub.add_parser(name, help=module.HELP, description=module.HELP, formatter_class=HelpFormatter)
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
