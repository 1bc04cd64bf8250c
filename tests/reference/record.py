"""Simulated tests written as recordings: hammer or release, DAQ, noise, beam.toml + recording.csv + truth.json."""
from __future__ import annotations

import json
from dataclasses import asdict, dataclass
from functools import partial
from pathlib import Path

import numpy as np

from bayesbeam.io import Beam, Excitation, Recording, Sensor, TipBody, write_recording
from bayesbeam.io.atomic import write_text

from . import friction, integrate
from .augmented import relaxation_blocks
from .daq import AntiAlias, measurement_chain
from .relaxation import RELAXATION_KEYS
from .system import BeamCase, full_blocks, matrices, modal_blocks

#: Gaussian pulses start this many standard deviations after the first simulated instant
GAUSSIAN_LEAD = 8.0


@dataclass(frozen=True)
class Hammer:
    """A hammer blow at ``location`` (m): a Gaussian pulse of ``peak`` N and standard deviation
    ``width`` s centred on ``t0`` s. Smooth, so the fine grid's cubic interpolation is accurate
    (error ~ (h/width)^4) and its spectrum, exp(-(2 pi f width)^2/2), leaves nothing to alias."""

    location: float
    peak: float = 20.0
    width: float = 1e-3
    t0: float = 0.01

    def __post_init__(self):
        if self.t0 < GAUSSIAN_LEAD * self.width:
            raise ValueError(f"a Gaussian pulse needs t0 >= {GAUSSIAN_LEAD:g} widths (the beam rests at t = 0); "
                             f"got t0 = {self.t0} s, width = {self.width} s")

    def force(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(f in N, df/dt in N/s) at times t (s)."""
        z = (np.asarray(t, dtype=float) - self.t0) / self.width
        f = self.peak * np.exp(-0.5 * z**2)
        return f, -z / self.width * f


@dataclass(frozen=True)
class Release:
    """Free decay from the static deflection under ``tip_load`` (N) at the tip, released at t = 0."""

    tip_load: float


@dataclass(frozen=True)
class Noise:
    """Seeded white Gaussian noise: ``sensor`` x each channel's RMS, ``force`` x the force's peak."""

    sensor: float = 0.0
    force: float = 0.0


@dataclass(frozen=True)
class Numerics:
    """Discretisation: elements, fine-grid factor, modal cut-off for memory (rad/s, default the
    fine grid's Nyquist: 2 pi fs oversample / 2) and the memory quadrature step."""

    n_elements: int = 60
    oversample: int = 16
    omega_cut: float | None = None
    du: float = 0.5


_CLEAN: dict[str, tuple] = {}


def simulate(case: BeamCase, excitation, fs: float, n: int, numerics: Numerics = Numerics()):
    """Clean recorded signals: (force (n,) N or None, responses (n, n_sensors)) sampled at k / fs.

    Remembered for the test run (keyed by the inputs' repr), so that repeated noise draws of one
    test cost one simulation.
    """
    key = repr((case, excitation, fs, n, numerics))
    if key not in _CLEAN:
        _CLEAN[key] = _simulate(case, excitation, fs, n, numerics)
    force, signals = _CLEAN[key]
    return (None if force is None else force.copy()), signals.copy()


def _simulate(case: BeamCase, excitation, fs: float, n: int, numerics: Numerics):
    daq = AntiAlias(fs, numerics.oversample)
    h = 1.0 / (fs * numerics.oversample)
    fine = (np.arange((n - 1) * numerics.oversample + 2 * daq.half + 1) - daq.half) * h
    blocks = _blocks(case, excitation, fs, numerics)
    # a delay tau: the response channels read y(t - tau), i.e. the same exact simulation on the grid
    # shifted by -tau (the force is analytic, the beam at rest or in equilibrium before it): no interpolation
    shifted = fine - case.effects.get("tau", 0.0)
    step = _stepper(case, numerics)
    chain = partial(measurement_chain, h=h, f_hp=case.effects.get("f_hp", 0.0), gains=case.effects.get("gains"))
    if isinstance(excitation, Hammer):
        f, df = excitation.force(shifted)
        responses = step(blocks, h, np.zeros(blocks.B.shape), f, df)
        return daq.sample(excitation.force(fine)[0], n), daq.sample(chain(responses), n)
    return None, daq.sample(chain(_release(blocks, excitation.tip_load, shifted, h, step)), n)


def _stepper(case: BeamCase, numerics: Numerics):
    """The time stepping: exact for the linear beam, with tip friction that of :mod:`.friction`."""
    if "F_c" not in case.effects:
        return integrate.step
    return partial(friction.step, friction.TipFriction.of(case, numerics.n_elements))


def _blocks(case: BeamCase, excitation, fs: float, numerics: Numerics):
    mats = matrices(case, numerics.n_elements)
    load_at = excitation.location if isinstance(excitation, Hammer) else case.length
    omega_cut = numerics.omega_cut or 2 * np.pi * fs * numerics.oversample / 2
    if case.relaxes:
        return relaxation_blocks(case, mats, load_at, omega_cut, numerics.du)
    if not case.has_memory:
        return full_blocks(case, mats, load_at)
    return modal_blocks(case, mats, load_at, omega_cut, numerics.du)


def _release(blocks, tip_load: float, times: np.ndarray, h: float, step=integrate.step) -> np.ndarray:
    """Outputs at ``times``: at rest under the load before t = 0, free afterwards."""
    rest = blocks.equilibrium(tip_load)
    before = int(np.sum(times < 0))
    out = np.empty((times.size, blocks.F.size))
    out[:before] = np.einsum("bos,bs->o", blocks.C, rest) + blocks.F * tip_load
    start = integrate.propagate(blocks, rest, times[before])
    zeros = np.zeros(times.size - before)
    out[before:] = step(blocks, h, start, zeros, zeros)
    return out


MECHANISM_KEYS = {"air": ("gamma",), "strain_rate": ("cdI",), "time_hysteresis": ("alpha", "beta"),
                  "spatial_hysteresis": ("a", "b"), **RELAXATION_KEYS}
EFFECT_NAMES = {"k_theta": "root_compliance", "c_theta": "root_damping", "m_s": "sensor_mass",
                "sensor_masses": "sensor_mass", "P": "axial_load",
                "tau": "measurement_delay", "F_c": "dry_friction", "f_hp": "high_pass", "gains": "channel_gain",
                **dict.fromkeys(("m_b", "k_b", "c_b"), "base_support"),
                **dict.fromkeys(("m_a", "k_a", "c_a", "x_a"), "attachment")}
TIP_ACCELEROMETER = "accel_tip"
NOTES = {"simulator": "tests.reference: Hermite cubic finite elements, exact exponential stepping",
         "daq": "every channel passes one zero-phase Kaiser-windowed-sinc low-pass (flat to 1e-5 below 0.40 fs, "
                "-100 dB above 0.50 fs) on a fine grid, then is sampled simultaneously"}


def record(beam: Beam, damping: dict, *, excitation, fs: float, duration: float, EI: float | None = None,
           tip: TipBody | None = None, effects: dict | None = None, sensors: tuple[Sensor, ...] | None = None,
           noise: Noise = Noise(), seed: int = 0, out=None, numerics: Numerics = Numerics(),
           name: str = "reference", material: dict | None = None) -> Recording:
    """Simulate a test of ``beam`` and return it as a Recording; with ``out``, also write it there.

    beam: the beam as ``beam.toml`` states it (its ``modulus`` is the nominal one);
    EI: the true bending stiffness (N m^2), default ``beam.nominal_EI``; tip: default none;
    damping: the paper's parameters (gamma, cdI, alpha, beta, a, b; SI units) or the literature's
    (c_e, mu; c_f, nu; Delta, tau_T: :mod:`tests.reference.relaxation`);
    effects: k_theta (N m/rad), c_theta (N m s/rad), m_s (kg, at the first sensor), sensor_masses
    (kg per sensor, in the order of ``sensors``), P (N), tau (s), f_hp (Hz, AC coupling of the response
    channels), gains (one per sensor: each response channel reads 1 + g times the motion), m_a, k_a,
    c_a, x_a (kg, N/m, N s/m, m: a body on a spring and dashpot at x_a, its own dof),
    F_c (N, Coulomb friction at the tip; memory-free damping only);
    material: a ``[material]`` table written to beam.toml as given (docs/format.md);
    excitation: :class:`Hammer` (force channel "force") or :class:`Release` (no force channel);
    sensors: default a tip accelerometer; noise: :class:`Noise`, drawn from ``seed``.
    ``out`` gets beam.toml, recording.csv and truth.json (the parameters, noise sds, numerics).
    """
    tip = tip or TipBody()
    sensors = tuple(sensors or (Sensor(TIP_ACCELEROMETER, beam.length, "acceleration", TIP_ACCELEROMETER),))
    case = BeamCase(beam.length, beam.rho_a, beam.nominal_EI if EI is None else EI, tip.mass, tip.rotary_inertia,
                    dict(damping), dict(effects or {}), tuple((s.location, s.quantity) for s in sensors))
    n = round(duration * fs)
    force, signals = simulate(case, excitation, fs, n, numerics)
    rng = np.random.default_rng(seed)
    sensor_sd = noise.sensor * np.sqrt(np.mean(signals**2, axis=0))
    signals = signals + sensor_sd * rng.standard_normal(signals.shape)
    force_sd = 0.0
    if force is not None:
        force_sd = noise.force * float(np.max(np.abs(force)))
        force = force + force_sd * rng.standard_normal(force.shape)
        described = Excitation("force", location=excitation.location, column="force")
    else:
        described = Excitation("release", tip_load=excitation.tip_load)
    rec = Recording(beam, tip, described, sensors, np.arange(n) / fs, signals, force,
                    extra={"notes": NOTES, **({"material": dict(material)} if material else {})})
    if out is not None:
        truth = _truth(name, case, excitation, fs, n, seed, sensors, sensor_sd, force_sd, noise, numerics)
        write_recording(rec, out, overwrite=True)
        write_text(Path(out) / "truth.json", json.dumps(truth, indent=2) + "\n")
    return rec


def _truth_entry(key: str, value, sensors) -> dict:
    """An effect's true parameters by the names bayesbeam fits: sensor_masses as m_s_<sensor>, gains
    as g_<sensor> (g for a recording's only sensor)."""
    if key == "sensor_masses":
        return {f"m_s_{s.name}": float(m) for s, m in zip(sensors, value)}
    if key == "gains":
        return {"g": float(value[0])} if len(sensors) == 1 else {f"g_{s.name}": float(g) for s, g in zip(sensors, value)}
    return {key: value}


def _effects_truth(effects: dict, sensors) -> dict:
    """{effect name: its true parameters}; an effect of several keys (a base's m_b, k_b, c_b) gathers them."""
    out: dict[str, dict] = {}
    for key, value in effects.items():
        out.setdefault(EFFECT_NAMES[key], {}).update(_truth_entry(key, value, sensors))
    return out


def _truth(name, case, excitation, fs, n, seed, sensors, sensor_sd, force_sd, noise, numerics) -> dict:
    mechanisms = [m for m, keys in MECHANISM_KEYS.items() if keys[0] in case.damping]
    return {
        "dataset": name,
        "simulator": "tests.reference",
        "beam_true": {"EI": case.EI, "rhoA": case.rho_a, "length": case.length, "tip_mass": case.m_T,
                      "tip_inertia": case.J},
        "mechanisms": mechanisms,
        "damping": dict(case.damping),
        "effects": _effects_truth(case.effects, sensors),
        "excitation": {"kind": "force" if isinstance(excitation, Hammer) else "release", **asdict(excitation)},
        "sensors": [{"name": s.name, "location": s.location, "quantity": s.quantity} for s in sensors],
        "fs": fs,
        "n_samples": n,
        "seed": seed,
        "noise": {"sensor_fraction_of_rms": noise.sensor, "force_fraction_of_peak": noise.force,
                  "sensor_sigma": dict(zip([s.name for s in sensors], map(float, sensor_sd))),
                  "force_sigma_N": force_sd},
        "numerics": asdict(numerics),
    }
