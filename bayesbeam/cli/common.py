"""Helpers shared by the commands: input errors, exit codes, ``--set`` parsing, executors."""
from __future__ import annotations

EXIT_BAD_INPUT = 2
#: a fit that stopped at --max-steps before its chains converged
EXIT_NOT_CONVERGED = 3


class UsageError(ValueError):
    """Bad command-line input, reported without a traceback."""


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
