"""Make the concealed-effects study's recordings: each catalogue effect on two beams, plus nulls.

    OPENBLAS_NUM_THREADS=1 python studies/concealed_effects/generate.py [--overwrite]

Beams (hammer at 0.75 l, Gaussian force pulse, one tip accelerometer, 3 s at 1024 Hz):

* ``paper``: Banks & Inman's beam (Table 1), no tip body, q3 damping at the paper's values;
* ``alu``: an aluminium strip 0.5 m x 25 mm x 3 mm with a 50 g tip block, q1 damping.

**Not the fitting model's grid.** Every recording is simulated with N = 48 spline intervals (the
fits use N <= 16) at 4096 Hz (the force evaluated at the fine instants), then passed through a
zero-phase anti-alias FIR (flat to 0.40 fs of the recorded rate, stopped from 0.50 fs) and kept
every 4th sample, as a DAQ records; the recorded force is the pulse sampled at 1024 Hz (clean).
Sensor noise: Gaussian, 2 % of the channel's RMS, seeded.

**Sizes** (moderate: a careful analyst could see them, they are not glaring), calibrated here on
each beam with the generating model: a root spring lowering mode 1 by 2 %; a sensor of 12 g on
the paper beam, 4 g on the 100 g strip (with its 50 g tip block: mode 1 -2.5 %); a 0.5 ms delay; a tension raising mode 1 by 2 %; quadratic
drag and tip friction each changing the response by 10 % RMS. ``recordings.md`` lists them all.
"""
from __future__ import annotations

import argparse
import time
from dataclasses import replace
from pathlib import Path

import numpy as np
from scipy import optimize, signal

from bayesbeam.io import Beam, Excitation, Recording, Sensor, TipBody, load_recording, write_recording
from bayesbeam.io.atomic import write_text
from bayesbeam.io.provenance import write_json
from bayesbeam.model import BeamModel

HERE = Path(__file__).resolve().parent
FS, FACTOR, DURATION, N_FINE, NOISE = 1024.0, 4, 3.0, 48, 0.02
#: the recorded band edges as fractions of FS (the shipped examples' DAQ)
PASS, STOP = 0.40, 0.50
SENSOR = Sensor(name="accel_tip", location=None, quantity="acceleration", column="accel_tip")

BEAMS = {
    "paper": {"beam": Beam(length=1.0, density=1710.0, area=0.597e-3, second_moment=1.64e-9, modulus=2.7e10),
              "tip": TipBody(), "model": "q3", "damping": {"gamma": 0.12, "a": 0.025, "b": 0.18},
              "pulse": {"peak": 20.0, "width": 0.003}, "sensor_mass": 0.012},
    "alu": {"beam": Beam(length=0.5, density=2700.0, area=7.5e-5, second_moment=5.625e-11, modulus=7.0e10),
            "tip": TipBody(mass=0.05, rotary_inertia=2.3e-6), "model": "q1",
            "damping": {"gamma": 0.18, "cdI": 5.5e-6}, "pulse": {"peak": 5.0, "width": 0.002},
            "sensor_mass": 0.004},
}
EFFECTS = ("root_compliance", "sensor_mass", "measurement_delay", "axial_load", "quadratic_drag", "dry_friction")
NULLS = {"null1": 11, "null2": 12}


def hammer(spec: dict, fs: float) -> Recording:
    """A hammer recording of ``spec``'s beam at ``fs`` with zero signals (the force: a Gaussian pulse)."""
    beam = spec["beam"]
    n = round(fs * DURATION)
    t = np.arange(n) / fs
    force = spec["pulse"]["peak"] * np.exp(-0.5 * ((t - 0.02) / spec["pulse"]["width"]) ** 2)
    return Recording(beam=beam, tip=spec["tip"], excitation=Excitation("force", location=0.75 * beam.length,
                                                                       column="force"),
                     sensors=(replace(SENSOR, location=beam.length),), time=t, signals=np.zeros((n, 1)),
                     force=force)


def truth_params(spec: dict) -> dict:
    return {"EI": spec["beam"].nominal_EI, **spec["damping"]}


# ---------------------------------------------------------------------------- calibration
def calibrate(name: str, spec: dict) -> dict:
    """The effect's parameter at the study's size on this beam (see the module docstring)."""
    coarse = hammer(spec, FS)
    base = truth_params(spec)
    if name == "sensor_mass":
        return {"m_s": spec["sensor_mass"]}
    if name == "measurement_delay":
        return {"tau": 5e-4}
    if name in ("root_compliance", "axial_load"):
        f0 = BeamModel(coarse, spec["model"], N_FINE).natural_frequencies(base, 1)[0]
        model = BeamModel(coarse, spec["model"], N_FINE, effects=name)
        key, target = ("k_theta", -0.02) if name == "root_compliance" else ("P", +0.02)

        def shift(log_value):
            return model.natural_frequencies({**base, key: np.exp(log_value)}, 1)[0] / f0 - 1 - target
        # k_theta from EI/l (nearly a pin) to 1e4 EI/l (nearly a clamp); P from 1 mN to 1 kN
        scale = base["EI"] / spec["beam"].length if key == "k_theta" else 1e-3
        return {key: float(np.exp(optimize.brentq(shift, np.log(scale), np.log(1e4 * scale if key == "k_theta"
                                                                                else 1e3), xtol=1e-6)))}
    key = "c_q" if name == "quadratic_drag" else "F_c"
    linear = BeamModel(coarse, spec["model"], 16).simulate(base)
    model = BeamModel(coarse, spec["model"], 16, effects=name)

    def change(log_value):
        y = model.simulate({**base, key: np.exp(log_value)})
        return np.sqrt(np.mean((y - linear) ** 2) / np.mean(linear**2)) - 0.10
    return {key: float(np.exp(optimize.brentq(change, np.log(1e-5), np.log(1e3), xtol=1e-3)))}


