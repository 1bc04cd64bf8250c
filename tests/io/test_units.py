"""Channel units: the table of bayesbeam.io.units, and each unit through load_recording.

Every factor is checked against a constant written here, not taken from the module: standard
gravity 9.80665 m/s^2 and the inch 0.0254 m are exact by definition, the pound-force is
0.45359237 kg (exact) times standard gravity = 4.4482216152605 N.
"""
from pathlib import Path

import numpy as np
import pytest

from bayesbeam.io import RecordingError, load_recording
from bayesbeam.io.units import parse_unit
from tests.io.test_recording import BEAM_TOML

N = 256  # the fewest samples a recording may hold
DT = 1.0 / 1024  # s, exact in binary

#: (unit as written, quantity, SI value of one unit) for every unit of docs/format.md
UNITS = [
    ("g", "acceleration", 9.80665), ("m/s^2", "acceleration", 1.0), ("mm/s^2", "acceleration", 0.001),
    ("in/s^2", "acceleration", 0.0254),
    ("m/s", "velocity", 1.0), ("mm/s", "velocity", 0.001), ("um/s", "velocity", 1e-6), ("in/s", "velocity", 0.0254),
    ("m", "displacement", 1.0), ("mm", "displacement", 0.001), ("um", "displacement", 1e-6),
    ("in", "displacement", 0.0254),
    ("N", "force", 1.0), ("kN", "force", 1000.0), ("lbf", "force", 4.4482216152605),
]
#: other spellings of the same units
SPELLINGS = [("m/s²", "m/s^2"), ("m s^-2", "m/s^2"), ("m*s^-2", "m/s^2"), ("m s⁻²", "m/s^2"), ("m/s/s", "m/s^2"),
             ("m/s2", "m/s^2"), ("mm/s²", "mm/s^2"), ("µm", "um"), ("μm", "um"), ("m s^-1", "m/s"), ("µm/s", "um/s"),
             ("gn", "g"), ("G", "g"), (" m / s ", "m/s")]

BEAM = BEAM_TOML.split("\n\n")[0]  # the [beam] table of the reader's tests
TOML = BEAM + """

[excitation]
kind = "force"
location = 0.75
column = "force"
{force_keys}

[[sensor]]
name = "tip"
location = 1.0
quantity = "{quantity}"
column = "{column}"
{sensor_keys}
"""
SIGNAL = [(k % 7 - 3) * 0.125 for k in range(N)]  # exact in binary and in decimal
FORCE = [k % 3 - 1.0 for k in range(N)]
SIGNAL_SI, FORCE_SI = np.array(SIGNAL), np.array(FORCE)


def make(tmp_path: Path, quantity="acceleration", sensor_keys="", force_keys="", column="signal",
         header="time,force,signal", signal=SIGNAL) -> Path:
    directory = tmp_path / "rec"
    directory.mkdir()
    toml = TOML.format(quantity=quantity, sensor_keys=sensor_keys, force_keys=force_keys, column=column)
    (directory / "beam.toml").write_text(toml, encoding="utf-8")
    rows = "".join(f"{k * DT!r},{f!r},{s!r}\n" for k, (f, s) in enumerate(zip(FORCE, signal)))
    (directory / "recording.csv").write_text(header + "\n" + rows, encoding="utf-8")
    return directory


@pytest.mark.parametrize("text, quantity, factor", UNITS)
def test_table_factor(text, quantity, factor):
    unit = parse_unit(text)
    assert (unit.quantity, unit.factor) == (quantity, factor)


@pytest.mark.parametrize("text, canonical", SPELLINGS)
def test_spellings(text, canonical):
    assert parse_unit(text) == parse_unit(canonical)


@pytest.mark.parametrize("text", ["gram", "gr", "m/s^3", "kg", "", "furlong"])
def test_unknown_units(text):
    assert parse_unit(text) is None


@pytest.mark.parametrize("text, quantity, factor", [u for u in UNITS if u[1] != "force"])
def test_sensor_unit_converts_at_load(tmp_path, text, quantity, factor):
    """Stated in beam.toml, each unit scales the signal by its factor (rel 1e-15: one product)."""
    rec = load_recording(make(tmp_path, quantity, f'unit = "{text}"'))
    np.testing.assert_allclose(rec.signals[:, 0], SIGNAL_SI * factor, rtol=1e-15, atol=0)
    assert rec.sensors[0].unit == parse_unit(text).symbol


