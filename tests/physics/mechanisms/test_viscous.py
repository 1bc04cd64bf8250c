"""Air and Kelvin-Voigt damping against the closed-form modal damping of eq. (26)."""
import numpy as np
import pytest

from bayesbeam.physics.assembly import BeamOperators
from bayesbeam.physics.basis import SplineBasis
from bayesbeam.physics.mechanisms import REGISTRY
from bayesbeam.response.system import SecondOrderSystem

from tests.physics.test_assembly import exact_clamped_free


@pytest.mark.parametrize("gamma, cdI", [(1.7561, 2.05e5 * 1.64e-9), (0.3, 7e-5), (0.0, 1e-4), (0.5, 0.0)])
def test_q1_damping_ratios_match_eq26(gamma, cdI):
    """zeta_m = (gamma/rhoA + cdI beta_m^4/rhoA) / (2 omega_m), omega_m^2 = EI beta_m^4/rhoA.

    Paper beam (Table 1), no tip body, N = 32: the only error is the spline error of beta_m^4
    (< 1e-3 for the first 9 modes), which enters zeta at the same relative size: tolerance 2e-3.
    """
    rho_a, EI = 1710 * 0.597e-3, 2.68e10 * 1.64e-9
    ops = BeamOperators(SplineBasis(1.0, 32), rho_a)
    values = {"gamma": gamma, "cdI": cdI}
    damping = REGISTRY["air"].damping(ops, values) + REGISTRY["strain_rate"].damping(ops, values)
    poles = SecondOrderSystem(ops.M, damping, EI * ops.K0).poles()[:9]
    b4 = exact_clamped_free(9) ** 4
    omega = np.sqrt(EI * b4 / rho_a)
    zeta = (gamma / rho_a + cdI * b4 / rho_a) / (2 * omega)
    np.testing.assert_allclose(-poles.real / np.abs(poles), zeta, rtol=2e-3)
    np.testing.assert_allclose(np.abs(poles), omega, rtol=1e-3)


def test_air_damping_matrix_is_gamma_times_beam_mass():
    ops = BeamOperators(SplineBasis(1.0, 8), rho_a=2.0, m_T=0.5)
    np.testing.assert_allclose(REGISTRY["air"].damping(ops, {"gamma": 0.3}), 0.3 * ops.M0)
