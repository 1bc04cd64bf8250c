"""Delimited text as data-acquisition systems export it: the columns of cells, and their names and units.

A DAQ's text export differs from a recording's CSV (docs/format.md) in ways a reader can tell
from the file itself: it may begin with metadata (``# Sample rate: 4096 Hz``), separate its cells
by tabs, semicolons or spaces, write decimal commas (``0,125``), put each channel's unit in its
header cell (``Accel tip (g)``, ``Time [ms]``), and print the time with fewer digits than a
float holds. :func:`read_text_export` reads such a file into a
:class:`~bayesbeam.io.table.ChannelTable`; ``load_recording`` reads ``[recording] file``
through :func:`read_export_cells` when it is not a plain comma CSV.

Sniffing (each can be stated instead): the delimiter is the first of tab, semicolon, comma,
runs of whitespace that splits most of the file's last lines into one count (at least 2) of numbers;
the decimal mark is the comma when the delimiter is not a comma and the cells read as numbers
only with it. The header is the first line of that many cells followed by a line whose cells
are mostly numbers; a line of units between header and data is taken as the units. Lines
before the header (and comment lines starting with ``#``, ``%``, ``;``, ``//`` anywhere) are
metadata: their ``key: value`` and ``key = value`` pairs are kept. Every line number in an
error is the file's physical line, counting from 1.
"""
from __future__ import annotations

import csv
import math
import re
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .errors import RecordingError
from .table import Channel, ChannelTable
from .units import parse_unit

MAX_MAGNITUDE = 1e100
"""Largest accepted magnitude of any number, in SI units: far beyond any quantity a test
measures or describes, and small enough that sums of squares over any record, and the
model's products of such values, stay finite (1e308 would overflow when squared)."""
COMMENT_PREFIXES = ("#", "%", ";", "//")
#: the delimiters sniffed, in order of preference; " " stands for runs of whitespace
DELIMITERS = ("\t", ";", ",", " ")
#: header names (lower case, unit removed) that mark the time column
TIME_NAMES = ("time", "t", "zeit", "temps", "tiempo", "tempo", "x_value", "time_s", "seconds")
#: how many of the file's last lines the delimiter and decimal mark are sniffed from
SNIFF_LINES = 20
_RATE_KEYS = ("sample rate", "sampling rate", "sample frequency", "sampling frequency", "fs", "samplerate",
              "sample_rate", "sampling_rate", "rate")
_STEP_KEYS = ("dt", "delta t", "delta_t", "time step", "sample interval", "sampling interval", "increment")
_RATE_UNITS = {"hz": 1.0, "khz": 1e3, "s/s": 1.0, "sa/s": 1.0, "samples/s": 1.0, "": 1.0}


# --------------------------------------------------------------------------- the cells


@dataclass(frozen=True)
class CellTable:
    """The cells of a delimited file, kept as text until a column is asked for.

    header: the header cells as written; rows: the data cells, decimal commas already made
    points; lines: the file's physical line number (from 1) of each row.
    """

    path: Path
    header: tuple[str, ...]
    rows: list[list[str]]
    lines: list[int]

    def column(self, name: str) -> np.ndarray:
        """The finite float64 values of column ``name``, or RecordingError at the first bad cell."""
        j = self.header.index(name)
        cells = [row[j] for row in self.rows]
        try:
            values = np.fromiter(map(float, cells), dtype=np.float64, count=len(cells))
        except ValueError:
            raise self._unparsable(name, cells) from None
        bad = np.flatnonzero(~np.isfinite(values))
        if bad.size:
            i = bad[0]
            what = "NaN" if np.isnan(values[i]) else "an infinite value"
            raise RecordingError(
                self.path, f'line {self.lines[i]}, column "{name}"', f"{cells[i].strip()!r} is {what}",
                "replace the bad sample or trim the record so that it excludes it.",
            )
        bad = np.flatnonzero(np.abs(values) > MAX_MAGNITUDE)
        if bad.size:
            i = bad[0]
            raise RecordingError(
                self.path, f'line {self.lines[i]}, column "{name}"',
                f"{cells[i].strip()!r} is beyond the magnitudes a recording can hold (up to {MAX_MAGNITUDE:g})",
                "write the channel in SI units (m, m/s, m/s^2, N, s), and replace or trim a corrupt sample.",
            )
        return values

    def cells(self, name: str) -> list[str]:
        """The text of column ``name``'s cells."""
        j = self.header.index(name)
        return [row[j] for row in self.rows]

    def _unparsable(self, name: str, cells: list[str]) -> RecordingError:
        """The error for the first cell of ``cells`` that float() refuses."""
        line, cell = next((line, cell) for line, cell in zip(self.lines, cells) if not is_float(cell))
        problem = "empty cell" if not cell.strip() else f"{cell!r} is not a number"
        return RecordingError(
            self.path, f'line {line}, column "{name}"', problem,
            "write a plain decimal number there (e.g. 0.0125 or 1.25e-2, '.' as decimal point), "
            "or trim the record to the rows where every channel has a value.",
        )


