"""The sensors' own masses: a point mass at each sensor's location.

Weak form: :math:`\\sum_j m_{s,j}\\, u_{tt}(x_j)\\, \\psi(x_j)`, i.e.
:math:`M \\mathrel{+}= \\sum_j m_{s,j}\\, r_j r_j^T` with :math:`r_j = B(x_j)`, one mass (kg) per
sensor j at its placement x_j (its stated location plus a fitted offset ``dx_<s>``).

Parameter names (:func:`mass_names`): ``m_s`` when the recording has one sensor, ``m_s_<sensor
name>`` for each sensor when it has several, so that a mass belongs to a sensor by name, never
by the order of the ``[[sensor]]`` tables.

Every model carries the masses beam.toml states on the sensors (:attr:`BeamModel.carried_mass
<bayesbeam.model.BeamModel>`); with this effect a sensor's fitted mass *replaces* its stated
one. So the effect adds :math:`\\sum_j (m_{s,j} - m^{stated}_j)\\, r_j r_j^T` (0 where nothing
is stated), and it vanishes (``absent``) where each fitted mass equals the stated one: the model
without the effect.
"""
from __future__ import annotations

import copy
from typing import ClassVar

from bayesbeam.physics.effects.base import Effect, octave, per_sensor

#: the parameter of a recording's only sensor, and of sensor <s> among several
SINGLE, PER_SENSOR = "m_s", "m_s_{}"


def mass_names(sensor_names) -> tuple[str, ...]:
    """The effect's parameter per sensor: ``("m_s",)`` for one sensor, ``m_s_<name>`` for several.

    >>> mass_names(["tip"]), mass_names(["tip", "mid"])
    (('m_s',), ('m_s_tip', 'm_s_mid'))
    """
    return per_sensor(SINGLE, PER_SENSOR, sensor_names)


class SensorMass(Effect):
    name = "sensor_mass"
    parameters = (SINGLE,)
    absent: ClassVar[dict[str, float]] = {SINGLE: 0.0}
    units: ClassVar[dict[str, str]] = {SINGLE: "kg"}
    description = "point mass of each sensor at its location (m_s; m_s_<sensor> with several sensors)"
    #: the stated mass (kg) each parameter replaces, in the order of ``parameters`` (0: none stated)
    stated: tuple[float, ...] = (0.0,)

    def bind(self, recording) -> SensorMass:
        """The effect for ``recording``: a mass per sensor (:func:`mass_names`), each vanishing at
        the sensor's stated mass (0 where none is stated)."""
        bound = copy.copy(self)
        bound.parameters = mass_names(s.name for s in recording.sensors)
        bound.stated = tuple(m or 0.0 for m in recording.setup.sensor_masses) or (0.0,) * len(bound.parameters)
        bound.units = dict.fromkeys(bound.parameters, "kg")
        bound.absent = dict(zip(bound.parameters, bound.stated))
        return bound

    def mass(self, ops, values, setup):
        added = None
        for name, stated, x in zip(self.parameters, self.stated, setup.sensor_locations):
            term = (values[name] - stated) * ops.point_matrix(x)
            added = term if added is None else added + term
        return added

    def reference(self, values):
        return {name: octave(values[name]) for name in self.parameters}
