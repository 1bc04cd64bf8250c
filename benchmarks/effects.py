#!/usr/bin/env python
"""Effects benchmark: the cost of the missing-physics effects in ``model.simulate``.

    python benchmarks/effects.py            # about 3-6 minutes on 2 cores
    python benchmarks/effects.py --quick    # about 1-2 minutes (solve_ivp on a shorter prefix)
    python benchmarks/effects.py --linear-only   # tables 1, 1b, 1c and 1d only

On the 4 s, 2048 Hz recording ``data/examples/paper_q3_hammer`` (q3 at its true parameters):

1. **Linear effects** (root_compliance, sensor_mass, axial_load, measurement_delay) against each
   of the paper's three base models, N = 16, 32 and 48, with the transfer form the system takes
   (``SecondOrderSystem.form``): they only change M, K, the root condition or a phase factor, so
   they should cost what the base model costs. What they cannot avoid: an effect that changes M
   or K changes the mode shapes with its parameter, so its model solves one eigenproblem per call
   where the base model reuses cached shapes scaled by EI; a root spring adds a degree of freedom
   (the root slope); beside q2's memory a root spring takes the ``low_rank`` form and an axial
   load's full-rank geometric stiffness the ``banded`` form, an elimination of Z(s) per frequency
   (no modal form exists for it).
   **1b.** ``system(p).poles(below)`` under the DAQ stopband for q2 with a root spring, a sensor
   mass or an axial load against q2 alone: all a free decay's likelihood needs besides mode shapes.
   **1c.** The whole free-decay log-likelihood of the real record (its study's window and band),
   q2 and q2 with each of those effects. **1d.** Where the time of q1 and q2 with a root spring
   (``low_rank``) or an axial load (``complex``, ``banded``) goes: building the system, the
   form's once-per-system work, the per-frequency work (also per degree of freedom) and the
   output.
2. **Nonlinear effects** (quadratic_drag, dry_friction) at N = 16: ms per ``simulate`` (target
   100 ms), the size of the effect (RMS of y - y_linear over RMS of y), the accuracy at the
   default step (RMS difference to a run with 4x more substeps, relative to the effect's RMS),
   and for friction the number of events.
   **2b.** The same two effects where a diagnosis meets them: the concealed-effects study's
   recordings ``alu_quadratic_drag`` and ``alu_dry_friction`` (3 s at 1024 Hz, q1, N = 24, their
   truth.json parameters): ms per ``simulate`` and per likelihood evaluation (``Likelihood.
   log_likelihood`` of ``prepare`` at the default band), this module against the baseline, the
   module as of commit :data:`BASELINE` (before the compiled kernels), loaded from git into the
   same process; the ratio is baseline / now, measured interleaved in this run, and the largest
   output difference between the two relative to the signal.
3. **solve_ivp on the same system** (same M, D, K, the same band-limited force as
   benchmarks/forward.py, started at rest 128 samples before the record): BDF with the exact
   Jacobian for drag; for friction BDF per phase with event location (slip: tip velocity reaches
   zero; stick: the holding force reaches F_c), the textbook exact treatment. Run on a prefix of
   the record and extrapolated by length (marked ~). For the difference to bayesbeam, solve_ivp's
   tip acceleration is passed through the DAQ passband W on a fine grid first (its plain samples
   would alias the acceleration's jumps at friction events into the band).

Times are process CPU time on one thread (see benchmarks/README.md); --wall for wall time.
"""
import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_var] = "1"          # one core, before numpy is imported

import argparse
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
# the working tree's bayesbeam, even if another copy is installed
sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

import _common as c
import numpy as np
import tables
from scipy.integrate import solve_ivp

from bayesbeam import BeamModel, load_recording
from bayesbeam.response import nonlinear as nl
from bayesbeam.response.linear import STOPBAND

