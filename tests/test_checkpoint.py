"""bayesbeam.checkpoint: steps saved as they finish, read back on a resumed run, refused for another run.

A diagnosis killed part-way and resumed to the uninterrupted result: tests/test_diagnosis.py; the
command line's --resume: tests/cli/test_diagnose_command.py."""
import numpy as np
import pytest

from bayesbeam.checkpoint import IDENTITY, NOTHING_SAVED, Checkpoint, remove

RUN = {"recording": {"sha256": "ab12"}, "settings": "DiagnoseConfig(rounds=2)"}


def counted(value):
    """A step's work that counts its calls."""
    calls = []

    def run():
        calls.append(1)
        return value
    return run, calls


def test_a_step_runs_once_and_a_resumed_run_reads_it_back(tmp_path):
    run, calls = counted({"log_z": np.array([1.5, 2.5])})
    first = Checkpoint(tmp_path / "c", RUN).step("compare", {"models": ["q1"], "starts": {"EI": np.float64(3.9)}}, run)
    again = Checkpoint(tmp_path / "c", RUN, resume=True)
    second = again.step("compare", {"models": ["q1"], "starts": {"EI": 3.9}}, run)
    assert len(calls) == 1 and again.read_back == 1
    np.testing.assert_array_equal(second["log_z"], first["log_z"])
    # other inputs are another step: it runs
    again.step("compare", {"models": ["q1"], "starts": {"EI": 3.9000001}}, run)
    assert len(calls) == 2 and again.read_back == 1
    assert not list((tmp_path / "c").glob("*.tmp"))         # written to a temporary name, then moved


def test_a_run_that_does_not_resume_starts_from_nothing(tmp_path):
    run, calls = counted(1)
    Checkpoint(tmp_path / "c", RUN).step("optimise", {"models": ["q1"]}, run)
    Checkpoint(tmp_path / "c", RUN).step("optimise", {"models": ["q1"]}, run)
    assert len(calls) == 2


def test_resuming_where_nothing_was_saved_starts_and_says_so(tmp_path):
    said = []
    c = Checkpoint(tmp_path / "new", RUN, resume=True, log=said.append)
    assert "nothing to resume" in said[0]
    assert not (tmp_path / "new").exists()                  # a run refused before its first step leaves nothing
    c.step("compare", {}, lambda: 1)
    assert (tmp_path / "new" / IDENTITY).is_file()


@pytest.mark.parametrize("changed, key", [({"settings": "DiagnoseConfig(rounds=3)"}, "settings"),
                                          ({"recording": {"sha256": "cd34"}}, "recording"),
                                          ({"model": "q3"}, "model")])
def test_resuming_another_run_is_refused_naming_the_file_the_setting_and_the_fix(tmp_path, changed, key):
    Checkpoint(tmp_path / "c", RUN).step("compare", {}, lambda: 1)
    with pytest.raises(ValueError) as refused:
        Checkpoint(tmp_path / "c", {**RUN, **changed}, resume=True)
    message = str(refused.value)
    assert str(tmp_path / "c" / IDENTITY) in message and f'"{key}"' in message and "--overwrite" in message


def test_an_input_no_checkpoint_can_name_is_refused(tmp_path):
    with pytest.raises(TypeError, match="object"):
        Checkpoint(tmp_path / "c", RUN).step("compare", {"rival": object()}, lambda: 1)


def test_remove_leaves_what_is_not_a_checkpoints(tmp_path):
    c = Checkpoint(tmp_path / "c", RUN)
    c.step("compare", {}, lambda: 1)
    (tmp_path / "c" / "notes.txt").write_text("mine")
    remove(tmp_path / "c")
    assert [p.name for p in (tmp_path / "c").iterdir()] == ["notes.txt"]
    (tmp_path / "c" / "notes.txt").unlink()
    remove(tmp_path / "c")
    assert not (tmp_path / "c").exists()
    remove(tmp_path / "c")                                    # nothing there: nothing to do


def test_nothing_saved_runs_every_step():
    run, calls = counted(2)
    assert NOTHING_SAVED.step("compare", {}, run) == 2 and NOTHING_SAVED.step("compare", {}, run) == 2
    assert len(calls) == 2



#: the job the run is killed in (None: not killed)
KILLED_AT = 3


def _square_unless_killed(x):
    if x == KILLED_AT:
        raise KeyboardInterrupt
    return x * x


def test_map_saves_each_job_as_it_finishes_and_a_resumed_run_runs_only_the_rest(tmp_path, monkeypatch):
    import io
    import sys

    from bayesbeam.executors import SerialExecutor
    from bayesbeam.progress import Progress

    def inputs(i):
        return {"model": "q1", "seed": i}

    with pytest.raises(KeyboardInterrupt):
        Checkpoint(tmp_path, RUN).map(SerialExecutor(), _square_unless_killed, list(range(6)), inputs)
    assert len(list(tmp_path.glob("_square_unless_killed-*.pkl"))) == KILLED_AT     # jobs 0-2 saved
    monkeypatch.setattr(sys.modules[__name__], "KILLED_AT", None)
    executor, ran = SerialExecutor(), []
    real_map = executor.map
    executor.map = lambda fn, jobs, **kw: ran.extend(jobs) or real_map(fn, jobs, **kw)
    resumed = Checkpoint(tmp_path, RUN, resume=True)
    with Progress(file=io.StringIO()).stage("runs", 6) as bar:
        assert resumed.map(executor, _square_unless_killed, list(range(6)), inputs, bar=bar) == [x * x for x in range(6)]
        assert bar.done == 6
    assert ran == [3, 4, 5] and resumed.read_back == 3


def test_nothing_saved_maps_on_the_executor():
    from bayesbeam.executors import SerialExecutor

    assert NOTHING_SAVED.map(SerialExecutor(), abs, [-1, 2], None) == [1, 2]
