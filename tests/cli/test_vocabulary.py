"""One command-line vocabulary: a flag means the same in every subcommand that has it.

The parsers are read from ``build_parser()`` (what ``--help`` prints); the runs are stopped at the
library call they lead to, so these tests cost parsing and a recording load, not a fit.
"""
import argparse
import os
import re
import shlex
import sys
import types
from pathlib import Path

import pytest

import bayesbeam.comparison
import bayesbeam.diagnosis
import bayesbeam.inference
from bayesbeam.cli import COMMANDS, build_parser, main
from bayesbeam.cli.common import UsageError
from bayesbeam.cli.fit import fit_config
from bayesbeam.inference.likelihood import NOISE_MODELS

ROOT = Path(__file__).resolve().parents[2]
HAMMER = str(ROOT / "data" / "examples" / "paper_q3_hammer")
FITTING = ("fit", "compare", "batch", "diagnose")
#: flag -> the commands that must have it, spelled and meaning the same in each
SHARED = {
    "--executor": FITTING,
    "--processes": FITTING,
    "--quiet": FITTING,
    "--effect": ("simulate", *FITTING),
    "--no-force-window": ("simulate", *FITTING),
    "--noise": FITTING,
    "--no-force-noise": FITTING,
    "--seed": ("simulate", *FITTING),
    "--config": FITTING,
    "--start": FITTING,
    "--stop": FITTING,
    "--max-frequency": FITTING,
}
WRITING = ("simulate", "fit", "compare", "batch", "diagnose", "ema", "era", "import")


def subparsers() -> dict[str, argparse.ArgumentParser]:
    action = next(a for a in build_parser()._actions if isinstance(a, argparse._SubParsersAction))
    return dict(action.choices)


def options(parser) -> dict[str, argparse.Action]:
    return {s: a for a in parser._actions for s in a.option_strings}


def rendered_help(parser, action) -> str:
    """The help text of one option exactly as ``--help`` prints it (defaults expanded), unwrapped."""
    return parser._get_formatter()._expand_help(action)


def argv(command: str, *extra: str, out: str = "x") -> list[str]:
    """A minimal valid command line of ``command``."""
    positional = {"ema": ["table.csv", "--beam", "beam.toml"], "import": ["a.uff", "--beam", "beam.toml"],
                  "models": []}.get(command, [HAMMER])
    return [command, *positional, *extra, *(["--out", out] if command in WRITING else [])]


def parse(command: str, *extra: str, out: str = "x"):
    return build_parser().parse_args(argv(command, *extra, out=out))


class Reached(Exception):
    """Raised by a stand-in for the library call a command leads to, carrying its arguments."""


def stop_at(monkeypatch, module, name):
    def stand_in(*args, **kwargs):
        raise Reached(args, kwargs)

    monkeypatch.setattr(module, name, stand_in)


# ---------------------------------------------------------------------------- help and defaults
def test_shared_flags_agree_in_every_command_that_has_them():
    parsers = subparsers()
    for flag, commands in SHARED.items():
        seen = {}
        for name in commands:
            assert flag in options(parsers[name]), f"{name} has no {flag}"
            action = options(parsers[name])[flag]
            seen[name] = (action.choices and sorted(action.choices), action.default, action.type, action.nargs,
                          type(action).__name__, rendered_help(parsers[name], action))
        assert len(set(map(repr, seen.values()))) <= 1, f"{flag} differs: {seen}"


def test_noise_is_the_likelihood_model_and_noise_level_the_simulated_noise():
    parsers = subparsers()
    for name, parser in parsers.items():
        flags = options(parser)
        if "--noise" in flags:
            assert tuple(flags["--noise"].choices) == NOISE_MODELS, name
    assert "--noise" not in options(parsers["simulate"]) and options(parsers["simulate"])["--noise-level"].type is float
    assert parse("simulate").noise_level == 0.0
    # "--modes" keeps modes 1..N in era only; simulate prints modes with --print-modes
    assert [n for n, p in parsers.items() if "--modes" in options(p)] == ["era"]
    assert parse("simulate", "--print-modes", "4").print_modes == 4


def test_every_option_shows_its_default():
    """Each option's help ends with its default or states it in words ("default: automatic"):
    on/off switches and required options excepted."""
    for name, parser in subparsers().items():
        for action in parser._actions:
            if not action.option_strings or action.required or action.nargs == 0:
                continue
            assert "default" in rendered_help(parser, action), f"{name} {action.option_strings[0]}"


