"""The ``low_rank`` and ``banded`` transfer forms.

``low_rank``: M and K depart from the bare beam's along a few directions.

A root spring adds k_theta e e^T to EI K_0 while the memory acts on K_0 alone; a sensor mass or a
tip body adds to M while air damping stays gamma M_0. No modal basis then diagonalises everything,
but in the modes of (K, M) the damping and memory matrices are diagonal plus rank r, and the form
corrects the diagonal one by an r x r Woodbury solve per frequency. References: C Z(s)^-1 B with
Z(s) = s^2 M + s D + K - G(s) K_h assembled from the raw matrices and solved per frequency in 30
digits (independent of every modal form), and the complex and dense forms of the same system.

``banded``: a memory term beside a full-rank added stiffness (an axial load) has no modal form;
Z(s) is eliminated per frequency in its band, checked against the same 30-digit solves and the
dense solve.
"""
import dataclasses

import mpmath as mp
import numpy as np
import pytest

from bayesbeam.io.recording import load_recording
from bayesbeam.model import BeamModel
from bayesbeam.physics.assembly import BeamOperators
from bayesbeam.physics.basis import SplineBasis
from bayesbeam.physics.mechanisms import Air, TimeHysteresis
from bayesbeam.response.system import SecondOrderSystem
from tests.galerkin_reference import EI, LENGTH, RHO_A, state_matrix

MEMORY = {"alpha": 0.5, "beta": 20.0, "r": np.inf}    # |G| up to 2 % of EI at mode 1: visible


def _pinned(n=12):
    return BeamOperators(SplineBasis(LENGTH, n, root="pinned"), rho_a=RHO_A)


def _system(ops, springs, gamma=0.0):
    """q2 (+ air) on a pinned basis with rank-len(springs) stiffness W diag(S) W^T beside EI K_0."""
    w = np.stack([ops.root_slope, ops.rows([0.4], deriv=1)[0]], axis=1)[:, :len(springs)]
    s = np.asarray(springs, dtype=float)
    K = EI * ops.K0 + w @ np.diag(s) @ w.T
    g = TimeHysteresis().relaxation(MEMORY)
    return SecondOrderSystem(ops.M, Air().damping(ops, {"gamma": gamma}), K, g, ops.K0, departures=w)


def _direct(system, s, C, B):
    out = []
    for si in s:
        z = si**2 * system.M + si * system.D + system.K - system.relaxation(np.array([si]))[0] * system.K_h
        out.append(C @ np.linalg.solve(z, B))
    return np.array(out)


def _exact(system, s, C, B, digits=30):
    """C Z(s)^-1 B solved in ``digits``-digit arithmetic for the same (float) matrices and G(s)."""
    mp.mp.dps = digits
    out = []
    k_h = np.zeros_like(system.K) if system.K_h is None else system.K_h
    for si in s:
        g = 0.0 if system.relaxation is None else system.relaxation(np.array([si]))[0]
        z = mp.matrix([[mp.mpc(si) ** 2 * system.M[i, j] + mp.mpc(si) * system.D[i, j] + system.K[i, j]
                        - mp.mpc(g) * k_h[i, j] for j in range(system.size)] for i in range(system.size)])
        cols = [mp.lu_solve(z, mp.matrix(b.tolist())) for b in B.T]
        out.append(C @ np.array([[complex(col[i]) for col in cols] for i in range(system.size)]))
    return np.array(out)


