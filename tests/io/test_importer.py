"""import_file: DAQ files -> recording folders. The skeleton is refused key by key until filled in;
with a beam description the recording loads at once and equals the source in SI; the real ds4
record's .lvm gives the shipped recording; refusals name the file, the place and the fix."""
import re
from pathlib import Path

import numpy as np
import pytest
from nptdms import ChannelObject, GroupObject, RootObject, TdmsWriter
from scipy.io import savemat

from bayesbeam.io import RecordingError, load_recording, write_uff58
from bayesbeam.io.importer import FORMATS, column_names, import_file, placeholders, read_channels
from bayesbeam.io.units import STANDARD_GRAVITY

ROOT = Path(__file__).resolve().parents[2]
DS4 = ROOT / "data" / "real" / "ds4-cantilever-freedecay"
HAMMER = ROOT / "data" / "examples" / "paper_q3_hammer"
N, RATE = 400, 2048.0
RNG = np.random.default_rng(11)
ACCEL_G = RNG.standard_normal(N) * 0.3
FORCE_KN = np.where(np.arange(N) == 20, 0.1, 0.0) + RNG.standard_normal(N) * 1e-4
BEAM = (HAMMER / "beam.toml").read_text().split("\n[excitation]")[0] + "\n"  # the paper beam's [beam] table
DESCRIBED = BEAM + """
[excitation]
kind = "force"
location = 0.75

[[sensor]]
name = "tip"
location = 1.0
quantity = "acceleration"
column = "Accel_tip"
"""
#: the values written are the file's times a unit's factor, which is one rounding (half an ulp,
#: 1.1e-16 relative); a wrong factor (g as 9.81 m/s^2, 3.4e-4 off) is far outside this
CONVERSION_RTOL = 1e-15


def hammer_tdms(path):
    with TdmsWriter(path) as writer:
        props = {"wf_increment": 1 / RATE, "wf_start_offset": 0.0}
        writer.write_segment([RootObject(), GroupObject("Test", properties={"rig": "bench 2"}),
                              ChannelObject("Test", "Hammer", FORCE_KN, properties={**props, "unit_string": "kN"}),
                              ChannelObject("Test", "Accel tip", ACCEL_G, properties={**props, "unit_string": "g"})])
    return path


def hammer_mat(path):
    savemat(path, {"time": np.arange(N) / RATE, "hammer": FORCE_KN, "accel_tip": ACCEL_G,
                   "units": {"hammer": "kN", "accel_tip": "g"}})
    return path


def fill(toml: Path, key: str, value: str) -> None:
    """Put ``value`` in the first placeholder line of ``key``, as the user would."""
    text = toml.read_text()
    toml.write_text(re.sub(rf"^# {key} = \.\.\..*$", f"{key} = {value}", text, count=1, flags=re.MULTILINE))


def refused_where(folder) -> str:
    with pytest.raises(RecordingError) as caught:
        load_recording(folder)
    assert caught.value.problem == "missing"
    return caught.value.where


def test_the_skeleton_is_refused_key_by_key_until_filled_then_loads(tmp_path):
    out = import_file(hammer_tdms(tmp_path / "hit.tdms"), tmp_path / "rec")
    toml = out / "beam.toml"
    keys = ["[beam] length", "[beam] density", "[beam] area", "[beam] second_moment", "[beam] modulus",
            "[excitation] location", "[[sensor]] #1 location"]
    assert placeholders(toml) == keys
    values = {"length": "1.0", "density": "1710.0", "area": "0.000597", "second_moment": "1.64e-9",
              "modulus": "2.68e10", "location": "0.75"}
    for key in keys:  # each refusal names the next key to fill in, with the fix
        table, name = key.split(" ")[0], key.split(" ")[-1]
        assert refused_where(out).startswith(table) and refused_where(out).endswith(f".{name}")
        fill(toml, name, values[name] if key != keys[-1] else "1.0")
    assert placeholders(toml) == []
    rec = load_recording(out)
    assert (rec.excitation.kind, rec.excitation.column, rec.excitation.location) == ("force", "Hammer", 0.75)
    assert (rec.sensors[0].name, rec.sensors[0].quantity, rec.sensors[0].column) == ("Accel_tip", "acceleration",
                                                                                      "Accel_tip")
    np.testing.assert_allclose(rec.force, FORCE_KN * 1e3, rtol=CONVERSION_RTOL, atol=0)
    np.testing.assert_allclose(rec.signals[:, 0], ACCEL_G * STANDARD_GRAVITY, rtol=CONVERSION_RTOL, atol=0)
    assert rec.extra["notes"]["rig"] == "bench 2" and rec.extra["notes"]["imported_from"] == "hit.tdms"