PRE = 128                    # samples integrated before t = 0 by solve_ivp (the force is acausal)
SPLINE_FACTOR = 32
RTOL = 1e-8
TARGET_MS = 100.0
#: spline intervals of the linear tables (48: the paper beam's fitted N in the studies)
SIZES = (16, 32, 48)
PARAMS = {"EI": 44.28, "gamma": 0.12, "a": 0.025, "b": 0.18}
#: the base models of the linear-effects table, at benchmarks/forward.py's parameters
BASES = (("q1", {"EI": 44.28, "gamma": 0.12, "cdI": 2e-5}), ("q2", {"EI": 44.28, "alpha": 0.05, "beta": 20.0}),
         ("q3", PARAMS))
LINEAR = (("root_compliance", {"k_theta": 3500.0}), ("sensor_mass", {"m_s": 0.01}),
          ("axial_load", {"P": 20.0}), ("measurement_delay", {"tau": 0.3 / 2048}))
NONLINEAR = (("quadratic_drag", {"c_q": 0.02}), ("quadratic_drag", {"c_q": 1.0}),
             ("dry_friction", {"F_c": 0.01}), ("dry_friction", {"F_c": 0.1}))
#: table 2b: the baseline the compiled integrator is timed against (git commit of bayesbeam/response/
#: nonlinear.py before it), and the concealed-effects recordings it is timed on
BASELINE = "04696b9"
CONCEALED = os.path.join(c.ROOT, "studies", "concealed_effects", "recordings")
CONCEALED_N = 24


# ----------------------------------------------------------------------------- solve_ivp
def _matrices(model, values):
    system = model.system(values)
    minv = np.linalg.inv(system.M)
    n = system.size
    A = np.block([[np.zeros((n, n)), np.eye(n)], [-minv @ system.K, -minv @ system.D]])
    load = model.ops.rows([model.recording.excitation.location])[0]
    return system, minv, A, np.concatenate([np.zeros(n), minv @ load]), n


def ivp_drag(model, values, force, t_end):
    """BDF on x' = A x + b f(t) + [0; M^-1 f_drag(w')] with the exact Jacobian."""
    _, minv, A, b, n = _matrices(model, values)
    rows, w = model.effects[0].quadrature(model.ops)
    c_q = values["c_q"]
    mq = minv @ rows.T * w                          # M^-1 B^T diag(w)

    def rhs(t, x):
        v = rows @ x[n:]
        out = A @ x + b * force(t)
        out[n:] -= c_q * (mq @ (np.abs(v) * v))
        return out

    def jac(t, x):
        v = rows @ x[n:]
        J = A.copy()
        J[n:, n:] -= (mq * (2 * c_q * np.abs(v))) @ rows
        return J

    t0 = -PRE * model.recording.dt
    start = c.now()
    sol = solve_ivp(rhs, (t0, t_end), np.zeros(2 * n), method="BDF", rtol=RTOL, jac=jac,
                    atol=1e-14, dense_output=True)
    elapsed = c.now() - start
    if not sol.success:
        raise RuntimeError(sol.message)

    def displacement(times):
        return (sol.sol(times)[:n]).T @ model.rows.T
    return displacement, elapsed, {"nfev": sol.nfev}


