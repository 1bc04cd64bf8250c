"""The thermoelastic mechanism's prediction against heat conduction solved independently, with
handbook constants stated here (not bayesbeam's MATERIALS table).

Recordings: the reference simulator (:mod:`tests.reference`) with thermoelastic damping from the
heat equation across the thickness, solved (:mod:`tests.reference.thermoelastic`: the insulated
slab's odd thermal modes, checked against Lifshitz & Roukes' closed form in
tests/reference/test_thermoelastic.py), not Zener's single term. A clamped strip 0.3 m x 25 mm x
1 mm, no tip body, struck at 0.225 m by a 0.5 ms Gaussian pulse, tip accelerometer, 1 s at
1024 Hz, 2 % sensor and 0.5 % force noise, beam.toml's modulus 7 % above the truth. The fit is
``thermoelastic`` alone (EI and zener_scale kappa), N chosen automatically, on the default band
(0.38 fs: modes 1-4, 9-312 Hz), by the fit's own optimum and its Laplace covariance
(:func:`bayesbeam.inference.fit.choose_discretisation`): the 99 % interval of kappa is
exp(log kappa +- 2.576 sd). kappa is determined to 0.2 % (aluminium) and 1 % (steel) in log sd;
the 0.5 and 99.5 % quantiles of a 600-step emcee chain (16 walkers) agree with the Laplace
interval's ends to 5e-4 on both recordings (measured).

Constants (T0 = 293 K; Delta = E alpha_T^2 T0 / (rho c_p), chi = k / (rho c_p), tau = h^2/(pi^2 chi)):

* 6061-T6 aluminium, Aluminum Association typical values as MatWeb's data sheet "Aluminum
  6061-T6; 6061-T651" tabulates them: E = 68.9 GPa, rho = 2700 kg/m^3, alpha_T = 23.6e-6 1/K (mean,
  20-100 C), c_p = 896 J/(kg K), k = 167 W/(m K): Delta = 4.65e-3, tau = 1.47 ms (peak 108 Hz,
  between modes 2 and 3: zeta 0.02, 0.09, 0.11, 0.07 % for modes 1-4).
* plain carbon steel: rho = 7854 kg/m^3, c_p = 434 J/(kg K), k = 60.5 W/(m K) from Incropera &
  DeWitt, Fundamentals of Heat and Mass Transfer, Table A.1 ("Plain carbon steel", 300 K);
  E = 30e6 psi = 206.8 GPa and alpha_T = 6.7e-6 1/F = 12.06e-6 1/K (mean, 32-212 F) from Metal
  Suppliers Online, "Carbon Steels 1020": Delta = 2.5e-3, tau = 5.7 ms (peak 28 Hz, between
  modes 1 and 2).

What kappa should be. The package's model is Zener's single term with the whole Delta at the
slowest thermal time; the slab's series puts 98.6 % of Delta there and the rest at 9, 25, ...
times the rate. Per mode the two differ in loss (Im) and in stiffening (Re) by a ratio
series/single that :func:`single_term_ratios` computes from the reference alone: 0.986-0.998 on
the aluminium strip's modes 1-4 (below and around the peak), 0.986-1.06 on the steel strip's
(above it, where the series falls as omega^-1/2 and the single term as omega^-1). The fitted kappa
is a weighted mean of such per-mode ratios, so a correct package puts its interval across that
range: the test asserts the 99 % interval meets it. Measured: 0.993-1.004 and 1.022-1.074 (the
seeds, 31 and 32, fixed before the first run).

Power. kappa only scales the strength, so a strength off by a factor g moves the interval by
exactly 1/g (up to the prior's pull, a log-normal of sd 0.5, negligible at these widths); the test
asserts the interval is narrow enough that g = 1.3 or 1/1.3 moves it off the range. Applied to a
copy of the package, Delta x 1.3 in ``ZenerConstants.strength`` gives kappa = 0.766 and 0.80
(both fail).

The named material. A third recording's [material] says only ``name = "aluminium"`` (with the
test's temperature and thickness), so the package's own 6061-T6 constants predict the damping of
the beam made with the handbook's. Handbooks disagree: NIST's cryogenic curve fits for 6061-T6
at 293 K (alpha_T 22.6e-6, c_p 943, k 154, E 70.4 GPa) give a Delta 11 % below the Aluminum
Association's. So this asserts agreement within 12 %: the interval meets the range widened by
that factor. The package's 23e-6 gives kappa = 1.049 (alpha_T^2 5 % below the AA value); a
table constant off by Delta x 1.3 gives 0.81 and fails.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pytest

from bayesbeam.inference.fit import FitConfig, choose_discretisation
from bayesbeam.io import Beam
from tests.acceptance.cases import NOMINAL_OVER_TRUE
from tests.reference import BeamCase, Hammer, record
from tests.reference.recordings import NOISE
from tests.reference.relaxation import heat_conduction, zener
from tests.reference.system import matrices, undamped_modes

pytestmark = pytest.mark.slow  # three fits, about 10 s (docs/testing.md)

T0 = 293.0
LENGTH, WIDTH, THICKNESS = 0.3, 25e-3, 1e-3
FS, DURATION = 1024.0, 1.0
HAMMER = Hammer(0.75 * LENGTH, peak=1.0, width=5e-4, t0=5e-3)
#: the fit's default band, 0.38 fs
BAND = 0.38 * FS
#: two-sided 99 % normal quantile
Z99 = 2.576
#: a strength off by this factor (either way) must move the interval off the predicted range
POWER = 1.3
#: the handbooks' spread in Delta for 6061-T6 (AA typical against NIST at 293 K: 11 %)
HANDBOOK_SPREAD = 1.12


@dataclass(frozen=True)
class Handbook:
    """A material's constants: E (Pa), rho (kg/m^3), alpha_T (1/K), c_p (J/(kg K)), k (W/(m K))."""

    E: float
    rho: float
    alpha_T: float
    c_p: float
    k: float

    @property
    def chi(self) -> float:
        """Thermal diffusivity k/(rho c_p), m^2/s."""
        return self.k / (self.rho * self.c_p)

    @property
    def Delta(self) -> float:
        """Zener's relaxation strength E alpha_T^2 T0/(rho c_p) at T0."""
        return self.E * self.alpha_T**2 * T0 / (self.rho * self.c_p)

    @property
    def tau(self) -> float:
        """The slowest thermal time across the strip, h^2/(pi^2 chi), s."""
        return THICKNESS**2 / (np.pi**2 * self.chi)


