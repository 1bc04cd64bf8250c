"""A data-acquisition system's file -> a recording folder (``bayesbeam import``, docs/format.md).

:func:`read_channels` reads a file by its extension (or ``format``) into a
:class:`~bayesbeam.io.table.ChannelTable`; :func:`write_import` writes it as ``recording.csv``
(time in s on a uniform grid, then one column per channel with the values as the file holds
them: units are converted at load, from each channel's ``unit`` in beam.toml) and
``beam.toml``; :func:`import_file` does both.

Without a beam description, beam.toml is a skeleton: the channels, units and sampling from the
file, the excitation and each sensor's quantity guessed from units and names, and every key the
file cannot state (the beam's, the locations, a free decay's start) as a commented-out line
marked ``FILL IN``, so that ``load_recording`` refuses the folder, naming the first such key,
until the user has filled them in. With one (``beam``, a beam.toml), its tables are taken as
they are and the recording is loaded at once.
"""
from __future__ import annotations

import os
import re
import shutil
from pathlib import Path

import numpy as np

from .channels import checked_table
from .errors import RecordingError
from .recording import (
    _BEAM_KEYS,
    _MEANING,
    DEFAULT_CSV,
    DEFAULT_TIME_COLUMN,
    QUANTITIES,
    _check_target,
    _move_into_place,
    _read_toml,
    _sibling,
    _toml_pairs,
    _toml_table,
    _toml_value,
    load_recording,
    write_recording,
)
from .table import ChannelTable
from .units import parse_unit

#: extension -> format; ``format=`` names one of FORMATS
EXTENSIONS = {".lvm": "lvm", ".tdms": "tdms", ".mat": "mat", ".uff": "uff", ".unv": "uff",
              ".csv": "text", ".txt": "text", ".tsv": "text", ".dat": "text"}
FORMATS = ("lvm", "tdms", "mat", "uff", "text")
FORMAT_NAMES = {"lvm": "LabVIEW Measurement", "tdms": "NI TDMS", "mat": "MATLAB", "uff": "UFF58",
                "text": "delimited text export"}
#: options that only one format reads: option -> format
FORMAT_OPTIONS = {"group": "tdms", "delimiter": "text", "decimal": "text"}
#: a time column is a print of a uniform grid when every sample lies within this many steps of it:
#: rounding to the print's last digit moves a sample by at most half a unit of that digit, under
#: 1 % of a step whenever the step is printed to 3 significant digits; a dropped or repeated
#: sample moves the samples after it by a whole step
MAX_GRID_DEVIATION = 0.01
#: a time that starts further than this many steps from 0 is a clock (an absolute time stamp):
#: start + k step then loses the step's digits, so the recording counts time from the first sample
MAX_START_STEPS = 1e7
#: a rate the file states is the time column's when the two spans agree to this (relative): a clock
#: 1 ppm off is a clock, not a printing; 9 printed decimals over a 1 s record leave 5e-10
STATED_RATE_MATCH = 1e-6
#: a channel with a force unit, or called so, is the hammer's (or a load cell's) force
FORCE_NAME = re.compile(r"force|hammer|load.?cell|impact", re.IGNORECASE)
FILL_IN = "FILL IN"
_BEAM_HINTS = {"length": "l, m, the free length from the clamp", "density": "rho, kg/m^3",
               "area": "A, m^2 (rho A is the mass per unit length)", "second_moment": "I, m^4",
               "modulus": "E, Pa, nominal (centres the prior on EI)"}


# --------------------------------------------------------------------------- reading


def detect_format(path: str | os.PathLike, format: str | None = None) -> str:
    """``format`` when given (one of FORMATS), else the format of ``path``'s extension."""
    file = Path(path)
    if format is not None:
        if format not in FORMATS:
            raise RecordingError(file, "--format", f"unknown format {format!r}", f"use one of {', '.join(FORMATS)}.")
        return format
    fmt = EXTENSIONS.get(file.suffix.lower())
    if fmt is None:
        raise RecordingError(file, "file name", f"unknown extension {file.suffix!r} "
                             f"(known: {', '.join(EXTENSIONS)})", f"pass --format with one of {', '.join(FORMATS)}.")
    return fmt


