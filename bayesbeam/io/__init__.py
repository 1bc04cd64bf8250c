"""Reading and writing recordings (the format of docs/format.md)."""

from .errors import RecordingError
from .recording import (
    Beam,
    Excitation,
    Recording,
    Sensor,
    TipBody,
    load_recording,
    write_recording,
)
from .text import read_text_export
from .uff import load_beam_description, read_uff58, write_uff58, write_uff_modes

__all__ = [
    "Beam",
    "Excitation",
    "Recording",
    "RecordingError",
    "Sensor",
    "TipBody",
    "load_beam_description",
    "load_recording",
    "read_text_export",
    "read_uff58",
    "write_recording",
    "write_uff58",
    "write_uff_modes",
]