@pytest.mark.parametrize("text, factor", [(u[0], u[2]) for u in UNITS if u[1] == "force"])
def test_force_unit_converts_at_load(tmp_path, text, factor):
    rec = load_recording(make(tmp_path, force_keys=f'unit = "{text}"'))
    np.testing.assert_allclose(rec.force, FORCE_SI * factor, rtol=1e-15, atol=0)
    assert rec.excitation.unit == text


@pytest.mark.parametrize("text, quantity, factor", [u for u in UNITS if u[1] != "force"])
def test_header_unit_converts_at_load(tmp_path, text, quantity, factor):
    """Stated only in the header cell (``signal (g)``), with beam.toml's column naming the bare name."""
    rec = load_recording(make(tmp_path, quantity, header=f"time,force,signal ({text})"))
    np.testing.assert_allclose(rec.signals[:, 0], SIGNAL_SI * factor, rtol=1e-15, atol=0)


def test_no_unit_is_si_and_bit_identical(tmp_path):
    rec = load_recording(make(tmp_path))
    np.testing.assert_array_equal(rec.signals[:, 0], SIGNAL_SI)
    assert rec.sensors[0].unit is None and rec.excitation.unit is None


def test_sensitivity_in_volts_per_g(tmp_path):
    """10 mV/g: a value of v volts is v / 0.01 g = v / 0.01 * 9.80665 m/s^2."""
    rec = load_recording(make(tmp_path, sensor_keys='unit = "g"\nsensitivity = 0.01', header="time,force,signal (V)"))
    np.testing.assert_allclose(rec.signals[:, 0], SIGNAL_SI / 0.01 * 9.80665, rtol=1e-15, atol=0)
    assert rec.sensors[0].unit == "g"


def test_sensitivity_of_a_force_in_mv(tmp_path):
    """A hammer of 2.25 mV/N recorded in mV: N = mV * 1e-3 / 2.25e-3."""
    rec = load_recording(make(tmp_path, force_keys="sensitivity = 2.25e-3", header="time,force [mV],signal"))
    np.testing.assert_allclose(rec.force, FORCE_SI * 1e-3 / 2.25e-3, rtol=1e-15, atol=0)


def test_scale(tmp_path):
    rec = load_recording(make(tmp_path, sensor_keys="scale = 980.665"))
    np.testing.assert_allclose(rec.signals[:, 0], SIGNAL_SI * 980.665, rtol=1e-15, atol=0)


@pytest.mark.parametrize("keys, where, words", [
    ('unit = "mm"', "[[sensor]] #1 .unit", "a unit of displacement, not of acceleration"),
    ('unit = "gram"', "[[sensor]] #1 .unit", "unknown unit"),
    ('unit = "V"', "[[sensor]] #1 .unit", "a unit of voltage"),
    ("sensitivity = 0.01\nscale = 2.0", "[[sensor]] #1 .scale", "by itself"),
    ('unit = "g"\nscale = 2.0', "[[sensor]] #1 .scale", "by itself"),
    ("sensitivity = 0.0", "[[sensor]] #1 .sensitivity", "zero"),
    ('unit = 3', "[[sensor]] #1 .unit", "not a non-empty string"),
])
def test_bad_unit_keys_are_refused(tmp_path, keys, where, words):
    with pytest.raises(RecordingError) as info:
        load_recording(make(tmp_path, sensor_keys=keys))
    assert info.value.where == where and words in info.value.problem and info.value.fix


def test_header_and_toml_disagree(tmp_path):
    with pytest.raises(RecordingError) as info:
        load_recording(make(tmp_path, sensor_keys='unit = "m/s^2"', header="time,force,signal (g)"))
    err = info.value
    assert err.where == "[[sensor]] #1 .unit" and "'g'" in err.problem and "'m/s^2'" in err.problem
    assert "signal (g)" in err.problem and "recording.csv" in err.problem


def test_spellings_of_one_unit_agree(tmp_path):
    """m/s² in the header and m s^-2 in beam.toml are the same unit: no refusal."""
    rec = load_recording(make(tmp_path, sensor_keys='unit = "m s^-2"', header="time,force,signal (m/s²)"))
    np.testing.assert_array_equal(rec.signals[:, 0], SIGNAL_SI)


def test_sensitivity_on_a_channel_in_physical_units(tmp_path):
    with pytest.raises(RecordingError) as info:
        load_recording(make(tmp_path, sensor_keys="sensitivity = 0.01", header="time,force,signal (g)"))
    assert info.value.where == "[[sensor]] #1 .column" and "not volts" in info.value.problem


def test_unit_keys_do_not_warn(tmp_path):
    import warnings
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        load_recording(make(tmp_path, sensor_keys='unit = "g"', force_keys='unit = "N"'))
