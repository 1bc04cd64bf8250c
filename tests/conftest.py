"""The test dependencies declared in pyproject.toml's ``test`` extra are required, not optional:
a test that checks our code against a peer, or uses a tool, must run or fail, never skip silently.
"""
import importlib.util

import pytest

#: module -> the distribution that provides it (pyproject.toml, [project.optional-dependencies] test)
REQUIRED = {"dynesty": "dynesty", "pyyeti": "pyyeti", "sdypy.EMA": "sdypy-EMA", "mpmath": "mpmath",
            "distributed": "distributed", "hypothesis": "hypothesis"}


def _installed(module: str) -> bool:
    try:
        return importlib.util.find_spec(module) is not None
    except ModuleNotFoundError:  # the parent package (sdypy) is missing
        return False


def pytest_configure(config):
    missing = sorted(dist for module, dist in REQUIRED.items() if not _installed(module))
    if missing:
        raise pytest.UsageError(f"test dependencies missing: {', '.join(missing)}. "
                                f"Fix: pip install -e '.[test]' (they are the test extra in pyproject.toml)")
