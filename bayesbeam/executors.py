"""Where independent jobs run: this process, local worker processes, MPI ranks or a Dask cluster.

``get_executor(None | "local" | "serial" | "mpi" | "tcp://host:8786", processes)`` returns an
object with ``map(fn, *iterables, bar=None, done=None) -> list`` (results in order; ``bar``, a
:class:`bayesbeam.progress.Bar`, advances as each job finishes, in whatever order, and
``done(index, result)`` is called then, in this process: a checkpoint saves the result there) and
``close()``. Jobs must be module-level
functions of picklable arguments. Local processes are spawned (not forked), so a job sees a fresh
interpreter and BLAS is limited to one thread per worker (two workers on two cores, not two
workers each starting two BLAS threads). A local worker exits when the process that started it
ends, however it ends (killed by a batch scheduler, say): no orphan keeps computing a job
nobody will collect.
"""
from __future__ import annotations

import os
import threading
import time
from concurrent.futures import ProcessPoolExecutor
from concurrent.futures import as_completed as futures_as_completed

#: address schemes of a Dask scheduler
DASK_SCHEMES = ("tcp://", "tls://", "inproc://", "ucx://")
#: the executors named by a word (the others by a Dask scheduler address)
NAMED = ("serial", "local", "mpi")


class SerialExecutor:
    """Runs jobs one after another in this process (the default for one core or one job)."""

    workers = 1

    def map(self, fn, *iterables, bar=None, done=None) -> list:
        results = []
        for i, args in enumerate(zip(*iterables)):
            results.append(fn(*args))
            _finished(i, results[-1], bar, done)
        return results

    def close(self) -> None:
        pass


class LocalExecutor:
    """A pool of ``processes`` spawned worker processes on this machine."""

    def __init__(self, processes: int):
        import multiprocessing as mp

        self.workers = processes
        # spawned workers inherit the environment: one BLAS thread each (this process has
        # loaded its BLAS already, so it is unaffected)
        for name in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
            os.environ.setdefault(name, "1")
        self._pool = ProcessPoolExecutor(processes, mp_context=mp.get_context("spawn"),
                                         initializer=_exit_with_parent, initargs=(os.getpid(),))

    def map(self, fn, *iterables, bar=None, done=None) -> list:
        return _gather([self._pool.submit(fn, *args) for args in zip(*iterables)], futures_as_completed, bar, done)

    def close(self) -> None:
        self._pool.shutdown()


def _finished(index: int, result, bar, done) -> None:
    """Job ``index`` has finished with ``result``: tell ``done``, advance ``bar``."""
    if done is not None:
        done(index, result)
    if bar is not None:
        bar.advance()


def _gather(futures: list, completed, bar, done=None) -> list:
    """The futures' results in order, :func:`_finished` as each finishes (``completed``: the
    library's as_completed)."""
    if bar is not None or done is not None:
        index = {f: i for i, f in enumerate(futures)}
        for future in completed(futures):
            _finished(index[future], future.result(), bar, done)
    return [f.result() for f in futures]


#: how often a local worker checks that the process that started it is still there (s)
PARENT_POLL = 1.0


def _exit_with_parent(parent: int) -> None:
    """Start a watch in this worker: once its parent is gone (the worker is handed to another
    process), end the worker at once, whatever job it is in."""
    def watch():
        while os.getppid() == parent:
            time.sleep(PARENT_POLL)
        os._exit(1)

    threading.Thread(target=watch, daemon=True, name="exit-with-parent").start()


class DaskExecutor:
    """Jobs on a ``dask.distributed`` cluster given by its scheduler address (or a Client)."""

    def __init__(self, address):
        from distributed import Client

        self._own = not hasattr(address, "submit")
        self.client = Client(address) if self._own else address
        self.workers = max(1, sum(self.client.nthreads().values()))

    def map(self, fn, *iterables, bar=None, done=None) -> list:
        from distributed import as_completed

        return _gather(self.client.map(fn, *iterables, pure=False), as_completed, bar, done)

    def close(self) -> None:
        if self._own:
            self.client.close()


class MPIExecutor:
    """Jobs on the worker ranks of an MPI launch (``mpi4py.futures``)."""

    def __init__(self):
        self._pool = mpi_pool_class()()

    def map(self, fn, *iterables, bar=None, done=None) -> list:
        return _gather([self._pool.submit(fn, *args) for args in zip(*iterables)], futures_as_completed, bar, done)

    def close(self) -> None:
        self._pool.shutdown()


def mpi_pool_class():
    """``mpi4py.futures.MPIPoolExecutor``; ValueError naming the fix when mpi4py is missing."""
    try:
        from mpi4py.futures import MPIPoolExecutor
    except ImportError:
        raise ValueError("--executor mpi needs mpi4py (pip install mpi4py) and an MPI launch, e.g. "
                         "mpiexec -n 8 python -m mpi4py.futures -m bayesbeam.cli COMMAND ...") from None
    return MPIPoolExecutor


def get_executor(spec=None, processes: int | None = None):
    """An executor from a command-line ``--executor`` value (see module docstring)."""
    if spec is not None and not isinstance(spec, str):
        return DaskExecutor(spec)
    if spec and spec.startswith(DASK_SCHEMES):
        return DaskExecutor(spec)
    if spec == "mpi":
        return MPIExecutor()
    if spec is not None and spec not in NAMED:
        raise ValueError(f"--executor {spec!r}: expected 'serial', 'local', 'mpi' or a Dask scheduler address "
                         f"such as tcp://host:8786")
    processes = processes or os.cpu_count() or 1
    return SerialExecutor() if spec == "serial" or processes == 1 else LocalExecutor(processes)

