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

__all__ = [
    "Beam",
    "TipBody",
    "Excitation",
    "Sensor",
    "Recording",
    "RecordingError",
    "load_recording",
    "write_recording",
]
