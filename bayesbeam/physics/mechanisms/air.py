"""Viscous air damping (the paper's eq. 6): a distributed force gamma * u_t.

Weak form: :math:`\\gamma \\int_0^l u_t\\, \\psi \\,dx`, so :math:`D = \\gamma M_0`.
gamma in N s/m^2.
"""
from bayesbeam.physics.mechanisms.base import Mechanism


class Air(Mechanism):
    name = "air"
    parameters = ("gamma",)
    units = {"gamma": "N s/m^2"}
    description = "viscous air damping, force gamma*u_t per unit length"

    def damping(self, ops, values):
        return values["gamma"] * ops.M0
