"""Reader refusals, the shipped recordings, and the write/load round trip."""

import json
import pickle
from datetime import date
from pathlib import Path

import numpy as np
import pytest

from bayesbeam.io import (
    Beam,
    Excitation,
    Recording,
    RecordingError,
    Sensor,
    TipBody,
    load_recording,
    write_recording,
)
from bayesbeam.io.recording import MAX_MAGNITUDE, MIN_SAMPLES

DATA = Path(__file__).resolve().parents[2] / "data"
EXAMPLES = sorted(p for p in (DATA / "examples").iterdir() if p.is_dir())
REAL = DATA / "real" / "ds4-cantilever-freedecay" / "recording"

# A small valid recording; every refusal test breaks one thing in it.
BEAM_TOML = """\
[beam]
length = 1.0
density = 1710.0
area = 0.000597
second_moment = 1.64e-09
modulus = 2.84e10

[tip]
mass = 0.05
rotary_inertia = 1e-6

[excitation]
kind = "force"
location = 0.75
column = "force"

[[sensor]]
name = "tip"
location = 1.0
quantity = "acceleration"
column = "accel_tip"

[[sensor]]
name = "mid"
location = 0.5
quantity = "velocity"
column = "vel_mid"

[recording]
file = "recording.csv"
time_column = "time"

[notes]
test = "tiny"
"""
DT = 1.0 / 1024  # s, exact in binary
N = MIN_SAMPLES + 8  # the shortest record accepted, with room to delete a few rows
CSV = "time,force,accel_tip,vel_mid\n" + "".join(
    f"{k * DT!r},{k % 3 - 1.0!r},{0.5 * k!r},{-0.25 * k!r}\n" for k in range(N)
)
FREE_DECAY = 'kind = "free_decay"\nstart = 0.002\n'
RELEASE = 'kind = "release"\ntip_load = 0.4\n'
FORCE = 'kind = "force"\nlocation = 0.75\ncolumn = "force"\n'


def edit(text: str, old: str, new: str) -> str:
    assert old in text, f"test template lacks {old!r}"
    return text.replace(old, new, 1)


def make(tmp_path: Path, toml: str = BEAM_TOML, csv: str = CSV) -> Path:
    directory = tmp_path / "rec"
    directory.mkdir(parents=True)
    (directory / "beam.toml").write_text(toml, encoding="utf-8")
    (directory / "recording.csv").write_text(csv, encoding="utf-8")
    return directory


def csv_cell(line: int, column: int, value: str) -> str:
    """CSV with the cell at 1-based ``line`` (header = 1) and 0-based ``column`` replaced."""
    lines = CSV.splitlines()
    cells = lines[line - 1].split(",")
    cells[column] = value
    lines[line - 1] = ",".join(cells)
    return "\n".join(lines) + "\n"


def csv_line(line: int, text: str | None) -> str:
    """CSV with 1-based ``line`` replaced by ``text``, or deleted when ``text`` is None."""
    lines = CSV.splitlines()
    lines[line - 1 : line] = [] if text is None else [text]
    return "\n".join(lines) + "\n"


def refused(directory: Path, file_name: str, where: str) -> RecordingError:
    with pytest.raises(RecordingError) as info:
        load_recording(directory)
    err, message = info.value, str(info.value)
    assert Path(err.file).name == file_name and file_name in message
    assert where in err.where and where in message
    assert "Fix:" in message and err.fix
    return err


# --------------------------------------------------------------------------- the template


def test_template_loads(tmp_path):
    rec = load_recording(make(tmp_path))
    assert rec.beam == Beam(1.0, 1710.0, 0.000597, 1.64e-9, 2.84e10)
    assert rec.beam.rho_a == pytest.approx(1.02087)
    assert rec.beam.nominal_EI == pytest.approx(46.576)
    assert rec.tip == TipBody(0.05, 1e-6)
    assert rec.excitation == Excitation("force", location=0.75, column="force")
    assert [s.name for s in rec.sensors] == ["tip", "mid"]
    assert rec.n_samples == N and rec.dt == DT and rec.fs == 1024.0
    np.testing.assert_array_equal(rec.signals[:, rec.sensor_index("mid")], -0.25 * np.arange(N))
    np.testing.assert_array_equal(rec.force, np.arange(N) % 3 - 1.0)
    assert rec.extra == {"notes": {"test": "tiny"}}
    assert rec.source == tmp_path / "rec"


