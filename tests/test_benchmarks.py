"""The benchmark scripts (benchmarks/*.py) still fit the package's API: each is imported, and the code
of each that calls bayesbeam runs once, on a record cut to a fraction of a second.

The benchmarks reach into private names (effects.py calls ``BeamModel._output``, reads
``SecondOrderSystem._modal_split`` and imports ``bayesbeam.inference.likelihood._marginal``;
from_comparison.py and nonlinear_long.py build their recordings with tests/acceptance/cases.py's
``_setting`` and ``_nominal``), and nothing else runs them: a refactor broke them silently, and
the next person to run one met the AttributeError or TypeError minutes into it. What is checked
here is that every call still fits, not any number a benchmark prints (its tables come out
meaningless at these sizes). Shrunk, for one test at a time (monkeypatch):

- the timing loops call the timed function once (their own signatures are kept, see
  :func:`_forcing`), and the tables run at one size;
- the recordings are cut to their first samples, as few as each script's arithmetic allows;
- the long jobs (``compare``, ``diagnose``, a worker-process pool) are replaced by stand-ins that
  check each call against the real function's signature and return a committed result of it (a
  study's comparison.json or diagnosis.json), so the script's code around them runs as well.

Nothing is written into the repository: tables.py's results and README, profiles.py's output and
every temporary folder go to ``tmp_path``.
"""
import importlib
import inspect
import json
import sys
import tempfile
import time
from dataclasses import replace
from multiprocessing.pool import ThreadPool
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from bayesbeam.inference import sampler
from bayesbeam.inference.backend import BufferedHDFBackend
from bayesbeam.inference.posterior import BATCH_VARIABLE

ROOT = Path(__file__).resolve().parents[1]
BENCHMARKS = ROOT / "benchmarks"
SCRIPTS = sorted(path.stem for path in BENCHMARKS.glob("*.py"))
#: modules a benchmark adds to sys.modules besides the scripts: effects.py's baseline integrator from git
LOADED_BY_SCRIPTS = ("nonlinear_baseline",)
#: set to 1 by the scripts at import (one BLAS thread); pinned here so that the test restores them
THREAD_VARIABLES = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")
#: what the stand-ins of compare and diagnose return: their committed outputs
COMPARISON = ROOT / "studies" / "model_comparison" / "paper_q3_hammer" / "comparison.json"
DIAGNOSIS = ROOT / "studies" / "concealed_effects" / "out" / "paper_root_compliance" / "diagnosis.json"
#: the scripts a test below runs beyond their import; tables.py's rendering is run by
#: tests/studies/test_generated_tables.py and its ``record`` by every script here
RUN_HERE = ("_common", "basis", "batch", "catalogue", "chain_file", "compare", "diagnose", "effects", "forward",
            "from_comparison", "nonlinear_long", "ppc", "profiles", "sampling", "tables")


@pytest.fixture
def load_script(monkeypatch, tmp_path):
    """``load_script(name)`` imports benchmarks/<name>.py afresh, as its command line would (benchmarks/
    and the repository first on sys.path), and everything the import changes is undone afterwards:
    sys.path (effects.py, forward.py and tables.py insert into it), the thread variables, and
    sys.modules (the scripts' bare names, ``compare``, ``tables``, ... would otherwise stay, and a
    later test would run the old copy of a script edited in between)."""
    monkeypatch.syspath_prepend(str(ROOT))
    monkeypatch.syspath_prepend(str(BENCHMARKS))
    monkeypatch.setattr(sys, "dont_write_bytecode", True)     # no __pycache__ in benchmarks/
    for name in THREAD_VARIABLES:
        monkeypatch.setenv(name, "1")
    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))   # from_comparison's and effects.py's mkdtemp
    names = (*SCRIPTS, *LOADED_BY_SCRIPTS)
    saved = {name: sys.modules.pop(name) for name in names if name in sys.modules}

    def load(name: str):
        module = importlib.import_module(name)
        tables = sys.modules.get("tables")      # imported by nearly every script
        if tables is not None:
            monkeypatch.setattr(tables, "RESULTS", tmp_path / "results")
            monkeypatch.setattr(tables, "README", tmp_path / "README.md")
        return module

    yield load
    for name in names:
        sys.modules.pop(name, None)
    sys.modules.update(saved)


