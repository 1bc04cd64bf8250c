r"""A calibration error of each response channel: the channel reads (1 + g) times the motion.

An accelerometer's sensitivity is calibrated to about 2 % (the back-to-back comparison calibration
of ISO 16063-21 states 1-2 % at k = 2 over the flat band; data sheets give the sensitivity +-5 %
before it), and the DAQ's range and the entered sensitivity add their own. Each response channel
has its own g (dimensionless): ``g`` on a recording of one sensor, ``g_<sensor name>`` on one of
several (:func:`gain_names`, as the sensor masses are named), so a gain belongs to its sensor by
name. The force channel is not scaled: its calibration is the reference the gains are read
against.

What the data can tell: only ratios of calibrations. On a recording of one sensor and a measured
force, g is degenerate with a calibration error of the force channel (a force reading 3 % high is
g = 1/1.03 - 1), and the fitted g is their ratio, not the sensor's error; its prior keeps it to the
stated tolerance. On a free decay the amplitudes are the unknown state's, and a single channel's
gain is exactly degenerate with them: its posterior is its prior. With several sensors the gains'
differences show as a uniform amplitude ratio of one channel against the others.
"""
from __future__ import annotations

import copy
from typing import ClassVar

import numpy as np

from bayesbeam.physics.effects.base import Effect, per_sensor

#: the parameter of a recording's only sensor, and of sensor <s> among several
SINGLE, PER_SENSOR = "g", "g_{}"


def gain_names(sensor_names) -> tuple[str, ...]:
    """The effect's parameter per sensor: ``("g",)`` for one sensor, ``g_<name>`` for several.

    >>> gain_names(["tip"]), gain_names(["tip", "mid"])
    (('g',), ('g_tip', 'g_mid'))
    """
    return per_sensor(SINGLE, PER_SENSOR, sensor_names)


class ChannelGain(Effect):
    name = "channel_gain"
    parameters = (SINGLE,)
    absent: ClassVar[dict[str, float]] = {SINGLE: 0.0}
    units: ClassVar[dict[str, str]] = {SINGLE: "-"}
    description = "each response channel reads (1 + g) times the motion (g; g_<sensor> with several sensors)"

    def bind(self, recording) -> ChannelGain:
        """The effect for ``recording``: a gain per sensor (:func:`gain_names`)."""
        bound = copy.copy(self)
        bound.parameters = gain_names(s.name for s in recording.sensors)
        bound.units = dict.fromkeys(bound.parameters, "-")
        bound.absent = dict.fromkeys(bound.parameters, 0.0)
        return bound

    def check(self, values) -> None:
        """A gain may be negative, but the channel must keep its sign: 1 + g > 0."""
        for key in self.parameters:
            if not (np.isfinite(values[key]) and values[key] > -1):
                raise ValueError(f"{self.name}: {key} = {values[key]!r} is not physical (must be finite and > -1)")

    def channel_response(self, values, s):
        gains = np.array([values[p] for p in self.parameters])
        return None if not gains.any() else (1.0 + gains)[None, :]
