r"""Coulomb (dry) friction at the tip, stepped on the fine grid with the crossing located in the step.

The contact force on the tip is :math:`g = -F_c\,\mathrm{sign}(\dot w(l))` while the tip slides
(F_c in N, a point force at the tip, entering like the hammer through the full state's input
column); while it sticks, whatever holds it, within :math:`\pm F_c`. The linear part is
propagated exactly (:mod:`tests.reference.integrate`); ``g`` is piecewise constant on the fine
grid (step h), chosen by the discrete Coulomb law from the velocity the step would end with:

* slip: against the motion; on a step where the tip reverses, the force flips at the crossing,
  placed by linear interpolation of the velocity, so its impulse is right to O(h^2);
* stick: when the force that brings the tip to rest by the step's end stays within F_c, that
  force holds it (from the crossing on, when the tip arrives inside the step).

Other stick and slip changes are placed to the step, so an accelerometer's reading of the
friction force converges to first order in h: recordings with friction need
``Numerics(oversample=256)`` (about 2 % of the friction's share of a tip acceleration; the
default 16 leaves about 30 %). The accuracy is checked in ``tests/reference/test_reference.py``
against the textbook single-mode decrement (4 F_c / k per cycle) and under a refined step.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import integrate
from .system import BeamCase, Blocks, full_blocks, matrices


@dataclass(frozen=True)
class TipFriction:
    """F_c (N) and the full state's tip input: B (ns,) for a unit tip force, F (n_out,) its direct
    share of each output (accelerations), velocity (ns,) the row reading the tip's velocity."""

    F_c: float
    B: np.ndarray
    F: np.ndarray
    velocity: np.ndarray

    @classmethod
    def of(cls, case: BeamCase, n_elements: int) -> TipFriction:
        if case.has_memory or case.relaxes:
            raise ValueError("the reference steps tip friction on the full finite-element state only: drop the "
                             "memory (alpha, beta) or the relaxing moment, or drop F_c")
        mats = matrices(case, n_elements)
        at_tip = full_blocks(case, mats, case.length)
        n = mats.mesh.n_dof
        velocity = mats.mesh.rows([case.length])[0] @ np.eye(n, 2 * n, n)
        return cls(float(case.effects["F_c"]), at_tip.B[0], at_tip.F, velocity)


def step(tip: TipFriction, blocks: Blocks, h: float, x0: np.ndarray, f: np.ndarray, df: np.ndarray) -> np.ndarray:
    """As :func:`tests.reference.integrate.step` (one full-state block), with the tip friction."""
    if blocks.A.shape[0] != 1:
        raise ValueError("tip friction needs the full state as one block (tests.reference.system.full_blocks)")
    phi, gamma = (m[0] for m in integrate.hold_matrices(blocks, h))
    # the exact state change over a step under a unit tip force held constant (Van Loan's d0 column)
    push = integrate.hold_matrices(Blocks(blocks.A, tip.B[None], blocks.C, tip.F), h)[1][0, :, 0]
    mobility = tip.velocity @ push          # tip velocity gained per newton held over a step (> 0)
    coefficients = integrate.cubic_coefficients(f, df, h)
    readout = blocks.C[0]
    out = np.empty((f.size, blocks.F.size))
    # per step: the force at its start and at its end, and the fraction of the step before it flips
    first, last, flip = np.zeros(f.size), np.zeros(f.size), np.ones(f.size)
    x = np.array(x0, dtype=float)[0]
    for i in range(f.size - 1):
        out[i] = readout @ x
        free = phi @ x + gamma @ coefficients[i]
        first[i], last[i], flip[i] = _law(tip.F_c, tip.velocity @ x, tip.velocity @ free, mobility)
        x = free + push * (first[i] * flip[i] + last[i] * (1 - flip[i]))
    out[-1] = readout @ x
    return out + blocks.F[None, :] * f[:, None] + tip.F[None, :] * _around(first, last, flip)[:, None]


def _law(F_c: float, v0: float, v_free: float, mobility: float) -> tuple[float, float, float]:
    """(force at the step's start, at its end, fraction of the step before the change) of Coulomb's
    law over one step from tip velocity v0, ``v_free`` being the end velocity without friction.

    Stick when the force that brings the tip to rest by the step's end stays within F_c (held
    constant over the step); else slip against the motion, the force flipping where the velocity
    crosses zero (placed by linear interpolation) when the tip reverses inside the step."""
    holding = -v_free / mobility
    if v0 == 0.0:                                   # at rest: stays, or breaks away
        return (holding, holding, 1.0) if abs(holding) <= F_c else (-F_c * np.copysign(1, v_free),) * 2 + (1.0,)
    sliding = -F_c * np.sign(v0)
    v1 = v_free + mobility * sliding
    if v0 * v1 >= 0:
        return sliding, sliding, 1.0
    reached = v0 / (v0 - v1)                        # the tip's velocity reaches zero here
    if abs(holding) <= F_c:                         # and it sticks: the rest of the step holds it
        return sliding, (holding - reached * sliding) / (1 - reached), reached
    return sliding, -sliding, reached


def _around(first: np.ndarray, last: np.ndarray, flip: np.ndarray) -> np.ndarray:
    """The force's direct share (accelerations) at t_i: its mean over [t_i - h/2, t_i + h/2], each
    half from the step it lies in, so that the FIR sees each flip where it happens, as the state does."""
    def mean_between(a, b):   # mean over the fractions [a, b] of each step
        before = np.clip(flip, a, b) - a
        return (first * before + last * (b - a - before)) / (b - a)

    left, right = mean_between(0.0, 0.5), mean_between(0.5, 1.0)
    return np.concatenate([[left[0]], (right[:-2] + left[1:-1]) / 2, [right[-2]]]) if first.size > 1 else first