def test_beam_toml_path_accepted(tmp_path):
    assert load_recording(make(tmp_path) / "beam.toml").n_samples == N


def test_defaults_when_tip_and_recording_tables_absent(tmp_path):
    toml = BEAM_TOML.split("[tip]")[0] + "[excitation]" + BEAM_TOML.split("[excitation]")[1]
    toml = toml.split("[recording]")[0]
    rec = load_recording(make(tmp_path, toml))
    assert rec.tip == TipBody(0.0, 0.0) and rec.extra == {}


def test_unused_key_warns_and_is_ignored(tmp_path):
    with pytest.warns(UserWarning, match=r"\[tip\] \.mas"):
        rec = load_recording(make(tmp_path, edit(BEAM_TOML, "mass = 0.05", "mass = 0.05\nmas = 1.0")))
    assert rec.tip.mass == 0.05


def test_key_of_another_kind_warns(tmp_path):
    with pytest.warns(UserWarning, match="location"):
        rec = load_recording(make(tmp_path, edit(BEAM_TOML, FORCE, FREE_DECAY + "location = 0.75\n")))
    assert rec.excitation == Excitation("free_decay", start=0.002) and rec.force is None


def test_jitter_under_limit_accepted(tmp_path):
    csv = csv_cell(4, 0, repr(2 * DT * (1 + 2e-7)))  # a step off by 4e-7 relative
    assert load_recording(make(tmp_path, csv=csv)).n_samples == N


# --------------------------------------------------------------------------- refusals: files


def test_missing_beam_toml(tmp_path):
    refused(tmp_path / "nowhere", "beam.toml", "file")


def test_missing_csv(tmp_path):
    directory = make(tmp_path)
    (directory / "recording.csv").unlink()
    refused(directory, "recording.csv", "file")


def test_invalid_toml_syntax_names_the_line(tmp_path):
    refused(make(tmp_path, edit(BEAM_TOML, "density = 1710.0", "density = ")), "beam.toml", "line 3")


# --------------------------------------------------------------------------- refusals: beam.toml


def test_missing_beam_table(tmp_path):
    toml = "[tip]" + BEAM_TOML.split("[tip]")[1]
    refused(make(tmp_path, toml), "beam.toml", "[beam]")


@pytest.mark.parametrize(
    "old, where",
    [
        ("length = 1.0\n", "[beam] .length"),
        ('kind = "force"\n', "[excitation] .kind"),
        ("location = 0.75\n", "[excitation] .location"),
        ('column = "force"\n', "[excitation] .column"),
        ('quantity = "velocity"\n', "[[sensor]] #2 .quantity"),
    ],
)
def test_missing_required_key(tmp_path, old, where):
    refused(make(tmp_path, edit(BEAM_TOML, old, "")), "beam.toml", where)


def test_release_needs_tip_load(tmp_path):
    toml = edit(BEAM_TOML, FORCE, 'kind = "release"\n')
    refused(make(tmp_path, toml), "beam.toml", "[excitation] .tip_load")


def test_free_decay_needs_start(tmp_path):
    toml = edit(BEAM_TOML, FORCE, 'kind = "free_decay"\n')
    refused(make(tmp_path, toml), "beam.toml", "[excitation] .start")


def test_no_sensor_table(tmp_path):
    toml = BEAM_TOML.split("[[sensor]]")[0] + "[recording]" + BEAM_TOML.split("[recording]")[1]
    refused(make(tmp_path, toml), "beam.toml", "[[sensor]]")


def test_single_bracket_sensor_table(tmp_path):
    toml = BEAM_TOML.split("[[sensor]]")[0] + '[sensor]\nname = "tip"\n'
    refused(make(tmp_path, toml), "beam.toml", "[sensor]")


def test_duplicate_sensor_names(tmp_path):
    toml = edit(BEAM_TOML, 'name = "mid"', 'name = "tip"')
    refused(make(tmp_path, toml), "beam.toml", "[[sensor]] #2 .name")


