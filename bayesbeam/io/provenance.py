"""Provenance of output files: the bayesbeam version and the git commit an output was made with.

Every JSON document bayesbeam writes goes through :func:`write_json`, which appends
``"provenance": {"bayesbeam_version": ..., "git_commit": ...}``. ``git_commit`` is the commit of
the checkout the package was imported from, with ``-dirty`` when tracked files differ from it
(untracked files do not count: a run's own outputs are untracked until committed), and ``null``
when the package is not a git checkout (an installed wheel) or git is absent.
"""
from __future__ import annotations

import json
import shutil
import subprocess
from functools import lru_cache
from pathlib import Path

from bayesbeam.io.atomic import write_text

#: the package's own directory (``.../bayesbeam``)
PACKAGE_DIR = Path(__file__).resolve().parents[1]
#: git calls give up after this long (s): provenance must never stall or fail a run
GIT_TIMEOUT = 10.0


def git_commit(package_dir: Path = PACKAGE_DIR) -> str | None:
    """``git rev-parse HEAD`` of the checkout whose top level holds ``package_dir``, ``-dirty``
    appended when tracked files have changes; None when that is not a checkout or git fails."""
    package_dir = Path(package_dir).resolve()
    top = _git(package_dir, "rev-parse", "--show-toplevel")
    # a package installed inside some other repository (a virtualenv in a project) is not a checkout of itself
    if top is None or Path(top).resolve() / package_dir.name != package_dir:
        return None
    head = _git(package_dir, "rev-parse", "HEAD")
    changes = _git(package_dir, "status", "--porcelain", "--untracked-files=no")
    if head is None or changes is None:
        return None
    return head + ("-dirty" if changes else "")


def _git(directory: Path, *args: str) -> str | None:
    """stdout of ``git -C directory args`` stripped, or None when git is absent or fails."""
    git = shutil.which("git")
    if git is None:
        return None
    try:
        done = subprocess.run([git, "-C", str(directory), *args], capture_output=True, text=True,
                              timeout=GIT_TIMEOUT, check=False)
    except (OSError, subprocess.SubprocessError):
        return None
    return done.stdout.strip() if done.returncode == 0 else None


@lru_cache(maxsize=1)
def provenance() -> dict:
    """``{"bayesbeam_version", "git_commit"}`` of this process, looked up once: a run that writes
    several files into the checkout records the state it started from in all of them."""
    from bayesbeam import __version__

    return {"bayesbeam_version": __version__, "git_commit": git_commit()}


def write_json(document: dict, path) -> Path:
    """Write ``document`` plus its ``provenance`` to ``path`` as indented JSON, atomically.

    numpy scalars are written as Python numbers; ``document`` itself is not changed.
    """
    if not isinstance(document, dict):
        raise TypeError(f"{path}: a JSON output must be an object (dict) to carry its provenance, "
                        f"not {type(document).__name__}")
    return write_text(path, json.dumps({**document, "provenance": provenance()}, indent=2, default=_jsonable) + "\n")


def _jsonable(value):
    if hasattr(value, "item"):
        return value.item()
    raise TypeError(f"cannot write {type(value).__name__} to JSON")
