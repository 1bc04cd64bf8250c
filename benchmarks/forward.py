#!/usr/bin/env python
"""Forward-model benchmark: bayesbeam's ``model.simulate`` against time integrators.

    python benchmarks/forward.py            # full run, about 8 minutes on 2 cores, then the effects
    python benchmarks/forward.py --quick    # under 2 minutes: baselines on short prefixes
    python benchmarks/forward.py --no-effects   # without the effects' tables

Times ``model.simulate(params)`` for q1, q2, q3 at N = 16 and 32 on the 4 s, 2048 Hz recording
``data/examples/paper_q3_hammer`` and, in the same run, on the same M, D, K and the same force:

* ``scipy.integrate.solve_ivp`` (BDF, rtol 1e-8) on the first-order form, driven by the
  band-limited force (N = 16 only);
* ``pyyeti.ode.SolveExp2`` (exact exponential, first-order hold) (a) on the record's grid with
  the samples as given and (b) on a grid 16x finer with the band-limited force;
  for q2 the augmented state space with ``pyyeti.ode.SolveExp1``.

Then the missing-physics effects on the same recording: ``benchmarks/effects.py``, run
from here (its tables 1-3: each linear effect against its base model, drag and friction against
100 ms, solve_ivp on the same nonlinear systems; with ``--quick`` its tables 1 and 1b alone).

See benchmarks/README.md for what is measured and why; _common.py for the building blocks.
"""
import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_var] = "1"          # one core, before numpy is imported

import argparse
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

import _common as c
import numpy as np
import tables
from scipy.integrate import solve_ivp

from bayesbeam import load_recording

try:
    import pyyeti
    from pyyeti import ode as pyyeti_ode
    PYYETI_ERROR = None
except Exception as exc:  # noqa: BLE001 - report whatever went wrong and go on without it
    pyyeti = pyyeti_ode = None
    PYYETI_ERROR = f"{type(exc).__name__}: {exc}"

PRE = 128            # samples integrated before t = 0: f_c is not causal (see _common)
SPLINE_FACTOR = 32   # fine grid of the cubic spline that solve_ivp evaluates
UPSAMPLE = 16        # pyyeti (b): steps per record sample
RTOL = 1e-8
TARGET_MS = {"q1": 2.0, "q2": 10.0, "q3": 2.0}
TARGET_RATIO_IVP = 1000.0
TARGET_DIFF = 1e-6


# ----------------------------------------------------------------------------- baselines
def run_solve_ivp(model, system, spline, kernel, n_out: int):
    """BDF on x' = A x + B f_c(t) from -PRE dt (at rest) to the n_out-th sample."""
    space = c.state_space(model, system, kernel, sparse_form=kernel is not None)
    dt = model.recording.dt
    scale = c.state_scale(system, space, model.force, dt, kernel)
    t_eval = model.recording.time[:n_out]
    A, B = space.A, space.B

    def rhs(t, x):
        return A @ x + B * spline(t)

    t0 = c.now()
    sol = solve_ivp(rhs, (-PRE * dt, t_eval[-1]), np.zeros(A.shape[0]), method="BDF",
                    rtol=RTOL, atol=1e-3 * RTOL * scale, t_eval=t_eval, jac=A)
    y = space.output(sol.y, spline(t_eval))
    elapsed = c.now() - t0
    if not sol.success:
        raise RuntimeError(f"solve_ivp failed: {sol.message}")
    return y, elapsed, {"states": A.shape[0], "nfev": sol.nfev, "nlu": sol.nlu}


def pyyeti_second_order(model, system, force_values: np.ndarray, h: float, stride: int, start: int):
    """SolveExp2 (order=1) on M, D, K; tip accelerations every ``stride`` steps from ``start``."""
    load = model.ops.rows([model.recording.excitation.location])[0]
    forcing = load[:, None] * force_values[None, :]      # parameter-free: built outside timing

    def run():
        solver = pyyeti_ode.SolveExp2(system.M, system.D, system.K, h, order=1)
        sol = solver.tsolve(forcing)
        return (model.rows @ sol.a[:, start::stride]).T

    return run


