r"""Amplitude-dependent air drag along the beam: a force :math:`-c_q\,|u_t|\,u_t` per unit length.

Form drag of a strip moving broadside through air, :math:`c_q = \tfrac12 \rho_{air} C_d\, b`
(b the strip width; about 0.02 N s^2/m^3 for a 20 mm strip in air). It dissipates
:math:`c_q \int_0^l |u_t|^3 dx` per unit time, so it damps large amplitudes more than small ones,
which no linear mechanism does. c_q in N s^2/m^3.

Weak form: the generalized force :math:`f_i = -c_q \int_0^l |u_t|\,u_t\, B_i\,dx`, evaluated with
:data:`POINTS_PER_INTERVAL` Gauss-Legendre points per spline interval on the velocity field
:math:`u_t(x_q) = B(x_q)\,\dot w`. The integrand is piecewise polynomial except where
:math:`u_t` changes sign (there it is :math:`C^1`), so the quadrature error is of the same order
as the spline error of the velocity field. The effect is nonlinear: it adds nothing to M, D or
K, and :mod:`bayesbeam.response.nonlinear` integrates it in time.
"""
from __future__ import annotations

from functools import lru_cache
from typing import ClassVar

import numpy as np

from bayesbeam.physics.basis import SplineBasis
from bayesbeam.physics.effects.base import Effect

#: Gauss points per spline interval for the drag integral
POINTS_PER_INTERVAL = 4


@lru_cache(maxsize=16)
def _quadrature(basis: SplineBasis, points: int):
    x, w = basis.quadrature(points)
    return basis.evaluate(x), w


class QuadraticDrag(Effect):
    name = "quadratic_drag"
    parameters = ("c_q",)
    absent: ClassVar[dict[str, float]] = {"c_q": 0.0}
    units = {"c_q": "N s^2/m^3"}
    description = "amplitude-dependent air drag, force c_q |u_t| u_t per unit length along the beam"
    linear = False

    def quadrature(self, ops) -> tuple[np.ndarray, np.ndarray]:
        """Velocity rows ``B(x_q)`` (n_points, n_dof) and weights (m) of the drag integral."""
        return _quadrature(ops.basis, POINTS_PER_INTERVAL)

    @staticmethod
    def law(values):
        """The drag per unit length (N/m) as a function of the local velocity (m/s)."""
        c_q = values["c_q"]
        return lambda v: -c_q * np.abs(v) * v

    def force(self, ops, values, velocity: np.ndarray) -> np.ndarray:
        """Generalized drag force (N) for generalized velocities ``velocity`` (..., n_dof)."""
        rows, w = self.quadrature(ops)
        v = velocity @ rows.T
        return (self.law(values)(v) * w) @ rows
