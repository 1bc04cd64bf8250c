"""What a long run tells the person waiting for it: one bar per stage with the time left, and notes.

A :class:`Progress` is what the commands and the Python API hand down as ``log``: called with a
line of text it prints a note (above any open bar); :meth:`Progress.stage` opens a bar for a
stage of countable work (models optimised, SMC runs, emcee steps). Bars are ``tqdm.auto``'s: a
widget in a Jupyter notebook (with ipywidgets installed; text bars without it), a redrawn line on
a terminal, a few plain lines in a log file;
tqdm's estimate of the time left is the rate so far times the work left, so a stage whose
total is not known in advance (an emcee chain stops when it is long enough) updates its total as
the estimate of what is needed improves (:meth:`Bar.retotal`).

``Progress(enabled=False)`` (``--quiet``, ``progress=False``) prints nothing; code that takes
``log=None`` uses :data:`SILENT`.
"""
from __future__ import annotations

import importlib.util
import sys
from contextlib import contextmanager

# in a notebook tqdm.auto draws widgets, which need ipywidgets; without it, it falls back to text
# bars and warns on every import: take the text bars directly then
if importlib.util.find_spec("ipywidgets") is not None:
    from tqdm.auto import tqdm
else:
    from tqdm import tqdm


class Bar:
    """One stage's bar: ``advance(n)`` as work is done, ``retotal(total)`` when the work needed is
    better known, ``describe(text)`` for the figures shown after the count."""

    def __init__(self, bar):
        self._bar = bar

    def advance(self, n: int = 1) -> None:
        self._bar.update(n)

    def retotal(self, total: int) -> None:
        self._bar.total = max(int(total), self._bar.n)
        self._bar.refresh()

    def describe(self, text: str) -> None:
        self._bar.set_postfix_str(text, refresh=True)

    @property
    def done(self) -> int:
        return int(self._bar.n)


class Progress:
    """Notes and stage bars on ``file`` (default stderr); nothing at all when not ``enabled``."""

    def __init__(self, enabled: bool = True, file=None, note=None):
        self.enabled = enabled
        self.file = file
        self._note = note

    def __call__(self, text: str) -> None:
        """A note: one line, printed above any open bar (or handed to ``note``)."""
        if self._note is not None:
            self._note(text)
        elif self.enabled:
            tqdm.write(f"  {text}", file=self.file or sys.stderr)

    @contextmanager
    def stage(self, description: str, total: int, unit: str = "job"):
        """A bar for ``total`` units of ``description``'s work, closed when the block ends."""
        bar = tqdm(total=total, desc=f"  {description}", unit=f" {unit}", file=self.file or sys.stderr,
                   disable=not self.enabled, dynamic_ncols=True, leave=True, mininterval=0.5)
        try:
            yield Bar(bar)
        finally:
            bar.close()


#: the progress of code called with ``log=None``
SILENT = Progress(enabled=False)


def as_progress(log) -> Progress:
    """``log`` as a :class:`Progress`: itself; :data:`SILENT` for None; a callable taking a line of
    text gets the notes and no bars."""
    if log is None or isinstance(log, Progress):
        return log or SILENT
    return Progress(enabled=False, note=log)
