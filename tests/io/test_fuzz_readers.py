"""Property-based fuzz of the DAQ-file readers and the import behind them.

Any mutation of a LabVIEW Measurement text, of a MATLAB workspace (and a saved .mat file cut
short), or of a TDMS file's channel data (and its bytes) must give a ChannelTable or a RecordingError, never
another exception; every table accepted must import (``write_import``) to a recording folder or
be refused with a RecordingError. Hypothesis runs a fixed, derandomised set of examples per
reader, so the test is repeatable and bounded (about 15 s in all).
"""
import warnings

import numpy as np
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st
from nptdms import ChannelObject, GroupObject, RootObject, TdmsWriter
from scipy.io import savemat

from bayesbeam.io import RecordingError
from bayesbeam.io.importer import read_channels, write_import
from bayesbeam.io.table import ChannelTable

LVM_LINES = [
    "LabVIEW Measurement\t", "Writer_Version\t2", "Reader_Version\t2", "Separator\tTab", "Decimal_Separator\t.",
    "Multi_Headings\tYes", "X_Columns\tOne", "Time_Pref\tRelative", "Operator\tme", "***End_of_Header***\t", "",
    "Channels\t2\t", "Samples\t6\t6\t", "Y_Unit_Label\tg\tN\t", "X_Dimension\tTime\tTime\t", "X0\t0.0\t0.0\t",
    "Delta_X\t0.001\t0.001\t", "***End_of_Header***\t", "X_Value\tAccel\tForce\tComment",
    *[f"{k * 0.001!r}\t{np.sin(k):.6f}\t{np.cos(k):.4f}" for k in range(6)],
]
numbers = st.one_of(st.floats(allow_nan=True, allow_infinity=True), st.integers(-(10**20), 10**20),
                    st.sampled_from([0.0, -0.0, 1e308, 5e-324]))
junk = st.text(alphabet=st.characters(codec="utf-8", exclude_categories=("Cs",)), max_size=8)
cell_text = numbers.map(repr) | junk | st.sampled_from(["", "***End_of_Header***", "Channels", "X_Value", "1,5",
                                                        "Comma", "Multi", "No", "\t", "nan"])
lvm_mutations = st.one_of(
    st.tuples(st.just("cell"), st.tuples(st.integers(0, 40), st.integers(0, 4)), cell_text),
    st.tuples(st.just("delete"), st.integers(0, 40), st.none()),
    st.tuples(st.just("insert"), st.integers(0, 40), st.sampled_from(LVM_LINES)),
    st.tuples(st.just("truncate"), st.integers(0, 40), st.none()),
    st.tuples(st.just("char"), st.tuples(st.integers(0, 40), st.integers(0, 30)), junk),
)
series = st.one_of(st.integers(0, 12).map(lambda n: np.sin(np.arange(n, dtype=float))),
                   st.lists(numbers.map(float), min_size=0, max_size=8).map(lambda v: np.array(v, dtype=float)))
vectors = st.one_of(
    series,
    st.integers(1, 4).map(lambda k: np.arange(8 * k, dtype=float).reshape(8, k)),
    st.sampled_from([np.zeros((0, 3)), np.ones((2, 2, 2)), np.array([1 + 2j, 3]), np.array([True, False])]),
)
mat_values = st.one_of(vectors, numbers.map(float), junk, st.dictionaries(st.sampled_from(["a", "t", "units"]),
                                                                          vectors | junk, max_size=3))
workspaces = st.dictionaries(st.sampled_from(["t", "time", "fs", "dt", "acc", "acc_unit", "units", "X", "data",
                                              "force"]), mat_values, max_size=6)
tdms_channels = st.lists(st.tuples(
    st.sampled_from(["Time", "a", "b", "force"]),
    st.one_of(series,
              st.just(np.array(["x", "y"])), st.just(np.arange(5, dtype=np.int32))),
    st.fixed_dictionaries({}, optional={"wf_increment": numbers.map(float), "unit_string": junk,
                                        "wf_start_offset": numbers.map(float)}),
), min_size=0, max_size=3)


def rarely(strategy):
    """``strategy`` in about one example of four, else None: most examples reach the reader's own checks."""
    return st.one_of(st.none(), st.none(), st.none(), strategy)


def mutate_lvm(action, where, payload) -> str:
    lines = list(LVM_LINES)
    if action == "cell":
        i, j = where[0] % len(lines), where[1]
        cells = lines[i].split("\t")
        cells[j % len(cells)] = payload
        lines[i] = "\t".join(cells)
    elif action == "delete":
        del lines[where % len(lines)]
    elif action == "insert":
        lines.insert(where % len(lines), payload)
    elif action == "truncate":
        lines = lines[: where % len(lines)]
    else:
        i, j = where[0] % len(lines), where[1]
        lines[i] = lines[i][:j] + payload + lines[i][j + 1:]
    return "\n".join(lines) + "\n"


def reads_or_is_refused(path, out) -> None:
    """read_channels gives a ChannelTable (which imports or is refused) or a RecordingError."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # e.g. scipy's on odd workspaces
        try:
            table = read_channels(path)
        except RecordingError as err:
            event(f"refused at {err.where.split(',')[0][:20]}")
            return
        assert isinstance(table, ChannelTable)
        try:
            write_import(table, out, overwrite=True)
            event("imported")
        except RecordingError:
            event("import refused")


def damage(path, cut, flip) -> None:
    """Invert the bits of byte ``flip`` and cut the file after ``cut`` bytes (None: leave be)."""
    data = bytearray(path.read_bytes())
    if flip is not None and data:
        data[flip % len(data)] ^= 0xFF
    path.write_bytes(bytes(data[:cut] if cut is not None else data))


FUZZ = settings(max_examples=300, deadline=None, derandomize=True, database=None,
                suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])


@FUZZ
@given(mutation=lvm_mutations)
def test_any_mutation_of_an_lvm_text_reads_or_is_refused(tmp_path, mutation):
    (tmp_path / "f.lvm").write_text(mutate_lvm(*mutation), encoding="utf-8")
    reads_or_is_refused(tmp_path / "f.lvm", tmp_path / "rec")


@FUZZ
@given(workspace=workspaces, cut=rarely(st.integers(0, 400)))
def test_any_mat_workspace_or_cut_mat_file_reads_or_is_refused(tmp_path, workspace, cut):
    """Cut, not bit-flipped: scipy's v5 reader (scipy 1.17) crashes the interpreter on some flipped
    bytes (a segmentation fault in read_var_array), which no Python reader can turn into an error."""
    path = tmp_path / "f.mat"
    try:
        savemat(path, workspace)
    except (ValueError, TypeError):  # scipy cannot write this workspace: nothing to read
        event("not writable")
        return
    damage(path, cut, None)
    reads_or_is_refused(path, tmp_path / "rec")


@FUZZ
@given(channels=tdms_channels, cut=rarely(st.integers(0, 2000)), flip=rarely(st.integers(0, 2000)))
def test_any_tdms_channel_data_reads_or_is_refused(tmp_path, channels, cut, flip):
    path = tmp_path / "f.tdms"
    objects = [ChannelObject("G", f"{name} {k}" if k else name, values, properties=props)
               for k, (name, values, props) in enumerate(channels)]
    with TdmsWriter(path) as writer:
        writer.write_segment([RootObject(), GroupObject("G"), *objects])
    damage(path, cut, flip)
    reads_or_is_refused(path, tmp_path / "rec")
