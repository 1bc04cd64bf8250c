"""A constant axial force P (tension positive): geometric stiffness.

Weak form: :math:`P \\int_0^l u_x \\psi_x\\,dx`, i.e. :math:`K \\mathrel{+}= P\\, G_0`. P in N; a
compressive P (negative) softens the beam and must stay below the buckling load.
"""
from typing import ClassVar

import numpy as np

from bayesbeam.physics.effects.base import Effect


class AxialLoad(Effect):
    name = "axial_load"
    parameters = ("P",)
    absent: ClassVar[dict[str, float]] = {"P": 0.0}
    units = {"P": "N"}
    description = "constant axial force (tension positive), geometric stiffness P <u_x, psi_x>"

    def check(self, values):
        if not np.isfinite(values["P"]):
            raise ValueError(f"axial_load: P = {values['P']!r} is not finite")

    def stiffness(self, ops, values, setup):
        return values["P"] * ops.G0
