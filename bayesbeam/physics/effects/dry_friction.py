r"""Coulomb (dry) friction at the tip: a rubbing contact or a cable, with stick-slip.

The contact force g on the tip obeys the set-valued Coulomb law

.. math:: g \in -F_c\,\mathrm{Sign}(u_t(l)), \qquad
          \mathrm{Sign}(v) = \{v/|v|\} \ (v \ne 0), \quad [-1, 1] \ (v = 0),

i.e. while the tip slides the force is :math:`-F_c\,\mathrm{sign}(u_t(l))`, and while it sticks
the force is whatever holds it (the constraint force), as long as that stays within
:math:`\pm F_c`. F_c in N. In weak form the force enters through the tip row :math:`e = B(l)`:
:math:`M\ddot w + D\dot w + K w = b f + e\,g`. The effect is nonlinear (it adds nothing to M, D
or K); :mod:`bayesbeam.response.nonlinear` treats the stick-slip exactly (no regularised sign).

The textbook signature: a single mode of stiffness k (referred to the tip) under Coulomb
friction loses :math:`4F_c/k` of amplitude per cycle, a decay envelope linear in time, and stops
within :math:`F_c/k` of equilibrium.
"""
from __future__ import annotations

from typing import ClassVar

import numpy as np

from bayesbeam.physics.effects.base import Effect


class DryFriction(Effect):
    name = "dry_friction"
    parameters = ("F_c",)
    absent: ClassVar[dict[str, float]] = {"F_c": 0.0}
    units = {"F_c": "N"}
    description = "Coulomb friction opposing the tip velocity (rubbing contact, cable), with stick-slip"
    linear = False

    def contact_row(self, ops, setup=None) -> np.ndarray:
        """The row e = B(l): tip displacement u(l) = e @ w, and the friction's load vector."""
        return ops.tip_value

    @staticmethod
    def bound(values) -> float:
        """The friction limit F_c (N)."""
        return float(values["F_c"])
