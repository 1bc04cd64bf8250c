"""Mutation run: named deliberate bugs in bayesbeam/, each applied alone to a copy of the tree, and
the verdict of the tests that guard it (docs/testing.md, "Mutation run").

    python -m tests.mutants [NAME ...] [--list] [--tests PATH ...] [--all-tests] [--per-path]

Each mutant is one exact edit (file, source text, replacement). For each, the working tree (the
package, tests, data, docs, studies; no .git or caches) is copied to a temporary directory, the
edit is applied there (refused unless the source text occurs exactly once, so a stale mutant
cannot silently test the unmutated code), and ``python -m pytest -q -x`` runs the mutant's guard
paths inside the copy with PYTHONPATH on it. A probe plugin (``-p _mutant_probe``) records which
bayesbeam the run imported, and the run counts only if it is the copy's. Verdicts: "caught" (a
test failed or errored; its node id is reported), "not caught" (all passed), "error" (collection
failed, no test ran, or the copy was not the package imported). The tree itself is never edited.
Not collected by pytest (no test_ prefix).
"""
from __future__ import annotations

import argparse
import os
import shutil
import subprocess
import sys
import tempfile
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
#: left out of the copy: version control, caches, build metadata (stale bytecode must not shadow
#: the mutated source)
IGNORE = shutil.ignore_patterns(".git", ".venv", "__pycache__", "*.egg-info", ".pytest_cache", ".ruff_cache",
                                ".hypothesis", ".benchmarks")
PROBE_MODULE = "_mutant_probe"
#: the probe plugin written into each copy: it refuses the run unless the imported bayesbeam is
#: the copy's, and writes the imported path for the driver to check again
PROBE = '''import os
from pathlib import Path

import pytest


def pytest_configure(config):
    import bayesbeam
    where = Path(bayesbeam.__file__).resolve()
    Path(os.environ["BAYESBEAM_MUTANT_PROBE"]).write_text(str(where))
    if Path(os.environ["BAYESBEAM_MUTANT_ROOT"]).resolve() not in where.parents:
        raise pytest.UsageError(f"bayesbeam imported from {where}, not from the mutated copy")
'''
RUN_TIMEOUT = 3600.0   # seconds per pytest run; far above the guards' few seconds


@dataclass(frozen=True)
class Mutant:
    """A deliberate bug: ``source`` (exactly once in ``file``) becomes ``replacement``; ``guards``
    are the test paths (files or node ids) expected to catch it."""

    name: str
    file: str
    source: str
    replacement: str
    guards: tuple[str, ...]
    bug: str


FRACTIONAL = "bayesbeam/physics/mechanisms/fractional.py"
FRACTIONAL_LINE = "return -c_f * np.power(np.asarray(s, dtype=complex), nu)"
THERMOELASTIC = "bayesbeam/physics/mechanisms/thermoelastic.py"
SIGNALS = "bayesbeam/response/signals.py"
SANITY = "tests/reference/test_literature.py::test_sanity_against_bayesbeam_simulate"

