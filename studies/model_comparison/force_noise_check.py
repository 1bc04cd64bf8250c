"""Is q3's remaining offset on paper_q3_hammer bad luck or bias? Fresh noise on the same test.

    OPENBLAS_NUM_THREADS=1 python studies/model_comparison/force_noise_check.py [--draws 10]

The example's q3 posterior (force noise marginalised) puts gamma and b about two sd from the
truth. This script rebuilds the example's test from its ``truth.json`` (the half-sine hammer pulse
sampled band-limited, the true q3 parameters, the sensor and force noise levels), simulates
the clean tip acceleration with the model at N = 64, and fits ``--draws`` fresh noise draws
(sensor noise and force-channel noise, seeds 2000 +) exactly as ``bayesbeam compare`` does
(band to 150 Hz), by the optimum and its Laplace covariance at N = 48, with and without the
force noise marginalised. Per parameter it reports the mean of z = (optimum - truth)/sd (bias),
its sd (1 when the Laplace width is right) and how often the truth lies inside the 90 %
interval. Writes ``force_noise_check.md`` beside this script.

The simulation uses the fitting model's own physics (at a finer N), so this isolates what the
noise does; the example itself was made by an independent generator.
"""
from __future__ import annotations

import argparse
import json
from dataclasses import replace
from pathlib import Path

import numpy as np

from bayesbeam import BeamModel, load_recording
from bayesbeam.inference.fit import FitConfig, prepare
from bayesbeam.inference.sampler import find_optimum
from bayesbeam.io.atomic import write_text
from bayesbeam.response.signals import decimate

HERE = Path(__file__).resolve().parent
EXAMPLE = HERE.parents[1] / "data" / "examples" / "paper_q3_hammer"
FINE = 16          # the pulse is evaluated at 16x the recorded rate, then band-limited


def clean_test():
    """(recording with the true force and clean signals, truth values, sensor sd, force sd)."""
    rec = load_recording(EXAMPLE)
    truth = json.loads((EXAMPLE / "truth.json").read_text())
    exc = truth["excitation"]
    fine_time = rec.time[0] + np.arange(rec.n_samples * FINE) * rec.dt / FINE
    phase = (fine_time - exc["t0"]) / exc["width"]
    pulse = np.where((phase >= 0) & (phase <= 1), exc["peak"] * np.sin(np.pi * phase), 0.0)
    fine = replace(rec, time=fine_time, signals=np.zeros((fine_time.size, 1)), force=pulse)
    force = decimate(fine, FINE, force_window=False).force
    values = {"EI": truth["beam_true"]["EI"], **truth["damping"]}
    rec = replace(rec, force=force)
    clean = BeamModel.from_recording(rec, "q3", 64, force_window=False).simulate(values)
    noise = truth["noise"]
    return rec.with_signals(clean), values, noise["accel_tip_sigma"], noise["force_sigma_N"]


def z_scores(rec, values: dict, marginalised: bool) -> np.ndarray:
    post = prepare(rec, "q3", FitConfig(max_frequency=150.0, force_noise=marginalised), 48).posterior
    best = find_optimum(post, np.random.default_rng(0), start=values)
    k = len(post.model_names)
    truth = np.array([p.to_coordinate(values[n]) for p, n in zip(post.priors[:k], post.model_names)])
    return (best.theta[:k] - truth) / np.sqrt(np.diag(best.covariance)[:k])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--draws", type=int, default=10)
    args = parser.parse_args()
    rec, values, sensor_sd, force_sd = clean_test()
    z = {True: [], False: []}
    for seed in range(2000, 2000 + args.draws):
        rng = np.random.default_rng(seed)
        noisy = replace(rec.with_signals(rec.signals + sensor_sd * rng.standard_normal(rec.signals.shape)),
                        force=rec.force + force_sd * rng.standard_normal(rec.n_samples))
        for marginalised, draws in z.items():
            draws.append(z_scores(noisy, values, marginalised))
        print(f"seed {seed}: z with {np.round(z[True][-1], 2)}, without {np.round(z[False][-1], 2)}", flush=True)
    names = list(values)
    lines = ["# Force noise on the paper_q3_hammer test: fresh noise draws",
             "", "Written by `force_noise_check.py`; see its docstring for the method.", "",
             (f"{args.draws} draws (seeds 2000-{1999 + args.draws}); sensor noise sd {sensor_sd:.4g} m/s^2, "
              f"force noise sd {force_sd:.4g} N; fit: q3, N = 48, band to 150 Hz."), ""]
    for marginalised, label in ((True, "force noise marginalised (default)"), (False, "`--no-force-noise`")):
        arr = np.array(z[marginalised])
        lines += [f"## {label}", "", "| parameter | mean z (bias) | sd z (1 = calibrated) | truth inside 90 % |",
                  "|---|---|---|---|"]
        lines += [f"| {n} | {arr[:, i].mean():+.2f} | {arr[:, i].std(ddof=1):.2f} | "
                  f"{np.mean(np.abs(arr[:, i]) < 1.645):.0%} |" for i, n in enumerate(names)]
        lines.append("")
    path = HERE / "force_noise_check.md"
    write_text(path, "\n".join(lines))
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
