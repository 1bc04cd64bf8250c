"""LabVIEW Measurement files (``.lvm``, the text files of LabVIEW's "Write To Measurement File").

A file opens with ``LabVIEW Measurement`` and a file header (``key<sep>value`` lines up to
``***End_of_Header***``) whose ``Separator`` (``Tab`` or ``Comma``), ``Decimal_Separator``
(``.`` or ``,``) and ``X_Columns`` (``No``, ``One`` or ``Multi``) say how to read the rest.
Then come one or more segments, each a header (``Channels``, ``Samples``, ``Y_Unit_Label``,
``X0``, ``Delta_X``, ... one value per channel, up to ``***End_of_Header***``), a line of
column names, and the rows of samples. The columns are the channels, each preceded by an
``X_Value`` column with ``X_Columns = Multi``, all by one with ``One``, none with ``No``; a last
``Comment`` column may hold text and is skipped.

:func:`read_lvm` returns the channels (named by the column-name line, in the units of
``Y_Unit_Label``), the time (the ``X_Value`` column, or ``X0 + k Delta_X`` without one; None
without either, when the rate must be given), the sampling rate ``1 / Delta_X`` as the header
states it, and the file header's other keys as metadata. Segments are joined when they hold the same channels in the same units at the same
``Delta_X``; otherwise the file is refused. Blank lines are skipped. Everything refused names
the line.
"""
from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .channels import checked_table
from .errors import RecordingError
from .table import Channel, ChannelTable

MAGIC = "LabVIEW Measurement"
END = "***End_of_Header***"
#: the first key of every segment header
SEGMENT_START = "Channels"
SEPARATORS = {"Tab": "\t", "Comma": ","}
#: the file-header keys that say how the file is laid out, not what it holds
LAYOUT_KEYS = ("Writer_Version", "Reader_Version", "Separator", "Decimal_Separator", "Multi_Headings", "X_Columns")
READ_FIX = "export the data again from LabVIEW as a LabVIEW Measurement (.lvm) text file"


@dataclass
class _Layout:
    separator: str
    decimal: str
    x_columns: str  # "No", "One" or "Multi"
    metadata: dict[str, str]


@dataclass
class _Segment:
    line: int  # 1-based line of its first header line
    header: dict[str, list[str]] = field(default_factory=dict)
    names: list[str] = field(default_factory=list)
    rows: list[list[str]] = field(default_factory=list)
    row_lines: list[int] = field(default_factory=list)


def read_lvm(path: str | os.PathLike) -> ChannelTable:
    """The channels of a LabVIEW Measurement file (module docstring); RecordingError naming the line."""
    file = Path(path)
    lines = _lines(file)
    layout, at = _file_header(file, lines)
    segments = _segments(file, lines, at, layout)
    parsed = [_parse_segment(file, s, layout) for s in segments]
    return _joined(file, parsed, layout)


def _lines(file: Path) -> list[str]:
    if not file.is_file():
        raise RecordingError(file, "file", "no such file", "pass the path of a .lvm file.")
    raw = file.read_bytes()
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError:
        text = raw.decode("cp1252", errors="replace")  # LabVIEW writes the Windows code page
    return text.splitlines()


def _cells(line: str, separator: str) -> list[str]:
    """The cells of ``line`` without the empty ones LabVIEW leaves at the end."""
    cells = [c.strip() for c in line.split(separator)]
    while cells and not cells[-1]:
        cells.pop()
    return cells


def _key_value(line: str) -> tuple[str, str]:
    """A file-header line split at its first tab or comma (the separator is not known yet)."""
    for k, char in enumerate(line):
        if char in "\t,":
            return line[:k].strip(), line[k + 1:].split(char)[0].strip()
    return line.strip(), ""


def _file_header(file: Path, lines: list[str]) -> tuple[_Layout, int]:
    """The layout the file header states, and the index of the line after its end."""
    if not lines or not lines[0].startswith(MAGIC):
        raise RecordingError(file, "line 1", f"does not start with {MAGIC!r}", READ_FIX + ".")
    pairs = {}
    for i, line in enumerate(lines[1:], 1):
        key, value = _key_value(line)
        if key == END:
            return _layout(file, pairs), i + 1
        if key:
            pairs[key] = (value, i + 1)
    raise RecordingError(file, "file header", f"no {END} line", READ_FIX + ".")