MUTANTS = (
    Mutant("fractional_scale", FRACTIONAL, FRACTIONAL_LINE,
           "return -1.1 * c_f * np.power(np.asarray(s, dtype=complex), nu)",
           ("tests/physics/mechanisms/test_fractional.py", SANITY),
           "fractional transform G(s) = -c_f s^nu times 1.1"),
    Mutant("fractional_order", FRACTIONAL, FRACTIONAL_LINE,
           "return -c_f * np.power(np.asarray(s, dtype=complex), 1 - nu)",
           ("tests/physics/mechanisms/test_fractional.py",),
           "fractional order nu -> 1 - nu (invisible at nu = 0.5)"),
    Mutant("spatial_first_interval", "bayesbeam/physics/mechanisms/spatial_hysteresis.py",
           "density[k == 0] *= (u[k == 0] / width) ** 2", "density[k == 0] *= (1.05 * u[k == 0] / width) ** 2",
           ("tests/physics/mechanisms/test_spatial_hysteresis.py",),
           "spatial hysteresis: the s^2 of F = s^2 Q on the first interval 10 % high"),
    Mutant("exponential_rate", "bayesbeam/physics/mechanisms/exponential.py",
           "return -c_e * mu * s / (s + mu)", "return -c_e * mu * s / (s + 2 * mu)",
           ("tests/physics/mechanisms/test_exponential.py", SANITY),
           "exponential relaxation mu/(s + mu) -> mu/(s + 2 mu)"),
    Mutant("thermoelastic_delta", THERMOELASTIC,
           "return cls(per_ei, mat.thickness**2", "return cls(1.3 * per_ei, mat.thickness**2",
           ("tests/physics/mechanisms/test_thermoelastic.py",),
           "Zener's Delta from the [material] table times 1.3"),
    Mutant("thermoelastic_strength", THERMOELASTIC,
           "return -strength * ei * s * tau / (1.0 + s * tau)",
           "return -1.3 * strength * ei * s * tau / (1.0 + s * tau)",
           ("tests/physics/mechanisms/test_thermoelastic.py",),
           "Zener transform's strength kappa Delta times 1.3"),
    Mutant("root_dashpot", "bayesbeam/physics/effects/root_damping.py",
           'return values["c_theta"] * np.outer(e, e)', 'return 0.5 * values["c_theta"] * np.outer(e, e)',
           ("tests/physics/effects/test_root_damping.py", SANITY),
           "root dashpot c_theta times 0.5"),
    Mutant("force_noise_variance", SIGNALS,
           "noise = ForceNoise(sd, position, sd**2 * window[kept] ** 2)",
           "noise = ForceNoise(sd, position, 1.2 * sd**2 * window[kept] ** 2)",
           ("tests/response/test_signals.py",
            "tests/inference/test_likelihood.py::test_force_noise_variance_is_calibrated_on_reference_recordings"),
           "ForceNoise variance times 1.2"),
    Mutant("force_noise_decimated_variance", SIGNALS,
           "return sd[:, None] * rt[:k].T", "return 1.1 * sd[:, None] * rt[:k].T",
           ("tests/response/test_signals.py",),
           "a decimated fit's force-noise inputs 1.1 x too strong (variance 1.21)"),
    Mutant("force_noise_grouped", SIGNALS,
           "noise = ForceNoise(sd, position, np.ones(mixing.shape[1]), mixing, factor)",
           "noise = ForceNoise(sd, np.rint(position), np.ones(mixing.shape[1]), mixing, factor)",
           ("tests/response/test_signals.py",),
           "a decimated fit's recorded force samples moved onto the nearest decimated samples"),
    Mutant("release_rest_dropped", "bayesbeam/inference/fit.py",
           "rest=release_rest(rec))", "rest=None)",
           ("tests/response/test_signals.py",),
           "a release decimated as if every channel read zero before the record's start"),
    Mutant("release_rest_zero", "bayesbeam/response/signals.py",
           "np.broadcast_to(held, (reach,)", "np.broadcast_to(0.0, (reach,)",
           ("tests/response/test_signals.py",),
           "the held values padded before a release's start replaced by zeros"),
    Mutant("own_mode_appended", "bayesbeam/model.py",
           "own = np.pad(appended, (0, size - len(appended)))", "own = np.zeros((size, size))",
           ("tests/physics/effects/test_attachment.py",),
           "an attached body's own degree of freedom left out of its mass: its mode numbered as the beam's"),
    Mutant("own_mode_added", "bayesbeam/model.py",
           "own[: ops.size, : ops.size] += added", "own[: ops.size, : ops.size] += 0 * added",
           ("tests/physics/effects/test_base_support.py",),
           "a base's mass left out of its own mass: its mode numbered as the beam's"),
    Mutant("polish_searches", "bayesbeam/comparison.py",
           "start=start, search=False)", "start=start)",
           ("tests/inference/test_sampler.py",),
           "a host's optimisation from another host's values repeats its global search"),
    Mutant("ladder_stall", "bayesbeam/inference/fit.py",
           'record["max_shift_sd"] >= below', 'record["max_shift_sd"] >= 1.5 * below',
           ("tests/inference/test_sampler.py",),
           "the N ladder climbs on while a rung's shift is up to 1.5 x the rung's below"),
    Mutant("tuned_body_band", "bayesbeam/diagnosis.py",
           "max(zeta * frequency, resolution)", "max(1.1 * zeta * frequency, resolution)",
           ("tests/test_stand_in.py",),
           "a tuned body's half-power band zeta_m f_m widened by 10 %"),
    Mutant("tuned_body_window", "bayesbeam/diagnosis.py",
           "resolution = projection.fs / (projection.n_blocks * projection.block)",
           "resolution = 1.1 * projection.fs / (projection.n_blocks * projection.block)",
           ("tests/test_stand_in.py",),
           "a tuned body's band from the window's resolution 1/T widened by 10 %"),
    Mutant("tuned_body_kept", "bayesbeam/diagnosis.py",
           '"m_a": 0.0})', "})",
           ("tests/test_stand_in.py",),
           "the beam's modes for the tuned-body rule computed with the body still on"),
    Mutant("kass_raftery_swap", "bayesbeam/comparison.py",
           '(3.0, "strong"), (1.0, "positive")', '(1.0, "strong"), (3.0, "positive")',
           ("tests/test_comparison.py",),
           "Kass & Raftery thresholds 1 and 3 swapped (KASS_RAFTERY)"),
)
BY_NAME = {m.name: m for m in MUTANTS}


