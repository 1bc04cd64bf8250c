"""Generated blocks in markdown files: tables and numbers written by the script that made them.

A block sits between two marker comments on lines of their own::

    <!-- begin: NAME -->
    ...generated text...
    <!-- end: NAME -->

:func:`replace_block` swaps what lies between them for a new body and leaves the rest of the file
(the prose) alone; :func:`write_blocks` does that for several blocks of one file and writes it
atomically. The studies' and benchmarks' scripts render their blocks from their committed JSON,
and a test re-renders every block and fails when the markdown has drifted from it.
"""
from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from bayesbeam.io.atomic import write_text

_MARKER = re.compile(r"^<!-- (begin|end): ([\w.-]+) -->$", re.MULTILINE)


def begin_marker(name: str) -> str:
    return f"<!-- begin: {name} -->"


def end_marker(name: str) -> str:
    return f"<!-- end: {name} -->"


def replace_block(text: str, name: str, body: str, source: str = "the markdown") -> str:
    """``text`` with the body of block ``name`` replaced by ``body``.

    ``source`` names the file in the error raised when the block's markers are missing, repeated
    or out of order.
    """
    start, stop = _span(text, name, source)
    return text[:start] + "\n" + body.strip("\n") + "\n" + text[stop:]


def read_block(text: str, name: str, source: str = "the markdown") -> str:
    """The body of block ``name`` (without its markers and the newlines next to them)."""
    start, stop = _span(text, name, source)
    return text[start:stop].strip("\n")


def block_names(text: str) -> list[str]:
    """Names of the blocks in ``text``, in order (each begin marker once)."""
    return [m.group(2) for m in _MARKER.finditer(text) if m.group(1) == "begin"]


def write_blocks(path, blocks: dict[str, str]) -> Path:
    """Replace the blocks ``{name: body}`` of the markdown file ``path``; written atomically, and only
    when something changed (an unchanged file keeps its modification time)."""
    path = Path(path)
    old = path.read_text(encoding="utf-8")
    new = old
    for name, body in blocks.items():
        new = replace_block(new, name, body, str(path))
    return write_text(path, new) if new != old else path


def write_files(files: dict) -> list[Path]:
    """:func:`write_blocks` for every ``{path: {name: body}}`` of a script's generated text."""
    return [write_blocks(path, blocks) for path, blocks in files.items()]


def markdown_table(head: list[str], rows: list[list[str]]) -> str:
    """A pipe table: header, separator and one line per row (cells as given)."""
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for row in rows:
        if len(row) != len(head):
            raise ValueError(f"table row {row!r} has {len(row)} cells, the header {len(head)}")
        lines.append("| " + " | ".join(row) + " |")
    return "\n".join(lines)


def significant(value: float, digits: int = 4) -> str:
    """``value`` to ``digits`` significant digits, positional between 1e-4 and 1e6 (``1000``, not
    ``1e+03``), in exponent form outside."""
    if value and 1e-4 <= abs(value) < 1e6:
        return np.format_float_positional(value, precision=digits, unique=False, fractional=False, trim="-")
    return f"{value:.{digits}g}"


def resolving_digits(q: dict) -> int:
    """Significant digits that resolve a posterior summary's 90% interval (``q05``, ``q50``, ``q95``):
    three, plus one per decade the median stands above the interval's width."""
    width = q["q95"] - q["q05"]
    ratio = abs(q["q50"]) / width if width > 0 and q["q50"] else 1.0
    return min(8, 3 + max(0, int(np.floor(np.log10(ratio)))))


def interval_ends(low: float, high: float, digits: int = 4) -> tuple[str, str]:
    """``low`` and ``high`` to ``digits`` significant digits, or to as many more (up to 8) as make
    two different values read differently (44.2791 and 44.2803 read 44.279 and 44.280, not 44.28
    twice)."""
    while digits < 8 and low != high and significant(low, digits) == significant(high, digits):
        digits += 1
    return significant(low, digits), significant(high, digits)


def median_and_interval(q: dict) -> str:
    """'median [q05, q95]' of a posterior summary, to :func:`resolving_digits`."""
    digits = resolving_digits(q)
    return f"{significant(q['q50'], digits)} [{significant(q['q05'], digits)}, {significant(q['q95'], digits)}]"


def _span(text: str, name: str, source: str) -> tuple[int, int]:
    """(end of the begin marker's line, start of the end marker's line) of block ``name``."""
    begins = [m for m in _MARKER.finditer(text) if m.groups() == ("begin", name)]
    ends = [m for m in _MARKER.finditer(text) if m.groups() == ("end", name)]
    pair = f"'{begin_marker(name)}' and '{end_marker(name)}'"
    if not begins or not ends:
        missing = " and ".join(m for m, found in ((begin_marker(name), begins), (end_marker(name), ends)) if not found)
        raise ValueError(f"{source}: no {missing} line: add the pair {pair}, each on a line of its own, "
                         f"where the generated text belongs")
    if len(begins) > 1 or len(ends) > 1:
        raise ValueError(f"{source}: block '{name}' is marked more than once: keep one pair {pair}")
    if ends[0].start() < begins[0].end():
        raise ValueError(f"{source}: '{end_marker(name)}' comes before '{begin_marker(name)}': swap them")
    return begins[0].end(), ends[0].start()
