r"""The likelihood of a recording's sensor channels given a model's simulated response.

Band-limited, block-wise Gaussian likelihood
--------------------------------------------
The fitted window of every channel is cut into consecutive blocks of ``block`` samples. Within
each block the residual :math:`r = y - \hat y` is projected onto its DFT bins below
``max_frequency``, scaled to be orthonormal (DC by :math:`1/\sqrt L`, real and imaginary parts of
the other bins by :math:`\sqrt{2/L}`). For white noise of sd :math:`\sigma` these coordinates are
independent :math:`N(0, \sigma^2)` *exactly* (the projection is orthonormal), so

.. math:: \log p(y \mid q, \sigma) = \sum_{c}\sum_{j} -\tfrac12 \log(2\pi v_{cj}) - \frac{z_{cj}^2}{2 v_{cj}},

with :math:`v_{cj} = \sigma_c^2`. It is the paper's least-squares criterion (eqs. 30-31) with the
noise level made explicit, restricted to the band the model is trusted in: the DAQ's own
transition band above 0.40 fs (whose shape no recording states) and spline-inaccurate high modes
are left out by ``max_frequency``. The blocks are independent, so the per-block sums are the
pointwise terms that leave-one-out / leave-future-out estimators need.

Noise. The sd of every channel is *sampled* (``sigma_<sensor>``, log-uniform prior), not
marginalised: the same code then serves coloured noise and the free-decay amplitudes below, and
the summary reports the noise level a user wants to see. ``noise = "ar1"`` replaces white noise by
a per-channel AR(1) process (coefficient ``phi_<sensor>``), whose variance in bin f is
:math:`\sigma^2 / |1 - \phi e^{-2\pi i f/f_s}|^2` (the Whittle approximation: exact as the block
grows, good when the block is much longer than the correlation time 1/(1-phi) samples). It
matters when residuals are coloured: unmodelled higher modes, mains pickup, or the force channel's
noise driving the beam inside the impact window.

Free decay. The unknown state at ``start`` enters linearly through the modal amplitudes
:math:`a` (:meth:`BeamModel.free_decay_basis`, :math:`y = \Psi a`). They are *marginalised
analytically* under a Gaussian prior :math:`a \sim N(0, S^2)`, wide and the same rule for every
model (S_j = 10 x data RMS / column RMS), so evidences stay comparable:

.. math::

    \log p = -\tfrac12\big[D\log 2\pi + \log|V| + \log|S^2| + \log|A| + \tilde y^T\tilde y
             - b^T A^{-1} b\big],\quad A = S^{-2} + \tilde\Psi^T\tilde\Psi,\ b = \tilde\Psi^T\tilde y,

with whitened :math:`\tilde y = V^{-1/2} z`, :math:`\tilde\Psi = V^{-1/2} \Psi`. Pointwise terms of a
free decay are conditional on the posterior-mean amplitudes :math:`A^{-1}b`.
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np
from scipy import linalg, signal

NOISE_MODELS = ("white", "ar1")


@dataclass(frozen=True)
class BandProjection:
    """Orthonormal block-DFT coordinates of a window below a frequency limit.

    ``i0:i1`` is the sample window, ``block`` the block length L (the window is cut into
    floor((i1-i0)/L) blocks; the remainder after the last full block is left out), ``fs`` the
    sampling rate and ``max_frequency`` the highest bin kept (Hz, below fs/2).
    """

    fs: float
    i0: int
    i1: int
    block: int
    max_frequency: float

    def __post_init__(self):
        if self.n_blocks < 1:
            raise ValueError(f"the fitted window ({self.i1 - self.i0} samples) is shorter than one "
                             f"block ({self.block} samples): widen --start/--stop or lower the block")
        if not 0 < self.max_frequency < self.fs / 2:
            raise ValueError(f"max_frequency {self.max_frequency} Hz must lie in (0, fs/2 = {self.fs / 2} Hz)")

    @property
    def n_blocks(self) -> int:
        return (self.i1 - self.i0) // self.block

    @cached_property
    def n_bins(self) -> int:
        """Bins kept per block, DC included."""
        return int(np.floor(self.max_frequency * self.block / self.fs)) + 1

    @cached_property
    def scale(self) -> np.ndarray:
        s = np.full(self.n_bins, np.sqrt(2.0 / self.block))
        s[0] = 1.0 / np.sqrt(self.block)
        return s

    @property
    def size(self) -> int:
        """Coordinates per channel: per block, DC plus real and imaginary parts of the rest."""
        return self.n_blocks * (2 * self.n_bins - 1)

    def project(self, x: np.ndarray) -> np.ndarray:
        """Coordinates of x (n_samples, ...) : array (size, ...)."""
        seg = x[self.i0 : self.i0 + self.n_blocks * self.block]
        seg = seg.reshape((self.n_blocks, self.block) + x.shape[1:])
        spec = np.fft.rfft(seg, axis=1)[:, : self.n_bins] * self.scale.reshape((1, -1) + (1,) * (x.ndim - 1))
        parts = np.concatenate([spec.real, spec[:, 1:].imag], axis=1)
        return parts.reshape((self.size,) + x.shape[1:])

    @cached_property
    def frequencies(self) -> np.ndarray:
        """Frequency (Hz) of every coordinate."""
        f = np.arange(self.n_bins) * self.fs / self.block
        return np.tile(np.concatenate([f, f[1:]]), self.n_blocks)

    @cached_property
    def blocks(self) -> np.ndarray:
        """Block index of every coordinate."""
        return np.repeat(np.arange(self.n_blocks), 2 * self.n_bins - 1)

    def block_times(self, time: np.ndarray) -> np.ndarray:
        """Start time (s) of each block."""
        return time[self.i0 + self.block * np.arange(self.n_blocks)]


class Likelihood:
    """log p(recording | model parameters, noise parameters) in the band and window given.

    Parameters
    ----------
    model : BeamModel
    projection : BandProjection
    noise : {"white", "ar1"}
    """

    def __init__(self, model, projection: BandProjection, noise: str = "white"):
        if noise not in NOISE_MODELS:
            raise ValueError(f"noise model {noise!r} is not one of {NOISE_MODELS}")
        self.model = model
        self.projection = projection
        self.noise = noise
        rec = model.recording
        self.channels = tuple(s.name for s in rec.sensors)
        self.z_data = projection.project(rec.signals)          # (D, c)
        self.free_decay = rec.excitation.kind == "free_decay"

    @cached_property
    def noise_names(self) -> tuple[str, ...]:
        names = tuple(f"sigma_{c}" for c in self.channels)
        return names + (tuple(f"phi_{c}" for c in self.channels) if self.noise == "ar1" else ())

    @cached_property
    def channel_rms(self) -> dict[str, float]:
        """RMS of each channel's band coordinates (sets the scale of the noise priors)."""
        return {c: float(np.sqrt(np.mean(self.z_data[:, i] ** 2))) for i, c in enumerate(self.channels)}

    def variance(self, noise: dict) -> np.ndarray:
        """Noise variance of every coordinate and channel: (D, c)."""
        sigma = np.array([noise[f"sigma_{c}"] for c in self.channels])
        v = np.broadcast_to(sigma**2, self.z_data.shape).copy()
        if self.noise == "ar1":
            phi = np.array([noise[f"phi_{c}"] for c in self.channels])
            w = np.exp(-2j * np.pi * self.projection.frequencies / self.model.recording.fs)
            v = v / np.abs(1 - phi[None, :] * w[:, None]) ** 2
        return v

    def draw_noise(self, noise: dict, shape, rng: np.random.Generator) -> np.ndarray:
        """A draw of the noise model in time (n_samples, c): white, or each channel's AR(1) process."""
        sigma = np.array([noise[f"sigma_{c}"] for c in self.channels])
        e = rng.standard_normal(shape)
        if self.noise == "ar1":
            phi = np.array([noise[f"phi_{c}"] for c in self.channels])
            e = np.stack([signal.lfilter([1.0], [1.0, -p], e[:, i]) for i, p in enumerate(phi)], axis=1)
        return e * sigma[None, :]

    # ------------------------------------------------------------------ evaluation
    def residual(self, params: dict) -> np.ndarray:
        """Band coordinates of data minus model (forced or released recordings): (D, c)."""
        return self.z_data - self.projection.project(self.model.simulate(params))

    def log_likelihood(self, params: dict, noise: dict) -> float:
        v = self.variance(noise)
        if self.free_decay:
            return self._marginal_free_decay(params, v)[0]
        r = self.residual(params)
        return float(-0.5 * np.sum(np.log(2 * np.pi * v) + r**2 / v))

    def pointwise(self, params: dict, noise: dict) -> np.ndarray:
        """Per-block log-likelihood terms, summed over channels: (n_blocks,)."""
        v = self.variance(noise)
        if self.free_decay:
            coef = self._marginal_free_decay(params, v)[1]
            r = self.z_data - np.einsum("dcj,j->dc", self._projected_basis(params), coef)
        else:
            r = self.residual(params)
        terms = -0.5 * (np.log(2 * np.pi * v) + r**2 / v)
        return np.bincount(self.projection.blocks, weights=terms.sum(axis=1),
                           minlength=self.projection.n_blocks)

    def predict(self, params: dict, noise: dict | None = None) -> np.ndarray:
        """The model's signals (n_samples, c); for free decay with posterior-mean amplitudes."""
        if not self.free_decay:
            return self.model.simulate(params)
        v = self.variance(noise) if noise is not None else np.ones_like(self.z_data)
        return self.model.simulate(params, self._marginal_free_decay(params, v)[1])

    # ------------------------------------------------------------------ free decay
    def _projected_basis(self, params) -> np.ndarray:
        basis = self.model.free_decay_basis(params)            # (n, c, J)
        return self.projection.project(basis)                  # (D, c, J)

    @cached_property
    def _data_rms(self) -> float:
        return float(np.sqrt(np.mean(self.z_data**2)))

    def _marginal_free_decay(self, params, v: np.ndarray) -> tuple[float, np.ndarray]:
        """Log marginal likelihood over the modal amplitudes, and their posterior mean."""
        psi = self._projected_basis(params)
        col_rms = np.sqrt(np.mean(psi**2, axis=(0, 1)))
        s2 = (10.0 * self._data_rms / np.maximum(col_rms, np.finfo(float).tiny)) ** 2
        w = 1.0 / np.sqrt(v)
        y = (self.z_data * w).ravel()
        p = (psi * w[:, :, None]).reshape(y.size, -1)
        a = np.diag(1.0 / s2) + p.T @ p
        b = p.T @ y
        chol = linalg.cho_factor(a)
        coef = linalg.cho_solve(chol, b)
        logdet_a = 2 * np.sum(np.log(np.diag(chol[0])))
        value = -0.5 * (y.size * np.log(2 * np.pi) + np.sum(np.log(v)) + np.sum(np.log(s2))
                        + logdet_a + y @ y - b @ coef)
        return float(value), coef