def ivp_friction(model, values, force, t_end):
    """BDF per phase with events: slip (g = -F_c sign v_tip) until v_tip = 0, stick (the force
    holding the tip, e^T M^-1 (D w' + K w - b f) / e^T M^-1 e) until it reaches F_c."""
    _, minv, A, b, n = _matrices(model, values)
    e = model.ops.tip_value
    F_c = values["F_c"]
    me = np.concatenate([np.zeros(n), minv @ e])
    mu = e @ minv @ e
    hold_row = -np.concatenate([np.zeros(n), e]) @ A / mu          # g_hold = hold_row x - (e.b) f / mu
    hold_b = -(np.concatenate([np.zeros(n), e]) @ b) / mu
    A_stick = A + np.outer(me, hold_row)
    b_stick = b + me * hold_b
    vel = np.concatenate([np.zeros(n), e])

    def demand(t, x):
        return hold_row @ x + hold_b * force(t)

    t, x = -PRE * model.recording.dt, np.zeros(2 * n)
    mode, sgn = "stick", 1.0
    segments, nfev, events = [], 0, 0
    start = c.now()
    while t < t_end:
        if mode == "slip":
            g = -F_c * sgn

            def rhs(tt, xx, g=g):
                return A @ xx + b * force(tt) + me * g

            def event(tt, xx, s=sgn):
                return s * (vel @ xx)
            jac = A
        else:
            def rhs(tt, xx):
                return A_stick @ xx + b_stick * force(tt)

            def event(tt, xx):
                return F_c - abs(demand(tt, xx))
            jac = A_stick
        event.terminal, event.direction = True, -1
        sol = solve_ivp(rhs, (t, t_end), x, method="BDF", rtol=RTOL, atol=1e-14, jac=jac,
                        events=event, dense_output=True)
        nfev += sol.nfev
        segments.append((t, sol.t[-1], sol.sol, rhs))
        t, x = sol.t[-1], sol.y[:, -1].copy()
        if sol.status != 1:
            break
        events += 1
        g = demand(t, x)
        if mode == "slip" and abs(g) <= F_c:
            mode = "stick"
            x[n:] -= (minv @ e) * (e @ x[n:]) / mu        # remove the located zero's round-off
        else:
            mode, sgn = "slip", -np.sign(g)
    elapsed = c.now() - start

    def displacement(times):
        times = np.asarray(times)
        out = np.empty((times.size, model.rows.shape[0]))
        for a, z, dense, _ in segments:
            sel = (times >= a) & (times <= z)
            if sel.any():
                out[sel] = (dense(times[sel])[:n]).T @ model.rows.T
        return out
    return displacement, elapsed, {"nfev": nfev, "events": events}


# ----------------------------------------------------------------------------- helpers
def rms(x):
    return float(np.sqrt(np.mean(np.square(x))))


def linear_ms(model, params) -> float:
    """ms per simulate: best of 30 batches of 10 calls, or of 3 single calls when one takes > 50 ms."""
    t0 = c.now()
    model.simulate(params)
    if c.now() - t0 > 0.05:
        return per_call(lambda: model.simulate(params), 3)
    return c.best_time(lambda: model.simulate(params), 10, 30) * 1e3


def print_header() -> None:
    """Column heads of tables 1, 1b and 1c: model, transfer form, ms and ratio at every N."""
    print(f"{'model':44} {'form':>9}" + "".join(f" {f'N={N} ms':>9} {'ratio':>8}" for N in SIZES))


def print_row(table: str, label: str, form: str, ms: dict, base: dict) -> None:
    """One row of those tables: ms per call at every N and its ratio to ``base`` at the same N."""
    _record_row(table, {"model": label, "form": form, "ms": {str(N): ms[N] for N in SIZES},
                        "ratio": {str(N): ms[N] / base[N] for N in SIZES}})
    print(f"{label:44} {form:>9}" + "".join(f" {ms[N]:9.2f} {ms[N] / base[N]:8.2f}" for N in SIZES))


def _record_row(table: str, row: dict) -> None:
    """Keep a printed row in the benchmark's results (benchmarks/results/effects.json)."""
    tables.MEASURED.setdefault(table, []).append(row)


def per_call(func, repeat: int) -> float:
    """Best of ``repeat`` single calls (ms): a nonlinear simulate is long enough to time alone."""
    best = np.inf
    for _ in range(repeat):
        t0 = c.now()
        func()
        best = min(best, c.now() - t0)
    return best * 1e3