def test_two_sensors_on_one_column(tmp_path):
    toml = edit(BEAM_TOML, 'column = "vel_mid"', 'column = "accel_tip"')
    refused(make(tmp_path, toml), "beam.toml", "[[sensor]] #2 .column")


@pytest.mark.parametrize("key", ["length", "density", "area", "second_moment", "modulus"])
@pytest.mark.parametrize("bad", ["0.0", "-1.0"])
def test_non_positive_beam_property(tmp_path, key, bad):
    toml = BEAM_TOML.replace(f"\n{key} = ", f"\n{key} = {bad}\n#")
    refused(make(tmp_path, toml), "beam.toml", f"[beam] .{key}")


@pytest.mark.parametrize("key", ["mass", "rotary_inertia"])
def test_negative_tip_property(tmp_path, key):
    toml = BEAM_TOML.replace(f"\n{key} = ", f"\n{key} = -1e-3\n#")
    refused(make(tmp_path, toml), "beam.toml", f"[tip] .{key}")


def test_non_numeric_toml_value(tmp_path):
    refused(make(tmp_path, edit(BEAM_TOML, "length = 1.0", 'length = "1.0"')), "beam.toml", "[beam] .length")


def test_non_finite_toml_value(tmp_path):
    toml = edit(BEAM_TOML, "modulus = 2.84e10", "modulus = inf")
    refused(make(tmp_path, toml), "beam.toml", "[beam] .modulus")


def test_unknown_kind(tmp_path):
    toml = edit(BEAM_TOML, 'kind = "force"', 'kind = "shaker"')
    refused(make(tmp_path, toml), "beam.toml", "[excitation] .kind")


def test_unknown_quantity(tmp_path):
    toml = edit(BEAM_TOML, 'quantity = "velocity"', 'quantity = "strain"')
    refused(make(tmp_path, toml), "beam.toml", "[[sensor]] #2 .quantity")


@pytest.mark.parametrize("bad", ["1.2", "-0.01"])
def test_sensor_location_outside_beam(tmp_path, bad):
    toml = edit(BEAM_TOML, "location = 0.5", f"location = {bad}")
    refused(make(tmp_path, toml), "beam.toml", "[[sensor]] #2 .location")


def test_excitation_location_outside_beam(tmp_path):
    toml = edit(BEAM_TOML, "location = 0.75", "location = 1.5")
    refused(make(tmp_path, toml), "beam.toml", "[excitation] .location")


@pytest.mark.parametrize("start", ["-0.001", "0.5", repr((N - 1) * DT)])
def test_free_decay_start_outside_record(tmp_path, start):
    toml = edit(BEAM_TOML, FORCE, f'kind = "free_decay"\nstart = {start}\n')
    refused(make(tmp_path, toml), "beam.toml", "[excitation] .start")


# --------------------------------------------------------------------------- refusals: the CSV


def test_missing_cell(tmp_path):
    refused(make(tmp_path, csv=csv_cell(5, 2, "")), "recording.csv", 'line 5, column "accel_tip"')


def test_short_row(tmp_path):
    refused(make(tmp_path, csv=csv_line(3, "0.1,0.0")), "recording.csv", "line 3")


def test_non_numeric_cell(tmp_path):
    refused(make(tmp_path, csv=csv_cell(6, 1, "1.2.3")), "recording.csv", 'line 6, column "force"')


@pytest.mark.parametrize("value", ["nan", "inf", "-Infinity"])
def test_non_finite_cell(tmp_path, value):
    refused(make(tmp_path, csv=csv_cell(7, 3, value)), "recording.csv", 'line 7, column "vel_mid"')


def test_non_finite_time(tmp_path):
    refused(make(tmp_path, csv=csv_cell(2, 0, "nan")), "recording.csv", 'line 2, column "time"')


@pytest.mark.parametrize("value", [repr(2 * DT), repr(DT)])  # repeated, then decreasing
def test_time_not_increasing(tmp_path, value):
    refused(make(tmp_path, csv=csv_cell(5, 0, value)), "recording.csv", 'line 5, column "time"')


