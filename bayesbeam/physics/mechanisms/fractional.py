r"""Fractional Kelvin-Voigt damping (Bagley & Torvik 1983): a fractional derivative of the curvature.

The bending moment gains :math:`c_f\, D^\nu u_{xx}`, :math:`0 < \nu < 1` (Riemann-Liouville
derivative from rest, c_f in N m^2 s^nu, nu dimensionless). In weak form, as for strain rate,
:math:`c_f \int_0^l D^\nu u_{xx}\,\psi''\,dx`; its Laplace transform from rest is
:math:`c_f\, s^\nu K_0 W(s)`, so on the hereditary path (:class:`Mechanism`,
:math:`Z = s^2 M + s D + K - \hat G(s) K_0`)

.. math:: \hat G(s) = -c_f\, s^\nu  \qquad (\text{principal branch, cut on } s \le 0).

Complex modulus and loss factor: along :math:`s = i\omega` the bending stiffness becomes
:math:`EI + c_f \omega^\nu (\cos\tfrac{\nu\pi}2 + i \sin\tfrac{\nu\pi}2)`, so each mode of the
bare beam has the loss factor

.. math:: \eta(\omega) = \frac{c_f\,\omega^\nu \sin(\nu\pi/2)}{EI + c_f\,\omega^\nu \cos(\nu\pi/2)},

which grows only as :math:`\omega^\nu` (near-constant for small nu: the internal friction of
many metals and polymers), against :math:`\omega^1` for Kelvin-Voigt. Limits: nu -> 1 is
Kelvin-Voigt with cdI = c_f; nu -> 0 is a stiffness c_f added to EI with no loss.

Causality and passivity: :math:`s^\nu` is analytic off the negative real axis, and
:math:`-\mathrm{Im}\,\hat G(i\omega) = c_f \omega^\nu \sin(\nu\pi/2) > 0` for omega > 0 (a
positive loss); the static stiffness is EI (:math:`\hat G(0) = 0`). The branch cut gives a free
decay a slowly decaying non-oscillatory part besides the modes; a free-decay likelihood keeps
the poles only (:meth:`bayesbeam.model.BeamModel.free_decay_basis`).
"""
import numpy as np

from bayesbeam.physics.mechanisms.base import Mechanism


def fractional_transform(s, c_f: float, nu: float):
    """G(s) = -c_f s^nu (N m^2), principal branch."""
    return -c_f * np.power(np.asarray(s, dtype=complex), nu)


class Fractional(Mechanism):
    name = "fractional"
    parameters = ("c_f", "nu")
    units = {"c_f": "N m^2 s^nu", "nu": "-"}
    hereditary = True
    description = "fractional Kelvin-Voigt (Bagley-Torvik), moment c_f D^nu u_xx, 0 < nu < 1"

    def check(self, values):
        super().check(values)
        if not 0 < values["nu"] < 1:
            raise ValueError(f"fractional: nu = {values['nu']!r} must lie in (0, 1) "
                             "(nu = 1 is strain_rate with cdI = c_f)")

    def relaxation(self, values):
        c_f, nu = values["c_f"], values["nu"]
        return lambda s: fractional_transform(s, c_f, nu)