def size(name: str, spec: dict, values: dict) -> dict:
    """How big the effect is: mode 1-4 frequency shifts (linear effects), RMS change (all)."""
    rec = hammer(spec, FS)
    base = truth_params(spec)
    plain = BeamModel(rec, spec["model"], 16)
    model = BeamModel(rec, spec["model"], 16, effects=name)
    y0, y1 = plain.simulate(base), model.simulate({**base, **values})
    out = {"rms_change": float(np.sqrt(np.mean((y1 - y0) ** 2) / np.mean(y0**2)))}
    if all(e.linear for e in model.effects):
        f0, f1 = plain.natural_frequencies(base, 4), model.natural_frequencies({**base, **values}, 4)
        out["frequency_shift_percent"] = [float(v) for v in 100 * (f1 / f0 - 1)]
    return out


# ---------------------------------------------------------------------------- generation
def anti_alias(y: np.ndarray) -> np.ndarray:
    """Zero-phase FIR at the fine rate (flat to PASS FS, stop band from STOP FS), every FACTOR-th sample."""
    fine = FS * FACTOR
    taps = signal.firwin(1001, 0.5 * (PASS + STOP) * FS, width=(STOP - PASS) * FS, fs=fine)
    return signal.filtfilt(taps, [1.0], y, axis=0)[::FACTOR]


def make(beam_name: str, effect: str | None, values: dict, seed: int) -> tuple[Recording, dict]:
    spec = BEAMS[beam_name]
    fine = hammer(spec, FS * FACTOR)
    clean = anti_alias(BeamModel(fine, spec["model"], N_FINE, force_window=False, effects=effect).simulate(
        {**truth_params(spec), **values}))
    rng = np.random.default_rng(seed)
    noisy = clean + NOISE * np.sqrt(np.mean(clean**2, axis=0)) * rng.standard_normal(clean.shape)
    rec = hammer(spec, FS).with_signals(noisy)
    generation = {"n_intervals": N_FINE, "fs_fine": FS * FACTOR, "fs": FS, "duration": DURATION,
                  "noise_fraction": NOISE, "seed": seed,
                  "filter": f"zero-phase FIR (firwin 1001 taps, filtfilt) flat to {PASS} fs, stop from {STOP} fs, "
                            f"decimated by {FACTOR}"}
    truth = {"beam": beam_name, "damping_model": spec["model"], "damping": spec["damping"],
             "EI": spec["beam"].nominal_EI, "effect": effect, "effect_parameters": values,
             "size": size(effect, spec, values) if effect else None, "generation": generation}
    return replace(rec, extra={**rec.extra, "simulation": {"study": "concealed_effects", **generation}}), truth


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--overwrite", action="store_true", help="replace existing recordings")
    args = parser.parse_args(argv)
    started = time.perf_counter()
    table = ["| recording | damping | effect | parameter | mode 1-4 shift (%) | response change (RMS) |",
             "|---|---|---|---|---|---|"]
    for b, beam_name in enumerate(BEAMS):
        jobs = [(e, 100 * b + i) for i, e in enumerate(EFFECTS)] + [(None, 100 * b + s) for s in NULLS.values()]
        for k, (effect, seed) in enumerate(jobs):
            name = f"{beam_name}_{effect or list(NULLS)[k - len(EFFECTS)]}"
            values = calibrate(effect, BEAMS[beam_name]) if effect else {}
            rec, truth = make(beam_name, effect, values, seed)
            path = write_recording(rec, HERE / "recordings" / name, overwrite=args.overwrite)
            write_json(truth, path / "truth.json")
            load_recording(path)                                    # it reads back
            shift = truth["size"] and truth["size"].get("frequency_shift_percent")
            table.append(f"| {name} | {truth['damping_model']} {truth['damping']} | {effect or '-'} | "
                         f"{', '.join(f'{k} = {v:.4g}' for k, v in values.items()) or '-'} | "
                         f"{', '.join(f'{v:+.2f}' for v in shift) if shift else '-'} | "
                         f"{truth['size']['rms_change']:.1%} |" if truth["size"] else f"| {name} | "
                         f"{truth['damping_model']} {truth['damping']} | - | - | - | - |")
            print(f"{name}: {values} ({time.perf_counter() - started:.0f} s)", flush=True)
    text = ("# Concealed-effects recordings\n\nWritten by `generate.py` (see its docstring for how they are "
            "made).\n\n" + "\n".join(table) + "\n")
    write_text(HERE / "recordings.md", text)
    print(f"done in {time.perf_counter() - started:.0f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
