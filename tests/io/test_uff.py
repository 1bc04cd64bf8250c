"""UFF: recording -> dataset 58 -> recording round trips, units, directions, nodes, refusals."""

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
import pyuff

from bayesbeam.io import (
    Excitation,
    RecordingError,
    load_recording,
    read_uff58,
    write_recording,
    write_uff58,
    write_uff_modes,
)
from bayesbeam.io.uff import _dataset58, _sample_step

EXAMPLES = Path(__file__).resolve().parents[2] / "data" / "examples"
HAMMER, RELEASE = EXAMPLES / "paper_q3_hammer", EXAMPLES / "alu_q1_release"
BEAM = """\
[beam]
length = 1.0
density = 1710.0
area = 0.000597
second_moment = 1.64e-09
modulus = 2.68e10
"""
STEP = 1 / 1024  # s
N = 64


def full_precision(rec, seed=0):
    """``rec`` with signals (and force) that need all 17 digits to print exactly."""
    rng = np.random.default_rng(seed)
    force = None if rec.force is None else rng.standard_normal(rec.n_samples) * np.pi
    return replace(rec, signals=rng.standard_normal(rec.signals.shape) * np.e, force=force)


@pytest.mark.parametrize("example", [HAMMER, RELEASE])
def test_binary_round_trip_is_exact(tmp_path, example):
    rec = full_precision(load_recording(example))
    back = read_uff58(write_uff58(rec, tmp_path / "r.uff", binary=True), example / "beam.toml")
    # 58b stores the float64 samples themselves; the sampling rates (2048, 4096 Hz) are
    # recovered exactly from the 6-digit step; ``==`` compares every array bit for bit and
    # the beam, tip, excitation, sensors and [notes].
    assert back == rec


def test_ascii_round_trip_keeps_twelve_digits(tmp_path):
    rec = full_precision(load_recording(HAMMER))
    back = read_uff58(write_uff58(rec, tmp_path / "r.uff"), HAMMER / "beam.toml")
    # ASCII dataset 58 prints E20.11: 12 significant digits, relative rounding <= 5e-12.
    np.testing.assert_allclose(back.signals, rec.signals, rtol=5e-12, atol=0)
    np.testing.assert_allclose(back.force, rec.force, rtol=5e-12, atol=0)
    np.testing.assert_array_equal(back.time, rec.time)
    assert (back.beam, back.tip, back.excitation, back.sensors, back.extra) == (
        rec.beam, rec.tip, rec.excitation, rec.sensors, rec.extra)


@pytest.mark.parametrize("example", [HAMMER, RELEASE])
def test_shipped_examples_round_trip_exactly_in_ascii(tmp_path, example):
    rec = load_recording(example)  # their CSVs print 9 digits, within the 12 of E20.11
    assert read_uff58(write_uff58(rec, tmp_path / "r.uff"), example / "beam.toml") == rec


def test_free_decay_round_trip_takes_the_start_from_beam_toml(tmp_path):
    rec = load_recording(HAMMER)
    rec = replace(rec, excitation=Excitation("free_decay", start=1.0), force=None, extra={})
    described = write_recording(rec, tmp_path / "fd")
    assert read_uff58(write_uff58(rec, tmp_path / "r.uff"), described / "beam.toml") == rec


def test_written_file_holds_what_modal_software_reads(tmp_path):
    rec = load_recording(HAMMER)  # force at 0.75 m, accelerometer at 1.0 m
    sets = pyuff.UFF(str(write_uff58(rec, tmp_path / "r.uff"))).read_sets()
    assert [s["type"] for s in sets] == [164, 2411, 58, 58]
    assert sets[0]["units_code"] == 1  # SI
    np.testing.assert_array_equal(sets[1]["node_nums"], [1, 2])
    np.testing.assert_array_equal(sets[1]["x"], [0.75, 1.0])
    force, accel = sets[2], sets[3]
    assert (force["id1"], force["ordinate_spec_data_type"], force["ordinate_axis_units_lab"]) == ("force", 13, "N")
    assert (accel["id1"], accel["ordinate_spec_data_type"], accel["ordinate_axis_units_lab"]) == (
        "accel_tip", 12, "m/s^2")
    assert (accel["func_type"], accel["rsp_node"], accel["rsp_dir"], accel["ref_node"]) == (1, 2, 3, 1)
    assert accel["abscissa_inc"] == pytest.approx(rec.dt, rel=1e-5)  # printed with 6 digits


