"""``bayesbeam simulate``: a recording's sensors under a damping model, optionally with noise."""
from __future__ import annotations

from dataclasses import replace

import numpy as np

from bayesbeam import __version__
from bayesbeam.cli.common import parse_assignments
from bayesbeam.io import load_recording, write_recording, write_uff58
from bayesbeam.model import BeamModel

HELP = "simulate a recording's sensors under a damping model"


def add_arguments(sim) -> None:
    sim.add_argument("recording", help="recording directory (beam.toml + recording.csv)")
    sim.add_argument("--model", default="q1", help="preset (q1, q2, q3) or mechanisms joined by '+'")
    sim.add_argument("--effect", action="append", metavar="EFFECT",
                     help="add a missing-physics effect (repeatable), e.g. --effect root_compliance")
    sim.add_argument("--set", action="append", metavar="NAME=VALUE",
                     help="parameter value in SI units (repeatable); EI defaults to the nominal E*I")
    sim.add_argument("--n-intervals", type=int, default=16, help="spline intervals N (default 16)")
    sim.add_argument("--noise", type=float, default=0.0,
                     help="add Gaussian noise, sd as a fraction of each channel's RMS (e.g. 0.02)")
    sim.add_argument("--seed", type=int, default=None, help="random seed for --noise")
    sim.add_argument("--no-force-window", action="store_true",
                     help="use the whole force channel (default: impact force window)")
    sim.add_argument("--modes", type=int, default=9, help="modes to print (default 9)")
    sim.add_argument("--out", required=True, help="output recording directory")
    sim.add_argument("--overwrite", action="store_true", help="replace an existing --out")
    sim.add_argument("--uff", action="store_true", help="also write OUT/recording.uff (UFF58 time histories)")


def modal_table(model: BeamModel, params, n_modes: int = 9) -> str:
    """The first modes' natural frequencies and damping ratios as aligned text."""
    freq = model.natural_frequencies(params, n_modes)
    zeta = model.modal_damping_ratios(params, n_modes)
    lines = [f"{'mode':>4}  {'f_n (Hz)':>11}  {'zeta (%)':>9}"]
    lines += [f"{i + 1:>4}  {f:>11.4f}  {100 * z:>9.4f}" for i, (f, z) in enumerate(zip(freq, zeta))]
    return "\n".join(lines)


def add_noise(signals: np.ndarray, fraction: float, seed: int | None) -> np.ndarray:
    """Gaussian noise with standard deviation ``fraction`` of each channel's RMS."""
    rng = np.random.default_rng(seed)
    rms = np.sqrt(np.mean(signals**2, axis=0))
    return signals + rng.standard_normal(signals.shape) * fraction * rms


def run(args) -> int:
    rec = load_recording(args.recording)
    model = BeamModel.from_recording(rec, args.model, args.n_intervals,
                                     force_window=False if args.no_force_window else None,
                                     effects=args.effect)
    params = {"EI": rec.beam.nominal_EI, **parse_assignments(args.set)}
    values = model.values(params)
    initial = model.fit_initial(params) if rec.excitation.kind == "free_decay" else None
    signals = model.simulate(params, initial)
    if args.noise:
        signals = add_noise(signals, args.noise, args.seed)
    provenance = {"bayesbeam": __version__, "source": str(rec.source), "model": model.name,
                  "n_intervals": model.n_intervals, "noise_fraction_of_rms": float(args.noise or 0.0),
                  **{k: v for k, v in values.items() if np.isfinite(v)}}
    if args.seed is not None:
        provenance["seed"] = args.seed
    out = replace(rec.with_signals(signals), extra={**rec.extra, "simulation": provenance})
    path = write_recording(out, args.out, overwrite=args.overwrite)
    print(f"model {model.name} (N = {model.n_intervals}) on {rec.source}")
    print(", ".join(f"{k} = {v:.6g} {model.units.get(k, '')}".rstrip() for k, v in values.items()))
    print(modal_table(model, params, args.modes))
    print(f"wrote {path}")
    if args.uff:
        print(f"wrote {write_uff58(out, path / 'recording.uff')}")
    return 0
