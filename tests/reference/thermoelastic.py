r"""Thermoelastic damping of a beam from heat conduction across its thickness, solved exactly.

A beam of thickness h (coordinate z across it, |z| <= h/2) bends with curvature kappa(t); the fibre
at z strains by eps = -z kappa. The uniaxial stress is sigma = E (eps - alpha_T theta), theta the
temperature rise over T0, and the heat equation with the thermoelastic source (heat capacity C
per unit volume; C at constant strain and rho c_p differ by a fraction of order Delta, ~1e-3) is

.. math:: C\,\theta_t = k\,\theta_{zz} - E\alpha_T T_0\,\varepsilon_t
          \quad\Longrightarrow\quad \theta_t = \chi\,\theta_{zz} + b\,z\,\kappa_t,
          \qquad b = \frac{E\alpha_T T_0}{C},\ \chi = \frac{k}{C},

with insulated faces, :math:`\theta_z(\pm h/2) = 0` (heat leaves the faces far more slowly than it
crosses the thickness). The moment :math:`M = -\int \sigma z\,dA = EI\kappa + E\alpha_T w\int\theta z\,dz`
(w the width). From rest, in Laplace (m^2 = s/chi),

.. math:: \Theta(z) = b\,K\left(z - \frac{\sinh mz}{m\cosh(mh/2)}\right), \qquad
          \int_{-h/2}^{h/2} z\,\Theta\,dz = b\,K\left(\frac{h^3}{12} - \frac{h}{m^2}
          + \frac{2\tanh(mh/2)}{m^3}\right),

so with :math:`\Delta = E\alpha_T^2 T_0/C` and :math:`\xi = h\sqrt{s/\chi}` the moment is
:math:`M = EI\,[1 + \Delta\,(1 - f)]\,K` with

.. math:: f(\xi) = \frac{24}{\xi^3}\left(\frac{\xi}{2} - \tanh\frac{\xi}{2}\right),

Lifshitz & Roukes' (Phys. Rev. B 61, 5600 (2000), Eq. 9) f(omega) at s = i omega (theirs is
written with tan of k b/2, k = (1 - i) sqrt(omega/(2 chi)), the same function). f(0) = 1 (the
isothermal modulus E), f(inf) = 0 (the adiabatic E (1 + Delta)); :math:`1 - f = \xi^2/10 - 17\xi^4/1680 + \dots`

The partial fractions :math:`\tanh(x) = \sum_{n\,\mathrm{odd}} 8x/(4x^2 + n^2\pi^2)` with
:math:`\sum_{n\,\mathrm{odd}} n^{-2} = \pi^2/8` and :math:`\sum_{n\,\mathrm{odd}} n^{-4} = \pi^4/96` turn this into
the thermal modes of the insulated slab (the eigenfunctions odd in z, sin(n pi z/h) with n odd):

.. math:: 1 - f = \sum_{n\,\mathrm{odd}} w_n\,\frac{s}{s + r_n}, \qquad
          w_n = \frac{96}{\pi^4 n^4}, \qquad r_n = \frac{n^2\pi^2\chi}{h^2} = \frac{n^2}{\tau_T},

tau_T = h^2/(pi^2 chi) the slowest mode's time, which carries 96/pi^4 = 98.6 % of the strength:
Zener's single term is this series' first. :func:`thermal_modes` keeps the first ``n_modes`` odd
modes and lumps the rest into one exponential whose c/r and c/r^2 match the tail's sums of
w_n/r_n and w_n/r_n^2 (summed term by term; the full sums are pi^2 tau_T/10 and
17 pi^4 tau_T^2/1680, the xi^2 and xi^4 terms above): the tail's rates lie far above the band,
where :math:`s/(s + r) = s/r - s^2/r^2 + O((s/r)^3)`, so what remains is of order
:math:`w_N\,(|s|\tau_T/N^2)^3` with N = 2 n_modes + 1.
"""
from __future__ import annotations

import numpy as np

#: odd thermal modes kept one by one (the rest lumped): the tail then starts at n = 21, rate
#: 441 / tau_T, and the sum errs from 1 - f by 1e-11 for |s| tau_T <= 10 and 1e-8 up to 100
#: (measured; tests/reference/test_thermoelastic.py bounds it)
THERMAL_MODES = 10
#: odd modes summed for the lumped tail's two sums
TAIL_TERMS = 100_000


def slab_response(s, tau_T: float) -> np.ndarray:
    """1 - f(xi) at complex frequencies s (1/s), xi^2 = s h^2/chi = pi^2 s tau_T: the relaxing part
    of the bending stiffness over EI Delta (dimensionless), in closed form (module docstring)."""
    xi = np.pi * np.sqrt(np.asarray(s, dtype=complex) * tau_T)
    return 1.0 - 24.0 / xi**3 * (xi / 2 - np.tanh(xi / 2))


def thermal_modes(tau_T: float, n_modes: int = THERMAL_MODES) -> tuple[np.ndarray, np.ndarray]:
    """(weights w_n, rates r_n in 1/s) of 1 - f: the first ``n_modes`` odd modes of the slab whose
    slowest time is tau_T (s), then one exponential for the rest (module docstring)."""
    n = 2.0 * np.arange(n_modes) + 1.0
    weights, rates = 96.0 / (np.pi**4 * n**4), n**2 / tau_T
    # the tail term by term (no cancellation against the closed-form sums): beyond TAIL_TERMS odd
    # modes its sums are below 1e-25 of the first tail term's
    tail = 2.0 * np.arange(n_modes, n_modes + TAIL_TERMS) + 1.0
    first = np.sum(96.0 / np.pi**4 * tau_T / tail[::-1] ** 6)            # sum of w/r (s)
    second = np.sum(96.0 / np.pi**4 * tau_T**2 / tail[::-1] ** 8)        # sum of w/r^2 (s^2)
    # one term c s/(s + r) ~ c s/r - c s^2/r^2: c/r = first, c/r^2 = second
    return np.append(weights, first**2 / second), np.append(rates, first / second)
