"""The ``bayesbeam`` command line: thin argument parsing over the library.

Exit status: 0 on success, 2 for bad input (a message naming the file, key or value and the fix).
"""
from __future__ import annotations

import argparse
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np

from bayesbeam import __version__
from bayesbeam.io import RecordingError, load_recording, write_recording
from bayesbeam.model import BeamModel

EXIT_BAD_INPUT = 2
#: a fit that stopped at --max-steps before its chains converged
EXIT_NOT_CONVERGED = 3


class UsageError(ValueError):
    """Bad command-line input, reported without a traceback."""


def parse_assignments(items: list[str]) -> dict[str, float]:
    """``["EI=44", "gamma=0.09"]`` -> ``{"EI": 44.0, "gamma": 0.09}``."""
    out = {}
    for item in items or []:
        key, sep, value = item.partition("=")
        if not sep or not key.strip():
            raise UsageError(f"--set {item!r}: expected NAME=VALUE, e.g. --set EI=44.0")
        try:
            out[key.strip()] = float(value)
        except ValueError:
            raise UsageError(f"--set {item!r}: {value!r} is not a number") from None
    return out


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


def cmd_simulate(args) -> int:
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
    return 0


def cmd_fit(args) -> int:
    from bayesbeam.inference import FitConfig, fit, load_fit_config
    from bayesbeam.inference.sampler import stderr_progress
    from bayesbeam.report.fit_outputs import write_fit

    rec = load_recording(args.recording)
    overrides = {"start": args.start, "stop": args.stop, "max_frequency": args.max_frequency,
                 "n_intervals": args.n_intervals, "noise": args.noise, "walkers": args.walkers,
                 "max_steps": args.max_steps, "seed": args.seed,
                 "effects": tuple(args.effect) if args.effect else None}
    config = (load_fit_config(args.config, **overrides) if args.config
              else FitConfig(**{k: v for k, v in overrides.items() if v is not None}))
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    log = None if args.quiet else stderr_progress
    result = fit(rec, args.model, config, pool=_executor(args), backend_path=out / "chains.h5",
                 resume=args.resume, log=log, progress=log)
    paths = write_fit(result, out)
    summary = result.summary
    print(f"model {summary['model']} ({result.problem.model.name}), N = {summary['n_intervals']}, "
          f"band 0-{summary['band']['max_frequency_hz']:.0f} Hz")
    for name, s in summary["parameters"].items():
        print(f"  {name:>8} = {s['q50']:.6g}  90% [{s['q05']:.6g}, {s['q95']:.6g}] {s['unit']}  "
              f"(ESS {s['ess']:.0f}, R-hat {s['r_hat']:.3f})")
    state = "converged" if result.converged else "NOT converged"
    print(f"chains {state}: {summary['convergence']['reason']}; wrote {', '.join(p.name for p in paths)} in {out}")
    return 0 if result.converged else EXIT_NOT_CONVERGED


def _executor(args):
    """The pool for parallel likelihood evaluations: local processes (default) or MPI."""
    if args.executor == "mpi":
        try:
            from mpi4py.futures import MPIPoolExecutor
        except ImportError:
            raise UsageError("--executor mpi needs mpi4py (pip install mpi4py) and an MPI launch, "
                             "e.g. mpiexec -n 8 python -m mpi4py.futures -m bayesbeam.cli fit ...") from None
        from bayesbeam.inference.sampler import init_worker

        # the posterior is only known after preparation: fit() passes it through _pool_for
        return _DeferredPool(lambda post: MPIPoolExecutor(initializer=init_worker, initargs=(post,)))
    return args.processes if args.processes > 1 else None


class _DeferredPool:
    """A pool factory called with the log posterior once it exists (see inference.fit._pool_for)."""

    def __init__(self, factory):
        self.factory = factory


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="bayesbeam", description=__doc__.splitlines()[0])
    parser.add_argument("--version", action="version", version=f"bayesbeam {__version__}")
    sub = parser.add_subparsers(dest="command", required=True)

    sim = sub.add_parser("simulate", help="simulate a recording's sensors under a damping model")
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
    sim.set_defaults(func=cmd_simulate)

    fit = sub.add_parser("fit", help="sample the posterior of a damping model's parameters")
    fit.add_argument("recording", help="recording directory (beam.toml + recording.csv)")
    fit.add_argument("--model", default="q1", help="preset (q1, q2, q3) or mechanisms joined by '+'")
    fit.add_argument("--effect", action="append", metavar="EFFECT", help="add a missing-physics effect")
    fit.add_argument("--config", help="fit file (TOML): [fit] settings and [prior.NAME] tables")
    fit.add_argument("--n-intervals", type=int, help="fix the spline intervals N (default: automatic)")
    fit.add_argument("--start", type=float, help="start of the fitted window (s)")
    fit.add_argument("--stop", type=float, help="end of the fitted window (s)")
    fit.add_argument("--max-frequency", type=float,
                     help="top of the fitted band (Hz; default 0.38 fs, the record is decimated to suit)")
    fit.add_argument("--noise", choices=["white", "ar1"], help="noise model per channel (default white)")
    fit.add_argument("--walkers", type=int, help="emcee walkers (default max(4 x dim, 16))")
    fit.add_argument("--max-steps", type=int, help="cap on steps per walker (default 20000)")
    fit.add_argument("--seed", type=int, help="random seed (default 1)")
    fit.add_argument("--processes", type=int, default=1, help="local worker processes (default 1)")
    fit.add_argument("--executor", choices=["local", "mpi"], default="local",
                     help="where likelihoods run: local processes or an MPI pool (mpi4py.futures)")
    fit.add_argument("--resume", action="store_true", help="continue the chains saved in OUT/chains.h5")
    fit.add_argument("--quiet", action="store_true", help="no progress lines on stderr")
    fit.add_argument("--out", required=True, help="output directory")
    fit.set_defaults(func=cmd_fit)
    return parser


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    try:
        return args.func(args)
    except (RecordingError, UsageError, ValueError, FileExistsError) as exc:
        print(f"bayesbeam {args.command}: error: {exc}", file=sys.stderr)
        return EXIT_BAD_INPUT


if __name__ == "__main__":
    sys.exit(main())
