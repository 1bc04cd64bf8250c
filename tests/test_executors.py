"""Executors: the same jobs give the same results serially, in local processes and on Dask, and
advance a progress bar as each job finishes."""
import io

import numpy as np
import pytest

from bayesbeam.comparison import CompareConfig, compare
from bayesbeam.executors import DaskExecutor, LocalExecutor, SerialExecutor, get_executor
from bayesbeam.inference.fit import FitConfig
from bayesbeam.progress import Progress
from tests.inference import cases


def square(x):
    return x * x


@pytest.fixture(scope="module")
def cluster():
    import distributed  # a dependency of bayesbeam itself: missing fails, never skips
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=None) as c:
        yield c


def test_get_executor_reads_the_command_line_value():
    assert isinstance(get_executor("serial"), SerialExecutor)
    assert isinstance(get_executor("local", processes=1), SerialExecutor)
    with pytest.raises(ValueError, match="tcp://host:8786"):
        get_executor("cluster-please")


def test_local_processes_keep_the_order():
    executor = LocalExecutor(2)
    try:
        assert executor.map(square, range(7)) == [x * x for x in range(7)]
    finally:
        executor.close()


@pytest.mark.parametrize("processes", [1, 2])
def test_a_bar_advances_once_per_finished_job(processes):
    executor = get_executor("local", processes)
    out = io.StringIO()
    try:
        with Progress(file=out).stage("squares", 7) as bar:
            assert executor.map(square, range(7), bar=bar) == [x * x for x in range(7)]
            assert bar.done == 7
    finally:
        executor.close()
    assert "squares" in out.getvalue() and "7/7" in out.getvalue()


@pytest.mark.parametrize("processes", [1, 2])
def test_done_hears_of_each_job_with_its_index_and_result_as_it_finishes(processes):
    executor = get_executor("local", processes)
    heard = []
    try:
        assert executor.map(square, range(7), done=lambda i, r: heard.append((i, r))) == [x * x for x in range(7)]
    finally:
        executor.close()
    assert sorted(heard) == [(x, x * x) for x in range(7)]


def test_done_hears_of_dask_jobs_too(cluster):
    heard = []
    executor = DaskExecutor(cluster.scheduler_address)
    try:
        assert executor.map(square, range(5), done=lambda i, r: heard.append((i, r))) == [x * x for x in range(5)]
    finally:
        executor.close()
    assert sorted(heard) == [(x, x * x) for x in range(5)]


#: a program that starts a local worker, prints its pid, then keeps it busy with a long job
_ORPHAN = """
import os, time
from bayesbeam.executors import LocalExecutor

def pid(_):
    return os.getpid()

if __name__ == "__main__":
    executor = LocalExecutor(1)
    print(executor.map(pid, [0])[0], flush=True)
    executor.map(time.sleep, [120])
"""


def test_a_local_worker_ends_with_the_process_that_started_it(tmp_path):
    """The starting process is killed (SIGKILL: no clean-up runs) while its worker is in a 120 s
    job: the worker must be gone well before its 120 s job would end (it checks for its parent every
    PARENT_POLL = 1 s), not compute on as an orphan. The wait is a liveness bound, not a timing
    claim: 60 s leaves any loaded machine room and still ends an hour before an orphan would."""
    import os
    import signal
    import subprocess
    import sys
    import time

    script = tmp_path / "orphan.py"
    script.write_text(_ORPHAN)
    parent = subprocess.Popen([sys.executable, str(script)], stdout=subprocess.PIPE, text=True)
    try:
        worker = int(parent.stdout.readline())
        time.sleep(0.5)                                   # the long job is under way
        os.kill(parent.pid, signal.SIGKILL)
        parent.wait()
        deadline = time.monotonic() + 60.0
        while time.monotonic() < deadline and _alive(worker):
            time.sleep(0.1)
        alive = _alive(worker)
    finally:
        parent.kill()
    if alive:
        os.kill(worker, signal.SIGKILL)
    assert not alive


def _alive(pid: int) -> bool:
    """Whether process pid exists and is not a zombie (an exited child its parent has not reaped)."""
    try:
        with open(f"/proc/{pid}/stat") as stat:
            return stat.read().split(") ")[-1][0] != "Z"
    except FileNotFoundError:
        return False


@pytest.mark.slow
def test_a_comparison_on_a_dask_cluster_equals_the_serial_one(cluster):
    """Every job is seeded from the comparison's seed, not from where it runs: bit-identical."""
    rec, _ = cases.simulated("q1", seed=3, fs=256.0)
    config = CompareConfig(FitConfig(n_intervals=6), repeats=2, replicates=10)
    _, serial = compare(rec, ["air", "q1"], config, SerialExecutor())
    executor = get_executor(cluster.scheduler_address)
    assert isinstance(executor, DaskExecutor) and executor.workers == 2
    out = io.StringIO()
    try:
        _, dask = compare(rec, ["air", "q1"], config, executor, log=Progress(file=out))
    finally:
        executor.close()
    assert "evidence (SMC)" in out.getvalue() and "4/4" in out.getvalue()     # 2 models x 2 repeats
    assert dask["ranking"] == serial["ranking"]
    for m in ("air", "q1"):
        assert dask["models"][m]["log_evidence"] == serial["models"][m]["log_evidence"]
        np.testing.assert_array_equal(dask["models"][m]["evidence"]["repeats"], serial["models"][m]["evidence"]["repeats"])
