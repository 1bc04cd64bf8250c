"""LabVIEW Measurement (.lvm) reader: the real ds4 record, hand-written layouts read back, refusals."""
from pathlib import Path

import numpy as np
import pytest

from bayesbeam.io import RecordingError
from bayesbeam.io.lvm import read_lvm

ROOT = Path(__file__).resolve().parents[2]
DS4 = ROOT / "data" / "real" / "ds4-cantilever-freedecay" / "timeseries_data.lvm"
RNG = np.random.default_rng(3)
#: values with few decimal digits, so the text written and the floats read back are the same numbers
ACCEL = np.round(RNG.standard_normal(40), 6)
FORCE = np.round(RNG.standard_normal(40) * 100, 4)


def lvm_text(channels: dict, *, x_columns="One", separator="Tab", decimal=".", segments=1, dt=0.001,
             comment_row=None) -> str:
    """A LabVIEW Measurement file holding ``channels`` (name -> (unit, values)), written by hand
    after NI's description of the format, split into ``segments`` equal segments."""
    sep = {"Tab": "\t", "Comma": ","}[separator]
    names, units = list(channels), [u for u, _ in channels.values()]
    data = np.column_stack([v for _, v in channels.values()])
    n = len(names)

    def line(*cells):
        return sep.join(str(c) for c in cells) + sep + "\n"

    def number(x):
        return repr(float(x)).replace(".", decimal)

    out = [f"LabVIEW Measurement{sep}\n", line("Writer_Version", 2), line("Reader_Version", 2),
           line("Separator", separator), line("Decimal_Separator", decimal), line("Multi_Headings", "Yes"),
           line("X_Columns", x_columns), line("Time_Pref", "Relative"), line("Operator", "tester"),
           line("***End_of_Header***"), "\n"]
    rows_per = data.shape[0] // segments
    for s in range(segments):
        x0 = s * rows_per * dt
        out += [line("Channels", n), line("Samples", *[rows_per] * n), line("Y_Unit_Label", *units),
                line("X_Dimension", *["Time"] * n), line("X0", *[number(x0)] * n),
                line("Delta_X", *[number(dt)] * n), line("***End_of_Header***")]
        heads = {"Multi": [c for name in names for c in ("X_Value", name)], "One": ["X_Value", *names],
                 "No": names}[x_columns]
        out.append(sep.join([*heads, "Comment"]) + "\n")
        for k in range(s * rows_per, (s + 1) * rows_per):
            x = number(k * dt)
            values = [number(v) for v in data[k]]
            cells = {"Multi": [c for v in values for c in (x, v)], "One": [x, *values], "No": values}[x_columns]
            if k == comment_row:
                cells.append("hammer hit")
            out.append(sep.join(cells) + "\n")
    return "".join(out)


def write(tmp_path, text, name="test.lvm"):
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return path


def test_the_real_ds4_record_reads_as_its_columns():
    table = read_lvm(DS4)
    columns = np.loadtxt(DS4, skiprows=23)  # the README's own route: 23 header lines, time and g
    (channel,) = table.channels
    assert (channel.name, channel.unit) == ("Acceleration", "g")
    # both routes parse the same decimal text with the correctly rounded float(): identical arrays
    np.testing.assert_array_equal(channel.values, columns[:, 1])
    np.testing.assert_array_equal(table.time, columns[:, 0])
    assert table.sample_rate == 1 / 0.000605 and table.metadata["Operator"] == "puja"


