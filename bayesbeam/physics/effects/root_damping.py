r"""Losses at the clamp: a rotational dashpot beside the root spring.

The clamp resists the root slope with the impedance :math:`k_\theta + c_\theta s`:
u(0) = 0 and :math:`EI u_{xx}(0) = k_\theta u_x(0) + c_\theta u_{xt}(0)`. The spring is the
``root_compliance`` effect (k_theta, N m/rad; it frees the root slope of the basis); this effect
adds the dashpot, :math:`c_\theta\, u_{xt}(0)\, \psi_x(0)` in the weak form, i.e.
:math:`D \mathrel{+}= c_\theta\, e_0' e_0'^T` with :math:`e_0' = B'(0)`. c_theta in N m s/rad.

A rigid clamp has no root slope, so a dashpot there does nothing: the effect needs the
``root_compliance`` effect in the same model (the model refuses it alone), and the clamp's
losses as a damping model of their own are ``root_compliance+root_damping`` (EI, k_theta,
c_theta; the bare beam otherwise undamped). As c_theta -> 0 the elastic root is recovered.

To first order in c_theta, mode m (mass-normalised shape phi_m, root slope phi_m'(0)) gains
:math:`\zeta_m = c_\theta\,\varphi_m'(0)^2 / (2\omega_m)`. The pattern over the modes depends
on the clamp's stiffness: at a stiff clamp the root slope is set by the root moment,
:math:`\varphi_m'(0) \approx EI\varphi_m''(0)/k_\theta`, and the damping grows with the mode
(about as omega_m, like Kelvin-Voigt damping); only a soft clamp (k_theta l / EI of order 1 or
less), whose first mode rotates about the root, damps mode 1 most (tests/physics/effects/
test_root_damping.py covers k_theta l / EI from 0.1 to 1100).
"""
from typing import ClassVar

import numpy as np

from bayesbeam.physics.effects.base import Effect


class RootDamping(Effect):
    name = "root_damping"
    parameters = ("c_theta",)
    absent: ClassVar[dict[str, float]] = {"c_theta": 0.0}
    units = {"c_theta": "N m s/rad"}
    description = "rotational dashpot at the clamp, root impedance k_theta + c_theta s (needs root_compliance)"
    root = "pinned"
    requires = ("root_compliance",)

    def damping(self, ops, values, setup):
        e = ops.root_slope
        return values["c_theta"] * np.outer(e, e)