def is_float(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def check_header(path: Path, header: tuple[str, ...], line: int) -> None:
    """Refuse a header that names a column twice."""
    for j, name in enumerate(header):
        if name in header[:j]:
            raise RecordingError(
                path, f'line {line}, column "{name}"', "column name used twice", "give every column its own name."
            )


# --------------------------------------------------------------------------- names and units


_UNIT_SUFFIX = re.compile(r"^(.*?)\s*[(\[]([^()\[\]]*)[)\]]\s*$")


def split_unit(cell: str) -> tuple[str, str | None]:
    """A header cell's name and the unit in its trailing brackets: ``"Accel tip (g)"`` ->
    ``("Accel tip", "g")``, ``"Time [ms]"`` -> ``("Time", "ms")``; ``(cell, None)`` without one."""
    match = _UNIT_SUFFIX.match(cell.strip())
    if not match or not match[1] or not match[2].strip():
        return cell.strip(), None
    return match[1], match[2].strip()


def find_column(header: tuple[str, ...], column: str) -> list[str]:
    """The header cells ``column`` names: the cell written so, else those whose name without
    its unit is ``column``, else those whose name and unit are ``column``'s."""
    if column in header:
        return [column]
    named = [cell for cell in header if split_unit(cell)[0] == column]
    return named or [cell for cell in header if split_unit(cell) == split_unit(column)]


def time_column(header: tuple[str, ...]) -> str | None:
    """The header cell of the time column, recognised by its name (``time``, ``t``, ``Time (s)``,
    ``Zeit [ms]``, ...) or by a time unit; None when no cell is."""
    for cell in header:
        name, unit = split_unit(cell)
        if name.lower() in TIME_NAMES:
            return cell
    for cell in header:
        unit = parse_unit(split_unit(cell)[1])
        if unit is not None and unit.quantity == "time":
            return cell
    return None


# --------------------------------------------------------------------------- reading the text


@dataclass(frozen=True)
class TextExport:
    """What :func:`read_export_cells` found: the cells, the delimiter (" ": runs of whitespace) and
    decimal mark, the metadata's ``key: value`` pairs and a sample rate (Hz) it states."""

    cells: CellTable
    delimiter: str
    decimal: str
    metadata: dict[str, str] = field(default_factory=dict)
    sample_rate: float | None = None


def read_text_export(path, *, delimiter: str | None = None, decimal: str | None = None,
                     sample_rate: float | None = None) -> ChannelTable:
    """Read a DAQ's delimited text export into a ChannelTable (see the module docstring).

    delimiter: ``","``, ``";"``, ``"\\t"`` or ``" "`` (runs of whitespace), sniffed when None;
    decimal: ``"."`` or ``","``, sniffed when None; sample_rate: Hz, overrides one the file states.
    The time column, when one is recognised, becomes ``time`` in s (its header unit s, ms or us
    converted); every other column is a channel, its values as written and its unit as its
    header cell states. Raises RecordingError naming the file, the line and the fix.
    """
    path = Path(path)
    export = read_export_cells(path, delimiter=delimiter, decimal=decimal)
    cells = export.cells
    time_cell = time_column(cells.header)
    time = None if time_cell is None else cells.column(time_cell) * time_factor(path, time_cell)
    channels = tuple(Channel(*split_unit(cell), cells.column(cell)) for cell in cells.header if cell != time_cell)
    if sample_rate is not None and not (math.isfinite(sample_rate) and sample_rate > 0):
        raise RecordingError(path, "sample_rate", f"{sample_rate!r} is not a positive rate",
                             "give the sample rate in Hz.")
    return ChannelTable(path, channels, time, sample_rate or export.sample_rate, export.metadata)


def time_factor(path: Path, cell: str) -> float:
    """Seconds per unit of the time column ``cell`` (1 without a unit); RecordingError for a
    unit that is not a time."""
    stated = split_unit(cell)[1]
    if stated is None:
        return 1.0
    unit = parse_unit(stated)
    if unit is None or unit.quantity != "time":
        raise RecordingError(path, f'column "{cell}"', f"the time column's unit {stated!r} is not s, ms or us",
                             "write the time in s, ms or us and say so in its header, e.g. Time (s).")
    return unit.factor


def read_export_cells(path: Path, *, delimiter: str | None = None, decimal: str | None = None,
                      skip_lines: int = 0) -> TextExport:
    """The cells of a text export, its header found and its delimiter and decimal mark sniffed
    unless stated; the first ``skip_lines`` lines are metadata whatever they hold."""
    lines = _physical_lines(path)
    delimiter = _stated_delimiter(path, delimiter)
    if decimal not in (None, ".", ","):
        raise RecordingError(path, "decimal", f"{decimal!r} is not a decimal mark", 'state decimal = "." or ",".')
    delimiter, decimal, width = _sniff(path, lines, skip_lines, delimiter, decimal)
    candidates = [(number, text) for number, text in enumerate(lines[skip_lines:], skip_lines + 1)
                  if text.strip() and not _comment(text, delimiter)]
    split = _LazyCells(candidates, delimiter, width)
    start = _header_index(path, candidates, split, width, decimal)
    header, names = _header(split, start, width)
    check_header(path, header, candidates[names][0])
    rows, row_lines = _data_rows(path, lines, candidates[start][0] + 1, delimiter, width, decimal)
    metadata = _metadata(lines[: candidates[names][0] - 1], delimiter, decimal)
    cells = CellTable(path, header, rows, row_lines)
    return TextExport(cells, delimiter, decimal, metadata, _stated_rate(metadata))


#: the delimiters a user may state, and how they are read (" ": runs of whitespace)
STATED_DELIMITERS = {",": ",", ";": ";", "\t": "\t", "tab": "\t", " ": " ", "space": " ", "whitespace": " "}


def _stated_delimiter(path: Path, delimiter: str | None) -> str | None:
    if delimiter is None or delimiter in STATED_DELIMITERS:
        return STATED_DELIMITERS.get(delimiter)
    raise RecordingError(path, "delimiter", f"{delimiter!r} is not a delimiter this reader knows",
                         'state delimiter = ",", ";", "\\t" (tab) or " " (runs of whitespace).')


def _physical_lines(path: Path) -> list[str]:
    if not path.is_file():
        raise RecordingError(path, "file", "no such file",
                             "put the data file next to beam.toml, or correct [recording] file in beam.toml.")
    data = path.read_bytes()
    try:
        text = data.decode("utf-8-sig")
    except UnicodeDecodeError:
        text = data.decode("cp1252", errors="replace")  # Windows DAQ software writes µ, ° in cp1252
    # Only these three end a line in an editor; str.splitlines would also split at \f, \x1c, ...
    return re.split(r"\r\n|\r|\n", text)


def _cells(text: str, delimiter: str) -> list[str]:
    if delimiter == " ":
        return _joined_units(text.split())
    if '"' not in text:
        cells = text.split(delimiter)  # what csv would give, without its cost per line
    else:
        try:
            cells = next(csv.reader([text], delimiter=delimiter))
        except (csv.Error, StopIteration):
            return [text]
    if len(cells) > 1 and not cells[-1].strip() and text.rstrip().endswith(delimiter):
        cells = cells[:-1]  # many loggers end every line with the delimiter
    return [cell.strip() for cell in cells]


def _joined_units(tokens: list[str]) -> list[str]:
    """Whitespace-split tokens with a bracketed unit joined to the name before it (``Time (s)``)."""
    cells = []
    for token in tokens:
        if cells and re.fullmatch(r"[(\[][^()\[\]]*[)\]]", token):
            cells[-1] += " " + token
        else:
            cells.append(token)
    return cells


def _as_number(cell: str, decimal: str) -> str:
    return cell.replace(",", ".") if decimal == "," else cell


def _numeric(cells: list[str], decimal: str) -> int:
    return sum(is_float(_as_number(cell, decimal)) for cell in cells)


def _sniff(path: Path, lines: list[str], skip_lines: int, delimiter, decimal) -> tuple[str, str, int]:
    """The delimiter, decimal mark and cell count of the data, from the file's last lines."""
    if delimiter == "," and decimal == ",":
        raise RecordingError(path, "decimal", "a comma cannot be both the delimiter and the decimal mark",
                             'state delimiter = ";" or "\\t" for a file with decimal commas.')
    numbered = [(number, text) for number, text in enumerate(lines[skip_lines:], skip_lines + 1) if text.strip()]
    if not numbered:
        raise RecordingError(path, "file", "no data", "export the channels with a header line and one row per sample.")
    tail = [text for _, text in numbered[-SNIFF_LINES:] if not _comment(text)] or [numbered[-1][1]]
    for d in DELIMITERS if delimiter is None else (delimiter,):
        rows = [_cells(text, d) for text in tail]
        width = Counter(map(len, rows)).most_common(1)[0][0]
        marks = [decimal] if decimal else ["."] if d == "," else [".", ","]
        for mark in marks:
            # most of the last lines are rows of numbers: a header, a note or a bad cell may be among them
            numbers = sum(len(row) == width and _numeric(row, mark) == width for row in rows)
            if width >= 2 and 2 * numbers > len(rows):
                return d, mark, width
        if delimiter is not None:
            return d, decimal or ".", width
    raise RecordingError(
        path, f"line {numbered[-1][0]}",
        "cannot tell how the columns are separated: the file's last lines do not split into one number "
        "of numeric cells (at least 2) by tabs, semicolons, commas or whitespace",
        'state [recording] delimiter (e.g. delimiter = ";") and, for decimal commas, decimal = ",", '
        "or save the data as comma-separated values with a header line",
    )


class _LazyCells:
    """The cells of each candidate line, split when first asked for: the header is near the top
    of a long file, so most lines need not be split twice."""

    def __init__(self, candidates, delimiter: str, width: int):
        self._candidates, self._delimiter, self._width, self._cells = candidates, delimiter, width, {}

    def __len__(self) -> int:
        return len(self._candidates)

    def __getitem__(self, k: int) -> list[str]:
        if k not in self._cells:
            text = self._candidates[k][1]
            cells = _cells(text, self._delimiter)
            if self._delimiter == " " and len(cells) != self._width:
                # a header of names with spaces, the columns set apart by tabs or runs of spaces
                wide = re.split(r"\s*\t\s*|\s{2,}", text.strip())
                cells = wide if len(wide) == self._width else cells
            self._cells[k] = cells
        return self._cells[k]


def _header_index(path: Path, candidates, split, width: int, decimal: str) -> int:
    """Index in ``candidates`` of the header: the first line of ``width`` cells, not all numbers,
    followed by a line of ``width`` cells most of which are numbers."""
    for k in range(len(split) - 1):
        here, after = split[k], split[k + 1]
        if len(here) == width and _numeric(here, decimal) < width and len(after) == width \
                and 2 * _numeric(after, decimal) >= width:
            return k
    if not candidates:
        raise RecordingError(path, "file", "no lines but comments", "export the channels with a header line "
                             "and one row per sample.")
    first = next((candidates[k][0] for k in range(len(split)) if len(split[k]) == width), candidates[-1][0])
    raise RecordingError(path, f"line {first}", f"no header line naming the {width} columns above the data",
                         "add a header line naming the columns, e.g. Time (s), Accel tip (g), above the first row.")


def _comment(text: str, delimiter: str | None = None) -> bool:
    """A comment line; not one that starts with the delimiter (an empty first cell)."""
    text = text.lstrip()
    return text.startswith(COMMENT_PREFIXES) and not (delimiter and delimiter.strip() and text.startswith(delimiter))


def _header(split, start: int, width: int) -> tuple[tuple[str, ...], int]:
    """The header cells and the index of the names line: a line of units (``s``, ``(g)``, ``[N]``)
    under a line of names is joined with it into ``name (unit)``."""
    names = split[start - 1] if start > 0 else None
    units = [cell.strip("()[]") for cell in split[start]]
    if names is None or len(names) != width or not all(not u or parse_unit(u) for u in units):
        return tuple(split[start]), start
    return tuple(f"{name} ({unit})" if unit and split_unit(name)[1] is None else name
                 for name, unit in zip(names, units)), start - 1


def _data_rows(path: Path, lines: list[str], first: int, delimiter, width: int, decimal: str):
    """The data cells from physical line ``first`` on, and their line numbers; comment lines are
    skipped, trailing blank lines too, a blank line inside the data or a row of another width refused."""
    rows, numbers, blank = [], [], None
    for number, text in enumerate(lines[first - 1:], first):
        if not text.strip():
            blank = blank or number
            continue
        if _comment(text, delimiter):
            continue
        if blank is not None:
            raise RecordingError(path, f"line {blank}", "blank line inside the data", "delete the blank line.")
        cells = _cells(text, delimiter)
        if len(cells) != width:
            raise RecordingError(path, f"line {number}", f"{len(cells)} cells where the header names {width} columns",
                                 "give every row exactly one value per header column.")
        rows.append(cells if decimal == "." else [_as_number(cell, decimal) for cell in cells])
        numbers.append(number)
    return rows, numbers


_PAIR = re.compile(r"^(.+?)\s*(?:=|:(?=\s|$))\s*(.*)$")


def _metadata(lines: list[str], delimiter, decimal: str) -> dict[str, str]:
    """The ``key: value`` / ``key = value`` / ``key<delimiter>value`` pairs of the lines before the header."""
    pairs = {}
    for text in lines:
        text = re.sub(r"^(?:#|%|;|//)+\s*", "", text.strip())
        match = _PAIR.match(text)
        cells = _cells(text, delimiter)
        if match:
            pairs.setdefault(match[1].strip(), match[2].strip())
        elif len(cells) == 2 and cells[0]:
            pairs.setdefault(cells[0], _as_number(cells[1], decimal) if is_float(_as_number(cells[1], decimal))
                             else cells[1])
    return pairs


def _stated_rate(metadata: dict[str, str]) -> float | None:
    """A sample rate (Hz) the metadata states as a rate (``Sample rate: 4096 Hz``) or a step (``dt = 1e-3``)."""
    for key, value in metadata.items():
        name, unit_in_key = split_unit(key)
        name = re.sub(r"[\s_-]+", " ", name.lower()).strip()
        match = re.match(r"^([-+]?[\d.,]+(?:[eE][-+]?\d+)?)\s*(.*)$", value.strip())
        if not match or not is_float(match[1].replace(",", ".")):
            continue
        number, unit = float(match[1].replace(",", ".")), (match[2] or unit_in_key or "").strip()
        if not (math.isfinite(number) and number > 0):
            continue
        if name in _RATE_KEYS or name.replace(" ", "_") in _RATE_KEYS:
            factor = _RATE_UNITS.get(unit.lower())
            if factor is not None:
                return number * factor
        if name in _STEP_KEYS or name.replace(" ", "_") in _STEP_KEYS:
            step = parse_unit(unit or "s")
            if step is not None and step.quantity == "time":
                return 1.0 / (number * step.factor)
    return None


# --------------------------------------------------------------------------- time as printed


_PRINTED = re.compile(r"^\s*[-+]?\d*(?:\.(\d*))?(?:[eE]([-+]?\d+))?\s*$")


def print_resolution(cells: list[str]) -> np.ndarray:
    """One unit in the last printed digit of each cell (``"0.000244141"`` -> 1e-9, ``"1.5e-3"`` ->
    1e-4). A cell printed shorter than both its neighbours (trailing zeros dropped, ``"0.5"`` among
    9-decimal cells) is exact to their precision, so it takes the coarser of theirs."""
    resolution = np.empty(len(cells))
    for i, cell in enumerate(cells):
        match = _PRINTED.match(cell)
        decimals = len(match[1] or "") if match else 0
        exponent = int(match[2]) if match and match[2] and len(match[2]) < 6 else 0
        resolution[i] = 10.0 ** min(exponent - decimals, 300)  # "0e400" is a finite 0
    if resolution.size > 2:
        neighbours = np.maximum(np.r_[resolution[1], resolution[:-1]], np.r_[resolution[1:], resolution[-2]])
        resolution = np.minimum(resolution, neighbours)
    return resolution