def read_channels(path: str | os.PathLike, *, format: str | None = None, group: str | None = None,
                  delimiter: str | None = None, decimal: str | None = None,
                  sample_rate: float | None = None) -> ChannelTable:
    """The channels of a DAQ file, by its extension or ``format``; RecordingError naming the fix.

    ``group`` picks a TDMS group; ``delimiter`` and ``decimal`` are a text export's;
    ``sample_rate`` (Hz) is passed on to the text reader (the others state their own).
    """
    file = Path(path)
    fmt = detect_format(file, format)
    given = {"group": group, "delimiter": delimiter, "decimal": decimal}
    for option, owner in FORMAT_OPTIONS.items():
        if given[option] is not None and fmt != owner:
            raise RecordingError(file, f"--{option}", f"applies to {FORMAT_NAMES[owner]} files, not {fmt}",
                                 f"leave --{option} out.")
    if fmt == "lvm":
        from .lvm import read_lvm

        return read_lvm(file)
    if fmt == "tdms":
        from .tdms import read_tdms

        return read_tdms(file, group=group)
    if fmt == "mat":
        from .matfile import read_mat

        return read_mat(file)
    if fmt == "uff":
        from .uff import read_uff58_channels

        return read_uff58_channels(file)
    from .text import read_text_export

    return read_text_export(file, delimiter=delimiter, decimal=decimal, sample_rate=sample_rate)


def import_file(path: str | os.PathLike, out_dir: str | os.PathLike, *, beam: str | os.PathLike | None = None,
                format: str | None = None, overwrite: bool = False, group: str | None = None,
                delimiter: str | None = None, decimal: str | None = None,
                sample_rate: float | None = None) -> Path:
    """Read ``path`` (:func:`read_channels`) and write the recording folder ``out_dir``
    (:func:`write_import`); a UFF file with ``beam`` goes through :func:`~bayesbeam.io.uff.read_uff58`
    (positions from its nodes). Returns ``out_dir``."""
    if detect_format(path, format) == "uff" and beam is not None:
        from .uff import read_uff58

        if sample_rate is not None:
            raise RecordingError(path, "--sample-rate", "a UFF file states its own step", "leave --sample-rate out.")
        return write_recording(read_uff58(path, beam), out_dir, overwrite=overwrite)
    table = read_channels(path, format=format, group=group, delimiter=delimiter, decimal=decimal,
                          sample_rate=sample_rate)
    return write_import(table, out_dir, beam=beam, overwrite=overwrite, sample_rate=sample_rate,
                        format=detect_format(path, format))


# --------------------------------------------------------------------------- the recording


def uniform_time(table: ChannelTable, sample_rate: float | None = None) -> tuple[np.ndarray, float | None]:
    """The recording's time (s) on a uniform grid, and the file's start (s) when it was a clock.

    The grid is: ``sample_rate`` (Hz) when given, from the file's first time (or 0); else the file's
    time, ``t[0] + k dt``, refused when a sample lies more than MAX_GRID_DEVIATION steps off it,
    with dt the step of the rate the file states when its grid ends where the time column does to
    STATED_RATE_MATCH (a printed time, 2.5e-10 s off at 9 decimals, would turn 1/2048 s into
    0.00048828125003 s), else ``(t[-1] - t[0]) / (n - 1)``; else the file's sampling rate, from 0.
    """
    n = table.channels[0].values.size
    if sample_rate is not None:
        rate = checked_table(table.source, list(table.channels), sample_rate=sample_rate).sample_rate
        start, step = (0.0 if table.time is None else float(table.time[0])), 1.0 / rate
    elif table.time is not None:
        start, step = float(table.time[0]), _time_step(table)
        _check_grid(table, start, step)
    elif table.sample_rate is not None:
        start, step = 0.0, 1.0 / table.sample_rate
    else:
        raise RecordingError(table.source, "time", "the file states neither a time nor a sampling rate",
                             "give the sampling rate: --sample-rate HZ (sample_rate=).")
    if abs(start) > MAX_START_STEPS * step:
        return step * np.arange(n), start
    return start + step * np.arange(n), None


