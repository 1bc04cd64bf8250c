"""Atomic file output: a reader never sees a half-written file."""
from __future__ import annotations

import os
import uuid
from pathlib import Path


def atomic_write(path, write) -> Path:
    """Call ``write(temporary_path)`` on a sibling of ``path``, then rename it to ``path``.

    The temporary file is removed if ``write`` fails. It has the suffix ``.tmp``, so writers
    that infer a format from the name must be told the format.
    """
    path = Path(os.path.abspath(path))
    temporary = path.with_name(f".{path.name}.{uuid.uuid4().hex[:12]}.tmp")
    try:
        write(temporary)
        os.replace(temporary, path)
    finally:
        temporary.unlink(missing_ok=True)
    return path


def write_text(path, text: str) -> Path:
    """Write ``text`` (UTF-8) to ``path`` atomically."""
    return atomic_write(path, lambda p: p.write_text(text, encoding="utf-8"))