def pyyeti_memory(model, system, kernel: c.ExponentialSum, force_values: np.ndarray, h: float,
                  stride: int, start: int):
    """SolveExp1 (order=1) on the augmented state space of a model with memory, mode by mode.

    The undamped modes Phi diagonalise D and K_h (form "diagonal", as for q2), so the augmented
    system (q_j, q_j', z_j1 .. z_jm) decouples exactly into N+1 systems of 2+m states (the same
    transformation as pyyeti's pre_eig=True): q_j'' + d_j q_j' + (lam_j - c_inf h_j) q_j
    - h_j sum_k c_k z_jk = phi_j^T b f, z_jk' = q_j - mu_k z_jk.
    """
    if system.form != "diagonal":
        raise NotImplementedError("pyyeti memory baseline needs modally diagonal D and K_h")
    load = model.ops.rows([model.recording.excitation.location])[0]
    m = kernel.size

    def run():
        lam, phi = system.undamped
        d = np.diag(phi.T @ system.D @ phi)
        kh = np.diag(phi.T @ system.K_h @ phi)
        gain, out = phi.T @ load, model.rows @ phi
        acc = np.zeros((out.shape[0], force_values.size))
        forcing = np.zeros((2 + m, force_values.size))
        for j in range(lam.size):
            a = np.zeros((2 + m, 2 + m))
            a[0, 1] = 1.0
            a[1, 0] = -(lam[j] - kernel.c_inf * kh[j])
            a[1, 1] = -d[j]
            a[1, 2:] = kh[j] * kernel.c
            a[2:, 0] = 1.0
            a[2:, 2:] = np.diag(-kernel.mu)
            forcing[1] = gain[j] * force_values
            sol = pyyeti_ode.SolveExp1(a, h, order=1).tsolve(forcing)
            acc += np.outer(out[:, j], sol.v[1])       # v = y' = A y + f: row 1 is q_j''
        return acc[:, start::stride].T

    return run


def pyyeti_runner(model, system, kernel, force_values, h, stride, start):
    if kernel is None:
        return pyyeti_second_order(model, system, force_values, h, stride, start)
    return pyyeti_memory(model, system, kernel, force_values, h, stride, start)


def difference(y: np.ndarray, reference: np.ndarray) -> float:
    """max |y - reference| / max |reference| over the samples of y (a prefix of the record)."""
    return float(np.max(np.abs(y - reference[: len(y)])) / np.max(np.abs(reference)))


def timed(run, repeat: int):
    """(result, best seconds) over ``repeat`` calls."""
    best, out = np.inf, None
    for _ in range(repeat):
        t0 = c.now()
        out = run()
        best = min(best, c.now() - t0)
    return out, best


