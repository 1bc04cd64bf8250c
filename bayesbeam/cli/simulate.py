"""``bayesbeam simulate``: a recording's sensors under a damping model, optionally with noise."""
from __future__ import annotations

from dataclasses import replace

import numpy as np

from bayesbeam import __version__
from bayesbeam.cli.common import (
    DEFAULT_SEED,
    UsageError,
    add_effect_option,
    add_force_window_option,
    add_out_options,
    add_seed_option,
    model_spec,
    output_folder,
    parse_assignments,
    positive_int,
)
from bayesbeam.io import load_recording, write_recording, write_uff58
from bayesbeam.model import BeamModel

HELP = "simulate a recording's sensors under a damping model"


def add_arguments(sim) -> None:
    sim.add_argument("recording", help="recording directory (beam.toml + recording.csv)")
    sim.add_argument("--model", default="q1", help="preset (q1, q2, q3) or mechanisms joined by '+' "
                                                   "(bayesbeam models lists them)")
    add_effect_option(sim)
    sim.add_argument("--set", action="append", metavar="NAME=VALUE",
                     help="parameter value in SI units, repeatable (default: EI = the nominal E*I; "
                          "every other parameter must be given)")
    sim.add_argument("--n-intervals", type=positive_int, default=16, metavar="N", help="spline intervals N")
    sim.add_argument("--noise-level", type=float, default=0.0, metavar="FRACTION",
                     help="add Gaussian noise of standard deviation FRACTION x each channel's RMS (e.g. 0.02)")
    add_seed_option(sim)
    add_force_window_option(sim)
    sim.add_argument("--print-modes", type=positive_int, default=9, metavar="N",
                     help="modes whose frequency and damping ratio are printed")
    add_out_options(sim, "the simulated recording", recording=True)
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
    output_folder(args)
    if args.noise_level < 0:
        raise UsageError(f"--noise-level {args.noise_level}: must be >= 0 (a fraction of each channel's RMS)")
    rec = load_recording(args.recording)
    model = BeamModel.from_recording(rec, model_spec(args.model, args.effect), args.n_intervals,
                                     force_window=False if args.no_force_window else None)
    params = {"EI": rec.beam.nominal_EI, **parse_assignments(args.set)}
    values = model.values(params)
    initial = model.fit_initial(params) if rec.excitation.kind == "free_decay" else None
    signals = model.simulate(params, initial)
    seed = DEFAULT_SEED if args.seed is None else args.seed
    if args.noise_level:
        signals = add_noise(signals, args.noise_level, seed)
    provenance = {"bayesbeam": __version__, "source": str(rec.source), "model": model.name,
                  "n_intervals": model.n_intervals, "noise_fraction_of_rms": float(args.noise_level),
                  **{k: v for k, v in values.items() if np.isfinite(v)}}
    if args.noise_level:
        provenance["seed"] = seed
    out = replace(rec.with_signals(signals), extra={**rec.extra, "simulation": provenance})
    path = write_recording(out, args.out, overwrite=args.overwrite)
    print(f"model {model.name} (N = {model.n_intervals}) on {rec.source}")
    print(", ".join(f"{k} = {v:.6g} {model.units.get(k, '')}".rstrip() for k, v in values.items()))
    print(modal_table(model, params, args.print_modes))
    print(f"wrote {path}")
    if args.uff:
        print(f"wrote {write_uff58(out, path / 'recording.uff')}")
    return 0
