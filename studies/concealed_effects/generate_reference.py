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
(a base's f_b, m_b, zeta_b from the simulated m_b, k_b, c_b; a body's f_a, m_a, zeta_a, x_a from its
m_a, k_a, c_a, x_a).
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


def _body() -> dict:
    m_a, omega_a, zeta_a = 0.03 * BEAM_MASS, 2 * np.pi * 45.0, 0.02
    return {"m_a": m_a, "k_a": m_a * omega_a**2, "c_a": 2 * zeta_a * m_a * omega_a, "x_a": 0.6}


def _body_truth(body: dict) -> dict:
    omega = np.sqrt(body["k_a"] / body["m_a"])
    return {"f_a": float(omega / (2 * np.pi)), "m_a": body["m_a"], "zeta_a": float(body["c_a"] / (2 * body["m_a"] * omega)),
            "x_a": body["x_a"]}


def _base() -> dict:
    m_b, omega_b, zeta_b = 5.0, 2 * np.pi * 80.0, 0.05
    return {"m_b": m_b, "k_b": m_b * omega_b**2, "c_b": 2 * zeta_b * m_b * omega_b}


def _base_truth(base: dict) -> dict:
    omega = np.sqrt(base["k_b"] / base["m_b"])
    return {"f_b": float(omega / (2 * np.pi)), "m_b": base["m_b"], "zeta_b": float(base["c_b"] / (2 * base["m_b"] * omega))}


#: case -> (simulated effects, {effect: {parameter: truth}} in the diagnosis's names, seed)
CASES = {
    "attachment": (_body(), {"attachment": _body_truth(_body())}, 21),
    "base_support": (_base(), {"base_support": _base_truth(_base())}, 22),
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
