"""Time hysteresis: the kernel, its transform limits, and admissibility."""
import numpy as np
import pytest
from scipy import integrate

from bayesbeam.physics.mechanisms.time_hysteresis import (TimeHysteresis, memory_kernel,
                                                          relaxation_transform, static_relaxation)


def test_static_relaxation_is_the_kernel_integral():
    # substitute sigma = u^2 to remove the 1/sqrt(sigma) singularity: d sigma = 2u du
    for r in (0.05, 1.0, np.inf):
        ref, _ = integrate.quad(lambda u: memory_kernel(u * u, 2.0, 30.0, r) * 2 * u, 0,
                                np.sqrt(min(r, 50.0)), epsabs=0, epsrel=1e-12)
        assert np.isclose(static_relaxation(2.0, 30.0, r), ref, rtol=1e-9)


def test_transform_large_r_tends_to_infinite_memory():
    s = np.array([0.5 + 20j, 3 + 700j])
    np.testing.assert_allclose(relaxation_transform(s, 1.0, 5.0, 50.0),
                               relaxation_transform(s, 1.0, 5.0, np.inf), rtol=1e-12)


def test_memory_dissipates_energy():
    """Im G(i w) < 0 for w > 0: the memory moment lags the curvature (positive loss)."""
    w = np.logspace(-1, 4, 50)
    g = relaxation_transform(1j * w, 0.8, 12.0, np.inf)
    assert np.all(g.imag < 0)


def test_default_memory_is_infinite():
    assert TimeHysteresis().defaults == {"r": np.inf}


def test_refuses_non_positive_memory_length():
    with pytest.raises(ValueError, match="r"):
        TimeHysteresis().check({"alpha": 1.0, "beta": 1.0, "r": 0.0})
