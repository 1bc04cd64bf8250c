"""MATLAB ``.mat`` files: v4-v7 with scipy.io.loadmat, v7.3 (HDF5) with h5py.

:func:`read_mat` reads the workspace a file holds: its variables, and the fields of a struct
variable one level down (named by the field, or ``struct.field`` when a variable has that name).
Then

* a vector named ``t``, ``time`` or ``Time`` is the time in s;
* a scalar named ``fs``, ``Fs``, ``sample_rate`` or ``sampling_rate`` is the rate in Hz, ``dt``
  the step in s;
* every other numeric vector is a channel, and every column of a 2-D array ``x`` is one,
  ``x_1`` ... ``x_k`` (the array's dimension that matches the channels' length is time);
* a channel's unit is the text of ``<name>_unit`` (or ``_units``), else of a struct ``units``'s
  field ``<name>``, else the ``<name>`` entry of a cell array ``units`` holding one text per
  channel in order; None when the file states none;
* other scalars and texts are the metadata. Complex arrays, cell arrays and arrays of three or
  more dimensions are not channels, and are left out.

v7.3 files store arrays transposed (HDF5 is row-major); they are read back in MATLAB's
orientation, so both versions give the same channels.
"""
from __future__ import annotations

import os
import re
from pathlib import Path

import numpy as np

from .channels import checked_table
from .errors import RecordingError
from .table import Channel, ChannelTable

TIME_NAMES = ("t", "time", "Time")
RATE_NAMES = ("fs", "Fs", "sample_rate", "sampling_rate")
STEP_NAMES = ("dt",)
UNITS_NAME = "units"
READ_FIX = "save the workspace with MATLAB's save (e.g. save('test.mat', 't', 'acc', 'fs'))"


def read_mat(path: str | os.PathLike) -> ChannelTable:
    """The channels of a MATLAB file's workspace (module docstring); RecordingError naming the variable."""
    file = Path(path)
    variables = _flattened(_workspace(file))
    time = variables.pop(next((n for n in TIME_NAMES if _is_vector(variables.get(n))), None), None)
    rate = _rate(file, variables)
    units = _units(variables)
    arrays = {n: v for n, v in variables.items() if _is_channel_array(v) and not _is_unit_name(n)}
    length = _length(time, arrays)
    channels = [c for name, array in arrays.items() for c in _channels(file, name, array, length)]
    channels = [Channel(c.name, _unit_of(c.name, units, channels), c.values) for c in channels]
    metadata = {n: _text(v) for n, v in variables.items() if n not in arrays and _text(v) is not None}
    return checked_table(file, channels, time=None if time is None else _vector(time), sample_rate=rate,
                         metadata=metadata, empty_fix=f"store each channel as a numeric vector; {READ_FIX}.")


# --------------------------------------------------------------------------- the workspace


def _workspace(file: Path) -> dict:
    """Variable name -> value: numbers as arrays in MATLAB's orientation, texts as str, structs as dict."""
    import h5py

    if not file.is_file():
        raise RecordingError(file, "file", "no such file", "pass the path of a .mat file.")
    try:
        if h5py.is_hdf5(file):
            with h5py.File(file, "r") as h5:
                return {k: _hdf5_value(v) for k, v in h5.items() if not k.startswith("#")}
        from scipy.io import loadmat

        return {k: v for k, v in loadmat(file, simplify_cells=True).items() if not k.startswith("__")}
    except Exception as err:  # scipy and h5py raise ValueError, TypeError, OSError ... on a damaged file
        raise RecordingError(file, "file", f"not a readable MATLAB file ({type(err).__name__}: {err})",
                             READ_FIX + ".") from err


def _hdf5_value(node):
    """A v7.3 variable: a group is a struct, a char array is text, a numeric array is transposed back."""
    import h5py

    if isinstance(node, h5py.Group):
        return {k: _hdf5_value(v) for k, v in node.items()}
    kind = node.attrs.get("MATLAB_class", b"")
    kind = kind.decode() if isinstance(kind, bytes) else str(kind)
    data = node[()]
    if kind == "char":
        return "".join(map(chr, np.asarray(data).reshape(-1)))
    if kind in ("cell", "struct", "logical") or np.asarray(data).dtype.kind not in "iufb":
        return None  # references into #refs#: not channels
    return np.asarray(data).T


