"""The optional set-up keys of beam.toml (docs/format.md): read, kept, written back, checked when read.

FORMAT.md carries keys it does not name along without refusing them, so a bad set-up value must
not stop a recording from loading; ``Recording.setup`` refuses it, naming the file, key and fix.
"""

import warnings
from pathlib import Path

import numpy as np
import pytest

from bayesbeam.io import RecordingError, load_recording, write_recording
from bayesbeam.io.recording import MIN_SAMPLES, SetUp

DATA = Path(__file__).resolve().parents[2] / "data"
REPO = DATA.parent
#: every recording shipped in the repository: the examples, the real record, the studies' records
SHIPPED = sorted(p.parent for p in REPO.glob("data/**/beam.toml")) + sorted(
    p.parent for p in REPO.glob("studies/*/recordings/*/beam.toml"))

STATED = """\
[beam]
length = 0.759
length_tolerance = 0.005
density = 7850.0
area = 2.6039e-4
second_moment = 5.7329e-10
modulus = 2.0e11

[tip]
mass = 0.0
rotary_inertia = 0.0
mass_tolerance = 0.002
rotary_inertia_tolerance = 1e-7

[excitation]
kind = "free_decay"
start = 0.01

[[sensor]]
name = "tip"
location = 0.75
quantity = "acceleration"
column = "accel_tip"
mass = 0.006
location_tolerance = 0.004

[[sensor]]
name = "mid"
location = 0.4
quantity = "acceleration"
column = "accel_mid"
"""
CSV = "time,accel_tip,accel_mid\n" + "".join(f"{k / 1024!r},{float(np.sin(k / 7.0))!r},{float(np.cos(k / 5.0))!r}\n"
                                              for k in range(MIN_SAMPLES + 8))


def make(tmp_path: Path, toml: str = STATED) -> Path:
    directory = tmp_path / "rec"
    directory.mkdir()
    (directory / "beam.toml").write_text(toml, encoding="utf-8")
    (directory / "recording.csv").write_text(CSV, encoding="utf-8")
    return directory


def quietly_loaded(directory: Path):
    """load_recording with every warning an error: a set-up key must not be taken for a typo."""
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        return load_recording(directory)


def test_the_stated_setup_is_read_without_warnings_and_exposed(tmp_path):
    rec = quietly_loaded(make(tmp_path))
    assert rec.setup == SetUp(length_tolerance=0.005, tip_mass_tolerance=0.002, tip_rotary_inertia_tolerance=1e-7,
                              sensor_masses=(0.006, None), location_tolerances=(0.004, 0.0),
                              high_pass_corners=(None, None), gain_tolerances=(None, None))
    assert rec.setup.stated_mass == 0.006
    # the nominal description is what it was: the set-up keys change no other field
    assert rec.beam.length == 0.759 and rec.sensors[0].location == 0.75 and rec.tip.mass == 0.0


def test_write_and_load_keep_the_stated_setup(tmp_path):
    rec = quietly_loaded(make(tmp_path))
    back = quietly_loaded(write_recording(rec, tmp_path / "copy"))
    assert back == rec and back.setup == rec.setup and back.setup_keys == rec.setup_keys


@pytest.mark.parametrize(("old", "new", "where"), [
    ("mass = 0.006", "mass = -0.006", "[[sensor]] #1 .mass"),
    ("mass = 0.006", 'mass = "6 g"', "[[sensor]] #1 .mass"),
    ("location_tolerance = 0.004", "location_tolerance = nan", "[[sensor]] #1 .location_tolerance"),
    ("length_tolerance = 0.005", "length_tolerance = inf", "[beam] .length_tolerance"),
    ("length_tolerance = 0.005", "length_tolerance = -0.001", "[beam] .length_tolerance"),
    ("length_tolerance = 0.005", "length_tolerance = 0.759", "[beam] .length_tolerance"),   # not below l
    ("mass_tolerance = 0.002", "mass_tolerance = -1e-3", "[tip] .mass_tolerance"),
    ("rotary_inertia_tolerance = 1e-7", "rotary_inertia_tolerance = -inf", "[tip] .rotary_inertia_tolerance"),
])
def test_a_bad_setup_value_loads_but_is_refused_when_read(tmp_path, old, new, where):
    assert old in STATED
    rec = quietly_loaded(make(tmp_path, STATED.replace(old, new, 1)))   # FORMAT.md: carried along
    with pytest.raises(RecordingError) as info:
        _ = rec.setup
    err, message = info.value, str(info.value)
    assert Path(err.file).name == "beam.toml" and err.where == where and where in message
    assert "Fix:" in message and err.fix


def test_a_stated_mass_of_zero_is_a_statement_not_an_absence(tmp_path):
    """A non-contact sensor (a laser vibrometer) adds no mass: 0 is accepted and kept apart from
    a mass not stated (None)."""
    rec = quietly_loaded(make(tmp_path, STATED.replace("mass = 0.006", "mass = 0.0", 1)))
    assert rec.setup.sensor_masses == (0.0, None)


@pytest.mark.parametrize("directory", SHIPPED, ids=lambda p: p.name)
def test_shipped_recordings_load_as_before(directory):
    """No shipped recording states a set-up key, so each loads without a warning, carries none,
    and reads as the set-up of its nominal values (nothing stated, every tolerance 0)."""
    rec = quietly_loaded(directory)
    assert rec.setup_keys == {}
    n = len(rec.sensors)
    assert rec.setup == SetUp(sensor_masses=(None,) * n, location_tolerances=(0.0,) * n,
                              high_pass_corners=(None,) * n, gain_tolerances=(None,) * n)


def test_the_shipped_list_holds_the_examples_and_the_real_record():
    names = {p.name for p in SHIPPED}
    assert {"paper_q3_hammer", "alu_q1_release", "paper_rootcomp_hammer", "recording"} <= names


