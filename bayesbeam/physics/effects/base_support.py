r"""The clamp's support: a base of its own mass on a spring and a dashpot (a support resonance).

The clamp grips the beam rigidly in rotation but sits on a base of mass m_b (kg) that translates
on a spring k_b (N/m) and a dashpot c_b (N s/m) to ground: a test-stand block on its bolts, a
shaker table, a bench. So u(0, t) = y_b(t) is free and u_x(0) = 0 (``root = "sliding"``), and the
root shear drives the base,

.. math:: m_b\,\ddot y_b + c_b\,\dot y_b + k_b\,y_b = -EI\,u_{xxx}(0, t)

(a tip load P up makes EI u_xxx = -P along the beam and lifts the base by P/k_b). With u the
absolute displacement the base's energies add to the weak form at x = 0:
:math:`M \mathrel{+}= m_b e_0 e_0^T`, :math:`D \mathrel{+}= c_b e_0 e_0^T`,
:math:`K \mathrel{+}= k_b e_0 e_0^T` with :math:`e_0 = B(0)`. Every damping mechanism then acts
on the absolute motion (air damping on u_t), the sensors read absolute motion and the hammer's
row is unchanged. All three matrices lie along e_0, so the model keeps the ``low_rank`` transfer
form (one direction beside the tip body's).

**What it does.** Written with the clamped beam's mass-normalised modes phi_m (frequencies
omega_m, root participation :math:`L_m = \int \rho A\,\varphi_m + m_T\varphi_m(l)`,
:math:`\sum_m L_m^2 = \rho A l + m_T`), the undamped frequencies solve exactly

.. math:: k_b - \omega^2 m_b = \omega^2 \sum_m L_m^2\,\frac{\omega_m^2}{\omega_m^2 - \omega^2} ,

the base against the clamped beam's dynamic mass at its root. Far below mode 1 the beam rides
rigidly: one mode at :math:`\sqrt{k_b/(m_b + \rho A l + m_T)}`. Near mode m the base and the mode
form a two-degree-of-freedom pair (mass matrix ((m_b + rho A l + m_T, L_m), (L_m, 1)), stiffness
diag(k_b, omega_m^2)) that splits into two modes sharing the base's damping. A mode away from the
base's resonance is pushed from it by :math:`\delta(\omega_m^2) \approx -\omega_m^4 L_m^2 /
(k_b - \omega_m^2 m_e)`, m_e the base's mass plus what the beam's other modes carry at omega_m
(:math:`m_b + \rho A l + m_T - L_1^2` for mode 1): down below the resonance, up above it; a stiff
base (:math:`k_b \gg \omega_m^2 m_e`) lowers mode m by :math:`\omega_m^4 L_m^2 / k_b`.

**Parameters.** The base is fitted as its own natural frequency f_b (Hz), mass m_b (kg) and
damping ratio zeta_b (-):

.. math:: k_b = m_b (2\pi f_b)^2, \qquad c_b = 2\,\zeta_b\, m_b\, (2\pi f_b)

(:func:`base_constants` gives m_b, k_b, c_b). Why not (m_b, k_b, c_b) themselves: a support
resonance is placed by its frequency against the band, which k_b alone does not say (it depends on
m_b), and a dashpot's effect by its damping ratio; independent priors on k_b and c_b would have to
span 11 and more decades to reach every base frequency and damping ratio for every mass. The
effect vanishes only as f_b -> inf (a rigid base; the sliding basis cannot represent the clamp
itself), so its ``absent`` point is finite and stated: f_b = :data:`ABSENT_RATIO` = 1e4 times the
nominal clamped beam's fundamental f_1 (:func:`fundamental`), the top of f_b's prior, with m_b and
zeta_b at their priors' medians, :data:`ABSENT_MASS` = 3.16 rho A l and :data:`ABSENT_DAMPING` =
0.017. There, by the shift above, mode m moves by about :math:`\tfrac12 (f_m/f_b)^2 L_m^2/m_b`:
under 1e-6 of itself for the first 8 modes even at m_b = rho A l, and the base's damping gives
mode m about :math:`\zeta_b (\omega_m/\omega_b)^3 L_m^2/m_b`, under 1e-9. The held mass matters
to the diagnosis's one-parameter screen, which scans f_b with m_b and zeta_b held there
(:mod:`bayesbeam.checks.signatures`).
Without a recording (unbound) ``absent`` is that limit, f_b = inf.

**Rotation of the base** (its rotary inertia) is left out. A rotating support is the root spring
and dashpot (``root_compliance``, ``root_damping``), massless: the base's rotary inertia
J_b = m_b r_g^2 (r_g its radius of gyration) competes with the beam's own about the clamp,
:math:`\rho A l^3/3 + m_T l^2`, a lever arm l that the base's compact r_g lacks (a 5 kg block of
r_g = 5 cm under a 1 kg, 1 m beam has 4 % of it), whereas in translation m_b competes with
rho A l one to one. With ``root_compliance`` in the same model the root is ``"free"`` (u(0) and
u_x(0) both free): a base that translates and a clamp that rotates are fitted together.
"""
from __future__ import annotations

