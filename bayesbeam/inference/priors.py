r"""Priors a structural dynamicist would accept by default, and their TOML overrides.

Every parameter is sampled in an unconstrained-enough coordinate: the logarithm for the positive
physical parameters, the value itself for the few that may be negative. The default table
(units SI, the paper's names; l = beam length, EI_0 = nominal E*I of beam.toml):

=============  ==============  ==========================================  ======================
parameter      unit            default prior                               why
=============  ==============  ==========================================  ======================
EI             N m^2           log-normal, median EI_0, sd(log) 0.25       a nominal can be 20% off
gamma          N s/m^2         log-uniform [1e-5, 1e2]                     air damping, 7 decades
cdI            N m^2 s         log-uniform [1e-10, 1e-1]                   Kelvin-Voigt, 9 decades
alpha          N m^2 s^-1/2    log-uniform [1e-6 EI_0, 1 EI_0]             memory strength
beta           1/s             log-uniform [1e-2, 1e4]                     memory decay rate
a              N s             log-uniform [1e-6, 1e2]                     spatial hysteresis
b              m               log-uniform [1e-3 l, l]                     kernel width
k_theta        N m/rad         log-uniform [EI_0/l, 1e5 EI_0/l]            root spring
m_s            kg              log-uniform [1e-4, 0.2 rho A l]             sensor mass
P              N               uniform [-0.5 P_cr, 10 P_cr]                axial load
c_q            N s^2/m^3       log-uniform [1e-4, 1e3]                     quadratic drag
F_c            N               log-uniform [1e-5, 10]                      dry friction
tau            s               uniform [0, 0.005]                          acquisition delay
sigma_<s>      sensor units    log-uniform [1e-6, 10] x channel RMS        noise sd per channel
phi_<s>        -               uniform [-0.99, 0.99]                       AR(1) coefficient
=============  ==============  ==========================================  ======================

P_cr = pi^2 EI_0 / (4 l^2) is the cantilever's Euler buckling load. Outside its support a prior
returns -inf; it never raises inside the sampler.

Overrides in a fit TOML file, one table per parameter::

    [prior.EI]
    kind = "lognormal"     # median, sigma (of the log)
    median = 44.0
    sigma = 0.1

    [prior.gamma]
    kind = "loguniform"    # low, high (> 0)
    low = 1e-3
    high = 10.0

    [prior.P]
    kind = "uniform"       # low, high
    low = -5.0
    high = 50.0
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

KINDS = ("lognormal", "loguniform", "uniform")


@dataclass(frozen=True)
class Prior:
    """A one-dimensional prior with its sampling coordinate.

    ``kind``: "lognormal" (a = median, b = sd of log), "loguniform" (a = low, b = high) or
    "uniform" (a = low, b = high). Log-scale kinds are sampled in z = log(value).
    """

    kind: str
    a: float
    b: float

    def __post_init__(self):
        if self.kind not in KINDS:
            raise ValueError(f"prior kind {self.kind!r} is not one of {KINDS}")
        if not (np.isfinite(self.a) and np.isfinite(self.b)):
            raise ValueError(f"{self.kind} prior needs finite numbers, got {self.a}, {self.b}")
        if self.kind == "lognormal" and not (self.a > 0 and self.b > 0):
            raise ValueError(f"lognormal prior needs median > 0 and sigma > 0, got {self.a}, {self.b}")
        if self.kind == "loguniform" and not (0 < self.a < self.b):
            raise ValueError(f"loguniform prior needs 0 < low < high, got {self.a}, {self.b}")
        if self.kind == "uniform" and not self.a < self.b:
            raise ValueError(f"uniform prior needs low < high, got {self.a}, {self.b}")

    @property
    def log_scale(self) -> bool:
        return self.kind != "uniform"

    def to_value(self, z):
        """Physical value from the sampling coordinate."""
        return np.exp(z) if self.log_scale else z

    def to_coordinate(self, value):
        return np.log(value) if self.log_scale else value

    def log_density(self, z: float) -> float:
        """Log prior density of the sampling coordinate z (the Jacobian is included)."""
        if self.kind == "lognormal":
            return -0.5 * ((z - np.log(self.a)) / self.b) ** 2 - np.log(self.b * np.sqrt(2 * np.pi))
        lo, hi = (np.log(self.a), np.log(self.b)) if self.kind == "loguniform" else (self.a, self.b)
        return -np.log(hi - lo) if lo <= z <= hi else -np.inf

    def bounds(self) -> tuple[float, float]:
        """Support in the sampling coordinate (+-4 sd for the log-normal)."""
        if self.kind == "lognormal":
            return np.log(self.a) - 4 * self.b, np.log(self.a) + 4 * self.b
        return (np.log(self.a), np.log(self.b)) if self.kind == "loguniform" else (self.a, self.b)

    def draw(self, rng: np.random.Generator, size=None):
        """Random draws of the sampling coordinate."""
        if self.kind == "lognormal":
            return rng.normal(np.log(self.a), self.b, size)
        return rng.uniform(*self.bounds(), size)

    def median(self) -> float:
        """Prior median of the sampling coordinate."""
        return float(np.mean(self.bounds())) if self.kind != "lognormal" else float(np.log(self.a))

    def describe(self) -> str:
        names = {"lognormal": ("median", "sigma"), "loguniform": ("low", "high"), "uniform": ("low", "high")}
        k1, k2 = names[self.kind]
        return f"{self.kind}({k1}={self.a:.4g}, {k2}={self.b:.4g})"


def default_priors(beam, parameter_names, channel_rms: dict[str, float]) -> dict[str, Prior]:
    """The default table above, for a model's parameters and a recording's channels."""
    ei0, length, mass = beam.nominal_EI, beam.length, beam.rho_a * beam.length
    p_cr = np.pi**2 * ei0 / (4 * length**2)
    table = {
        "EI": Prior("lognormal", ei0, 0.25),
        "gamma": Prior("loguniform", 1e-5, 1e2),
        "cdI": Prior("loguniform", 1e-10, 1e-1),
        "alpha": Prior("loguniform", 1e-6 * ei0, ei0),
        "beta": Prior("loguniform", 1e-2, 1e4),
        "a": Prior("loguniform", 1e-6, 1e2),
        "b": Prior("loguniform", 1e-3 * length, length),
        "k_theta": Prior("loguniform", ei0 / length, 1e5 * ei0 / length),
        "m_s": Prior("loguniform", 1e-4, 0.2 * mass),
        "P": Prior("uniform", -0.5 * p_cr, 10 * p_cr),
        "c_q": Prior("loguniform", 1e-4, 1e3),
        "F_c": Prior("loguniform", 1e-5, 10.0),
        "tau": Prior("uniform", 0.0, 0.005),
    }
    out = {}
    for name in parameter_names:
        if name not in table:
            raise ValueError(f"no default prior for parameter {name!r}; give one in the fit file "
                             f"as [prior.{name}]")
        out[name] = table[name]
    for channel, rms in channel_rms.items():
        out[f"sigma_{channel}"] = Prior("loguniform", 1e-6 * rms, 10 * rms)
    return out


def prior_from_table(name: str, table: dict, file: str = "fit file") -> Prior:
    """A Prior from a ``[prior.NAME]`` TOML table; ValueError naming the key and the fix."""
    kind = table.get("kind")
    keys = {"lognormal": ("median", "sigma"), "loguniform": ("low", "high"), "uniform": ("low", "high")}
    if kind not in keys:
        raise ValueError(f"{file}: [prior.{name}] kind = {kind!r}: expected one of {KINDS}. "
                         f"Fix: e.g. kind = \"loguniform\" with low and high")
    missing = [k for k in keys[kind] if k not in table]
    if missing:
        raise ValueError(f"{file}: [prior.{name}] needs {missing} for kind = {kind!r}. "
                         f"Fix: add {' and '.join(f'{k} = <number>' for k in missing)}")
    try:
        return Prior(kind, float(table[keys[kind][0]]), float(table[keys[kind][1]]))
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{file}: [prior.{name}]: {exc}. Fix: give numbers with a non-empty support") from None
