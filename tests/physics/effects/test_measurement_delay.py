"""measurement_delay: a band-limited fractional delay, a pure phase e^{-i omega tau}."""
import numpy as np
import pytest

from bayesbeam import BeamModel
from tests.physics.effects.helpers import PAPER_EI, recording

FS = 1024.0


def harmonic_model(freq: float):
    """Heavy air damping, gamma = 40 N s/m^2: every mode is underdamped (mode 1 at zeta = 0.85) and
    decays at gamma/(2 rho A) = 19.6/s, so the start-up transient is below 1e-10 of the response
    after 1.2 s and the response is the steady harmonic one."""
    def force(t):
        return np.sin(2 * np.pi * freq * t)
    rec = recording(fs=FS, duration=2.5, force=force, sensors=((1.0, "acceleration"), (0.6, "displacement")))
    return rec, BeamModel(rec, "air", 12, effects="measurement_delay", force_window=False)


@pytest.mark.parametrize("freq, tau_samples", [(31.0, 0.37), (180.0, 2.61), (333.0, 0.5)])
def test_harmonic_response_is_delayed_by_a_pure_phase(freq, tau_samples):
    """Interior of the record against Re[H(i w) e^{-i w tau} e^{i w t}], H solved here directly.

    Tolerance 1e-7 of the amplitude: the transient (below 1e-10) and the band-limit edge effects
    of a sine switched on at 0 and off at the end (confined to ~100 samples at each end,
    excluded) are the only differences; the frequency lies in the passband (W = 1 - O(1e-10)).
    """
    rec, model = harmonic_model(freq)
    gamma, tau = 40.0, tau_samples / FS
    y = model.simulate({"EI": PAPER_EI, "gamma": gamma, "tau": tau})
    system = model.system({"EI": PAPER_EI, "gamma": gamma, "tau": tau})
    w = 2 * np.pi * freq
    x = np.linalg.solve(-w**2 * system.M + 1j * w * system.D + system.K, model.load)  # no library H
    gain = (model.rows @ x) * (1j * w) ** model.orders
    t = rec.time
    expect = (gain[None, :] * np.exp(1j * w * (t[:, None] - tau))).imag   # force = Im e^{i w t}
    inner = (t > 1.2) & (t < t[-1] - 0.15)
    scale = np.abs(gain)[None, :]
    assert np.max(np.abs(y[inner] - expect[inner]) / scale) < 1e-7


def test_whole_sample_delay_is_a_shift():
    """tau = 3 dt: y_tau[n] = y_0[n - 3] to 1.5e-8 of the peak.

    On the FFT grid a whole-sample phase is a circular shift and the exponential window cancels
    exactly; what remains is the solver's wrap-around floor e^-18 = 1.5e-8 (its docstring),
    seen in the last samples of a record that ends while the beam still rings.
    """
    rec = recording(fs=FS, duration=1.0)
    model = BeamModel(rec, "q1", 12, effects="measurement_delay")
    p = {"EI": PAPER_EI, "gamma": 0.2, "cdI": 1e-4}
    y0 = model.simulate({**p, "tau": 0.0})
    y3 = model.simulate({**p, "tau": 3 / FS})
    assert np.max(np.abs(y3[3:] - y0[:-3])) < 1.5e-8 * np.max(np.abs(y0))


def test_the_force_channel_is_not_delayed():
    """The delay acts on the responses only: it does not change the model's input."""
    rec = recording(fs=FS, duration=0.5)
    model = BeamModel(rec, "air", 8, effects="measurement_delay")
    assert model.delay({"EI": PAPER_EI, "gamma": 0.1, "tau": 2e-3}) == 2e-3
    np.testing.assert_array_equal(model.force, BeamModel(rec, "air", 8).force)