def _layout(file: Path, pairs: dict[str, tuple[str, int]]) -> _Layout:
    def value(key: str, default: str, choices) -> str:
        text, line = pairs.get(key, (default, None))
        if text not in choices:
            raise RecordingError(file, f"line {line}, {key}", f"unknown value {text!r}",
                                 f"set {key} to one of {', '.join(choices)}.")
        return text

    separator = SEPARATORS[value("Separator", "Tab", tuple(SEPARATORS))]
    decimal = value("Decimal_Separator", ".", (".", ","))
    metadata = {k: v for k, (v, _) in pairs.items() if k not in LAYOUT_KEYS}
    return _Layout(separator, decimal, value("X_Columns", "One", ("No", "One", "Multi")), metadata)


def _segments(file: Path, lines: list[str], at: int, layout: _Layout) -> list[_Segment]:
    """Each segment's header, column names and rows of cells, as text."""
    segments, segment, state = [], None, "header"
    for i in range(at, len(lines)):
        cells = _cells(lines[i], layout.separator)
        if not cells:
            continue
        if state == "data" and cells[0] == SEGMENT_START:
            state = "header"  # the next segment's header
        if state == "header":
            if segment is None or segment.names:
                segment = _Segment(i + 1)
                segments.append(segment)
            if cells[0] == END:
                state = "names"
            else:
                segment.header[cells[0]] = cells[1:]
        elif state == "names":
            segment.names, state = cells, "data"
        else:
            segment.rows.append(lines[i].split(layout.separator))
            segment.row_lines.append(i + 1)
    if not segments or not segments[-1].rows:
        where = f"line {segments[-1].line}" if segments else "file"
        raise RecordingError(file, where, "no rows of samples after the segment header", READ_FIX + ", with its data.")
    return segments


def _is_number(text: str, decimal: str) -> bool:
    try:
        float(text.replace(decimal, "."))
    except ValueError:
        return False
    return True


@dataclass
class _Parsed:
    segment: _Segment
    names: list[str]
    units: list[str | None]
    delta_x: float | None
    values: np.ndarray  # (n_rows, n_channels)
    time: np.ndarray | None


def _parse_segment(file: Path, s: _Segment, layout: _Layout) -> _Parsed:
    names, x_at, channel_at = _columns(file, s, layout)
    width = 1 + max(x_at + channel_at)
    for row, line in zip(s.rows, s.row_lines):
        if len([c for c in row[:width] if c.strip()]) < width:
            blank = next((k for k in range(width) if k >= len(row) or not row[k].strip()), width - 1)
            raise RecordingError(file, f'line {line}, column "{s.names[blank] if blank < len(s.names) else blank}"',
                                 f"{len(row)} cell(s), a sample missing where {width} columns are named",
                                 "export channels of one length, each with a value in every row.")
    cells = np.array([row[:width] for row in s.rows], dtype=object)
    numbers = {k: _numbers(file, s, cells[:, k], s.names[k], layout.decimal) for k in set(x_at + channel_at)}
    values = np.column_stack([numbers[k] for k in channel_at])
    units = _per_channel(file, s, "Y_Unit_Label", len(names)) or [None] * len(names)
    delta_x = _delta_x(file, s, len(names))
    time = _time(file, s, layout, [numbers[k] for k in x_at], delta_x, len(s.rows), len(names))
    return _Parsed(s, names, [u or None for u in units], delta_x, values, time)


def _columns(file: Path, s: _Segment, layout: _Layout) -> tuple[list[str], list[int], list[int]]:
    """Channel names, and the column indices of the X values and of the channels."""
    names = s.names[:-1] if s.names and s.names[-1] == "Comment" else list(s.names)
    n = _channel_count(file, s, names, layout)
    if layout.x_columns == "Multi":
        x_at, channel_at = list(range(0, 2 * n, 2)), list(range(1, 2 * n, 2))
    elif layout.x_columns == "One":
        x_at, channel_at = [0], list(range(1, n + 1))
    else:
        x_at, channel_at = [], list(range(n))
    return [names[k] for k in channel_at], x_at, channel_at