# ----------------------------------------------------------------------------- shrinking
def _forcing(real, **forced):
    """``real`` called with the arguments ``forced`` whatever its caller passed (e.g. ``repeat=1``
    of a timing loop); a call that does not fit ``real``'s signature fails as it would unpatched."""
    signature = inspect.signature(real)
    # a renamed parameter would drop out of bound.kwargs unseen, and the shrinking with it
    unknown = set(forced) - set(signature.parameters)
    if unknown:
        raise TypeError(f"{real.__name__} has no parameter {sorted(unknown)}: update the shrinking here")

    def call(*args, **kwargs):
        bound = signature.bind(*args, **kwargs)
        bound.arguments.update(forced)
        return real(*bound.args, **bound.kwargs)
    return call


def _ms_of_one_call(fn, clock=time.process_time) -> float:
    """A timing of one call in ms, never 0 (the scripts divide by their timings)."""
    start = clock()
    fn()
    return max(1e3 * (clock() - start), 1e-6)


def _shortened(rec, samples: int):
    """The recording's first ``samples`` samples."""
    cut = slice(0, samples)
    return replace(rec, time=rec.time[cut], signals=rec.signals[cut],
                   force=None if rec.force is None else rec.force[cut])


def _loading_short(load, samples: int, keep=()):
    """``load`` (a load_recording) giving the first ``samples`` samples of every recording but those in ``keep``."""
    kept = {str(path) for path in keep}

    def load_short(path):
        rec = load(path)
        return rec if str(path) in kept else _shortened(rec, samples)
    return load_short


def _timing_once(monkeypatch, common) -> None:
    """_common.best_time (effects.py, forward.py, nonlinear_long.py) times one call."""
    monkeypatch.setattr(common, "best_time", _forcing(common.best_time, number=1, repeat=1))


# ----------------------------------------------------------------------------- stand-ins of long jobs
def _stand_in(real, result):
    """Instead of ``real`` (minutes of fitting): bind each call to ``real``'s signature (a TypeError
    where ``real`` would raise one), keep it in ``.calls``, and return ``result(*args, **kwargs)``."""
    signature = inspect.signature(real)

    def call(*args, **kwargs):
        call.calls.append(signature.bind(*args, **kwargs))
        return result(*args, **kwargs)
    call.calls = []
    return call


def _committed_comparison(*_args, **_kwargs):
    """compare's (results, summary): the committed comparison of paper_q3_hammer."""
    summary = json.loads(COMPARISON.read_text())
    return dict.fromkeys(summary["models"]), summary


def _committed_diagnosis(*_args, **_kwargs):
    """diagnose's Diagnosis, as far as the benchmarks read it: its committed diagnosis.json."""
    return SimpleNamespace(to_dict=lambda: json.loads(DIAGNOSIS.read_text()))


def _thread_pool(posterior, processes):
    """local_pool's pool in threads of this process: the same initializer and worker functions,
    without seconds of spawning processes that import bayesbeam."""
    return ThreadPool(processes, initializer=sampler.init_worker, initargs=(posterior,))


# ----------------------------------------------------------------------------- the tests
@pytest.mark.parametrize("name", SCRIPTS)
def test_every_benchmark_imports(load_script, name):
    """Catches a name the script imports that is gone: ``from bayesbeam... import X`` at module level,
    the tests/ helpers (``tests.acceptance.cases._nominal``), another script's function
    (``from diagnose import timed_diagnose``)."""
    load_script(name)


def test_every_benchmark_is_run_here():
    """A new script in benchmarks/ gets a run below, not only its import: its calls into the package
    are what breaks."""
    assert sorted(RUN_HERE) == SCRIPTS, "add a test that runs the new script's code, and list it in RUN_HERE"


