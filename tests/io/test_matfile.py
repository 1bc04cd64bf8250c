"""MATLAB .mat reader: v5 files written by scipy.io.savemat and v7.3 (HDF5) files written with h5py in
MATLAB's layout read back to the same channels; time, rate and units by name; refusals."""
import h5py
import numpy as np
import pytest
from scipy.io import savemat

from bayesbeam.io import RecordingError
from bayesbeam.io.matfile import read_mat

RNG = np.random.default_rng(7)
N = 300
TIME = np.arange(N) / 1024.0
ACCEL = RNG.standard_normal(N)
PAIR = RNG.standard_normal((N, 2))  # a MATLAB N x 2 array: two channels
WORKSPACE = {"t": TIME, "acc": ACCEL, "strain": PAIR, "acc_unit": "g", "units": {"strain": "um"},
             "fs": 1024.0, "operator": "tester"}


def write_v73(path, variables):
    """``variables`` as MATLAB 7.3 stores them: an HDF5 file after a 512-byte header, each array
    transposed (MATLAB is column-major), texts as uint16 char arrays, structs as groups."""
    with h5py.File(path, "w", userblock_size=512) as h5:
        for name, value in variables.items():
            _h5_variable(h5, name, value)
    with open(path, "r+b") as stream:
        stream.write(b"MATLAB 7.3 MAT-file, written by the test with h5py. HDF5 schema 1.00 .".ljust(116))
    return path


def _h5_variable(parent, name, value):
    if isinstance(value, dict):
        group = parent.create_group(name)
        group.attrs["MATLAB_class"] = np.bytes_("struct")
        for field, inner in value.items():
            _h5_variable(group, field, inner)
        return
    if isinstance(value, str):
        data, kind = np.array([[ord(c)] for c in value], dtype=np.uint16), "char"
    else:
        data, kind = np.atleast_2d(np.asarray(value, dtype=float)).T, "double"  # a vector as MATLAB's 1 x n
    parent.create_dataset(name, data=data).attrs["MATLAB_class"] = np.bytes_(kind)


def check_workspace(table):
    names = [(c.name, c.unit) for c in table.channels]
    assert names == [("acc", "g"), ("strain_1", "um"), ("strain_2", "um")]
    # both formats store the float64 values themselves: exact
    np.testing.assert_array_equal(table.channels[0].values, ACCEL)
    np.testing.assert_array_equal(np.column_stack([c.values for c in table.channels[1:]]), PAIR)
    np.testing.assert_array_equal(table.time, TIME)
    assert table.sample_rate == 1024.0 and table.metadata["operator"] == "tester"


def test_a_v5_workspace_reads_back(tmp_path):
    savemat(tmp_path / "w.mat", WORKSPACE)
    check_workspace(read_mat(tmp_path / "w.mat"))


def test_a_v73_workspace_reads_back(tmp_path):
    check_workspace(read_mat(write_v73(tmp_path / "w.mat", WORKSPACE)))


@pytest.mark.parametrize("write", ["v5", "v7.3"])
def test_a_struct_of_channels_with_a_step(tmp_path, write):
    workspace = {"data": {"Time": TIME, "force": ACCEL * 10, "force_unit": "kN"}, "dt": 1 / 1024.0}
    path = tmp_path / "s.mat"
    savemat(path, workspace) if write == "v5" else write_v73(path, workspace)
    table = read_mat(path)
    assert [(c.name, c.unit) for c in table.channels] == [("force", "kN")]
    np.testing.assert_array_equal(table.channels[0].values, ACCEL * 10)
    assert table.sample_rate == 1024.0  # 1 / (1/1024): both exact in binary


@pytest.mark.parametrize("write", ["v5", "v7.3"])
def test_a_square_array_gives_its_columns(tmp_path, write):
    """A MATLAB 3 x 3 array is three channels, its columns, in both versions (v7.3 stores it transposed)."""
    workspace = {"t": np.array([0.0, 0.5, 1.0]), "sq": np.arange(9.0).reshape(3, 3)}
    path = tmp_path / "q.mat"
    savemat(path, workspace) if write == "v5" else write_v73(path, workspace)
    np.testing.assert_array_equal(read_mat(path).channels[0].values, [0.0, 3.0, 6.0])


def test_units_as_a_cell_array_in_channel_order(tmp_path):
    savemat(tmp_path / "c.mat", {"a": ACCEL, "b": ACCEL * 2, "units": np.array(["g", "N"], dtype=object)})
    assert [c.unit for c in read_mat(tmp_path / "c.mat").channels] == ["g", "N"]


def test_without_units_a_channel_has_none(tmp_path):
    savemat(tmp_path / "n.mat", {"a": ACCEL})
    table = read_mat(tmp_path / "n.mat")
    assert table.channels[0].unit is None and table.time is None and table.sample_rate is None


def refusal(path) -> RecordingError:
    with pytest.raises(RecordingError) as caught:
        read_mat(path)
    return caught.value


def test_vectors_of_unequal_length_are_refused(tmp_path):
    savemat(tmp_path / "u.mat", {"a": ACCEL, "b": ACCEL[:-3]})
    err = refusal(tmp_path / "u.mat")
    assert err.where == 'channel "b"' and f"{N - 3} samples" in err.problem


def test_an_array_that_fits_no_time_is_refused(tmp_path):
    savemat(tmp_path / "a.mat", {"t": TIME, "block": np.ones((5, 7))})
    assert refusal(tmp_path / "a.mat").where == "variable 'block'"


def test_a_workspace_without_numbers_is_refused(tmp_path):
    savemat(tmp_path / "e.mat", {"note": "nothing here"})
    assert "no channel" in refusal(tmp_path / "e.mat").problem


def test_a_non_positive_rate_is_refused(tmp_path):
    savemat(tmp_path / "r.mat", {"a": ACCEL, "fs": -1.0})
    assert refusal(tmp_path / "r.mat").where == "variable 'fs'"


@pytest.mark.parametrize("content", [b"", b"MATLAB 5.0 MAT-file" + bytes(200), b"\x89HDF\r\n\x1a\n" + bytes(50)])
def test_an_unreadable_file_is_refused(tmp_path, content):
    (tmp_path / "x.mat").write_bytes(content)
    assert refusal(tmp_path / "x.mat").where == "file"
