r"""The measurement chain's AC coupling: a first-order high-pass of every response channel.

An IEPE accelerometer's built-in amplifier has a discharge time constant (typically 0.5-5 s), and a
DAQ's AC coupling blocks the channel's DC bias with a series capacitor: both make the recorded
response the motion through :math:`H(s) = s / (s + 2\pi f_{hp})`, f_hp in Hz. Two such stages in
series act above their corners like one at the sum of the corners (phase lead
:math:`(f_1 + f_2)/f`), which is the one f_hp fitted. Every mode of frequency f is seen with the
gain :math:`f / \sqrt{f^2 + f_{hp}^2}` and the phase lead :math:`\arctan(f_{hp}/f)`: the effect
lives at the lowest mode.

The force channel is not filtered. An impact hammer's load cell is IEPE too, but its pulse lasts
about a millisecond, some thousand times shorter than the coupling's time constant, so the pulse
passes with a relative error of order f_hp x the pulse length (1e-4 to 1e-3); a quasi-static force
gauge is DC coupled (a strain-gauge or charge amplifier in its long time-constant setting).

A free decay is the filter's response, from rest at ``start``, to the modes switched on there
(:meth:`~bayesbeam.physics.effects.base.Effect.channel_poles`): each mode :math:`e^{p t}` becomes
:math:`H(p) e^{p t} + \frac{2\pi f_{hp}}{p + 2\pi f_{hp}} e^{-2\pi f_{hp} t}`, the filter's own
pole carrying what the mode's step at ``start`` charged it with.
"""
from __future__ import annotations

from typing import ClassVar

import numpy as np

from bayesbeam.physics.effects.base import Effect


class HighPass(Effect):
    name = "high_pass"
    parameters = ("f_hp",)
    absent: ClassVar[dict[str, float]] = {"f_hp": 0.0}
    units: ClassVar[dict[str, str]] = {"f_hp": "Hz"}
    description = ("every response channel passes the sensor's and DAQ's AC coupling, a first-order high-pass "
                   "s/(s + 2 pi f_hp); the force channel does not")

    def channel_response(self, values, s):
        corner = _corner(values)
        if corner == 0:
            return None
        s = np.asarray(s, dtype=complex)
        return (s / (s + corner))[:, None]

    def channel_poles(self, values):
        corner = _corner(values)
        return np.array([-corner]), np.array([-corner])


def _corner(values) -> float:
    """The corner 2 pi f_hp (rad/s)."""
    return 2 * np.pi * values["f_hp"]
