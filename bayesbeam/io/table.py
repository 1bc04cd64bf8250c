"""What a data-acquisition file holds, before it is described as a beam test: named channels.

Every reader of a DAQ's own file (a delimited text export, LabVIEW ``.lvm``, NI TDMS, MATLAB
``.mat``, UFF58) returns a :class:`ChannelTable`; ``bayesbeam import`` turns one into a recording
folder (docs/format.md), and ``load_recording`` reads a text export through the same table.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np


@dataclass(frozen=True)
class Channel:
    """One sampled signal as the file names it.

    name: the channel's name without its unit (``"Accel tip"`` of ``"Accel tip (g)"``);
    unit: the unit the file states for it (``"g"``, ``"m/s^2"``, ``"V"``), None when it states none;
    values: the samples as written, in that unit (1-D float array).
    """

    name: str
    unit: str | None
    values: np.ndarray


@dataclass(frozen=True)
class ChannelTable:
    """The channels of one file, sampled together.

    source: the file read; channels: in the file's order; time: the time column in s when the file
    holds one (None when the samples are known only by their rate); sample_rate: Hz, when the file
    or the user states it; metadata: what the file says of itself besides the samples (a header's
    ``key: value`` pairs, a TDMS group's properties), as text, for the import's notes.
    """

    source: Path
    channels: tuple[Channel, ...]
    time: np.ndarray | None = None
    sample_rate: float | None = None
    metadata: dict[str, str] = field(default_factory=dict)

    def channel(self, name: str) -> Channel:
        """The channel called ``name``; KeyError naming the channels there are."""
        for c in self.channels:
            if c.name == name:
                return c
        raise KeyError(f"{self.source}: no channel {name!r}; it has {[c.name for c in self.channels]}")
