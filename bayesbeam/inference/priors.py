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
m_s, m_s_<s>   kg              log-uniform [1e-4, 0.2] rho A l             sensor mass (*)
P              N               uniform [-0.5 P_cr, 10 P_cr]                axial load
c_q            N s^2/m^3       log-uniform [1e-4, 1e3]                     quadratic drag
F_c            N               log-uniform [1e-5, 10]                      dry friction
tau            s               uniform [0, 0.005]                          acquisition delay
c_f            N m^2 s^nu      log-uniform [1e-8 EI_0, 1 EI_0] (x 1 s^nu)  fractional strength
nu             -               uniform [0.01, 0.99]                        fractional order
c_e            N m^2 s         log-uniform [1e-10, 1e-1]                   as cdI (its mu -> inf limit)
mu             1/s             log-uniform [1, 1e5]                        relaxation rate
zener_scale    -               log-normal, median 1, sd(log) 0.5           Zener's prediction
c_theta        N m s/rad       log-uniform [1e-6, 10] EI_0/l (x 1 s)       root dashpot
f_b            Hz              log-uniform [0.1, 1e4] f_1                  base's frequency
m_b            kg              log-uniform [0.1, 100] rho A l              base's mass
zeta_b         -               log-uniform [1e-3, 0.3]                     base's damping ratio
f_hp           Hz              log-uniform [0.01, 5]                       AC coupling (***)
f_a            Hz              log-uniform [0.01, 1e4] f_1                 attached body's frequency (****)
m_a            kg              log-uniform [1e-3, 1] rho A l               attached body's mass
zeta_a         -               log-uniform [1e-3, 0.3]                     its link's damping ratio
x_a            m               uniform [0, l]                              where it is attached
g, g_<s>       -               normal, mean 0, sd 0.02                     channel gain (***)
sigma_<s>      sensor units    log-uniform [1e-6, 10] x channel RMS        noise sd per channel
phi_<s>        -               uniform [-0.99, 0.99]                       AR(1) coefficient
l              m               uniform [l - t_l, l + t_l]                  free length (**)
dx_<s>         m               uniform [-t_s, t_s], on the beam            sensor offset (**)
dx_hammer      m               uniform [-t_h, t_h], on the beam            hammer offset (**)
=============  ==============  ==========================================  ======================

P_cr = pi^2 EI_0 / (4 l^2) is the cantilever's Euler buckling load. f_1 = (1.8751)^2 sqrt(EI_0 / (rho A l^4))
/ (2 pi) is the nominal clamped beam's fundamental (Hz, no tip body). Outside its support a prior
returns -inf; it never raises inside the sampler.

(*) The ``sensor_mass`` effect fits a mass at each sensor: m_s for a recording's only sensor,
m_s_<s> for sensor <s> of several. What beam.toml states about the set-up (``Recording.setup``)
replaces a default: when a sensor states its own mass m (> 0), its mass is log-normal with
median m and sd(log) :data:`SENSOR_MASS_SIGMA` = 0.3. The maker's mass is exact to
a few per cent, but the mass that moves with the beam also holds the mounting (stud, wax or
magnet) and the moving part of the cable, and the sensor is not a point: one sd is a factor 1.35,
three sds a factor 2.5 either way. Without a stated mass the default scales with the beam's mass
rho A l: a sensor of 1e-4 rho A l moves no frequency by more than 2e-4 of itself, one of 0.2
rho A l is a heavier body than any sensor mounted on a beam.

