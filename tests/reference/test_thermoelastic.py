"""The reference's solved thermoelastic damping (:mod:`tests.reference.thermoelastic`) against the
heat equation and Lifshitz & Roukes (Phys. Rev. B 61, 5600 (2000)).

* the closed form 1 - f(xi) is the heat equation's: a finite-volume solution of the insulated
  slab driven by the strain rate, across the thickness on its own;
* it is Lifshitz & Roukes' modulus E_omega = E [1 + Delta (1 + f_LR(omega))] (their f written with
  tan and k = (1 - i) sqrt(omega/(2 chi))) and its imaginary part their loss Q^-1 / Delta;
* the sum of exponentials (the slab's odd thermal modes, weights 96/(pi^4 n^4), rates n^2/tau_T,
  a lumped tail) is the closed form;
* each mode of a strip simulated with it has the pole of the exact characteristic equation
  s^2 + omega_m^2 (1 + Delta (1 - f(s))) = 0 and the damping ratio Q^-1(omega_m)/2.

Dimensionless throughout: xi^2 = s h^2/chi = pi^2 s tau_T with tau_T = h^2/(pi^2 chi).
"""
from __future__ import annotations

import numpy as np
from scipy.linalg import solve_banded

from bayesbeam.io import Beam
from tests.reference.relaxation import heat_conduction, zener
from tests.reference.test_literature import case_of, damping_ratio, newton, oscillatory_poles
from tests.reference.thermoelastic import slab_response, thermal_modes

#: a 1 mm 6061-T6 strip at 293 K (AA typical constants: tests/acceptance/test_thermoelastic_reference.py)
STRIP = Beam(0.3, 2700.0, 2.5e-5, 2.5e-2 * 1e-3**3 / 12, 68.9e9)
DELTA, TAU = 68.9e9 * 23.6e-6**2 * 293.0 / (2700.0 * 896.0), 1e-3**2 / (np.pi**2 * 167.0 / (2700.0 * 896.0))
#: omega tau_T from below the first mode of any test beam to ten times the relaxation
OMEGA_TAU = np.geomspace(1e-3, 10.0, 801)


def heat_equation_moment(xi2: complex, cells: int) -> complex:
    """12 int z theta dz over the slab |z| <= 1/2 of xi^2 theta - theta'' = xi^2 z, theta' = 0 at the
    faces (the temperature per unit b K h of the module docstring of tests.reference.thermoelastic),
    by cell-centred finite volumes: second order in the cell size."""
    d = 1.0 / cells
    z = (np.arange(cells) + 0.5) * d - 0.5
    main = np.full(cells, xi2 + 2.0 / d**2, dtype=complex)
    main[[0, -1]] -= 1.0 / d**2                     # no flux through the faces
    off = np.full(cells, -1.0 / d**2, dtype=complex)
    theta = solve_banded((1, 1), np.array([off, main, off]), xi2 * z)
    return 12.0 * np.sum(z * theta) * d


def test_closed_form_solves_the_heat_equation_across_the_thickness():
    """Finite volumes on 800 and 1600 cells, Richardson-extrapolated (error O(cells^-4): measured
    below 1.1e-12 from omega tau = 0.01 to 10; 3e-7 on 1600 cells alone), against 1 - f(xi): bound
    1e-9. A moment integral or a boundary condition taken wrongly (a fixed face temperature, tan
    for tanh) misses by order 1."""
    for wt in (0.01, 0.1, 0.5, 1.0, 3.0, 10.0):
        xi2 = 1j * np.pi**2 * wt
        coarse, fine = heat_equation_moment(xi2, 800), heat_equation_moment(xi2, 1600)
        solved = (4 * fine - coarse) / 3
        assert abs(solved - slab_response(1j * wt, 1.0)) < 1e-9, (wt, solved, slab_response(1j * wt, 1.0))