@pytest.mark.parametrize("rate", [1024, 2048, 4096, 5000, 12800, 25600, 51200, 44100, 1651])
def test_sampling_rate_is_recovered_from_the_printed_step(rate):
    printed = float(f"{1 / rate:.5e}")  # what E13.5 keeps
    assert _sample_step(printed) == 1 / rate


def test_an_unround_step_is_kept_as_printed():
    assert _sample_step(4.12345e-4) == 4.12345e-4


# --------------------------------------------------------------------------- crafted files


def channel(name, quantity, node, data, **fields):
    """A dataset-58 dict as pyuff writes it; ``fields`` override any key."""
    dset = _dataset58(name, quantity, node, 0, STEP * np.arange(len(data)), np.asarray(data, float), False)
    return {**dset, **fields}


def nodes(*xs):
    return {"type": 2411, "node_nums": list(range(1, len(xs) + 1)), "def_cs": [0] * len(xs),
            "disp_cs": [0] * len(xs), "color": [8] * len(xs), "x": list(xs), "y": [0.0] * len(xs),
            "z": [0.0] * len(xs)}


def make(tmp_path, *sets, toml=BEAM + '[excitation]\nkind = "release"\ntip_load = 0.5\n'):
    path = tmp_path / "test.uff"
    pyuff.UFF(str(path)).write_sets(list(sets), mode="overwrite")
    beam = tmp_path / "beam.toml"
    beam.write_text(toml)
    return path, beam


RAMP = np.linspace(-1.0, 1.0, N)


def test_units_labels_directions_and_dataset_164(tmp_path):
    units_mm = {"type": 164, "units_code": 5, "units_description": "mm", "temp_mode": 1,
                "length": 1000.0, "force": 1000.0, "temp": 1.0, "temp_offset": 273.15}
    path, beam = make(
        tmp_path, units_mm, nodes(0.5, 1.0),
        channel("a_g", "acceleration", 2, RAMP, ordinate_axis_units_lab="g"),
        channel("d_mm", "displacement", 1, RAMP, ordinate_axis_units_lab="mm", rsp_dir=-3),
        channel("a_164", "acceleration", 2, RAMP, ordinate_axis_units_lab="NONE"),
        channel("v_label", "velocity", 1, RAMP, ordinate_spec_data_type=0, ordinate_axis_units_lab="m/s"),
    )
    rec = read_uff58(path, beam)
    assert [s.quantity for s in rec.sensors] == ["acceleration", "displacement", "acceleration", "velocity"]
    assert [s.location for s in rec.sensors] == [1.0, 0.5, 1.0, 0.5]
    expected = np.column_stack([9.80665 * RAMP, -1e-3 * RAMP, 1e-3 * RAMP, RAMP])
    np.testing.assert_allclose(rec.signals, expected, rtol=1e-11)  # E20.11 printing
    assert rec.excitation == Excitation("release", tip_load=0.5)
    assert rec.dt == STEP


def test_nodes_table_in_beam_toml_overrides_the_file(tmp_path):
    path, beam = make(tmp_path, nodes(0.5), channel("v", "velocity", 1, RAMP),
                      toml=BEAM + '[excitation]\nkind = "release"\ntip_load = 0.5\n[nodes]\n1 = 0.25\n')
    assert read_uff58(path, beam).sensors[0].location == 0.25


def test_frf_datasets_are_skipped_with_a_warning(tmp_path):
    path, beam = make(tmp_path, nodes(1.0), channel("v", "velocity", 1, RAMP),
                      channel("H", "velocity", 1, RAMP, func_type=4))
    with pytest.warns(UserWarning, match=r"datasets \[3\] are not time histories"):
        rec = read_uff58(path, beam)
    assert [s.name for s in rec.sensors] == ["v"]
    path, beam = make(tmp_path, nodes(1.0), channel("H", "velocity", 1, RAMP, func_type=4))
    with pytest.warns(UserWarning), pytest.raises(RecordingError, match="no dataset 58 with function type 1"):
        read_uff58(path, beam)


FORCE_TOML = BEAM + '[excitation]\nkind = "force"\nlocation = 0.9\n'