class MutantError(RuntimeError):
    """A mutant that cannot be applied as written: the run refuses rather than test unmutated code."""


def _refusal(mutant: Mutant, text: str) -> str | None:
    """Why the mutant cannot be applied to ``text`` (its file's source), or None."""
    count = text.count(mutant.source)
    if count == 1:
        return None
    return (f"{mutant.file}: mutant {mutant.name}: its source text {mutant.source!r} occurs {count} times, "
            f"not once. Fix: update the mutant in tests/mutants.py to the module's present code")


def apply(mutant: Mutant, root: Path) -> None:
    """Edit ``mutant.file`` under ``root``; MutantError unless its source text occurs exactly once."""
    path = root / mutant.file
    text = path.read_text()
    refusal = _refusal(mutant, text)
    if refusal:
        raise MutantError(refusal)
    path.write_text(text.replace(mutant.source, mutant.replacement))


def check_applies(mutant: Mutant) -> str:
    """'applies' if the mutant's source text is in the tree exactly once, else why not."""
    return _refusal(mutant, (ROOT / mutant.file).read_text()) or "applies"


@dataclass(frozen=True)
class Verdict:
    mutant: str
    paths: tuple[str, ...]
    verdict: str          # "caught", "not caught" or "error"
    detail: str           # the failing node id, or what went wrong


def run_pytest(copy: Path, paths: tuple[str, ...]) -> tuple[int, str, str]:
    """(exit status, output, the bayesbeam path the probe saw) of pytest on ``paths`` in ``copy``."""
    probe = copy / "imported.txt"
    env = {**os.environ, "PYTHONPATH": str(copy), "OPENBLAS_NUM_THREADS": "1", "PYTHONDONTWRITEBYTECODE": "1",
           "BAYESBEAM_MUTANT_ROOT": str(copy), "BAYESBEAM_MUTANT_PROBE": str(probe)}
    # named guard paths run whole, their long-tier tests included (-m "" lifts pyproject's -m "not long")
    every_test = ("-m", "") if paths else ()
    command = [sys.executable, "-m", "pytest", "-q", "-x", "-p", "no:cacheprovider", "-p", PROBE_MODULE,
               *every_test, "--rootdir", str(copy), *paths]
    try:
        done = subprocess.run(command, cwd=copy, env=env, capture_output=True, text=True, check=False,
                              timeout=RUN_TIMEOUT)
    except subprocess.TimeoutExpired:
        return -1, f"timed out after {RUN_TIMEOUT:.0f} s", ""
    return done.returncode, done.stdout + done.stderr, probe.read_text() if probe.exists() else ""