def test_closed_form_is_lifshitz_and_roukes_modulus_and_loss():
    """Their E_omega = E [1 + Delta (1 + f_LR)], f_LR = 24/(b k)^3 (b k/2 - tan(b k/2)),
    k = (1 - i) sqrt(omega/(2 chi)), b the thickness; and Q^-1 = Delta (6/x^2 - 6/x^3 (sinh x + sin x)/
    (cosh x + cos x)), x = b sqrt(omega/(2 chi)), the imaginary part to first order in Delta.
    The same functions written differently: agreement to rounding (measured 7e-13: the cancellation
    in xi/2 - tanh(xi/2) at the low end), bound 1e-11."""
    h, chi = 1.0, 1.0 / np.pi**2                 # tau_T = h^2/(pi^2 chi) = 1
    omega = OMEGA_TAU
    bk = (1 - 1j) * np.sqrt(omega / (2 * chi)) * h
    f_lr = 24 / bk**3 * (bk / 2 - np.tan(bk / 2))
    assert np.max(np.abs((1 + f_lr) - slab_response(1j * omega, 1.0))) < 1e-11
    x = h * np.sqrt(omega / (2 * chi))
    loss = 6 / x**2 - 6 / x**3 * (np.sinh(x) + np.sin(x)) / (np.cosh(x) + np.cos(x))
    assert np.max(np.abs(loss - slab_response(1j * omega, 1.0).imag)) < 1e-11


def test_thermal_modes_are_the_closed_form():
    """The ten odd modes and the lumped tail against 1 - f at s = i omega: measured 8e-12 up to
    omega tau = 10 and 8e-9 up to 100; bounds 1e-10 and 1e-7. Without the tail term the sum misses
    by 3e-7, and Zener's single term by 9e-3 at omega tau = 1 (the loss peak is 0.5): the series is
    what is tested, not its first term. The first 5000 modes' weights sum to
    one (the adiabatic limit, f(inf) = 0; the rest is 1e-12) and the weights over the rates to
    pi^2 tau/10 (1 - f = xi^2/10 + ...); the lumped tail keeps the latter (its weight is chosen for
    c/r and c/r^2, not for the sum of weights, which it misses by 3e-6)."""
    weights, rates = thermal_modes(1.0, 5000)
    assert abs(weights[:-1].sum() - 1) < 1e-11
    weights, rates = thermal_modes(1.0)
    assert abs(np.sum(weights / rates) - np.pi**2 / 10) < 1e-14
    series = heat_conduction(1.0, 1.0, 1.0)
    exact = slab_response(1j * OMEGA_TAU, 1.0)
    assert np.max(np.abs(series.transform(1j * OMEGA_TAU) - exact)) < 1e-10
    wide = np.geomspace(10.0, 100.0, 201)
    assert np.max(np.abs(series.transform(1j * wide) - slab_response(1j * wide, 1.0))) < 1e-7
    single = zener(1.0, 1.0, 1.0).transform(1j * OMEGA_TAU)
    assert np.max(np.abs(single - exact)) > 4e-3                   # the test can tell the two apart


def test_each_modes_damping_is_the_exact_thermoelastic_loss():
    """The 1 mm strip with Delta = 4.6e-3, tau = 1.5 ms (peak at 108 Hz): per mode (modes 1-6,
    9-770 Hz) the reference blocks' pole solves s^2 + omega_m^2 (1 + Delta (1 - f(s))) = 0 (the bare
    beam's modes decouple: its curvature matrix is its stiffness over EI) to the eigensolver's
    rounding and the tail's error (measured 2.5e-12; bound 1e-9), and its
    damping ratio is Q^-1(omega_m)/2 = Delta Im(1 - f)/2 within 2 Delta relative (first order in
    Delta; the exact ratio's denominator is 1 + Delta Re(1 - f): measured -0.95 Delta at mode 6)."""
    case = case_of(STRIP, damping={"Delta_slab": DELTA, "tau_slab": TAU})
    omega, poles = oscillatory_poles(case)
    exact = np.array([newton(lambda s, w=w: s**2 + w**2 * (1 + DELTA * slab_response(s, TAU)), 1j * w)
                      for w in omega])
    assert np.max(np.abs(poles / exact - 1)) < 1e-9, np.abs(poles / exact - 1)
    loss = DELTA * slab_response(1j * np.abs(poles), TAU).imag
    assert np.all(np.abs(damping_ratio(poles) / (loss / 2) - 1) < 2 * DELTA), (damping_ratio(poles), loss / 2)
