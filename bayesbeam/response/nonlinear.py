r"""Time integration of the nonlinear effects: quadratic drag and Coulomb friction with stick-slip.

The model is :math:`M\ddot w + D\dot w + K w = b\,f(t) + E\,g(t)`: the linear Galerkin system of
:class:`~bayesbeam.model.BeamModel` (any memory-free damping model, any linear effects) plus a
nonlinear force :math:`g` entering through :math:`E` -- the tip row :math:`e` for
``dry_friction``, :math:`B(x_q)^T \mathrm{diag}(w_q)` (4 Gauss points per interval) for
``quadratic_drag``.

Superposition: the linear part stays exact
------------------------------------------
.. math:: y = \underbrace{W\,H\,F}_{\text{exact linear solver}} + \;W\,H_E\,\mathcal{G},
          \qquad \mathcal{G}(s) = \int g(t)\,e^{-st}\,dt .

1. The first term is what :mod:`bayesbeam.response.linear` computes for the linear model
   (DAQ passband ``W`` applied once, static offset of a release), unchanged.
2. The integrator only produces the history ``g``. The nonlinear force needs the linear
   response's velocities (and, for friction, a few more signals) on a fine grid of step
   :math:`h = \Delta t/U`; they come exactly from the input spectrum by zero-padding, once per
   call. The input used for them is the recorded one, *through* ``W``: the recording does not
   determine the true input in the DAQ's transition band (0.40-0.50 fs), and ``W`` makes its
   acausal tails Gaussian (about 20 samples), so the integration starts at rest
   :data:`MARGIN` samples before the first sample and ends as many after the last, and nothing
   wraps around the exponentially windowed FFT period. (Shannon's brick-wall reconstruction has
   1/t tails, which that window amplifies by e^36 at the period's end: unusable.) For the linear
   model this choice is invisible; with a nonlinear force, results differ from a brick-wall
   input only inside the transition band (tests: 0.4% there for a held tip, 1e-10 below 0.40 fs).
3. ``g`` is a piecewise polynomial on the fine grid (per step its mean and first moment for
   friction; the cubic through the four nearest nodes for drag), whose transform is exact:
   the DFT of its node values times a hold kernel (:func:`hold_mean`, :func:`hold_moment`,
   :func:`hold_cubic`). Its response goes through the exact transfer function and ``W``, on a
   grid of its own with room for the margins: band-limited like the measured channels, with no
   aliasing from the fine grid. Only that grid's bins of the fine grid's DFT are formed: the U
   phases of the nodes (every U-th node from node j) transformed at the grid's length and
   combined with their shifts.

Hence ``F_c = 0`` or ``c_q = 0`` gives the linear solver's output exactly (the integrator runs
and adds zeros). Between nodes the linear dynamics are propagated exactly in the complex modes
:math:`\lambda_j` of the first-order form, so the stiff spline modes far above the band need no
small step; only the representation of ``g`` is discretised.

Drag: exponential integrator with a cubic force, implicit
---------------------------------------------------------
On step l the force is the cubic through nodes l-1 .. l+2; the modal state then obeys exactly
:math:`z_{l+1} = e^{\lambda h} z_l + \sum_j W_j(\lambda h)\,\beta g_{l+j}` with weights from
:math:`\varphi`-functions (:func:`hold_weights`), and :math:`g = -c_q |v| v` at the Gauss points
of the new nodes: implicit, fourth order for smooth forces (|v| v has a jump of its second
derivative where v changes sign: third to fourth order observed). Blocks of up to 256 nodes
(plus one of overlap, whose last step uses the quadratic through l-1 .. l+1) are solved together
by fixed-point iteration to :data:`DRAG_RTOL`, every sweep of a block (its linear recurrence
stepped node by node, the products to and from the Gauss points) in compiled code
(:func:`bayesbeam.response._kernels.drag_block`); where the iteration contracts too slowly the
block shrinks, down to one node with Newton's method, so any c_q is solved. Default U = 2
(:data:`SUBSTEPS`): on a hammer test of the paper's beam 0.7% of the drag effect's RMS (fourth
order: 0.05% at U = 4).

Friction: exact stick-slip, events located inside the steps
-----------------------------------------------------------
* *Slip* (``g = -F_c sign(v_tip)``, constant): closed-form modal propagation; the tip velocity
  at each node of a window (up to :data:`_WINDOW_MAX` nodes) is one row of a table times the
  state at the window's start.
* *Stick* (tip held): the beam with its tip held at the stuck deflection is an exact reduced
  linear system (basis :math:`T` of :math:`e^\perp`, the tip deflection along the static shape
  :math:`\psi = K^{-1}e/(e^TK^{-1}e)`). Its forced response and the force holding its tip (the
  friction demand) come once from the FFT like the linear response; a stick phase is the
  closed-form free propagation of the difference, and the demand at each node of a window is
  again one table row times the state. Each step's force is represented by its exact mean and first moment.
* Events are located inside the step: where the tip velocity reaches zero, or the demand
  reaches :math:`\pm F_c`, by a safeguarded Newton iteration on the exact intra-step solution
  (the linear signals interpolated by 6-point Lagrange polynomials on the nodes). At a zero of
  the velocity the tip sticks if the demand at that instant is within :math:`\pm F_c`,
  otherwise it slides on (normally reversed); a stuck tip starts to slide, in the direction of
  the demand, when the demand leaves :math:`\pm F_c`. Sub-step parts of a step are propagated
  exactly; the sub-step shape of the force enters the output through the step's mean and
  first moment. Default U = 16: on a hammer test with hundreds of events, 0.06% of the
  friction effect's RMS. Its error jumps wherever an event crosses a fine node, so the
  likelihood is rough on the scale of these jumps; on a long quiet record that scale reaches
  the posterior's own, and the samplers' moves stall: on 8 s of a released paper beam with
  20 mN of friction at 409.6 Hz, the log likelihood's jitter along log EI (steps 1e-5, a
  third of its posterior sd) is 1.3 nats at U = 8 and 0.14 at U = 16
  (tests/response/test_nonlinear.py), at about 1.5 x the cost per simulation
  (benchmarks/nonlinear_long.py).
* The whole event loop runs in compiled code, one call per simulation
  (:func:`bayesbeam.response._kernels.friction_run`): the sliding phases with every reversal
  inside them (:func:`~bayesbeam.response._kernels.friction_slide`), the held phases, the
  conversions between the two states and the location of the events. A forced record whose tip
  leaves a hold or sticks again takes a second call: the held-minus-free forced response those
  conversions read is built (one FFT) only for such a history. Python sets up the modes and
  window tables before, and the output stage after. The state is real, so the loop carries one
  mode of each complex-conjugate pair (weight 2) and the real ones (:func:`_half`); where the
  undamped modes diagonalise D, the modes of the free and of the held beam come in closed form
  per undamped mode (:func:`_mode_pairs`).

A force held constant over a step and chosen to null the tip velocity at its end (Moreau's
time-stepping on the exact exponential) would be unstable here: with :math:`\omega h \gg 1`
for the top spline modes the sampled zero dynamics leave the unit circle. The exactly held
system avoids that.

Release with friction: the initial state is the static deflection of the linear model under
``tip_load``, with the friction carrying none of the load (it was applied and held while the
contact was free, e.g. shaken loose); at release the tip sticks if :math:`F_c` can hold the full
elastic tip force ``tip_load``, otherwise it slides.

Not covered: ``free_decay`` recordings (the unknown state at ``start`` does not enter linearly),
memory mechanisms (time hysteresis) with a nonlinear effect, and both nonlinear effects at once.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from functools import lru_cache

import numpy as np
from scipy import fft, linalg

from bayesbeam.physics.effects.dry_friction import DryFriction
from bayesbeam.physics.effects.quadratic_drag import QuadraticDrag
from bayesbeam.response import _kernels
from bayesbeam.response.linear import FrequencyGrid
from bayesbeam.response.system import SecondOrderSystem

#: fine steps per sample (h = dt / U), chosen from the convergence study in the tests and, for
#: friction, the likelihood's smoothness on long records (module docstring)
SUBSTEPS = {"dry_friction": 16, "quadratic_drag": 2}
#: samples integrated before the first and after the last sample: W's kernel (and the filtered
#: input's tails) have a Gaussian envelope of about 20 samples standard deviation, below 1e-13
#: at 160
MARGIN = 160
#: relative tolerance of the drag's implicit equations (max-norm over a block): the fixed-point
#: iteration contracts by ~1e-3 per sweep for physical drag, so the solution is ~1e-11 exact
DRAG_RTOL = 1e-8
#: nodes per drag block: longer blocks need a few more sweeps, shorter ones more numpy calls
_DRAG_BLOCK = 256
#: fixed-point sweeps of a drag block before it is shrunk (it is, sooner, when they stall)
_DRAG_SWEEPS = 60
#: nodes between re-basings of the closed-form propagation in held and sliding phases (rows of
#: the window tables): the compiled loops stop at the first event whatever the window, so a
#: longer one saves nothing there and costs table rows built per simulation
_WINDOW_MIN, _WINDOW_MAX = 16, 64


# ----------------------------------------------------------------------------------- public
@dataclass
class NonlinearSolution:
    """The response and the history of the nonlinear force.

    ``output`` (n_samples, n_sensors) as :meth:`BeamModel.simulate`; ``step`` h (s);
    ``t_start`` time of node 0 relative to the first sample (s; negative when the integration
    starts before it). ``force``: friction, per step its mean and 12 x first moment
    (n_nodes - 1, 2) in N; drag, the generalized force at the nodes (n_nodes, n_dof) in N.
    ``final_state`` [w; w_t] at the last node (for a release the whole state; for a force the
    part due to ``g``). ``record``: per-node diagnostics when asked for (tip u, v and event
    counts for friction; Gauss-point velocities and forces for drag), else empty.
    """

    output: np.ndarray
    step: float
    t_start: float
    force: np.ndarray
    final_state: np.ndarray
    record: dict = field(default_factory=dict)


def simulate_nonlinear(model, params, initial=None, substeps: int | None = None) -> np.ndarray:
    """Sensor signals (n_samples, n_sensors) of a model with a nonlinear effect (see module doc)."""
    return integrate(model, params, initial, substeps).output


def integrate(model, params, initial=None, substeps: int | None = None, *, drag_law=None,
              record: bool = False) -> NonlinearSolution:
    """Integrate ``model`` at ``params``; see the module docstring for the method.

    ``substeps`` U (fine steps per sample) defaults to :data:`SUBSTEPS` of the effect.
    ``drag_law`` (drag only, for verification) ``(c_q, c_v)`` replaces the drag per unit length
    by -c_q |v| v - c_v v (c_q = 0: a linear force, which the exact solver can check).
    ``record`` keeps per-node diagnostics.
    """
    if initial is not None:
        raise ValueError("`initial` applies to free_decay recordings only")
    effect = next(e for e in model.effects if not e.linear)     # one: BeamModel refuses more
    values = model.values(params)
    system = model.system(values)
    U = int(substeps or SUBSTEPS[effect.name])
    if U < 1:
        raise ValueError(f"substeps must be >= 1, got {U}")
    rows, setup = model.placement(values)
    ops = model.operators(values)
    plant = _Plant(model, system, U, rows, model.load_at(values))
    if isinstance(effect, DryFriction):
        e_row = effect.contact_row(ops, setup)
        solver = _Friction(plant, e_row, effect.bound(values), record)
        force = solver.run()
        inputs, seq, hold = e_row[:, None], force[:, None, :], "moments"
    elif isinstance(effect, QuadraticDrag):
        rows, weights = effect.quadrature(ops)
        solver = _Drag(plant, rows, weights, drag_law or (values["c_q"], 0.0), record)
        force = solver.run()
        inputs, seq, hold = np.eye(plant.n), force, "cubic"
    else:  # pragma: no cover - guarded by the registry
        raise TypeError(f"no integrator for effect {effect.name}")
    chain = model.channel_response(values, plant.grid.s)
    y = model.linear_response(system, values) + plant.response(inputs, seq, hold, model.delay(values), chain)
    return NonlinearSolution(y, plant.h, plant.t_start, force, solver.final_state, solver.record)


# ----------------------------------------------------------------------------------- helpers
def phi1(z):
    """(e^z - 1)/z, accurate for small |z| (complex)."""
    z = np.asarray(z, dtype=complex)
    small = np.abs(z) < 1e-4
    safe = np.where(small, 1.0, z)
    return np.where(small, 1 + z / 2 + z * z / 6, np.expm1(safe) / safe)


def _modes(system: SecondOrderSystem):
    """Complex modes (lambda, V, V^-1) of the first-order form. Complex even when every mode is
    overdamped, where the eigen-solver returns real arrays: the integrator's modal states are
    complex throughout (and its compiled kernels typed so).

    Where the undamped modes diagonalise D (the ``diagonal`` form, no memory term) each mode's
    pair is in closed form (:func:`_mode_pairs`), with no eigen-solve of the first-order form.
    """
    if system.relaxation is None and system.form == "diagonal":
        return _mode_pairs(*system.undamped, np.diag(system.modal_damping), system.M)
    lam, vec = system.state_modes
    vec = vec.astype(complex)
    return lam.astype(complex), vec, np.linalg.inv(vec)


def _mode_pairs(omega2: np.ndarray, phi: np.ndarray, c: np.ndarray, M: np.ndarray):
    r"""(lambda, V, V^-1) of q'' + c q' + omega^2 q = 0 per undamped mode phi (mass-normalised).

    The roots :math:`\lambda_\pm = -c/2 \pm \sqrt{c^2/4 - \omega^2}` (Im >= 0 first), the
    columns :math:`[\phi; \lambda \phi]`, and from q = phi^T M w the coordinates
    :math:`z_+ = (q' - \lambda_- q)/(\lambda_+ - \lambda_-)`, :math:`z_- = (\lambda_+ q - q')/(\lambda_+ - \lambda_-)`.
    """
    root = np.sqrt(0.25 * c * c - omega2 + 0j)
    plus, minus = -0.5 * c + root, -0.5 * c - root
    gap = (plus - minus)[:, None]
    rows = (phi.T @ M) / gap
    lam = np.concatenate([plus, minus])
    V = np.block([[phi, phi], [phi * plus, phi * minus]])
    Vi = np.block([[-minus[:, None] * rows, rows], [plus[:, None] * rows, -rows]])
    return lam, V, Vi


def _half(lam: np.ndarray, V: np.ndarray, Vi: np.ndarray) -> tuple:
    """The modes (lambda, V, V^-1) of :func:`_half_modes` only, V's columns times their weights:
    a real state's modal coordinates on the other modes are the conjugates, so ``(V z).real``
    and every Re(c . z) of the kept coordinates z = V^-1 x equal the full sums, at half the work."""
    keep, twice = _half_modes(lam)
    return lam[keep], V[:, keep] * twice, Vi[keep]


def _real_rows(a: np.ndarray) -> np.ndarray:
    """Re a, -Im a interleaved by columns: ``_real_rows(a) @ z.view(float) = Re(a @ z)``.

    One real product on the complex vector's own memory, with no copy of its parts.
    """
    out = np.empty(a.shape[:-1] + (2 * a.shape[-1],))
    out[..., 0::2], out[..., 1::2] = a.real, -a.imag
    return out


def _complex_columns(a: np.ndarray) -> np.ndarray:
    """Re a, Im a interleaved by columns: ``(x @ _complex_columns(a)).view(complex) = x @ a`` for real x."""
    out = np.empty(a.shape[:-1] + (2 * a.shape[-1],))
    out[..., 0::2], out[..., 1::2] = a.real, a.imag
    return out


def _stack(z: np.ndarray) -> np.ndarray:
    """The real and imaginary parts of a complex vector, interleaved (a view), for :func:`_real_rows`."""
    return np.ascontiguousarray(z).view(float)


def _powers(base: np.ndarray, count: int) -> np.ndarray:
    """Rows base**0 .. base**(count - 1) by cumulative products: rounding ~count x 1e-16, at a
    fraction of the cost of count x size complex exponentials."""
    out = np.empty((count, base.size), dtype=base.dtype)
    out[0] = 1.0
    np.cumprod(np.broadcast_to(base, (count - 1, base.size)), axis=0, out=out[1:])
    return out


def _half_modes(lam: np.ndarray):
    """Indices of the modes with Im >= 0 and their weights (2 for complex, 1 for real ones).

    For a real state the coefficients of conjugate modes are conjugate, so Re(c z) summed
    over all modes equals Re(2 c z) over the upper half plus the real modes.
    """
    scale = np.max(np.abs(lam))
    real = np.abs(lam.imag) <= 1e-12 * scale
    keep = np.flatnonzero(real | (lam.imag > 0))
    return keep, np.where(real[keep], 1.0, 2.0)


@lru_cache(maxsize=8)
def _plant_grid(n: int, dt: float) -> FrequencyGrid:
    """The plant's FFT grid, one per record length: its bins, window and passband are computed once."""
    return FrequencyGrid(n, dt)


