"""Where the time goes: a benchmark's job run in one process under cProfile, its top entries saved.

    python benchmarks/profiles.py compare [--max-frequency HZ] [--path current|baseline]
    python benchmarks/profiles.py diagnose [--model q1] [--concealed NAME] [--path current|baseline]

runs the job of ``benchmarks/compare.py`` or ``benchmarks/diagnose.py`` (same recording, same
settings; ``--path`` picks that script's baseline or current settings) on a serial executor, so
that every evaluation is in the profile (the benchmarks themselves spread the jobs over worker
processes, which a profile of the main process would show only as waiting), and writes
``benchmarks/results/<result>.<path>.profile.txt`` (the result's name as in benchmarks/README.md): the wall time and the
:data:`TOP` entries by cumulative and by own time. A serial run takes about twice a two-process
run's wall time, and cProfile adds its own overhead to every Python call: the shares, not the
seconds, are what to read.
"""
from __future__ import annotations

import cProfile
import io
import pstats
import sys
import time

import compare as compare_benchmark  # benchmarks/compare.py: the script's folder is first on sys.path
import diagnose as diagnose_benchmark
from tables import RESULTS

from bayesbeam.comparison import DEFAULT_MODELS, compare
from bayesbeam.diagnosis import diagnose
from bayesbeam.executors import SerialExecutor
from bayesbeam.io import load_recording

#: entries kept per ordering
TOP = 25
#: the benchmark scripts whose jobs can be profiled
BENCHMARKS = {"compare": compare_benchmark, "diagnose": diagnose_benchmark}


def job(benchmark: str, args, path: str):
    """The benchmark's job at its ``path`` settings, as a callable of no arguments, and its result's name."""
    module = BENCHMARKS[benchmark]
    baseline, current = module.configs(args)
    config = current if path == "current" else baseline
    if benchmark == "compare":
        rec = load_recording(module.EXAMPLE)
        name = "compare" if args.max_frequency else "compare_full"
        return (lambda: compare(rec, DEFAULT_MODELS, config, SerialExecutor())), name
    rec, model, _ = diagnose_benchmark.recording(args)
    name = diagnose_benchmark.result_name(args.concealed)
    return (lambda: diagnose(rec, model, config, SerialExecutor())), name


def summary(profile: cProfile.Profile, seconds: float, title: str) -> str:
    """The profile's top entries by cumulative and by own time, under a title line."""
    text = io.StringIO()
    text.write(f"{title}\nwall time {seconds:.1f} s under cProfile, one process\n")
    for order, label in (("cumulative", "cumulative time"), ("tottime", "own time")):
        text.write(f"\n--- top {TOP} by {label} ---\n")
        stats = pstats.Stats(profile, stream=text)
        stats.strip_dirs().sort_stats(order).print_stats(TOP)
    return text.getvalue()


def main(argv=None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    if not argv or argv[0] not in BENCHMARKS:
        print(__doc__)
        return 2
    benchmark, rest = argv[0], argv[1:]
    parser = BENCHMARKS[benchmark].parser()
    parser.add_argument("--path", choices=("current", "baseline"), default="current")
    args = parser.parse_args(rest)
    run, name = job(benchmark, args, args.path)
    profile = cProfile.Profile()
    started = time.perf_counter()
    profile.runcall(run)
    seconds = time.perf_counter() - started
    out = RESULTS / f"{name}.{args.path}.profile.txt"
    RESULTS.mkdir(exist_ok=True)
    command = " ".join(["python", "benchmarks/profiles.py", *argv])
    tmp = out.with_suffix(".tmp")
    tmp.write_text(summary(profile, seconds, f"Output of `{command}`"))
    tmp.replace(out)
    print(f"wrote {out} ({seconds:.1f} s)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
