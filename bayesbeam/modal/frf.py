r"""Frequency response from impact tests (H1) and a rational-fraction modal fit.

H1 estimator. With force f(t) and response x(t) sampled every dt seconds, one or more
impacts (averages a), and DFTs F_a, X_a:

    H1(w_k) = sum_a conj(F_a) X_a / sum_a |F_a|^2,
    coherence = |sum_a conj(F_a) X_a|^2 / (sum_a |F_a|^2 sum_a |X_a|^2)   (1 for a = 1).

H1 is biased low only by noise on the force, which the force window suppresses.

Windows. A lightly damped response has not died out by the end of the record; an
exponential window ``w(t) = exp(-t / tau)`` (t from the first sample) forces it to.
Applied to *both* channels it changes the system, not just the data, because

    exp(-t/tau) (h * f)(t) = ((exp(-t/tau) h) * (exp(-t/tau) f))(t),

so the windowed H1 is exactly the FRF of the impulse response ``exp(-t/tau) h(t)``,
i.e. ``H(i w + 1/tau)``: every pole ``s = -zeta w_n + i w_d`` moves to ``s - 1/tau``.
The fitted (windowed) poles are corrected exactly by

    sigma = zeta_w w_w - 1/tau,  w_d = w_w sqrt(1 - zeta_w^2),
    w_n = sqrt(sigma^2 + w_d^2),  zeta = sigma / w_n,

which to first order is ``zeta = zeta_w - 1 / (tau w_n)``. The force window is
rectangular: 1 from the record start to ``force_window`` seconds after the force
peak and 0 after, removing what the force channel records while the hammer is off
the beam. Choose it longer than the pulse so the pulse itself is untouched.

Modal fit. ``fit_rational_fraction`` fits ``H(s) ~ N(s) / D(s)`` with D monic of degree
2n (n modes) and N of degree 2n (default; the extra degree absorbs a constant residual
from modes above the band), by Sanathanan-Koerner iteration: the linearised problem
``N(s_k) - H_k D(s_k) = 0`` is solved in least squares with weights
``1 / |D_previous(s_k)|``, which converges to the fit of ``N/D`` itself. ``s`` is
scaled by the highest fitted frequency to keep the monomial basis well conditioned;
this is meant for a band holding a few modes (fit wider ranges band by band).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = [
    "FrfEstimate",
    "RationalFit",
    "fit_rational_fraction",
    "h1_estimate",
    "modal_parameters",
    "remove_window_damping",
]


@dataclass(frozen=True)
class FrfEstimate:
    """H1 estimate: ``frequency_hz`` (Hz), complex ``h1`` (response unit / N),
    ``coherence`` (0-1), exponential-window time constant ``tau`` (s, None = no window)."""

    frequency_hz: np.ndarray
    h1: np.ndarray
    coherence: np.ndarray
    tau: float | None
    n_averages: int


@dataclass(frozen=True)
class RationalFit:
    """``H(s) = N(s/w0) / D(s/w0)``; polynomial coefficients lowest power first.

    ``frequencies_hz`` (undamped, |s| / 2 pi) and ``damping_ratios`` (-Re s / |s|) are
    those of the fitted poles in the upper half plane, ascending.
    """

    frequencies_hz: np.ndarray
    damping_ratios: np.ndarray
    numerator: np.ndarray
    denominator: np.ndarray
    omega_scale: float

    def __call__(self, frequency_hz):
        """The fitted FRF at the given frequencies (Hz)."""
        s = 2j * np.pi * np.asarray(frequency_hz, float) / self.omega_scale
        return np.polyval(self.numerator[::-1], s) / np.polyval(self.denominator[::-1], s)


def _as_averages(x) -> np.ndarray:
    x = np.asarray(x, dtype=float)
    return x[None, :] if x.ndim == 1 else x


def _force_window(force, dt, duration):
    """Rectangular window: 1 up to ``duration`` s after each record's force peak, then 0."""
    n = force.shape[1]
    last = np.argmax(np.abs(force), axis=1) + round(duration / dt)
    return (np.arange(n)[None, :] <= last[:, None]).astype(float)