@pytest.mark.parametrize("make", [hammer_tdms, hammer_mat])
def test_with_a_beam_description_the_recording_equals_the_source_in_si(tmp_path, make):
    source = make(tmp_path / ("hit.tdms" if make is hammer_tdms else "hit.mat"))
    (tmp_path / "beam.toml").write_text(DESCRIBED.replace("Accel_tip", "Accel_tip" if make is hammer_tdms
                                                          else "accel_tip"))
    rec = load_recording(import_file(source, tmp_path / "rec", beam=tmp_path / "beam.toml"))
    np.testing.assert_allclose(rec.force, FORCE_KN * 1e3, rtol=CONVERSION_RTOL, atol=0)
    np.testing.assert_allclose(rec.signals[:, 0], ACCEL_G * STANDARD_GRAVITY, rtol=CONVERSION_RTOL, atol=0)
    # k / 2048 s: the grid t0 + k dt from the file's end points is exact in binary here
    np.testing.assert_array_equal(rec.time, np.arange(N) / RATE)
    assert rec.excitation.column.lower() == "hammer" and rec.sensors[0].name == "tip"


def test_a_free_decay_skeleton_asks_for_the_start(tmp_path):
    savemat(tmp_path / "ring.mat", {"fs": RATE, "velocity": ACCEL_G, "velocity_unit": "mm/s"})
    out = import_file(tmp_path / "ring.mat", tmp_path / "rec")
    text = (out / "beam.toml").read_text()
    assert 'kind = "free_decay"' in text and 'quantity = "velocity"' in text
    assert placeholders(out / "beam.toml")[-2:] == ["[excitation] start", "[[sensor]] #1 location"]


@pytest.mark.parametrize("unit,quantity", [("m/s^2", "acceleration"), ("m/s", "velocity"), ("mm", "displacement"),
                                           ("g", "acceleration")])
def test_the_quantity_is_guessed_from_the_unit(tmp_path, unit, quantity):
    savemat(tmp_path / "x.mat", {"fs": RATE, "x": ACCEL_G, "x_unit": unit})
    text = (import_file(tmp_path / "x.mat", tmp_path / "rec") / "beam.toml").read_text()
    assert f'quantity = "{quantity}"' in text and f'unit = "{unit}"' in text


@pytest.mark.parametrize("unit", ["V", None])
def test_a_channel_in_volts_or_without_unit_leaves_the_quantity_to_fill_in(tmp_path, unit):
    """A unit of volts is written as stated and marked: load refuses it as no unit of the quantity
    until the user states the calibration (sensitivity with the unit, or scale)."""
    savemat(tmp_path / "x.mat", {"fs": RATE, "x": ACCEL_G, **({"x_unit": unit} if unit else {})})
    out = import_file(tmp_path / "x.mat", tmp_path / "rec")
    assert "[[sensor]] #1 quantity" in placeholders(out / "beam.toml")
    assert ("[[sensor]] #1 unit" in placeholders(out / "beam.toml")) == (unit == "V")


def test_a_force_is_found_by_its_name_when_its_unit_is_volts(tmp_path):
    savemat(tmp_path / "x.mat", {"fs": RATE, "load_cell": FORCE_KN, "load_cell_unit": "V", "a": ACCEL_G})
    text = (import_file(tmp_path / "x.mat", tmp_path / "rec") / "beam.toml").read_text()
    assert 'kind = "force"\ncolumn = "load_cell"' in text


def test_column_names_are_plain_and_distinct(tmp_path):
    savemat(tmp_path / "x.mat", {"data": {"a b": ACCEL_G}, "a_b": ACCEL_G, "time": np.arange(N) / RATE})
    table = read_channels(tmp_path / "x.mat")
    assert column_names(table) == ["a_b", "a_b_2"]


def test_a_clock_time_is_counted_from_the_first_sample(tmp_path):
    savemat(tmp_path / "x.mat", {"t": 3.7e9 + np.arange(N) / RATE, "a": ACCEL_G, "a_unit": "g"})
    out = import_file(tmp_path / "x.mat", tmp_path / "rec")
    lines = (out / "recording.csv").read_text().splitlines()
    assert lines[1].startswith("0.0,") and "time_origin_s = 3700000000.0" in (out / "beam.toml").read_text()


