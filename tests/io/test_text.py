"""DAQ text exports: the reader of bayesbeam.io.text, and load_recording through it.

The reference is the shipped hammer example (a plain comma CSV in SI units): each test writes
the same record the way a DAQ would export it and checks that it loads to the same SI arrays.
"""
import warnings
from pathlib import Path

import numpy as np
import pytest

from bayesbeam.io import RecordingError, load_recording, read_text_export, write_recording
from bayesbeam.io.text import print_resolution, split_unit

EXAMPLE = Path(__file__).resolve().parents[2] / "data" / "examples" / "paper_q3_hammer"
REFERENCE = load_recording(EXAMPLE)
G = 9.80665  # standard gravity, m/s^2 (exact by definition)
FS = 2048.0  # Hz, the example's rate
ROWS = 2048  # the example cut to its first second keeps the test fast; the impact is at sample 62
PRINTED = 5e-10 * (1 + 1e-6)  # s: half a unit of the 9th decimal, with room for float64 rounding

BEAM_TOML = (EXAMPLE / "beam.toml").read_text(encoding="utf-8")


def reference_cut():
    """The example's first ROWS samples, as a recording, for comparison."""
    rec = REFERENCE
    from dataclasses import replace
    return replace(rec, time=rec.time[:ROWS], signals=rec.signals[:ROWS], force=rec.force[:ROWS])


def export_lines(time_format="{:.9f}", delimiter="\t", decimal=".", units=("s", "N", "g")) -> list[str]:
    """The example as a DAQ exports it: two # lines, a header with units, the acceleration in g."""
    scale = {"g": 1 / G, "m/s^2": 1.0, "mm/s^2": 1e3}[units[2]]
    header = delimiter.join([f"Time ({units[0]})", f"Hammer ({units[1]})", f"Accel tip ({units[2]})"])
    lines = ["# Exported 2026-11-20 14:03:11", f"# Sample rate: {FS:g} Hz", header]
    time_scale = {"s": 1.0, "ms": 1e3}[units[0]]
    for t, f, a in zip(REFERENCE.time[:ROWS], REFERENCE.force[:ROWS], REFERENCE.signals[:ROWS, 0]):
        cells = [time_format.format(t * time_scale), f"{f:.8e}", f"{a * scale:.9e}"]
        lines.append(delimiter.join(cells).replace(".", decimal))
    return lines


def recording_dir(tmp_path: Path, lines: list[str], recording_keys: str = "", sensor_keys: str = "",
                  columns=("Hammer", "Accel tip")) -> Path:
    directory = tmp_path / "export"
    directory.mkdir(parents=True)
    (directory / "export.txt").write_text("\n".join(lines) + "\n", encoding="utf-8")
    toml = (BEAM_TOML.replace('column = "force"', f'column = "{columns[0]}"')
            .replace('column = "accel_tip"', f'column = "{columns[1]}"\n{sensor_keys}')
            .replace('file = "recording.csv"\ntime_column = "time"', f'file = "export.txt"\n{recording_keys}'))
    (directory / "beam.toml").write_text(toml, encoding="utf-8")
    return directory


def assert_same_record(rec, time_tolerance, accel_relative):
    """rec equals the cut example: time to ``time_tolerance`` s, force exactly as printed to 9
    digits (rel 1e-8), acceleration to ``accel_relative`` (its print's relative rounding)."""
    expected = reference_cut()
    assert rec.n_samples == ROWS
    np.testing.assert_allclose(rec.time, expected.time, rtol=0, atol=time_tolerance)
    np.testing.assert_allclose(rec.force, expected.force, rtol=1e-8, atol=0)
    peak = np.max(np.abs(expected.signals))
    np.testing.assert_allclose(rec.signals, expected.signals, rtol=accel_relative, atol=1e-12 * peak)