def test_effects_runs_every_table(load_script, monkeypatch):
    """effects.py --quick, tables 1 to 3, at N = 16 on 0.25 s of the hammer record (table 1c keeps the
    real record its window needs), solve_ivp only over the samples before t = 0.

    Catches what broke it before: ``BeamModel._output``'s signature (table 1d), the cached properties
    its ``prepare`` reads per transfer form (``_modal_split``, ``_modal_state_modes``, ``_band``,
    ``modal_damping``, ``_modal_memory``), ``likelihood._marginal`` and ``Likelihood._latent`` (1c),
    ``poles`` (1b), ``nonlinear.SUBSTEPS`` and ``integrate`` (2), nonlinear.py of commit BASELINE
    loaded from git against today's package (2b), the model's matrices in the solve_ivp baselines (3)."""
    effects = load_script("effects")
    _timing_once(monkeypatch, effects.c)
    monkeypatch.setattr(effects, "SIZES", (16,))
    monkeypatch.setattr(effects, "per_call", _forcing(effects.per_call, repeat=1))
    monkeypatch.setattr(effects, "interleaved_ms", _forcing(effects.interleaved_ms, repeat=1))
    # --quick compares the first 0.25 s (512 samples) with solve_ivp, so the record keeps them
    monkeypatch.setattr(effects, "load_recording", _loading_short(effects.load_recording, 512, keep=[effects.REAL]))
    monkeypatch.setattr(effects, "PRE", 2)

    def before_the_record(ivp):
        """solve_ivp from -PRE dt to 0 instead of seconds of BDF; the solution held after that."""
        def run(model, values, force, _t_end):
            displacement, elapsed, info = ivp(model, values, force, 0.0)
            return (lambda times: displacement(np.minimum(times, 0.0))), elapsed, info
        return run
    monkeypatch.setattr(effects, "ivp_drag", before_the_record(effects.ivp_drag))
    monkeypatch.setattr(effects, "ivp_friction", before_the_record(effects.ivp_friction))
    assert effects.main(["--quick"]) == 0
    # every table made its rows: none was left out by the shrinking
    assert sorted(effects.tables.MEASURED) == ["1", "1b", "1c", "1d", "2", "2b", "3"]


def test_common_builds_its_baselines_from_the_model(load_script):
    """_common.py's helpers on q2 (the memory kernel takes every branch) at N = 8: the state-space forms
    with and without the kernel, the approximate system and its transfer error, the exact documented
    response. Catches a change of ``SecondOrderSystem``'s constructor or fields (M, D, K, K_h,
    ``relaxation``, ``undamped``), ``transfer``'s arguments, ``model.ops.rows``, ``grid``, ``orders``."""
    c = load_script("_common")
    rec = _shortened(c.load_recording(c.RECORDING), 384)
    model = c.load_model("q2", 8, rec)
    system = model.system(c.PARAMS["q2"])
    kernel = c.sum_of_exponentials(c.PARAMS["q2"]["alpha"], c.PARAMS["q2"]["beta"], step=4.0)
    c.transfer_error(model, system, kernel)
    for memory in (None, kernel):
        space = c.state_space(model, system, memory, sparse_form=memory is not None)
        c.state_scale(system, space, model.force, rec.dt, memory)
    force = c.BandLimitedForce(model.force, rec.dt)
    force.spline_error(8, 4)
    force.leak(4)
    exact = c.documented_response(model, system, 4)
    assert exact.shape == model.simulate(c.PARAMS["q2"]).shape
    c.in_band(exact, rec.fs)


def test_forward_runs_its_tables(load_script, monkeypatch):
    """forward.py --quick --no-effects on 384 samples (the in-band comparison skips 128 of them and
    its filter 131 more), q2's kernel as 9 exponentials instead of 52: bayesbeam against solve_ivp
    and pyyeti, every model at both sizes."""
    forward = load_script("forward")
    _timing_once(monkeypatch, forward.c)
    monkeypatch.setattr(forward, "load_recording", _loading_short(forward.load_recording, 384))
    monkeypatch.setattr(forward, "PRE", 4)
    monkeypatch.setattr(forward.c, "sum_of_exponentials", _forcing(forward.c.sum_of_exponentials, step=4.0))
    assert forward.main(["--quick", "--no-effects"]) == 0
    assert forward.pyyeti is not None, forward.PYYETI_ERROR     # a test dependency: its baselines ran


