"""Maxwell-Betti reciprocity: force at x1 / sensor at x2 equals force at x2 / sensor at x1.

Every model here has symmetric M, D, K and K_h, so Z(s) is complex symmetric and
C Z^-1 B = (B^T Z^-1 C^T)^T: swapping the load and sensor rows must not change the response.
Each of the solver's forms but low_rank (tests/response/test_system.py) is exercised (diagonal,
complex, banded, dense) with the paper's parameter vectors q1, q2, q3, with and without a tip body.
"""
import numpy as np
import pytest

from bayesbeam.physics.mechanisms import (
    Air,
    SpatialHysteresis,
    StrainRate,
    TimeHysteresis,
)
from bayesbeam.response.linear import FrequencyGrid, force_response
from bayesbeam.response.system import SecondOrderSystem
from tests.galerkin_reference import EI, paper_operators

X1, X2 = 0.3, 0.85
FS, N_SAMPLES = 2048.0, 2048
TIP = (0.2, 0.003)  # m_T (kg), J (kg m^2)

CASES = [  # (model, tip body, expected modal form)
    ("q1", (0.0, 0.0), "diagonal"),
    ("q1", TIP, "complex"),        # air with a tip body is not modal
    ("q3", (0.0, 0.0), "complex"),
    ("q3", TIP, "complex"),
    ("q2", (0.0, 0.0), "diagonal"),
    ("q2", TIP, "diagonal"),
    ("q2+air", TIP, "banded"),     # memory beside non-modal damping
    ("q2+q3", (0.0, 0.0), "dense"),  # memory beside spatial hysteresis: no band
]


def _system(model, tip_body):
    ops = paper_operators(16, *tip_body)
    D, g, K_h = 0 * ops.M, None, None
    if model == "q1":
        D = Air().damping(ops, {"gamma": 0.5}) + StrainRate().damping(ops, {"cdI": 2e-4})
    elif model == "q3":
        D = (Air().damping(ops, {"gamma": 0.090189})
             + SpatialHysteresis().damping(ops, {"a": 1.040394, "b": 0.064362}))
    else:
        g = TimeHysteresis().relaxation({"alpha": 10.0, "beta": 5.0, "r": np.inf})
        K_h = ops.K0
        if model == "q2+air":
            D = Air().damping(ops, {"gamma": 0.5})
        if model == "q2+q3":
            D = SpatialHysteresis().damping(ops, {"a": 1.040394, "b": 0.064362})
    return ops, SecondOrderSystem(ops.M, D, EI * ops.K0, g, K_h)


@pytest.mark.parametrize("model, tip_body, form", CASES)
def test_transfer_functions_are_reciprocal(model, tip_body, form):
    """H_21(s) = H_12(s) on the solver's frequency grid: max |H12 - H21| / max |H12| < 1e-10.

    Measured: 0 (diagonal, bit-identical), 8e-17 (banded), 5e-15 (dense), up to 4.4e-12 (complex: round-off of the
    non-symmetric eigendecomposition of the 34 x 34 state matrix, whose poles span 3.7 Hz to
    7.5 kHz). The required 1e-10 is 20x above the worst.
    """
    ops, system = _system(model, tip_body)
    assert system.form == form
    s = FrequencyGrid(N_SAMPLES, 1 / FS).s
    r1, r2 = ops.rows([X1]), ops.rows([X2])
    h12 = system.transfer(s, r2, r1.T)[:, 0, 0]
    h21 = system.transfer(s, r1, r2.T)[:, 0, 0]
    assert np.max(np.abs(h12 - h21)) / np.max(np.abs(h12)) < 1e-10


@pytest.mark.parametrize("model, tip_body, form", CASES)
def test_responses_are_reciprocal(model, tip_body, form):
    """Displacement, velocity, acceleration at x2 for a random (white, seeded) force at x1 vs
    the swapped pair, relative to each output's peak.

    First half of the record: < 1e-10 (measured <= 2.7e-12). Whole record: < 1e-8 (measured
    <= 1.3e-9): the exponential window multiplies the output by e^(sigma t), up to e^18 at the
    end, so round-off differences between the two computations (1e-16) grow to ~1e-9 there, as
    the module docstring of bayesbeam.response.linear states ("near 1e-8 relative").
    """
    ops, system = _system(model, tip_body)
    force = np.random.default_rng(1989).standard_normal(N_SAMPLES)
    grid = FrequencyGrid(N_SAMPLES, 1 / FS)
    r1, r2 = ops.rows([X1])[0], ops.rows([X2])[0]
    y12 = force_response(system, grid, np.array([r2, r2, r2]), [0, 1, 2], r1, force)
    y21 = force_response(system, grid, np.array([r1, r1, r1]), [0, 1, 2], r2, force)
    rel = np.abs(y12 - y21) / np.max(np.abs(y12), axis=0)
    assert np.max(rel[: N_SAMPLES // 2]) < 1e-10
    assert np.max(rel) < 1e-8