def test_top_level_help_says_what_the_tool_does_and_has_three_examples_that_parse():
    parser = build_parser()
    text = parser.format_help()
    assert "thin argument parsing" not in text and "damping" in parser.description
    examples = re.findall(r"^  (bayesbeam .+?)$", parser.epilog.replace("\\\n", ""), flags=re.MULTILINE)
    assert len(examples) == 3
    for line in examples:
        parser.parse_args(shlex.split(line)[1:])           # every flag of the examples exists


def test_every_command_is_registered_once_with_help():
    assert set(subparsers()) == set(COMMANDS) and "models" in COMMANDS
    for name, parser in subparsers().items():
        assert parser.description, name


def _documented_commands():
    """Whole ``bayesbeam COMMAND ... --out DIR`` lines in the docs and the studies' READMEs,
    except synopses with placeholders (``...``, ``<name>``, ``[--out DIR]``)."""
    files = [*ROOT.glob("docs/*.md"), *ROOT.glob("studies/*/README.md"), ROOT / "benchmarks" / "README.md"]
    pattern = re.compile(r"(?:^|`|\s)(bayesbeam [a-z-]+\b[^`\n#]*--out [^`\n#]*)", flags=re.MULTILINE)
    for path in files:
        for match in pattern.finditer(path.read_text()):
            line = match.group(1).strip()
            if not any(mark in line for mark in ("...", "<", "[")) and line.split()[1] in COMMANDS:
                yield path.relative_to(ROOT), line


def test_documented_command_lines_parse():
    """Every command line the docs show uses flags that exist (the docs follow a renamed flag)."""
    parser = build_parser()
    failures = []
    lines = list(_documented_commands())
    assert len(lines) >= 10                                   # the pattern finds the docs' commands
    for path, line in lines:
        try:
            parser.parse_args(shlex.split(line)[1:])
        except SystemExit:
            failures.append(f"{path}: {line}")
    assert not failures, "\n".join(failures)


# ---------------------------------------------------------------------------- where the work runs
@pytest.mark.parametrize("command", FITTING)
def test_executor_values_and_processes_default(command, capsys):
    for value in ("serial", "local", "mpi", "tcp://scheduler:8786"):
        assert parse(command, "--executor", value).executor == value
    assert parse(command).executor == "local" and parse(command).processes is None
    with pytest.raises(SystemExit) as stop:
        parse(command, "--executor", "cluster")
    assert stop.value.code == 2 and "tcp://host:8786" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        parse(command, "--processes", "0")


def test_default_processes_are_all_cores_in_fit_and_the_job_commands():
    from bayesbeam.cli.common import job_executor
    from bayesbeam.cli.fit import walker_pool
    from bayesbeam.executors import SerialExecutor

    cores = os.cpu_count()
    assert walker_pool(parse("fit")) == (cores if cores > 1 else None)      # a pool of that many processes
    assert walker_pool(parse("fit", "--executor", "serial")) is None
    executor = job_executor(parse("compare"))
    try:
        assert executor.workers == cores
    finally:
        executor.close()
    assert isinstance(job_executor(parse("batch", "--executor", "serial")), SerialExecutor)


def test_fit_refuses_a_dask_address_naming_the_commands_that_take_it():
    from bayesbeam.cli.fit import walker_pool

    with pytest.raises(UsageError, match="compare, batch and diagnose"):
        walker_pool(parse("fit", "--executor", "tcp://scheduler:8786"))


@pytest.fixture
def fake_mpi4py(monkeypatch):
    """mpi4py.futures stood in for by a thread pool (same constructor and map): the wiring of
    --executor mpi is tested without an MPI launch."""
    from concurrent.futures import ThreadPoolExecutor

    futures = types.ModuleType("mpi4py.futures")
    futures.MPIPoolExecutor = ThreadPoolExecutor
    package = types.ModuleType("mpi4py")
    package.futures = futures
    monkeypatch.setitem(sys.modules, "mpi4py", package)
    monkeypatch.setitem(sys.modules, "mpi4py.futures", futures)


def test_mpi_runs_jobs_and_fit_pools(fake_mpi4py):
    from bayesbeam.cli.common import job_executor
    from bayesbeam.cli.fit import walker_pool
    from bayesbeam.inference import sampler

    executor = job_executor(parse("compare", "--executor", "mpi"))
    try:
        assert executor.map(pow, [2, 3], [3, 2]) == [8, 9]
    finally:
        executor.close()
    deferred = walker_pool(parse("fit", "--executor", "mpi"))
    pool = deferred.factory(abs)                  # the workers hold the posterior (here: abs)
    try:
        assert list(pool.map(sampler.worker_log_prob, [-2.0, 3.0])) == [2.0, 3.0]
    finally:
        pool.shutdown()