def test_basis_runs_its_tables(load_script, monkeypatch):
    """basis.py's three tables at one loose tolerance and two small grids: ``tip_body_betas``,
    ``BeamOperators``, ``SplineBasis(degree=)``, ``undamped_modes`` and ``BeamModel(degree=)``."""
    basis = load_script("basis")
    monkeypatch.setattr(basis, "TOLERANCES", (1e-2,))
    monkeypatch.setattr(basis, "GRIDS", {3: (8,), 5: (4,)})
    monkeypatch.setattr(basis, "REFERENCE", (5, 8))
    monkeypatch.setattr(basis, "CHECK", (5, 6))
    monkeypatch.setattr(basis, "ms_per_call", _ms_of_one_call)
    monkeypatch.setattr(basis, "load_recording", _loading_short(basis.load_recording, 512))
    assert basis.main([]) == 0


def test_batch_runs_its_tables(load_script, monkeypatch):
    """batch.py on 0.5 s (the least a 150 Hz fit takes): ``prepare``'s posterior, ``profile_noise``,
    ``coordinates``, ``log_prob_batch`` at both bands, and the SMC evidence runs (one model, 16
    particles) with ``laplace_reference``, ``find_optimum(start=)`` and ``smc``'s result's fields."""
    monkeypatch.setenv(BATCH_VARIABLE, "1")     # evidence_runs sets it and pops it: restored after a failure
    batch = load_script("batch")
    monkeypatch.setattr(batch, "load_recording", _loading_short(batch.load_recording, 1024))
    monkeypatch.setattr(batch, "best_time", _forcing(batch.best_time, repeats=1))
    monkeypatch.setattr(batch, "smc", _forcing(batch.smc, n_particles=16))
    evidence_runs = batch.evidence_runs

    def first_model_only(*args):
        with monkeypatch.context() as patch:
            patch.setattr(batch, "MODELS", dict(list(batch.MODELS.items())[:1]))
            return evidence_runs(*args)
    monkeypatch.setattr(batch, "evidence_runs", first_model_only)
    assert batch.main(["--sets", "2", "--n-intervals", "8"]) == 0


def test_sampling_runs_its_measurements(load_script, monkeypatch):
    """sampling.py --quick at N = 8 on 0.5 s, the pool in threads, emcee stopped at its first check
    (every ESS inflated): ``find_optimum``, ``initial_ball``, ``local_pool``'s signature,
    ``worker_log_prob``, ``burn_in`` and ``effective_sample_size``."""
    sampling = load_script("sampling")
    monkeypatch.setattr(sampler, "_WORKER_POSTERIOR", None)    # init_worker sets it in this process here
    monkeypatch.setattr(sampling, "load_recording", _loading_short(sampling.load_recording, 1024))
    monkeypatch.setattr(sampling, "evaluations_per_second",
                        lambda post, theta: 1e3 / _ms_of_one_call(lambda: post(theta)))
    monkeypatch.setattr(sampling, "CHECK_EVERY", 10)
    ess = sampling.effective_sample_size
    monkeypatch.setattr(sampling, "effective_sample_size", lambda *args: 1e6 * ess(*args))
    monkeypatch.setattr(sampling, "local_pool", _stand_in(sampling.local_pool, _thread_pool))
    assert sampling.main(["--n-intervals", "8", "--quick"]) == 0
    assert len(sampling.local_pool.calls) == 1


