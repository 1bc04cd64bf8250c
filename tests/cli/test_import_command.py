"""``bayesbeam import``: what it prints, the options it passes on, UFF round trips, refusals (exit 2)."""
import numpy as np
from nptdms import ChannelObject, GroupObject, RootObject, TdmsWriter

from bayesbeam.cli import main
from bayesbeam.io import load_recording
from bayesbeam.io.units import STANDARD_GRAVITY
from tests.cli.test_modal_commands import HAMMER, PAPER_BEAM

Q3 = ["--model", "q3", "--set", "EI=44.28", "--set", "gamma=0.12", "--set", "a=0.025", "--set", "b=0.18"]
N = 512
ACCEL_G = np.round(np.random.default_rng(2).standard_normal(N) * 0.1, 6)


def tdms(path):
    props = {"wf_increment": 1 / 1024, "wf_start_offset": 0.0, "unit_string": "g"}
    with TdmsWriter(path) as writer:
        writer.write_segment([RootObject(), GroupObject("Empty"), GroupObject("Run 1"), GroupObject("Run 2"),
                              ChannelObject("Run 1", "accel", ACCEL_G, properties=props),
                              ChannelObject("Run 2", "accel 2", ACCEL_G[::-1].copy(), properties=props)])
    return path


def test_import_prints_the_channels_and_what_to_fill_in(tmp_path, capsys):
    assert main(["import", str(tdms(tmp_path / "t.tdms")), "--out", str(tmp_path / "rec"), "--group", "Run 2"]) == 0
    out = capsys.readouterr().out
    assert "1 channel(s), 512 samples at 1024 Hz, 0.499023 s" in out and "accel 2 (g)" in out
    assert "[beam] length" in out and "[excitation] start" in out and "[[sensor]] #1 location" in out
    assert f"bayesbeam check {tmp_path / 'rec'}" in out


def test_a_text_export_imports_with_a_beam_and_loads(tmp_path, capsys):
    rows = "".join(f"{k / 1024!r}\t{float(a)!r}\n".replace(".", ",") for k, a in enumerate(ACCEL_G))
    (tmp_path / "export.txt").write_text("# Operator: me\nTime (s)\tAccel (g)\n" + rows)
    (tmp_path / "beam.toml").write_text(PAPER_BEAM + '[excitation]\nkind = "free_decay"\nstart = 0.1\n\n'
                                        '[[sensor]]\nname = "tip"\nlocation = 1.0\nquantity = "acceleration"\n'
                                        'column = "Accel"\n')
    assert main(["import", str(tmp_path / "export.txt"), "--beam", str(tmp_path / "beam.toml"), "--decimal", ",",
                 "--out", str(tmp_path / "rec")]) == 0
    assert "Accel (g)" in capsys.readouterr().out
    rec = load_recording(tmp_path / "rec")
    # decimal text read back, times g_n: one rounding (see tests/io/test_importer.py)
    np.testing.assert_allclose(rec.signals[:, 0], ACCEL_G * STANDARD_GRAVITY, rtol=1e-15, atol=0)


def test_simulate_uff_imports_back_to_the_same_recording(tmp_path, capsys):
    sim = tmp_path / "sim"
    assert main(["simulate", str(HAMMER), *Q3, "--out", str(sim), "--uff"]) == 0
    assert "recording.uff" in capsys.readouterr().out
    back = tmp_path / "back"
    assert main(["import", str(sim / "recording.uff"), "--beam", str(sim / "beam.toml"), "--out", str(back)]) == 0
    assert "8192 samples at 2048 Hz" in capsys.readouterr().out
    original, imported = load_recording(sim), load_recording(back)
    # ASCII UFF58 keeps 12 significant digits of the simulated doubles; all else is exact.
    np.testing.assert_allclose(imported.signals, original.signals, rtol=5e-12, atol=0)
    np.testing.assert_array_equal(imported.force, original.force)  # the example's 9-digit force
    np.testing.assert_array_equal(imported.time, original.time)
    assert (imported.sensors, imported.excitation, imported.extra) == (
        original.sensors, original.excitation, original.extra)


def test_import_of_an_absent_uff_exits_2(tmp_path, capsys):
    (tmp_path / "beam.toml").write_text(PAPER_BEAM)
    code = main(["import", str(tmp_path / "absent.uff"), "--beam", str(tmp_path / "beam.toml"),
                 "--out", str(tmp_path / "o")])
    assert code == 2 and "no such file" in capsys.readouterr().err


def test_bad_input_exits_2_naming_the_place_and_the_fix(tmp_path, capsys):
    (tmp_path / "x.xyz").write_text("1,2\n")
    assert main(["import", str(tmp_path / "x.xyz"), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert "x.xyz: file name: unknown extension '.xyz'" in err and "Fix: pass --format with one of" in err
    assert main(["import", str(tdms(tmp_path / "t.tdms")), "--group", "Run 3", "--out", str(tmp_path / "o")]) == 2
    assert "group 'Run 3': no such group" in capsys.readouterr().err
    assert not (tmp_path / "o").exists()
