"""Kelvin-Voigt (strain-rate) damping, the paper's eqs. (7)-(9).

The bending moment gains :math:`c_d I\\, u_{xxt}`; in weak form
:math:`c_dI \\int_0^l u_{xxt}\\, \\psi''\\,dx`, so :math:`D = c_dI\\, K_0`. The damping moment
enters the free-end conditions through the same integral (natural boundary conditions).
cdI in N m^2 s.
"""
from bayesbeam.physics.mechanisms.base import Mechanism


class StrainRate(Mechanism):
    name = "strain_rate"
    parameters = ("cdI",)
    units = {"cdI": "N m^2 s"}
    description = "Kelvin-Voigt damping, moment cdI*u_xxt"

    def damping(self, ops, values):
        return values["cdI"] * ops.K0