(**) A free length stated with ``[beam] length_tolerance`` t_l > 0 makes the length l a parameter
of every model, uniform over [l - t_l, l + t_l] (l the stated length); a sensor whose location
beam.toml states with a ``location_tolerance`` t_s > 0 is placed at its stated location plus the
offset dx_<s>, uniform over [-t_s, t_s] cut to the stated beam ([-x_s, l - x_s] for a sensor stated
at x_s; a tip sensor's offset is [-t_s, 0]). A force recording's ``[excitation]
location_tolerance`` t_h > 0 does the same for the hammer: dx_hammer, uniform over [-t_h, t_h] cut
to [-x_f, l - x_f]. A tolerance states an interval and nothing about where
inside it the value lies, and the uniform is the least informative distribution on an interval (a
normal of sd t/2 cut at +-t would claim the stated value is likelier than its neighbours, which the
tolerance does not say).

(***) The ``high_pass`` effect's corner f_hp: an IEPE sensor's discharge time constant is 0.5 to
20 s (0.3 to 0.008 Hz) and a DAQ's AC coupling sits at 0.1 to 3.4 Hz (0.5 Hz is common), so
0.01-5 Hz holds every corner a sensor and DAQ in series give; a DC-coupled chain is f_hp -> 0, which
the effect's absence is. When ``[[sensor]] high_pass_hz`` states a data-sheet corner, f_hp is
log-normal about it (the geometric mean of the stated corners when several sensors state one) with
sd(log) :data:`HIGH_PASS_SIGMA` = 0.5: a data sheet gives a typical or bounding corner, not a
measured one, and the DAQ's coupling in series moves the effective corner by up to its own.
The ``channel_gain`` effect's g (g_<s> per sensor of several) is normal about 0 with sd the
sensor's ``gain_tolerance``, 0.02 where none is stated: a comparison calibration's uncertainty
(ISO 16063-21, 1-2 % at k = 2). A normal, not a uniform, because a calibration's uncertainty is a
standard deviation, not a bound.

(****) The ``attachment`` effect's body (its own frequency f_a on its link, mass m_a, the link's
damping ratio zeta_a, place x_a): m_a from a thousandth of the beam's mass (a cable clamp on a light
beam) to the beam's own (a shaker's armature on a thin strip); f_a from a hundredth of the beam's
fundamental, where the body hangs free of the beam and the effect vanishes, to 1e4 f_1, where it
rides along as a point mass (the base's top, and for the same reason); zeta_a as the base's, from
a metal stinger to a soft pad; x_a anywhere on the span.

Why the literature mechanisms' priors: a fractional Kelvin-Voigt beam's loss factor is about
(c_f/EI) omega^nu sin(nu pi/2), so c_f/EI_0 in [1e-8, 1] spans loss factors of 1e-8 to 1 at 1 rad/s
whatever nu, and nu is uniform inside the open interval the mechanism admits. The exponential
kernel tends to Kelvin-Voigt with cdI = c_e as mu -> inf, so c_e has cdI's prior and the two are
compared on equal terms; mu runs from below a beam's fundamental (1/s) to far above its band
(1e5 1/s, the viscous limit). The thermoelastic scale is 1 where Zener's theory and the handbook
constants hold; sd(log) 0.5 allows a factor 1.6 either way at one sd (constants, the single
thermal mode, the temperature). The root dashpot's c_theta / k_theta is the clamp's relaxation
time; c_theta l / EI_0 in [1e-6, 10] s spans modal damping from negligible to tens of per cent at a
compliant clamp (k_theta near EI_0/l); at a nearly rigid clamp the root hardly turns, and no
dashpot there damps much.

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

    [prior.g]
    kind = "normal"        # mean, sd
    mean = 0.0
    sd = 0.05
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from bayesbeam.model import HAMMER_OFFSET, LENGTH, SENSOR_OFFSET
from bayesbeam.physics.effects.attachment import ABSENT_RATIO as ATTACHMENT_RATIO
from bayesbeam.physics.effects.attachment import MASS_RANGE as ATTACHMENT_MASS
from bayesbeam.physics.effects.base_support import ABSENT_RATIO, DAMPING_RANGE, MASS_RANGE, fundamental
from bayesbeam.physics.effects.channel_gain import PER_SENSOR as PER_GAIN
from bayesbeam.physics.effects.channel_gain import SINGLE as GAIN
from bayesbeam.physics.effects.channel_gain import gain_names
from bayesbeam.physics.effects.sensor_mass import PER_SENSOR, SINGLE, mass_names

#: sd of a channel's gain g where beam.toml states no ``gain_tolerance`` (see (***) above)
DEFAULT_GAIN_TOLERANCE = 0.02

KINDS = ("lognormal", "loguniform", "uniform", "normal")
#: the names of a kind's two numbers, as a [prior.NAME] table spells them
BOUND_NAMES = {"lognormal": ("median", "sigma"), "loguniform": ("low", "high"), "uniform": ("low", "high"),
               "normal": ("mean", "sd")}


@dataclass(frozen=True)
class Prior:
    """A one-dimensional prior with its sampling coordinate.

    ``kind``: "lognormal" (a = median, b = sd of log), "loguniform" (a = low, b = high) or
    "uniform" (a = low, b = high) or "normal" (a = mean, b = sd). Log-scale kinds are sampled in
    z = log(value), the others in the value.
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
        if self.kind == "normal" and not self.b > 0:
            raise ValueError(f"normal prior needs sd > 0, got {self.b}")

    @property
    def log_scale(self) -> bool:
        return self.kind not in ("uniform", "normal")

    @property
    def _centred(self) -> tuple[float, float] | None:
        """(centre, sd) of the sampling coordinate for the Gaussian kinds, else None."""
        if self.kind == "lognormal":
            return float(np.log(self.a)), self.b
        return (self.a, self.b) if self.kind == "normal" else None

    def to_value(self, z):
        """Physical value from the sampling coordinate."""
        return np.exp(z) if self.log_scale else z

    def to_coordinate(self, value):
        return np.log(value) if self.log_scale else value

    def log_density(self, z: float) -> float:
        """Log prior density of the sampling coordinate z (the Jacobian is included)."""
        if self._centred:
            centre, sd = self._centred
            return -0.5 * ((z - centre) / sd) ** 2 - np.log(sd * np.sqrt(2 * np.pi))
        lo, hi = (np.log(self.a), np.log(self.b)) if self.kind == "loguniform" else (self.a, self.b)
        return -np.log(hi - lo) if lo <= z <= hi else -np.inf

    def bounds(self) -> tuple[float, float]:
        """Support in the sampling coordinate (+-4 sd for the log-normal and the normal)."""
        if self._centred:
            centre, sd = self._centred
            return centre - 4 * sd, centre + 4 * sd
        return (np.log(self.a), np.log(self.b)) if self.kind == "loguniform" else (self.a, self.b)

    def draw(self, rng: np.random.Generator, size=None):
        """Random draws of the sampling coordinate."""
        if self._centred:
            return rng.normal(*self._centred, size)
        return rng.uniform(*self.bounds(), size)

    def median(self) -> float:
        """Prior median of the sampling coordinate."""
        return float(np.mean(self.bounds()))

    def describe(self) -> str:
        k1, k2 = BOUND_NAMES[self.kind]
        return f"{self.kind}({k1}={self.a:.4g}, {k2}={self.b:.4g})"


#: The default table above as data: parameter -> (kind, first, second), each of the two numbers a
#: factor times a scale of the beam named in :data:`SCALES` ("" for none).
DEFAULTS: dict[str, tuple[str, tuple[float, str], tuple[float, str]]] = {
    "EI": ("lognormal", (1.0, "EI_0"), (0.25, "")),
    "gamma": ("loguniform", (1e-5, ""), (1e2, "")),
    "cdI": ("loguniform", (1e-10, ""), (1e-1, "")),
    "alpha": ("loguniform", (1e-6, "EI_0"), (1.0, "EI_0")),
    "beta": ("loguniform", (1e-2, ""), (1e4, "")),
    "a": ("loguniform", (1e-6, ""), (1e2, "")),
    "b": ("loguniform", (1e-3, "l"), (1.0, "l")),
    "k_theta": ("loguniform", (1.0, "EI_0/l"), (1e5, "EI_0/l")),
    "m_s": ("loguniform", (1e-4, "rho A l"), (0.2, "rho A l")),
    "P": ("uniform", (-0.5, "P_cr"), (10.0, "P_cr")),
    "c_q": ("loguniform", (1e-4, ""), (1e3, "")),
    "F_c": ("loguniform", (1e-5, ""), (10.0, "")),
    "tau": ("uniform", (0.0, ""), (0.005, "")),
    "c_f": ("loguniform", (1e-8, "EI_0"), (1.0, "EI_0")),
    "nu": ("uniform", (0.01, ""), (0.99, "")),
    "c_e": ("loguniform", (1e-10, ""), (1e-1, "")),
    "mu": ("loguniform", (1.0, ""), (1e5, "")),
    "zener_scale": ("lognormal", (1.0, ""), (0.5, "")),
    "c_theta": ("loguniform", (1e-6, "EI_0/l"), (10.0, "EI_0/l")),
    "f_b": ("loguniform", (0.1, "f_1"), (ABSENT_RATIO, "f_1")),
    "m_b": ("loguniform", (MASS_RANGE[0], "rho A l"), (MASS_RANGE[1], "rho A l")),
    "zeta_b": ("loguniform", (DAMPING_RANGE[0], ""), (DAMPING_RANGE[1], "")),
    "f_hp": ("loguniform", (0.01, ""), (5.0, "")),
    "f_a": ("loguniform", (ATTACHMENT_RATIO, "f_1"), (ABSENT_RATIO, "f_1")),
    "m_a": ("loguniform", (ATTACHMENT_MASS[0], "rho A l"), (ATTACHMENT_MASS[1], "rho A l")),
    "zeta_a": ("loguniform", (DAMPING_RANGE[0], ""), (DAMPING_RANGE[1], "")),
    "x_a": ("uniform", (0.0, "l"), (1.0, "l")),
    GAIN: ("normal", (0.0, ""), (DEFAULT_GAIN_TOLERANCE, "")),
}
#: the noise parameters' defaults, per channel <s>: sigma_<s> scales with the channel's RMS
NOISE_DEFAULTS: dict[str, tuple[str, tuple[float, str], tuple[float, str]]] = {
    "sigma": ("loguniform", (1e-6, "RMS"), (10.0, "RMS")),
    "phi": ("uniform", (-0.99, ""), (0.99, "")),
}
#: the scales of the defaults: l = beam length, EI_0 = nominal E*I, rho A l = the beam's mass,
#: P_cr = pi^2 EI_0 / (4 l^2) (Euler buckling load of the cantilever)
SCALES = {
    "": lambda beam: 1.0,
    "EI_0": lambda beam: beam.nominal_EI,
    "l": lambda beam: beam.length,
    "EI_0/l": lambda beam: beam.nominal_EI / beam.length,
    "rho A l": lambda beam: beam.rho_a * beam.length,
    "P_cr": lambda beam: np.pi**2 * beam.nominal_EI / (4 * beam.length**2),
    "f_1": fundamental,
}


#: sd of log m_s (m_s_<s>) about the sensor's stated mass (see (*) above)
SENSOR_MASS_SIGMA = 0.3
#: sd of log f_hp about the stated data-sheet corner (see (***) above)
HIGH_PASS_SIGMA = 0.5


def default_priors(beam, parameter_names, channel_rms: dict[str, float], setup=None) -> dict[str, Prior]:
    """The default table above, for a model's parameters and a recording's channels; ``setup``
    (a recording's :class:`~bayesbeam.io.recording.SetUp`) replaces the defaults it informs and
    gives the priors of the fitted length and sensor offsets."""
    out = {}
    for name in parameter_names:
        stated = tolerance_prior(name, beam, setup)
        if stated is not None:
            out[name] = stated
            continue
        key = default_key(name)
        if key not in DEFAULTS:
            raise ValueError(f"no default prior for parameter {name!r}; give one in the fit file "
                             f"as [prior.{name}]")
        kind, (a, scale_a), (b, scale_b) = DEFAULTS[key]
        out[name] = setup_prior(name, setup) or Prior(kind, a * SCALES[scale_a](beam), b * SCALES[scale_b](beam))
    kind, (low, _), (high, _) = NOISE_DEFAULTS["sigma"]
    for channel, rms in channel_rms.items():
        out[f"sigma_{channel}"] = Prior(kind, low * rms, high * rms)
    return out


def default_key(name: str) -> str:
    """The row of :data:`DEFAULTS` of parameter ``name``: a sensor's mass m_s_<s> takes m_s's, a
    sensor's gain g_<s> g's."""
    if name.startswith(PER_SENSOR.format("")):
        return SINGLE
    return GAIN if name.startswith(PER_GAIN.format("")) else name


def stated_sensor_masses(setup) -> dict[str, float | None]:
    """{``sensor_mass`` parameter (m_s, or m_s_<s> per sensor): the sensor's stated mass (kg), None
    where not stated}; empty when ``setup`` is None."""
    if setup is None:
        return {}
    return dict(zip(mass_names(s.name for s in setup.sensors), setup.sensor_masses))


def setup_prior(name: str, setup) -> Prior | None:
    """The prior the stated set-up gives parameter ``name``, or None where it states nothing about it."""
    mass = stated_sensor_masses(setup).get(name)
    if mass:
        return Prior("lognormal", mass, SENSOR_MASS_SIGMA)
    if setup is None:
        return None
    corners = [f for f in setup.high_pass_corners if f is not None]
    if name == "f_hp" and corners:
        return Prior("lognormal", float(np.exp(np.mean(np.log(corners)))), HIGH_PASS_SIGMA)
    tolerance = dict(zip(gain_names(s.name for s in setup.sensors), setup.gain_tolerances)).get(name)
    return Prior("normal", 0.0, tolerance) if tolerance is not None else None


def stated_gain_tolerances(setup) -> dict[str, float]:
    """{``channel_gain`` parameter (g, or g_<s> per sensor): the sensor's calibration tolerance, its
    stated ``gain_tolerance`` or :data:`DEFAULT_GAIN_TOLERANCE`}."""
    names = gain_names(s.name for s in setup.sensors)
    return {n: DEFAULT_GAIN_TOLERANCE if tol is None else tol for n, tol in zip(names, setup.gain_tolerances)}


def tolerance_prior(name: str, beam, setup) -> Prior | None:
    """The prior of the fitted length ``l``, a sensor offset ``dx_<s>`` or the hammer's ``dx_hammer``
    (m), uniform over the stated tolerance (see (**) above); None when ``name`` is none of them or
    nothing is stated."""
    if setup is None:
        return None
    if name == LENGTH and setup.length_tolerance > 0:
        return Prior("uniform", beam.length - setup.length_tolerance, beam.length + setup.length_tolerance)
    placed = [(SENSOR_OFFSET.format(s.name), s.location, t) for s, t in zip(setup.sensors, setup.location_tolerances)]
    placed.append((HAMMER_OFFSET, setup.hammer_location, setup.excitation_location_tolerance))
    for offset, location, tolerance in placed:
        if name == offset and tolerance > 0:
            return Prior("uniform", max(-tolerance, -location), min(tolerance, beam.length - location))
    return None


#: ``bayesbeam models``'s lines for the set-up's priors (their numbers depend on each recording's set-up)
SETUP_PRIORS = {LENGTH: "uniform(low=l - length_tolerance, high=l + length_tolerance)",
                SENSOR_OFFSET.format("<s>"): "uniform(low=-location_tolerance, high=location_tolerance), cut to the beam",
                HAMMER_OFFSET: "uniform(low=-[excitation] location_tolerance, high=location_tolerance), cut to the beam"}


def noise_prior(kind_of_parameter: str) -> Prior:
    """The default prior of a noise parameter that does not scale with its channel (``"phi"``)."""
    kind, (a, _), (b, _) = NOISE_DEFAULTS[kind_of_parameter]
    return Prior(kind, a, b)


def describe_default(name: str) -> str:
    """A default prior in terms of the beam's scales, e.g. ``loguniform(low=1e-06 EI_0, high=EI_0)``;
    ``name`` is a parameter of :data:`DEFAULTS` or a noise parameter of :data:`NOISE_DEFAULTS`."""
    kind, *bounds = DEFAULTS[name] if name in DEFAULTS else NOISE_DEFAULTS[name]
    terms = [f"{key}={_scaled(factor, scale)}" for key, (factor, scale) in zip(BOUND_NAMES[kind], bounds)]
    return f"{kind}({', '.join(terms)})"


def _scaled(factor: float, scale: str) -> str:
    if not scale or factor == 0:            # a zero bound needs no scale: "low=0", not "low=0 l"
        return f"{factor:.4g}"
    return scale if factor == 1 else f"{factor:.4g} {scale}"


def prior_from_table(name: str, table: dict, file: str = "fit file") -> Prior:
    """A Prior from a ``[prior.NAME]`` TOML table; ValueError naming the key and the fix."""
    kind = table.get("kind")
    keys = BOUND_NAMES
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