@lru_cache(maxsize=8)
def _output_kernels(grid: FrequencyGrid, substeps: int, t_start: float, hold: str, count: int) -> tuple:
    """Parameter-free factors of the output stage: the window e^{-sigma t} of the ``count``
    nodes (from node 0), and per hold kernel, bin and phase j (the nodes j, j + U, ...: see
    :meth:`_Plant.response`) one factor (n_holds, n_bins, U).

    The factor: the hold kernel (:func:`hold_cubic`, or :func:`hold_mean` and
    :func:`hold_moment`) at x = s h, times the passband W, 1/U (the node sums approximate
    integrals over h = dt/U), the shift e^{-s t_start} of node 0 and the phase's own shift
    e^{-2 pi i j k / (U n_fft)} on bin k.
    """
    h = grid.dt / substeps
    x = grid.s * h
    gain = grid.weight / substeps * np.exp(-grid.s * t_start)
    holds = (hold_cubic(x),) if hold == "cubic" else (hold_mean(x), hold_moment(x))
    bins = np.arange(grid.freq.size)
    phases = np.exp(-2j * np.pi / (substeps * grid.n_fft) * np.outer(bins, np.arange(substeps)))
    factors = np.stack([(k * gain)[:, None] * phases for k in holds])
    return np.exp(-grid.sigma * h * np.arange(count)), factors


