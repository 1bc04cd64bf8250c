"""Energy: conservation without damping, and the work-energy balance with each viscous mechanism.

All generalized displacements and velocities are output (rows = identity, orders 0 and 1), so
E(t) = 1/2 v^T M v + 1/2 w^T K w is known at every sample. The force is a Gaussian pulse of
std 16 samples at fs = 2048 Hz (spectrum exp(-(2 pi f std)^2 / 2): below 1e-20 from
200 Hz = 0.1 fs on), so every signal here is band-limited far below Nyquist and its samples
determine it exactly.
"""
import numpy as np
import pytest

from bayesbeam.physics.mechanisms import Air, SpatialHysteresis, StrainRate
from bayesbeam.response.linear import FrequencyGrid, force_response
from bayesbeam.response.system import SecondOrderSystem
from tests.galerkin_reference import EI, gaussian, paper_operators

FS, N_SAMPLES, X_FORCE = 2048.0, 4096, 0.75
DT = 1 / FS
T = DT * np.arange(N_SAMPLES)
PULSE_CENTRE, PULSE_STD = 0.1, 16 * DT
FORCE = gaussian(T, PULSE_CENTRE, PULSE_STD, peak=10.0)


def _outputs(ops, D, orders):
    """All dofs for each order in ``orders``: list of (n, dofs) arrays."""
    system = SecondOrderSystem(ops.M, D, EI * ops.K0)
    nd = ops.size
    rows = np.vstack([np.eye(nd)] * len(orders))
    order_list = [k for k in orders for _ in range(nd)]
    y = force_response(system, FrequencyGrid(N_SAMPLES, DT), rows, order_list,
                       ops.rows([X_FORCE])[0], FORCE)
    return system, [y[:, i * nd : (i + 1) * nd] for i in range(len(orders))]


def _energy(ops, w, v):
    K = EI * ops.K0
    return 0.5 * np.sum(v * (v @ ops.M), axis=1) + 0.5 * np.sum(w * (w @ K), axis=1)


@pytest.mark.parametrize("tip_body", [(0.0, 0.0), (0.2, 0.003)])
def test_undamped_energy_is_conserved(tip_body):
    """After the pulse (6 std past its centre) E(t) is constant: peak-to-peak / mean 2.6e-9
    (no tip body) and 4.4e-9 (tip body) measured, bound 1e-7 (the required accuracy). The exponential
    window amplifies round-off by up to e^18 ~ 7e7 towards the end of the record (1e-8
    relative), which the bound covers.
    The energy also equals the input work int f v(x_f) dt (trapezoid sum, exact for this
    band-limited integrand that vanishes at both ends): 3e-11 measured, same bound."""
    ops = paper_operators(16, *tip_body)
    system, (w, v) = _outputs(ops, 0 * ops.M, (0, 1))
    assert system.form == "diagonal"
    energy = _energy(ops, w, v)
    after = T > PULSE_CENTRE + 6 * PULSE_STD
    mean = energy[after].mean()
    assert np.ptp(energy[after]) / mean < 1e-7
    work = DT * np.sum(FORCE * (v @ ops.rows([X_FORCE])[0]))
    assert abs(work / mean - 1) < 1e-7


def _mechanisms(ops):
    mech = {
        "air": Air().damping(ops, {"gamma": 0.5}),                  # mode-1 damping ratio 1%
        "strain_rate": StrainRate().damping(ops, {"cdI": 6e-3}),    # mode-2 damping ratio 1%
        "spatial_hysteresis": SpatialHysteresis().damping(ops, {"a": 1.040394, "b": 0.064362}),
    }
    mech["combined"] = mech["air"] + mech["strain_rate"] + mech["spatial_hysteresis"]
    return mech


@pytest.mark.parametrize("name, tip_body", [
    ("air", (0.0, 0.0)), ("strain_rate", (0.0, 0.0)), ("spatial_hysteresis", (0.0, 0.0)),
    ("combined", (0.0, 0.0)), ("air", (0.2, 0.003)), ("combined", (0.2, 0.003)),
])
def test_energy_balance_with_damping(name, tip_body):
    """int_0^T f v(x_f) dt = E(T) + int_0^T v^T D v dt at the end of the 2 s record.

    The input work: the trapezoid sum of a band-limited integrand (bandwidth < fs) that
    vanishes at both ends is exact to round-off (its error is the
    integrand's spectrum at fs, below e^-1000). The dissipation integrand g = v^T D v is not
    zero at T: the trapezoid sum gets the Euler-Maclaurin end correction -dt^2/12 g'(T) with the
    exact g' = 2 v^T D a (acceleration output); what is left, dt^4/720 g'''(T), is below
    (2 omega_2 dt)^4 / 720 ~ 5e-7 of g'(T)-scale terms and in practice ~1e-9 (measured
    1.5e-10 to 1.5e-9 of the input work). Bound 1e-7 relative to the input work: 70x the
    largest measured value, 100x tighter than the required 1e-5, and far below the dissipated
    fraction (5% spatial hysteresis, 14% strain rate, 42-67% air and the combinations).
    """
    ops = paper_operators(16, *tip_body)
    D = _mechanisms(ops)[name]
    _, (w, v, a) = _outputs(ops, D, (0, 1, 2))
    work = DT * np.sum(FORCE * (v @ ops.rows([X_FORCE])[0]))
    g = np.sum(v * (v @ D), axis=1)
    g_dot = 2 * np.sum(v * (a @ D), axis=1)
    dissipated = DT * (np.sum(g) - 0.5 * (g[0] + g[-1])) - DT**2 / 12 * (g_dot[-1] - g_dot[0])
    final = _energy(ops, w[-1:], v[-1:])[0]
    assert dissipated > 0.04 * work, "the test must see the damping"
    assert abs((final + dissipated) / work - 1) < 1e-7