@pytest.mark.parametrize("x_columns", ["Multi", "One", "No"])
@pytest.mark.parametrize("separator,decimal", [("Tab", "."), ("Tab", ","), ("Comma", ".")])
def test_two_channels_in_two_segments_read_back(tmp_path, x_columns, separator, decimal):
    text = lvm_text({"Accel tip": ("g", ACCEL), "Force": ("N", FORCE)}, x_columns=x_columns,
                    separator=separator, decimal=decimal, segments=2, comment_row=3)
    table = read_lvm(write(tmp_path, text))
    assert [(c.name, c.unit) for c in table.channels] == [("Accel tip", "g"), ("Force", "N")]
    # the values are printed with repr and parsed back: exact
    np.testing.assert_array_equal(table.channels[0].values, ACCEL)
    np.testing.assert_array_equal(table.channels[1].values, FORCE)
    # X_Value columns hold repr(k dt); without them X0 + k Delta_X is computed: one rounding, 1 ulp of 0.04 s
    np.testing.assert_allclose(table.time, 0.001 * np.arange(40), rtol=0, atol=1e-17)
    assert table.sample_rate == 1000.0 and table.metadata["segments"] == "2"


def test_a_channel_without_unit_label_has_none(tmp_path):
    text = lvm_text({"a": ("", ACCEL)})
    assert read_lvm(write(tmp_path, text)).channels[0].unit is None


def refusal(tmp_path, text) -> RecordingError:
    with pytest.raises(RecordingError) as caught:
        read_lvm(write(tmp_path, text))
    return caught.value


def test_an_empty_file_is_refused(tmp_path):
    err = refusal(tmp_path, "")
    assert err.where == "line 1" and "LabVIEW Measurement" in err.problem


def test_a_header_without_data_is_refused(tmp_path):
    text = lvm_text({"a": ("g", ACCEL)})
    err = refusal(tmp_path, text[: text.index("X_Value")])
    assert "no rows of samples" in err.problem


def test_a_non_numeric_cell_is_refused_with_its_line_and_column(tmp_path):
    text = lvm_text({"a": ("g", ACCEL), "b": ("N", FORCE)}).replace(repr(float(FORCE[5])), "1.2.3", 1)
    err = refusal(tmp_path, text)
    line = text.splitlines().index(next(t for t in text.splitlines() if "1.2.3" in t)) + 1
    assert (err.where, err.problem) == (f'line {line}, column "b"', "'1.2.3' is not a number")


def test_channels_of_unequal_length_are_refused_with_the_line(tmp_path):
    lines = lvm_text({"a": ("g", ACCEL), "b": ("N", FORCE)}, x_columns="Multi").splitlines(keepends=True)
    # the last sample of channel b is missing: its X and value cells are empty
    lines[-1] = "\t".join(lines[-1].split("\t")[:2] + ["", ""]) + "\n"
    err = refusal(tmp_path, "".join(lines))
    assert err.where.startswith(f"line {len(lines)}, column") and "missing" in err.problem


def test_segments_with_other_units_are_refused(tmp_path):
    text = lvm_text({"a": ("g", ACCEL)}, segments=2)
    first_units = text.index("Y_Unit_Label")
    second = text.index("Y_Unit_Label", first_units + 1)
    text = text[:second] + text[second:].replace("Y_Unit_Label\tg", "Y_Unit_Label\tm/s^2", 1)
    err = refusal(tmp_path, text)
    assert err.where.startswith("segment at line") and "differ from the first segment" in err.problem


def test_a_column_count_that_does_not_fit_channels_is_refused(tmp_path):
    text = lvm_text({"a": ("g", ACCEL), "b": ("N", FORCE)}).replace("Channels\t2", "Channels\t3", 1)
    assert "column names for 3 channel(s)" in refusal(tmp_path, text).problem


def test_a_decimal_comma_between_commas_is_refused(tmp_path):
    text = lvm_text({"a": ("g", ACCEL)}, separator="Comma").replace("Decimal_Separator,.", "Decimal_Separator,,")
    assert refusal(tmp_path, text).where == "line 5, Decimal_Separator"


def test_without_x_values_or_delta_x_the_time_is_left_to_the_user(tmp_path):
    text = lvm_text({"a": ("g", ACCEL)}, x_columns="No")
    text = "".join(line for line in text.splitlines(keepends=True) if not line.startswith(("Delta_X", "X0")))
    table = read_lvm(write(tmp_path, text))
    assert table.time is None and table.sample_rate is None
    np.testing.assert_array_equal(table.channels[0].values, ACCEL)
