r"""Eigensystem Realization Algorithm (Juang & Pappa 1985) for free decays.

A free decay (or impulse response) sampled every ``dt`` seconds on m channels,
``y_k = y(k dt)``, is modelled as ``x_{k+1} = A x_k``, ``y_k = C x_k``. The block
Hankel matrices (r block rows, s columns)

    H(0)_{ij} = y_{i+j},    H(1)_{ij} = y_{i+j+1},     i < r, j < s,

factor as ``H(0) = O X`` and ``H(1) = O A X`` (O observability, X = [x_0, A x_0, ...]).
With the truncated SVD ``H(0) ~ U_n S_n V_n^T`` (n = model order),

    A = S_n^{-1/2} U_n^T H(1) V_n S_n^{-1/2},  C = first m rows of U_n S_n^{1/2},
    x_0 = first column of S_n^{1/2} V_n^T.

Each eigenpair ``A psi = lambda psi`` gives a continuous-time pole
``s = ln(lambda) / dt``, natural frequency ``|s| / 2 pi`` (Hz, undamped),
damping ratio ``-Re(s) / |s|``, mode shape ``C psi`` at the channels and modal
amplitude ``(Psi^{-1} x_0)``, so that for the kept (upper-half-plane) modes

    y_i(t_k) ~ sum_j 2 Re(phi_ij a_j exp(s_j k dt)).

Quality indicators per mode:

* EMAC (extended modal amplitude coherence, output form; Pappa, Elliott & Schenk 1993):
  the mode's shape in the last block row of the identified observability matrix is
  compared with ``phi lambda^(r-1)``, its extrapolation from the first block row. For
  each channel, amplitude agreement ``min(|p|/|q|, |q|/|p|)`` times phase agreement
  ``max(0, 1 - |angle(q/p)| / (pi/4))``; averaged over channels with weights
  ``|phi_i|^2``. 1 = perfectly consistent over the record; noise modes score low.
* MPC (modal phase collinearity): ``((l1 - l2) / (l1 + l2))^2`` with l1 >= l2 the
  eigenvalues of the 2x2 matrix of inner products of Re(phi) and Im(phi). 1 for a real
  (normal) mode shape, 0 for a circular one; always 1 for a single channel.

Spurious poles are removed by these documented criteria (``era`` arguments):

1. only one pole of each complex-conjugate pair is kept (Im lambda > 0); real
   eigenvalues (Im lambda = 0, non-oscillatory or at the Nyquist frequency) cannot be
   vibration modes and are dropped;
2. unstable or undamped poles (``|lambda| >= 1``, damping ratio <= 0) are dropped;
3. poles with damping ratio above ``max_damping`` (default 0.2) are dropped: lightly
   damped structures do not have them, noise fits do;
4. poles with EMAC below ``min_emac`` (default 0.8) are dropped: in the tests'
   noisy records physical modes score above 0.95 and noise poles below 0.7;
5. poles with MPC below ``min_mpc`` (default 0, i.e. off: non-proportional damping
   legitimately gives complex shapes) are dropped.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.linalg import eigh

__all__ = [
    "EraModes",
    "HankelSVD",
    "StabilizationDiagram",
    "default_rows",
    "era",
    "hankel_svd",
    "mac",
    "plot_stabilization",
    "stabilization",
    "subset",
]


@dataclass(frozen=True)
class EraModes:
    """Identified modes, sorted by frequency.

    ``frequencies_hz`` undamped natural frequencies (Hz); ``damping_ratios`` (fractions);
    ``mode_shapes`` complex (n_channels, n_modes), largest component scaled to 1;
    ``amplitudes`` complex modal amplitudes at the first sample (units of y);
    ``emac``, ``mpc`` quality indicators in [0, 1]; ``singular_values`` of H(0);
    ``order`` the model order used.
    """

    frequencies_hz: np.ndarray
    damping_ratios: np.ndarray
    mode_shapes: np.ndarray
    amplitudes: np.ndarray
    emac: np.ndarray
    mpc: np.ndarray
    singular_values: np.ndarray
    order: int

    def reconstruct(self, n_samples: int, dt: float) -> np.ndarray:
        """The free decay these modes predict, shape (n_samples, n_channels)."""
        s = (
            2
            * np.pi
            * self.frequencies_hz
            * (-self.damping_ratios + 1j * np.sqrt(1 - self.damping_ratios**2))
        )
        t = np.arange(n_samples)[:, None] * dt
        return 2 * np.real((np.exp(t * s) * self.amplitudes) @ self.mode_shapes.T)


@dataclass(frozen=True)
class StabilizationDiagram:
    """Poles per model order and their stability flags (same order as ``poles[k]``).

    ``stable_frequency[k][i]``: a pole of the previous order lies within ``freq_tol``
    (relative) in frequency; ``stable[k][i]``: and within ``damping_tol`` (relative) in
    damping ratio and with MAC >= ``mac_tol``.
    """

    orders: list[int]
    poles: list[EraModes]
    stable_frequency: list[np.ndarray]
    stable: list[np.ndarray]


def mac(phi_a, phi_b):
    """Modal assurance criterion ``|a^H b|^2 / ((a^H a)(b^H b))`` between two shapes."""
    return np.abs(np.vdot(phi_a, phi_b)) ** 2 / (np.vdot(phi_a, phi_a).real * np.vdot(phi_b, phi_b).real)


def _as_channels(y) -> np.ndarray:
    y = np.asarray(y, dtype=float)
    if y.ndim == 1:
        y = y[:, None]
    if y.ndim != 2 or not np.all(np.isfinite(y)):
        raise ValueError("y must be a finite array of shape (n_samples, n_channels)")
    return y


def _hankel(y, rows, cols, shift):
    """Block Hankel matrix with entries y[i + j + shift], shape (rows * m, cols)."""
    windows = np.lib.stride_tricks.sliding_window_view(y[shift : shift + rows + cols - 1], cols, axis=0)
    # windows[i, c, j] = y[shift + i + j, c]; a strided view of y, copied to contiguous for BLAS
    return np.ascontiguousarray(windows.reshape(rows * y.shape[1], cols))


@dataclass(frozen=True)
class HankelSVD:
    """SVD ``U S Vt`` of the block Hankel matrix H(0) of a free decay, and H(1).

    One decomposition serves any number of model orders (:func:`era`, :func:`stabilization`).
    From ``hankel_svd(..., rank=k)`` it may hold only the leading k triplets (orders up to k).
    """

    U: np.ndarray
    S: np.ndarray
    Vt: np.ndarray
    H1: np.ndarray
    n_channels: int
    rows: int


def default_rows(n_samples: int, n_channels: int) -> int:
    """Default Hankel block rows r: ``min(n_samples // 3, max(20, 300 // n_channels))``."""
    return min(n_samples // 3, max(20, 300 // n_channels))


#: the Gram route of :func:`hankel_svd` is taken only while the last kept eigenvalue of H H^T is
#: above this fraction of the largest, i.e. sigma_rank / sigma_1 > 1e-4: forming H H^T perturbs its
#: eigenvalues by about r * eps * sigma_1^2 (r = rows of H), 7e-6 of such an eigenvalue at r = 300,
#: while below it the full SVD is taken (noise-free decays, whose trailing values are round-off)
GRAM_FLOOR = 1e-8


def hankel_svd(y, n_rows: int | None = None, n_cols: int | None = None, rank: int | None = None) -> HankelSVD:
    """Decompose the free decay ``y`` (n_samples, n_channels); rows and columns as in :func:`era`.

    ``rank=None``: the full thin SVD of H(0) (every singular value, as :func:`stabilization` and
    the automatic order need). ``rank=k``: only the leading k singular triplets, which is all that
    :func:`era` uses at a given order n <= k, by :func:`_leading_svd` (an eigen-decomposition of
    the r x r Gram matrix H H^T: five times cheaper than the full SVD on a 300 x 1170 Hankel
    matrix at k = 16, benchmarks/ppc.py); it falls back to the full SVD when the k-th singular
    value is too small for the Gram matrix to resolve (:data:`GRAM_FLOOR`).
    """
    y = _as_channels(y)
    n_samples, m = y.shape
    rows = n_rows or default_rows(n_samples, m)
    cols = n_cols or n_samples - rows
    if rows < 2 or cols < 2 or rows + cols > n_samples:
        raise ValueError(
            f"Hankel of {rows} block rows x {cols} columns needs {rows + cols} samples, have {n_samples}"
        )
    H0 = _hankel(y, rows, cols, 0)
    leading = _leading_svd(H0, rank) if rank is not None and rank < min(H0.shape) else None
    U, S, Vt = leading or np.linalg.svd(H0, full_matrices=False)
    return HankelSVD(U, S, Vt, _hankel(y, rows, cols, 1), m, rows)


def _leading_svd(H, rank):
    """The leading ``rank`` singular triplets of H, or None where the Gram route cannot resolve them.

    The eigenvectors of the Gram matrix G = H H^T (one BLAS-3 product, then a partial symmetric
    eigen-solve of the r x r matrix) span the dominant left singular subspace. One Rayleigh-Ritz
    step, the SVD of the small rank x s matrix B = Q^T H, returns singular values, right vectors
    and (as Q W) left vectors consistent with H to working precision within that subspace; its
    error is the subspace's, of order eps * sigma_1^2 / (sigma_k^2 - sigma_(k+1)^2), which for the
    noisy decays of a posterior predictive check moves ERA's frequencies and damping ratios by
    about 1e-11 relative, as much as two LAPACK drivers of the full SVD (gesdd, gesvd) differ by on
    the same decays (benchmarks/ppc.py prints both).
    """
    r = H.shape[0]
    lam, Q = eigh(H @ H.T, subset_by_index=[r - rank, r - 1])      # ascending
    if lam[0] <= GRAM_FLOOR * lam[-1]:
        return None
    W, S, Vt = np.linalg.svd(Q.T @ H, full_matrices=False)
    return Q @ W, S, Vt


def _auto_order(S, max_order=200):
    """Order at the largest drop of log singular value, rounded up to even (pairs)."""
    s = S[: max_order + 1]
    s = s[s > 0]
    k = int(np.argmax(np.log(s[:-1]) - np.log(s[1:]))) + 1
    return k + (k % 2)


def _mpc(phi):
    """Modal phase collinearity of one complex shape (1 = real mode, 0 = circular)."""
    re, im = phi.real, phi.imag
    M = np.array([[re @ re, re @ im], [re @ im, im @ im]])
    l2, l1 = np.linalg.eigvalsh(M)
    return ((l1 - l2) / (l1 + l2)) ** 2


def _emac(q, p, weights):
    """Output EMAC of one mode: identified q vs predicted p, per channel, weighted."""
    ratio = np.minimum(np.abs(p) / np.abs(q), np.abs(q) / np.abs(p))
    phase = np.maximum(0.0, 1 - np.abs(np.angle(q / p)) / (np.pi / 4))
    return float(np.sum(weights * ratio * phase) / np.sum(weights))


def _all_modes(dec: HankelSVD, order: int, dt: float) -> EraModes:
    """Realize the given order and return every upper-half-plane pole, unfiltered."""
    if not 1 <= order <= len(dec.S) or dec.S[order - 1] <= 0:
        raise ValueError(f"model order {order} exceeds the rank of the Hankel matrix")
    m = dec.n_channels
    sq = np.sqrt(dec.S[:order])
    Un, Vn = dec.U[:, :order], dec.Vt[:order].T
    A = (Un.T @ dec.H1 @ Vn) / np.outer(sq, sq)
    observ = Un * sq  # O = U S^(1/2)
    lam, psi = np.linalg.eig(A)
    amplitudes = np.linalg.solve(psi, sq * dec.Vt[:order, 0])
    keep = lam.imag > 1e-12 * np.abs(lam)
    lam, psi, amplitudes = lam[keep], psi[:, keep], amplitudes[keep]
    shapes = observ[:m] @ psi
    last = observ[-m:] @ psi
    scale = shapes[np.argmax(np.abs(shapes), axis=0), np.arange(shapes.shape[1])]
    s = np.log(lam) / dt
    emac, mpc = _indicators(shapes, last, lam, dec.rows)
    by_freq = np.argsort(np.abs(s))
    return EraModes(
        frequencies_hz=(np.abs(s) / (2 * np.pi))[by_freq],
        damping_ratios=(-s.real / np.abs(s))[by_freq],
        mode_shapes=(shapes / scale)[:, by_freq],
        amplitudes=(amplitudes * scale)[by_freq],
        emac=emac[by_freq],
        mpc=mpc[by_freq],
        singular_values=dec.S,
        order=order,
    )


def _indicators(shapes, last, lam, rows):
    """EMAC (first vs last block row of the observability matrix) and MPC per mode."""
    emac = [
        _emac(last[:, j], shapes[:, j] * lam[j] ** (rows - 1), np.abs(shapes[:, j]) ** 2)
        for j in range(len(lam))
    ]
    mpc = [_mpc(shapes[:, j]) for j in range(len(lam))]
    return np.array(emac), np.array(mpc)


def subset(modes: EraModes, keep) -> EraModes:
    """The modes selected by ``keep`` (boolean mask or indices), same order and settings."""
    return EraModes(
        modes.frequencies_hz[keep],
        modes.damping_ratios[keep],
        modes.mode_shapes[:, keep],
        modes.amplitudes[keep],
        modes.emac[keep],
        modes.mpc[keep],
        modes.singular_values,
        modes.order,
    )


def _physical(modes, max_damping, min_emac, min_mpc):
    """Criteria 2-5 of the module docstring (criterion 1 is applied in realization)."""
    z = modes.damping_ratios
    return (z > 0) & (z <= max_damping) & (modes.emac >= min_emac) & (modes.mpc >= min_mpc)


def era(
    y,
    dt: float,
    *,
    order: int | None = None,
    n_rows: int | None = None,
    n_cols: int | None = None,
    max_damping: float = 0.2,
    min_emac: float = 0.8,
    min_mpc: float = 0.0,
) -> EraModes:
    """Identify modes from a free decay ``y`` of shape (n_samples, n_channels), step ``dt`` (s).

    ``order``: model order n (twice the number of modes expected, plus some slack for
    noise, whose extra poles the filters remove). Default: the largest drop in the
    singular values of H(0), rounded up to even -- fine for clean data; with noise,
    choose it from a stabilization diagram. ``n_rows`` (block rows r) defaults to
    ``default_rows(n_samples, n_channels)``; ``n_cols`` to the remaining
    samples. More columns average noise better; r * n_channels must exceed the order.
    ``y`` may also be a :class:`HankelSVD` of the decay (then rows and columns are its own).
    """
    dec = y if isinstance(y, HankelSVD) else hankel_svd(y, n_rows, n_cols)
    modes = _all_modes(dec, order or _auto_order(dec.S), dt)
    return subset(modes, _physical(modes, max_damping, min_emac, min_mpc))


def _stability(current: EraModes, previous: EraModes | None, freq_tol, damping_tol, mac_tol):
    n = len(current.frequencies_hz)
    freq_ok, all_ok = np.zeros(n, bool), np.zeros(n, bool)
    if previous is None or len(previous.frequencies_hz) == 0:
        return freq_ok, all_ok
    for i in range(n):
        j = int(np.argmin(np.abs(previous.frequencies_hz - current.frequencies_hz[i])))
        df = abs(previous.frequencies_hz[j] / current.frequencies_hz[i] - 1)
        dz = abs(previous.damping_ratios[j] / current.damping_ratios[i] - 1)
        freq_ok[i] = df <= freq_tol
        all_ok[i] = (
            freq_ok[i]
            and dz <= damping_tol
            and mac(previous.mode_shapes[:, j], current.mode_shapes[:, i]) >= mac_tol
        )
    return freq_ok, all_ok


def stabilization(
    y,
    dt: float,
    orders,
    *,
    n_rows: int | None = None,
    n_cols: int | None = None,
    max_damping: float = 0.2,
    min_emac: float = 0.0,
    freq_tol: float = 0.01,
    damping_tol: float = 0.05,
    mac_tol: float = 0.98,
) -> StabilizationDiagram:
    """Poles for each model order in ``orders`` (ascending), with stability flags.

    One SVD serves all orders. Poles are filtered as in ``era`` (criteria 1-3, and
    EMAC if ``min_emac`` > 0); a pole is *stable* if the previous order has one within
    ``freq_tol`` in frequency, ``damping_tol`` in damping (both relative) and with
    MAC >= ``mac_tol``. Physical modes stay stable as the order grows; noise poles wander.
    ``y`` may also be a :class:`HankelSVD` of the decay, e.g. the one :func:`era` used.
    """
    dec = y if isinstance(y, HankelSVD) else hankel_svd(y, n_rows, n_cols)
    orders = sorted(int(n) for n in orders)
    poles, stable_f, stable = [], [], []
    for n in orders:
        modes = _all_modes(dec, n, dt)
        modes = subset(modes, _physical(modes, max_damping, min_emac, 0.0))
        f_ok, ok = _stability(modes, poles[-1] if poles else None, freq_tol, damping_tol, mac_tol)
        poles.append(modes)
        stable_f.append(f_ok)
        stable.append(ok)
    return StabilizationDiagram(orders, poles, stable_f, stable)


def plot_stabilization(diagram: StabilizationDiagram, ax=None):
    """Frequency against model order: filled = stable, '+' = frequency only, '.' = new.

    Returns the matplotlib Axes. Import of matplotlib is deferred to here so that the
    numerical functions do not need it.
    """
    import matplotlib.pyplot as plt

    if ax is None:
        _, ax = plt.subplots(figsize=(7, 4))
    for n, modes, f_ok, ok in zip(diagram.orders, diagram.poles, diagram.stable_frequency, diagram.stable):
        f = modes.frequencies_hz
        ax.plot(f[ok], np.full(ok.sum(), n), "o", color="tab:green", ms=4)
        ax.plot(f[f_ok & ~ok], np.full((f_ok & ~ok).sum(), n), "+", color="tab:orange", ms=5)
        ax.plot(f[~f_ok], np.full((~f_ok).sum(), n), ".", color="0.6", ms=3)
    ax.set(xlabel="frequency (Hz)", ylabel="model order")
    ax.plot([], [], "o", color="tab:green", label="stable (f, zeta, MAC)")
    ax.plot([], [], "+", color="tab:orange", label="stable frequency")
    ax.plot([], [], ".", color="0.6", label="new")
    ax.legend(loc="upper right", fontsize=8)
    return ax
