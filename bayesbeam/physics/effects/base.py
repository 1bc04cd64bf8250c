"""The one interface of every missing-physics effect.

An effect is something real that a damping model leaves out: a compliant clamp, the sensor's
own mass, an axial load, amplitude-dependent drag or friction, a delay in the acquisition.
Like a damping mechanism it has named parameters (SI units) and adds to the Galerkin system:

* linear effects add to the mass, damping or stiffness matrix, change the root condition of the basis,
  delay the response channels, or filter them (a transfer function of the measurement chain applied
  to each response channel, never to the force); the exact frequency-domain solver handles them;
* nonlinear effects add a velocity-dependent force that needs a time integrator
  (:mod:`bayesbeam.response.nonlinear`);
* an additive signal on the response channels that is linear in unknown amplitudes (mains pickup)
  gives those amplitudes' columns (:meth:`Effect.latent_columns`), which the likelihood
  marginalises; the simulated response is unchanged.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from bayesbeam.physics.assembly import BeamOperators
from bayesbeam.physics.component import Component


@dataclass(frozen=True)
class Setup:
    """What an effect may need to know of the test set-up (positions in m from the clamp)."""

    sensor_locations: tuple[float, ...]
    force_location: float | None = None


class Effect(Component):
    """A missing-physics effect: parameters (the catalogue's names, SI units) and contributions."""

    #: root condition the basis must satisfy with this effect on ("clamped", "pinned" or "sliding";
    #: a model joins them, :func:`bayesbeam.physics.basis.combined_root`)
    root: str = "clamped"
    #: True when the effect keeps the equations linear
    linear: bool = True
    #: True when the effect brings degrees of freedom of its own (an attached body's motion),
    #: appended after the beam's by :meth:`extend`
    extends: bool = False
    #: the parameter that places the effect on the span (m from the clamp), which the screen scans
    #: over places as well as the first parameter (:mod:`bayesbeam.checks.signatures`); None: no place
    place: str | None = None
    #: parameter values at which the effect vanishes (the optimiser's global search starts there:
    #: an effect's prior median, such as a tension of several buckling loads, is no neutral guess)
    absent: ClassVar[dict[str, float]] = {}
    #: words for a mode the effect's own mass carries (an attached body's, a base's), or "" when it
    #: brings none (:meth:`bayesbeam.model.BeamModel.mode_labels` numbers the beam's modes without it)
    own_mode: str = ""

    def mass(self, ops: BeamOperators, values, setup: Setup) -> np.ndarray | None:
        """Added mass matrix (kg in generalised coordinates), or None."""
        return None

    def stiffness(self, ops: BeamOperators, values, setup: Setup) -> np.ndarray | None:
        """Added stiffness matrix (N/m in generalised coordinates), or None."""
        return None

    def damping(self, ops: BeamOperators, values, setup: Setup) -> np.ndarray | None:
        """Added damping matrix (N s/m in generalised coordinates), or None."""
        return None

    def extend(self, ops: BeamOperators, values, setup: Setup, mass: np.ndarray, damping: np.ndarray,
               stiffness: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(mass, damping, stiffness) with the effect's own degrees of freedom appended after those
        given (the beam's first, then those of the effects before it), coupled to the beam through
        its rows in ``ops``; the sensors, the load and a memory term act on the beam's alone.
        Default (``extends`` False): the matrices as given."""
        return mass, damping, stiffness

    def reference(self, values) -> dict[str, float]:
        """The effect's parameter values at the reference beam near ``values`` whose undamped
        modes the ``low_rank`` transfer form caches (it then corrects them by a rank-r term
        instead of solving an eigenproblem per call); ``mass(ops, reference)`` must give the
        reference's added mass and ``stiffness(ops, reference)`` its added stiffness *per unit
        EI*, so that one set of modes serves every EI.

        The values lie on a grid fixed in advance (see :func:`octave`), so the answer depends on
        the parameters alone, and the correction stays small: it is computed by cancellation, whose
        rounding a resonance amplifies. Default: where the effect vanishes (``absent``).
        """
        return dict(self.absent)

    def delay(self, values) -> float:
        """Delay of every response channel behind the motion (s); the force channel is not delayed."""
        return 0.0

    def channel_response(self, values, s: np.ndarray) -> np.ndarray | None:
        """The measurement chain's transfer function at complex frequencies ``s`` (1/s), applied to
        the response channels (never the force): an array broadcastable to (len(s), n_sensors),
        or None where it is 1 (the default: the effect does not filter the channels)."""
        return None

    def latent_columns(self, time: np.ndarray, values, n_sensors: int, max_frequency: float) -> np.ndarray | None:
        """Columns Psi (n_samples, n_sensors, J) of an additive signal Psi a on the response channels
        with unknown amplitudes a, at the record's ``time`` (s) and for a likelihood whose band ends
        at ``max_frequency`` (Hz); None (the default) where the effect adds none. They must not
        depend on the beam's parameters: the likelihood caches them per value of the effect's own.
        The likelihood marginalises a under its one wide prior rule for latent amplitudes
        (:mod:`bayesbeam.inference.likelihood`)."""
        return None

    def channel_poles(self, values) -> tuple[np.ndarray, np.ndarray]:
        """(poles q_k (1/s), residues r_k (1/s)) of :meth:`channel_response`, a rational function with
        simple poles shared by every channel; empty by default. A free decay's mode e^{p t} seen
        from rest through it gives H(p) e^{p t} + sum_k r_k / (q_k - p) e^{q_k t}
        (:meth:`bayesbeam.model.BeamModel.free_decay_basis`)."""
        return np.empty(0), np.empty(0)


def per_sensor(single: str, pattern: str, sensor_names) -> tuple[str, ...]:
    """An effect's parameter per sensor: ``(single,)`` for a recording's only sensor,
    ``pattern.format(name)`` for each of several, so that a parameter belongs to a sensor by name,
    never by the order of the ``[[sensor]]`` tables."""
    names = tuple(sensor_names)
    return (single,) if len(names) == 1 else tuple(pattern.format(n) for n in names)


def oscillator(mass: float, frequency: float, damping_ratio: float) -> tuple[float, float]:
    """(k, c) of a mass (kg) on a spring and dashpot of natural frequency ``frequency`` (Hz) and
    ``damping_ratio``: k = m (2 pi f)^2 (N/m), c = 2 zeta m 2 pi f (N s/m). An attached body and a
    translating base are fitted this way (their frequency and damping ratio, not k and c)."""
    omega = 2 * np.pi * frequency
    return mass * omega**2, 2 * damping_ratio * mass * omega


def octave(x: float) -> float:
    """The power of two nearest to x on a log scale (within a factor sqrt(2)), 0 for x <= 0."""
    return 0.0 if x <= 0 else float(2.0 ** np.round(np.log2(x)))