def h1_estimate(
    force, response, dt: float, *, tau: float | None = None, force_window: float | None = None
) -> FrfEstimate:
    """H1 FRF from impact records.

    Parameters
    ----------
    force, response : arrays of shape (n_samples,) or (n_averages, n_samples)
        Force (N) and response (any unit) of each impact, sampled every ``dt`` s.
    tau : float, optional
        Time constant (s) of the exponential window applied to both channels; its
        added damping is removed by ``modal_parameters``/``remove_window_damping``.
    force_window : float, optional
        Seconds kept after the force peak (rectangular force window).
    """
    f, x = _as_averages(force), _as_averages(response)
    if f.shape != x.shape:
        raise ValueError(f"force {f.shape} and response {x.shape} must have the same shape")
    if force_window is not None:
        f = f * _force_window(f, dt, force_window)
    if tau is not None:
        w = np.exp(-np.arange(f.shape[1]) * dt / tau)
        f, x = f * w, x * w
    F, X = np.fft.rfft(f, axis=1), np.fft.rfft(x, axis=1)
    sfx = np.sum(np.conj(F) * X, axis=0)
    sff, sxx = np.sum(np.abs(F) ** 2, axis=0), np.sum(np.abs(X) ** 2, axis=0)
    with np.errstate(invalid="ignore", divide="ignore"):
        h1 = sfx / sff
        coherence = np.abs(sfx) ** 2 / (sff * sxx)
    return FrfEstimate(np.fft.rfftfreq(f.shape[1], dt), h1, coherence, tau, f.shape[0])


def _sk_step(s, H, weights, n_num, n_den):
    """One Sanathanan-Koerner step: weighted linear LS for N and monic D."""
    num_cols = s[:, None] ** np.arange(n_num + 1)
    den_cols = -H[:, None] * s[:, None] ** np.arange(n_den)
    M = np.hstack([num_cols, den_cols]) * weights[:, None]
    rhs = H * s**n_den * weights
    coef = np.linalg.lstsq(np.vstack([M.real, M.imag]), np.concatenate([rhs.real, rhs.imag]), rcond=None)[0]
    return coef[: n_num + 1], np.r_[coef[n_num + 1 :], 1.0]


def fit_rational_fraction(
    frequency_hz, frf, n_modes: int, *, band=None, numerator_degree: int | None = None, iterations: int = 30
) -> RationalFit:
    """Fit ``n_modes`` modes to a complex FRF over ``band`` = (f_lo, f_hi) Hz (default: all f > 0)."""
    f, H = np.asarray(frequency_hz, float), np.asarray(frf, complex)
    lo, hi = band if band is not None else (0.0, np.inf)
    keep = (f > max(lo, 0.0)) & (f <= hi) & np.isfinite(H)
    n_den = 2 * n_modes
    n_num = n_den if numerator_degree is None else numerator_degree
    if keep.sum() < n_num + n_den + 1:
        raise ValueError(f"{keep.sum()} frequency lines in the band; need more than {n_num + n_den + 1}")
    w0 = 2 * np.pi * f[keep].max()
    s, H = 2j * np.pi * f[keep] / w0, H[keep]
    weights = np.ones(len(s))
    for _ in range(iterations):
        num, den = _sk_step(s, H, weights, n_num, n_den)
        new = 1.0 / np.abs(np.polyval(den[::-1], s))
        if np.allclose(new / new.max(), weights / weights.max(), rtol=1e-10, atol=0):
            break
        weights = new
    poles = np.roots(den[::-1]) * w0
    poles = poles[poles.imag > 0]
    poles = poles[np.argsort(np.abs(poles))]
    return RationalFit(np.abs(poles) / (2 * np.pi), -poles.real / np.abs(poles), num, den, w0)


def remove_window_damping(frequencies_hz, damping_ratios, tau: float):
    """Undo the exponential window ``exp(-t / tau)``: shift each pole by +1/tau (exact).

    Returns ``(frequencies_hz, damping_ratios)`` of the unwindowed system.
    """
    w = 2 * np.pi * np.asarray(frequencies_hz, float)
    zeta = np.asarray(damping_ratios, float)
    sigma = zeta * w - 1.0 / tau
    wd = w * np.sqrt(1 - zeta**2)
    wn = np.hypot(sigma, wd)
    return wn / (2 * np.pi), sigma / wn


def modal_parameters(estimate: FrfEstimate, n_modes: int, *, band=None, numerator_degree: int | None = None):
    """Frequencies (Hz) and damping ratios from an H1 estimate, window damping removed."""
    fit = fit_rational_fraction(
        estimate.frequency_hz, estimate.h1, n_modes, band=band, numerator_degree=numerator_degree
    )
    if estimate.tau is None:
        return fit.frequencies_hz, fit.damping_ratios
    return remove_window_damping(fit.frequencies_hz, fit.damping_ratios, estimate.tau)
