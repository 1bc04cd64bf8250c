"""emcee's HDF5 chain file, written a block of steps at a time.

emcee's :class:`~emcee.backends.HDFBackend` opens the file three times per step (its shape, its
blobs, the write): on a model whose likelihood takes a millisecond that is half of a fit's time.
:class:`BufferedHDFBackend` keeps the steps in memory and writes them together, every
:data:`FLUSH_STEPS` steps or :data:`FLUSH_SECONDS` seconds, and before anything reads the file
(emcee's convergence checks, ``get_chain``, ``iteration``). Each write stores the random state of
its last step, as emcee's does per step, so a run killed between writes resumes from the last
written step and continues exactly as the uninterrupted run: it loses at most the steps since.
"""
from __future__ import annotations

import time

import emcee
import numpy as np

#: steps kept in memory at most before they are written
FLUSH_STEPS = 50
#: ... and seconds: a slow model's steps are not held longer than this
FLUSH_SECONDS = 10.0


class BufferedHDFBackend(emcee.backends.HDFBackend):
    """:class:`emcee.backends.HDFBackend` whose ``save_step`` buffers; the file is the same."""

    def __init__(self, filename, *args, **kwargs):
        super().__init__(filename, *args, **kwargs)
        self._pending: list[tuple] = []
        self._written_at = time.monotonic()

    def save_step(self, state, accepted):
        blobs = None if state.blobs is None else np.copy(state.blobs)
        self._pending.append((np.copy(state.coords), np.copy(state.log_prob), blobs, np.copy(accepted),
                              state.random_state))
        if len(self._pending) >= FLUSH_STEPS or time.monotonic() - self._written_at >= FLUSH_SECONDS:
            self.flush()

    def flush(self) -> None:
        """Write the buffered steps (none: nothing happens)."""
        if not self._pending:
            return
        steps, self._pending = self._pending, []
        with super().open("a") as f:        # the parent's open: this class's would flush again
            g = f[self.name]
            start = int(g.attrs["iteration"])
            stop = start + len(steps)
            g["chain"][start:stop] = np.stack([s[0] for s in steps])
            g["log_prob"][start:stop] = np.stack([s[1] for s in steps])
            if steps[0][2] is not None:
                g["blobs"][start:stop] = np.stack([s[2] for s in steps])
            g["accepted"][:] += np.sum([s[3] for s in steps], axis=0)
            for i, value in enumerate(steps[-1][4]):
                g.attrs[f"random_state_{i}"] = value
            g.attrs["iteration"] = stop
        self._written_at = time.monotonic()

    def open(self, mode="r"):
        # every read (and emcee's own writes: grow, reset) sees the buffered steps written first
        self.flush()
        return super().open(mode)
