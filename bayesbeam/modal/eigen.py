"""Eigenvalues of the uniform Euler-Bernoulli cantilever, bare or with a tip body.

The undamped beam ``EI u_xxxx + rho_a u_tt = 0`` with ``u = phi(x) exp(i omega t)``
gives ``phi'''' = beta^4 phi`` with ``beta^4 = rho_a omega^2 / EI`` (paper eq. 21).
Everything here works with the dimensionless ``b = beta * l`` ("beta l"), which is
what Table 2 of Banks & Inman (1989) lists (they take l = 1 m).

Clamped-free, no tip body (Table 2)::

    1 + cos(b) cosh(b) = 0.

Clamped at x = 0, tip body of mass m_T (kg) and rotary inertia J (kg m^2) at x = l.
The paper's boundary conditions (4)-(5),

    EI u_xx(l) = -J u_xtt(l),        (EI u_xx)_x(l) = m_T u_tt(l),

become, for a harmonic motion, ``EI phi''(l) = J omega^2 phi'(l)`` and
``EI phi'''(l) = -m_T omega^2 phi(l)`` (the same follows from the boundary terms of
the weak form ``int EI phi'' psi'' = omega^2 [int rho_a phi psi + m_T phi psi(l)
+ J phi' psi'(l)]``). With ``phi = A (cosh - cos) + B (sinh - sin)`` (which already
meets phi(0) = phi'(0) = 0), the mass ratio ``mu = m_T / (rho_a l)`` and the inertia
ratio ``j = J / (rho_a l^3)``, the 2x2 determinant is twice

    D(b) = 1 + c C + mu b (c S - s C) - j b^3 (s C + c S) + mu j b^4 (1 - c C),

with c, s = cos b, sin b and C, S = cosh b, sinh b. Limits used by the tests:
mu = j = 0 gives the bare cantilever; mu -> oo gives tan b = tanh b (clamped-pinned)
for all but the lowest root, which tends to 0 as b_1^4 ~ 3 / (mu + 33/140); j -> oo
gives tan b = -tanh b (clamped-guided, the tip slides without rotating) and
b_1^4 ~ 1 / (j + 1/20); both give 1 - c C = 0 (clamped-clamped) beyond two low roots.

Roots are found on scaled forms that stay O(1) for large b (``D / cosh`` and, with a
tip body, ``D / (cosh b (1 + mu b)(1 + j b^3))``), so 30 or more modes are no problem.
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import brentq

__all__ = [
    "clamped_free_betas",
    "natural_frequencies_hz",
    "tip_body_betas",
    "tip_body_determinant",
]

# Bracket half-width around the asymptote (2m - 1) pi / 2. The bare-cantilever root
# differs from the asymptote by at most 0.304 (m = 1); 1.0 < pi/2 keeps the bracket
# between two extrema of cos, where cos + 1/cosh is monotone and changes sign once.
_BARE_HALF_WIDTH = 1.0
# Scan step for the tip-body roots: a fraction of the asymptotic root spacing (pi),
# far below the smallest spacing between consecutive roots met in practice.
_SCAN_STEP = np.pi / 200.0
# Smallest b scanned: tip masses up to mu ~ 3e16 (b_1 ~ (3 / mu)^(1/4)) are covered.
_SCAN_START = 1e-4


def _bare_scaled(b: float) -> float:
    """``(1 + cos b cosh b) / cosh b = cos b + 1 / cosh b``; bounded for all b."""
    return np.cos(b) + 1.0 / np.cosh(b)


def clamped_free_betas(n: int) -> np.ndarray:
    """First ``n`` roots ``b = beta l`` of ``1 + cos b cosh b = 0`` (dimensionless).

    Each root is bracketed around its asymptote ``(2m - 1) pi / 2`` and polished with
    Brent's method on ``cos b + 1/cosh b`` to machine precision.
    """
    if n < 1:
        raise ValueError(f"n must be a positive number of modes, got {n}")
    roots = []
    for m in range(1, n + 1):
        guess = (2 * m - 1) * np.pi / 2
        lo, hi = max(guess - _BARE_HALF_WIDTH, 1e-9), guess + _BARE_HALF_WIDTH
        roots.append(brentq(_bare_scaled, lo, hi, xtol=1e-15, rtol=4 * np.finfo(float).eps))
    return np.array(roots)


def tip_body_determinant(b, mu: float, j: float, *, scaled: bool = True):
    """The frequency determinant ``D(b)`` of the clamped beam with a tip body.

    Parameters
    ----------
    b : float or array
        Dimensionless frequency parameter ``beta l``.
    mu, j : float
        Tip mass ratio ``m_T / (rho_a l)`` and inertia ratio ``J / (rho_a l^3)``.
    scaled : bool
        If True, return ``D / (cosh b (1 + mu b)(1 + j b^3))``, which has the same
        positive roots and stays bounded; if False, the raw ``D(b)`` (overflows for
        b beyond ~700, used by the tests as an independent brute-force check).
    """
    b = np.asarray(b, dtype=float)
    c, s = np.cos(b), np.sin(b)
    if not scaled:
        C, S = np.cosh(b), np.sinh(b)
        return 1 + c * C + mu * b * (c * S - s * C) - j * b**3 * (s * C + c * S) + mu * j * b**4 * (1 - c * C)
    sech, th = 1.0 / np.cosh(b), np.tanh(b)
    d = sech + c + mu * b * (c * th - s) - j * b**3 * (s + c * th) + mu * j * b**4 * (sech - c)
    return d / ((1 + mu * b) * (1 + j * b**3))


def tip_body_betas(n: int, *, rho_a: float, length: float, m_T: float, J: float) -> np.ndarray:
    """First ``n`` roots ``b = beta l`` for a cantilever carrying a tip body.

    Parameters (SI): ``rho_a`` mass per unit length (kg/m), ``length`` l (m), ``m_T``
    tip mass (kg), ``J`` tip rotary inertia about the beam's end (kg m^2).

    Adding mass or rotary inertia only lowers the eigenvalues (Rayleigh's min-max
    principle), so the n wanted roots lie below the bare cantilever's n-th root. The
    scaled determinant is sampled from 1e-4 (log-spaced at first, to catch the very low
    first root of a heavy tip body, ``b_1^4 ~ 3 / mu``) up to that bound in steps of
    pi/200, and every sign change is polished with Brent's method. Finding fewer than n
    sign changes raises. A double root, where D touches zero without changing sign,
    would be missed; the root-count check catches it only if it is among the first n.
    """
    if min(rho_a, length) <= 0 or min(m_T, J) < 0:
        raise ValueError("need rho_a > 0, length > 0, m_T >= 0 and J >= 0")
    if m_T == 0 and J == 0:
        return clamped_free_betas(n)
    mu, j = m_T / (rho_a * length), J / (rho_a * length**3)
    b_max = clamped_free_betas(n)[-1] + _SCAN_STEP
    grid = np.concatenate(
        [np.geomspace(_SCAN_START, _SCAN_STEP, 40)[:-1], np.arange(_SCAN_STEP, b_max, _SCAN_STEP)]
    )
    values = tip_body_determinant(grid, mu, j)
    changes = np.flatnonzero(np.sign(values[:-1]) * np.sign(values[1:]) < 0)
    roots = [brentq(tip_body_determinant, grid[k], grid[k + 1], args=(mu, j), xtol=1e-14) for k in changes]
    if len(roots) < n:
        raise RuntimeError(f"found {len(roots)} roots below b = {b_max:.3f}, expected {n}")
    return np.array(roots[:n])


def natural_frequencies_hz(
    n: int, *, EI: float, rho_a: float, length: float, m_T: float = 0.0, J: float = 0.0
) -> np.ndarray:
    """Undamped natural frequencies (Hz) of the first ``n`` modes.

    ``omega_m = (b_m / l)^2 sqrt(EI / rho_a)`` (paper eq. 25 with eq. 21), ``f = omega / 2 pi``;
    ``EI`` in N m^2, ``rho_a`` in kg/m, ``length`` in m, ``m_T`` in kg, ``J`` in kg m^2.
    """
    if EI <= 0:
        raise ValueError(f"EI must be positive, got {EI}")
    b = tip_body_betas(n, rho_a=rho_a, length=length, m_T=m_T, J=J)
    return (b / length) ** 2 * np.sqrt(EI / rho_a) / (2 * np.pi)