# ----------------------------------------------------------------------------- main
def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true",
                        help="under 2 minutes: baselines on record prefixes, fewer repeats")
    parser.add_argument("--wall", action="store_true",
                        help="time with wall-clock time (time.perf_counter) instead of process CPU time")
    parser.add_argument("--no-effects", action="store_true",
                        help="skip the missing-physics effects' tables (benchmarks/effects.py)")
    parser.add_argument("--tables", action="store_true", help="only re-render README.md's block from benchmarks/results/forward and effects.json")
    args = parser.parse_args(argv)
    quick = args.quick
    if args.wall:
        c.CLOCK["clock"] = time.perf_counter
    started = time.perf_counter()

    rec = load_recording(c.RECORDING)
    dt, n = rec.dt, rec.n_samples
    duration = n * dt
    # record prefixes (samples) for the slow baselines
    ivp_samples = {"q1": n, "q2": n // 8, "q3": n}                # q2: 918 states, see README
    if quick:
        ivp_samples = {"q1": n // 8, "q2": n // 32, "q3": n // 8}
    pyy_b_samples = n // 8 if quick else n
    bb_repeat = 10 if quick else 30
    pyy_repeat = 1 if quick else 3

    print(f"bayesbeam forward benchmark{' (--quick)' if quick else ''}")
    print(f"machine: {c.machine()}")
    print(f"load average (1, 5, 15 min) at start: {', '.join(f'{x:.2f}' for x in os.getloadavg())}"
          " (other processes on the machine disturb the timings)")
    print("clock: " + ("wall time (time.perf_counter)" if args.wall else
                       "process CPU time (time.process_time; one thread, so equal to wall time on an "
                       "idle machine; use --wall for wall time)"))
    if pyyeti is not None:
        print(f"pyyeti {pyyeti.__version__}")
    else:
        print(f"pyyeti NOT AVAILABLE ({PYYETI_ERROR}): its baselines are skipped")
    print(f"recording: {os.path.relpath(c.RECORDING, c.ROOT)}, {duration:g} s at {rec.fs:g} Hz "
          f"({n} samples), force at {rec.excitation.location} m, tip accelerometer")

    force0 = c.BandLimitedForce(c.load_model("q1", 16, rec).force, dt)
    print(f"band-limited force: cubic spline on dt/{SPLINE_FACTOR} errs by "
          f"{force0.spline_error(SPLINE_FACTOR, PRE):.1e} of the peak (measured at midpoints); "
          f"f_c before -{PRE} dt (not integrated) is {force0.leak(PRE):.0e} of the peak")
    if quick:
        print(f"--quick: solve_ivp on the first {ivp_samples['q1'] * dt:g} s (q1, q3) and "
              f"{ivp_samples['q2'] * dt:g} s (q2), pyyeti (b) on the first {pyy_b_samples * dt:g} s; "
              "their ms are extrapolated to the full record (marked ~), differences are on the prefix")
    else:
        print(f"solve_ivp on the full record for q1 and q3, on the first {ivp_samples['q2'] * dt:g} s "
              "for q2 (ms extrapolated to the full record, marked ~)")
    print()

    rows, notes = [], []
    for q in ("q1", "q2", "q3"):
        params = c.PARAMS[q]
        for N in (16, 32):
            model = c.load_model(q, N, rec)
            system = model.system(params)
            force = c.BandLimitedForce(model.force, dt)
            y_bb = model.simulate(params)
            y_doc = c.documented_response(model, system, PRE)
            peak = np.max(np.abs(y_bb))

            # bayesbeam, timeit-style
            t_once = c.best_time(lambda m=model, p=params: m.simulate(p), 3, 1)
            number = max(1, int(0.05 / t_once))       # short batches: the best one dodges noise
            t_bb = c.best_time(lambda m=model, p=params: m.simulate(p), number, bb_repeat)
            entry = {"model": q, "N": N, "bb_ms": 1e3 * t_bb, "peak": peak, "baselines": []}
            y_doc2 = c.documented_response(model, system, 2 * PRE)
            entry["baselines"].append({"name": "exact documented output (reference)",
                                       "ms": None, "diff": difference(y_doc, y_bb),
                                       "diff_doc": difference(y_doc2, y_doc), "self": True})

            skip = 128
            in_band = (np.max(np.abs(c.in_band(y_bb, rec.fs)[skip:] - c.in_band(y_doc, rec.fs)[skip:]))
                       / peak)
            notes.append(f"{q} N={N}: bayesbeam vs the exact documented output: "
                         f"{difference(y_doc, y_bb):.1e} over the full band, {in_band:.1e} below "
                         f"0.37 fs (Kaiser FIR, samples {skip}..end): the difference is in the "
                         "0.40-0.50 fs transition band")
            kernel = None
            if system.relaxation is not None:
                kernel = c.sum_of_exponentials(params["alpha"], params["beta"])
                h_err, g_err = c.transfer_error(model, system, kernel)
                notes.append(f"{q} N={N}: the baselines integrate a {kernel.size}-term sum of "
                             f"exponentials (+ instantaneous term) for the kernel; on 0..fs/2 its "
                             f"G(i w) errs by {g_err:.1e} relative, the tip-acceleration transfer "
                             f"function by {h_err:.1e} of its max. bayesbeam uses the exact kernel.")

            # solve_ivp (N = 16 only)
            if N == 16:
                k = ivp_samples[q]
                y, secs, info = run_solve_ivp(model, system, force.spline(SPLINE_FACTOR, PRE),
                                              kernel, k)
                factor = (n + PRE) / (k + PRE)
                entry["baselines"].append({
                    "name": f"solve_ivp BDF rtol {RTOL:g}, {info['states']} states",
                    "ms": 1e3 * secs * factor, "est": k < n,
                    "diff": difference(y, y_bb), "diff_doc": difference(y, y_doc)})
                if k < n:
                    notes.append(f"{q} N=16 solve_ivp: {1e3 * secs:.0f} ms measured on the first "
                                 f"{k * dt:g} s (+{PRE * dt:g} s before t=0), x{factor:.2f} to the full record; "
                                 f"{info['nfev']} RHS calls, {info['nlu']} LU factorisations")
                else:
                    notes.append(f"{q} N=16 solve_ivp: {info['nfev']} RHS calls, "
                                 f"{info['nlu']} LU factorisations")

            # pyyeti
            if pyyeti is not None:
                name = "pyyeti SolveExp2" if kernel is None else "pyyeti SolveExp1 aug."
                run = pyyeti_runner(model, system, kernel, model.force, dt, 1, 0)
                y, secs = timed(run, pyy_repeat)
                entry["baselines"].append({"name": f"{name} (a) record grid, samples",
                                           "ms": 1e3 * secs,
                                           "diff": difference(y, y_bb),
                                           "diff_doc": difference(y, y_doc)})
                k = pyy_b_samples
                values = force.fine(UPSAMPLE, PRE)[: (PRE + k) * UPSAMPLE]
                run = pyyeti_runner(model, system, kernel, values, dt / UPSAMPLE, UPSAMPLE,
                                    PRE * UPSAMPLE)
                y, secs = timed(run, 1 if kernel is not None else max(1, pyy_repeat - 1))
                factor = (n + PRE) / (k + PRE)
                entry["baselines"].append({
                    "name": f"{name} (b) dt/{UPSAMPLE}, band-limited",
                    "ms": 1e3 * secs * factor, "est": k < n,
                    "diff": difference(y, y_bb), "diff_doc": difference(y, y_doc)})
            rows.append(entry)
            print(f"  done {q} N={N} ({time.perf_counter() - started:.0f} s)", file=sys.stderr)

    # convergence of pyyeti (b) with the step, q1 N = 16 (full run only)
    convergence = []
    if pyyeti is not None and not quick:
        model = c.load_model("q1", 16, rec)
        system = model.system(c.PARAMS["q1"])
        force = c.BandLimitedForce(model.force, dt)
        y_bb = model.simulate(c.PARAMS["q1"])
        y_doc = c.documented_response(model, system, PRE)
        ys = {}
        for U in (8, 16, 32):
            run = pyyeti_runner(model, system, None, force.fine(U, PRE), dt / U, U, PRE * U)
            ys[U], secs = timed(run, 1)
            convergence.append((f"U={U}", 1e3 * secs, c.relative_difference(ys[U], y_bb),
                                c.relative_difference(ys[U], y_doc)))
        y_r = (4 * ys[32] - ys[16]) / 3
        convergence.append(("Richardson (4 y32 - y16)/3", convergence[1][1] + convergence[2][1],
                            c.relative_difference(y_r, y_bb), c.relative_difference(y_r, y_doc)))

    tables.record(rows=rows, notes=notes, convergence=[dict(zip(("label", "ms", "vs_bayesbeam", "vs_exact"), row))
                                                       for row in convergence], target_ms=TARGET_MS)
    # ------------------------------------------------------------------ report
    print("Max |y - y_bayesbeam| / max |y_bayesbeam| (\"vs bayesbeam\") and the same against the")
    print("exact documented output F^-1{H W F} (\"vs exact\", computed without time stepping).")
    print("ratio = baseline ms / bayesbeam ms; ~ = extrapolated from a prefix (see notes).")
    print("(a): the samples joined linearly (first-order hold), as a peer would; (b): the band-limited")
    print("force on a 16x finer grid. q2 baselines: SolveExp1 on the augmented state space (memory")
    print("kernel as a sum of exponentials), decoupled mode by mode. In brackets on the reference row:")
    print("how much the reference moves when twice as much lead-in is computed (its own accuracy).")
    print()
    head = (f"{'model':5} {'N':>3} {'bayesbeam':>10}  {'baseline':46} {'ms':>10} {'ratio':>9} "
            f"{'vs bayesbeam':>12} {'vs exact':>9}")
    print(head)
    print("-" * len(head))
    for e in rows:
        first = True
        for b in e["baselines"]:
            lead = (f"{e['model']:5} {e['N']:>3} {e['bb_ms']:>7.2f} ms" if first
                    else " " * 21)
            first = False
            if b["ms"] is None:
                ms, ratio = "-", "-"
            else:
                ms = f"{'~' if b.get('est') else ''}{b['ms']:.0f}"
                ratio = f"{'~' if b.get('est') else ''}{b['ms'] / e['bb_ms']:.0f}x"
            exact = f"({b['diff_doc']:.0e})" if b.get("self") else f"{b['diff_doc']:.1e}"
            print(f"{lead}  {b['name']:46} {ms:>10} {ratio:>9} {b['diff']:>12.1e} {exact:>9}")
    print()
    for note in notes:
        print(f"note: {note}")
    if convergence:
        print()
        print("pyyeti SolveExp2 (b) against the step dt/U, q1 N=16 (first-order hold: O(U^-2)):")
        for label, ms, d_bb, d_doc in convergence:
            print(f"  {label:28} {ms:8.0f} ms   vs bayesbeam {d_bb:.1e}   vs exact {d_doc:.1e}")

    # ------------------------------------------------------------------ targets
    print()
    print("Targets (printed, not asserted):")
    for e in rows:
        q, N = e["model"], e["N"]
        if N == 16:
            ok = e["bb_ms"] <= TARGET_MS[q]
            print(f"  {q} N=16 simulate <= {TARGET_MS[q]:g} ms: {e['bb_ms']:.2f} ms "
                  f"-> {'MET' if ok else 'NOT MET'}")
    for e in rows:
        q, N = e["model"], e["N"]
        for b in e["baselines"]:
            if b["ms"] is None:
                continue
            ratio = b["ms"] / e["bb_ms"]
            short = b["name"].split(",")[0]
            need = TARGET_RATIO_IVP if short.startswith("solve_ivp") else 1.0
            speed = "MET" if ratio >= need else "NOT MET"
            same = "MET" if b["diff"] <= TARGET_DIFF else "NOT MET"
            print(f"  {q} N={N} vs {short:37}: {ratio:8.0f}x faster (need >= {need:g}x) {speed:7}; "
                  f"same answer to {TARGET_DIFF:g}: {b['diff']:.1e} {same} (vs exact {b['diff_doc']:.1e})")
    worst = max(b["diff"] for e in rows for b in e["baselines"] if b.get("self"))
    if worst > TARGET_DIFF:
        print(f"  (bayesbeam itself differs from the exact documented output by up to {worst:.1e}: no "
              f"integrator driven by the documented band-limited force can agree with it to {TARGET_DIFF:g})")
    else:
        print(f"  (bayesbeam agrees with the exact documented output to {worst:.1e}, so the baselines' "
              "differences are their own errors: see the vs exact column)")
    print()
    print(f"total {time.perf_counter() - started:.0f} s; load average at the end: "
          f"{', '.join(f'{x:.2f}' for x in os.getloadavg())}")
    return 0


def run_all(argv: list[str]) -> int:
    """The forward benchmark, then (unless ``--no-effects``) the effects benchmark, each saved to
    benchmarks/results and rendered into benchmarks/README.md; ``--tables`` re-renders both."""
    import effects

    status = tables.run("forward", main, argv)
    if status or "--no-effects" in argv:
        return status
    effects_argv = [a for a, given in (("--linear-only", "--quick" in argv), ("--wall", "--wall" in argv),
                                       ("--tables", "--tables" in argv)) if given]
    return tables.run("effects", effects.main, effects_argv)


if __name__ == "__main__":
    sys.exit(run_all(sys.argv[1:]))
