"""Property-based fuzz of the text-export reader and of load_recording through it.

The shipped hammer example, cut to its first ROWS samples, is written as a DAQ exports it
(metadata lines, tabs, units in the header, the acceleration in g, 9-decimal time); any mutation
of that file, or of the [recording] keys that say how to read it, must give a ChannelTable or
Recording, or a RecordingError: never another exception. An accepted recording must hold
finite SI arrays and a strictly increasing time. Hypothesis runs a fixed, derandomised set of
300 examples per test, so the test is repeatable and bounded (a few seconds).
"""
from pathlib import Path

import numpy as np
from hypothesis import event, given, settings
from hypothesis import strategies as st

from bayesbeam.io import RecordingError, read_text_export
from bayesbeam.io.table import ChannelTable
from tests.io.test_fuzz import FUZZ as FUZZ_CSV
from tests.io.test_fuzz import loaded, mutate_lines

EXAMPLE = Path(__file__).resolve().parents[2] / "data" / "examples" / "paper_q3_hammer"
ROWS = 300
G = 9.80665  # m/s^2


def _export_lines() -> list[str]:
    rows = (EXAMPLE / "recording.csv").read_text(encoding="utf-8").splitlines()[1: ROWS + 1]
    lines = ["# Exported 2026-11-20 14:03:11", "# Sample rate: 2048 Hz", "Time (s)\tHammer (N)\tAccel tip (g)"]
    for row in rows:
        t, f, a = map(float, row.split(","))
        lines.append(f"{t:.9f}\t{f:.6e}\t{a / G:.6e}")
    return lines


LINES = _export_lines()
TOML = ((EXAMPLE / "beam.toml").read_text(encoding="utf-8")
        .replace('column = "force"', 'column = "Hammer"').replace('column = "accel_tip"', 'column = "Accel tip"')
        .replace('file = "recording.csv"\ntime_column = "time"', 'file = "export.txt"\n{keys}'))

junk = st.text(alphabet=st.characters(codec="utf-8", exclude_categories=("Cs",)), max_size=8)
cells = st.one_of(junk, st.sampled_from(["nan", "inf", "1e308", "", "0,5", "1.2.3", "-0", "1e-320", "(g)", "#", "0e400", "1e99999"]),
                  st.floats().map(repr))
inserted = st.sampled_from(["# note", "% fs = 4096", "fs = 0", "dt = -1", "Sample rate: 1e400 Hz", "", "   ",
                            "a\tb\tc", "1\t2\t3", "Time (s)\tHammer (N)\tAccel tip (g)", "s\tN\tg", "//", ";",
                            "1\t2", "x = ", "Time [ms]\tHammer [kN]\tAccel tip [V]"])
mutations = st.one_of(
    st.tuples(st.just("cell"), st.tuples(st.integers(0, ROWS + 2), st.integers(0, 2)), cells),
    st.tuples(st.just("insert"), st.integers(0, ROWS + 3), inserted),
    st.tuples(st.just("delete"), st.integers(0, ROWS + 2), st.none()),
    st.tuples(st.just("truncate"), st.integers(0, ROWS + 3), st.none()),
    st.tuples(st.just("delimiter"), st.none(), st.sampled_from([";", ",", " ", "  ", "|", "\t\t"])),
    st.tuples(st.just("decimal"), st.none(), st.sampled_from([",", ";"])),
    st.tuples(st.just("char"), st.tuples(st.integers(0, ROWS + 2), st.integers(0, 40)), junk),
)
recording_keys = st.one_of(st.just([]), st.lists(st.sampled_from([
    'delimiter = "\\t"', 'delimiter = ";"', 'delimiter = ","', 'delimiter = " "', 'delimiter = "x"',
    'decimal = ","', 'decimal = "."', 'sample_rate = 2048', 'sample_rate = 4096', "sample_rate = 0",
    "sample_rate = 1e300", "skip_lines = 2", "skip_lines = 400", "skip_lines = -1", 'time_column = "Time"',
    'time_column = "t"']), max_size=2, unique_by=lambda key: key.split("=")[0]))
units = st.one_of(st.just(""), st.just('unit = "g"'), st.sampled_from(
    ['unit = "m/s^2"', 'unit = "mm"', "sensitivity = 0.01", "scale = 0", 'unit = "g"\nsensitivity = 0.01']))


def mutate(action, where, payload) -> str:
    return mutate_lines(LINES, action, where, payload, "\t")


def write(tmp_path: Path, export: str, keys: list[str], unit: str) -> Path:
    directory = tmp_path / "rec"
    directory.mkdir(exist_ok=True)
    (directory / "export.txt").write_text(export, encoding="utf-8")
    toml = TOML.format(keys="\n".join(keys)).replace('column = "Accel tip"', f'column = "Accel tip"\n{unit}')
    (directory / "beam.toml").write_text(toml, encoding="utf-8")
    return directory


FUZZ = settings(FUZZ_CSV, max_examples=300)


@FUZZ
@given(mutation=mutations)
def test_any_mutated_export_reads_or_is_refused(tmp_path, mutation):
    path = write(tmp_path, mutate(*mutation), [], "") / "export.txt"
    try:
        table = read_text_export(path)
    except RecordingError as err:
        event(f"refused at {err.where.split(',')[0].split(' ')[0]}")
        return
    event("read")
    assert isinstance(table, ChannelTable) and table.channels
    assert all(np.all(np.isfinite(c.values)) for c in table.channels)


@FUZZ
@given(mutation=mutations, keys=recording_keys, unit=units)
def test_any_mutated_export_loads_or_is_refused(tmp_path, mutation, keys, unit):
    rec = loaded(write(tmp_path, mutate(*mutation), keys, unit))
    if rec is None:
        return
    assert np.all(np.isfinite(rec.signals)) and np.all(np.isfinite(rec.force)) and np.all(np.diff(rec.time) > 0)
