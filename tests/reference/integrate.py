r"""Exact time stepping of the linear blocks under a piecewise-cubic force.

On each step [t_i, t_i + h] the force is the cubic Hermite interpolant of f and f' at the two ends
(error :math:`h^4 \max|f''''|/384`, the only approximation: the force is known analytically), and
the state moves by the exact solution of :math:`\dot x = A x + B f`:

.. math:: x_{i+1} = e^{Ah} x_i + \sum_{k=0}^{3} \Gamma_k\, d_k,\qquad
          \Gamma_k = \int_0^h e^{A(h-s)} B\, \frac{s^{3-k}}{(3-k)!}\, ds,

with :math:`f(t_i + s) = \sum_k d_k s^{3-k}/(3-k)!`. Both :math:`e^{Ah}` and the
:math:`\Gamma_k` are blocks of one matrix exponential of the system augmented with the
polynomial's generator (Van Loan's construction), so stiff modes far above 1/h are exact too.
"""
from __future__ import annotations

import numpy as np
from scipy import linalg

from .system import Blocks


def hold_matrices(blocks: Blocks, h: float) -> tuple[np.ndarray, np.ndarray]:
    """(e^{Ah} (nb, ns, ns), Gamma (nb, ns, 4)) for the step h (s)."""
    nb, ns, _ = blocks.A.shape
    big = np.zeros((nb, ns + 4, ns + 4))
    big[:, :ns, :ns] = blocks.A
    big[:, :ns, ns] = blocks.B
    for k in range(3):  # the generator of (p3, p2, p1, p0): p3' = p2, p2' = p1, p1' = p0
        big[:, ns + k, ns + k + 1] = 1.0
    expo = linalg.expm(big * h)
    return expo[:, :ns, :ns], expo[:, :ns, ns:]


def cubic_coefficients(f: np.ndarray, df: np.ndarray, h: float) -> np.ndarray:
    """d (n-1, 4) of each step's cubic Hermite interpolant: f(t_i + s) = d0 + d1 s + d2 s^2/2 + d3 s^3/6."""
    f0, f1, g0, g1 = f[:-1], f[1:], df[:-1], df[1:]
    c2 = (3 * (f1 - f0) / h - 2 * g0 - g1) / h
    c3 = (2 * (f0 - f1) / h + g0 + g1) / h**2
    return np.stack([f0, g0, 2 * c2, 6 * c3], axis=1)


def step(blocks: Blocks, h: float, x0: np.ndarray, f: np.ndarray, df: np.ndarray) -> np.ndarray:
    """Outputs (n, n_out) at the n grid times t_0 + i h, from state x0 (nb, ns) at t_0.

    ``f``, ``df``: the force (N) and its time derivative (N/s) at the grid times.
    """
    phi, gamma = hold_matrices(blocks, h)
    coefficients = cubic_coefficients(f, df, h)
    readout = blocks.C.transpose(1, 0, 2).reshape(blocks.F.size, -1)   # (n_out, nb * ns)
    out = np.empty((f.size, blocks.F.size))
    x = np.array(x0, dtype=float)[:, :, None]
    out[0] = readout @ x.ravel()
    for i in range(f.size - 1):
        x = phi @ x + gamma @ coefficients[i][:, None]
        out[i + 1] = readout @ x.ravel()
    return out + blocks.F[None, :] * f[:, None]


def propagate(blocks: Blocks, x0: np.ndarray, t: float) -> np.ndarray:
    """The free state (no force) a time t (s) after x0."""
    return np.einsum("bst,bt->bs", linalg.expm(blocks.A * t), x0)
