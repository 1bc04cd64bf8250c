r"""Thermoelastic damping (Zener 1937): heat flow across the thickness relaxes the modulus.

Bending compresses one face and stretches the other; the faces heat and cool adiabatically, and
the heat that flows across the thickness h before the stress reverses is lost. Zener's standard
linear solid, one relaxation at the slowest thermal time of the plate, gives the bending stiffness

.. math:: EI(s) = EI\left(1 + \Delta\,\frac{s\tau}{1 + s\tau}\right), \qquad
          \Delta = \frac{E\,\alpha_T^2\,T_0}{\rho\,c_p}, \qquad \tau = \frac{h^2}{\pi^2 \chi},

EI the relaxed (isothermal, static) stiffness, E = EI / I with I the [beam] second moment, rho the
[beam] density, alpha_T (1/K), T0 (K), c_p (J/(kg K)), chi (m^2/s) and h (m) from the
recording's ``[material]`` table (:attr:`bayesbeam.io.Recording.material`; docs/format.md). On
the hereditary path (:math:`Z = s^2 M + s D + K - \hat G(s) K_0`)

.. math:: \hat G(s) = -\kappa\,\Delta\, EI\,\frac{s\tau}{1 + s\tau},

with one fitted parameter, the scale kappa (``zener_scale``, dimensionless): the material
constants *predict* each mode's damping and kappa = 1 is Zener's value.

kappa = 1 puts the whole strength Delta in this one term. Heat conduction across an insulated
slab relaxes through the odd thermal modes n = 1, 3, 5, ..., of strengths 96 Delta/(pi^4 n^4) at
times tau/n^2 (tests/reference/thermoelastic.py): the slowest carries 96/pi^4 = 98.6 % of Delta,
the rest relax 9, 25, ... times faster. So the exact loss over the single term's is
pi^2/10 = 0.987 well below the peak (omega tau << 1), 0.988 at it, 1.05 at omega tau = 10, and
tends to 12/pi^2 = 1.22 far above it (tests/physics/mechanisms/test_thermoelastic.py). A fitted
kappa that is Zener's physics therefore lies between about 0.99 and 1.2, by where the fitted
modes sit against 1/tau; no single scale (not 96/pi^4) makes the one term exact at every
frequency. Along s = i omega the
loss factor is :math:`\kappa\Delta\,\omega\tau / (1 + \omega^2\tau^2(1 + \kappa\Delta))`, so to
first order in Delta (2e-3 for steel, 4e-3 for aluminium at 293 K) each mode's damping ratio is

.. math:: \zeta_m = \frac{\kappa\Delta}{2}\,\frac{\omega_m\tau}{1 + \omega_m^2\tau^2},

largest, Delta / 4, at omega tau = 1. Exactly, each bare-beam mode's denominator times
:math:`1 + s\tau` is the cubic :math:`\tau s^3 + s^2 + \omega_m^2\tau(1 + \kappa\Delta)s + \omega_m^2`.
Causal (one pole at -1/tau), passive (:math:`-\mathrm{Im}\,\hat G(i\omega) > 0`), and
:math:`\hat G(0) = 0`. The mechanism assumes a homogeneous beam of uniform thickness h.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from bayesbeam.physics.mechanisms.base import Mechanism


def zener_transform(s, strength: float, tau: float, ei: float):
    """G(s) = -strength EI s tau / (1 + s tau) (N m^2); ``strength`` = kappa Delta."""
    s = np.asarray(s, dtype=complex)
    return -strength * ei * s * tau / (1.0 + s * tau)


@dataclass(frozen=True)
class ZenerConstants:
    """What the material fixes: Delta per unit EI (1/(N m^2)) and the relaxation time tau (s)."""

    strength_per_EI: float
    tau: float

    @classmethod
    def of(cls, recording) -> ZenerConstants:
        """From the recording's [beam] (I, rho) and [material] tables (RecordingError if missing)."""
        beam, mat = recording.beam, recording.material
        # Delta = E alpha^2 T0 / (rho c_p) with E = EI / I
        per_ei = mat.thermal_expansion**2 * mat.temperature / (beam.second_moment * beam.density * mat.specific_heat)
        return cls(per_ei, mat.thickness**2 / (np.pi**2 * mat.thermal_diffusivity))

    def strength(self, ei: float) -> float:
        """Zener's relaxation strength Delta at this EI (dimensionless)."""
        return self.strength_per_EI * ei


class Thermoelastic(Mechanism):
    name = "thermoelastic"
    parameters = ("zener_scale",)
    units: ClassVar[dict[str, str]] = {"zener_scale": "-"}
    hereditary = True
    description = ("thermoelastic (Zener), EI(s) = EI (1 + kappa Delta s tau/(1 + s tau)), "
                   "Delta and tau from [material]")
    #: the material's constants, set by :meth:`bind` (None in the registry's unbound instance)
    constants: ZenerConstants | None = None

    def bind(self, recording) -> Thermoelastic:
        bound = Thermoelastic()
        bound.constants = ZenerConstants.of(recording)
        return bound

    def relaxation(self, values):
        if self.constants is None:
            raise ValueError("thermoelastic: no material constants; build the model from a recording "
                             "(BeamModel binds each mechanism to its recording's [material] table)")
        strength, tau, ei = values["zener_scale"] * self.constants.strength(values["EI"]), self.constants.tau, values["EI"]
        return lambda s: zener_transform(s, strength, tau, ei)
