r"""A body attached to the beam at one point: a mass on a spring and a dashpot.

A shaker's armature on its stinger, a cable clamp, an instrument bolted on through a rubber pad:
a mass m_a (kg) joined to the beam at x_a (m from the clamp) by a spring k_a (N/m) and a dashpot
c_a (N s/m) in parallel. Its displacement y is a degree of freedom of its own, appended after the
beam's (:meth:`~bayesbeam.physics.effects.base.Effect.extend`); with :math:`r = B(x_a)` the rows
of the basis at x_a and :math:`u_a = r^T w` the beam's deflection there,

.. math::

    \begin{pmatrix} M & 0 \\ 0 & m_a \end{pmatrix}, \quad
    D \mathrel{+}= c_a \begin{pmatrix} r r^T & -r \\ -r^T & 1 \end{pmatrix}, \quad
    K \mathrel{+}= k_a \begin{pmatrix} r r^T & -r \\ -r^T & 1 \end{pmatrix} .

Seen from the beam it is a point load :math:`-Z(s)\,u_a` with the dynamic stiffness

.. math:: Z(s) = \frac{m_a s^2 (k_a + c_a s)}{m_a s^2 + c_a s + k_a} ,

whose limits are the two simpler bodies: a stiff link (k_a, c_a -> infinity) carries the mass
along, :math:`Z = m_a s^2`, the ``sensor_mass``'s point mass at x_a; a heavy body (m_a -> infinity)
stays put and the link is a spring and dashpot to ground, :math:`Z = k_a + c_a s`. Between them
the body has its own mode near :math:`\omega_a = \sqrt{k_a / m_a}`: below it the attachment adds
mass to the beam's modes (lowers them), above it stiffness (raises them), and a beam mode near
omega_a splits in two. Each mode m is shifted and damped in proportion to :math:`\varphi_m(x_a)^2`
(mass-normalised shapes), which is what places x_a: the shifts' pattern over the modes is the
squared mode shapes' pattern at one point of the span.

**Parameters.** The body is fitted as its own natural frequency f_a (Hz, on its link with the beam
held still), its mass m_a (kg), the link's damping ratio zeta_a (-) and its place x_a (m):

.. math:: k_a = m_a (2\pi f_a)^2, \qquad c_a = 2\,\zeta_a\, m_a\, (2\pi f_a)

(:func:`link_constants` gives m_a, k_a, c_a), for the reasons the base's are
(:mod:`bayesbeam.physics.effects.base_support`): the body's mode is placed by f_a against the band,
and independent priors on k_a and c_a would span many decades to reach every body. The effect
vanishes as f_a -> 0 (the body hangs free of the beam) or m_a -> 0; at m_a = 0 it adds no degree of
freedom. Its ``absent`` point is f_a = :data:`ABSENT_RATIO` = 0.01 times the nominal clamped beam's
fundamental f_1 (the bottom of f_a's prior; there the link's stiffness moves mode m by about
:math:`\tfrac12 (f_a/f_m)^2 m_a\varphi_m(x_a)^2`: 6e-6 of mode 1 for the absent body at the tip,
2e-4 for one of the beam's own mass), with m_a and zeta_a at their priors' medians and the body at the tip, where
every mode sees it. The diagnosis's screen scans f_a from there with m_a and zeta_a held, so that
its family runs from no body through a body with a mode of its own in the band to a point mass
riding on the beam, and repeats the scan at places along the span (:attr:`place`,
:mod:`bayesbeam.checks.signatures`).
"""
from __future__ import annotations

import copy
from typing import ClassVar

import numpy as np

from bayesbeam.physics.effects.base import Effect, oscillator
from bayesbeam.physics.effects.base_support import ABSENT_DAMPING, fundamental

#: the absent body's own frequency, in units of the nominal clamped beam's fundamental f_1
ABSENT_RATIO = 0.01
#: the default prior's range of the body's mass, in units of the beam's mass rho A l
#: (:mod:`bayesbeam.inference.priors`)
MASS_RANGE = (1e-3, 1.0)
#: the absent body's mass (in rho A l): the prior's median (its link's damping ratio is the base's
#: ABSENT_DAMPING, the median of the same prior)
ABSENT_MASS = float(np.sqrt(np.prod(MASS_RANGE)))


def link_constants(values) -> dict[str, float]:
    """The body's mass m_a (kg), the link's spring k_a (N/m) and dashpot c_a (N s/m) from the fitted
    f_a, m_a, zeta_a."""
    k_a, c_a = oscillator(values["m_a"], values["f_a"], values["zeta_a"])
    return {"m_a": values["m_a"], "k_a": k_a, "c_a": c_a}


class Attachment(Effect):
    name = "attachment"
    parameters = ("f_a", "m_a", "zeta_a", "x_a")
    absent: ClassVar[dict[str, float]] = {"f_a": 0.0, "m_a": 1.0, "zeta_a": ABSENT_DAMPING, "x_a": np.inf}
    """Unbound: the limit f_a -> 0 (the body hangs free; its mass and place are then immaterial)."""
    units: ClassVar[dict[str, str]] = {"f_a": "Hz", "m_a": "kg", "zeta_a": "-", "x_a": "m"}
    description = ("a body of mass m_a joined to the beam at x_a by a spring and a dashpot (a shaker's stinger, a "
                   "cable clamp, an attached instrument): its own degree of freedom, natural frequency f_a, link "
                   "damping ratio zeta_a (k_a = m_a (2 pi f_a)^2, c_a = 2 zeta_a m_a 2 pi f_a)")
    extends = True
    place = "x_a"
    own_mode = "the attached body's own mode"

    def bind(self, recording) -> Attachment:
        """The effect for ``recording``: absent at f_a = ABSENT_RATIO f_1, the body at the tip."""
        bound = copy.copy(self)
        beam = recording.beam
        bound.absent = {"f_a": ABSENT_RATIO * fundamental(beam), "m_a": ABSENT_MASS * beam.rho_a * beam.length,
                        "zeta_a": ABSENT_DAMPING, "x_a": beam.length}
        return bound

    def extend(self, ops, values, setup, mass, damping, stiffness):
        if values["m_a"] == 0 or values["f_a"] == 0:        # no body, or one hanging free of the beam
            return mass, damping, stiffness
        link = _link(ops.rows([values["x_a"]])[0], len(mass))
        constants = link_constants(values)
        grown = [np.pad(a, (0, 1)) for a in (mass, damping, stiffness)]
        grown[0][-1, -1] = constants["m_a"]
        return grown[0], grown[1] + constants["c_a"] * link, grown[2] + constants["k_a"] * link


def _link(row: np.ndarray, size: int) -> np.ndarray:
    """(size + 1, size + 1): the form of a unit spring between the beam's deflection ``row`` . w
    (the row on the beam's degrees of freedom, the first of ``size``) and the last coordinate."""
    e = np.zeros(size + 1)
    e[: row.size], e[-1] = row, -1.0
    return np.outer(e, e)
