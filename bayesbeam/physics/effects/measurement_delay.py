"""A delay tau of every response channel behind the motion (acquisition, filters).

A band-limited fractional delay: the response channels' spectra are multiplied by
:math:`e^{-s\\tau}`, not shifted by whole samples; the force channel is not delayed. tau in s.
"""
from typing import ClassVar

from bayesbeam.physics.effects.base import Effect


class MeasurementDelay(Effect):
    name = "measurement_delay"
    parameters = ("tau",)
    absent: ClassVar[dict[str, float]] = {"tau": 0.0}
    units = {"tau": "s"}
    description = "every response channel lags the motion by tau (band-limited fractional delay)"

    def delay(self, values):
        return values["tau"]