def _cyclic_take(x: np.ndarray, start: int, count: int) -> np.ndarray:
    """Entries start .. start + count - 1 along x's last axis, modulo its length (before 0 wraps).

    The signals here are FFT'd along their last, contiguous axis: 30-40 % faster than along
    axis 0 of the (time, channel) arrays, with identical results.
    """
    return x[..., (start + np.arange(count)) % x.shape[-1]]


class _Plant:
    """The linear system on the fine grid: modes, input signals, and the exact output stage."""

    def __init__(self, model, system: SecondOrderSystem, substeps: int, rows: np.ndarray, load: np.ndarray):
        rec = model.recording
        # an FFT grid of its own with room for MARGIN samples before and after the record (and
        # for a release before the first sample), far from the windowed period's wrap-around
        before = max(0, int(np.ceil(float(rec.time[0]) / rec.dt)))
        grid = _plant_grid(rec.n_samples + 3 * MARGIN + before, rec.dt)
        self.model, self.system, self.grid = model, system, grid
        self.rows = rows            # the sensors' point rows (n_sensors, n_dof), where they sit at these values
        self.n = system.size
        self.U = substeps
        self.h = rec.dt / substeps
        self.lam, self.V, self.Vi = _modes(system)
        self.Minv = np.linalg.inv(system.M)
        exc = rec.excitation
        # samples integrated before the first one and after the last: the filtered input's
        # Gaussian tails and the passband's kernel on the output need ~150 (see MARGIN)
        margin = MARGIN
        t_end = float(rec.time[-1] - rec.time[0]) + margin * rec.dt
        if exc.kind == "release":
            # node 0 is the release (t = 0); the first sample is at rec.time[0]
            self.t_start = -float(rec.time[0])
            self.x0 = np.concatenate([np.linalg.solve(system.K, load * exc.tip_load),
                                      np.zeros(self.n)])
        else:
            self.t_start = -margin * rec.dt
            self.x0 = np.zeros(2 * self.n)
        self.forced = exc.kind == "force"
        self.n_nodes = int(np.ceil((t_end - self.t_start) / self.h - 1e-9)) + 1
        self.n_fine = substeps * grid.n_fft
        if self.n_nodes > self.n_fine:       # the history must not wrap around the FFT period
            raise ValueError("the integration interval does not fit the FFT grid")
        self.tau = self.t_start + self.h * np.arange(self.n_nodes)
        if self.forced:
            # the input as recorded: the samples' spectrum through the passband W. Its acausal
            # tails are Gaussian (about 20 samples), so the history can start at rest before the
            # first sample and nothing wraps around the exponentially windowed FFT period
            self.s_in = grid.s
            force = np.concatenate([model.force, np.zeros(grid.n - rec.n_samples)])
            self.f_in = grid.spectrum(force) * grid.weight
            self.b = load
            self._offset = round(self.t_start / self.h)

    # ------------------------------------------------------------------ input signals
    def fine(self, spectrum: np.ndarray) -> np.ndarray:
        """Samples at the nodes (n_nodes, ch) of a signal given on the grid's bins.

        Zero-padding the spectrum interpolates the (band-limited) signal; nodes before the first
        sample are read from the end of the period, where the window makes them exact.
        """
        x = _cyclic_take(fft.irfft(spectrum.T, self.n_fine), self._offset, self.n_nodes)
        return (x * (self.U * np.exp(self.grid.sigma * self.tau))).T

    def coarse(self, spectrum: np.ndarray, factor: int = 2, pad: int = 32):
        """A signal tabulated at step dt/factor from ``pad`` steps before node 0, for :meth:`at`.

        Cheaper than :meth:`fine` when a signal is read only at a few (event) times.
        """
        step = self.grid.dt / factor
        start = round(self.t_start / step) - pad
        count = int(np.ceil((self.tau[-1] - self.t_start) / step)) + 2 * pad + 1
        t = start * step + step * np.arange(count)
        x = _cyclic_take(fft.irfft(spectrum.T, factor * self.grid.n_fft), start, count)
        return (x * (factor * np.exp(self.grid.sigma * t))).T, start * step, step

    def linear_spectrum(self, C: np.ndarray, order: int = 0) -> np.ndarray:
        """Spectrum of C w^(order) of the linear response to the input, (n_bins, n_rows)."""
        h = self.system.transfer(self.s_in, C, self.b[:, None])[:, :, 0]
        return h * (self.s_in**order * self.f_in)[:, None]

    # ------------------------------------------------------------------ output stage
    def response(self, inputs: np.ndarray, seq: np.ndarray, hold: str, delay: float,
                 chain: np.ndarray | None = None) -> np.ndarray:
        """Sensor outputs (n, n_sensors) of the force history ``seq`` applied through ``inputs``.

        ``inputs`` (n_dof, r) are the load vectors of r forces. hold "cubic": ``seq``
        (n_nodes, r) holds node values of forces interpolated by the cubic through the four
        nearest nodes (:func:`hold_cubic`). hold "moments": ``seq``
        (n_nodes - 1, r, 2) holds per step the mean c0 and the first moment
        c1 = 12 int_0^1 (u - 1/2) g du of each force (u = (t - t_k)/h): the force is taken as
        c0 + c1 (u - 1/2) on each step, exact for forces linear within the steps. ``chain``
        (n_freq, n_sensors): the measurement chain on this grid (BeamModel.channel_response), or None.
        """
        grid, model = self.grid, self.model
        series = seq.T if hold == "moments" else seq.T[None]          # (n_holds, r, count)
        window, factors = _output_kernels(grid, self.U, self.t_start, hold, series.shape[-1])
        # the DFT of length U n_fft on its first n_fft/2 + 1 bins, as the U phases' DFTs of
        # length n_fft (nodes j, j + U, ...) combined with their shifts: the bins kept only
        padded = np.zeros(series.shape[:-1] + (self.n_fine,))
        np.multiply(series, window, out=padded[..., :series.shape[-1]])
        phases = fft.rfft(padded.reshape(series.shape[:-1] + (grid.n_fft, self.U)), axis=-2)
        spec = np.einsum("crkj,ckj->rk", phases, factors)
        if delay:
            spec *= np.exp(-grid.s * delay)
        h = self.system.transfer(grid.s, self.rows, inputs)
        out = np.einsum("for,rf->fo", h, spec)
        out *= np.stack([grid.s**q for q in model.orders], axis=1)
        if chain is not None:
            out *= chain
        return grid.samples(out)[: model.recording.n_samples]