def test_the_users_export_loads_to_the_si_record(tmp_path):
    """Tabs, # lines, units in the header, the acceleration in g, time printed with 9 decimals.
    Time: rebuilt as t0 + i dt from its first and last cells, so within their rounding (half a
    unit of the 9th decimal, PRINTED) of i/fs. Acceleration: printed to 10 significant digits
    in g, so within 1e-9 relative of the SI value once multiplied by g."""
    rec = load_recording(recording_dir(tmp_path, export_lines()))
    assert_same_record(rec, PRINTED, 1e-9)
    assert rec.sensors[0].unit == "g" and rec.excitation.unit == "N"
    assert rec.fs == pytest.approx(FS, rel=PRINTED / 1.0)  # the record lasts 1 s
    # rebuilt, not taken as printed: uniform to the last bit
    np.testing.assert_array_equal(rec.time, rec.time[0] + np.arange(ROWS) * rec.dt)


def test_g_is_standard_gravity_not_gram(tmp_path):
    """The channel is multiplied by 9.80665: a wrong factor (1, 1e-3 for gram) is 10x off or more."""
    rec = load_recording(recording_dir(tmp_path, export_lines()))
    printed = np.array([float(line.split("\t")[2]) for line in export_lines()[3:]])
    np.testing.assert_allclose(rec.signals[:, 0], printed * G, rtol=1e-15)


def test_semicolons_and_decimal_commas(tmp_path):
    rec = load_recording(recording_dir(tmp_path, export_lines(delimiter=";", decimal=",")))
    assert_same_record(rec, PRINTED, 1e-9)


def test_decimal_comma_stated(tmp_path):
    lines = export_lines(delimiter=";", decimal=",")
    rec = load_recording(recording_dir(tmp_path, lines, 'delimiter = ";"\ndecimal = ","'))
    assert_same_record(rec, PRINTED, 1e-9)


def test_whitespace_separated(tmp_path):
    lines = [line.replace("Accel tip", "Accel_tip") for line in export_lines(delimiter="   ")]
    rec = load_recording(recording_dir(tmp_path, lines, columns=("Hammer", "Accel_tip")))
    assert_same_record(rec, PRINTED, 1e-9)


def test_time_in_milliseconds(tmp_path):
    """Time [ms] printed with 6 decimals (1 ns): converted to s and rebuilt to within its print."""
    rec = load_recording(recording_dir(tmp_path, export_lines("{:.6f}", units=("ms", "N", "g"))))
    assert_same_record(rec, PRINTED, 1e-9)


def test_sample_rate_without_a_time_column(tmp_path):
    """No time column: the time is i / sample_rate, exact (2048 Hz is a power of two)."""
    lines = [line.split("\t", 1)[1] for line in export_lines()[2:]]
    rec = load_recording(recording_dir(tmp_path, lines, "sample_rate = 2048"))
    np.testing.assert_array_equal(rec.time, np.arange(ROWS) / FS)
    assert_same_record(rec, 0.0, 1e-9)


def test_missing_time_column_names_the_stated_rate(tmp_path):
    """Without sample_rate, a file with no time column is refused; the fix names the rate the
    file's metadata states."""
    lines = ["# Sample rate: 2048 Hz"] + [line.split("\t", 1)[1] for line in export_lines()[2:]]
    with pytest.raises(RecordingError) as info:
        load_recording(recording_dir(tmp_path, lines))
    assert info.value.where == "[recording] .time_column"
    assert "sample_rate" in info.value.fix and "2048 Hz" in info.value.fix


def test_sample_rate_that_disagrees_with_the_time_column(tmp_path):
    with pytest.raises(RecordingError) as info:
        load_recording(recording_dir(tmp_path, export_lines(), "sample_rate = 4096"))
    assert info.value.where == "[recording] .sample_rate" and "2048" in info.value.problem


def test_unit_in_header_agrees_with_toml_unit(tmp_path):
    rec = load_recording(recording_dir(tmp_path, export_lines(), sensor_keys='unit = "g"'))
    assert_same_record(rec, PRINTED, 1e-9)