def _channel_count(file: Path, s: _Segment, names: list[str], layout: _Layout) -> int:
    expected = {"Multi": lambda n: 2 * n, "One": lambda n: n + 1, "No": lambda n: n}[layout.x_columns]
    stated = s.header.get("Channels")
    if not stated or not stated[0].isdigit() or int(stated[0]) < 1:
        raise RecordingError(file, f"line {s.line}, Channels", f"missing or not a count ({stated})",
                             READ_FIX + " (each segment header states its Channels).")
    n = int(stated[0])
    if len(names) != expected(n):
        raise RecordingError(file, f"line {s.row_lines[0] - 1 if s.rows else s.line}",
                             f"{len(names)} column names for {n} channel(s) with X_Columns = {layout.x_columns}",
                             "name every column in the column-name line after the segment header.")
    return n


def _numbers(file: Path, s: _Segment, cells: np.ndarray, name: str, decimal: str) -> np.ndarray:
    text = [c.strip().replace(decimal, ".") for c in cells]
    try:
        return np.array(text, dtype=float)
    except ValueError:
        k = next(k for k, t in enumerate(text) if not _is_number(t, "."))
        raise RecordingError(file, f'line {s.row_lines[k]}, column "{name}"', f"{cells[k].strip()!r} is not a number",
                             f"write a plain number there, with {decimal!r} as the decimal separator the "
                             "header states.") from None


def _per_channel(file: Path, s: _Segment, key: str, n: int) -> list[str] | None:
    """The header's ``key`` values, one per channel (one value stands for all); None when absent."""
    values = s.header.get(key)
    if not values:
        return None
    if len(values) == 1:
        return values * n
    if len(values) != n:
        raise RecordingError(file, f"segment at line {s.line}, {key}", f"{len(values)} values for {n} channels",
                             f"state {key} once per channel.")
    return values


def _delta_x(file: Path, s: _Segment, n: int) -> float | None:
    values = _per_channel(file, s, "Delta_X", n)
    if values is None:
        return None
    steps = {_number_or_refuse(file, s, "Delta_X", v) for v in values}
    if len(steps) != 1 or not next(iter(steps)) > 0.0:
        raise RecordingError(file, f"segment at line {s.line}, Delta_X", f"{values}: not one positive step",
                             "export channels sampled together at one rate.")
    return steps.pop()


def _number_or_refuse(file: Path, s: _Segment, key: str, text: str) -> float:
    try:
        return float(text.replace(",", "."))
    except ValueError:
        raise RecordingError(file, f"segment at line {s.line}, {key}", f"{text!r} is not a number",
                             f"write {key} as a number.") from None


def _time(file: Path, s: _Segment, layout: _Layout, x_columns, delta_x, rows: int, n: int) -> np.ndarray | None:
    if x_columns:
        for x in x_columns[1:]:
            if not np.array_equal(x, x_columns[0]):
                k = int(np.flatnonzero(x != x_columns[0])[0])
                raise RecordingError(file, f"line {s.row_lines[k]}", "the channels' X_Value columns differ",
                                     "export channels sampled together (one time for all).")
        return x_columns[0]
    if delta_x is None:
        return None  # the samples are known by their rate only, which the user states
    x0 = _per_channel(file, s, "X0", n)
    start = _number_or_refuse(file, s, "X0", x0[0]) if x0 else 0.0
    return start + delta_x * np.arange(rows)


def _joined(file: Path, parsed: list[_Parsed], layout: _Layout) -> ChannelTable:
    first = parsed[0]
    for p in parsed[1:]:
        same = (p.names, p.units, p.delta_x) == (first.names, first.units, first.delta_x)
        if not same:
            raise RecordingError(file, f"segment at line {p.segment.line}",
                                 f"channels {p.names} in {p.units} every {p.delta_x} s differ from the first "
                                 f"segment's {first.names} in {first.units} every {first.delta_x} s",
                                 "export one record of the same channels per file.")
    values = np.vstack([p.values for p in parsed])
    channels = [Channel(name, unit, values[:, k]) for k, (name, unit) in enumerate(zip(first.names, first.units))]
    metadata = {**layout.metadata, "segments": str(len(parsed))}
    if first.delta_x is not None:
        metadata["Delta_X"] = repr(first.delta_x)
    rate = None if first.delta_x is None else 1.0 / first.delta_x
    times = [p.time for p in parsed]
    time = None if any(t is None for t in times) else np.concatenate(times)
    return checked_table(file, channels, time=time, sample_rate=rate, metadata=metadata)
