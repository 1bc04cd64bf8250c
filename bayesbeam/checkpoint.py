"""Steps of a long run saved as they finish, so that a run killed part-way resumes where it stopped.

A :class:`Checkpoint` keeps the result of each expensive step (a comparison, a wave of
optimisations, each SMC run of a comparison as it finishes: :meth:`Checkpoint.map`) in its
folder, in a file named by the step and the SHA-256 of its inputs (the models, their starting
values, the rivals' evidence; a run's seed and reference density). The run's identity (the recording's
fingerprint and every setting the numbers depend on) is written beside them, in
``identity.json``. Every random draw of a run is seeded from its settings, so a resumed run asks
for the same steps with the same inputs in the same order: a step whose file exists is read back
instead of run, and the run goes on with the numbers the killed one had. A step with other inputs
has another file name and runs.

Resuming with another identity is refused (ValueError naming ``identity.json``, the setting that
differs and the fix): the saved steps are another run's. A run that does not resume clears the
folder first. The files are pickles written to a temporary name and moved into place, so a run
killed while writing leaves no half file; unpickling runs code, so resume only from a folder your
own run wrote.
"""
from __future__ import annotations

import hashlib
import json
import pickle
from pathlib import Path

from bayesbeam.io.atomic import atomic_write, write_text

IDENTITY = "identity.json"


class Checkpoint:
    """The steps saved in ``folder`` for the run ``identity`` (a JSON-ready dict); ``resume``: read
    back the steps found there (else the folder is cleared). ``log``: a callable taking a line of
    text, told of each step read back."""

    def __init__(self, folder, identity: dict, resume: bool = False, log=None):
        self.folder = Path(folder)
        self.identity = json.loads(json.dumps(identity, default=_plain))
        self.say = log or (lambda _text: None)
        self.read_back = 0
        file = self.folder / IDENTITY
        if resume and file.is_file():
            _check_identity(file, json.loads(file.read_text()), self.identity)
        else:
            if resume:
                self.say(f"nothing to resume in {self.folder}: starting from the beginning")
            remove(self.folder)

    def step(self, name: str, inputs, run):
        """``run()``'s result for the step ``name`` with ``inputs`` (JSON-ready): read back when this
        folder holds it, else run and saved."""
        path = self._path(name, inputs)
        if path.is_file():
            self.say(f"{name} read back from {path}")
            return self._read(path)
        result = run()
        self._save(path, result)
        return result

    def map(self, executor, fn, jobs: list, inputs, bar=None) -> list:
        """``executor.map(fn, jobs)``, job i a step named by ``fn`` and ``inputs(i)``: those this
        folder holds are read back (``bar`` advanced for them), the others run and each is saved as
        it finishes, so that a kill loses only the jobs running then."""
        paths = [self._path(fn.__name__, inputs(i)) for i in range(len(jobs))]
        results = {i: self._read(p) for i, p in enumerate(paths) if p.is_file()}
        if results:
            self.say(f"{len(results)} of {len(jobs)} {fn.__name__} runs read back from {self.folder}")
        if bar is not None:
            for _ in results:
                bar.advance()
        todo = [i for i in range(len(jobs)) if i not in results]
        ran = executor.map(fn, [jobs[i] for i in todo], bar=bar, done=lambda k, r: self._save(paths[todo[k]], r))
        results.update(zip(todo, ran))
        return [results[i] for i in range(len(jobs))]

    def _path(self, name: str, inputs) -> Path:
        digest = hashlib.sha256(json.dumps(inputs, sort_keys=True, default=_plain).encode()).hexdigest()[:16]
        return self.folder / f"{name}-{digest}.pkl"

    def _save(self, path: Path, result) -> None:
        """Save a step's ``result``; the folder and its identity are written with the first (a run
        refused before any step leaves nothing behind)."""
        identity = self.folder / IDENTITY
        if not identity.is_file():
            self.folder.mkdir(parents=True, exist_ok=True)
            write_text(identity, json.dumps(self.identity, indent=1))
        data = pickle.dumps(result, protocol=pickle.HIGHEST_PROTOCOL)
        atomic_write(path, lambda temporary: temporary.write_bytes(data))

    def _read(self, path: Path):
        self.read_back += 1
        return pickle.loads(path.read_bytes())


class NoCheckpoint:
    """Nothing saved: each step runs."""

    read_back = 0

    @staticmethod
    def step(_name: str, _inputs, run):
        return run()

    @staticmethod
    def map(executor, fn, jobs: list, _inputs, bar=None) -> list:
        return executor.map(fn, jobs, bar=bar)


#: the checkpoint of a run that saves nothing
NOTHING_SAVED = NoCheckpoint()


def remove(folder) -> None:
    """Remove the steps saved in ``folder``, its identity, and the folder when nothing else is in it."""
    folder = Path(folder)
    if not folder.is_dir():
        return
    for path in [*folder.glob("*.pkl"), *folder.glob("*.tmp"), folder / IDENTITY]:
        path.unlink(missing_ok=True)
    if not any(folder.iterdir()):
        folder.rmdir()


def _plain(value):
    """JSON's fallback: numpy scalars and arrays as Python numbers and lists."""
    if hasattr(value, "tolist"):
        return value.tolist()
    raise TypeError(f"{type(value).__name__} is not an input a checkpoint can name")


def _check_identity(file: Path, saved: dict, own: dict) -> None:
    for key in sorted(set(saved) | set(own)):
        if saved.get(key) != own.get(key):
            raise ValueError(f"{file}: \"{key}\" is {saved.get(key)!r} there, {own.get(key)!r} in this run: the "
                             f"saved steps are another run's. Fix: resume with that run's recording and options, "
                             f"or start again (--overwrite instead of --resume)")
