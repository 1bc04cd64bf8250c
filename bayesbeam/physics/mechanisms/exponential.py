r"""Exponential relaxation (Biot): a non-viscous damping moment with an exponential kernel.

The bending moment gains a memory of the curvature rate,

.. math:: \int_{-\infty}^t c_e\,\mu\, e^{-\mu (t - \sigma)}\, u_{xxt}(\sigma)\, d\sigma ,

c_e in N m^2 s, mu in 1/s: the kernel identified from beam tests by Adhikari & Woodhouse
(2001, J. Sound Vib. 243). The kernel integrates to c_e, so as mu -> infinity (a memory much
shorter than a period) it is Kelvin-Voigt damping with cdI = c_e. From rest its Laplace
transform is :math:`c_e\,\mu\, s/(s + \mu)\, K_0 W(s)`; on the hereditary path
(:math:`Z = s^2 M + s D + K - \hat G(s) K_0`)

.. math:: \hat G(s) = -\frac{c_e\,\mu\, s}{s + \mu}.

For the bare beam each mode's denominator :math:`s^2 + \omega_m^2 (1 + \hat c\,\mu s/(s + \mu))`,
:math:`\hat c = c_e/EI`, times :math:`s + \mu` is the cubic
:math:`s^3 + \mu s^2 + \omega_m^2 (1 + \hat c\mu) s + \omega_m^2 \mu`: one oscillatory pair and
one real (relaxation) pole per mode. Along :math:`s = i\omega` the loss factor is
:math:`\eta = \hat c\,\mu^2\omega / (\mu^2 + \omega^2 + \hat c\,\mu\,\omega^2)`: viscous
(:math:`\hat c\,\omega`) below mu, falling as :math:`1/\omega` above it. Causal (one pole at
-mu), passive (:math:`-\mathrm{Im}\,\hat G(i\omega) = c_e\mu^2\omega/(\mu^2 + \omega^2) > 0`), and
the static stiffness is EI (:math:`\hat G(0) = 0`).
"""
import numpy as np

from bayesbeam.physics.mechanisms.base import Mechanism


def exponential_transform(s, c_e: float, mu: float):
    """G(s) = -c_e mu s / (s + mu) (N m^2)."""
    s = np.asarray(s, dtype=complex)
    return -c_e * mu * s / (s + mu)


class Exponential(Mechanism):
    name = "exponential"
    parameters = ("c_e", "mu")
    units = {"c_e": "N m^2 s", "mu": "1/s"}
    hereditary = True
    description = "exponential relaxation (Biot), moment int c_e mu exp(-mu (t - s)) u_xxt(s) ds"

    def check(self, values):
        super().check(values)
        if not values["mu"] > 0:
            raise ValueError(f"exponential: mu = {values['mu']!r} must be > 0 1/s")

    def relaxation(self, values):
        c_e, mu = values["c_e"], values["mu"]
        return lambda s: exponential_transform(s, c_e, mu)
