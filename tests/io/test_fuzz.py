"""Property-based fuzz of the recording reader on the shipped hammer example.

Any mutation of ``beam.toml`` or ``recording.csv`` must give either a :class:`Recording` or a
:class:`RecordingError` (never another exception), and every recording the reader accepts must
simulate to finite values. The example is cut to its first ROWS samples (the impact lies at
sample 62) and simulated at N = 4, so one example costs milliseconds; hypothesis runs a fixed,
derandomised set of 400 examples per file, so the test is repeatable and bounded (about 10 s).
"""
import math
import warnings
from pathlib import Path

import numpy as np
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st

from bayesbeam.io import Recording, RecordingError, load_recording
from bayesbeam.model import BeamModel

EXAMPLE = Path(__file__).resolve().parents[2] / "data" / "examples" / "paper_q3_hammer"
ROWS = 400
TOML = (EXAMPLE / "beam.toml").read_text(encoding="utf-8")
CSV_LINES = (EXAMPLE / "recording.csv").read_text(encoding="utf-8").splitlines()[: ROWS + 1]
#: q1 at the paper's damping (gamma in N s/m^2, cdI in N m^2 s); EI is the recording's nominal one
DAMPING = {"gamma": 0.2, "cdI": 2e-4}

numbers = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True),
    st.sampled_from([0.0, -0.0, 1e308, -1e308, 1e-308, 5e-324, 1e200, 1e-200, 1e154, 1e16]),
    st.integers(min_value=-(10**30), max_value=10**30),
)
number_text = numbers.map(repr) | st.sampled_from(["nan", "inf", "-inf", "1e999", "0x10", "1,5", ""])
junk = st.text(alphabet=st.characters(codec="utf-8", exclude_categories=("Cs",)), max_size=8)


toml_values = st.one_of(
    number_text, junk.map(lambda s: '"' + s.replace('"', "") + '"'),
    st.sampled_from(["true", '"force"', '"release"', '"free_decay"', '"velocity"', "[1, 2]", "{}",
                     '"accel_tip"', '"time"']))
toml_lines = st.sampled_from(["[tip]", "mass = 0.1", "rotary_inertia = -1", "[[sensor]]", "start = 0.01",
                              "tip_load = 1e308", "[recording]", "x = 1"])
#: a mutation is a small tuple (action, where, payload), applied by mutate_toml / mutate_csv, so a
#: failing example prints in a line
toml_mutations = st.one_of(
    st.tuples(st.just("value"), st.integers(0, 200), toml_values),
    st.tuples(st.just("delete"), st.integers(0, 200), st.none()),
    st.tuples(st.just("insert"), st.integers(0, 200), toml_lines),
    st.tuples(st.just("char"), st.tuples(st.integers(0, 200), st.integers(0, 80)), junk),
)
csv_mutations = st.one_of(
    st.tuples(st.just("cell"), st.tuples(st.integers(0, ROWS), st.integers(0, 2)), number_text | junk),
    st.tuples(st.just("column"), st.integers(0, 2), numbers),     # a channel scaled by any factor
    st.tuples(st.just("delete"), st.integers(0, ROWS), st.none()),
    st.tuples(st.just("truncate"), st.integers(0, ROWS + 1), st.none()),
    st.tuples(st.just("delimiter"), st.none(), st.sampled_from([";", "\t", " ", "|"])),
    st.tuples(st.just("char"), st.tuples(st.integers(0, ROWS), st.integers(0, 40)), junk),
)


def mutate_toml(action, where, payload) -> str:
    lines = TOML.splitlines()
    if action == "char":
        i, j = where[0] % len(lines), where[1]
        lines[i] = lines[i][:j] + payload + lines[i][j + 1:]
    else:
        i = where % len(lines)
        if action == "value":
            lines[i] = lines[i].split("=", 1)[0] + "= " + payload if "=" in lines[i] else payload
        elif action == "delete":
            del lines[i]
        else:
            lines.insert(i, payload)
    return "\n".join(lines) + "\n"


def mutate_lines(lines: list[str], action, where, payload, delimiter: str = ",") -> str:
    """The file of ``lines`` (cells separated by ``delimiter``) with one mutation applied."""
    lines = list(lines)
    if action == "cell":
        i, j = where
        cells = lines[i].split(delimiter)
        cells[j % len(cells)] = payload
        lines[i] = delimiter.join(cells)
    elif action == "column":
        lines[1:] = [_scaled(line, where, payload) for line in lines[1:]]
    elif action == "insert":
        lines.insert(where, payload)
    elif action == "delete":
        del lines[where]
    elif action == "truncate":
        lines = lines[:where]
    elif action == "delimiter":
        lines = [line.replace(delimiter, payload) for line in lines]
    elif action == "decimal":
        lines = [line.replace(".", payload) for line in lines]
    else:
        i, j = where
        lines[i] = lines[i][:j] + payload + lines[i][j + 1:]
    return "\n".join(lines) + "\n"


def mutate_csv(action, where, payload) -> str:
    return mutate_lines(CSV_LINES, action, where, payload)


def _scaled(line: str, j: int, factor) -> str:
    cells = line.split(",")
    try:
        cells[j] = repr(float(cells[j]) * factor)
    except (OverflowError, ValueError):
        cells[j] = "inf"
    return ",".join(cells)


def loaded(directory: Path) -> Recording | None:
    """The recording in ``directory``, or None when it is refused (a RecordingError, counted as a
    hypothesis event); any other exception fails the test."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")          # unused-key and unknown-unit warnings are part of the contract
        try:
            rec = load_recording(directory)
        except RecordingError as err:
            event(f"refused at {err.where.split(',')[0]}")
            return None
    event("accepted")
    assert isinstance(rec, Recording)
    return rec


def check(tmp_path: Path, toml: str, csv: str) -> None:
    directory = tmp_path / "rec"
    directory.mkdir(exist_ok=True)
    (directory / "beam.toml").write_text(toml, encoding="utf-8")
    (directory / "recording.csv").write_text(csv, encoding="utf-8")
    rec = loaded(directory)
    if rec is None:
        return
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model = BeamModel.from_recording(rec, "q1", 4)
        params = {"EI": rec.beam.nominal_EI, **DAMPING}
        initial = model.fit_initial(params) if rec.excitation.kind == "free_decay" else None
        y = model.simulate(params, initial)
    assert np.all(np.isfinite(y)), "an accepted recording simulates to non-finite values"
    assert math.isfinite(float(np.sum(y.astype(float) ** 2)))


FUZZ = settings(max_examples=400, deadline=None, derandomize=True, database=None,
                suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])


@FUZZ
@given(mutation=toml_mutations)
def test_any_mutation_of_beam_toml_loads_or_is_refused(tmp_path, mutation):
    check(tmp_path, mutate_toml(*mutation), "\n".join(CSV_LINES) + "\n")


@FUZZ
@given(mutation=csv_mutations)
def test_any_mutation_of_recording_csv_loads_or_is_refused(tmp_path, mutation):
    check(tmp_path, TOML, mutate_csv(*mutation))