def print_poles(rec) -> None:
    """Table 1b: ms per ``system(p).poles(below)`` for q2 and q2 with a linear effect, ratio to q2.

    A free decay's likelihood needs only the poles under the DAQ stopband (``below`` = 2 pi 0.5
    fs, as ``BeamModel.free_decay_basis`` asks) and their mode shapes, not the transfer function;
    q2 alone takes the per-mode Newton iteration, q2 with an effect the Rayleigh functional one.
    """
    q2, below = dict(BASES)["q2"], 2 * np.pi * STOPBAND * rec.fs
    print(f"1b. Poles with memory (what a free decay's likelihood needs): ms per system(p).poles(below = "
          f"{below / (2 * np.pi):g} Hz) (best of 30 batches of 10 calls), ratio to q2")
    print_header()
    rows = [("q2", {}, ())] + [(f"q2 + {name}", extra, (name,)) for name, extra in LINEAR[:3]]
    base = None
    for label, extra, effects in rows:
        p = {**q2, **extra}
        models = {N: BeamModel(rec, "q2", N, effects=effects) for N in SIZES}
        ms = {N: c.best_time(lambda m=m, p=p: m.system(p).poles(below), 10, 30) * 1e3 for N, m in models.items()}
        base = base or ms
        print_row("1b", label, models[16].system(p).form, ms, base)
    print()


#: table 1c: the real record with the window and band of studies/real_steel_cantilever and q2's medians
#: from the paper's five models compared there, the effects at the values its diagnoses fitted (k_theta,
#: P) or a typical accelerometer (m_s)
REAL = os.path.join(c.ROOT, "data", "real", "ds4-cantilever-freedecay", "recording")
REAL_FIT = {"start": 1.12, "stop": 5.12, "max_frequency": 150.0}
REAL_Q2 = {"EI": 98.76, "alpha": 48.1, "beta": 873.0}
REAL_EFFECTS = (("root_compliance", {"k_theta": 4.1e6}), ("sensor_mass", {"m_s": 0.005}),
                ("axial_load", {"P": -2.3}))


def print_free_decay() -> None:
    """Table 1c: ms per free-decay log-likelihood on the real record, q2 and q2 + an effect.

    A free decay's likelihood marginalises the modal amplitudes of the poles under the stopband:
    poles, their mode shapes and the damped exponentials on the fitted window. Timed: the latent
    terms and the marginal (``Likelihood.log_likelihood`` less its noise variances). The first row
    builds the exponentials on every sample of the record instead: the baseline for what the
    window saves.
    """
    from bayesbeam.inference.fit import FitConfig, prepare
    from bayesbeam.inference.likelihood import _marginal

    rec = load_recording(REAL)
    print(f"1c. Free-decay log-likelihood on {os.path.relpath(REAL, c.ROOT)} (window {REAL_FIT['start']:g}-"
          f"{REAL_FIT['stop']:g} s, band {REAL_FIT['max_frequency']:g} Hz): ms per call (best of 20 batches "
          f"of 10), ratio to q2")
    print_header()
    rows = [("q2, basis on the whole record", {}, (), True), ("q2", {}, (), False)]
    rows += [(f"q2 + {name} ({', '.join(f'{k}={v:g}' for k, v in extra.items())})", extra, (name,), False)
             for name, extra in REAL_EFFECTS]
    results = []
    for label, extra, effects, whole in rows:
        ms = {}
        for N in SIZES:
            problem = prepare(rec, "q2", FitConfig(effects=effects, **REAL_FIT), N)
            lik, p = problem.likelihood, {**REAL_Q2, **extra}
            v = lik.variance(lik.profile_noise(p))
            ms[N] = c.best_time(lambda lik=lik, p=p, v=v, w=whole: _marginal(*lik._latent(p, whole=w)[2:], v),
                                10, 20) * 1e3
        results.append((label, problem.model.system(p).form, ms))
    base = results[1][2]
    for label, form, ms in results:
        print_row("1c", label, form, ms, base)
    print()


#: table 1d: q1 and q2 alone and with their costliest linear effects (the ``low_rank`` and
#: full-rank forms), at table 1's values
STAGE_ROWS = tuple((base, effects) for base in ("q1", "q2") for effects in ((), ("root_compliance",), ("axial_load",)))


def prepare(system):
    """Compute what ``system``'s transfer form needs once per system (its cached properties): the
    form's choice and then the split (``low_rank``), the complex modes (``complex``), the band
    order (``banded``) or the modal damping and memory (``diagonal``)."""
    needs = {"low_rank": ("_modal_split",), "complex": ("_modal_state_modes",), "banded": ("_band",),
             "diagonal": ("modal_damping",) + (("_modal_memory",) if system.relaxation else ()),
             "dense": ("modal_damping", "_modal_memory")}
    for name in needs[system.form]:
        getattr(system, name)
    return system