def test_a_sample_rate_given_overrides_the_files(tmp_path):
    savemat(tmp_path / "x.mat", {"fs": 1000.0, "a": ACCEL_G})
    out = import_file(tmp_path / "x.mat", tmp_path / "rec", sample_rate=RATE)
    time = np.loadtxt(out / "recording.csv", delimiter=",", skiprows=1)[:, 0]
    np.testing.assert_array_equal(time, np.arange(N) / RATE)  # k / 2048 is exact in binary


def test_a_printed_time_takes_the_rate_the_file_states(tmp_path):
    """Time printed to 9 decimals (each within 5e-10 s of k / 2048) and a stated 2048 Hz: the grid
    is the stated rate's, exactly k / 2048; the printed column alone would give a step 2.5e-10 s /
    (N - 1) off. A stated rate 1 % off the column's is not taken (the column wins)."""
    rows = "".join(f"{k / RATE:.9f}\t{a:.6g}\n" for k, a in enumerate(ACCEL_G))
    for stated, expected in ((RATE, np.arange(N) / RATE), (1.01 * RATE, None)):
        export = tmp_path / f"export_{stated:g}.txt"
        export.write_text(f"# Sample rate: {stated:g} Hz\nTime (s)\tAccel tip (g)\n" + rows)
        out = import_file(export, tmp_path / f"rec_{stated:g}")
        time = np.loadtxt(out / "recording.csv", delimiter=",", skiprows=1)[:, 0]
        if expected is not None:
            np.testing.assert_array_equal(time, expected)
        else:
            np.testing.assert_allclose(time, np.arange(N) / RATE, rtol=0, atol=1e-9)


def test_a_time_with_a_gap_is_refused_naming_the_sample(tmp_path):
    time = np.arange(N) / RATE
    time[200:] += 1 / RATE  # a dropped sample
    savemat(tmp_path / "x.mat", {"t": time, "a": ACCEL_G})
    with pytest.raises(RecordingError) as caught:
        import_file(tmp_path / "x.mat", tmp_path / "rec")
    assert caught.value.where.startswith("time, sample") and "--sample-rate" in caught.value.fix
    assert not (tmp_path / "rec").exists()


def test_a_file_without_time_or_rate_is_refused(tmp_path):
    savemat(tmp_path / "x.mat", {"a": ACCEL_G})
    with pytest.raises(RecordingError, match="--sample-rate"):
        import_file(tmp_path / "x.mat", tmp_path / "rec")


def test_an_unknown_extension_names_the_format_choices(tmp_path):
    (tmp_path / "x.bin").write_bytes(b"\0")
    with pytest.raises(RecordingError) as caught:
        import_file(tmp_path / "x.bin", tmp_path / "rec")
    assert caught.value.where == "file name" and all(f in caught.value.fix for f in FORMATS)


def test_an_option_of_another_format_is_refused(tmp_path):
    with pytest.raises(RecordingError) as caught:
        import_file(hammer_mat(tmp_path / "x.mat"), tmp_path / "rec", group="Test")
    assert caught.value.where == "--group" and "TDMS" in caught.value.problem


def test_an_empty_file_is_refused(tmp_path):
    (tmp_path / "x.lvm").write_text("")
    with pytest.raises(RecordingError) as caught:
        import_file(tmp_path / "x.lvm", tmp_path / "rec")
    assert caught.value.file == str(tmp_path / "x.lvm") and caught.value.where == "line 1"


def test_a_sensor_naming_a_channel_the_file_lacks_is_refused(tmp_path):
    (tmp_path / "beam.toml").write_text(DESCRIBED.replace('"Accel_tip"', '"accel"'))
    with pytest.raises(RecordingError) as caught:
        import_file(hammer_tdms(tmp_path / "x.tdms"), tmp_path / "rec", beam=tmp_path / "beam.toml")
    assert caught.value.where == "[[sensor]] #1 .column" and "Hammer, Accel_tip" in caught.value.problem


def test_the_write_is_atomic_and_refuses_a_non_empty_folder(tmp_path):
    source = hammer_tdms(tmp_path / "x.tdms")
    out = tmp_path / "rec"
    out.mkdir()
    (out / "mine.txt").write_text("keep")
    with pytest.raises(FileExistsError):
        import_file(source, out)
    assert [p.name for p in out.iterdir()] == ["mine.txt"]
    import_file(source, out, overwrite=True)
    assert sorted(p.name for p in out.iterdir()) == ["beam.toml", "recording.csv"]
    assert [p.name for p in tmp_path.iterdir() if p.name.startswith(".")] == []  # no staging left over


