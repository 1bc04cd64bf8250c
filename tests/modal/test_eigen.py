"""Cantilever eigenvalues: Table 2, the characteristic equations, and provable limits."""

import csv
from pathlib import Path

import numpy as np
import pytest
from scipy.optimize import brentq

from bayesbeam.modal.eigen import (
    clamped_free_betas,
    natural_frequencies_hz,
    tip_body_betas,
    tip_body_determinant,
)

TABLE2 = Path(__file__).resolve().parents[2] / "data" / "paper" / "table2_eigenvalues.csv"


# Characteristic equations of the limiting problems, divided by cosh b. Their roots are
# found independently of the tip-body code.
def _clamped_pinned(b):  # tip cannot translate: tan b = tanh b
    return np.sin(b) - np.cos(b) * np.tanh(b)


def _clamped_guided(b):  # tip cannot rotate, shear free: tan b = -tanh b
    return np.sin(b) + np.cos(b) * np.tanh(b)


def _clamped_clamped(b):  # 1 - cos b cosh b = 0
    return 1 / np.cosh(b) - np.cos(b)


def _roots_of(f, n):
    grid = np.linspace(0.5, (n + 2) * np.pi, 20000)
    v = f(grid)
    idx = np.flatnonzero(np.sign(v[:-1]) != np.sign(v[1:]))
    return np.array([brentq(f, grid[k], grid[k + 1], xtol=1e-14) for k in idx[:n]])


def test_betas_match_table2_to_printed_decimals():
    with TABLE2.open() as fh:
        printed = np.array([float(row["beta_l"]) for row in csv.DictReader(fh)])
    # Table 2 prints 3 decimals, so rounding our root to 3 decimals must give it exactly.
    assert np.array_equal(np.round(clamped_free_betas(len(printed)), 3), printed)


def test_bare_roots_solve_equation_up_to_mode_30():
    b = clamped_free_betas(30)
    # cos b + 1/cosh b is O(1)-scaled, so 1e-12 is a few ulps of its derivative (~1).
    assert np.max(np.abs(np.cos(b) + 1 / np.cosh(b))) < 1e-12
    asymptote = (2 * np.arange(1, 31) - 1) * np.pi / 2
    # The gap to the asymptote decays like 2 exp(-b); by mode 10 it is below 1e-12.
    assert np.all(np.abs(b - asymptote)[9:] < 1e-12)
    assert np.all(np.diff(b) > 0)


def _clamped_free(b):  # 1 + cos b cosh b = 0, divided by cosh b
    return np.cos(b) + 1 / np.cosh(b)


#: the first clamped-free roots as the vibration literature tabulates them, to 10 decimals
PUBLISHED_CLAMPED_FREE = [1.8751040687, 4.6940911330, 7.8547574382, 10.9955407349]


def test_zero_tip_body_is_the_bare_cantilever():
    """Without a tip body the roots are those of cosh b cos b = -1, found here by brentq on the
    characteristic equation, apart from the module's own root finder. The independent roots
    reproduce the published ones to their 10 printed decimals (bound 6e-11: half a unit in the
    last place plus brentq's 1e-14); both tip-body routes meet them to 1e-12 (the exact zero)
    and 1e-9 (a tip body of 1e-12 kg shifts the roots by ~1e-12, the scan's tolerance is 1e-9)."""
    expected = _roots_of(_clamped_free, 8)
    np.testing.assert_allclose(expected[:4], PUBLISHED_CLAMPED_FREE, rtol=0, atol=6e-11)
    np.testing.assert_allclose(tip_body_betas(8, rho_a=1.02, length=1.0, m_T=0.0, J=0.0), expected, rtol=0, atol=1e-12)
    # A vanishing but non-zero tip body goes through the scan path.
    tiny = tip_body_betas(8, rho_a=1.02, length=1.0, m_T=1e-12, J=1e-15)
    np.testing.assert_allclose(tiny, expected, rtol=0, atol=1e-9)