def test_time_not_uniform(tmp_path):
    csv = csv_cell(4, 0, repr(2 * DT * (1 + 1e-5)))
    refused(make(tmp_path, csv=csv), "recording.csv", 'line 4, column "time"')


def test_dropped_sample_is_not_uniform(tmp_path):
    refused(make(tmp_path, csv=csv_line(5, None)), "recording.csv", 'line 5, column "time"')


@pytest.mark.parametrize(
    "old, new, where",
    [
        ('column = "vel_mid"', 'column = "vel_tip"', "[[sensor]] #2 .column"),
        ('column = "force"', 'column = "hammer"', "[excitation] .column"),
        ('time_column = "time"', 'time_column = "t"', "[recording] .time_column"),
    ],
)
def test_column_missing_from_csv(tmp_path, old, new, where):
    err = refused(make(tmp_path, edit(BEAM_TOML, old, new)), "beam.toml", where)
    assert "recording.csv" in err.problem


@pytest.mark.parametrize("rows", [1, 3, MIN_SAMPLES - 1])
def test_too_few_samples(tmp_path, rows):
    csv = "".join(CSV.splitlines(keepends=True)[: rows + 1])
    err = refused(make(tmp_path, csv=csv), "recording.csv", "file")
    assert f"{rows} data row(s)" in err.problem and str(MIN_SAMPLES) in err.problem


def test_fewest_samples_accepted(tmp_path):
    csv = "".join(CSV.splitlines(keepends=True)[: MIN_SAMPLES + 1])
    assert load_recording(make(tmp_path, csv=csv)).n_samples == MIN_SAMPLES


@pytest.mark.parametrize("value", ["1e308", "-1.7e308", repr(10 * MAX_MAGNITUDE)])
def test_overflowing_cell(tmp_path, value):
    """Finite, but its square (and any sum of squares over the record) overflows."""
    err = refused(make(tmp_path, csv=csv_cell(9, 2, value)), "recording.csv", 'line 9, column "accel_tip"')
    assert value in err.problem


def test_largest_magnitude_accepted(tmp_path):
    rec = load_recording(make(tmp_path, csv=csv_cell(9, 2, repr(MAX_MAGNITUDE))))
    assert rec.signals[7, 0] == MAX_MAGNITUDE


def test_overflowing_toml_value(tmp_path):
    refused(make(tmp_path, edit(BEAM_TOML, "modulus = 2.84e10", "modulus = 1e308")), "beam.toml", "[beam] .modulus")


@pytest.mark.parametrize("step", [1e-12, 1e6])
def test_sampling_step_in_the_wrong_unit(tmp_path, step):
    csv = "time,force,accel_tip,vel_mid\n" + "".join(f"{k * step!r},{k % 3 - 1.0},0.5,0.25\n" for k in range(N))
    err = refused(make(tmp_path, csv=csv), "recording.csv", 'column "time"')
    assert "seconds" in err.fix


def test_all_zero_force_channel(tmp_path):
    lines = CSV.splitlines()
    csv = "\n".join([lines[0]] + [",".join([c[0], "0.0", *c[2:]]) for c in (line.split(",") for line in lines[1:])])
    err = refused(make(tmp_path, csv=csv + "\n"), "recording.csv", 'column "force"')
    assert "zero in every sample" in err.problem and "free_decay" in err.fix


@pytest.mark.parametrize("delimiter", [";", "\t", " "])
def test_other_delimiters_read_as_the_comma_csv(tmp_path, delimiter):
    """A text export separated by semicolons, tabs or spaces reads to the very same arrays
    (exact: the cells are the same text)."""
    expected = load_recording(make(tmp_path / "csv"))
    assert load_recording(make(tmp_path / "other", csv=CSV.replace(",", delimiter))) == expected


def test_semicolons_with_decimal_commas_read_as_the_comma_csv(tmp_path):
    """The European spreadsheet export: ';' between cells and ',' as the decimal point."""
    expected = load_recording(make(tmp_path / "csv"))
    csv = CSV.replace(",", ";").replace(".", ",")
    assert load_recording(make(tmp_path / "other", csv=csv)) == expected


