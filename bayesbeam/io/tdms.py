"""NI TDMS files (LabVIEW, NI DAQExpress, FlexLogger, SignalExpress), read with npTDMS.

A TDMS file holds groups of channels. :func:`read_tdms` reads the channels of one group: the
one named by ``group``, else the first group that holds a numeric channel. Its numeric channels
are the signals, each in the unit of its ``unit_string`` property (None without one). The
time comes from a channel called ``Time``/``time``/``t`` or holding timestamps (taken in s from
its first sample), else from the waveform properties, ``wf_start_offset + k wf_increment``
(``wf_increment``, s, must be the same for every channel), whose rate ``1 / wf_increment`` is
returned as well. Text channels are skipped. The file's and the group's properties are the
metadata.
"""
from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from .channels import checked_table
from .errors import RecordingError
from .table import Channel, ChannelTable

TIME_NAMES = ("time", "t")
READ_FIX = "export the measurement as a TDMS file (File > Save As .tdms in the acquisition software)"


def read_tdms(path: str | os.PathLike, *, group: str | None = None) -> ChannelTable:
    """The channels of one group of a TDMS file (module docstring); RecordingError naming the fix."""
    file = Path(path)
    tdms = _open(file)
    chosen = _group(file, tdms, group)
    numeric = [c for c in chosen.channels() if _is_numeric(c) or _is_timestamp(c)]
    time_channel = next((c for c in numeric if _is_timestamp(c) or c.name.strip().lower() in TIME_NAMES), None)
    signals = [c for c in numeric if c is not time_channel and not _is_timestamp(c)]
    channels = [Channel(c.name, _unit(c), np.asarray(c[:], dtype=float)) for c in signals]
    step = _increment(file, chosen.name, signals)
    time = _seconds(time_channel) if time_channel is not None else None
    if time is None and step is not None:
        start = float(signals[0].properties.get("wf_start_offset", 0.0))
        time = start + step * np.arange(channels[0].values.size)
    metadata = {"group": chosen.name, "groups": ", ".join(g.name for g in tdms.groups())}
    metadata |= {str(k): str(v) for k, v in {**tdms.properties, **chosen.properties}.items()}
    return checked_table(file, channels, time=time, sample_rate=None if step is None else 1.0 / step,
                         metadata=metadata, empty_fix=f"choose a group with numeric channels ({metadata['groups']}).")


def _open(file: Path):
    from nptdms import TdmsFile

    if not file.is_file():
        raise RecordingError(file, "file", "no such file", "pass the path of a .tdms file.")
    try:
        return TdmsFile.read(file)
    except Exception as err:  # npTDMS raises ValueError, KeyError, struct.error ... on a damaged file
        raise RecordingError(file, "file", f"not a readable TDMS file ({type(err).__name__}: {err})",
                             READ_FIX + ".") from err


def _group(file: Path, tdms, name: str | None):
    groups = tdms.groups()
    names = ", ".join(repr(g.name) for g in groups) or "none"
    if name is not None:
        found = [g for g in groups if g.name == name]
        if not found:
            raise RecordingError(file, f"group {name!r}", f"no such group (its groups: {names})",
                                 "pass --group with one of those names.")
        return found[0]
    for g in groups:
        if any(_is_numeric(c) for c in g.channels()):
            return g
    raise RecordingError(file, "file", f"no group holds a numeric channel (groups: {names})", READ_FIX + ".")


def _is_numeric(channel) -> bool:
    kind = np.dtype(channel.dtype).kind if channel.dtype is not None else "O"
    return kind in "iuf"


def _is_timestamp(channel) -> bool:
    return channel.dtype is not None and np.dtype(channel.dtype).kind == "M"


def _unit(channel) -> str | None:
    unit = channel.properties.get("unit_string")
    return str(unit) if unit is not None else None


def _increment(file: Path, group: str, signals) -> float | None:
    steps = {float(c.properties["wf_increment"]) for c in signals if "wf_increment" in c.properties}
    if len(steps) > 1:
        raise RecordingError(file, f"group {group!r}", f"channels with different wf_increment {sorted(steps)} s",
                             "export channels sampled together at one rate, or each rate's channels in a group.")
    step = steps.pop() if steps else None
    if step is not None and not 0.0 < step < np.inf:
        raise RecordingError(file, f"group {group!r}", f"wf_increment {step!r} s is not a positive step",
                             "export the waveform with its sampling interval, or give --sample-rate.")
    return step


def _seconds(channel) -> np.ndarray:
    values = np.asarray(channel[:])
    if values.dtype.kind == "M":
        return (values - values[0]) / np.timedelta64(1, "s") if values.size else values.astype(float)
    return values.astype(float)
