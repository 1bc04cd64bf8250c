"""The command line: simulate writes a loadable recording; bad input exits 2 with a fix."""
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from bayesbeam import load_recording
from bayesbeam.cli import main

DATA = Path(__file__).resolve().parents[1] / "data"
Q3 = ["--model", "q3", "--set", "EI=44.28", "--set", "gamma=0.12", "--set", "a=0.025", "--set", "b=0.18"]


def test_simulate_writes_a_recording_and_prints_modes(tmp_path, capsys):
    out = tmp_path / "sim"
    assert main(["simulate", str(DATA / "examples" / "paper_q3_hammer"), *Q3, "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "3.685" in printed and "wrote" in printed
    sim, src = load_recording(out), load_recording(DATA / "examples" / "paper_q3_hammer")
    np.testing.assert_array_equal(sim.time, src.time)
    np.testing.assert_array_equal(sim.force, src.force)
    assert sim.extra["simulation"]["model"] == "air+spatial_hysteresis"


def test_noise_is_reproducible_with_a_seed(tmp_path):
    rec = str(DATA / "examples" / "alu_q1_release")
    args = ["--model", "q1", "--set", "EI=3.9375", "--set", "gamma=0.18", "--set", "cdI=5.5e-6",
            "--noise-level", "0.02", "--seed", "7"]
    for name in ("a", "b"):
        assert main(["simulate", rec, *args, "--out", str(tmp_path / name)]) == 0
    a, b = load_recording(tmp_path / "a"), load_recording(tmp_path / "b")
    np.testing.assert_array_equal(a.signals, b.signals)


def test_free_decay_simulation_starts_from_the_recorded_state(tmp_path):
    rec = str(DATA / "real" / "ds4-cantilever-freedecay" / "recording")
    args = ["--model", "q1", "--set", "EI=95.5", "--set", "gamma=0.05", "--set", "cdI=2e-5"]
    assert main(["simulate", rec, *args, "--n-intervals", "8", "--out", str(tmp_path / "s")]) == 0
    assert load_recording(tmp_path / "s").n_samples == 81920


def test_missing_parameter_exits_2_naming_it(tmp_path, capsys):
    code = main(["simulate", str(DATA / "examples" / "paper_q3_hammer"), "--model", "q3",
                 "--out", str(tmp_path / "x")])
    assert code == 2
    assert "gamma (N s/m^2)" in capsys.readouterr().err


def test_bad_set_syntax_exits_2(tmp_path, capsys):
    code = main(["simulate", str(DATA / "examples" / "paper_q3_hammer"), "--set", "EI:44",
                 "--out", str(tmp_path / "x")])
    assert code == 2
    assert "NAME=VALUE" in capsys.readouterr().err


def test_existing_output_is_not_overwritten(tmp_path, capsys):
    out = tmp_path / "sim"
    out.mkdir()
    (out / "keep.txt").write_text("x")
    code = main(["simulate", str(DATA / "examples" / "paper_q3_hammer"), *Q3, "--out", str(out)])
    assert code == 2 and (out / "keep.txt").exists()
    assert "keep.txt" in capsys.readouterr().err
    # --overwrite replaces the folder by the recording, as its help says
    assert main(["simulate", str(DATA / "examples" / "paper_q3_hammer"), *Q3, "--out", str(out), "--overwrite"]) == 0
    assert not (out / "keep.txt").exists() and load_recording(out).n_samples == 8192


def test_bad_recording_exits_2(tmp_path, capsys):
    code = main(["simulate", str(tmp_path), "--out", str(tmp_path / "x")])
    assert code == 2
    assert "Fix" in capsys.readouterr().err


def test_console_script_runs():
    done = subprocess.run([sys.executable, "-m", "bayesbeam.cli", "--version"], capture_output=True, text=True)
    assert done.returncode == 0 and "bayesbeam" in done.stdout


FIT_ARGS = ["--model", "air", "--stop", "0.5", "--max-frequency", "60", "--n-intervals", "8",
            "--walkers", "8", "--executor", "serial", "--quiet"]


def test_fit_writes_outputs_and_flags_unconverged_chains(tmp_path, capsys):
    """A deliberately short run: all outputs exist and the exit status says 'not converged' (3)."""
    import json

    out = tmp_path / "fit"
    rec = str(DATA / "examples" / "paper_q3_hammer")
    code = main(["fit", rec, *FIT_ARGS, "--max-steps", "60", "--out", str(out)])
    assert code == 3
    for name in ("posterior.nc", "summary.json", "corner.png", "trace.png", "fit.png", "chains.h5"):
        assert (out / name).stat().st_size > 0, name
    summary = json.loads((out / "summary.json").read_text())
    assert summary["converged"] is False and "max_steps" in summary["convergence"]["reason"]
    assert set(summary["parameters"]) == {"EI", "gamma"}
    # the force channel's 1 % noise (0.56 N) is measured and its response marginalised
    assert summary["noise"]["force_noise"]["sd_N"] == pytest.approx(0.562, rel=0.05)
    assert summary["noise"]["force_noise"]["samples"] > 0
    assert "NOT converged" in capsys.readouterr().out
    # (--resume, on a killed run: tests/test_resume.py)
    # without --resume or --overwrite the written folder is refused
    assert main(["fit", rec, *FIT_ARGS, "--max-steps", "90", "--out", str(out)]) == 2
    assert "--overwrite or --resume" in capsys.readouterr().err


def test_fit_refuses_an_unknown_model(tmp_path, capsys):
    code = main(["fit", str(DATA / "examples" / "paper_q3_hammer"), "--model", "q9", "--out", str(tmp_path / "x")])
    assert code == 2 and "unknown damping mechanism" in capsys.readouterr().err


@pytest.mark.parametrize("command", ["fit", "compare", "diagnose"])
def test_the_spline_degree_is_an_option_of_every_fitting_command(command, capsys):
    """--degree reaches the fit's configuration (quintic by default, the paper's cubics on request);
    a degree without a refinement ladder is refused by the parser, naming the choices."""
    from bayesbeam.cli import build_parser
    from bayesbeam.cli.fit import fit_config
    from bayesbeam.inference import FitConfig

    parser = build_parser()
    rec = str(DATA / "examples" / "paper_q3_hammer")
    args = parser.parse_args([command, rec, "--degree", "3", "--out", "x"])
    assert fit_config(args).degree == 3
    assert fit_config(parser.parse_args([command, rec, "--out", "x"])).degree == FitConfig.degree == 5
    with pytest.raises(SystemExit):
        parser.parse_args([command, rec, "--degree", "4", "--out", "x"])
    assert "choose from 3, 5" in capsys.readouterr().err
