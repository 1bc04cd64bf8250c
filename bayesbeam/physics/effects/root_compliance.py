"""A compliant clamp: a rotational spring at the root.

u(0) = 0 and EI u_xx(0) = k_theta u_x(0): the basis admits a root slope (``root = "pinned"``)
and the spring adds :math:`k_\\theta\\, u_x(0)\\, \\psi_x(0)` to the weak form, i.e.
:math:`K \\mathrel{+}= k_\\theta\\, e_0' e_0'^T` with :math:`e_0' = B'(0)`. k_theta in N m/rad;
as k_theta grows the clamped beam is recovered.
"""
from typing import ClassVar

import numpy as np

from bayesbeam.physics.effects.base import Effect, octave


class RootCompliance(Effect):
    name = "root_compliance"
    parameters = ("k_theta",)
    absent: ClassVar[dict[str, float]] = {"k_theta": np.inf}
    units = {"k_theta": "N m/rad"}
    description = "rotational spring at the clamp, EI u_xx(0) = k_theta u_x(0)"
    root = "pinned"

    def check(self, values):
        super().check(values)
        if not values["k_theta"] > 0:
            raise ValueError(f"root_compliance: k_theta = {values['k_theta']!r} must be > 0 N m/rad")

    def stiffness(self, ops, values, setup):
        e = ops.root_slope
        return values["k_theta"] * np.outer(e, e)

    def reference(self, values):
        # per unit EI, so k_theta / EI on the grid: the clamp itself (k_theta -> inf) has no matrix
        return {"k_theta": octave(values["k_theta"] / values["EI"])}