def hold_mean(x):
    """int_0^1 exp(-x u) du = (1 - e^-x)/x: transform of a unit step-long pulse (per h)."""
    x = np.asarray(x, dtype=complex)
    small = np.abs(x) < 1e-4
    safe = np.where(small, 1.0, x)
    return np.where(small, 1 - x / 2 + x * x / 6, -np.expm1(-safe) / safe)


def hold_moment(x):
    """int_0^1 (u - 1/2) exp(-x u) du: transform of the step-long ramp u - 1/2 (per h)."""
    x = np.asarray(x, dtype=complex)
    small = np.abs(x) < 0.1
    safe = np.where(small, 1.0, x)
    series = np.zeros_like(x)
    term = np.ones_like(x)                            # (-x)^k / k!
    for k in range(1, 16):                            # sum (-x)^k/k! * k / (2 (k+1)(k+2))
        term = term * (-x) / k
        series = series + term * k / (2.0 * (k + 1) * (k + 2))
    direct = (-np.expm1(-safe) - safe * np.exp(-safe)) / safe**2 + 0.5 * np.expm1(-safe) / safe
    return np.where(small, series, direct)


# ----------------------------------------------------------------------------------- friction
def _lagrange_coefficients(points: int = 6) -> np.ndarray:
    """C (points, points): weight of node j at xi is sum_p C[j, p] xi^p (nodes 0..points-1)."""
    nodes = np.arange(points, dtype=float)
    out = np.empty((points, points))
    for j in range(points):
        others = np.delete(nodes, j)
        poly = np.poly(others) / np.prod(nodes[j] - others)
        out[j] = poly[::-1]
    return out


