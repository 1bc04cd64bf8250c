"""Small recordings from the reference simulator for acceptance tests (data the model did not make).

Each entry of :data:`RECORDINGS` is one test, 1 s at 1024 Hz, 2 % sensor noise (of each channel's
RMS) and 0.5 % force noise (of the peak); the beam.toml states a nominal modulus 7 % above
(paper beam) or 6 % below (strip) the true one, so a prior centred on the nominal EI is off the
truth. Two beams:

* the paper's (Table 1, E = 2.7e10 Pa, EI = 44.28 N m^2), struck at 0.75 m by a Gaussian hammer
  pulse of 2 ms standard deviation (20 N peak), tip accelerometer;
* an aluminium strip 0.5 m x 25 mm x 3 mm with a 50 g tip block (EI = 3.9375 N m^2), struck at
  0.375 m by a 1 ms pulse (a hard tip: the strip's modes 3-4 need it).

Damping values are those of ``tests/inference/cases.py`` (restated here: the simulator imports
nothing of the model's tests). Effects: a root spring (3500 N m/rad, mode 1 about 2 % lower;
under q1 and under q2), a 0.5 ms delay of the response channels, a 20 g sensor mass at the tip. Null recordings (no
effect) include one with a tip displacement channel and a release test.

Use the fixture (one per test run): import ``reference_recordings`` into a conftest or test module, then
``reference_recordings("paper_q3")`` is the folder (built once per run, about 0.3-0.6 s each);
``reference_recordings("paper_q1", seed=3)`` is another noise draw of the same test. Outside
pytest, :func:`build` writes one into a folder of your choice. truth.json holds the true values.
"""
from __future__ import annotations

import zlib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pytest

from bayesbeam.io import Beam, Sensor, TipBody

from .record import Hammer, Noise, Numerics, Release, record

PAPER_EI = 2.7e10 * 1.64e-9
#: the paper's beam as its beam.toml states it: nominal modulus 7 % above the true 2.7e10 Pa
PAPER_BEAM = Beam(length=1.0, density=1710.0, area=0.597e-3, second_moment=1.64e-9, modulus=1.07 * 2.7e10)
ALU_EI = 7.0e10 * 5.625e-11
#: the strip as its beam.toml states it: nominal modulus 6 % below the true 7.0e10 Pa
ALU_BEAM = Beam(length=0.5, density=2700.0, area=7.5e-5, second_moment=5.625e-11, modulus=0.94 * 7.0e10)
ALU_TIP = TipBody(mass=0.05, rotary_inertia=2.3e-6)

PAPER_DAMPING = {
    "air": {"gamma": 0.3},
    "strain_rate": {"cdI": 7e-5},
    "q1": {"gamma": 0.3, "cdI": 7e-5},
    "q2": {"alpha": 2.0, "beta": 200.0},
    "q3": {"gamma": 0.12, "a": 0.025, "b": 0.18},
}
ALU_DAMPING = {
    "air": {"gamma": 0.18},
    "strain_rate": {"cdI": 2e-5},
    "q1": {"gamma": 0.18, "cdI": 2e-5},
    "q2": {"alpha": 0.3, "beta": 300.0},
    "q3": {"gamma": 0.1, "a": 5e-3, "b": 0.12},
}

FS, DURATION = 1024.0, 1.0
NOISE = Noise(sensor=0.02, force=0.005)
PAPER_HAMMER = Hammer(location=0.75, peak=20.0, width=2e-3, t0=0.02)
ALU_HAMMER = Hammer(location=0.375, peak=5.0, width=1e-3, t0=0.01)


def _accelerometer(length: float) -> Sensor:
    return Sensor("accel_tip", length, "acceleration", "accel_tip")


def _displacement(length: float) -> Sensor:
    return Sensor("disp_tip", length, "displacement", "disp_tip")


@dataclass(frozen=True)
class Spec:
    """One test: which beam, model, effects, excitation and sensors."""

    beam: str                      # "paper" or "alu"
    model: str                     # a key of PAPER_DAMPING / ALU_DAMPING
    effects: dict = field(default_factory=dict)
    release: float | None = None   # tip load (N) of a release test, else a hammer blow
    displacement: bool = False     # add a tip displacement channel
    numerics: Numerics = field(default_factory=Numerics)

    def arguments(self) -> dict:
        paper = self.beam == "paper"
        beam = PAPER_BEAM if paper else ALU_BEAM
        sensors = (_accelerometer(beam.length),) + ((_displacement(beam.length),) if self.displacement else ())
        excitation = Release(self.release) if self.release else (PAPER_HAMMER if paper else ALU_HAMMER)
        return {"beam": beam, "damping": (PAPER_DAMPING if paper else ALU_DAMPING)[self.model],
                "EI": PAPER_EI if paper else ALU_EI, "tip": None if paper else ALU_TIP,
                "effects": self.effects, "sensors": sensors, "excitation": excitation, "numerics": self.numerics}


RECORDINGS = {
    **{f"paper_{m}": Spec("paper", m) for m in PAPER_DAMPING},
    **{f"alu_{m}": Spec("alu", m) for m in ALU_DAMPING},
    "paper_q1_root_spring": Spec("paper", "q1", {"k_theta": 3500.0}),
    "paper_q1_delay": Spec("paper", "q1", {"tau": 5e-4}),
    "paper_q1_sensor_mass": Spec("paper", "q1", {"m_s": 0.02}),
    # the root spring couples the modes under time hysteresis: one memory block, so fewer modes and exponentials
    "paper_q2_root_spring": Spec("paper", "q2", {"k_theta": 3500.0},
                                 numerics=Numerics(omega_cut=2 * np.pi * 1500, du=0.7, oversample=8)),
    "alu_q1_displacement": Spec("alu", "q1", displacement=True),
    "alu_q1_release": Spec("alu", "q1", release=0.4, displacement=True),
}
"""Every recording this module builds, by name; all but those with effects are null recordings."""


def build(name: str, out, seed: int | None = None) -> Path:
    """Write recording ``name`` (a key of :data:`RECORDINGS`) into folder ``out``; return it.

    ``seed`` picks the noise draw (default: one fixed per name)."""
    if name not in RECORDINGS:
        raise KeyError(f"no reference recording {name!r}; known: {', '.join(RECORDINGS)}")
    seed = zlib.crc32(name.encode()) if seed is None else seed
    record(**RECORDINGS[name].arguments(), fs=FS, duration=DURATION, noise=NOISE, seed=seed, out=out, name=name)
    return Path(out)


@pytest.fixture(scope="session")
def reference_recordings(tmp_path_factory):
    """A function name, seed=None -> folder of that recording, built once per run."""
    root = tmp_path_factory.mktemp("reference_recordings")
    built: dict[tuple, Path] = {}

    def get(name: str, seed: int | None = None) -> Path:
        if (name, seed) not in built:
            built[name, seed] = build(name, root / (name if seed is None else f"{name}_seed{seed}"), seed)
        return built[name, seed]

    return get