def test_unit_disagreement_is_refused(tmp_path):
    """Header says g, beam.toml says m/s^2: refused naming both and the fix."""
    with pytest.raises(RecordingError) as info:
        load_recording(recording_dir(tmp_path, export_lines(), sensor_keys='unit = "m/s^2"'))
    err = info.value
    assert err.where == "[[sensor]] #1 .unit" and Path(err.file).name == "beam.toml"
    assert "'m/s^2'" in err.problem and "'g'" in err.problem and "Accel tip (g)" in err.problem
    assert "correct [[sensor]] #1 unit" in err.fix


def test_header_unit_of_another_quantity_is_refused(tmp_path):
    lines = [line.replace("Accel tip (g)", "Accel tip (mm)") for line in export_lines()]
    with pytest.raises(RecordingError) as info:
        load_recording(recording_dir(tmp_path, lines))
    assert info.value.where == "[[sensor]] #1 .column" and "displacement" in info.value.problem


def test_volts_with_sensitivity(tmp_path):
    """An accelerometer of 10 mV/g recorded in V: SI = V / 0.01 * g, to the print's 1e-9."""
    lines = export_lines()
    lines[2] = lines[2].replace("Accel tip (g)", "Accel tip (V)")
    lines[3:] = [f"{t}\t{f}\t{float(a) * 0.01!r}" for t, f, a in (line.split("\t") for line in lines[3:])]
    rec = load_recording(recording_dir(tmp_path, lines, sensor_keys='unit = "g"\nsensitivity = 0.01'))
    assert_same_record(rec, PRINTED, 1e-9)
    assert rec.sensors[0].unit == "g"


def test_volts_with_scale(tmp_path):
    """scale = SI units per V: 9.80665 / 0.01 m/s^2 per V for the same 10 mV/g accelerometer."""
    lines = export_lines()
    lines[2] = lines[2].replace("Accel tip (g)", "Accel tip (mV)")
    lines[3:] = [f"{t}\t{f}\t{float(a) * 10.0!r}" for t, f, a in (line.split("\t") for line in lines[3:])]
    rec = load_recording(recording_dir(tmp_path, lines, sensor_keys=f"scale = {G / 0.01!r}"))
    assert_same_record(rec, PRINTED, 1e-9)


def test_volts_without_sensitivity_are_refused(tmp_path):
    lines = [line.replace("Accel tip (g)", "Accel tip (V)") for line in export_lines()]
    with pytest.raises(RecordingError) as info:
        load_recording(recording_dir(tmp_path, lines))
    assert "sensitivity" in info.value.fix and info.value.where == "[[sensor]] #1 .column"


def test_written_recording_reads_back_in_si(tmp_path):
    """write_recording writes the SI values with unit = "m/s^2" and the column without "(g)":
    reading it back gives the identical arrays."""
    rec = load_recording(recording_dir(tmp_path, export_lines()))
    again = load_recording(write_recording(rec, tmp_path / "copy"))
    np.testing.assert_array_equal(again.signals, rec.signals)
    np.testing.assert_array_equal(again.time, rec.time)
    assert again.sensors[0].unit == "m/s^2" and again.sensors[0].column == "Accel tip"
    assert again.excitation.unit == "N"


@pytest.mark.parametrize("columns", [("Hammer (N)", "Accel tip (g)"), ("Hammer [N]", "Accel tip [g]")])
def test_column_named_with_its_unit(tmp_path, columns):
    """The header cell in full, or its name and unit in the other brackets."""
    rec = load_recording(recording_dir(tmp_path, export_lines(), columns=columns))
    assert_same_record(rec, PRINTED, 1e-9)


def test_metadata_line_is_never_a_column_name(tmp_path):
    """A misnamed column is refused listing the header's columns, not the # lines."""
    with pytest.raises(RecordingError) as info:
        load_recording(recording_dir(tmp_path, export_lines(), columns=("Hammer", "Accel")))
    assert "Accel tip (g)" in info.value.problem and "Exported" not in str(info.value)