@pytest.mark.parametrize(
    "sets, toml, where, fragment",
    [
        ([channel("x", "velocity", 1, RAMP, ordinate_axis_units_lab="furlong/s")], None,
         "dataset #2 (58, 'x')", "units label 'furlong/s'"),
        ([channel("x", "velocity", 7, RAMP)], None, "dataset #2 (58, 'x')", "node 7 has no position"),
        ([channel("x", "velocity", 1, RAMP), channel("y", "velocity", 1, RAMP, rsp_dir=2)], None,
         "dataset #3 (58, 'y')", "axis 2"),
        ([channel("x", "velocity", 1, RAMP), channel("y", "velocity", 1, RAMP, rsp_dir=5)], None,
         "dataset #3 (58, 'y')", "not a translation"),
        ([channel("x", "velocity", 1, RAMP), channel("y", "velocity", 1, RAMP[:-1])], None,
         "dataset #3 (58, 'y')", "63 samples"),
        ([channel("x", "velocity", 1, RAMP), channel("x", "velocity", 1, RAMP)], None,
         "dataset #3 (58, 'x')", "used twice"),
        ([channel("f", "force", 1, RAMP), channel("g", "force", 1, RAMP), channel("x", "velocity", 1, RAMP)],
         None, "file", "more than one force channel"),
        ([channel("f", "force", 1, RAMP)], None, "file", "no response channel"),
        ([channel("x", "velocity", 1, RAMP)], BEAM, "[excitation]", "no force channel"),
        ([channel("f", "force", 1, RAMP), channel("x", "velocity", 1, RAMP)], None,
         "[excitation] .kind", "has a force channel"),
        ([channel("f", "force", 1, RAMP), channel("x", "velocity", 1, RAMP)], FORCE_TOML,
         "[excitation] .location", "force node 1 is at 1.0"),
        ([channel("x", "velocity", 1, RAMP)], BEAM + '[excitation]\nkind = "free_decay"\nstart = 5.0\n',
         "[excitation] .start", "outside the record"),
    ],
)
def test_refusals_name_the_dataset_or_key_and_the_fix(tmp_path, sets, toml, where, fragment):
    kwargs = {} if toml is None else {"toml": toml}
    path, beam = make(tmp_path, nodes(1.0), *sets, **kwargs)
    with pytest.raises(RecordingError) as err:
        read_uff58(path, beam)
    assert err.value.where == where and fragment in err.value.problem and err.value.fix


def test_missing_or_unreadable_files_are_refused(tmp_path):
    beam = tmp_path / "beam.toml"
    beam.write_text(BEAM)
    with pytest.raises(RecordingError, match="no such file"):
        read_uff58(tmp_path / "absent.uff", beam)
    garbage = tmp_path / "garbage.uff"
    garbage.write_text("    -1\n    58\nthis is not a dataset\n    -1\n")
    with pytest.raises(RecordingError, match="UFF"):
        read_uff58(garbage, beam)
    with pytest.raises(RecordingError, match=r"\[beam\]"):
        read_uff58(garbage, tmp_path / "absent.toml")


def test_bad_nodes_table_is_refused(tmp_path):
    path, beam = make(tmp_path, nodes(1.0), channel("v", "velocity", 1, RAMP),
                      toml=BEAM + '[excitation]\nkind = "release"\ntip_load = 0.5\n[nodes]\ntip = 1.0\n')
    with pytest.raises(RecordingError) as err:
        read_uff58(path, beam)
    assert err.value.where == "[nodes] .tip" and "node number" in err.value.problem
    beam.write_text(BEAM + '[excitation]\nkind = "release"\ntip_load = 0.5\n[nodes]\n1 = 1.5\n')
    with pytest.raises(RecordingError, match="outside the beam"):
        read_uff58(path, beam)


def test_modes_as_dataset_55(tmp_path):
    shapes = np.array([[1.0 + 0.0j, -0.5 + 0.01j], [0.6 - 0.02j, 1.0 + 0.0j], [0.62 - 0.02j, 0.98 + 0.0j]])
    path = write_uff_modes(tmp_path / "m.uff", [0.5, 1.0, 1.0], [1, 2], [3.6, 23.1], [0.002, 0.001], shapes)
    sets = pyuff.UFF(str(path)).read_sets()
    assert [s["type"] for s in sets] == [164, 2411, 55, 55]
    second = sets[3]
    assert (second["analysis_type"], second["mode_n"]) == (3, 2)
    w, zeta = 2 * np.pi * 23.1, 0.001
    # E13.5: 6 significant digits; two sensors at 1.0 m are averaged into node 2.
    assert second["eig"] == pytest.approx(w * complex(-zeta, np.sqrt(1 - zeta**2)), rel=1e-5)
    np.testing.assert_allclose(second["r3"], [-0.5 + 0.01j, 0.99 + 0.0j], rtol=1e-5)
    np.testing.assert_array_equal(second["r1"], 0)
