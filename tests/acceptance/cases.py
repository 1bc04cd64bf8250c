"""Acceptance recordings: made by the independent reference simulator (:mod:`tests.reference`:
Hermite finite elements, exact exponential stepping, a continuous hammer pulse through an
anti-alias FIR, seeded sensor and force noise), never by :class:`bayesbeam.model.BeamModel`.

Every beam.toml states a modulus 7 % above the true one, so the EI prior (centred on the nominal
EI) is centred away from the truth, as it is for a real beam whose modulus comes from a handbook.

Beams are those of :mod:`tests.inference.cases`, damping and noise those of
:mod:`tests.reference.recordings` (realistic modal damping ratios of 0.01-1 %): the paper's beam (1 s at 512 Hz, a 4 ms Gaussian hammer pulse at 0.75 m) and an
aluminium strip with a 50 g tip block (1 s at 1024 Hz, a 1 ms pulse: a hard hammer tip).
"paper_long" is the paper's beam struck by the hard tip and recorded for 2 s at 1024 Hz: six
modes in the fitted band instead of four, and mode 1 (3.7 Hz, decaying over about 17 s) seen over
seven cycles instead of four. Its EI is then determined to 7 ppm, finer than the reference's
default 60 elements resolve (their h^4 error: an RMS difference from 180 elements of 2.1 % of the
noise sd, which over 2048 samples can move an estimate by 0.9 sd), so it is simulated on 120
(0.34 %: at most 0.15 sd).
"rich" is a long, rich record a fit decimates: the paper's beam struck at 0.6 m by an 80 N pulse
of 0.4 ms (the Gaussian of a 0.79 ms half-sine's peak and area), 4 s at 4096 Hz on 120 elements,
q3 damping gamma 0.2, a 0.03, b 0.2, 1.5 % sensor and 1 % force noise, fitted to 152 Hz (the
fit decimates by 10).
Noise: 2 % of each channel's RMS on the sensors, 0.5 % of the peak on the force (but "rich").
"""
from __future__ import annotations

from dataclasses import replace
from functools import cache

import numpy as np

from bayesbeam.io import Beam, Sensor
from tests.inference import cases
from tests.reference import Hammer, Noise, Numerics, Release, record
from tests.reference.recordings import ALU_DAMPING, NOISE, PAPER_DAMPING

#: the beam.toml's modulus over the true one
NOMINAL_OVER_TRUE = 1.07
#: damping of each model on each beam (the paper's names, SI units), EI excluded
DAMPING = {"paper": PAPER_DAMPING, "paper_long": PAPER_DAMPING, "alu": ALU_DAMPING,
           "rich": {"q3": {"gamma": 0.2, "a": 0.03, "b": 0.2}}}
#: concealed effects on the paper beam's q1 (the reference's names): a root spring of 100 EI/l
#: (mode 1 1.9 % low), a 0.5 ms delay of the response channels, a 10 g sensor at the tip
EFFECTS = {"root_compliance": {"k_theta": 4428.0}, "measurement_delay": {"tau": 5e-4},
           "sensor_mass": {"m_s": 0.01}}


def _nominal(beam: Beam) -> Beam:
    return replace(beam, modulus=beam.modulus * NOMINAL_OVER_TRUE)


