r"""The literature's hereditary damping of the bending moment as internal variables (augmented state).

Each mechanism adds to the elastic moment :math:`EI\,u_{xx}` a relaxing part whose Laplace
transform (from rest) is :math:`R(s)\,U_{xx}(s)` with

.. math:: R(s) = \sum_j c_j\,\frac{s}{s + r_j},

c_j in N m^2, rates r_j in 1/s. Each term is one internal variable per curvature dof,
:math:`z_j' = u_{xxt} - r_j z_j` (:math:`z_j = s/(s + r_j)\,U_{xx}`), and the moment gains
:math:`\sum_j c_j z_j`. In the weak form, as for the elastic moment, the force is
:math:`\sum_j c_j K_0 z_j` with :math:`z_j` now vectors in the displacement dofs, so the
integro-differential equation becomes an ordinary linear one that the reference integrates
exactly (:mod:`tests.reference.integrate`); :math:`R(0) = 0`: the static stiffness stays EI.

* **Exponential relaxation** (moment :math:`\int c_e\mu e^{-\mu(t-\sigma)}u_{xxt}(\sigma)d\sigma`):
  one term, :math:`c = c_e\mu`, :math:`r = \mu` (the integral is the variable itself).
* **Zener's standard linear solid** (relaxed stiffness EI, relaxation strength Delta, time tau):
  :math:`M = EI\kappa + EI\Delta(\kappa - \varepsilon)`, :math:`\tau\varepsilon' = \kappa - \varepsilon`
  for the anelastic curvature :math:`\varepsilon`; the variable :math:`z = \kappa - \varepsilon`
  obeys :math:`z' = \kappa' - z/\tau`: one term, :math:`c = EI\Delta`, :math:`r = 1/\tau`.
* **Fractional Kelvin-Voigt** (moment :math:`c_f D^\nu u_{xx}`, transform :math:`c_f s^\nu`):
  for 0 < nu < 1, :math:`s^{\nu-1} = \frac{\sin\nu\pi}{\pi}\int_0^\infty \frac{r^{\nu-1}}{s + r}dr`
  (Stieltjes), so with :math:`r = e^u`

  .. math:: s^\nu = \frac{\sin\nu\pi}{\pi}\int_{-\infty}^{\infty} e^{\nu u}\,\frac{s}{s + e^u}\,du,

  a continuum of exponential relaxations. The trapezoidal rule in u (step du, nodes u_k) gives
  :math:`c_k = c_f\frac{\sin\nu\pi}{\pi}\,du\,e^{\nu u_k}`, :math:`r_k = e^{u_k}`; the integrand is
  analytic in the strip :math:`|\mathrm{Im}\,u| < \pi - |\arg s|` (its poles sit at
  :math:`e^u = -s`), about pi/2 for a lightly damped beam, so the error falls like
  :math:`e^{-\pi^2/du}`. The two tails beyond the rates :math:`[r_{lo}, r_{hi}]` are each kept as
  one more exponential whose weight and rate match the tail's first two moments in closed form:

  - low, :math:`r \ll |s|`: :math:`s/(s + r) \approx 1 - r/s`, moments
    :math:`\int_0^{r_{lo}} r^{\nu-1}dr = r_{lo}^\nu/\nu` and :math:`\int_0^{r_{lo}} r^\nu dr = r_{lo}^{\nu+1}/(\nu+1)`;
  - high, :math:`r \gg |s|`: :math:`s/(s + r) \approx s/r - s^2/r^2`, moments
    :math:`r_{hi}^{\nu-1}/(1-\nu)` and :math:`r_{hi}^{\nu-2}/(2-\nu)`;

  each moment scaled, as in :mod:`tests.reference.memory`, by the factor
  :math:`(k\,du/2)/\sinh(k\,du/2)` by which the midpoint rule misjudges
  :math:`\int e^{\mp k u}du` over a half-line, so that the tails stand for the rule's own cells and
  the truncated sum keeps the rule's accuracy. What remains is of the tails' third moment:
  :math:`(r_{lo}/|s|)^{\nu+2}` and :math:`(|s|/r_{hi})^{3-\nu}`.
* **Thermoelastic damping, solved** (:mod:`tests.reference.thermoelastic`: heat conduction across
  the thickness, the odd thermal modes of an insulated slab): strength Delta_slab and the slowest
  mode's time tau_slab = h^2/(pi^2 chi) give :math:`c_n = EI\,\Delta\,96/(\pi^4 n^4)`,
  :math:`r_n = n^2/\tau` for n = 1, 3, 5, ... and one lumped tail term: the exact response of
  Zener's physics, not his single term.

:meth:`Relaxation.transform` gives R(s) for the tests to compare with the closed forms.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .thermoelastic import thermal_modes

#: relaxation parameters of the bending moment (BeamCase damping keys), by mechanism
RELAXATION_KEYS = {"exponential": ("c_e", "mu"), "fractional": ("c_f", "nu"), "thermoelastic": ("Delta", "tau_T"),
                   "thermoelastic_slab": ("Delta_slab", "tau_slab")}


@dataclass(frozen=True)
class Relaxation:
    """R(s) = sum_j c_j s / (s + r_j): weights c_j (N m^2), rates r_j (1/s)."""

    weights: np.ndarray
    rates: np.ndarray

    def transform(self, s) -> np.ndarray:
        """R(s) (N m^2) at the complex frequencies s (1/s)."""
        s = np.asarray(s, dtype=complex)[..., None]
        return np.sum(self.weights * s / (s + self.rates), axis=-1)

    def __add__(self, other: Relaxation) -> Relaxation:
        return Relaxation(np.concatenate([self.weights, other.weights]), np.concatenate([self.rates, other.rates]))


def exponential(c_e: float, mu: float) -> Relaxation:
    """Moment int c_e mu e^{-mu (t - s)} u_xxt(s) ds: c_e in N m^2 s, mu in 1/s."""
    return Relaxation(np.array([c_e * mu]), np.array([mu]))


def zener(EI: float, Delta: float, tau_T: float) -> Relaxation:
    """Standard linear solid of relaxed stiffness EI (N m^2), strength Delta, relaxation time tau_T (s)."""
    return Relaxation(np.array([EI * Delta]), np.array([1.0 / tau_T]))


def heat_conduction(EI: float, Delta: float, tau_slab: float) -> Relaxation:
    """Thermoelastic relaxation of a beam of relaxed stiffness EI (N m^2) and strength Delta from the
    heat equation across its thickness, slowest thermal time tau_slab = h^2/(pi^2 chi) (s)."""
    weights, rates = thermal_modes(tau_slab)
    return Relaxation(EI * Delta * weights, rates)


@dataclass(frozen=True)
class FractionalQuadrature:
    """s^nu as exponential relaxations on rates [r_lo, r_hi] (1/s), trapezoid step du in log-rate."""

    nu: float
    r_lo: float
    r_hi: float
    du: float = 0.5

    def __post_init__(self):
        if not 0 < self.nu < 1:
            raise ValueError(f"fractional damping needs 0 < nu < 1, got nu = {self.nu} (nu = 1 is cdI)")

    @classmethod
    def covering(cls, nu: float, omega_lo: float, omega_hi: float, du: float = 0.5) -> FractionalQuadrature:
        """Rates from 1e-5 omega_lo to 1e4 omega_hi (rad/s): the tails' errors, (1e-5)^(nu+2) and
        (1e-4)^(3-nu) of |s|^nu, stay below 2e-9 for |s| between omega_lo and omega_hi. Wider
        ranges buy nothing in the time response: rates far above 1/h (h the fine step) leave
        rounding of ~1e-7 of the response in the exact stepping (1e6 omega_hi), against ~3e-9 here."""
        return cls(nu, 1e-5 * omega_lo, 1e4 * omega_hi, du)

    @property
    def u(self) -> np.ndarray:
        n = int(np.ceil(np.log(self.r_hi / self.r_lo) / self.du))
        return np.log(self.r_lo) + self.du * (np.arange(n) + 0.5)

    def _cells(self, k: float) -> float:
        """The midpoint rule's sum over a half-line of cells of exp(-k u), over its integral."""
        return (k * self.du / 2) / np.sinh(k * self.du / 2)

    def relaxation(self, c_f: float) -> Relaxation:
        """R(s) ~ c_f s^nu (c_f in N m^2 s^nu)."""
        nu, u = self.nu, self.u
        scale = c_f * np.sin(nu * np.pi) / np.pi
        low_end, high_end = u[0] - self.du / 2, u[-1] + self.du / 2
        lo0 = np.exp(nu * low_end) / nu * self._cells(nu)                        # int_0^r_lo r^(nu-1) dr
        lo1 = np.exp((nu + 1) * low_end) / (nu + 1) * self._cells(nu + 1)        # int_0^r_lo r^nu dr
        hi1 = np.exp((nu - 1) * high_end) / (1 - nu) * self._cells(1 - nu)       # int_r_hi r^(nu-2) dr
        hi2 = np.exp((nu - 2) * high_end) / (2 - nu) * self._cells(2 - nu)       # int_r_hi r^(nu-3) dr
        # low: c s/(s + r) ~ c - c r/s, so c = lo0, c r = lo1; high: ~ c s/r - c s^2/r^2, so
        # c/r = hi1, c/r^2 = hi2: r = hi1/hi2, c = hi1^2/hi2
        weights = np.concatenate([[lo0], self.du * np.exp(nu * u), [hi1**2 / hi2]])
        rates = np.concatenate([[lo1 / lo0], np.exp(u), [hi1 / hi2]])
        return Relaxation(scale * weights, rates)


def relaxation_of(damping: dict, EI: float, omega_lo: float, omega_hi: float, du: float) -> Relaxation | None:
    """The moment's relaxation R(s) of a BeamCase's ``damping`` (None without one); the fractional
    quadrature covers omega_lo..omega_hi (rad/s) with step du."""
    parts = []
    if "c_e" in damping:
        parts.append(exponential(damping["c_e"], damping["mu"]))
    if "Delta" in damping:
        parts.append(zener(EI, damping["Delta"], damping["tau_T"]))
    if "Delta_slab" in damping:
        parts.append(heat_conduction(EI, damping["Delta_slab"], damping["tau_slab"]))
    if "c_f" in damping:
        quadrature = FractionalQuadrature.covering(damping["nu"], omega_lo, omega_hi, du)
        parts.append(quadrature.relaxation(damping["c_f"]))
    if not parts:
        return None
    total = parts[0]
    for part in parts[1:]:
        total = total + part
    return total
