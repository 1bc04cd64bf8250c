"""``bayesbeam fit``: the posterior of one damping model's parameters, to converged chains."""
from __future__ import annotations

from pathlib import Path

from bayesbeam.cli.common import EXIT_NOT_CONVERGED, UsageError
from bayesbeam.io import load_recording

HELP = "sample the posterior of a damping model's parameters"


def add_arguments(fit) -> None:
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
    fit.add_argument("--no-force-noise", action="store_true",
                     help="do not marginalise the response driven by the force channel's noise inside the impact window")
    fit.add_argument("--walkers", type=int, help="emcee walkers (default max(4 x dim, 16))")
    fit.add_argument("--max-steps", type=int, help="cap on steps per walker (default 20000)")
    fit.add_argument("--seed", type=int, help="random seed (default 1)")
    fit.add_argument("--processes", type=int, default=1, help="local worker processes (default 1)")
    fit.add_argument("--executor", choices=["local", "mpi"], default="local",
                     help="where likelihoods run: local processes or an MPI pool (mpi4py.futures)")
    fit.add_argument("--resume", action="store_true", help="continue the chains saved in OUT/chains.h5")
    fit.add_argument("--quiet", action="store_true", help="no progress lines on stderr")
    fit.add_argument("--out", required=True, help="output directory")


def fit_config(args):
    """The FitConfig of ``args``: a ``--config`` file with the command-line options on top."""
    from bayesbeam.inference import FitConfig, load_fit_config

    overrides = {"start": args.start, "stop": args.stop, "max_frequency": args.max_frequency,
                 "n_intervals": args.n_intervals, "noise": args.noise, "walkers": args.walkers,
                 "max_steps": args.max_steps, "seed": args.seed,
                 "effects": tuple(args.effect) if args.effect else None,
                 "force_noise": False if args.no_force_noise else None}
    return (load_fit_config(args.config, **overrides) if args.config
            else FitConfig(**{k: v for k, v in overrides.items() if v is not None}))


def run(args) -> int:
    from bayesbeam.inference import fit
    from bayesbeam.inference.sampler import stderr_progress
    from bayesbeam.report.fit_outputs import write_fit

    rec = load_recording(args.recording)
    config = fit_config(args)
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