def stage_times(model, p) -> dict:
    """ms per call of the stages of ``simulate``: ``system`` (M, D, K and a cached reference),
    ``prep`` (:func:`prepare` on a fresh system), ``transfer`` (the per-frequency work on the
    whole grid, the system prepared) and ``output`` (the drive, the delay, the inverse FFT)."""
    s, C, B = model.grid.s, model.rows, model.load[:, None]
    values = model.values(p)
    system = prepare(model.system(p))
    h = system.transfer(s, C, B)[:, :, 0]
    out = {"system": c.best_time(lambda: model.system(p), 10, 30)}
    out["prep"] = max(c.best_time(lambda: prepare(model.system(p)), 10, 30) - out["system"], 0.0)
    out["transfer"] = c.best_time(lambda: system.transfer(s, C, B), 5, 20)
    out["output"] = c.best_time(lambda: model._output(h, None, values), 10, 30)   # a hammer test: no static offset
    return {k: v * 1e3 for k, v in out.items()} | {"form": system.form, "dof": system.size, "freq": s.size}


def print_stages(rec) -> None:
    """Table 1d: where the extra time of the ``low_rank`` and full-rank forms goes.

    The last column is the per-frequency work per degree of freedom (ns): the ``diagonal`` form
    evaluates one real section per mode, the ``low_rank`` form the same sections for four
    products plus the r x r algebra, the ``complex`` form one section per complex mode pair, the
    ``banded`` form an elimination step per degree of freedom (O(b^2) complex updates, b the
    half-bandwidth).
    """
    print("1d. Stages of simulate: ms per call (best of 20-30 batches); transfer/(freq dof) = the "
          "per-frequency work in ns per frequency and degree of freedom")
    print(f"{'model':26} {'N':>3} {'form':>9} {'dof':>4} {'system':>7} {'prep':>7} {'transfer':>9} "
          f"{'output':>7} {'total':>7}  {'ns/(freq dof)':>13}")
    for base_name, effects in STAGE_ROWS:
        p = dict(BASES)[base_name]
        for name in effects:
            p = {**p, **dict(LINEAR)[name]}
        label = " + ".join((base_name,) + effects)
        for N in SIZES:
            t = stage_times(BeamModel(rec, base_name, N, effects=effects), p)
            total = t["system"] + t["prep"] + t["transfer"] + t["output"]
            per = t["transfer"] * 1e6 / (t["freq"] * t["dof"])
            _record_row("1d", {"model": label, "N": N, **t, "total": total, "ns_per_freq_dof": per})
            print(f"{label:26} {N:3d} {t['form']:>9} {t['dof']:4d} {t['system']:7.3f} {t['prep']:7.3f} "
                  f"{t['transfer']:9.3f} {t['output']:7.3f} {total:7.3f}  {per:13.2f}")
    print()


FINE = 16          # solve_ivp's acceleration is sampled at dt/FINE before the passband W


def through_passband(displacement, n: int, dt: float) -> np.ndarray:
    """The first n samples of the acceleration W * u''(t) of a solve_ivp solution, as a DAQ sees it.

    The acceleration jumps at every friction event (by 2 F_c e^T M^-1 e at a reversal), so its
    samples, even on a fine grid, alias those jumps into the band; bayesbeam's outputs are
    band-limited by W. The displacement u (callable) is C^1, so it is sampled on dt/FINE from
    -PRE dt, multiplied by (i omega)^2 W(omega) by FFT (zero-padded), and every FINE-th sample
    is kept. Samples within ~150 of the end see the cut and are not compared.
    """
    from bayesbeam.response.linear import daq_passband
    times = (np.arange(-PRE * FINE, n * FINE)) * (dt / FINE)
    u = displacement(times)
    size = 2 * u.shape[0]
    f = np.fft.rfftfreq(size, dt / FINE)
    spec = np.fft.rfft(u, size, axis=0) * (daq_passband(f, 1 / dt) * (2j * np.pi * f) ** 2)[:, None]
    return np.fft.irfft(spec, size, axis=0)[PRE * FINE::FINE][:n]