_LAGRANGE = _lagrange_coefficients()


def _compose(coef: np.ndarray, offset: float) -> np.ndarray:
    """Coefficients of p(offset + theta) in powers of theta, p given by ``coef`` (ascending)."""
    out = np.zeros(coef.size)
    shift = np.array([1.0])
    for c in coef:                       # p = sum c_i (offset + theta)^i
        out[: shift.size] += c * shift
        shift = np.convolve(shift, [offset, 1.0])
    return out


#: _SHIFTED[o] (6, 6): the six node values of a signal -> its interpolant on the step at offset o
#: from the first of them, in ascending powers of theta (:func:`_kernels.step_poly`)
_SHIFTED = np.array([[_compose(_LAGRANGE[j], off) for j in range(6)] for off in range(6)])
_NO_RECORD = np.zeros(0)


#: most events handled inside one fine step before the step is finished without further checks
_MAX_EVENTS_PER_STEP = 32


def _moment_weights() -> np.ndarray:
    """Weights of nodes l-1 .. l+2 giving the mean and 12 x first moment of their cubic on step l."""
    out = np.zeros((2, 4))
    for j, c in enumerate(_lagrange((-1.0, 0.0, 1.0, 2.0))):
        poly = np.polynomial.Polynomial(c)
        out[0, j] = poly.integ()(1.0) - poly.integ()(0.0)
        ramp = poly * np.polynomial.Polynomial([-0.5, 1.0])
        out[1, j] = 12.0 * (ramp.integ()(1.0) - ramp.integ()(0.0))
    return out


@lru_cache(maxsize=8)
def _null_basis(e: tuple) -> tuple[np.ndarray, np.ndarray]:
    """An orthonormal basis T of the null space of the row e, and T^T (both contiguous): one
    SVD per contact row, not per simulation."""
    T = np.ascontiguousarray(linalg.null_space(np.array(e)[None, :]))
    return T, np.ascontiguousarray(T.T)