HANDBOOKS = {
    # Aluminum Association typical values (MatWeb, "Aluminum 6061-T6; 6061-T651")
    "6061-T6": Handbook(E=68.9e9, rho=2700.0, alpha_T=23.6e-6, c_p=896.0, k=167.0),
    # Incropera & DeWitt Table A.1, plain carbon steel at 300 K (rho, c_p, k); Metal Suppliers
    # Online, carbon steel 1020 (E = 30e6 psi, alpha_T = 6.7e-6 1/F)
    "carbon steel": Handbook(E=30e6 * 6894.757, rho=7854.0, alpha_T=6.7e-6 * 1.8, c_p=434.0, k=60.5),
}


def strip(material: Handbook) -> Beam:
    """The strip as beam.toml states it: nominal modulus 7 % above the handbook's."""
    area, second_moment = WIDTH * THICKNESS, WIDTH * THICKNESS**3 / 12
    return Beam(LENGTH, material.rho, area, second_moment, material.E * NOMINAL_OVER_TRUE)


def stated(material: Handbook) -> dict:
    """The [material] table giving every constant (the handbook's)."""
    return {"thermal_expansion": material.alpha_T, "specific_heat": material.c_p,
            "thermal_diffusivity": material.chi, "temperature": T0, "thickness": THICKNESS}


def hammer_test(material: Handbook, table: dict, seed: int):
    """A reference hammer test of the strip with the solved thermoelastic damping."""
    beam = strip(material)
    return record(beam, {"Delta_slab": material.Delta, "tau_slab": material.tau}, EI=material.E * beam.second_moment,
                  excitation=HAMMER, fs=FS, duration=DURATION, noise=NOISE, seed=seed, material=table)


def single_term_ratios(material: Handbook) -> np.ndarray:
    """Per in-band mode, the series' relaxing stiffness over Zener's single term (same Delta and
    tau), real and imaginary parts: the kappa a correct package fits, mode by mode."""
    beam = strip(material)
    case = BeamCase(LENGTH, beam.rho_a, material.E * beam.second_moment)
    omega = undamped_modes(matrices(case, 60))[0]
    s = 1j * omega[omega < 2 * np.pi * BAND]
    series, single = heat_conduction(1.0, 1.0, material.tau).transform(s), zener(1.0, 1.0, material.tau).transform(s)
    return np.concatenate([series.real / single.real, series.imag / single.imag])


def zener_scale_interval(rec, seed: int) -> tuple[float, float]:
    """The 99 % Laplace interval of zener_scale from the fit's optimum (automatic N)."""
    problem, optimum, check = choose_discretisation(rec, "thermoelastic", FitConfig(seed=seed),
                                                    np.random.default_rng(seed))
    assert check["passed"], check
    i = problem.posterior.model_names.index("zener_scale")
    centre, sd = optimum.theta[i], np.sqrt(optimum.covariance[i, i])
    prior = problem.posterior.priors[i]
    return float(prior.to_value(centre - Z99 * sd)), float(prior.to_value(centre + Z99 * sd))


def meets(interval, lo: float, hi: float) -> bool:
    return interval[0] <= hi and interval[1] >= lo


@pytest.mark.parametrize("name, seed", [("6061-T6", 31), ("carbon steel", 32)])
def test_zener_scale_is_what_heat_conduction_predicts(name, seed):
    material = HANDBOOKS[name]
    ratios = single_term_ratios(material)
    interval = zener_scale_interval(hammer_test(material, stated(material), seed), seed)
    print(name, "predicted", ratios.min(), ratios.max(), "99 %", interval)
    assert meets(interval, ratios.min(), ratios.max()), (interval, ratios)
    # a strength off by POWER either way would move the interval off the range
    assert interval[1] < POWER * ratios.min() and interval[0] > ratios.max() / POWER, (interval, ratios)


def test_named_aluminium_predicts_the_handbook_strips_damping():
    material = HANDBOOKS["6061-T6"]
    ratios = single_term_ratios(material)
    named = {"name": "aluminium", "temperature": T0, "thickness": THICKNESS}
    interval = zener_scale_interval(hammer_test(material, named, 33), 33)
    print("named aluminium: predicted", ratios.min(), ratios.max(), "99 %", interval)
    assert meets(interval, ratios.min() / HANDBOOK_SPREAD, ratios.max() * HANDBOOK_SPREAD), (interval, ratios)
    # a table constant off by POWER in Delta either way would move the interval off the widened range
    low, high = ratios.min() / HANDBOOK_SPREAD, ratios.max() * HANDBOOK_SPREAD
    assert interval[1] < POWER * low and interval[0] > high / POWER, (interval, ratios)
