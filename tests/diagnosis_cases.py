"""Cheap diagnoses shared by the diagnosis tests (computed once per pytest run).

The inference tests' cheap case (paper beam, 1 s at 512 Hz, N = 6, 2 % noise, q1 damping,
tests/inference/cases.py) with a concealed effect at the size docs/diagnosis.md validates the map
and the signatures on, diagnosed blind against q1 with 2 SMC repeats and 20 map replicates.
"""
from __future__ import annotations

from functools import cache

from bayesbeam.compare import CompareConfig
from bayesbeam.diagnose import DiagnoseConfig, diagnose
from bayesbeam.inference.fit import FitConfig
from tests.inference import cases

#: concealed effects and their true values (k_theta = 100 EI/l: mode 1 -1.9 %)
CONCEALED = {"root_compliance": {"k_theta": 100 * cases.EI_TRUE}, "measurement_delay": {"tau": 5e-4}}
CONFIG = DiagnoseConfig(CompareConfig(FitConfig(n_intervals=6), repeats=2, replicates=20), replicates=20)


def recording(effect: str | None, seed: int = 3):
    """The cheap q1 recording with ``effect`` concealed (None: no effect)."""
    params = {**cases.TRUTH["q1"], **CONCEALED.get(effect, {})}
    return cases.simulated("q1" + (f"+{effect}" if effect else ""), seed, params=params)[0]


@cache
def diagnosed(effect: str | None, seed: int = 3):
    """The Diagnosis of :func:`recording` against q1 (serial: the tests' processes are the cores)."""
    return diagnose(recording(effect, seed), "q1", CONFIG)