def _time_step(table: ChannelTable) -> float:
    """The step of the file's time column: that of its stated rate when the two agree (see
    :func:`uniform_time`), else its mean step."""
    n, span = table.time.size, float(table.time[-1] - table.time[0])
    if table.sample_rate and abs(span * table.sample_rate / (n - 1) - 1.0) <= STATED_RATE_MATCH:
        return 1.0 / table.sample_rate
    return span / (n - 1)


def _check_grid(table: ChannelTable, start: float, step: float) -> None:
    time = table.time
    if not step > 0.0:
        raise RecordingError(table.source, "time", f"the time runs from {time[0]!r} to {time[-1]!r} s",
                             "export a time that increases, or pass --sample-rate.")
    off = np.abs(time - (start + step * np.arange(time.size))) / step
    k = int(np.argmax(off))
    if off[k] > MAX_GRID_DEVIATION:
        raise RecordingError(table.source, f"time, sample {k + 1}",
                             f"{time[k]!r} s lies {off[k]:.3g} steps off the uniform grid from {start!r} s every "
                             f"{step!r} s (a gap, a repeat or an uneven clock)",
                             "export one uninterrupted, uniformly sampled record, or pass --sample-rate to take "
                             "the samples as uniform.")


def column_names(table: ChannelTable) -> list[str]:
    """The CSV column of each channel: its name with each run of characters other than letters,
    digits, ``.``, ``-`` and ``_`` made one ``_``; ``_2``, ``_3`` ... added where names would repeat."""
    columns = []
    for k, channel in enumerate(table.channels, 1):
        base = re.sub(r"[^\w.\-]+", "_", channel.name).strip("_") or f"channel_{k}"
        name, j = base, 2
        while name in columns or name == DEFAULT_TIME_COLUMN:
            name, j = f"{base}_{j}", j + 1
        columns.append(name)
    return columns


def write_import(table: ChannelTable, out_dir: str | os.PathLike, *, beam: str | os.PathLike | None = None,
                 overwrite: bool = False, sample_rate: float | None = None, format: str | None = None) -> Path:
    """Write ``table`` as the recording folder ``out_dir`` (module docstring); atomic as
    :func:`~bayesbeam.io.write_recording`. With ``beam`` the folder is then loaded, and a
    RecordingError names what the written beam.toml still lacks."""
    time, clock = uniform_time(table, sample_rate)
    columns = column_names(table)
    notes = {"imported_from": table.source.name, "format": FORMAT_NAMES.get(format, "unstated"),
             "sampling_rate_hz": float((time.size - 1) / (time[-1] - time[0])), **table.metadata}
    if clock is not None:
        notes["time_origin_s"] = clock
    if beam is None:
        text = _skeleton(table, columns, time, notes)
    else:
        text = _described(table, columns, time, Path(beam), notes)
    out = _write_folder(out_dir, {"beam.toml": text, DEFAULT_CSV: _csv(time, table, columns)}, overwrite)
    if beam is not None:
        load_recording(out)
    return out


def _csv(time: np.ndarray, table: ChannelTable, columns: list[str]) -> str:
    rows = np.column_stack([time, *[c.values for c in table.channels]]).tolist()
    # repr() is the shortest text that reads back to the same float: the values as the file holds them
    return ",".join([DEFAULT_TIME_COLUMN, *columns]) + "\n" + "".join(",".join(map(repr, r)) + "\n" for r in rows)