def test_unknown_delimiter_is_refused(tmp_path):
    """Vertical bars are no delimiter the reader sniffs: refused, naming [recording] delimiter."""
    err = refused(make(tmp_path, csv=CSV.replace(",", "|")), "recording.csv", f"line {N + 1}")
    assert "separated" in err.problem and "[recording] delimiter" in err.fix


def test_empty_csv(tmp_path):
    refused(make(tmp_path, csv=""), "recording.csv", "line 1")


def test_duplicate_csv_column(tmp_path):
    csv = CSV.replace("vel_mid", "force", 1)
    refused(make(tmp_path, csv=csv), "recording.csv", 'line 1, column "force"')


def test_blank_line_inside_data(tmp_path):
    csv = CSV.replace("\n", "\n\n", 2).replace("\n\n", "\n", 1)  # line 3 is blank
    refused(make(tmp_path, csv=csv), "recording.csv", "line 3")


def test_trailing_blank_lines_accepted(tmp_path):
    assert load_recording(make(tmp_path, csv=CSV + "\n\n")).n_samples == N


# --------------------------------------------------------------------------- the error type


def test_error_message_and_pickling():
    err = RecordingError("a/beam.toml", "[beam] .length", "missing", "add it.")
    assert str(err) == "a/beam.toml: [beam] .length: missing. Fix: add it."
    assert isinstance(err, ValueError)
    again = pickle.loads(pickle.dumps(err))
    assert (again.file, again.where, again.problem, again.fix, str(again)) == (
        err.file, err.where, err.problem, err.fix, str(err),
    )


# --------------------------------------------------------------------------- shipped data


@pytest.mark.parametrize("directory", EXAMPLES, ids=lambda p: p.name)
def test_example_matches_its_truth(directory):
    truth = json.loads((directory / "truth.json").read_text())
    rec = load_recording(directory)
    assert rec.fs == truth["fs"] and rec.n_samples == truth["n_samples"]
    assert [(s.name, s.location, s.quantity) for s in rec.sensors] == [
        (s["name"], s["location"], s["quantity"]) for s in truth["sensors"]
    ]
    assert rec.excitation.kind == truth["excitation"]["kind"]
    assert rec.beam.length == truth["beam_true"]["length"]
    assert (rec.force is not None) == (rec.excitation.kind == "force")
    assert "notes" in rec.extra


def test_real_record():
    rec = load_recording(REAL)
    assert rec.n_samples == 81920
    # The CSV prints the time with 10 decimals, so the mean step is exact to ~1e-12.
    assert rec.fs == pytest.approx(51200 / 31, rel=1e-10)
    assert [(s.name, s.quantity, s.column) for s in rec.sensors] == [("tip", "acceleration", "accel_tip")]
    assert rec.excitation == Excitation("free_decay", start=1.12)
    assert rec.tip == TipBody(0.006, 0.0)
    assert rec.time[-1] == pytest.approx(49.6, abs=1e-3)


# --------------------------------------------------------------------------- writing


@pytest.mark.parametrize(
    "directory", [DATA / "examples" / "paper_q3_hammer", DATA / "examples" / "alu_q1_release", REAL],
    ids=["force", "release", "free_decay"],
)
def test_round_trip(tmp_path, directory):
    rec = load_recording(directory)
    out = write_recording(rec, tmp_path / "copy")
    again = load_recording(out)
    assert again == rec and again.source == out
    assert sorted(p.name for p in tmp_path.iterdir()) == ["copy"]  # no staging left behind


def small_recording(**changes) -> Recording:
    n = MIN_SAMPLES
    fields = {
        "beam": Beam(0.5, 2700.0, 7.5e-5, 5.625e-11, 7e10),
        "tip": TipBody(),
        "excitation": Excitation("release", tip_load=0.4),
        "sensors": (Sensor("time", 0.5, "displacement", "time"),),
        "time": np.arange(n) / 4096.0,
        "signals": np.linspace(0.0, 1e-3, n)[:, None] / 3.0,
        "extra": {
            "title": 'say "hi"\n\tthere \\ é \x7f',
            "notes": {"a": [1, 2.5, "x"], "when": date(2024, 5, 1), "ok": True, "sub": {"k y": -0.1}},
        },
    }
    return Recording(**(fields | changes))