def _flattened(workspace: dict) -> dict:
    """The variables, with a struct's fields one level down in place of the struct."""
    out = {}
    for name, value in workspace.items():
        if isinstance(value, dict) and name != UNITS_NAME:
            for field, inner in value.items():
                if field == UNITS_NAME and isinstance(inner, dict):  # the struct's own units table
                    out[UNITS_NAME] = {**out.get(UNITS_NAME, {}), **inner}
                    continue
                out[field if field not in workspace and field not in out else f"{name}.{field}"] = inner
        elif name == UNITS_NAME and isinstance(value, dict):
            out[UNITS_NAME] = {**value, **out.get(UNITS_NAME, {})}
        else:
            out[name] = value
    return out


# --------------------------------------------------------------------------- what each variable is


def _numeric(value) -> np.ndarray | None:
    if isinstance(value, (bool, str, dict)) or value is None:
        return None
    array = np.asarray(value)
    return array if array.dtype.kind in "iuf" else None


def _is_vector(value) -> bool:
    array = _numeric(value)
    return array is not None and array.size > 1 and sum(d > 1 for d in array.shape) == 1


def _vector(value) -> np.ndarray:
    return np.asarray(value, dtype=float).reshape(-1)


def _is_channel_array(value) -> bool:
    array = _numeric(value)
    return array is not None and array.size > 1 and sum(d > 1 for d in array.shape) <= 2


def _scalar(value) -> float | None:
    array = _numeric(value)
    return float(array.reshape(-1)[0]) if array is not None and array.size == 1 else None


def _rate(file: Path, variables: dict) -> float | None:
    for name in RATE_NAMES:
        if _scalar(variables.get(name)) is not None:
            return _positive(file, name, _scalar(variables.pop(name)), "Hz")
    for name in STEP_NAMES:
        if _scalar(variables.get(name)) is not None:
            return 1.0 / _positive(file, name, _scalar(variables.pop(name)), "s")
    return None


def _positive(file: Path, name: str, value: float, unit: str) -> float:
    if not 0.0 < value < np.inf:
        raise RecordingError(file, f"variable {name!r}", f"{value!r} {unit} is not a positive number",
                             f"store {name} in {unit}, or give --sample-rate.")
    return value


def _text(value) -> str | None:
    if isinstance(value, str):
        return value
    scalar = _scalar(value)
    return None if scalar is None else repr(scalar)


# --------------------------------------------------------------------------- channels and units


def _length(time, arrays: dict) -> int | None:
    """The channels' length: the time's, else the first vector's, else the first array's longer side."""
    if time is not None:
        return _vector(time).size
    vectors = [a for a in arrays.values() if _is_vector(a)]
    if vectors:
        return _vector(vectors[0]).size
    return max(np.asarray(next(iter(arrays.values()))).shape) if arrays else None


def _channels(file: Path, name: str, value, length: int | None) -> list[Channel]:
    if _is_vector(value):
        return [Channel(name, None, _vector(value))]
    array = np.asarray(value, dtype=float).reshape([d for d in np.shape(value) if d > 1])
    if array.shape[0] != length:
        array = array.T
    if array.shape[0] != length:
        raise RecordingError(file, f"variable {name!r}", f"a {np.shape(value)} array, neither side {length} long",
                             "store channels sampled together, each as long as the time vector.")
    return [Channel(f"{name}_{k}", None, array[:, k - 1]) for k in range(1, array.shape[1] + 1)]


def _is_unit_name(name: str) -> bool:
    return name == UNITS_NAME or re.search(r"_units?$", name) is not None


def _units(variables: dict):
    """What the file states of units: ``<name>_unit`` texts, and the ``units`` struct or cell array."""
    stated = {re.sub(r"_units?$", "", n): v for n, v in variables.items()
              if re.search(r"_units?$", n) and isinstance(v, str)}
    table = variables.get(UNITS_NAME)
    return stated, table


def _unit_of(channel: str, units, channels: list[Channel]) -> str | None:
    stated, table = units
    base = re.sub(r"_\d+$", "", channel)
    for key in (channel, base):
        if key in stated:
            return stated[key]
        if isinstance(table, dict) and isinstance(table.get(key), str):
            return table[key]
    if isinstance(table, (list, tuple, np.ndarray)) and len(table) == len(channels):
        entry = list(table)[[c.name for c in channels].index(channel)]
        return entry if isinstance(entry, str) else None
    return None
