"""The one error type the recording reader raises."""

from __future__ import annotations

from os import PathLike


class RecordingError(ValueError):
    """A recording that cannot be used, with where it went wrong and how to fix it.

    Attributes
    ----------
    file : str
        Path of the offending file (``beam.toml`` or the CSV).
    where : str
        The TOML key (``[[sensor]] #2 .location``) or the CSV place
        (``line 17, column "force"``); ``file`` when the whole file is at fault.
    problem : str
        What is wrong, without a final full stop.
    fix : str
        One sentence saying what to change.

    The message reads ``"{file}: {where}: {problem}. Fix: {fix}"``.
    """

    def __init__(self, file: str | PathLike, where: str, problem: str, fix: str):
        self.file = str(file)
        self.where = where
        self.problem = problem
        self.fix = fix
        super().__init__(f"{self.file}: {where}: {problem}. Fix: {fix}")

    def __reduce__(self):
        # The default pickling replays __init__ with the message alone, which fails;
        # worker pools (e.g. a parallel sampler) need the error to cross processes.
        return (type(self), (self.file, self.where, self.problem, self.fix))