@pytest.mark.parametrize("springs, gamma", [((3500.0,), 0.0), ((3500.0, -40.0), 0.3)])
def test_low_rank_form_equals_an_exact_solve_at_and_between_the_resonances(springs, gamma):
    """Relative to max |H|: at every resonance peak against a 30-digit solve, < 2e-10; on a grid
    between them against numpy's direct solve, < 1e-10.

    At a peak the form subtracts two large modal terms (the diagonal part alone resonates within a
    damping bandwidth of the true mode) and any relative error is amplified by 1/(2 zeta): measured
    2e-11 to 5e-11 (zeta = 7e-4, no air; LAPACK driver dependent) and 1.5e-12 (with air), the order
    of the other modal forms at a peak (:func:`bayesbeam.response.system.undamped_modes`: 6e-11 at
    N = 32); numpy's direct solve errs by up to 1.3e-10 there itself. Rank 2 (a second, negative spring in the span) and diagonal damping
    exercise the r x r solve and the damping term.
    """
    ops = _pinned()
    system = _system(ops, springs, gamma)
    assert system.form == "low_rank"
    C, B = ops.rows([1.0, 0.7]), ops.rows([0.75, 1.0]).T
    peaks = 1j * system.poles().imag
    exact = _exact(system, peaks, C, B)
    assert np.max(np.abs(system.transfer(peaks, C, B) - exact)) / np.max(np.abs(exact)) < 2e-10
    between = 1j * 2 * np.pi * np.linspace(0.1, 800.0, 401)
    direct = _direct(system, between, C, B)
    assert np.max(np.abs(system.transfer(between, C, B) - direct)) / np.max(np.abs(direct)) < 1e-10
    # the correction matters: without it (the diagonal part alone) the peaks are wrong by O(1)
    plain = dataclasses.replace(system, K_h=system.K / EI, departures=None)
    assert np.max(np.abs(plain.transfer(peaks, C, B) - exact)) / np.max(np.abs(exact)) > 0.05


def test_low_rank_form_needs_departures_that_span_every_non_modal_part():
    """With a tip body, air damping departs from modal form along the tip's directions too: given
    only the spring's direction, the form is not low_rank (the system verifies what it is given)."""
    ops = BeamOperators(SplineBasis(LENGTH, 8, root="pinned"), rho_a=RHO_A, m_T=0.2, J=0.003)
    system = _system(ops, (3500.0,), gamma=0.3)
    assert system.form == "banded"


@pytest.mark.parametrize("spec, extra, form", [
    ("q2+root_compliance", {"k_theta": 3500.0}, "low_rank"),
    ("q2+root_compliance+sensor_mass", {"k_theta": 3500.0, "m_s": 0.01}, "low_rank"),
    ("q2+sensor_mass", {"m_s": 0.01}, "diagonal"),            # K stays EI K_0: still modal
    ("q2+axial_load", {"P": 3.0}, "banded"),                  # P G_0 has full rank
    ("q1+sensor_mass", {"m_s": 0.01}, "low_rank"),            # gamma M_0 is no longer modal
    ("q1+root_compliance", {"k_theta": 3500.0}, "low_rank"),  # cdI K_0 is no longer modal
    ("q1+axial_load", {"P": 3.0}, "complex"),
    ("q3+sensor_mass", {"m_s": 0.01}, "complex"),             # spatial hysteresis: not bare-modal
])
def test_the_model_chooses_the_form_from_the_effects(spec, extra, form):
    """BeamModel passes the split (EI, W, S) of the effects' added stiffness when its rank is small.

    At the four lowest peaks against a 30-digit solve, bound as in the test above. The memory is
    the module's (zeta ~ 1e-3 at the peaks): at the example's alpha = 0.05, zeta ~ 7e-5 makes Z(s)
    at a peak so ill-conditioned (cond 6e7) that numpy's direct solve errs by 1e-9 there.
    """
    model = BeamModel(load_recording("data/examples/paper_rootcomp_hammer"), spec, n_intervals=8)
    params = {"EI": EI, "alpha": MEMORY["alpha"], "beta": MEMORY["beta"], "gamma": 0.3, "cdI": 7e-5,
              "a": 0.025, "b": 0.18, **extra}
    params = {k: v for k, v in params.items() if k in model.parameter_names}
    system = model.system(params)
    assert system.form == form
    if form == "low_rank":
        s = 1j * system.poles().imag[:4]
        C, B = np.eye(system.size)[:2], np.eye(system.size)[:, -2:]
        ref = _exact(system, s, C, B)
        assert np.max(np.abs(system.transfer(s, C, B) - ref)) / np.max(np.abs(ref)) < 2e-10