def test_check_prints_the_stated_setup_and_refuses_a_bad_value(tmp_path, capsys):
    """``bayesbeam check`` validates what a fit would: it shows the stated set-up and exits 2 with
    the key's message where the fit's priors would refuse it."""
    from bayesbeam.cli import main

    assert main(["check", str(make(tmp_path)), "--out", str(tmp_path / "out")]) == 0
    printed = capsys.readouterr().out
    assert "own mass 0.006 kg, position +- 0.004 m" in printed
    assert "stated tolerances: length +- 0.005 m, m_T +- 0.002 kg, J +- 1e-07 kg m^2" in printed
    bad = tmp_path / "bad"
    bad.mkdir()
    (bad / "beam.toml").write_text(STATED.replace("mass = 0.006", "mass = -0.006", 1), encoding="utf-8")
    (bad / "recording.csv").write_text(CSV, encoding="utf-8")
    assert main(["check", str(bad), "--out", str(tmp_path / "out_bad")]) == 2
    assert "[[sensor]] #1 .mass" in capsys.readouterr().err


# ---------------------------------------------------------------------------- the hammer's location tolerance
FORCE = STATED.replace('kind = "free_decay"\nstart = 0.01',
                       'kind = "force"\nlocation = 0.5\ncolumn = "force"\nlocation_tolerance = 0.003')
FORCE_CSV = "time,accel_tip,accel_mid,force\n" + "".join(
    f"{k / 1024!r},{float(np.sin(k / 7.0))!r},{float(np.cos(k / 5.0))!r},{float(k == 3)!r}\n"
    for k in range(MIN_SAMPLES + 8))


def make_force(tmp_path: Path, toml: str = FORCE) -> Path:
    directory = make(tmp_path, toml)
    (directory / "recording.csv").write_text(FORCE_CSV, encoding="utf-8")
    return directory


def test_the_hammers_tolerance_is_read_kept_and_written_back(tmp_path):
    """[excitation] location_tolerance of a force recording: read without a warning, exposed with the
    hammer's stated location, written back by write_recording."""
    rec = quietly_loaded(make_force(tmp_path))
    assert rec.setup.excitation_location_tolerance == 0.003 and rec.setup.hammer_location == 0.5
    back = quietly_loaded(write_recording(rec, tmp_path / "copy"))
    assert back.setup == rec.setup and back.setup_keys == rec.setup_keys


@pytest.mark.parametrize("value", ["-0.003", "nan", '"3 mm"'])
def test_a_bad_hammer_tolerance_is_refused_when_read(tmp_path, value):
    rec = quietly_loaded(make_force(tmp_path, FORCE.replace("location_tolerance = 0.003", f"location_tolerance = {value}")))
    with pytest.raises(RecordingError, match=r"\[excitation\] \.location_tolerance.*Fix:"):
        _ = rec.setup


def test_a_hammer_tolerance_beside_a_sensor_named_hammer_with_one_is_refused(tmp_path):
    """Both offsets would be called dx_hammer: the sensor's name is refused, with the fix."""
    rec = quietly_loaded(make_force(tmp_path, FORCE.replace('name = "tip"', 'name = "hammer"')))
    with pytest.raises(RecordingError, match=r"\[\[sensor\]\] #1 \.name.*dx_hammer.*Fix: rename the sensor"):
        _ = rec.setup


def test_without_a_hammer_the_key_is_unused(tmp_path):
    """A free decay has no hammer: the key warns as unused at load and reads as 0."""
    toml = STATED.replace("start = 0.01", "start = 0.01\nlocation_tolerance = 0.003")
    with pytest.warns(UserWarning, match="location_tolerance"):
        rec = load_recording(make(tmp_path, toml))
    assert rec.setup.excitation_location_tolerance == 0.0


def test_check_shows_the_hammers_tolerance(tmp_path, capsys):
    from bayesbeam.cli import main

    assert main(["check", str(make_force(tmp_path)), "--out", str(tmp_path / "out")]) == 0
    assert "hammer location +- 0.003 m" in capsys.readouterr().out


def test_the_measurement_chain_keys_are_read_kept_and_written_back(tmp_path):
    """[[sensor]] high_pass_hz (Hz) and gain_tolerance (a fraction): read per sensor, None where not
    stated, loaded without a warning and written back as stated."""
    toml = STATED.replace("location_tolerance = 0.004", "location_tolerance = 0.004\nhigh_pass_hz = 0.5\n"
                          "gain_tolerance = 0.03", 1)
    rec = quietly_loaded(make(tmp_path, toml))
    assert rec.setup.high_pass_corners == (0.5, None) and rec.setup.gain_tolerances == (0.03, None)
    back = quietly_loaded(write_recording(rec, tmp_path / "copy"))
    assert back.setup == rec.setup and back.setup_keys == rec.setup_keys


@pytest.mark.parametrize("key", ["high_pass_hz", "gain_tolerance"])
@pytest.mark.parametrize("value", ["0.0", "-0.5", '"0.5 Hz"', "inf"])
def test_a_bad_measurement_chain_value_is_refused_when_read(tmp_path, key, value):
    """0 is refused too (a DC-coupled sensor leaves high_pass_hz out; a gain known exactly states
    no tolerance): the message names the sensor's key and the fix."""
    toml = STATED.replace("location_tolerance = 0.004", f"location_tolerance = 0.004\n{key} = {value}", 1)
    rec = quietly_loaded(make(tmp_path, toml))
    with pytest.raises(RecordingError) as info:
        _ = rec.setup
    assert info.value.where == f"[[sensor]] #1 .{key}" and "Fix:" in str(info.value) and info.value.fix