def baseline_module():
    """bayesbeam/response/nonlinear.py as of commit BASELINE, imported under its own name, or the
    reason it cannot be (no git, no such commit, or an API it needs that the model no longer has)."""
    import importlib.util
    import subprocess
    import tempfile
    try:
        source = subprocess.run(["git", "show", f"{BASELINE}:bayesbeam/response/nonlinear.py"], cwd=c.ROOT,
                                capture_output=True, text=True, check=True).stdout
    except (OSError, subprocess.CalledProcessError) as err:
        return f"git show {BASELINE} failed: {err}"
    path = os.path.join(tempfile.mkdtemp(), "nonlinear_baseline.py")
    with open(path, "w") as fh:
        fh.write(source)
    spec = importlib.util.spec_from_file_location("nonlinear_baseline", path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module                 # its dataclasses look their module up
    spec.loader.exec_module(module)
    return module


def interleaved_ms(now, before, repeat: int = 7) -> tuple[float, float]:
    """Best of ``repeat`` single calls of each (ms), alternating, so both see the same machine load."""
    best = [np.inf, np.inf]
    for _ in range(repeat):
        for i, func in enumerate((now, before)):
            t0 = c.now()
            func()
            best[i] = min(best[i], c.now() - t0)
    return best[0] * 1e3, best[1] * 1e3


def print_concealed() -> None:
    """Table 2b: the nonlinear effects on the concealed-effects recordings, now against BASELINE."""
    import json

    from bayesbeam.inference.fit import FitConfig, prepare

    base = baseline_module()
    print(f"2b. Nonlinear effects on the concealed-effects recordings (q1, N = {CONCEALED_N}, truth.json "
          f"parameters): ms per call (best of 7, interleaved), baseline = nonlinear.py at {BASELINE}")
    if isinstance(base, str):
        print(f"  baseline unavailable: {base}")
    print(f"{'recording':22} {'sim ms':>8} {'base ms':>8} {'ratio':>6} {'lik ms':>8} {'base ms':>8} {'ratio':>6} "
          f"{'max dy/y':>9}")
    for name in ("quadratic_drag", "dry_friction"):
        folder = os.path.join(CONCEALED, f"alu_{name}")
        with open(os.path.join(folder, "truth.json")) as fh:
            truth = json.load(fh)
        p = {"EI": truth["EI"], **truth["damping"], **truth["effect_parameters"]}
        rec = load_recording(folder)
        model = BeamModel(rec, truth["damping_model"], CONCEALED_N, effects=name)
        lik = prepare(rec, truth["damping_model"], FitConfig(effects=(name,)), CONCEALED_N).likelihood
        noise = lik.profile_noise(p)

        def simulate(m=model, p=p):
            return m.simulate(p)

        def evaluate(lik=lik, p=p, noise=noise):
            return lik.log_likelihood(p, noise)
        row = {"recording": f"alu_{name}", "parameters": p}
        if isinstance(base, str):
            row.update(sim_ms=per_call(simulate, 7), lik_ms=per_call(evaluate, 7), sim_baseline_ms=np.nan,
                       lik_baseline_ms=np.nan, max_dy_over_y=np.nan)
        else:
            y = simulate()
            row["max_dy_over_y"] = float(np.max(np.abs(y - base.simulate_nonlinear(model, p))) / np.max(np.abs(y)))
            row["sim_ms"], row["sim_baseline_ms"] = interleaved_ms(simulate, lambda m=model, p=p:
                                                                   base.simulate_nonlinear(m, p))
            row["lik_ms"], row["lik_baseline_ms"] = interleaved_ms(evaluate, _with_module(base, evaluate))
        _record_row("2b", row)
        print(f"{row['recording']:22} {row['sim_ms']:8.1f} {row['sim_baseline_ms']:8.1f} "
              f"{row['sim_baseline_ms'] / row['sim_ms']:5.2f}x {row['lik_ms']:8.1f} {row['lik_baseline_ms']:8.1f} "
              f"{row['lik_baseline_ms'] / row['lik_ms']:5.2f}x {row['max_dy_over_y']:9.1e}")
    print("ratio = baseline / now; max dy/y = max |y - y_baseline| / max |y| of simulate; lik = the likelihood\n"
          "at the default band (prepare, FitConfig()), the baseline's through its simulate_nonlinear")
    print()


def _with_module(module, func):
    """``func`` run with ``BeamModel.simulate``'s nonlinear path taken from ``module``."""
    def run():
        saved = nl.simulate_nonlinear
        nl.simulate_nonlinear = module.simulate_nonlinear
        try:
            return func()
        finally:
            nl.simulate_nonlinear = saved
    return run


# ----------------------------------------------------------------------------- main
def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="solve_ivp on 0.25 s instead of 0.5 s")
    parser.add_argument("--wall", action="store_true", help="wall time instead of process CPU time")
    parser.add_argument("--linear-only", action="store_true", help="only tables 1, 1b, 1c and 1d (about 3 minutes)")
    parser.add_argument("--tables", action="store_true", help="only re-render README.md's block from benchmarks/results/effects.json")
    args = parser.parse_args(argv)
    if args.wall:
        c.CLOCK["clock"] = time.perf_counter
    started = time.perf_counter()
    rec = load_recording(c.RECORDING)
    dt, fs = rec.dt, rec.fs
    prefix = 0.25 if args.quick else 0.5
    print(f"bayesbeam effects benchmark{' (--quick)' if args.quick else ''}")
    print(f"machine: {c.machine()}")
    print("load average (1, 5, 15 min) at start: "
          + ", ".join(f"{x:.2f}" for x in os.getloadavg()))
    print("clock: " + ("wall time" if args.wall else "process CPU time (one thread)"))
    print(f"recording: {os.path.relpath(c.RECORDING, c.ROOT)}, {rec.n_samples * dt:g} s at "
          f"{fs:g} Hz ({rec.n_samples} samples); q3 at {PARAMS}")
    print()

    # 1. linear effects ------------------------------------------------------------------
    print("1. Linear effects: ms per simulate (best of 30 batches of ~50 ms; 3 single calls above 50 ms), "
          "ratio to the base model")
    print_header()
    for base_name, base_params in BASES:
        base = {N: linear_ms(BeamModel(rec, base_name, N), base_params) for N in SIZES}
        form = BeamModel(rec, base_name, 16).system(base_params).form
        print_row("1", base_name + " (base)", form, base, base)
        for name, extra in LINEAR:
            p = {**base_params, **extra}
            ms = {N: linear_ms(BeamModel(rec, base_name, N, effects=name), p) for N in SIZES}
            form = BeamModel(rec, base_name, 16, effects=name).system(p).form
            label = f"{base_name} + {name} ({', '.join(f'{k}={v:g}' for k, v in extra.items())})"
            print_row("1", label, form, ms, base)
    print()
    print_poles(rec)
    print_free_decay()
    print_stages(rec)

    if args.linear_only:
        return 0
    # 2. nonlinear effects ---------------------------------------------------------------
    print(f"2. Nonlinear effects at N = 16: ms per simulate (best of 5 calls; target {TARGET_MS:g} ms)")
    print(f"{'model':34} {'U':>3} {'ms':>8} {'target':>7} {'effect':>8} {'error':>9}  events")
    linear_y = BeamModel(rec, "q3", 16).simulate(PARAMS)
    results = {}
    for name, extra in NONLINEAR:
        m = BeamModel(rec, "q3", 16, effects=name)
        p = {**PARAMS, **extra}
        U = nl.SUBSTEPS[name]
        sol = nl.integrate(m, p, record=name == "dry_friction")
        ms = per_call(lambda m=m, p=p: m.simulate(p), 5)
        fine = nl.integrate(m, p, substeps=4 * U).output
        effect = rms(sol.output - linear_y)
        error = rms(sol.output - fine) / effect
        events = sol.record.get("events", {})
        ev = ", ".join(f"{k} {v}" for k, v in events.items() if v) if events else ""
        label = f"q3 + {name} ({', '.join(f'{k}={v:g}' for k, v in extra.items())})"
        ok = "ok" if ms <= TARGET_MS else "MISSED"
        _record_row("2", {"model": label, "substeps": U, "ms": ms, "target_ms": TARGET_MS,
                          "effect": effect / rms(sol.output), "error": error, "events": events})
        print(f"{label:34} {U:3d} {ms:8.1f} {ok:>7} {effect / rms(sol.output):8.1e} {error:9.1e}  {ev}")
        results[(name, tuple(extra.items()))] = (m, p, ms, sol.output)
    print("effect = RMS(y - y_linear) / RMS(y); error = RMS(y - y_4U) / RMS(y - y_linear), the\n"
          "discretisation error at the default U measured against 4x more substeps")
    print()
    print_concealed()

    # 3. solve_ivp -----------------------------------------------------------------------
    print(f"3. solve_ivp (BDF, rtol {RTOL:g}) on the same system, first {prefix:g} s "
          f"(+{PRE} samples before t = 0), extrapolated to the record (~)")
    windowed = BeamModel(rec, "q3", 16).force            # the model's (impact-windowed) force
    force = c.BandLimitedForce(windowed, dt).spline(SPLINE_FACTOR, PRE)
    t_end = prefix - dt
    n_pre = round(prefix / dt)
    scale = (rec.n_samples * dt + PRE * dt) / (prefix + PRE * dt)
    print(f"{'model':34} {'ivp ms':>10} {'~full ms':>10} {'ratio':>9} {'diff':>9} {'in band':>9}  notes")
    for name, extra in NONLINEAR:
        m, p, ms, y = results[(name, tuple(extra.items()))]
        runner = ivp_drag if name == "quadratic_drag" else ivp_friction
        acc_fn, elapsed, info = runner(m, p, force, t_end)
        full = elapsed * 1e3 * scale
        acc = through_passband(acc_fn, n_pre, dt)
        keep = slice(0, n_pre - 200)
        diff = float(np.max(np.abs(y[keep] - acc[keep])) / np.max(np.abs(acc[keep])))
        d_in, r_in = c.in_band(y[:n_pre] - acc, fs), c.in_band(acc, fs)
        keep_in = slice(128, n_pre - 200)
        diff_in = float(np.max(np.abs(d_in[keep_in])) / np.max(np.abs(r_in[keep_in])))
        label = f"q3 + {name} ({', '.join(f'{k}={v:g}' for k, v in extra.items())})"
        notes = ", ".join(f"{k} {v}" for k, v in info.items())
        _record_row("3", {"model": label, "ivp_ms": elapsed * 1e3, "full_ms_extrapolated": full,
                          "ratio": full / ms, "diff": diff, "diff_in_band": diff_in, **info})
        print(f"{label:34} {elapsed * 1e3:10.0f} {full:10.0f} {full / ms:8.0f}x {diff:9.1e} {diff_in:9.1e}  {notes}")
        print(f"  (done {time.perf_counter() - started:.0f} s)", file=sys.stderr)
    print("ratio = solve_ivp (extrapolated) / bayesbeam simulate. diff = max |y - y_ivp| / max |y_ivp| of\n"
          f"the tip acceleration over the prefix less its last 200 samples (the cut), y_ivp sampled at dt/{FINE}\n"
          "and passed through W. solve_ivp is driven by the force through W and its output passes W\n"
          "again, so its linear part carries W^2 where the model's has W: diff holds W (1 - W) H F, a\n"
          "transition-band (0.40-0.50 fs) difference. in band = the same below 0.37 fs (_common.in_band,\n"
          "samples 128 on): the integrators' own difference.")
    print()
    print(f"total {time.perf_counter() - started:.0f} s; load average at the end: "
          + ", ".join(f"{x:.2f}" for x in os.getloadavg()))
    return 0


if __name__ == "__main__":
    sys.exit(tables.run("effects", main))