@pytest.mark.parametrize("recording, spec, extra, other", [
    ("paper_rootcomp_hammer", "q1+sensor_mass", {"gamma": 0.3, "cdI": 7e-5, "m_s": 0.01}, "complex"),
    ("paper_rootcomp_hammer", "q1+root_compliance", {"gamma": 0.3, "cdI": 7e-5, "k_theta": 3500.0}, "complex"),
    ("alu_q1_release", "q2+air", {"alpha": 0.05, "beta": 20.0, "gamma": 0.18}, "banded"),
])
def test_low_rank_form_agrees_with_the_general_forms(recording, spec, extra, other):
    """The same system through the low_rank form and through the form it replaces (complex modes, or
    the band elimination), on the likelihood's own frequency grid: max |difference| / max |H| < 1e-10.

    Two exact forms by different algebra (a 2n x 2n eigendecomposition or an n x n solve per
    frequency, against diagonal sums and a Woodbury correction); measured 1e-15 to 9e-14. At the
    four lowest resonance peaks both stay within 2e-10 of a 30-digit solve (measured 7e-12 or less).
    """
    model = BeamModel(load_recording(f"data/examples/{recording}"), spec, n_intervals=12)
    system = model.system({"EI": 44.28 if recording.startswith("paper") else model.recording.beam.nominal_EI,
                           **extra})
    assert system.form == "low_rank"
    general = dataclasses.replace(system, departures=None)
    assert general.form == other
    s = model.grid.s[: model.grid.s.size // 2]
    h, ref = system.transfer(s, model.rows, model.load[:, None]), general.transfer(s, model.rows, model.load[:, None])
    assert np.max(np.abs(h - ref)) / np.max(np.abs(ref)) < 1e-10
    peaks = 1j * system.poles().imag[:4]
    exact = _exact(system, peaks, model.rows, model.load[:, None])
    for form in (system, general):
        assert np.max(np.abs(form.transfer(peaks, model.rows, model.load[:, None]) - exact)) < 2e-10 * np.max(np.abs(exact))


REFERENCED = [
    ("q1+root_compliance", {"gamma": 0.3, "cdI": 7e-5, "k_theta": 3000.0}),
    ("q1+sensor_mass", {"gamma": 0.3, "cdI": 7e-5, "m_s": 0.013}),
    ("q2+root_compliance", {**MEMORY, "k_theta": 3000.0}),
    ("q2+root_compliance+sensor_mass", {**MEMORY, "k_theta": 3000.0, "m_s": 0.013}),
]


@pytest.mark.parametrize("spec, extra", REFERENCED)
def test_low_rank_form_from_a_cached_reference_solves_no_eigenproblem(spec, extra, monkeypatch):
    """The model passes a reference beam with cached modes (the effects' parameters on an octave
    grid, :meth:`Effect.reference`), so a call solves no eigenproblem: with the eigen-solver made
    to fail after the first call, a second call in the same octave still simulates and, with a
    memory, finds its poles under the stopband. Its transfer function equals the one in the modes
    of (K, M) on the likelihood's grid to 1e-10 of max |H| (two exact forms by different algebra;
    measured 8e-13 to 1.1e-12), its poles theirs to 1e-11 (Newton's method on two secular
    functions, both converged to 1e-13 relative steps; measured 6e-14 and 7e-14)."""
    model = BeamModel(load_recording("data/examples/paper_rootcomp_hammer"), spec, n_intervals=12)
    params = {"EI": EI, **{k: v for k, v in extra.items() if k != "r"}}
    model.simulate(params)                                  # caches the reference's modes

    def no_eigensolve(*args):
        raise AssertionError("an eigenproblem was solved")

    monkeypatch.setattr("bayesbeam.model.undamped_modes", no_eigensolve)
    monkeypatch.setattr("bayesbeam.response.system.undamped_modes", no_eigensolve)
    nearby = {k: v * 1.1 if k in ("k_theta", "m_s", "EI") else v for k, v in params.items()}
    system = model.system(nearby)
    assert system.form == "low_rank" and system.reference is not None
    y = model.simulate(nearby)
    assert np.all(np.isfinite(y))
    below = 2 * np.pi * 0.4 * model.recording.fs
    poles = system.poles(below) if system.relaxation is not None else None
    monkeypatch.undo()
    s = model.grid.s[: model.grid.s.size // 2]
    C, B = model.rows, model.load[:, None]
    h = system.transfer(s, C, B)
    in_own_modes = dataclasses.replace(system, reference=None)
    expected = in_own_modes.transfer(s, C, B)
    assert np.max(np.abs(h - expected)) / np.max(np.abs(expected)) < 1e-10
    if poles is not None:       # Newton on the secular function from the reference's modes
        assert np.max(np.abs(poles - in_own_modes.poles(below)) / np.abs(poles)) < 1e-11


@pytest.mark.parametrize("k_theta", [30.0, 3000.0, 3e6, 1e7])
def test_low_rank_form_from_a_reference_is_exact_at_the_resonances(k_theta):
    """At the four lowest peaks against a 30-digit solve, from a compliant root (k_theta = 0.7 EI/l,
    nearly pinned) to stiff ones (7e4 and 2.3e5 EI/l, the latter off its reference by a factor
    1.16): < 1e-8 of max |H|.

    In the reference's modes a true resonance arises from the Woodbury capacitance 1 + r t
    vanishing, not from a modal denominator, so the rounding of the correction (relative to the
    largest stiffness: the spring's at a stiff root) is amplified by the peak's 1/(2 zeta):
    eps k_theta / (EI omega_1^2) / (2 zeta) ~ 1e-9 at 1e7 (zeta = 8e-4). At 30 mode 1 has
    zeta = 6e-5, so rounding of the capacitance is amplified 1/(2 zeta) = 8300 x; there the form in
    the modes of (K, M) errs by 2.5e-10 as well. The rounding itself depends on the LAPACK build:
    at 30 the low-rank form's error is 5e-10 with one numpy build and 2.5e-9 with another (3e-12,
    2e-10 and 5e-10 at 3e3, 3e6 and 1e7). 1e-8 bounds that amplified rounding with a factor of
    four to spare, while a wrong correction errs at order one; either is far below any
    likelihood's noise (1e-3 of the signal and more).
    """
    model = BeamModel(load_recording("data/examples/paper_rootcomp_hammer"), "q2+root_compliance", n_intervals=8)
    system = model.system({"EI": EI, "alpha": MEMORY["alpha"], "beta": MEMORY["beta"], "k_theta": k_theta})
    assert system.reference is not None and system._reference_split is not None
    s = 1j * system.poles().imag[:4]
    C, B = np.eye(system.size)[:2], np.eye(system.size)[:, -2:]
    exact = _exact(system, s, C, B)
    assert np.max(np.abs(system.transfer(s, C, B) - exact)) / np.max(np.abs(exact)) < 1e-8


def test_a_reference_that_departs_outside_the_directions_is_not_used():
    """The system verifies the reference it is given: a mass that departs from the reference's
    outside span W is refused (no reference split), and the form falls back to the modes of (K, M)."""
    model = BeamModel(load_recording("data/examples/paper_rootcomp_hammer"), "q2+root_compliance", n_intervals=8)
    system = model.system({"EI": EI, "alpha": MEMORY["alpha"], "beta": MEMORY["beta"], "k_theta": 3000.0})
    ref = system.reference
    wrong = dataclasses.replace(system, reference=ref._replace(mass=ref.mass * (1 + 1e-6)))
    assert system._reference_split is not None and wrong._reference_split is None
    assert wrong.form == "low_rank" and wrong._low_rank is not None


def test_without_memory_a_rank_two_departure_keeps_the_complex_form():
    """A tip body (m_T and J: two directions) on q1: complex modes cost less than the rank-2 algebra."""
    model = BeamModel(load_recording("data/examples/alu_q1_release"), "q1", n_intervals=8)
    system = model.system({"EI": model.recording.beam.nominal_EI, "gamma": 0.18, "cdI": 5.5e-6})
    assert system.departures.shape[1] == 2 and system.form == "complex"


BANDED = [("q2+axial_load", {"P": 3.0}),
          ("q2+root_compliance+axial_load", {"k_theta": 3500.0, "P": 3.0}),   # root slope reordered
          ("q2+air+sensor_mass+axial_load", {"gamma": 0.3, "m_s": 0.01, "P": -2.0})]


@pytest.mark.parametrize("spec, extra", BANDED)
def test_banded_form_equals_an_exact_solve_and_the_dense_one(spec, extra):
    """Memory beside an axial load's full-rank geometric stiffness (compression too).

    At the four lowest resonance peaks against a 30-digit solve: < 1e-9 of max |H| (measured 3.5e-10,
    8e-11, 2.8e-11). Z(s) is formed in the spline coordinates, where each entry carries a rounding
    of eps |K_ij| that a smooth mode's Z phi (small near its resonance) does not: a 30-digit solve of
    the rounded Z errs by 1.8e-10 on the first case, numpy's pivoted solve by 2.5e-10, and a peak
    amplifies it by 1/(2 zeta). The dense solve in modal coordinates forms Z where it is diagonal
    and reaches 4.5e-11; for a likelihood whose noise is 1e-3 of the signal both are exact.
    On the likelihood's whole grid against that dense solve (pivoted LU, different algebra):
    < 1e-10 (measured 1.6e-12 to 2.1e-12).

    The root slope is numbered last and couples to the first splines; reordered, the band stays 4
    wide. The elimination does not pivot: a vanishing pivot would show here."""
    model = BeamModel(load_recording("data/examples/paper_rootcomp_hammer"), spec, n_intervals=12)
    params = {"EI": EI, "alpha": MEMORY["alpha"], "beta": MEMORY["beta"], **extra}
    system = model.system(params)
    assert system.form == "banded" and system._band.width <= 4
    C, B = model.rows, model.load[:, None]
    peaks = 1j * system.poles().imag[:4]
    exact = _exact(system, peaks, C, B)
    assert np.max(np.abs(system.transfer(peaks, C, B) - exact)) < 1e-9 * np.max(np.abs(exact))
    h, dense = system.transfer(model.grid.s, C, B), system._transfer_dense(model.grid.s, C, B)
    assert np.max(np.abs(h - dense)) < 1e-10 * np.max(np.abs(dense))


def _frozen_kernel_poles(system):
    """Reference: per undamped mode, freeze G at the current s, take the nearest eigenvalue of the
    frozen quadratic problem (a 2n x 2n state matrix), repeat to convergence."""
    out = []
    for s in 1j * np.sqrt(system.undamped[0].astype(complex)):
        for _ in range(60):
            k = system.K - system.relaxation(np.array([s]))[0] * system.K_h
            cand = np.linalg.eigvals(state_matrix(system.M, system.D, k))
            new = cand[np.argmin(np.abs(cand - s))]
            done, s = abs(new - s) <= 1e-12 * abs(s), new
            if done:
                break
        out.append(s)
    p = np.array(out)
    return np.sort_complex(p[p.imag > 0])


@pytest.mark.parametrize("spec, extra, form", [
    ("q2+root_compliance", {"k_theta": 3500.0}, "low_rank"),
    ("q2+root_compliance+axial_load", {"k_theta": 3500.0, "P": 3.0}, "banded"),
    ("q2+axial_load", {"P": -3.0}, "banded"),
    ("q2+spatial_hysteresis", {"a": 0.025, "b": 0.18}, "dense"),
])
def test_poles_with_memory_agree_with_the_frozen_kernel_iteration(spec, extra, form):
    """Every pole by the Rayleigh functional iteration against freezing G(s) and taking the nearest
    eigenvalue (a different algorithm: 2n x 2n eigenvalues per step): < 1e-10 relative, measured 2.7e-12
    to 3.6e-11 at N = 16 (the reference's nonsymmetric eigenvalues err by about eps |p_max|, 1e-16 x
    3e5 rad/s, on |p|). The iteration's own poles make Z(p) singular to rounding: smallest over
    largest singular value < 1e-14, measured 1.0e-16 to 1.4e-16."""
    model = BeamModel(load_recording("data/examples/paper_rootcomp_hammer"), spec, n_intervals=16)
    params = {"EI": EI, "alpha": 0.05, "beta": MEMORY["beta"], **extra}
    system = model.system(params)
    assert system.form == form
    poles, ref = system.poles(), _frozen_kernel_poles(system)
    assert poles.size == system.size
    assert np.max(np.abs(np.sort_complex(poles) - ref) / np.abs(ref)) < 1e-10
    for p in poles:
        z = p**2 * system.M + p * system.D + system.K - system.relaxation(np.array([p]))[0] * system.K_h
        sv = np.linalg.svd(z, compute_uv=False)
        assert sv[-1] < 1e-14 * sv[0]


@pytest.mark.parametrize("spec, extra", [("q2+root_compliance", {"k_theta": 3500.0}),
                                         ("q2+axial_load", {"P": -3.0})])
def test_poles_below_a_frequency_follow_only_the_modes_that_can_reach_it(spec, extra, monkeypatch):
    """poles(below) is poles() cut at below (what a free decay's basis keeps), to 1e-12 relative:
    each mode's iteration runs alone, and following fewer modes can only change how many times a
    converged pole is refined (measured: identical). It follows only the
    modes under twice ``below``; when even the highest of those stays under ``below`` (forced here
    by following two modes), it follows every mode instead."""
    model = BeamModel(load_recording("data/examples/paper_rootcomp_hammer"), spec, n_intervals=16)
    system = model.system({"EI": EI, "alpha": 0.05, "beta": MEMORY["beta"], **extra})
    every = system.poles()
    below = 0.5 * (abs(every[2]) + abs(every[3]))                  # between the third and fourth pole
    assert system._tracked_modes(below) < system.size
    np.testing.assert_allclose(system.poles(below), every[:3], rtol=1e-12)
    monkeypatch.setattr(type(system), "_tracked_modes", lambda self, below: 2)
    np.testing.assert_allclose(system.poles(below), every[:3], rtol=1e-12)


def test_rayleigh_poles_equal_the_diagonal_newton_and_the_state_matrix_eigenvalues():
    """Two exact references: on a modal system (q2) the per-mode scalar Newton iteration; with a zero
    memory kernel beside non-modal damping, the eigenvalues of the first-order state matrix. Both
    < 1e-12 relative (measured 1e-20 and 2e-14)."""
    ops = BeamOperators(SplineBasis(LENGTH, 12, root="clamped"), rho_a=RHO_A, m_T=0.2, J=0.003)
    g = TimeHysteresis().relaxation(MEMORY)
    modal = SecondOrderSystem(ops.M, 0 * ops.M, EI * ops.K0, g, ops.K0)
    assert modal.form == "diagonal"
    diagonal = modal._poles_diagonal()
    assert np.max(np.abs(modal._poles_rayleigh(modal.size) - diagonal) / np.abs(diagonal)) < 1e-12
    air = Air().damping(ops, {"gamma": 0.3})
    zero = SecondOrderSystem(ops.M, air, EI * ops.K0, lambda s: np.zeros_like(s, dtype=complex), ops.K0)
    assert zero.form != "diagonal"
    plain = SecondOrderSystem(ops.M, air, EI * ops.K0)
    assert np.max(np.abs(zero.poles() - plain.poles()) / np.abs(plain.poles())) < 1e-12


def _tip_body_air(n=12, gamma=0.3):
    """q2 + air on a clamped beam with a tip body: M departs from rho_a M_0 along the tip body's
    two directions (m_T, J), so air damping gamma M_0 is diagonal plus rank two in the modes."""
    ops = BeamOperators(SplineBasis(LENGTH, n, root="clamped"), rho_a=RHO_A, m_T=0.2, J=0.003)
    w = np.linalg.svd(ops.M - RHO_A * ops.M0)[0][:, :2]
    g = TimeHysteresis().relaxation(MEMORY)
    return SecondOrderSystem(ops.M, Air().damping(ops, {"gamma": gamma}), EI * ops.K0, g, ops.K0, departures=w)


@pytest.mark.parametrize("system", [
    pytest.param(lambda: _system(_pinned(), (3500.0,)), id="root spring, rank 1"),
    pytest.param(lambda: _system(_pinned(30), (3500.0, -40.0), 0.3), id="two springs and air, rank 2"),
    pytest.param(lambda: _tip_body_air(12, 5.0), id="tip body and air, rank 2"),
])
def test_secular_poles_of_the_low_rank_form_equal_the_rayleigh_iteration(system):
    """The ``low_rank`` form's poles by Newton's method on its secular function, O(n r^2) per step,
    against the Rayleigh functional iteration (n x n solves; itself checked against the frozen-kernel
    reference above): < 1e-12 relative, measured 2e-19 to 4e-16 (both converge to rounding). Every
    pole makes Z(p) singular to rounding (smallest over largest singular value < 1e-14), and
    :meth:`poles` takes this path."""
    system = system()
    assert system.form == "low_rank"
    secular, rayleigh = system._poles_secular(system.size), system._poles_rayleigh(system.size)
    assert secular is not None
    assert np.max(np.abs(np.sort_complex(secular) - np.sort_complex(rayleigh)) / np.abs(np.sort_complex(rayleigh))) < 1e-12
    for p in secular:
        z = p**2 * system.M + p * system.D + system.K - system.relaxation(np.array([p]))[0] * system.K_h
        sv = np.linalg.svd(z, compute_uv=False)
        assert sv[-1] < 1e-14 * sv[0]
    upper = np.sort_complex(secular[secular.imag > 0])
    np.testing.assert_allclose(np.sort_complex(system.poles()), upper, rtol=1e-14)


def test_without_a_secular_root_the_poles_come_from_the_rayleigh_iteration(monkeypatch):
    """When the secular Newton iteration gives up (no convergence, or two modes on one root),
    :meth:`poles` takes the Rayleigh iteration: forced here, the poles are the Rayleigh ones."""
    system = _system(_pinned(), (3500.0,))
    rayleigh = system._poles_rayleigh(system.size)
    monkeypatch.setattr(SecondOrderSystem, "_poles_secular", lambda self, count: None)
    np.testing.assert_array_equal(np.sort_complex(system.poles()), np.sort_complex(rayleigh[rayleigh.imag > 0]))


def _svd_null_vector(system, p):
    vec = np.linalg.svd(system.dynamic_stiffness(np.array([p]))[0])[2][-1].conj()
    return vec / vec[np.argmax(np.abs(vec))]


@pytest.mark.parametrize("spec, extra", [("q1", {"gamma": 0.12, "cdI": 2e-5}),
                                         ("q3", {"gamma": 0.12, "a": 0.025, "b": 0.18}),
                                         ("q2+root_compliance", {"alpha": 0.05, "beta": 20.0, "k_theta": 3500.0}),
                                         ("q2+axial_load", {"alpha": 0.05, "beta": 20.0, "P": 5.0})])
def test_mode_shapes_are_the_null_vectors_of_the_dynamic_stiffness(spec, extra, monkeypatch):
    """One inverse-iteration solve per pole against the SVD's null vector (both scaled to a unit
    largest entry): < 1e-11, measured 2e-14 to 1.6e-12 at N = 16 (the poles are accurate to
    rounding; the solve's and the SVD's vectors differ by rounding over the gap to the next
    singular value). The SVD is not called on these poles; at a point that is not a pole the
    solve's residual is large and the SVD gives the smallest singular vector."""
    model = BeamModel(load_recording("data/examples/paper_rootcomp_hammer"), spec, n_intervals=16)
    system = model.system({"EI": EI, **extra})
    poles = system.poles()
    g = np.zeros(2) if system.relaxation is None else system.relaxation(poles[:2])
    raw = [p**2 * system.M + p * system.D + system.K - gp * (0 if system.K_h is None else system.K_h)
           for p, gp in zip(poles[:2], g)]
    np.testing.assert_allclose(system.dynamic_stiffness(poles[:2]), raw, rtol=1e-15, atol=0)
    expected = np.stack([_svd_null_vector(system, p) for p in poles], axis=1)
    with monkeypatch.context() as patch:
        patch.setattr(np.linalg, "svd", None)                  # the solve alone
        shapes = system.mode_shapes(poles)
    assert np.max(np.abs(shapes - expected)) < 1e-11
    off = 0.5 * (poles[0] + poles[1])
    np.testing.assert_allclose(system.mode_shapes(np.array([off]))[:, 0], _svd_null_vector(system, off), rtol=1e-12)


def test_poles_leave_out_modes_whose_iteration_does_not_converge():
    """Fractional damping c_f = 1 N m^2 s^nu, nu = 0.64 on the paper beam (EI 44.28 N m^2,
    diagonal form): from the seventh mode on c_f omega^nu exceeds 2 EI, each such mode's root lies
    far from i omega_m, and Newton's method from there wandered, once into the right half-plane
    (Re p = +20 s^-1, on a passive model). Every pole returned makes Z(p) singular to rounding
    (smallest over largest singular value < 1e-14, measured 7e-17) and lies in the left
    half-plane. With c_f = 1e-3 every mode converges and every mode's pole is kept."""
    model = BeamModel(load_recording("data/examples/paper_rootcomp_hammer"), "fractional", n_intervals=16)
    for c_f in (1.0, 1e-3):
        system = model.system({"EI": EI, "c_f": c_f, "nu": 0.64})
        assert system.form == "diagonal"
        poles = system.poles()
        assert np.all(poles.real < 0)
        for p in poles:
            sv = np.linalg.svd(system.dynamic_stiffness(np.array([p]))[0], compute_uv=False)
            assert sv[-1] < 1e-14 * sv[0]
    assert poles.size == system.size