def test_nine_decimal_time_in_a_plain_csv(tmp_path):
    """The time-as-printed rule holds for the comma CSV too: its jitter (4e-6 relative at
    2048 Hz, 1e-9 s over a step of 4.9e-4 s) is the print's own, and the time is rebuilt."""
    lines = export_lines(delimiter=",")[2:]
    rec = load_recording(recording_dir(tmp_path, lines))
    assert_same_record(rec, PRINTED, 1e-9)


def test_time_uneven_beyond_its_print_is_refused(tmp_path):
    """One time cell off by 3e-9 s at 9 decimals (beyond the 1e-9 its print allows): refused at
    its physical line, with the sample rate to rebuild from in the fix."""
    lines = export_lines()
    cells = lines[10].split("\t")
    cells[0] = f"{float(cells[0]) + 3e-9:.9f}"
    lines[10] = "\t".join(cells)
    with pytest.raises(RecordingError) as info:
        load_recording(recording_dir(tmp_path, lines))
    # the cell spoils the steps to it and from it, by the same amount: either may be named
    assert info.value.where.split(",")[0] in ("line 11", "line 12") and "sample_rate = 2048" in info.value.fix


def test_unknown_header_unit_warns_and_is_taken_as_si(tmp_path):
    lines = [line.replace("Accel tip (g)", "Accel tip (EU)") for line in export_lines()]
    with pytest.warns(UserWarning, match="'EU' is not a unit"):
        rec = load_recording(recording_dir(tmp_path, lines))
    assert rec.sensors[0].unit is None


# --------------------------------------------------------------------------- the reader alone


