r"""The beam with a relaxing bending moment (:mod:`tests.reference.relaxation`) as linear blocks.

In a basis :math:`\Phi` of the finite-element dofs (:math:`w = \Phi q`) the state is
:math:`(q, \dot q, z_1, \dots, z_J)`, each m long, and

.. math:: M_r\ddot q + D_r\dot q + K_r q + \sum_j c_j C_r z_j = \Phi^T b\,f(t),\qquad
          \dot z_j = \dot q - r_j z_j,

with :math:`M_r = \Phi^T M\Phi`, :math:`D_r`, :math:`K_r` likewise and :math:`C_r = \Phi^T K_0\Phi`
(the relaxing moment's weak form is the elastic one's, :math:`\int z_{xx}\psi''`). Two bases:

* all finite-element dofs (:math:`\Phi = I`) when only exponential relaxation or Zener's solid is
  present: one or two terms, no modal truncation (3n or 4n states for n dofs);
* the undamped modes of (K, M) below a cut-off for the fractional quadrature's dozens of terms
  and the thermal modes of the solved thermoelastic damping:
  one block per mode when :math:`D_r` and :math:`C_r` are diagonal (a bare or tip-loaded beam, with
  air or strain rate), else one block of all kept modes (a root spring or an axial load couples
  them through :math:`C_r`).
"""
from __future__ import annotations

import numpy as np

from .relaxation import Relaxation, relaxation_of
from .system import MAX_COUPLED_STATES, Blocks, Matrices, _is_diagonal, _readout, undamped_modes

#: relaxation terms simulated on every finite-element dof (exponential relaxation and Zener's solid
#: together); more terms run in the undamped modes
FULL_BASIS_TERMS = 2


def _block(case, mesh, relax: Relaxation, phi, mass, damping, stiffness, curvature, load):
    """(A, B, C, F) of the basis ``phi`` (n_dof, m) with its reduced matrices (m, m) and load (m,)."""
    m, n_terms = phi.shape[1], relax.rates.size
    ns = m * (2 + n_terms)
    A, B = np.zeros((ns, ns)), np.zeros(ns)
    A[:m, m : 2 * m] = np.eye(m)
    A[m : 2 * m, :m] = -np.linalg.solve(mass, stiffness)
    A[m : 2 * m, m : 2 * m] = -np.linalg.solve(mass, damping)
    per_term = -np.linalg.solve(mass, curvature)
    A[m : 2 * m, 2 * m :] = np.hstack([c * per_term for c in relax.weights])
    A[2 * m :, m : 2 * m] = np.tile(np.eye(m), (n_terms, 1))
    A[2 * m :, 2 * m :] = -np.diag(np.repeat(relax.rates, m))
    B[m : 2 * m] = np.linalg.solve(mass, load)
    disp = np.hstack([phi, np.zeros((phi.shape[0], ns - m))])
    vel = np.hstack([np.zeros((phi.shape[0], m)), phi, np.zeros((phi.shape[0], ns - 2 * m))])
    return (A, B, *_readout(case, mesh, A, B, disp, vel))


def relaxation_blocks(case, mats: Matrices, load_at: float, omega_cut: float, du: float = 0.5) -> Blocks:
    """Blocks of ``case`` (a BeamCase with a relaxing moment), unit force at ``load_at`` (m): all
    dofs with one or two terms (exponential, Zener), else the modes below ``omega_cut`` (rad/s), the
    fractional quadrature (step ``du``) covering the first mode to omega_cut."""
    omega, phi = undamped_modes(mats)
    relax = relaxation_of(case.damping, case.EI, omega[0], omega_cut, du)
    load = mats.mesh.rows([load_at])[0]
    if relax.rates.size <= FULL_BASIS_TERMS:
        block = _block(case, mats.mesh, relax, np.eye(mats.mesh.n_dof), mats.M, mats.D, mats.K, mats.K0, load)
        A, B, C, F = (np.asarray(part)[None] for part in block)
        return Blocks(A, B, C, F[0])
    keep = omega <= omega_cut
    omega, phi = omega[keep], phi[:, keep]
    damping, curvature = phi.T @ mats.D @ phi, phi.T @ mats.K0 @ phi
    coupled = not (_is_diagonal(damping) and _is_diagonal(curvature))
    if coupled and omega.size * (2 + relax.rates.size) > MAX_COUPLED_STATES:
        raise ValueError(f"fractional or solved thermoelastic damping with modes coupled by a root spring, an axial load or the damping "
                         f"needs one block of {omega.size * (2 + relax.rates.size)} states, over "
                         f"{MAX_COUPLED_STATES}. Fix: keep fewer modes or rates, e.g. Numerics(omega_cut=2 * pi * "
                         "2000, du=0.7).")
    groups = [np.arange(omega.size)] if coupled else [np.array([k]) for k in range(omega.size)]
    blocks = [_block(case, mats.mesh, relax, phi[:, g], np.eye(g.size), damping[np.ix_(g, g)],
                     np.diag(omega[g] ** 2), curvature[np.ix_(g, g)], phi[:, g].T @ load) for g in groups]
    A, B, C, F = (np.stack(parts) for parts in zip(*blocks))
    return Blocks(A, B, C, F.sum(axis=0))
