"""NI TDMS reader: files written by npTDMS's own TdmsWriter read back; groups; time; refusals."""
import numpy as np
import pytest
from nptdms import ChannelObject, GroupObject, RootObject, TdmsWriter

from bayesbeam.io import RecordingError
from bayesbeam.io.tdms import read_tdms

RNG = np.random.default_rng(5)
ACCEL = RNG.standard_normal(300)
FORCE = RNG.standard_normal(300) * 50
STEP = 1 / 2048  # s


def waveform(group, name, values, unit, step=STEP, start=0.0):
    properties = {"wf_increment": step, "wf_start_offset": start, "unit_string": unit}
    return ChannelObject(group, name, values, properties=properties)


def write_tdms(path, *objects, root=None):
    with TdmsWriter(path) as writer:
        writer.write_segment([RootObject(properties=root or {"name": "hammer test"}), *objects])
    return path


def test_a_group_of_waveforms_reads_back(tmp_path):
    path = write_tdms(tmp_path / "t.tdms", GroupObject("Log", properties={"operator": "me"}),
                      waveform("Log", "Force", FORCE, "N"), waveform("Log", "Accel tip", ACCEL, "g", start=0.25),
                      ChannelObject("Log", "Comment", np.array(["a", "b"])))
    table = read_tdms(path)
    assert [(c.name, c.unit) for c in table.channels] == [("Force", "N"), ("Accel tip", "g")]  # text skipped
    # TDMS stores the float64 samples themselves: exact
    np.testing.assert_array_equal(table.channels[0].values, FORCE)
    np.testing.assert_array_equal(table.channels[1].values, ACCEL)
    assert table.sample_rate == 2048.0
    # the first signal's wf_start_offset + k wf_increment, each a single rounding: within 1 ulp of 0.4 s
    np.testing.assert_allclose(table.time, 0.0 + STEP * np.arange(300), rtol=0, atol=1e-16)
    assert (table.metadata["group"], table.metadata["operator"], table.metadata["name"]) == ("Log", "me",
                                                                                          "hammer test")


def test_group_chooses_and_the_default_is_the_first_with_numbers(tmp_path):
    path = write_tdms(tmp_path / "t.tdms", GroupObject("Notes"), ChannelObject("Notes", "text", np.array(["x"])),
                      GroupObject("A"), waveform("A", "a", ACCEL, "g"),
                      GroupObject("B"), waveform("B", "b", FORCE, "N"))
    assert read_tdms(path).channels[0].name == "a"
    assert read_tdms(path, group="B").channels[0].name == "b"
    with pytest.raises(RecordingError) as caught:
        read_tdms(path, group="C")
    assert caught.value.where == "group 'C'" and "'Notes', 'A', 'B'" in caught.value.problem


def test_a_time_channel_is_the_time(tmp_path):
    time = 10.0 + STEP * np.arange(300)
    path = write_tdms(tmp_path / "t.tdms", GroupObject("G"), ChannelObject("G", "Time", time),
                      ChannelObject("G", "x", ACCEL, properties={"unit_string": "m/s^2"}))
    table = read_tdms(path)
    assert [c.name for c in table.channels] == ["x"] and table.sample_rate is None
    np.testing.assert_array_equal(table.time, time)  # the stored float64 values


def test_channels_of_unequal_length_are_refused(tmp_path):
    path = write_tdms(tmp_path / "t.tdms", GroupObject("G"), waveform("G", "a", ACCEL, "g"),
                      waveform("G", "b", FORCE[:-1], "N"))
    with pytest.raises(RecordingError) as caught:
        read_tdms(path)
    assert caught.value.where == 'channel "b"' and "299 samples" in caught.value.problem


def test_different_rates_are_refused(tmp_path):
    path = write_tdms(tmp_path / "t.tdms", GroupObject("G"), waveform("G", "a", ACCEL, "g"),
                      waveform("G", "b", FORCE, "N", step=2 * STEP))
    with pytest.raises(RecordingError, match="different wf_increment"):
        read_tdms(path)


@pytest.mark.parametrize("content", [b"", b"TDSm" + bytes(40), b"not a tdms file at all"])
def test_an_unreadable_file_is_refused(tmp_path, content):
    path = tmp_path / "t.tdms"
    path.write_bytes(content)
    with pytest.raises(RecordingError) as caught:
        read_tdms(path)
    assert caught.value.where == "file"