def test_ppc_runs_its_tables(load_script, monkeypatch):
    """ppc.py on 0.5 s, the optimum polished from the truth, 4 replicates per check, one committed
    study: ``decay_start``, ``era_modes(truncated)``, ``modes_in_band``, ``posterior_predictive_check``
    and its ``statistics`` and ``modes``, ``Likelihood.predict``, ``draw_noise``, ``projection``."""
    ppc = load_script("ppc")
    truth = json.loads((ppc.EXAMPLE / "truth.json").read_text())
    monkeypatch.setattr(ppc, "load_recording", _loading_short(ppc.load_recording, 1024))
    monkeypatch.setattr(ppc, "find_optimum", _forcing(ppc.find_optimum,
                                                      start={"EI": truth["beam_true"]["EI"], **truth["damping"]}))
    monkeypatch.setattr(ppc, "best_time", _forcing(ppc.best_time, repeats=1))
    monkeypatch.setattr(ppc, "posterior_predictive_check", _forcing(ppc.posterior_predictive_check, n_replicates=4))
    monkeypatch.setattr(ppc, "STUDIES", dict(list(ppc.STUDIES.items())[:1]))
    assert ppc.main([]) == 0


def test_chain_file_runs_and_compares_the_files(load_script, monkeypatch):
    """chain_file.py at 20 steps: ``prepare``, ``find_optimum(start=)``, ``run_emcee`` with and
    without a file, emcee's backend swapped in for the baseline and restored, the chains compared."""
    chain_file = load_script("chain_file")
    monkeypatch.setattr(chain_file, "STEPS", 20)
    assert chain_file.main([]) == 0
    assert sampler.BufferedHDFBackend is BufferedHDFBackend      # the baseline's swap undone
    assert chain_file.tables.MEASURED["chains_identical"]


def test_nonlinear_long_runs_with_compare_and_diagnose(load_script, monkeypatch):
    """nonlinear_long.py --compare --diagnose on a 1 s, 512 Hz reference release (tests/reference's
    ``record``, ``Release``, ``Noise``; tests/acceptance's ``_nominal``), one F_c: ``starting_rung``,
    ``prepare``, ``nonlinear.integrate(record=, substeps=)`` and its events; compare and diagnose stand in."""
    nonlinear_long = load_script("nonlinear_long")
    diagnose = load_script("diagnose")
    _timing_once(monkeypatch, nonlinear_long.c)
    monkeypatch.setattr(nonlinear_long, "record", _forcing(nonlinear_long.record, fs=512.0, duration=1.0))
    monkeypatch.setattr(nonlinear_long, "F_C_VALUES", (nonlinear_long.F_C_TRUE,))
    monkeypatch.setattr(nonlinear_long, "compare", _stand_in(nonlinear_long.compare, _committed_comparison))
    monkeypatch.setattr(diagnose, "diagnose", _stand_in(diagnose.diagnose, _committed_diagnosis))
    assert nonlinear_long.main(["--compare", "--diagnose"]) == 0
    assert (len(nonlinear_long.compare.calls), len(diagnose.diagnose.calls)) == (1, 2)


@pytest.mark.parametrize("argv", [[], ["--k-theta", "4000"]], ids=["plain", "root_spring"])
def test_from_comparison_runs(load_script, monkeypatch, tmp_path, argv):
    """from_comparison.py on a 0.25 s, 256 Hz two-sensor hammer test, compare and diagnose standing in:
    catches tests/acceptance/cases.py's ``_setting``, ``_nominal`` and ``DAMPING`` and the reference
    simulator's ``record`` (with a root spring's ``effects``), ``diagnose(from_comparison=)``."""
    script = load_script("from_comparison")
    for name, result in (("compare", _committed_comparison), ("diagnose", _committed_diagnosis),
                         ("write_comparison", lambda *_args: [])):
        monkeypatch.setattr(script, name, _stand_in(getattr(script, name), result))
    assert script.main(["--fs", "256", "--duration", "0.25", *argv]) == 0
    assert [call.arguments["rec"].signals.shape for call in script.compare.calls] == [(64, 2)] * 2
    reused = script.diagnose.calls[1].arguments["from_comparison"]
    assert Path(reused).parent == tmp_path                  # mkdtemp's folder, not one in the repository
    assert script.write_comparison.calls[0].arguments["out_dir"] == reused


@pytest.mark.parametrize("argv", [[], ["--max-frequency", "150", "--degree", "5", "--min-moved", "0.85"]],
                         ids=["default_band", "150_Hz"])
