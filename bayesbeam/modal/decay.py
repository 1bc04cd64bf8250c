r"""ERA on a recording: the free-decay part, mixed sensor quantities, bending-mode numbers.

:func:`bayesbeam.modal.era.era` works on any free decay. A recording needs four more steps,
which :func:`identify_modes` takes in this order:

1. **The free decay.** ERA models ``y_k = C A^k x_0``, which holds only once no force acts
   and the DAQ's anti-alias filter has settled (its impulse response is negligible beyond
   :data:`~bayesbeam.response.signals.EDGE` = 128 samples). The segment starts that many
   samples after the last force sample above 5 % of the peak (kind ``"force"``), after
   t = 0 (``"release"``) or after ``start`` (``"free_decay"``), unless a start is given.
2. **Channel scaling.** Each channel is divided by its RMS over the segment before the
   Hankel matrix is built, so an accelerometer (m/s^2) and a displacement sensor (m) count
   alike; the shapes are scaled back afterwards.
3. **Band.** Poles above ``max_frequency`` (default 0.40 fs, the top of the DAQ passband,
   where the anti-alias filter starts to distort amplitude and phase) are dropped.
4. **Mode numbers.** A modal table needs bending-mode numbers (``mode`` = 1 for the first),
   because eqs. (25)-(29) pair each frequency with the eigenvalue ``beta_m``. Each pole is
   given the number of the nearest (in log frequency) natural frequency of the nominal beam
   (E, I, rho A, l and tip body from beam.toml, :func:`~bayesbeam.modal.eigen.natural_frequencies_hz`),
   after scaling those by the median ratio of identified to nominal frequencies, so that a
   nominal E off by tens of percent does not shift the numbering. When two poles claim one
   mode, the one contributing most to the (scaled) response keeps it; the other is reported
   as unassigned. Expected modes inside the band with no pole are reported as missing (a
   sensor or the drive at a node of that mode, or a mode too weak to stand above the noise).

Mode shapes are returned as *displacement* shapes at the sensors: each channel's component
is divided by ``s^q`` (s the pole in rad/s; q = 0, 1, 2 for displacement, velocity,
acceleration) and the shape is scaled so that its largest component is 1.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from bayesbeam.io import Recording
from bayesbeam.modal.eigen import natural_frequencies_hz
from bayesbeam.modal.ema import ModalTable
from bayesbeam.modal.era import (
    EraModes,
    StabilizationDiagram,
    era,
    hankel_svd,
    stabilization,
    subset,
)
from bayesbeam.response.linear import ORDERS, PASSBAND
from bayesbeam.response.signals import EDGE

__all__ = ["RecordingModes", "decay_segment", "identify_modes", "nominal_frequencies"]

#: a force sample counts as part of the impact above this fraction of the peak force
FORCE_THRESHOLD = 0.05


@dataclass(frozen=True)
class RecordingModes:
    """Bending modes identified by ERA on a recording, lowest first.

    ``modes``: bending-mode numbers (1 = first); ``frequencies_hz`` (Hz, undamped);
    ``damping_ratios`` (fractions); ``shapes``: complex displacement shapes at the sensors,
    shape (n_sensors, n_modes), largest component 1; ``emac``, ``mpc`` (0-1).
    ``segment`` (s): first and last time used; ``order`` and ``n_rows``: the ERA model order
    and Hankel block rows; ``max_frequency_hz``: top of the band kept; ``nominal_hz``: the
    nominal beam's natural frequencies used for numbering; ``missing``: expected mode
    numbers in the band without a pole; ``unassigned``: poles that passed ERA's filters but
    lost their mode number to a stronger pole (dicts with frequency_hz, damping_ratio,
    emac, nearest_mode). ``diagram``: the stabilization diagram of the same Hankel matrix,
    if asked for.
    """

    modes: tuple[int, ...]
    frequencies_hz: np.ndarray
    damping_ratios: np.ndarray
    shapes: np.ndarray
    emac: np.ndarray
    mpc: np.ndarray
    segment: tuple[float, float]
    order: int
    n_rows: int
    max_frequency_hz: float
    nominal_hz: np.ndarray
    missing: tuple[int, ...] = ()
    unassigned: list[dict] = field(default_factory=list)
    diagram: StabilizationDiagram | None = None

    def table(self) -> ModalTable:
        """The modal table (mode, f in Hz, zeta as a fraction) that ``bayesbeam ema`` reads."""
        return ModalTable(
            tuple(int(m) for m in self.modes),
            tuple(float(f) for f in self.frequencies_hz),
            tuple(float(z) for z in self.damping_ratios),
        )


def decay_segment(rec: Recording, start: float | None = None, stop: float | None = None) -> tuple[int, int]:
    """Sample range ``[i0, i1)`` of the free decay (see step 1 of the module docstring).

    ``start`` and ``stop`` (s) override the automatic choice; ValueError if the range is
    empty or outside the record.
    """
    time = rec.time
    if start is None:
        i0 = _first_free_sample(rec) + EDGE
    else:
        i0 = int(np.searchsorted(time, start))
    i1 = rec.n_samples if stop is None else int(np.searchsorted(time, stop, side="right"))
    if not 0 <= i0 < i1 <= rec.n_samples:
        raise ValueError(
            f"{rec.source}: the free-decay segment [{start}, {stop}] s is empty or outside the record "
            f"[{time[0]}, {time[-1]}] s. Fix: pass --start/--stop inside the record, start before stop."
        )
    return i0, i1


def _first_free_sample(rec: Recording) -> int:
    """Index of the first sample after which no force acts (before the filter settles)."""
    exc = rec.excitation
    if exc.kind == "force":
        force = np.abs(rec.force)
        return int(np.flatnonzero(force >= FORCE_THRESHOLD * force.max())[-1]) + 1
    release = 0.0 if exc.kind == "release" else exc.start
    return int(np.searchsorted(rec.time, release))


def nominal_frequencies(rec: Recording, max_frequency_hz: float) -> np.ndarray:
    """Natural frequencies (Hz) of the nominal beam of ``rec``, through the first above the band."""
    beam, tip = rec.beam, rec.tip
    n = 4
    while True:
        f = natural_frequencies_hz(
            n, EI=beam.nominal_EI, rho_a=beam.rho_a, length=beam.length, m_T=tip.mass, J=tip.rotary_inertia
        )
        if f[-1] > max_frequency_hz:
            return f[: int(np.searchsorted(f, max_frequency_hz)) + 1]
        n *= 2


def _scaled_segment(rec: Recording, i0: int, i1: int) -> tuple[np.ndarray, np.ndarray]:
    """The segment with each channel divided by its RMS, and those RMS values."""
    y = rec.signals[i0:i1]
    rms = np.sqrt(np.mean(y**2, axis=0))
    if not np.all(rms > 0):
        names = [s.name for s, r in zip(rec.sensors, rms) if not r > 0]
        raise ValueError(f"{rec.source}: sensor(s) {names} are zero over the free decay. Fix: drop them.")
    return y / rms, rms


def _displacement_shapes(rec: Recording, modes: EraModes, rms: np.ndarray) -> np.ndarray:
    """Channel shapes of the scaled data -> displacement shapes, largest component 1."""
    s = 2 * np.pi * modes.frequencies_hz * (-modes.damping_ratios + 1j * np.sqrt(1 - modes.damping_ratios**2))
    q = np.array([ORDERS[sensor.quantity] for sensor in rec.sensors])
    shapes = modes.mode_shapes * rms[:, None] / s[None, :] ** q[:, None]
    peak = shapes[np.argmax(np.abs(shapes), axis=0), np.arange(shapes.shape[1])]
    return shapes / peak


def _assign(frequencies: np.ndarray, weights: np.ndarray, nominal: np.ndarray):
    """Bending-mode numbers of the poles (module step 4).

    Returns ``(nearest, numbers)``: the nearest mode number of each pole, and the number it
    keeps (0 where a stronger pole, by ``weights``, claims the same mode).
    """
    def nearest(scale):
        return 1 + np.argmin(np.abs(np.log(frequencies[:, None] / (scale * nominal[None, :]))), axis=1)

    scale = float(np.exp(np.median(np.log(frequencies / nominal[nearest(1.0) - 1]))))
    closest = nearest(scale)
    numbers = closest.copy()
    for m in np.unique(closest):
        claim = np.flatnonzero(closest == m)
        numbers[claim[claim != claim[np.argmax(weights[claim])]]] = 0
    return closest, numbers


def _numbers(found: EraModes, nominal: np.ndarray):
    """:func:`_assign` with each pole weighted by its share of the scaled response."""
    if not len(found.frequencies_hz):
        return np.zeros(0, int), np.zeros(0, int)
    weights = 2 * np.abs(found.amplitudes) * np.linalg.norm(found.mode_shapes, axis=0)
    return _assign(found.frequencies_hz, weights, nominal)


def identify_modes(
    rec: Recording,
    *,
    order: int | None = None,
    n_rows: int | None = None,
    start: float | None = None,
    stop: float | None = None,
    max_frequency: float | None = None,
    n_modes: int | None = None,
    min_emac: float = 0.8,
    diagram_orders=None,
) -> RecordingModes:
    """Bending modes of ``rec`` by ERA (module docstring: segment, scaling, band, numbering).

    ``order``: ERA model order; default three times the number of nominal modes in the band
    (rounded up to even), i.e. room for every mode plus as many noise poles again, which
    ERA's filters (damping, EMAC >= ``min_emac``) then remove. ``n_rows``: Hankel block
    rows (default :func:`~bayesbeam.modal.era.default_rows`). ``start``/``stop`` (s): the
    free-decay segment. ``max_frequency`` (Hz): top of the band (default 0.40 fs).
    ``n_modes``: keep bending modes 1..n_modes only. ``diagram_orders``: model orders of a
    stabilization diagram to build from the same SVD, or a callable giving them from the
    order used (e.g. ``lambda n: range(2, 2 * n + 1, 2)``); None for no diagram.
    """
    fmax = PASSBAND * rec.fs if max_frequency is None else float(max_frequency)
    nominal = nominal_frequencies(rec, fmax)
    n_band = int(np.sum(nominal <= fmax))
    order = order or 2 * ((3 * max(n_band, 1) + 1) // 2)
    i0, i1 = decay_segment(rec, start, stop)
    y, rms = _scaled_segment(rec, i0, i1)
    dec = hankel_svd(y, n_rows)
    found = era(dec, rec.dt, order=order, min_emac=min_emac)
    found = subset(found, found.frequencies_hz <= fmax)
    closest, numbers = _numbers(found, nominal)
    keep = (numbers > 0) & (numbers <= (n_modes or np.inf))
    kept = subset(found, keep)
    wanted = range(1, min(n_band, n_modes or n_band) + 1)
    if callable(diagram_orders):
        diagram_orders = diagram_orders(order)
    return RecordingModes(
        modes=tuple(int(m) for m in numbers[keep]),
        frequencies_hz=kept.frequencies_hz,
        damping_ratios=kept.damping_ratios,
        shapes=_displacement_shapes(rec, kept, rms),
        emac=kept.emac,
        mpc=kept.mpc,
        segment=(float(rec.time[i0]), float(rec.time[i1 - 1])),
        order=order,
        n_rows=dec.rows,
        max_frequency_hz=fmax,
        nominal_hz=nominal,
        missing=tuple(m for m in wanted if m not in set(numbers[keep])),
        unassigned=[_pole_record(found, i, closest[i]) for i in np.flatnonzero(numbers == 0)],
        diagram=None if diagram_orders is None else stabilization(dec, rec.dt, diagram_orders),
    )


def _pole_record(modes: EraModes, i: int, nearest: int) -> dict:
    return {
        "frequency_hz": float(modes.frequencies_hz[i]),
        "damping_ratio": float(modes.damping_ratios[i]),
        "emac": float(modes.emac[i]),
        "nearest_mode": int(nearest),
    }