def _setting(beam_name: str) -> dict:
    if beam_name == "paper":
        return {"beam": cases.PAPER_BEAM, "tip": None, "fs": 512.0, "duration": 1.0,
                "excitation": Hammer(0.75, peak=20.0, width=0.004, t0=0.04)}
    if beam_name == "paper_long":
        return {"beam": cases.PAPER_BEAM, "tip": None, "fs": 1024.0, "duration": 2.0,
                "excitation": Hammer(0.75, peak=20.0, width=0.001, t0=0.01), "numerics": Numerics(n_elements=120)}
    if beam_name == "rich":
        width = 2 * 0.79e-3 / (np.pi * np.sqrt(2 * np.pi))      # sd of the half-sine's Gaussian (s)
        return {"beam": cases.PAPER_BEAM, "tip": None, "fs": 4096.0, "duration": 4.0,
                "excitation": Hammer(0.6, peak=80.0, width=width, t0=0.01), "numerics": Numerics(n_elements=120),
                "noise": Noise(sensor=0.015, force=0.01)}
    return {"beam": cases.ALU_BEAM, "tip": cases.ALU_TIP, "fs": 1024.0, "duration": 1.0,
            "excitation": Hammer(0.75 * cases.ALU_BEAM.length, peak=20.0, width=0.001, t0=0.01)}


@cache
def hammer(model: str, beam_name: str = "paper", seed: int = 1, effect: str | None = None,
           displacement: bool = False, noise: Noise | None = None, fs: float | None = None):
    """A hammer test of ``model``'s damping (optionally with a concealed ``effect``, or a second,
    displacement channel at mid-span; ``noise`` other than the setting's; sampled at ``fs`` Hz
    instead of the setting's) and its truth: (Recording, {parameter: true value})."""
    s = _setting(beam_name)
    noise = noise or s.get("noise", NOISE)
    beam, damping = s["beam"], DAMPING[beam_name][model]
    sensors = None
    if displacement:
        sensors = (Sensor("accel_tip", beam.length, "acceleration", "accel_tip"),
                   Sensor("disp_mid", 0.5 * beam.length, "displacement", "disp_mid"))
    effects = EFFECTS[effect] if effect else None
    rec = record(_nominal(beam), damping, EI=beam.nominal_EI, tip=s["tip"], excitation=s["excitation"],
                 fs=fs or s["fs"], duration=s["duration"], effects=effects, sensors=sensors, noise=noise, seed=seed,
                 numerics=s.get("numerics", Numerics()),
                 name=f"{beam_name}_{model}" + (f"_{effect}" if effect else ""))
    return rec, {"EI": beam.nominal_EI, **damping, **(effects or {})}


def clean_hammer(model: str, beam_name: str = "paper", changes: dict | None = None, excitation=None,
                 duration: float | None = None):
    """:func:`hammer`'s test without noise (Recording): at the truth, with ``changes`` (EI and
    damping by name) made to it, or struck by another ``excitation`` for ``duration`` s (default
    the test's)."""
    s = _setting(beam_name)
    params = {"EI": s["beam"].nominal_EI, **DAMPING[beam_name][model], **(changes or {})}
    EI = params.pop("EI")
    return record(_nominal(s["beam"]), params, EI=EI, tip=s["tip"], excitation=excitation or s["excitation"],
                  fs=s["fs"], duration=duration or s["duration"], numerics=s.get("numerics", Numerics()))


def true_noise_sd(model: str, beam_name: str = "paper") -> tuple[float, float]:
    """(sensor noise sd in m/s^2, force noise sd in N) of :func:`hammer`'s tip accelerometer and
    force channel: the rule of :data:`NOISE` applied to the clean signals, as ``record`` applies it."""
    clean, noise = clean_hammer(model, beam_name), _setting(beam_name).get("noise", NOISE)
    return (noise.sensor * float(np.sqrt(np.mean(clean.signals[:, 0] ** 2))),
            noise.force * float(np.max(np.abs(clean.force))))


@cache
def release(model: str = "q1", seed: int = 1):
    """A release test of the aluminium strip (a 1 N tip load let go at t = 0): (Recording, truth)."""
    beam, damping = cases.ALU_BEAM, DAMPING["alu"][model]
    rec = record(_nominal(beam), damping, EI=beam.nominal_EI, tip=cases.ALU_TIP, excitation=Release(1.0),
                 fs=1024.0, duration=1.0, noise=NOISE, seed=seed, name=f"alu_{model}_release")
    return rec, {"EI": beam.nominal_EI, **damping}
