"""Make the study's second set: physics around the beam, simulated by the independent reference.

    OPENBLAS_NUM_THREADS=1 python studies/concealed_effects/generate_reference.py [--overwrite]

Recordings ``recordings/ref_<case>/`` made by :mod:`tests.reference` (Hermite finite elements,
exact exponential stepping, a zero-phase anti-alias FIR before sampling: nothing of bayesbeam's
physics), of the paper's beam (Table 1, no tip body) with q1 damping (gamma 0.3 N s/m^2, cdI 7e-5
N m^2 s), a Gaussian hammer pulse at 0.75 m, a tip accelerometer, 3 s at 1024 Hz, 2 % sensor
noise and 0.5 % force noise. Concealed in each, one thing the beam is attached to or the chain that
measures it:

* ``ref_attachment``: a body of 3 % of the beam's mass on a spring and dashpot at 0.6 m, its own
  mode at 45 Hz (between beam modes 2 and 3), link damping ratio 2 %;
* ``ref_base_support``: the clamp on a 5 kg base whose own mode is at 80 Hz (damping ratio 5 %);
* ``ref_high_pass``: the response channel's AC coupling at 1 Hz (mode 1 at 3.7 Hz);
* ``ref_mains_lines``: a 50 Hz line 20 dB above the noise floor of the amplitude spectrum (its
  DFT peak A N / 2 ten times the noise's sigma sqrt(N): A = 20 sigma / sqrt(N), N samples);
* ``ref_clamp_loss``: a compliant, lossy clamp, k_theta 4000 N m/rad and c_theta 0.8 N m s/rad;
* ``ref_null1``, ``ref_null2``: nothing concealed (two noise seeds).

Each truth.json names the concealed effects and their parameters by the names the diagnosis fits
(a base's f_b, m_b, zeta_b and a body's f_a, m_a, zeta_a, x_a, from which the simulator's k and c
are made).
"""
from __future__ import annotations

import argparse
import json
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parents[1]))       # tests.reference: the repository's simulator

from bayesbeam.io import Beam, load_recording, write_recording
from bayesbeam.io.provenance import write_json
from tests.reference import Hammer, Noise, record
from tests.reference.daq import mains_pickup

BEAM = Beam(length=1.0, density=1710.0, area=0.597e-3, second_moment=1.64e-9, modulus=2.7e10)
DAMPING = {"gamma": 0.3, "cdI": 7e-5}
FS, DURATION, NOISE = 1024.0, 3.0, Noise(sensor=0.02, force=0.005)
BEAM_MASS = BEAM.rho_a * BEAM.length


#: the attached body and the base by the names the diagnosis fits (frequency Hz, mass kg, damping ratio)
BODY = {"f_a": 45.0, "m_a": 0.03 * BEAM_MASS, "zeta_a": 0.02, "x_a": 0.6}
BASE = {"f_b": 80.0, "m_b": 5.0, "zeta_b": 0.05}


def _spring_and_dashpot(mass: float, frequency: float, damping_ratio: float) -> tuple[float, float]:
    """(k, c) the simulator takes for a mass on a spring and dashpot of this natural frequency and
    damping ratio: k = m omega^2, c = 2 zeta m omega."""
    omega = 2 * np.pi * frequency
    return mass * omega**2, 2 * damping_ratio * mass * omega


def _simulated_body() -> dict:
    k_a, c_a = _spring_and_dashpot(BODY["m_a"], BODY["f_a"], BODY["zeta_a"])
    return {"m_a": BODY["m_a"], "k_a": k_a, "c_a": c_a, "x_a": BODY["x_a"]}


def _simulated_base() -> dict:
    k_b, c_b = _spring_and_dashpot(BASE["m_b"], BASE["f_b"], BASE["zeta_b"])
    return {"m_b": BASE["m_b"], "k_b": k_b, "c_b": c_b}


#: case -> (simulated effects, {effect: {parameter: truth}} in the diagnosis's names, seed)
CASES = {
    "attachment": (_simulated_body(), {"attachment": BODY}, 21),
    "base_support": (_simulated_base(), {"base_support": BASE}, 22),
    "high_pass": ({"f_hp": 1.0}, {"high_pass": {"f_hp": 1.0}}, 23),
    "mains_lines": ({}, {"mains_lines": {"f_mains": 50.0}}, 24),
    "clamp_loss": ({"k_theta": 4000.0, "c_theta": 0.8},
                   {"root_compliance": {"k_theta": 4000.0}, "root_damping": {"c_theta": 0.8}}, 25),
    "null1": ({}, {}, 26),
    "null2": ({}, {}, 27),
}


def make(case: str, out: Path) -> dict:
    """Simulate ``case`` into ``out`` and return its truth.json."""
    effects, truth_effects, seed = CASES[case]
    rec = record(BEAM, DAMPING, excitation=Hammer(0.75, peak=20.0, width=1e-3, t0=0.02), fs=FS, duration=DURATION,
                 effects=effects, noise=NOISE, seed=seed, out=out, name=f"ref_{case}")
    truth = json.loads((out / "truth.json").read_text())
    if case == "mains_lines":
        sigma = truth["noise"]["sensor_sigma"]["accel_tip"]
        amplitude = 20 * sigma / np.sqrt(rec.n_samples)
        rec = load_recording(out)
        line = mains_pickup(rec.time, 50.0, [amplitude], [0.7])
        write_recording(replace(rec, signals=rec.signals + line[:, None]), out, overwrite=True)
        truth["mains"] = {"f_mains": 50.0, "amplitude": amplitude, "phase": 0.7}
    return {**truth, "beam": "paper_ref", "damping_model": "q1", "effect": "+".join(truth_effects) or None,
            "effect_parameters": {p: v for params in truth_effects.values() for p, v in params.items()}}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--overwrite", action="store_true")
    args = parser.parse_args(argv)
    for case in CASES:
        out = HERE / "recordings" / f"ref_{case}"
        if out.exists() and not args.overwrite:
            print(f"{out.name}: exists (--overwrite to remake)")
            continue
        truth = make(case, out)
        write_json(truth, out / "truth.json")
        print(f"{out.name}: {truth['effect'] or 'null'} {truth['effect_parameters']}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
