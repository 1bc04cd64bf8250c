"""Is a missed truth bad luck or bias? Refit a study recording's true model on fresh noise draws.

    OPENBLAS_NUM_THREADS=1 python studies/concealed_effects/truth_check.py paper_root_compliance [--draws 12]

When a diagnosis names the right effect but its 90 % interval misses the true value, two causes
are possible: the noise draw (a 90 % interval misses one time in ten, and a strongly correlated
pair such as EI and k_theta can sit several sd off together), or a systematic error (the fit's
grid, the band-limited input, the anti-alias filter). This script separates them with the true
model (damping + effect, told to the fit) at the N the diagnosis chose (the tool's default
spline degree, as ``run.py``'s diagnoses):

1. on the study's recording: log likelihood (noise sd profiled) at the truth and at the optimum,
   2 Delta ln L against chi-square with k = number of model parameters (Wilks);
2. on the noise-free recording: the optimum must return the truth (no systematic error);
3. on ``--draws`` fresh noise draws of the same clean signal: the optimum's z-scores
   (optimum - truth) / Laplace sd for each parameter, their mean (bias) and sd (calibration,
   1 when the Laplace width is right), and how often the truth is inside the 90 % interval.

Writes ``truth_check_<name>.md`` beside this script.
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np
from scipy import stats

from bayesbeam.inference.fit import FitConfig, prepare
from bayesbeam.inference.sampler import find_optimum
from bayesbeam.io import load_recording
from bayesbeam.io.atomic import write_text

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
import generate
from run import MAX_FREQUENCY


def true_values(truth: dict) -> dict:
    return {"EI": truth["EI"], **truth["damping"], **truth["effect_parameters"]}


def optimum(rec, truth: dict, n_intervals: int):
    """(optimum theta, Laplace covariance, posterior, truth's coordinates) of the true model."""
    effects = (truth["effect"],) if truth["effect"] else ()
    post = prepare(rec, truth["damping_model"], FitConfig(max_frequency=MAX_FREQUENCY, effects=effects),
                   n_intervals).posterior
    values = true_values(truth)
    best = find_optimum(post, np.random.default_rng(0), start=values)
    k = len(post.model_names)
    x_true = np.array([p.to_coordinate(values[n]) for p, n in zip(post.priors[:k], post.model_names)])
    return best.theta[:k], best.covariance[:k, :k], post, x_true


def profiled_log_likelihood(post, x) -> float:
    return post.log_likelihood(post.with_profiled_noise(x))


def z_scores(x, cov, x_true) -> np.ndarray:
    return (x - x_true) / np.sqrt(np.diag(cov))


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("name", help="a study recording, e.g. paper_root_compliance")
    parser.add_argument("--draws", type=int, default=12, help="fresh noise draws (default 12)")
    args = parser.parse_args(argv)
    truth = json.loads((HERE / "recordings" / args.name / "truth.json").read_text())
    diagnosis = json.loads((HERE / "out" / args.name / "diagnosis.json").read_text())
    n = diagnosis["final"]["n_intervals"]
    effect = (truth["effect"], truth["effect_parameters"]) if truth["effect"] else (None, {})
    seed = truth["generation"]["seed"]

    rec = load_recording(HERE / "recordings" / args.name)
    x, cov, post, x_true = optimum(rec, truth, n)
    k = len(x)
    gain = 2 * (profiled_log_likelihood(post, x) - profiled_log_likelihood(post, x_true))
    names = post.model_names
    lines = [(f"# Truth check: {args.name} (true model {truth['damping_model']}"
             f"{'+' + truth['effect'] if truth['effect'] else ''}, degree {post.likelihood.model.degree}, N = {n}, band to {MAX_FREQUENCY:g} Hz)"), "",
             "Written by `truth_check.py`; see its docstring for the method.", "",
             "## 1. The study's recording", "",
             (f"2 Delta ln L (optimum vs truth) = {gain:.2f} with k = {k}: chi-square p = "
             f"{stats.chi2.sf(gain, k):.3f}."), "",
             "| parameter | truth | optimum | Laplace sd | z |", "|---|---|---|---|---|"]
    z = z_scores(x, cov, x_true)
    opt, tru = post.values(np.r_[x, np.zeros(post.ndim - k)]), true_values(truth)
    sd_phys = [abs(post.priors[i].to_value(x[i] + np.sqrt(cov[i, i])) - opt[n_]) for i, n_ in enumerate(names)]
    lines += [f"| {n_} | {tru[n_]:.6g} | {opt[n_]:.6g} | {s:.3g} | {zi:+.2f} |"
              for n_, s, zi in zip(names, sd_phys, z)]

    generate.NOISE, noise = 0.0, generate.NOISE
    clean, _ = generate.make(truth["beam"], effect[0], effect[1], seed)
    x0, _cov0, _, _ = optimum(clean, truth, n)
    lines += ["", "## 2. Noise-free recording", "",
              "Optimum minus truth in units of the noisy fit's Laplace sd (0 = no systematic error):", "",
              "| " + " | ".join(names) + " |", "|" + "---|" * k,
              "| " + " | ".join(f"{v:+.3f}" for v in (x0 - x_true) / np.sqrt(np.diag(cov))) + " |"]

    generate.NOISE = noise
    zs = []
    for d in range(args.draws):
        rec_d, _ = generate.make(truth["beam"], effect[0], effect[1], 1000 + d)
        xd, covd, _, _ = optimum(rec_d, truth, n)
        zs.append(z_scores(xd, covd, x_true))
        print(f"draw {d + 1}/{args.draws}: z = {np.round(zs[-1], 2)}", flush=True)
    zs = np.array(zs)
    inside = np.mean(np.abs(zs) <= stats.norm.ppf(0.95), axis=0)
    lines += ["", f"## 3. {args.draws} fresh noise draws (seeds 1000-{999 + args.draws})", "",
              "| parameter | mean z (bias) | sd z (1 = calibrated) | truth inside 90 % |", "|---|---|---|---|"]
    lines += [f"| {n_} | {m:+.2f} | {s:.2f} | {f:.0%} |"
              for n_, m, s, f in zip(names, zs.mean(0), zs.std(0, ddof=1), inside)]
    write_text(HERE / f"truth_check_{args.name}.md", "\n".join(lines) + "\n")
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
