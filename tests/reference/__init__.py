"""An independent reference simulator for tests: recordings the fitted model did not make.

It shares nothing with :mod:`bayesbeam.physics`, :mod:`bayesbeam.response` or :mod:`bayesbeam.model`
(only :mod:`bayesbeam.io`, to write the format):

* space: Hermite cubic Euler-Bernoulli finite elements (:mod:`.fem`), 60 by default, clamped root
  or root spring (with a root dashpot), the clamp on a translating base (mass, spring, dashpot), tip body, sensor mass, an attached body on a spring and
  dashpot (its own dof, :func:`.system.matrices`), axial load, Coulomb friction at the
  tip (:mod:`.friction`), the paper's four damping mechanisms and the literature's three
  (fractional, exponential relaxation, Zener's solid), and thermoelastic damping solved from the
  heat equation across the thickness (:mod:`.thermoelastic`);
* time: exact exponential stepping of the first-order system under a piecewise-cubic (Hermite)
  force on a fine grid (:mod:`.integrate`); time hysteresis as a sum of exponentials that is exact
  in the limit, in the undamped modes (:mod:`.memory`, :mod:`.system`); the literature's
  mechanisms as internal variables of the bending moment, fractional damping through a quadrature
  of s^nu over relaxation rates (:mod:`.relaxation`, :mod:`.augmented`);
* acquisition: a continuous hammer pulse or a release, a zero-phase anti-alias FIR and decimation
  (:mod:`.daq`), a delay of the response channels, seeded sensor and force noise (:mod:`.record`).

>>> from bayesbeam.io import Beam
>>> from tests.reference import Hammer, Noise, record
>>> beam = Beam(1.0, 1710.0, 0.597e-3, 1.64e-9, 2.7e10)
>>> rec = record(beam, {"gamma": 0.3, "cdI": 7e-5}, excitation=Hammer(0.75), fs=512, duration=0.25,
...              noise=Noise(sensor=0.02, force=0.01), seed=1)
>>> rec.signals.shape
(128, 1)
"""
from .record import Hammer, Noise, Numerics, Release, record, simulate
from .system import BeamCase

__all__ = ["BeamCase", "Hammer", "Noise", "Numerics", "Release", "record", "simulate"]