def _write_folder(out_dir, files: dict[str, str], overwrite: bool) -> Path:
    """Write ``files`` (name -> text) as the folder ``out_dir``, atomically (write_recording's staging)."""
    out_dir = Path(os.path.abspath(out_dir))
    _check_target(out_dir, overwrite)
    out_dir.parent.mkdir(parents=True, exist_ok=True)
    staging = _sibling(out_dir, "tmp")
    staging.mkdir()
    try:
        for name, text in files.items():
            (staging / name).write_text(text, encoding="utf-8")
        _move_into_place(staging, out_dir)
    except BaseException:
        shutil.rmtree(staging, ignore_errors=True)
        raise
    return out_dir


# --------------------------------------------------------------------------- beam.toml


def _is_force(channel) -> bool:
    unit = parse_unit(channel.unit)
    if unit is not None and unit.quantity in QUANTITIES:
        return False
    return (unit is not None and unit.quantity == "force") or bool(FORCE_NAME.search(channel.name))


def _force_index(table: ChannelTable) -> int | None:
    return next((k for k, c in enumerate(table.channels) if _is_force(c)), None)


def _fill(key: str, hint: str) -> str:
    return f"# {key} = ...".ljust(26) + f"# {FILL_IN}: {hint}"


def _skeleton(table: ChannelTable, columns: list[str], time: np.ndarray, notes: dict) -> str:
    force = _force_index(table)
    lines = [f"# beam.toml of a recording made by `bayesbeam import` from {table.source.name}.",
             "# The channels, their units and the time come from the file; the rest is for you to state.",
             f'# Every line marked "{FILL_IN}" is a placeholder: remove its leading "# " and write the value.',
             "# Until then bayesbeam refuses this recording, naming the first key to fill in (docs/format.md).",
             "", "[beam]", *[_fill(key, _BEAM_HINTS[key]) for key in _BEAM_KEYS],
             "", "# [tip]                   # a body fixed at the free end; leave out for none",
             "# mass = 0.0              # m_T, kg", "# rotary_inertia = 0.0    # J, kg m^2",
             "", *_excitation_lines(table, columns, force, time)]
    for k, channel in enumerate(table.channels):
        if k != force:
            lines += ["", *_sensor_lines(channel, columns[k])]
    lines += _toml_table(["recording"], {"file": DEFAULT_CSV, "time_column": DEFAULT_TIME_COLUMN})
    lines += _toml_table(["notes"], notes)
    return "\n".join(lines) + "\n"


def _unit_lines(channel) -> list[str]:
    if channel.unit is None:
        return [("# unit = ...               # the file states no unit: the column is taken as SI unless you "
                 "state one")]
    unit = parse_unit(channel.unit)
    if unit is not None and unit.quantity == "voltage":  # refused at load until the calibration is stated
        return [f"unit = {_toml_value(channel.unit)}".ljust(26) + f"# {FILL_IN}: the unit of the quantity (\"g\"), "
                f"with sensitivity = {channel.unit} per that unit; or, in place of unit, scale = SI units per "
                f"{channel.unit}"]
    return [f"unit = {_toml_value(channel.unit)}"]


def _excitation_lines(table: ChannelTable, columns: list[str], force: int | None, time: np.ndarray) -> list[str]:
    if force is None:
        return ["[excitation]", ('kind = "free_decay"        # the file has no force channel (for a release '
                                 'from a static tip load: kind = "release", tip_load = N)'),
                _fill("start", f"s, from when no force acts (after the tap); the record runs {time[0]:.6g} to "
                      f"{time[-1]:.6g} s")]
    channel = table.channels[force]
    return ["[excitation]", 'kind = "force"', f"column = {_toml_value(columns[force])}", *_unit_lines(channel),
            _fill("location", "x_f, m from the clamp, where the force acts")]


def _sensor_lines(channel, column: str) -> list[str]:
    unit = parse_unit(channel.unit)
    if unit is not None and unit.quantity in QUANTITIES:
        quantity = [f'quantity = "{unit.quantity}"'.ljust(26) + f"# from the unit {channel.unit!r}"]
    else:
        quantity = [_fill("quantity", _MEANING["quantity"])]
    # the name is the column's: it enters parameter names (sigma_<name>, dx_<name>), so no spaces
    return ["[[sensor]]", f"name = {_toml_value(column)}", f"column = {_toml_value(column)}",
            *_unit_lines(channel), *quantity, _fill("location", "m from the clamp")]