def test_round_trip_of_odd_names_and_extra_tables(tmp_path):
    rec = small_recording()
    again = load_recording(write_recording(rec, tmp_path / "odd"))
    assert again == rec  # a sensor column called "time" pushes the time column aside


def test_write_refuses_non_empty_directory(tmp_path):
    (tmp_path / "out").mkdir()
    (tmp_path / "out" / "keep.txt").write_text("mine")
    with pytest.raises(FileExistsError, match="overwrite=True"):
        write_recording(small_recording(), tmp_path / "out")
    assert (tmp_path / "out" / "keep.txt").read_text() == "mine"


def test_write_into_empty_directory_and_overwrite(tmp_path):
    (tmp_path / "out").mkdir()
    write_recording(small_recording(), tmp_path / "out")
    replacement = small_recording(tip=TipBody(0.01, 0.0))
    write_recording(replacement, tmp_path / "out", overwrite=True)
    assert load_recording(tmp_path / "out") == replacement
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]


# --------------------------------------------------------------------------- the object


def test_arrays_are_read_only_copies():
    time = np.arange(4) / 8.0
    rec = small_recording(time=time, signals=np.zeros((4, 1)))
    assert time.flags.writeable
    with pytest.raises(ValueError):
        rec.signals[0, 0] = 1.0


def test_with_signals_checks_shape():
    rec = small_recording()
    assert rec.with_signals(rec.signals * 2) != rec
    with pytest.raises(ValueError, match="shape"):
        rec.with_signals(rec.signals[1:])


def test_force_present_exactly_for_kind_force():
    with pytest.raises(ValueError, match="force"):
        small_recording(force=np.zeros(MIN_SAMPLES))


def test_sensor_index_lists_names():
    with pytest.raises(KeyError, match="'time'"):
        small_recording().sensor_index("tip")


# --------------------------------------------------------------------------- the record and the band


def test_too_few_samples_for_the_requested_band(tmp_path):
    """264 samples at 1024 Hz: a fit below 20 Hz decimates by 20 (0.40 fs / 20 Hz), which leaves
    13 samples, fewer than the 128 the low-pass disturbs at the end. Refused naming the recording
    and the flags that fix it; at the full band the same record is accepted."""
    from bayesbeam.inference.fit import FitConfig, prepare

    rec = load_recording(make(tmp_path))
    with pytest.raises(RecordingError) as info:
        prepare(rec, "q1", FitConfig(max_frequency=20.0), 4)
    err = info.value
    assert Path(err.file) == tmp_path / "rec" and "below 20 Hz" in err.problem
    assert "--max-frequency" in err.fix and "--start/--stop" in err.fix
    assert prepare(rec, "q1", FitConfig(max_frequency=380.0), 4).decimation == 1


@pytest.mark.parametrize("factor, warned", [(1.0, False), (1.019, False), (0.981, False), (1.021, True),
                                            (0.979, True), (0.5, True)])
def test_a_material_thickness_off_the_rectangular_depth_is_warned_not_refused(factor, warned):
    """[material] thickness against sqrt(12 I / A) of [beam] (the paper beam: 5.74 mm): within 2 %
    silent, beyond it a warning naming the file, the key and both numbers; the table is read either
    way. Tolerance: the 2 % the format states, probed 0.1 % on either side of it."""
    import warnings
    from dataclasses import replace

    from tests.physics.effects.helpers import recording

    rec = recording("force", duration=0.3)
    depth = np.sqrt(12 * rec.beam.second_moment / rec.beam.area)
    table = {"name": "steel", "temperature": 293.0, "thickness": factor * depth}
    rec = replace(rec, extra={"material": table})
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        assert rec.material.thickness == factor * depth
    messages = [str(w.message) for w in caught]
    assert len(messages) == int(warned), messages
    if warned:
        assert "beam.toml: [material] .thickness: " in messages[0]
        assert f"{factor * depth:.4g} m" in messages[0] and f"sqrt(12 I / A) = {depth:.4g} m" in messages[0]
