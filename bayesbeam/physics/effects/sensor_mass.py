"""The accelerometer's own mass, a point mass m_s at the first sensor's location.

Weak form: :math:`m_s\\, u_{tt}(x_s)\\, \\psi(x_s)`, i.e. :math:`M \\mathrel{+}= m_s\\, r r^T`
with :math:`r = B(x_s)`. m_s in kg.
"""
from typing import ClassVar

from bayesbeam.physics.effects.base import Effect, octave


class SensorMass(Effect):
    name = "sensor_mass"
    parameters = ("m_s",)
    absent: ClassVar[dict[str, float]] = {"m_s": 0.0}
    units = {"m_s": "kg"}
    description = "point mass of the sensor at the first sensor's location"

    def mass(self, ops, values, setup):
        return values["m_s"] * ops.point_matrix(setup.sensor_locations[0])

    def reference(self, values):
        return {"m_s": octave(values["m_s"])}
