"""What the commands share: exit codes, input errors, ``--set`` parsing, and the options every
command spells and means the same way (output folder, executor, processes, effects, force window)."""
from __future__ import annotations

import argparse
import os
from pathlib import Path

EXIT_BAD_INPUT = 2
#: a fit that stopped at --max-steps before its chains converged
EXIT_NOT_CONVERGED = 3
#: the seed of everything random when --seed is not given (FitConfig's and CompareConfig's default)
DEFAULT_SEED = 1
EXECUTOR_HELP = ("where the work runs: 'serial' (this process), 'local' (--processes worker processes), 'mpi' "
                 "(the ranks of an mpiexec launch, needs mpi4py) or a Dask scheduler address tcp://HOST:PORT")
OVERWRITE_FILES_HELP = "write into a non-empty OUT, replacing the files this command writes (other files stay)"
OVERWRITE_FOLDER_HELP = "replace a non-empty OUT by the new recording (everything in it is removed)"


class UsageError(ValueError):
    """Bad command-line input, reported without a traceback."""


class HelpFormatter(argparse.ArgumentDefaultsHelpFormatter, argparse.RawDescriptionHelpFormatter):
    """Every option's help ends with its default, unless the help states it already (options whose
    default is computed say so in words) or the option is an on/off switch."""

    def _get_help_string(self, action):
        text = action.help or ""
        unset = action.default is None or action.default is False or action.default is argparse.SUPPRESS
        if "default" in text or unset or not action.option_strings:
            return text
        return f"{text} (default: %(default)s)"


def parse_assignments(items: list[str]) -> dict[str, float]:
    """``["EI=44", "gamma=0.09"]`` -> ``{"EI": 44.0, "gamma": 0.09}``."""
    out = {}
    for item in items or []:
        key, sep, value = item.partition("=")
        if not sep or not key.strip():
            raise UsageError(f"--set {item!r}: expected NAME=VALUE, e.g. --set EI=44.0")
        try:
            out[key.strip()] = float(value)
        except ValueError:
            raise UsageError(f"--set {item!r}: {value!r} is not a number") from None
    return out


def positive_int(text: str) -> int:
    """argparse type: an integer of at least 1."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not an integer") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"{value}: must be at least 1")
    return value


# ---------------------------------------------------------------------------- output folder
def add_out_options(p, contents: str, *, resume: str | None = None, recording: bool = False) -> None:
    """``--out DIR`` (required) and ``--overwrite``; ``--resume`` (help ``resume``) where the command
    continues earlier work in OUT. ``recording``: OUT is a recording folder, replaced as a whole."""
    p.add_argument("--out", required=True, metavar="DIR", help=f"output directory ({contents})")
    group = p.add_mutually_exclusive_group()
    group.add_argument("--overwrite", action="store_true",
                       help=OVERWRITE_FOLDER_HELP if recording else OVERWRITE_FILES_HELP)
    if resume:
        group.add_argument("--resume", action="store_true", help=resume)


def output_folder(args) -> Path:
    """``args.out``, refused (UsageError naming it and the fix) when it is a file, or a non-empty
    folder without ``--overwrite`` (or ``--resume``, where the command has it)."""
    out = Path(args.out)
    if out.exists() and not out.is_dir():
        raise UsageError(f"--out {out}: is a file, not a directory. Fix: choose a directory path.")
    resumable = hasattr(args, "resume")
    if out.is_dir() and not (args.overwrite or getattr(args, "resume", False)):
        entries = sorted(p.name for p in out.iterdir())
        if entries:
            shown = ", ".join(entries[:3]) + (", ..." if len(entries) > 3 else "")
            raise UsageError(f"--out {out}: the directory is not empty ({shown}). Fix: choose a new directory, "
                             f"or pass --overwrite{' or --resume' if resumable else ''}.")
    return out


# ---------------------------------------------------------------------------- where the work runs
def executor_value(text: str) -> str:
    """argparse type of ``--executor``: serial, local, mpi or a Dask scheduler address."""
    from bayesbeam.executors import DASK_SCHEMES, NAMED

    if text in NAMED or text.startswith(DASK_SCHEMES):
        return text
    raise argparse.ArgumentTypeError(f"{text!r}: expected serial, local, mpi or a Dask scheduler address "
                                     "such as tcp://host:8786")


def add_run_options(p) -> None:
    """``--executor``, ``--processes`` and ``--quiet``: where and how visibly the work runs."""
    p.add_argument("--executor", type=executor_value, default="local",
                   metavar="{serial,local,mpi,tcp://HOST:PORT}", help=EXECUTOR_HELP)
    p.add_argument("--processes", type=positive_int, metavar="N",
                   help=f"local worker processes (default: all cores, {os.cpu_count()} here)")
    p.add_argument("--quiet", action="store_true", help="no progress bars or notes on stderr")


def job_executor(args):
    """The executor of ``args.executor``/``args.processes`` for independent jobs (compare, batch,
    diagnose); ValueError naming the fix when it cannot be had (e.g. mpi without mpi4py)."""
    from bayesbeam.executors import get_executor

    return get_executor(args.executor, args.processes)


def add_seed_option(p) -> None:
    """``--seed``: unset means :data:`DEFAULT_SEED`, or a ``--config`` file's seed where one is read."""
    p.add_argument("--seed", type=int, help=f"random seed (default: {DEFAULT_SEED})")


# ---------------------------------------------------------------------------- the model
def add_effect_option(p) -> None:
    """``--effect NAME`` (repeatable): effects from the catalogue, joined to every model fitted."""
    from bayesbeam.physics.effects import REGISTRY

    p.add_argument("--effect", action="append", choices=sorted(REGISTRY), metavar="NAME",
                   help=f"add a missing-physics effect to the model(s), repeatable: {', '.join(sorted(REGISTRY))} "
                        "(parameters and priors: bayesbeam models; default: none)")


def add_models_option(p, default: str | None) -> None:
    """``--models``: damping models by name or named set (compare's list; diagnose's comparisons)."""
    p.add_argument("--models", default=default,
                   help="comma-separated presets or '+'-joined mechanisms (bayesbeam models lists them), or a "
                        "named set: paper (the default), literature, all")


def add_force_window_option(p) -> None:
    p.add_argument("--no-force-window", action="store_true",
                   help="use the whole force channel of a force recording, not only the impact force window")


def model_spec(spec: str, effects, option: str = "--model") -> str:
    """``spec`` with the ``--effect`` names joined in, checked (UsageError naming ``option``)."""
    from bayesbeam.model import join_model

    full = join_model(spec, effects or ())
    check_model(full, option)
    return full


def check_model(spec: str, option: str) -> None:
    """UsageError naming ``option`` unless ``spec`` names known mechanisms and effects that go together."""
    from bayesbeam.diagnosis import combinable
    from bayesbeam.model import resolve_model

    try:
        resolve_model(spec)
    except ValueError as exc:
        raise UsageError(f"{option} {spec}: {exc}") from None
    if not combinable(spec):
        raise UsageError(f"{option} {spec}: a nonlinear effect cannot carry a memory mechanism (the nonlinear "
                         "integrator needs a state-space model). Fix: leave that model out, or the effect.")