@pytest.mark.parametrize("mu, j", [(0.3, 0.0), (0.0, 0.05), (1.0, 0.2), (5.0, 0.01)])
def test_tip_body_roots_match_brute_force_sign_changes(mu, j):
    rho_a, length = 1.3, 0.8
    b = tip_body_betas(5, rho_a=rho_a, length=length, m_T=mu * rho_a * length, J=j * rho_a * length**3)
    # Independent check: the raw (unscaled) determinant on a 1e-4 grid.
    grid = np.arange(1e-4, b[-1] + 0.5, 1e-4)
    raw = tip_body_determinant(grid, mu, j, scaled=False)
    brute = grid[np.flatnonzero(np.sign(raw[:-1]) != np.sign(raw[1:]))][:5]
    # A sign change pins a root to within one grid step.
    np.testing.assert_allclose(b, brute, atol=1e-4)


def test_tip_body_lowers_every_root():
    # Rayleigh: more mass, same stiffness -> no eigenvalue rises.
    bare = clamped_free_betas(6)
    heavy = tip_body_betas(6, rho_a=1.0, length=1.0, m_T=0.5, J=0.02)
    assert np.all(heavy < bare)


def test_heavy_tip_mass_limit():
    mu = 1e3
    b = tip_body_betas(5, rho_a=1.0, length=1.0, m_T=mu, J=0.0)
    # Lowest mode: the beam is a spring 3EI/l^3 carrying m_T plus 33/140 of its own mass
    # (Rayleigh quotient with the static tip-load shape); error is O(mu^-2), ~1.6e-9 here.
    assert abs(b[0] ** 4 * (mu + 33 / 140) / 3 - 1) < 1e-8
    # Higher modes: the tip cannot translate -> clamped-pinned roots, error O(1/mu).
    np.testing.assert_allclose(b[1:], _roots_of(_clamped_pinned, 4), rtol=5e-3)


def test_heavy_tip_inertia_limit():
    j = 1e3
    b = tip_body_betas(5, rho_a=1.0, length=1.0, m_T=0.0, J=j)
    # Lowest mode: rotational spring EI/l carrying J plus 1/20 rho_a l^3 (Rayleigh).
    assert abs(b[0] ** 4 * (j + 1 / 20) - 1) < 1e-8
    # Higher modes: the tip slides without rotating -> clamped-guided roots.
    np.testing.assert_allclose(b[1:], _roots_of(_clamped_guided, 4), rtol=5e-3)


def test_heavy_tip_body_limit_is_clamped_clamped():
    b = tip_body_betas(6, rho_a=1.0, length=1.0, m_T=1e4, J=1e4)
    np.testing.assert_allclose(b[2:], _roots_of(_clamped_clamped, 4), rtol=1e-3)


def test_natural_frequencies_scale_as_expected():
    EI, rho_a = 2.68e10 * 1.64e-9, 1710 * 0.597e-3
    f1 = natural_frequencies_hz(3, EI=EI, rho_a=rho_a, length=1.0)
    expected = clamped_free_betas(3) ** 2 * np.sqrt(EI / rho_a) / (2 * np.pi)
    np.testing.assert_allclose(f1, expected, rtol=1e-14)
    # Doubling the length at fixed mass and inertia *ratios* divides every frequency by 4.
    f_short = natural_frequencies_hz(3, EI=EI, rho_a=rho_a, length=1.0, m_T=0.2 * rho_a, J=0.01 * rho_a)
    f_long = natural_frequencies_hz(3, EI=EI, rho_a=rho_a, length=2.0, m_T=0.4 * rho_a, J=0.08 * rho_a)
    np.testing.assert_allclose(f_long, f_short / 4, rtol=1e-12)


def test_rejects_nonsense():
    with pytest.raises(ValueError):
        clamped_free_betas(0)
    with pytest.raises(ValueError):
        tip_body_betas(3, rho_a=1.0, length=1.0, m_T=-1.0, J=0.0)
    with pytest.raises(ValueError):
        natural_frequencies_hz(3, EI=0.0, rho_a=1.0, length=1.0)