def write(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "export.txt"
    path.write_text(text, encoding="utf-8")
    return path


def test_read_text_export_gives_channels_units_and_metadata(tmp_path):
    table = read_text_export(write(tmp_path, "\n".join(export_lines()) + "\n"))
    assert [(c.name, c.unit) for c in table.channels] == [("Hammer", "N"), ("Accel tip", "g")]
    assert table.sample_rate == FS and table.metadata == {"Sample rate": "2048 Hz"}
    assert table.time[1] == pytest.approx(1 / FS, abs=5e-10)  # printed to 9 decimals


@pytest.mark.parametrize("statement, rate", [("fs = 4096", 4096.0), ("dt = 0.000244140625", 4096.0),
                                             ("Sampling frequency: 10 kHz", 1e4), ("% dt = 2 ms", 500.0)])
def test_sample_rate_read_from_metadata(tmp_path, statement, rate):
    text = f"{statement}\ntime,a\n" + "".join(f"{k},{k}\n" for k in range(5))
    assert read_text_export(write(tmp_path, text)).sample_rate == rate


def test_stated_sample_rate_overrides_the_file(tmp_path):
    text = "fs = 4096\ntime,a\n" + "".join(f"{k},{k}\n" for k in range(5))
    assert read_text_export(write(tmp_path, text), sample_rate=100.0).sample_rate == 100.0


def test_units_row_under_the_names(tmp_path):
    text = "Time;Force;Accel\ns;N;m/s²\n" + "".join(f"{k},5;{k};0,25\n" for k in range(5))
    table = read_text_export(write(tmp_path, text))
    assert [(c.name, c.unit) for c in table.channels] == [("Force", "N"), ("Accel", "m/s²")]
    np.testing.assert_array_equal(table.time, np.arange(5) + 0.5)
    np.testing.assert_array_equal(table.channel("Accel").values, np.full(5, 0.25))


def test_line_numbers_are_physical(tmp_path):
    """A bad cell is named by its line in the file, metadata and blank lines counted."""
    text = "# a\n\n# b\ntime\tx\n" + "".join(f"{k}\t{'oops' if k == 3 else k}\n" for k in range(6))
    with pytest.raises(RecordingError) as info:
        read_text_export(write(tmp_path, text))
    assert info.value.where == 'line 8, column "x"'


def test_short_row_is_refused_at_its_line(tmp_path):
    text = "time\tx\ty\n" + "".join(f"{k}\t{k}\n" if k == 4 else f"{k}\t{k}\t{k}\n" for k in range(30))
    with pytest.raises(RecordingError) as info:
        read_text_export(write(tmp_path, text))
    assert info.value.where == "line 6" and "2 cells" in info.value.problem


def test_no_header_is_refused(tmp_path):
    text = "# only numbers\n" + "".join(f"{k}\t{k}\n" for k in range(6))
    with pytest.raises(RecordingError) as info:
        read_text_export(write(tmp_path, text))
    assert "no header" in info.value.problem and info.value.where == "line 2"


def test_comma_cannot_be_both(tmp_path):
    with pytest.raises(RecordingError, match="both the delimiter and the decimal"):
        read_text_export(write(tmp_path, "t,a\n0,1\n"), delimiter=",", decimal=",")


@pytest.mark.parametrize("cell, expected", [("Accel tip (g)", ("Accel tip", "g")), ("Time [ms]", ("Time", "ms")),
                                            ("force", ("force", None)), ("(s)", ("(s)", None)),
                                            ("a (b) c", ("a (b) c", None))])
def test_split_unit(cell, expected):
    assert split_unit(cell) == expected


def test_print_resolution():
    """One unit in the last printed digit; a short cell among long ones takes theirs."""
    got = print_resolution(["0", "0.000244141", "0.5", "0.500244141", "1.5e-3", "2.50E+02", "3.5E+2"])
    np.testing.assert_array_equal(got, [1e-9, 1e-9, 1e-9, 1e-9, 1e-4, 1.0, 1.0])


def test_warnings_are_not_raised_for_a_plain_export(tmp_path):
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        load_recording(recording_dir(tmp_path, export_lines()))


def test_whitespace_columns_with_spaces_in_their_names(tmp_path):
    """Columns set apart by runs of spaces, names holding single spaces (``Accel tip (g)``)."""
    rec = load_recording(recording_dir(tmp_path, export_lines(delimiter="   ")))
    assert_same_record(rec, PRINTED, 1e-9)


def test_check_prints_the_stated_unit(tmp_path, capsys):
    """`bayesbeam check` shows the channel's unit as stated and what it became: "g -> m/s^2"."""
    from bayesbeam.cli import main

    assert main(["check", str(recording_dir(tmp_path, export_lines())), "--out", str(tmp_path / "out")]) == 0
    assert "column 'Accel tip' (g -> m/s^2)" in capsys.readouterr().out


def test_delimiter_at_the_end_of_every_line(tmp_path):
    """A logger that ends each line with its delimiter: no empty last column."""
    text = "time;a;\n" + "".join(f"{k};{k},5;\n" for k in range(5))
    table = read_text_export(write(tmp_path, text))
    assert [c.name for c in table.channels] == ["a"]
    np.testing.assert_array_equal(table.channel("a").values, np.arange(5) + 0.5)


def test_skip_lines(tmp_path):
    """Metadata that looks like a header and data (``a b`` over ``1 2``) is skipped by skip_lines."""
    lines = ["Channels", "a\tb\tc", "1\t2\t3"] + export_lines()[2:]
    with pytest.raises(RecordingError):
        load_recording(recording_dir(tmp_path / "without", lines))
    rec = load_recording(recording_dir(tmp_path / "with", lines, "skip_lines = 3"))
    assert_same_record(rec, PRINTED, 1e-9)


def test_only_comments_is_refused(tmp_path):
    with pytest.raises(RecordingError, match="no lines but comments"):
        read_text_export(write(tmp_path, "# Exported 2026-11-20\n"), delimiter="\t")


def test_export_keys_do_not_warn(tmp_path):
    """The [recording] keys of a text export are known keys: no unused-key warning."""
    lines = export_lines(delimiter=";", decimal=",")
    keys = 'delimiter = ";"\ndecimal = ","\nsample_rate = 2048\nskip_lines = 2\ntime_column = "Time"'
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        rec = load_recording(recording_dir(tmp_path, lines, keys))
    assert_same_record(rec, PRINTED, 1e-9)