def test_mpi_without_mpi4py_exits_2_with_the_fix(monkeypatch, tmp_path, capsys):
    monkeypatch.setitem(sys.modules, "mpi4py", None)          # import fails as if not installed
    for command in FITTING:
        assert main(argv(command, "--executor", "mpi", out=str(tmp_path / command))) == 2
        assert "pip install mpi4py" in capsys.readouterr().err


# ---------------------------------------------------------------------------- the output folder
def test_every_command_with_out_has_overwrite_with_one_of_two_meanings():
    """Results are written file by file into OUT; a recording replaces OUT as a whole."""
    from bayesbeam.cli.common import OVERWRITE_FILES_HELP, OVERWRITE_FOLDER_HELP

    parsers = subparsers()
    with_out = [n for n, p in parsers.items() if "--out" in options(p)]
    assert set(WRITING) <= set(with_out) and all("--overwrite" in options(parsers[n]) for n in with_out)
    for name in WRITING:
        flags = options(parsers[name])
        assert flags["--out"].required and flags["--out"].metavar == "DIR", name
        expected = OVERWRITE_FOLDER_HELP if name in ("simulate", "import") else OVERWRITE_FILES_HELP
        assert rendered_help(parsers[name], flags["--overwrite"]) == expected, name


@pytest.mark.parametrize("command", WRITING)
def test_every_writing_command_refuses_a_non_empty_out(command, tmp_path, capsys):
    out = tmp_path / "out"
    out.mkdir()
    (out / "notes.txt").write_text("mine")
    assert main(argv(command, out=str(out))) == 2
    err = capsys.readouterr().err
    assert "not empty (notes.txt)" in err and "--overwrite" in err
    assert [p.name for p in out.iterdir()] == ["notes.txt"]
    assert parse(command, "--overwrite", out=str(out)).overwrite is True


@pytest.mark.parametrize("command", ["fit", "diagnose", "batch"])
def test_resume_continues_where_the_command_resumes_and_excludes_overwrite(command, tmp_path, capsys):
    from bayesbeam.cli.common import output_folder

    (tmp_path / "chains.h5").write_text("")
    assert output_folder(parse(command, "--resume", out=str(tmp_path))) == tmp_path
    with pytest.raises(UsageError, match="--overwrite or --resume"):
        output_folder(parse(command, out=str(tmp_path)))
    with pytest.raises(SystemExit):
        parse(command, "--resume", "--overwrite")
    assert "not allowed with argument" in capsys.readouterr().err
    assert [n for n, p in subparsers().items() if "--resume" in options(p)] == ["fit", "diagnose", "batch"]


def test_out_that_is_a_file_is_refused(tmp_path, capsys):
    (tmp_path / "f").write_text("")
    assert main(argv("era", out=str(tmp_path / "f"))) == 2
    assert "is a file" in capsys.readouterr().err


# ---------------------------------------------------------------------------- --effect and the force window
def test_effect_joins_the_model_of_fit(monkeypatch, tmp_path):
    stop_at(monkeypatch, bayesbeam.inference, "fit")
    with pytest.raises(Reached) as reached:
        main(argv("fit", "--model", "q2", "--effect", "sensor_mass", "--effect", "axial_load",
                  "--executor", "serial", out=str(tmp_path / "o")))
    assert reached.value.args[0][1] == "q2+sensor_mass+axial_load"


@pytest.mark.parametrize("command", ["compare", "batch"])
def test_effect_joins_every_compared_model(command, monkeypatch, tmp_path):
    stop_at(monkeypatch, bayesbeam.comparison, "compare")
    with pytest.raises(Reached) as reached:
        main(argv(command, "--models", "q1,air", "--effect", "root_compliance", "--executor", "serial",
                  out=str(tmp_path / "o")))
    assert reached.value.args[0][1] == ["q1+root_compliance", "air+root_compliance"]


def test_effect_joins_diagnoses_baseline_or_every_default_model(monkeypatch, tmp_path):
    stop_at(monkeypatch, bayesbeam.diagnosis, "diagnose")
    with pytest.raises(Reached) as reached:
        main(argv("diagnose", "--model", "q2", "--effect", "sensor_mass", "--executor", "serial",
                  out=str(tmp_path / "a")))
    assert reached.value.args[0][1] == "q2+sensor_mass" and reached.value.args[1]["effects"] == ()
    with pytest.raises(Reached) as reached:
        main(argv("diagnose", "--effect", "quadratic_drag", "--executor", "serial", out=str(tmp_path / "b")))
    assert reached.value.args[0][1] is None and reached.value.args[1]["effects"] == ("quadratic_drag",)