class _Friction:
    """Exact event-driven stick-slip (see the module docstring)."""

    def __init__(self, plant: _Plant, e: np.ndarray, F_c: float, record: bool):
        self.p, self.e, self.F_c, self.keep = plant, e, F_c, record
        p, n, h = plant, plant.n, plant.h
        system = p.system
        M, D, K = system.M, system.D, system.K
        lam, V, Vi = self.lam, self.V, self.Vi = _half(p.lam, p.V, p.Vi)
        self.Minv_e = p.Minv @ e
        self.mu = float(e @ self.Minv_e)
        self.beta = Vi[:, n:] @ self.Minv_e
        self.cv, self.cu = e @ V[n:, :], e @ V[:n, :]
        self.cv_lam = self.cv * lam                          # tip acceleration of the free state
        self.gamma_h = h * phi1(lam * h) * self.beta         # state change per unit force, one step
        self.lam_h, self.beta_lam = lam * h, self.beta / lam
        self.cvb = self.cv * self.beta_lam
        idx = np.arange(_WINDOW_MAX + 1)
        self.epow = _powers(np.exp(self.lam_h), idx.size)
        self.spow = np.vstack([np.zeros_like(lam), np.cumsum(self.epow[:-1], axis=0)])
        # the sliding tip's velocity (and, recorded, displacement) j steps on: pv[j] . z + gam qv[j]
        pv = _real_rows(self.cv * self.epow)
        qv = (self.spow @ (self.cv * self.gamma_h)).real
        pu, qu = (_real_rows(self.cu * self.epow), (self.spow @ (self.cu * self.gamma_h)).real) if record else (pv, qv)
        self._tables = (pv, qv, pu, qu, self.epow, self.spow)
        self._free = np.stack([self.epow[1], self.lam_h, self.beta_lam, self.cv, self.cvb, self.cv_lam, self.cu, self.gamma_h])
        # the beam with its tip held: w = T q + psi u_tip, T spanning the null space of e
        self.T, T_t = _null_basis(tuple(e))
        kinv_e = np.linalg.solve(K, e)
        self.k_tip = 1.0 / float(e @ kinv_e)
        self.psi = kinv_e * self.k_tip
        T = self.T
        Mr, Dr, Kr = T.T @ M @ T, T.T @ D @ T, T.T @ K @ T
        self.reduced = SecondOrderSystem(Mr, Dr, Kr)
        lr, Vr, Vri = _half(*_modes(self.reduced))
        self.Vr, self.Vri, self.lr_h = Vr, Vri, lr * h
        ee = float(e @ e)
        MT_Mr = M @ T @ np.linalg.inv(Mr)
        row_q = e @ (K @ T - MT_Mr @ Kr) / ee
        row_qd = e @ (D @ T - MT_Mr @ Dr) / ee
        self.cg = np.concatenate([row_q, row_qd]) @ Vr       # held-tip force of the held state
        self.er_pow = _powers(np.exp(lr * h), idx.size)
        self.pg = _real_rows(self.cg * self.er_pow)
        # exact mean and first moment over step i of the held state's force: the held beam's
        # top modes oscillate within a step, so node values would alias them
        mean = phi1(lr * h)
        moment = 12.0 * hold_moment(-lr * h)
        self.pg_mean = _real_rows(self.cg * self.er_pow[:-1] * mean)
        self.pg_moment = _real_rows(self.cg * self.er_pow[:-1] * moment)
        self._linear_signals()
        # what the compiled event loop reads (:func:`_kernels.friction_run`)
        self._held = (self.lr_h, self.cg, self.k_tip, self.er_pow, self.pg, self.pg_mean, self.pg_moment,
                      np.ascontiguousarray(self._lin_moments))
        self._conv = (V, Vi, Vr, Vri, T, T_t, self.psi, self.Minv_e, np.ascontiguousarray(e))

    # ------------------------------------------------------------------ linear signals
    def _linear_signals(self):
        """Tip velocity, acceleration and held-tip force of the forced responses, at the nodes."""
        p, e, n = self.p, self.e, self.p.n
        if not p.forced:                   # a release: no forced response
            self.lin = np.zeros((p.n_nodes, 4))
            self._lin_moments = np.zeros((2, p.n_nodes))
            return
        T = self.T
        qc = self.reduced.transfer(p.s_in, np.eye(n - 1), (T.T @ p.b)[:, None])[:, :, 0] * p.f_in[:, None]
        s = p.s_in[:, None]
        system = p.system
        demand = ((s**2 * qc) @ (e @ system.M @ T) + (s * qc) @ (e @ system.D @ T)
                  + qc @ (e @ system.K @ T) - (e @ p.b) * p.f_in) / float(e @ e)
        self._held_spec = qc
        tip = p.linear_spectrum(e[None, :])
        # columns: v_lin, a_lin, held force, u_lin at the tip
        self.lin = np.ascontiguousarray(p.fine(np.hstack([s * tip, s**2 * tip, demand[:, None], tip])))
        # mean and first moment over every step of the held beam's forced force, from the cubic
        # through the four nearest nodes (clamped at the ends)
        col = self.lin[:, 2]
        v = col[np.clip(np.arange(-1, col.size + 2), 0, col.size - 1)]
        self._lin_moments = [w[0] * v[:-3] + w[1] * v[1:-2] + w[2] * v[2:-1] + w[3] * v[3:]
                             for w in _STEP_MOMENTS]

    def diff_spectrum(self) -> np.ndarray:
        """Spectrum (n_bins, n) of w_held - w_free, the held minus the free forced response."""
        return self._held_spec @ self.T.T - self.p.linear_spectrum(np.eye(self.p.n))

    def _diff(self) -> tuple:
        """The kernel's held-minus-free response of a forced record: :meth:`diff_spectrum`, the
        bins, and the response with its rate tabulated at dt/2 (:meth:`_Plant.coarse`); and
        ``timing`` (see :func:`_kernels.friction_run`) with the table's start and step. Built at
        the first conversion that needs it: a history that never leaves its initial hold nor
        sticks again never does."""
        p, spectrum = self.p, self.diff_spectrum()
        table, t0, step = p.coarse(np.hstack([spectrum, p.s_in[:, None] * spectrum]))
        timing = np.array([1.0, p.t_start, p.h, t0, step, p.grid.n_fft])
        return (spectrum, p.s_in, np.ascontiguousarray(table)), timing

    def run(self) -> np.ndarray:
        """The stick-slip history in compiled code (:func:`_kernels.friction_run`): one call, or
        two for a forced record whose tip leaves a hold or sticks (the second after building
        :meth:`_diff`). Returns per step the force's mean and 12 x first moment (N)."""
        p, n = self.p, self.p.n
        last = p.n_nodes - 1
        c0, c1 = np.zeros(last), np.zeros(last)
        counts = np.zeros(4, dtype=np.int64)              # stick, slip, reversal, tangency
        rec_u, rec_v = (np.zeros(p.n_nodes), np.zeros(p.n_nodes)) if self.keep else (_NO_RECORD, _NO_RECORD)
        ints = np.zeros(5, dtype=np.int64)
        reals = np.zeros(7)
        z, y = (self.Vi @ p.x0).astype(complex), np.zeros(self.lr_h.size, dtype=complex)
        diff = (np.zeros((0, n), dtype=complex), p.grid.s, np.zeros((0, 2 * n)))
        timing = np.array([float(p.forced), p.t_start, p.h, 0.0, 1.0, p.grid.n_fft])
        while _kernels.friction_run(ints, reals, z, y, last, self._free, self._tables, self._held, self._conv,
                                    self.lin, _LAGRANGE, _SHIFTED, self.F_c, self.mu, timing, diff, c0, c1,
                                    counts, self.keep, rec_u, rec_v, _MAX_EVENTS_PER_STEP, _WINDOW_MIN,
                                    _WINDOW_MAX) == _kernels.NEED_DIFF:
            diff, timing = self._diff()
        self.final_state = (self.V @ z).real
        events = dict(zip(("stick", "slip", "reversal", "tangency"), counts.tolist()))
        self.record = {"u_tip": rec_u, "v_tip": rec_v, "events": events} if self.keep else {}
        return np.stack([c0, c1], axis=1)