def test_compare_runs(load_script, monkeypatch, argv):
    """compare.py with compare standing in: its ``configs`` (``FitConfig(degree=)``, ``CompareConfig``'s
    ``repeats``, ``early_stop``, ``min_moved``), the executor, and its reading of the summary."""
    script = load_script("compare")
    monkeypatch.setattr(script, "compare", _stand_in(script.compare, _committed_comparison))
    assert script.main(argv) == 0
    assert len(script.compare.calls) == 2


@pytest.mark.parametrize("argv", [[], ["--model", "q1"], ["--concealed", "paper_quadratic_drag"]],
                         ids=["by_comparison", "model", "concealed"])
def test_diagnose_runs(load_script, monkeypatch, argv):
    """diagnose.py with diagnose standing in: its ``configs`` (``DiagnoseConfig``, ``CompareConfig``'s
    fields), ``recording`` of the example and of a concealed-effects recording, the summary it reads."""
    script = load_script("diagnose")
    monkeypatch.setattr(script, "diagnose", _stand_in(script.diagnose, _committed_diagnosis))
    assert script.main(argv) == 0
    assert len(script.diagnose.calls) == 2


def test_diagnoses_agree_up_to_damping_models_the_recheck_could_not_rank(load_script):
    """diagnose.py's agreement of the baseline and current paths: the same final effects, and each
    final damping model is the other's or tied with the other's re-check best (q1 and q3 with a root
    spring, tied on paper_rootcomp_hammer); a damping model outside the tie, or other
    effects, disagree."""
    same = load_script("diagnose").same_final

    def summary(final, best=None, tied=()):
        return {"final": {"model": final},
                "damping_recheck": best and {"best": best, "tied": list(tied)}}

    q3_path = summary("q3+root_compliance", "q3+root_compliance+root_damping", ["q1+root_compliance+root_damping"])
    q1_path = summary("q1+root_compliance", "q1+root_compliance+root_damping", ["q3+root_compliance+root_damping"])
    assert same(q3_path, q1_path) and same(q1_path, q3_path)
    assert not same(q3_path, summary("q1+root_compliance", "q1+root_compliance+root_damping"))
    assert not same(q3_path, summary("q3+root_compliance+root_damping", "q3+root_compliance+root_damping",
                                     ["q1+root_compliance+root_damping"]))
    assert same(summary("q1"), summary("q1")) and not same(summary("q1"), summary("q3"))


def test_catalogue_runs(load_script, monkeypatch):
    """catalogue.py with diagnose standing in: ``DiagnoseConfig.catalogue``, the effects ``REGISTRY``,
    the shipped examples' truth.json."""
    script = load_script("catalogue")
    diagnose = load_script("diagnose")       # catalogue.py's timed_diagnose calls diagnose.py's diagnose
    monkeypatch.setattr(diagnose, "diagnose", _stand_in(diagnose.diagnose, _committed_diagnosis))
    assert script.main([]) == 0
    examples = [path for path in script.EXAMPLES.iterdir() if (path / "truth.json").exists()]
    assert examples
    assert len(diagnose.diagnose.calls) == 2 * len(examples)      # baseline and current catalogue each


@pytest.mark.parametrize("argv", [["compare", "--max-frequency", "150"], ["diagnose", "--path", "baseline"]],
                         ids=["compare", "diagnose"])
def test_profiles_runs(load_script, monkeypatch, tmp_path, argv):
    """profiles.py with compare and diagnose standing in: its jobs from compare.py's and diagnose.py's
    parsers and ``configs``, the SerialExecutor, the profile written (to tmp_path, not benchmarks/results)."""
    script = load_script("profiles")
    monkeypatch.setattr(script, "RESULTS", tmp_path / "results")
    monkeypatch.setattr(script, "compare", _stand_in(script.compare, _committed_comparison))
    monkeypatch.setattr(script, "diagnose", _stand_in(script.diagnose, _committed_diagnosis))
    assert script.main(argv) == 0
    assert len(list((tmp_path / "results").glob("*.profile.txt"))) == 1
