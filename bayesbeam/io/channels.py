"""The checks every DAQ-file reader applies to the channels it found, before it returns them.

Each reader (``lvm.py``, ``tdms.py``, ``matfile.py``, ``uff.py``) names its own places (a line,
a group, a variable); what is left to refuse alike is shared here: no channel, channels of
unequal length, a sample that is not a finite number, a time vector that does not fit the
channels, a sampling rate that is not a positive number, two channels of one name.
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from .errors import RecordingError
from .table import Channel, ChannelTable

#: fewer samples than this hold no time step
MIN_CHANNEL_SAMPLES = 2


def checked_table(source: Path, channels: list[Channel], *, time=None, sample_rate=None, metadata=None,
                  empty_fix: str = "export at least one channel of samples.") -> ChannelTable:
    """The :class:`ChannelTable` of ``channels``, or RecordingError naming the channel and the fix."""
    if not channels:
        raise RecordingError(source, "file", "no channel of numeric samples found", empty_fix)
    channels = [_finite_channel(source, c) for c in channels]
    first = channels[0]
    for c in channels:
        if c.name in [d.name for d in channels[: channels.index(c)]]:
            raise RecordingError(source, f'channel "{c.name}"', "channel name used twice",
                                 "give every channel its own name in the acquisition software.")
        if c.values.size != first.values.size:
            raise RecordingError(source, f'channel "{c.name}"',
                                 f'{c.values.size} samples where channel "{first.name}" has {first.values.size}',
                                 "export channels sampled together over one record, all of one length.")
    if first.values.size < MIN_CHANNEL_SAMPLES:
        raise RecordingError(source, f'channel "{first.name}"', f"{first.values.size} sample(s)",
                             "export the whole record, not a single value.")
    if time is not None:
        time = _checked_time(source, np.asarray(time, dtype=float), first)
    return ChannelTable(source, tuple(channels), time, _checked_rate(source, sample_rate), dict(metadata or {}))


def _finite_channel(source: Path, channel: Channel) -> Channel:
    values = np.asarray(channel.values, dtype=float).reshape(-1)
    bad = np.flatnonzero(~np.isfinite(values))
    if bad.size:
        raise RecordingError(source, f'channel "{channel.name}", sample {bad[0] + 1}',
                             f"{values[bad[0]]!r} is not a finite number",
                             "replace the bad sample or trim the record so that it excludes it.")
    unit = channel.unit.strip() if isinstance(channel.unit, str) and channel.unit.strip() else None
    return Channel(channel.name.strip(), unit, values)


def _checked_time(source: Path, time: np.ndarray, first: Channel) -> np.ndarray:
    time = time.reshape(-1)
    if time.size != first.values.size:
        raise RecordingError(source, "time", f'{time.size} time values for {first.values.size} samples of channel '
                             f'"{first.name}"', "export the time vector of these channels, one value per sample.")
    bad = np.flatnonzero(~np.isfinite(time))
    if bad.size:
        raise RecordingError(source, f"time, sample {bad[0] + 1}", f"{time[bad[0]]!r} is not a finite number",
                             "export a complete time vector, or give the sampling rate instead.")
    return time


def _checked_rate(source: Path, rate) -> float | None:
    if rate is None:
        return None
    rate = float(rate)
    if not math.isfinite(rate) or rate <= 0.0:
        raise RecordingError(source, "sampling rate", f"{rate!r} Hz is not a positive number",
                             "state the sampling rate in Hz (--sample-rate).")
    return rate
