"""How ``fit.prepare`` cuts the window into blocks: lengths whose FFT is fast, little left over."""
from pathlib import Path

import numpy as np
import pytest

from bayesbeam.inference.fit import FFT_RADICES, FitConfig, fast_length, prepare
from bayesbeam.io import load_recording

EXAMPLE = Path(__file__).resolve().parents[2] / "data" / "examples" / "paper_q3_hammer"


def _largest_prime_factor(n: int) -> int:
    p, largest = 2, 1
    while n > 1:
        while n % p == 0:
            n, largest = n // p, p
        p += 1
    return largest


@pytest.mark.parametrize("n", [256, 302, 479, 1511, 4099, 32749])
def test_fast_length_is_the_longest_smooth_length_not_above_n(n):
    """By brute force: no length between it and n has only the FFT's radices as prime factors."""
    m = fast_length(n)
    assert m <= n and _largest_prime_factor(m) <= max(FFT_RADICES)
    assert all(_largest_prime_factor(k) > max(FFT_RADICES) for k in range(m + 1, n + 1))


def test_at_most_four_percent_of_a_block_is_left_over():
    """The bound docs/inference.md states, over every block length the default can ask for (>= 256)."""
    n = np.arange(256, 20000)
    lost = (n - np.array([fast_length(int(k)) for k in n])) / n
    assert lost.max() < 0.04


def test_the_default_blocks_of_the_shipped_hammer_test_have_a_fast_length():
    """paper_q3_hammer at 150 Hz: 1511 samples in 5 blocks would be 302 = 2 x 151 each (an FFT by
    Bluestein's algorithm); the blocks are 300 long and leave 11 samples of the window's end."""
    problem = prepare(load_recording(EXAMPLE), "q1", FitConfig(max_frequency=150.0), 8)
    projection = problem.likelihood.projection
    assert (projection.n_blocks, projection.block) == (5, 300)