# ----------------------------------------------------------------------------------- drag
#: Lagrange bases of the drag force on one step (theta in [0, 1] from node l to l + 1):
#: the cubic through nodes l-1 .. l+2 inside a block, the quadratic through l-1 .. l+1 at its end
_CUBIC_NODES, _QUADRATIC_NODES = (-1.0, 0.0, 1.0, 2.0), (-1.0, 0.0, 1.0)
#: modes with |lambda h| above this get the linear hold inside the integrator
_RESOLVED = np.inf


def phis(z, kmax: int) -> list:
    """[phi_1(z), ..., phi_kmax(z)], phi_k(z) = int_0^1 e^{(1-t) z} t^(k-1)/(k-1)! dt (complex)."""
    z = np.asarray(z, dtype=complex)
    small = np.abs(z) < 1.5
    safe = np.where(small, 1.0, z)
    out, prev, fact = [], np.exp(safe), 1.0
    for k in range(1, kmax + 1):
        rec = (prev - 1.0 / fact) / safe                   # phi_k = (phi_{k-1} - 1/(k-1)!)/z
        series = np.zeros_like(z)
        term = np.full_like(z, 1.0 / np.prod(np.arange(1, k + 1, dtype=float)))
        for m in range(20):                     # sum z^m / (m + k)!, |z| < 1.5: 1.5^20/20! = 1e-15
            series = series + term
            term = term * z / (m + k + 1)
        out.append(np.where(small, series, rec))
        prev, fact = rec, fact * k
    return out


def _lagrange(nodes) -> list[np.ndarray]:
    """Ascending monomial coefficients of the Lagrange basis polynomials on ``nodes``."""
    out = []
    for j, xj in enumerate(nodes):
        others = [x for i, x in enumerate(nodes) if i != j]
        out.append(np.poly(others)[::-1] / np.prod([xj - x for x in others]))
    return out


_STEP_MOMENTS = None     # set below, once _lagrange exists


def hold_weights(z, nodes) -> list:
    """int_0^1 e^{z (1-t)} L_j(t) dt for the Lagrange basis L_j on ``nodes`` (per z)."""
    basis = _lagrange(nodes)
    ph = phis(z, len(nodes))
    fact = np.cumprod([1.0] + list(range(1, len(nodes))))
    return [sum(c[k] * fact[k] * ph[k] for k in range(len(nodes))) for c in basis]


def hold_cubic(x):
    """Transform (per h) of the piecewise-cubic interpolant of unit node values, per node.

    With g(t_l + t h) = sum_j g_{l+j} L_j(t) (cubic through nodes l-1..l+2), the transform of
    the force is h sum_m g_m e^{-s t_m} K(s h) with K(x) = sum_j e^{j x} int_0^1 e^{-x t} L_j(t) dt
    = sum_j e^{(j-1) x} int_0^1 e^{x (1-t)} L_j(t) dt.
    """
    x = np.asarray(x, dtype=complex)
    w = hold_weights(x, _CUBIC_NODES)
    return sum(np.exp((j - 1) * x) * wj for j, wj in zip(_CUBIC_NODES, w))


