"""The one interface every damping mechanism implements.

A mechanism adds a term to the weak form of the beam equation. Two kinds occur in the paper:

* *viscous* terms, linear in the velocity: a constant matrix :math:`D_m` in
  :math:`M\\ddot w + (\\sum_m D_m)\\dot w + K w = F` (air, strain rate, spatial hysteresis);
* *hereditary* terms, a memory integral of the curvature: in the Laplace domain a scalar
  relaxation transform :math:`\\hat G(s)` times :math:`K_0` that is subtracted from the
  stiffness, :math:`K \\to EI\\,K_0 - \\hat G(s) K_0` (time hysteresis; and, from the literature
  since, fractional Kelvin-Voigt, exponential relaxation and thermoelastic damping).

Both come out of the weak form, so the damping moments appear in the free-end conditions as the
paper requires, without any extra boundary term.
"""
from __future__ import annotations

from collections.abc import Callable, Mapping

import numpy as np

from bayesbeam.physics.assembly import BeamOperators
from bayesbeam.physics.component import Component


class Mechanism(Component):
    """A damping mechanism: its parameters (the paper's names, SI units) and its contribution."""

    #: a memory term (``relaxation``): no finite state space, so no nonlinear time stepping
    hereditary = False
    #: the damping matrix (if any) is a combination of the bare beam's M_0 and K_0, and a memory
    #: acts on K_0: the bare beam's modes diagonalise both, so a tip body or an effect departs
    #: from modal form only by a low rank (the ``low_rank`` transfer form)
    bare_modal = True

    def damping(self, ops: BeamOperators, values: Mapping[str, float]) -> np.ndarray | None:
        """Viscous damping matrix D_m (N s/m in generalized coordinates), or None."""
        return None

    def relaxation(self, values: Mapping[str, float]) -> Callable[[np.ndarray], np.ndarray] | None:
        """The Laplace transform s -> G(s) (N m^2) of a hereditary kernel, or None."""
        return None