import copy
from typing import ClassVar

import numpy as np

from bayesbeam.physics.effects.base import Effect, octave, oscillator

#: the absent base's natural frequency, in units of the nominal clamped beam's fundamental f_1
ABSENT_RATIO = 1e4
#: the default priors' ranges of the base's mass (in units of the beam's mass rho A l) and of its
#: damping ratio (:mod:`bayesbeam.inference.priors`)
MASS_RANGE, DAMPING_RANGE = (0.1, 100.0), (1e-3, 0.3)
#: the absent base's mass (in rho A l) and damping ratio: the ranges' geometric centres, the priors'
#: medians (at the absent f_b neither reaches any mode; they are what the screen holds while it
#: scans f_b, and where the optimiser starts them)
ABSENT_MASS, ABSENT_DAMPING = float(np.sqrt(np.prod(MASS_RANGE))), float(np.sqrt(np.prod(DAMPING_RANGE)))
#: beta_1 l of the clamped-free beam (root of 1 + cos cosh = 0)
BETA_1 = 1.8751040687119611


def fundamental(beam) -> float:
    """The nominal clamped beam's fundamental f_1 (Hz), no tip body: (beta_1 l)^2 sqrt(EI_0 /
    (rho A l^4)) / (2 pi), the scale of the base's frequency."""
    return BETA_1**2 * np.sqrt(beam.nominal_EI / (beam.rho_a * beam.length**4)) / (2 * np.pi)


def base_constants(values) -> dict[str, float]:
    """The base's mass m_b (kg), spring k_b (N/m) and dashpot c_b (N s/m) from the fitted f_b, m_b, zeta_b."""
    k_b, c_b = oscillator(values["m_b"], values["f_b"], values["zeta_b"])
    return {"m_b": values["m_b"], "k_b": k_b, "c_b": c_b}


class BaseSupport(Effect):
    name = "base_support"
    parameters = ("f_b", "m_b", "zeta_b")
    absent: ClassVar[dict[str, float]] = {"f_b": np.inf, "m_b": 1.0, "zeta_b": ABSENT_DAMPING}
    """Unbound: the limit f_b -> inf (a rigid base; m_b is then immaterial)."""
    units: ClassVar[dict[str, str]] = {"f_b": "Hz", "m_b": "kg", "zeta_b": "-"}
    description = ("the clamp on a translating base: mass m_b on a spring and dashpot, natural frequency f_b, "
                   "damping ratio zeta_b (k_b = m_b (2 pi f_b)^2, c_b = 2 zeta_b m_b 2 pi f_b)")
    root = "sliding"
    own_mode = "the base's own mode"

    def bind(self, recording) -> BaseSupport:
        """The effect for ``recording``: absent at f_b = ABSENT_RATIO f_1, m_b = ABSENT_MASS rho A l."""
        bound = copy.copy(self)
        beam = recording.beam
        bound.absent = {"f_b": ABSENT_RATIO * fundamental(beam), "m_b": ABSENT_MASS * beam.rho_a * beam.length,
                        "zeta_b": ABSENT_DAMPING}
        return bound

    def check(self, values):
        super().check(values)
        for key in ("f_b", "m_b"):
            if not values[key] > 0:
                raise ValueError(f"base_support: {key} = {values[key]!r} {self.units[key]} must be > 0")

    def mass(self, ops, values, setup):
        return values["m_b"] * ops.point_matrix(0.0)

    def stiffness(self, ops, values, setup):
        return base_constants(values)["k_b"] * ops.point_matrix(0.0)

    def damping(self, ops, values, setup):
        return base_constants(values)["c_b"] * ops.point_matrix(0.0)

    def reference(self, values):
        # the grid's m_b and k_b / EI (the stiffness per unit EI), written back as f_b
        m_b, k_b = octave(values["m_b"]), octave(base_constants(values)["k_b"] / values["EI"])
        return {"f_b": float(np.sqrt(k_b / m_b) / (2 * np.pi)), "m_b": m_b, "zeta_b": 0.0}
