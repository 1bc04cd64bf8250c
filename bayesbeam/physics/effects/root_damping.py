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
(about as omega_m, like Kelvin-Voigt damping) while :math:`c_\theta\omega_m \ll k_\theta`;
only a soft clamp (k_theta l / EI of order 1 or less), whose first mode rotates about the root,
damps mode 1 most (tests/physics/effects/test_root_damping.py covers k_theta l / EI from 0.1 to 1100).

**Beyond first order.** Exactly, the root condition is the spring's with the Kelvin element's
complex stiffness :math:`\kappa = k_\theta + s c_\theta` (:math:`k_\theta + i\omega c_\theta` along
s = i omega), so a pole s solves the spring-root characteristic equation (no tip body)

.. math:: \kappa\,(1 + \cos\beta l\cosh\beta l) = \frac{EI}{l}\,\beta l\,
          (\sin\beta l\cosh\beta l - \cos\beta l\sinh\beta l), \qquad \beta^4 = -\rho A s^2 / EI .

Read with :math:`\lambda = -s^2` as the root stiffness :math:`K(\lambda)` that makes lambda a mode,
it passes k_theta at the elastic mode :math:`\lambda_m = \omega_m^2` with slope
:math:`d\lambda/d\kappa = \varphi_m'(0)^2` and has a pole at the clamped-free
:math:`\lambda_{c,m} = \omega_{c,m}^2` (no root stiffness raises a mode past its clamped value).
Keeping that pole, :math:`\lambda(\kappa) = \lambda_{c,m} - g/(1 + (\kappa - k_\theta)\varphi_m'(0)^2/g)`
with the gap :math:`g = \omega_{c,m}^2 - \omega_m^2`, and at :math:`\kappa - k_\theta = i\omega_m c_\theta`

.. math:: \zeta_m \approx \frac{g\,x}{2\,(\omega_m^2 (1 + x^2) + g\,x^2)}, \qquad
          x = \frac{\omega_m c_\theta\,\varphi_m'(0)^2}{g} .

For x << 1 this is the first-order form. The damping peaks at x ~ 1, at
:math:`\zeta_{max} \approx g/(4\omega_m^2) \approx (\omega_{c,m} - \omega_m)/(2\omega_m)`: a root
dashpot damps a mode at most by half the relative frequency the clamp's compliance takes from
it. Above the peak the dashpot locks the root, the mode tends to the clamped one and the damping
falls as :math:`g/(2x\,\omega_{c,m}^2)`, as 1/(omega_m c_theta). At a stiff clamp
:math:`g/\varphi_m'(0)^2 \approx k_\theta` (1.04-1.11 k_theta for modes 1-3 at k_theta l/EI = 100),
so the peak lies near :math:`\omega_m = k_\theta/c_\theta`: "grows about as omega_m" holds only below
it. The form drops terms of relative order g/omega_m^2 (4 zeta_max): against the model's modal
damping it holds to 1.9 % at k_theta l/EI = 100 for modes 1-3 and omega_m c_theta/k_theta from
0.01 to 10 (tests/physics/effects/test_root_damping.py).
"""
from typing import ClassVar

import numpy as np

from bayesbeam.physics.effects.base import Effect


class RootDamping(Effect):
    name = "root_damping"
    parameters = ("c_theta",)
    absent: ClassVar[dict[str, float]] = {"c_theta": 0.0}
    units: ClassVar[dict[str, str]] = {"c_theta": "N m s/rad"}
    description = "rotational dashpot at the clamp, root impedance k_theta + c_theta s (needs root_compliance)"
    root = "pinned"
    requires = ("root_compliance",)

    def damping(self, ops, values, setup):
        e = ops.root_slope
        return values["c_theta"] * np.outer(e, e)
