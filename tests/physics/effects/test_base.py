"""The effects' shared pieces: the octave grid of the low_rank form's reference beams."""
import numpy as np

from bayesbeam.physics.effects import REGISTRY
from bayesbeam.physics.effects.base import octave


def test_octave_is_the_nearest_power_of_two_on_a_log_scale():
    x = np.geomspace(1e-6, 1e8, 999)
    grid = np.array([octave(v) for v in x])
    assert np.all(np.log2(grid) == np.round(np.log2(grid)))            # powers of two
    assert np.all(np.abs(np.log2(x / grid)) <= 0.5)                     # within a factor sqrt(2)
    assert octave(0.0) == 0.0 and octave(-1.0) == 0.0


def test_each_linear_effect_names_a_finite_reference():
    """The reference beam must exist: finite values, a root spring's per unit EI, a sensor mass's
    zero at zero (where the effect vanishes)."""
    values = {"EI": 40.0, "k_theta": 4000.0, "m_s": 0.0, "P": 3.0, "tau": 1e-4}
    assert REGISTRY["root_compliance"].reference(values) == {"k_theta": 128.0}    # 100 -> 2^7
    assert REGISTRY["sensor_mass"].reference(values) == {"m_s": 0.0}
    assert REGISTRY["sensor_mass"].reference({**values, "m_s": 0.011}) == {"m_s": 2.0 ** -7}
    for name in ("axial_load", "measurement_delay"):
        assert all(np.isfinite(v) for v in REGISTRY[name].reference(values).values())