def test_diagnose_starts_from_the_default_models_that_carry_the_effects(monkeypatch):
    """The library joins the effects to each default model; a nonlinear effect leaves out the
    models with a memory mechanism, which its integrator cannot carry."""
    from bayesbeam import load_recording
    from bayesbeam.comparison import DEFAULT_MODELS
    from bayesbeam.physics.mechanisms import resolve

    stop_at(monkeypatch, bayesbeam.diagnosis, "compare")
    with pytest.raises(Reached) as reached:
        bayesbeam.diagnosis.diagnose(load_recording(HAMMER), None, effects=("sensor_mass",))
    assert reached.value.args[0][1] == [f"{m}+sensor_mass" for m in DEFAULT_MODELS]
    with pytest.raises(Reached) as reached:
        bayesbeam.diagnosis.diagnose(load_recording(HAMMER), None, effects=("quadratic_drag",))
    memoryless = [m for m in DEFAULT_MODELS if not any(k.hereditary for k in resolve(m))]
    assert "q2" not in memoryless and len(memoryless) == len(DEFAULT_MODELS) - 1
    assert reached.value.args[0][1] == [f"{m}+quadratic_drag" for m in memoryless]


def test_unknown_or_repeated_effect_exits_2(tmp_path, capsys):
    with pytest.raises(SystemExit):
        parse("compare", "--effect", "wet_towel")
    assert "wet_towel" in capsys.readouterr().err
    assert main(argv("fit", "--effect", "sensor_mass", "--effect", "sensor_mass", out=str(tmp_path / "a"))) == 2
    assert "twice" in capsys.readouterr().err
    assert main(argv("diagnose", "--effect", "sensor_mass", "--effect", "sensor_mass", out=str(tmp_path / "b"))) == 2
    assert "twice" in capsys.readouterr().err


@pytest.mark.parametrize("command", FITTING)
def test_force_flags_reach_the_fit_config(command):
    assert fit_config(parse(command)).force_window is None          # None: the window on a force recording
    assert fit_config(parse(command, "--no-force-window")).force_window is False
    assert fit_config(parse(command)).force_noise is True
    assert fit_config(parse(command, "--no-force-noise")).force_noise is False


def test_simulate_no_force_window_drives_the_beam_with_the_whole_force(tmp_path):
    """The shipped hammer record's force channel carries 1 % noise outside the impact: with the
    window the model sees zero force there, without it the noise drives the beam too."""
    from bayesbeam import load_recording

    q3 = ["--model", "q3", "--set", "gamma=0.12", "--set", "a=0.025", "--set", "b=0.18", "--n-intervals", "8"]
    assert main(["simulate", HAMMER, *q3, "--out", str(tmp_path / "w")]) == 0
    assert main(["simulate", HAMMER, *q3, "--no-force-window", "--out", str(tmp_path / "n")]) == 0
    windowed, whole = load_recording(tmp_path / "w").signals, load_recording(tmp_path / "n").signals
    # observed: the largest difference is 27 % of the largest response; 1 % is far above rounding
    # and the CSV's digits (1e-9 relative), so it can only come from the force the beam was given
    assert abs(windowed - whole).max() > 0.01 * abs(windowed).max()


# ---------------------------------------------------------------------------- bayesbeam models
def test_models_lists_every_registry_entry_with_units_and_default_priors(capsys):
    from bayesbeam.comparison import MODEL_SETS
    from bayesbeam.inference.priors import DEFAULTS, describe_default
    from bayesbeam.physics.effects import REGISTRY as EFFECTS
    from bayesbeam.physics.mechanisms import PRESETS
    from bayesbeam.physics.mechanisms import REGISTRY as MECHANISMS

    assert main(["models"]) == 0
    lines = capsys.readouterr().out.splitlines()
    for preset, mechanisms in PRESETS.items():
        assert any(line.split()[:1] == [preset] and " + ".join(mechanisms) in line for line in lines), preset
    for name, models in MODEL_SETS.items():
        assert any(line.split()[:1] == [name] and ", ".join(models) in line for line in lines), name
    for component in [*MECHANISMS.values(), *EFFECTS.values()]:
        assert any(line.split()[:1] == [component.name] for line in lines), component.name
        for name in component.parameters:
            line = next(line for line in lines if line.split()[:1] == [name])
            assert component.units[name] in line, name
            if name in DEFAULTS:
                assert describe_default(name) in line, name


def test_models_with_a_beam_prints_the_priors_fits_use(capsys):
    from bayesbeam import load_recording
    from bayesbeam.inference.priors import default_priors

    assert main(["models", "--beam", str(Path(HAMMER) / "beam.toml")]) == 0
    text = capsys.readouterr().out
    beam = load_recording(HAMMER).beam
    for name in ("EI", "alpha", "b", "k_theta", "m_s", "P"):
        assert default_priors(beam, (name,), {})[name].describe() in text, name