class _Drag:
    """Exponential integrator with a cubic force interpolant, implicit, block fixed-point iteration.

    On each step the drag force is the cubic through the nodes l-1 .. l+2 (the last step of a
    block, which is not kept, the quadratic through l-1 .. l+1); the linear part is exact, so
    the rule is fourth order for smooth forces. The block's nodes (plus one node of overlap)
    are found together by fixed-point iteration on g = law(v); see the module docstring.
    """

    def __init__(self, plant: _Plant, rows: np.ndarray, weights: np.ndarray, law: tuple[float, float],
                 record: bool):
        self.p, self.rows = plant, rows
        self.c_q, self.c_v = law           # drag per unit length -c_q |v| v - c_v v
        self.keep = record
        p, n, h = plant, plant.n, plant.h
        # one mode of each complex-conjugate pair (twice its real part), and the real modes
        self.modes, self.twice = _half_modes(p.lam)
        lam = p.lam[self.modes]
        self.beta = p.Vi[self.modes, n:] @ (p.Minv @ (rows.T * weights))     # (m, n_q)
        self.C = (rows @ p.V[n:, self.modes]) * self.twice                  # (n_q, m)
        self.m = lam.size
        # the sweeps' products pass through the n degrees of freedom (n < n_q, m): Gauss forces
        # -> generalized forces -> modal inputs, modal states -> generalized velocities -> Gauss
        # velocities, in real forms on the complex vectors' memory
        self.rows_w, self.rows_T = rows * weights[:, None], np.ascontiguousarray(rows.T)
        self.to_modal = _complex_columns((p.Vi[self.modes, n:] @ p.Minv).T)            # (n, 2m)
        self.to_velocity = np.ascontiguousarray(_real_rows(p.V[n:, self.modes] * self.twice).T)  # (2m, n)
        # cubic weights for the resolved modes; the linear hold (trapezoidal rule) for modes with
        # |lambda h| > 1, on which a cubic of aliased samples can pump energy (seen at U = 2)
        resolved = np.abs(lam * h) <= _RESOLVED
        linear = [h * w for w in hold_weights(lam * h, (0.0, 1.0))]
        zero = np.zeros_like(lam)
        self.cubic = np.array([np.where(resolved, h * w, lw) for w, lw in
                               zip(hold_weights(lam * h, _CUBIC_NODES), [zero] + linear + [zero])])
        self.quad = np.array([np.where(resolved, h * w, lw) for w, lw in
                              zip(hold_weights(lam * h, _QUADRATIC_NODES), [zero] + linear)])
        self.E = np.exp(lam * h)
        # the linear response's generalized velocities at the nodes (none: a release)
        self.vlin = p.fine(p.linear_spectrum(np.eye(n), order=1)) if p.forced else np.zeros((0, n))

    def law(self, v: np.ndarray) -> np.ndarray:
        """The drag per unit length (N/m) at the velocities v (m/s) (:func:`_kernels.drag_law`)."""
        return _kernels.drag_law(v, self.c_q, self.c_v)

    def _states(self, z0: np.ndarray, u: np.ndarray, k: int):
        """States at nodes k+1 .. k+S (S, m) from ``z0`` at node k, and their Gauss-point velocities.

        ``u`` (S + 2, m): the modal forces at nodes k-1 .. k+S (:func:`_kernels.drag_velocities`).
        """
        z = np.empty((u.shape[0] - 2, self.m), dtype=complex)
        return z, _kernels.drag_velocities(z0, u, self.cubic, self.quad, self.E, self._linear_velocities(k, z.shape[0]),
                                           self.to_velocity, self.rows_T, z)

    def _linear_velocities(self, k: int, count: int) -> np.ndarray:
        """The linear response's generalized velocities at nodes k+1 .. k+count, or (0, n) for none."""
        return self.vlin[k + 1:k + count + 1] if self.vlin.size else self.vlin

    def run(self) -> np.ndarray:
        p = self.p
        last = p.n_nodes - 1
        n_q = self.rows.shape[0]
        z = (p.Vi @ p.x0)[self.modes]
        v0 = (self.vlin[0] @ self.rows_T if self.vlin.size else 0.0) + (self.C @ z).real
        g_nodes = np.zeros((p.n_nodes + 1, n_q))       # row 0 is node -1 (at rest: no force)
        g_nodes[1] = self.law(v0)
        if self.keep:
            v_nodes = np.zeros((p.n_nodes, n_q))
            v_nodes[0] = v0
        block, k = _DRAG_BLOCK, 0
        self.iterations = self.newton_blocks = 0
        while k < last:
            L = min(block, last - k)
            S = L + 1 if k + L < last else L                # one node of overlap when possible
            u = np.zeros((S + 2, self.m), dtype=complex)   # modal forces at nodes k-1 .. k+S
            u[:2] = self._modal_input(g_nodes[k:k + 2])
            ok, sweeps, g, states, v, g_new = _kernels.drag_block(
                z, u, self.cubic, self.quad, self.E, self._linear_velocities(k, S), self.to_velocity, self.rows_T,
                self.rows_w, self.to_modal, self.c_q, self.c_v, DRAG_RTOL, _DRAG_SWEEPS)
            self.iterations += sweeps
            if not ok:
                if L > 1:
                    block = max(1, L // 4)
                    continue
                g, states, v = self._newton(z, g_nodes[k:k + 2], k, g_new, S)
                self.newton_blocks += 1
            g_nodes[k + 2:k + L + 2] = g[:L]
            if self.keep:
                v_nodes[k + 1:k + L + 1] = v[:L]
            z = states[L - 1]
            k += L
            block = min(2 * block, _DRAG_BLOCK) if ok else block
        self.final_state = (p.V[:, self.modes] @ (z * self.twice)).real
        self.record = {"v_gauss": v_nodes, "g_gauss": g_nodes[1:]} if self.keep else {}
        return g_nodes[1:] @ self.rows_w

    def _modal_input(self, g: np.ndarray) -> np.ndarray:
        """Modal inputs beta g for Gauss forces g (L, n_q)."""
        return (g @ self.rows_w @ self.to_modal).view(complex)

    def _newton(self, z0, g_known, k, g_guess, S):
        """The S (<= 2) nodes of a one-step block from state ``z0`` at node k by Newton's method
        in the Gauss forces.

        v = v_c + R g is affine in the unknown forces g (S n_q); R is built column block by
        column block from the step weights.
        """
        n_q, m = self.rows.shape[0], self.m
        u = np.zeros((S + 2, m), dtype=complex)
        u[:2] = self._modal_input(g_known)
        v_c = self._states(z0, u, k)[1]
        R = np.zeros((S * n_q, S * n_q))
        rest = np.zeros(m, dtype=complex)
        for i in range(S):                                  # response to unit forces at node k+1+i
            unit = np.zeros((S + 2, m), dtype=complex)
            unit[i + 2] = 1.0
            t = np.empty((S, m), dtype=complex)             # states at nodes k+1 .. k+S per unit modal input
            _kernels.drag_states(rest, unit, self.cubic, self.quad, self.E, t)
            for j in range(S):
                R[j * n_q:(j + 1) * n_q, i * n_q:(i + 1) * n_q] = ((self.C * t[j]) @ self.beta).real
        g = g_guess.ravel().copy()
        for _ in range(50):
            v = v_c.ravel() + R @ g
            r = g - self.law(v)
            slope = -2.0 * self.c_q * np.abs(v) - self.c_v          # d law / dv
            jac = np.eye(g.size) - slope[:, None] * R
            dg = np.linalg.solve(jac, -r)
            g = g + dg
            if np.max(np.abs(dg)) <= DRAG_RTOL * max(np.max(np.abs(g)), 1e-300):
                break
        else:
            raise RuntimeError("drag: Newton's method did not converge in one step")
        g = g.reshape(S, n_q)
        u[2:] = self._modal_input(g)
        states, v = self._states(z0, u, k)
        return g, states, v


_STEP_MOMENTS = _moment_weights()
