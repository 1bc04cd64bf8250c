"""Shared fixtures of the inference tests: cheap simulated recordings (see cases.py)."""
import pytest

from tests.inference import cases


@pytest.fixture(scope="session")
def air_case():
    """(recording, noise sd): model "air" on the paper's beam, N = 6, 2 % noise, seed 7."""
    return cases.simulated("air", seed=7)