def test_a_uff_file_without_beam_gives_a_skeleton_in_si(tmp_path):
    rec = load_recording(HAMMER)
    table = read_channels(write_uff58(rec, tmp_path / "r.uff", binary=True))
    assert [(c.name, c.unit) for c in table.channels] == [("force", "N"), ("accel_tip", "m/s^2")]
    np.testing.assert_array_equal(table.channels[1].values, rec.signals[:, 0])  # 58b: the float64 samples
    assert table.metadata["node accel_tip"] == "2 (x = 1.0 m)"


def test_the_real_ds4_lvm_gives_the_shipped_recording(tmp_path):
    out = import_file(DS4 / "timeseries_data.lvm", tmp_path / "ds4", beam=DS4 / "beam-description.toml")
    imported, shipped = load_recording(out), load_recording(DS4 / "recording")
    assert (imported.beam, imported.tip, imported.excitation) == (shipped.beam, shipped.tip, shipped.excitation)
    assert [(s.name, s.location, s.quantity) for s in imported.sensors] == [
        (s.name, s.location, s.quantity) for s in shipped.sensors]
    # Time: the shipped CSV holds k * 31/51200 s (the NI-9234's 51200/31 Hz) printed with 12 significant
    # digits (<= 5e-11 s off); the import's grid runs between the .lvm's first and last X_Value, each
    # printed with 6 decimals (<= 5e-7 s off), so every sample lies within 5e-7 s of the exact grid.
    np.testing.assert_allclose(imported.time, shipped.time, rtol=0, atol=5e-7 + 5e-11)
    # Values: the shipped CSV holds g * 9.80665 printed with 7 significant digits, so it lies within half
    # a unit of that 7th digit of the import's g * 9.80665 (plus a few ulps of the two floats at a tie).
    x, y = imported.signals[:, 0], shipped.signals[:, 0]
    with np.errstate(divide="ignore"):
        half_unit = 0.5 * 10.0 ** (np.floor(np.log10(np.abs(y))) - 6)
    assert np.all(np.abs(x - y) <= half_unit + 4 * np.spacing(np.abs(y)))


def test_a_channel_in_volts_is_refused_at_load_until_its_calibration_is_stated(tmp_path):
    savemat(tmp_path / "x.mat", {"fs": RATE, "x": ACCEL_G, "x_unit": "V"})
    out = import_file(tmp_path / "x.mat", tmp_path / "rec")
    toml = out / "beam.toml"
    for key, value in [("length", "1.0"), ("density", "1710.0"), ("area", "0.000597"), ("second_moment", "1.64e-9"),
                       ("modulus", "2.68e10"), ("start", "0.01"), ("quantity", '"acceleration"'),
                       ("location", "1.0")]:
        fill(toml, key, value)
    with pytest.raises(RecordingError) as caught:
        load_recording(out)
    assert caught.value.where == "[[sensor]] #1 .unit" and "sensitivity" in caught.value.fix
    toml.write_text(toml.read_text().replace('unit = "V"', 'unit = "g"\nsensitivity = 0.1'))
    rec = load_recording(out)  # 0.1 V per g: volts / 0.1 g
    np.testing.assert_allclose(rec.signals[:, 0], ACCEL_G / 0.1 * STANDARD_GRAVITY, rtol=CONVERSION_RTOL, atol=0)


def test_a_calibration_in_the_beam_description_keeps_the_file_unit_out(tmp_path):
    savemat(tmp_path / "x.mat", {"fs": RATE, "x": ACCEL_G, "x_unit": "V"})
    (tmp_path / "beam.toml").write_text(BEAM + '[excitation]\nkind = "free_decay"\nstart = 0.01\n\n[[sensor]]\n'
                                        'name = "tip"\nlocation = 1.0\nquantity = "acceleration"\ncolumn = "x"\n'
                                        "scale = 2.0\n")
    rec = load_recording(import_file(tmp_path / "x.mat", tmp_path / "rec", beam=tmp_path / "beam.toml"))
    np.testing.assert_allclose(rec.signals[:, 0], ACCEL_G * 2.0, rtol=CONVERSION_RTOL, atol=0)