def judge(name: str, paths: tuple[str, ...], copy: Path, status: int, output: str, imported: str) -> Verdict:
    """pytest's exit status read as a verdict: 1 is a failed or errored test, 0 all passed."""
    if not imported or copy.resolve() not in Path(imported).parents:
        return Verdict(name, paths, "error", f"bayesbeam not imported from the copy ({imported or 'no probe'})")
    summary = [line for line in output.splitlines() if line.startswith(("FAILED ", "ERROR "))]
    if status == 1:
        node = summary[0].split(" - ")[0].split(" ", 1)[1] if summary else "(no node id in the summary)"
        return Verdict(name, paths, "caught", node)
    if status == 0:
        return Verdict(name, paths, "not caught", "all passed")
    where = summary[0] if summary else " | ".join(output.strip().splitlines()[-3:])
    return Verdict(name, paths, "error", f"pytest exit status {status}: {where}")


def run_mutant(mutant: Mutant, runs: list[tuple[str, ...]]) -> list[Verdict]:
    """Copy the tree, apply the mutant, and run pytest once per entry of ``runs`` (tuples of paths)."""
    with tempfile.TemporaryDirectory(prefix=f"mutant-{mutant.name}-") as scratch:
        copy = Path(scratch) / "tree"
        shutil.copytree(ROOT, copy, ignore=IGNORE)
        apply(mutant, copy)
        (copy / f"{PROBE_MODULE}.py").write_text(PROBE)
        return [judge(mutant.name, paths, copy, *run_pytest(copy, paths)) for paths in runs]


def table(verdicts: list[Verdict]) -> str:
    rows = ["| mutant | bug | tests run | verdict | failing test / detail |", "|---|---|---|---|---|"]
    for v in verdicts:
        paths = ", ".join(v.paths) or "(whole default suite)"
        rows.append(f"| {v.mutant} | {BY_NAME[v.mutant].bug} | {paths} | {v.verdict} | {v.detail} |")
    return "\n".join(rows)


def listing() -> str:
    return "\n".join(f"{m.name}: {m.bug}\n    {m.file}: {m.source!r} -> {m.replacement!r}\n"
                     f"    guards: {', '.join(m.guards)}\n    {check_applies(m)}" for m in MUTANTS)


def parse(argv=None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(prog="python -m tests.mutants", description=__doc__.split("\n\n")[0])
    parser.add_argument("names", nargs="*", metavar="NAME", help="mutants to run (default: all)")
    parser.add_argument("--list", action="store_true", help="list the mutants and whether each applies")
    parser.add_argument("--tests", nargs="+", metavar="PATH", help="run these test paths instead of the guards")
    parser.add_argument("--all-tests", action="store_true", help="run the whole default run (no long tier) instead of the guards")
    parser.add_argument("--per-path", action="store_true", help="one pytest run, and one verdict, per guard path")
    args = parser.parse_args(argv)
    unknown = sorted(set(args.names) - set(BY_NAME))
    if unknown:
        parser.error(f"unknown mutant(s) {', '.join(unknown)}; known: {', '.join(BY_NAME)}")
    if args.tests and args.all_tests:
        parser.error("give --tests or --all-tests, not both")
    return args


def runs_of(mutant: Mutant, args: argparse.Namespace) -> list[tuple[str, ...]]:
    paths = () if args.all_tests else tuple(args.tests or mutant.guards)
    return [(p,) for p in paths] if args.per_path and paths else [paths]


def main(argv=None) -> int:
    args = parse(argv)
    if args.list:
        print(listing())
        return 0
    selected = [BY_NAME[n] for n in args.names] or list(MUTANTS)
    refusals = [r for r in map(check_applies, selected) if r != "applies"]
    if refusals:
        print("\n".join(refusals), file=sys.stderr)
        return 2
    verdicts = []
    for mutant in selected:
        for v in run_mutant(mutant, runs_of(mutant, args)):
            print(f"{v.mutant}: {v.verdict} ({v.detail})", flush=True)
            verdicts.append(v)
    print("\n" + table(verdicts))
    return 0 if all(v.verdict == "caught" for v in verdicts) else 1


if __name__ == "__main__":
    sys.exit(main())
