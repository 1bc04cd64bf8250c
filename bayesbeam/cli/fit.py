"""``bayesbeam fit``: the posterior of one damping model's parameters, to converged chains."""
from __future__ import annotations

import os

from bayesbeam.cli.common import (
    EXIT_NOT_CONVERGED,
    UsageError,
    add_effect_option,
    add_force_window_option,
    add_out_options,
    add_run_options,
    add_seed_option,
    output_folder,
    positive_int,
)
from bayesbeam.inference.fit import N_LADDERS, FitConfig
from bayesbeam.inference.likelihood import NOISE_MODELS
from bayesbeam.io import load_recording

HELP = "sample the posterior of a damping model's parameters"


def add_arguments(fit) -> None:
    fit.add_argument("recording", help="recording directory (beam.toml + recording.csv)")
    fit.add_argument("--model", default="q1", help="preset (q1, q2, q3) or mechanisms joined by '+' "
                                                   "(bayesbeam models lists them)")
    add_effect_option(fit)
    add_fit_options(fit)
    fit.add_argument("--walkers", type=positive_int, metavar="N", help="emcee walkers (default: max(4 x parameters, 16))")
    fit.add_argument("--max-steps", type=positive_int, metavar="N", help="cap on steps per walker (default: 20000)")
    add_run_options(fit)
    add_out_options(fit, "posterior.nc, summary.json, chains.h5 and plots",
                    resume="continue the chains saved in OUT/chains.h5")


def add_fit_options(p) -> None:
    """The fitted window and band, the discretisation, the noise model, the force channel and the
    seed: the options of a fit, shared by every command that fits (a --config file's settings
    apply where an option is not given)."""
    p.add_argument("--config", metavar="FILE", help="fit file (TOML): [fit] settings and [prior.NAME] tables (default: none)")
    p.add_argument("--n-intervals", type=positive_int, metavar="N", help="spline intervals N (default: automatic)")
    p.add_argument("--degree", type=int, choices=sorted(N_LADDERS), help="the splines' polynomial degree "
                   f"(default: {FitConfig.degree}; quintic reaches the cubic's accuracy with a third of the intervals)")
    p.add_argument("--start", type=float, metavar="SECONDS", help="start of the fitted window (s; default: the record's start, "
                                                "or the free decay's)")
    p.add_argument("--stop", type=float, metavar="SECONDS", help="end of the fitted window (s; default: the record's end)")
    p.add_argument("--max-frequency", type=float, metavar="HZ",
                   help="top of the fitted band (Hz; default: 0.38 fs, the record is decimated to suit)")
    p.add_argument("--noise", choices=NOISE_MODELS, help="the likelihood's noise model per channel "
                                                        "(default: white)")
    p.add_argument("--no-force-noise", action="store_true",
                   help="do not marginalise the response driven by the force channel's noise inside the impact window")
    add_force_window_option(p)
    add_seed_option(p)


def fit_config(args):
    """The FitConfig of ``args``: a ``--config`` file with the command-line options on top."""
    from bayesbeam.inference import load_fit_config

    overrides = {"start": args.start, "stop": args.stop, "max_frequency": args.max_frequency,
                 "n_intervals": args.n_intervals, "degree": args.degree, "noise": args.noise, "walkers": args.walkers,
                 "max_steps": args.max_steps, "seed": args.seed,
                 "force_window": False if args.no_force_window else None,
                 "force_noise": False if args.no_force_noise else None}
    return (load_fit_config(args.config, **overrides) if args.config
            else FitConfig(**{k: v for k, v in overrides.items() if v is not None}))


def run(args) -> int:
    from bayesbeam.api import run_fit
    from bayesbeam.report.fit_outputs import write_fit

    out = output_folder(args)
    rec = load_recording(args.recording)
    out.mkdir(parents=True, exist_ok=True)
    result = run_fit(args, rec, backend_path=out / "chains.h5").result
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


def walker_pool(args):
    """The pool of the chains' likelihood evaluations: none (serial), local processes or MPI ranks.
    The walkers of a step are evaluated together, so the pool must hold the posterior in each
    worker: a Dask cluster, which runs whole jobs, is for compare, batch and diagnose."""
    if args.executor == "mpi":
        from bayesbeam.executors import mpi_pool_class
        from bayesbeam.inference.sampler import init_worker

        pool_class = mpi_pool_class()
        # the posterior is only known after preparation: fit() passes it through _pool_for
        return _DeferredPool(lambda post: pool_class(initializer=init_worker, initargs=(post,)))
    if args.executor not in ("serial", "local"):
        raise UsageError(f"fit --executor {args.executor}: fit evaluates its walkers' likelihoods in a pool "
                         "on this machine or over MPI, not on a Dask cluster. Fix: --executor local or mpi "
                         "(compare, batch and diagnose take a Dask scheduler address)")
    processes = 1 if args.executor == "serial" else args.processes or os.cpu_count() or 1
    return processes if processes > 1 else None


class _DeferredPool:
    """A pool factory called with the log posterior once it exists (see inference.fit._pool_for)."""

    def __init__(self, factory):
        self.factory = factory
