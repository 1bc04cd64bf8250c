"""The test dependencies declared in pyproject.toml's ``test`` extra are required, not optional:
a test that checks our code against a peer, or uses a tool, must run or fail, never skip silently.
"""
import importlib.util

import pytest

#: module -> the distribution that provides it (pyproject.toml, [project.optional-dependencies] test)
REQUIRED = {"dynesty": "dynesty", "pyyeti": "pyyeti", "sdypy.EMA": "sdypy-EMA", "mpmath": "mpmath",
            "distributed": "distributed", "hypothesis": "hypothesis", "nbclient": "nbclient",
            "nbformat": "nbformat", "ipykernel": "ipykernel"}


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
    # keep the order of pytest_collection_modifyitems below: pytest-xdist's --dist loadfile would
    # otherwise hand out the modules with the most tests first
    if hasattr(config.option, "loadscopereorder"):
        config.option.loadscopereorder = False
    gone = [path for path in SLOWEST_FIRST if not (config.rootpath / path).is_file()]
    if gone:
        raise pytest.UsageError(f"tests/conftest.py: SLOWEST_FIRST names {', '.join(gone)}, which no longer "
                                f"exist. Fix: rename or remove them there")


#: the modules whose fits take minutes, slowest first (each one's total on 2 cores under
#: ``-n auto --dist loadfile``, from ``--durations=0``: in the default run, then in the long tier
#: ``-m long``; a dash where the module has no test in that run). xdist hands whole modules to the
#: workers in collection order as they free up: starting the longest first keeps one worker from
#: running a long module alone at the end (longest-processing-time-first scheduling). A module of
#: one run only may sit anywhere among the other run's
SLOWEST_FIRST = (                                     # default  long
    "tests/acceptance/test_compare.py",               #   -      445 s
    "tests/acceptance/test_sensor_order.py",          #  <1 s    295 s
    "tests/checks/test_signatures.py",                # 205 s     -
    "tests/test_python_docs.py",                      # 190 s     -
    "tests/acceptance/test_diagnose.py",              #  40 s    265 s
    "tests/test_diagnosis.py",                        #  15 s    245 s
    "tests/acceptance/test_calibration.py",           #  <1 s    170 s
    "tests/acceptance/test_literature.py",            #   -      160 s
    "tests/studies/test_first_run.py",                # 130 s     -
    "tests/test_resume.py",                           #  80 s     -
    "tests/inference/test_evidence.py",               #  60 s     80 s
    "tests/report/test_diagnosis_report.py",          #  55 s     -
    "tests/acceptance/test_fit.py",                   #   -       45 s
)


def pytest_collection_modifyitems(items):
    """The modules of :data:`SLOWEST_FIRST` first, in its order; the rest as collected. A test of
    the long tier must be marked slow too, so that the fast subset (-m "not slow") leaves it out."""
    unmarked = [item.nodeid for item in items if item.get_closest_marker("long") and not item.get_closest_marker("slow")]
    if unmarked:
        raise pytest.UsageError(f"marked long but not slow: {', '.join(unmarked)}. Fix: mark them slow as well")
    rank = {path: i for i, path in enumerate(SLOWEST_FIRST)}
    items.sort(key=lambda item: rank.get(item.nodeid.split("::")[0], len(rank)))