def _described(table: ChannelTable, columns: list[str], time: np.ndarray, beam: Path, notes: dict) -> str:
    """beam.toml from a beam description's tables, the channels' units filled in where it states none."""
    if not beam.is_file():
        raise RecordingError(beam, "file", "no such file", "pass the path of a beam.toml with a [beam] table.")
    doc = _read_toml(beam)
    units = {column: channel.unit for column, channel in zip(columns, table.channels)}
    lines = [f"# Recording made by `bayesbeam import` from {table.source.name} with {beam.name}."]
    lines += _toml_pairs({k: v for k, v in doc.items() if not isinstance(v, (dict, list))})
    for name, value in doc.items():
        if name in ("sensor", "excitation", "recording", "notes") or not isinstance(value, dict):
            continue
        lines += _toml_table([name], value)
    lines += _described_excitation(table, columns, time, doc, beam, units)
    lines += _described_sensors(table, columns, doc, beam, units)
    lines += _toml_table(["recording"], {"file": DEFAULT_CSV, "time_column": DEFAULT_TIME_COLUMN})
    lines += _toml_table(["notes"], notes | (doc.get("notes") if isinstance(doc.get("notes"), dict) else {}))
    return "\n".join(lines) + "\n"


def _with_unit(table: dict, label: str, beam: Path, columns: list[str], units: dict) -> dict:
    """``table`` with the unit of the channel its ``column`` names, unless it states one."""
    column = table.get("column")
    if isinstance(column, str) and column not in units:
        raise RecordingError(beam, f"{label} .column", f"the imported file has no channel {column!r} "
                             f"(its columns: {', '.join(columns)})", "name one of those columns.")
    if {"unit", "sensitivity", "scale"} & set(table) or units.get(column) is None:
        return table  # a calibration states its own unit (a voltage is never the quantity's)
    return {**table, "unit": units[column]}


def _described_excitation(table, columns, time, doc: dict, beam: Path, units: dict) -> list[str]:
    given = doc.get("excitation")
    force = _force_index(table)
    if not isinstance(given, dict):
        return ["", *_excitation_lines(table, columns, force, time)]
    if given.get("kind") == "force" and "column" not in given and force is not None:
        given = {**given, "column": columns[force]}
    return _toml_table(["excitation"], _with_unit(given, "[excitation]", beam, columns, units))


def _described_sensors(table, columns, doc: dict, beam: Path, units: dict) -> list[str]:
    given = doc.get("sensor")
    if not isinstance(given, list):
        force = _force_index(table)
        return [line for k, c in enumerate(table.channels) if k != force
                for line in ["", *_sensor_lines(c, columns[k])]]
    lines = []
    for i, sensor in enumerate(given, 1):
        sensor = _with_unit(sensor, f"[[sensor]] #{i}", beam, columns, units) if isinstance(sensor, dict) else sensor
        lines += ["", "[[sensor]]", *_toml_pairs(sensor if isinstance(sensor, dict) else {})]
    return lines


# --------------------------------------------------------------------------- what is left to fill in


def placeholders(beam_toml: str | os.PathLike) -> list[str]:
    """The keys a beam.toml still marks ``FILL IN`` (``[beam] length``, ``[[sensor]] #2 location``), in order."""
    found, table, sensors = [], "", 0
    for line in Path(beam_toml).read_text(encoding="utf-8").splitlines():
        header = re.match(r"\s*(\[\[?[\w.-]+\]\]?)", line)
        if header:
            sensors += header[1] == "[[sensor]]"
            table = f"[[sensor]] #{sensors}" if header[1] == "[[sensor]]" else header[1]
        elif placeholder := re.match(rf"#?\s*(\w+) = .*# {FILL_IN}", line):
            found.append(f"{table} {placeholder[1]}")
    return found
