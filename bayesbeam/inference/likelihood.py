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
matters when residuals are coloured: unmodelled higher modes or mains pickup.

Latent linear terms. Two unknowns enter the response linearly, :math:`y = \hat y + \Psi a`, and
are *marginalised analytically* under a Gaussian prior :math:`a \sim N(0, S^2)`:

.. math::

    \log p = -\tfrac12\big[D\log 2\pi + \log|V| + \log|S^2| + \log|A| + \tilde z^T\tilde z
             - b^T A^{-1} b\big],\quad A = S^{-2} + \tilde\Psi^T\tilde\Psi,\ b = \tilde\Psi^T\tilde z,

with whitened :math:`\tilde z = V^{-1/2} z`, :math:`\tilde\Psi = V^{-1/2} \Psi` (the Gaussian
:math:`N(z; 0, V + \Psi S^2 \Psi^T)` by the Woodbury identity, at the cost of a J x J solve).
Pointwise terms and predictions are conditional on the posterior mean :math:`A^{-1}b`.

- *Free decay*: the unknown state at ``start`` enters through the modal amplitudes
  (:meth:`BeamModel.free_decay_basis`), with a wide prior that is the same rule for every
  model (S_j = 10 x data RMS / column RMS), so evidences stay comparable.
- *Force noise* (errors in variables): the impact window keeps the noise of the force samples
  inside it, and that noise drives a response the sensor noise cannot explain (on the
  paper_q3_hammer example, 1 % force noise leaves a residual 1.4 x the sensor noise in the
  band to 150 Hz at the true parameters and biases gamma). The kept noise is the latent term,
  its variance measured from the force channel where the window is closed
  (:func:`bayesbeam.response.signals.force_noise`). At the recorded rate each kept sample is a
  latent term: :math:`\Psi` holds the model's responses to a unit force sample at each
  (:meth:`BeamModel.simulate_with_impulses`), :math:`S^2` their variance. A decimated fit keeps
  the recorded samples, which lie between its own: the latent terms are the few principal inputs
  that carry their noise's in-band content exactly (unit variance, each a fixed mixture of
  recorded samples at their own times; :meth:`BeamModel.simulate_with_inputs`). Grouping the
  recorded samples' noise onto the nearest decimated samples instead makes the marginal's
  covariance wrong in structure (its phases err by up to 1.15 rad at 152 Hz when 4096 Hz is
  decimated by 10) and q3's gamma and b posteriors about 25 % too narrow.
  With a clean force channel there is nothing to marginalise and the likelihood is the plain one.
"""
from __future__ import annotations

from collections.abc import Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from functools import cached_property

import numpy as np
from scipy import linalg, signal

from bayesbeam.physics.effects import Effect
from bayesbeam.response.signals import ForceNoise

NOISE_MODELS = ("white", "ar1")
#: a latent amplitude's prior sd gives its column this many times the data's RMS (the one wide
#: rule of the free-decay amplitudes and the effects' columns, the same for every model)
LATENT_PRIOR_FACTOR = 10.0


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

    @property
    def window(self) -> slice:
        """The samples the coordinates depend on: the whole blocks from i0."""
        return slice(self.i0, self.i0 + self.n_blocks * self.block)

    def project(self, x: np.ndarray) -> np.ndarray:
        """Coordinates of x (n_samples, ...) : array (size, ...)."""
        return self.project_window(x[self.window])

    def project_window(self, x: np.ndarray) -> np.ndarray:
        """Coordinates of the samples ``x[window]`` (given alone): array (size, ...)."""
        seg = x.reshape((self.n_blocks, self.block) + x.shape[1:])
        spec = np.fft.rfft(seg, axis=1)[:, : self.n_bins] * self.scale.reshape((1, -1) + (1,) * (x.ndim - 1))
        parts = np.concatenate([spec.real, spec[:, 1:].imag], axis=1)
        return parts.reshape((self.size,) + x.shape[1:])

    def project_last(self, x: np.ndarray) -> np.ndarray:
        """:meth:`project` of signals with time on the last axis: (..., n_samples) -> (..., size)."""
        seg = x[..., self.window].reshape(x.shape[:-1] + (self.n_blocks, self.block))
        spec = np.fft.rfft(seg, axis=-1)[..., : self.n_bins] * self.scale
        return np.concatenate([spec.real, spec[..., 1:].imag], axis=-1).reshape(x.shape[:-1] + (self.size,))

    def project_shifted(self, h: np.ndarray, first: int, shifts: np.ndarray) -> np.ndarray:
        r"""Coordinates of the shifted copies :math:`x_k[t] = h[t - s_k]` of signals h, without
        building the copies: (K, ..., size), each ``[k, ...]`` equal to :meth:`project` of copy k.

        ``h`` (n_h, ...) holds the signals at sample lags ``first``, ``first`` + 1, ... and must
        cover the lags ``i0 - max(shifts)`` to ``i0 + n_blocks L - min(shifts) - 1``; ``shifts``
        (K,) are integers. With :math:`u_b = i_0 + bL - s_0` (:math:`s_0` the smallest shift,
        :math:`d_k = s_k - s_0`) and :math:`\omega = e^{-2\pi i f/L}` (so :math:`\omega^L = 1`),
        a block's DFT of copy k differs from that of the least shifted copy only by the d_k
        samples that enter and leave the block:

        .. math:: \sum_{l<L} h[u_b + l - d]\,\omega^l = \omega^{d}\Big(A_b
                  + \sum_{j=1}^{d} \big(h[u_b - j] - h[u_{b+1} - j]\big)\,\omega^{-j}\Big),
                  \qquad A_b = \sum_{l<L} h[u_b + l]\,\omega^l :

        one FFT per block and a running sum over the shifts, where the copies cost K FFTs per block
        and the copies themselves an (n, K) gather (the force noise's K = 10 to 44 latent columns).
        Rounding: a few eps of :math:`\sum_l |h[u_b + l]|`.
        """
        shifts = np.asarray(shifts, dtype=int)
        rest = h.shape[1:]
        h = h.reshape(h.shape[0], -1)
        s0, d = shifts.min(), shifts - shifts.min()
        starts = self.i0 + self.block * np.arange(self.n_blocks + 1) - s0 - first     # u_b in h's rows
        if starts[0] - d.max() < 0 or starts[-1] > h.shape[0]:
            raise ValueError(f"h covers lags {first} to {first + h.shape[0] - 1}: too few for shifts "
                             f"{shifts.min()} to {shifts.max()} of the window {self.window}")
        blocks = h[starts[0]:starts[-1]].T.reshape(-1, self.n_blocks, self.block)
        steps = np.arange(d.max() + 1)
        bins = np.arange(self.n_bins)
        # running[j] = A + sum_{i<=j} (h[u_b - i] - h[u_{b+1} - i]) omega^-i: (D + 1, B, blocks, bins)
        running = np.empty((steps.size,) + blocks.shape[:2] + (self.n_bins,), dtype=complex)
        running[0] = np.fft.rfft(blocks, axis=-1)[..., :self.n_bins]
        edge = (h[starts[:-1, None] - steps[1:]] - h[starts[1:, None] - steps[1:]]).transpose(1, 2, 0)
        turn = np.exp(2j * np.pi * np.outer(steps[1:], bins) / self.block)             # omega^-j (D, bins)
        np.multiply(edge[..., None], turn[:, None, None, :], out=running[1:])
        for j in steps[1:]:                     # a loop over slabs: numpy's complex cumsum is 7x slower
            running[j] += running[j - 1]
        contiguous = d.size == steps.size and np.array_equal(d, steps)
        spec = running if contiguous else running[d]
        spec *= (np.exp(-2j * np.pi * np.outer(d, bins) / self.block) * self.scale)[:, None, None, :]
        parts = np.concatenate([spec.real, spec[..., 1:].imag], axis=-1)
        return parts.reshape((shifts.size,) + rest + (self.size,))

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
    force_noise : ForceNoise, optional
        The noise left in the windowed force samples
        (:func:`bayesbeam.response.signals.force_noise`); the response it drives is marginalised.
    """

    def __init__(self, model, projection: BandProjection, noise: str = "white",
                 force_noise: ForceNoise | None = None):
        if noise not in NOISE_MODELS:
            raise ValueError(f"noise model {noise!r} is not one of {NOISE_MODELS}")
        self.model = model
        self.projection = projection
        self.noise = noise
        rec = model.recording
        self.channels = tuple(s.name for s in rec.sensors)
        self.z_data = projection.project(rec.signals)          # (D, c)
        self.free_decay = rec.excitation.kind == "free_decay"
        self.force_noise = force_noise if force_noise is not None and force_noise.size else None
        if self.force_noise is not None and rec.excitation.kind != "force":
            raise ValueError("force noise applies to recordings with a measured force only")
        self._effect_terms_at = None        # (the effects' own values, their latent terms) last built

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
    @property
    def latent(self) -> bool:
        """True when the likelihood marginalises linear latent terms (free-decay amplitudes, force
        noise or an effect's columns such as mains pickup)."""
        return self.free_decay or self.force_noise is not None or bool(self._column_effects)

    @cached_property
    def _column_effects(self) -> tuple:
        """The model's effects that add latent columns to the response channels (mains pickup)."""
        return tuple(e for e in self.model.effects if type(e).latent_columns is not Effect.latent_columns)

    def residual(self, params: dict) -> np.ndarray:
        """Band coordinates of data minus model (forced or released recordings; no latent
        terms): (D, c)."""
        return self._remembered("residual", params,
                                lambda: self.z_data - self.projection.project(self.model.simulate(params)))

    @contextmanager
    def reusing(self):
        """Within the block, a model evaluation at parameters the block has just evaluated is reused:
        the optimiser's profiled posterior (:meth:`LogPosterior.profiled`) profiles the noise and then
        evaluates the likelihood at one point, and simulates once for both, not twice."""
        self._reused = ()
        try:
            yield self
        finally:
            self._reused = None

    def _remembered(self, what: str, params: dict, compute):
        """``compute()``, or inside :meth:`reusing` the result of the previous call when that asked
        for the same ``what`` at the same parameters (one result is kept)."""
        if getattr(self, "_reused", None) is None:
            return compute()
        key = (what, tuple(sorted(params.items())))
        if self._reused and self._reused[0] == key:
            return self._reused[1]
        value = compute()
        self._reused = (key, value)
        return value

    def log_likelihood(self, params: dict, noise: dict) -> float:
        v = self.variance(noise)
        if self.latent:
            _, _, z, psi, s2 = self._latent(params)
            return _marginal(z, psi, s2, v)[0]
        r = self.residual(params)
        return float(-0.5 * np.sum(np.log(2 * np.pi * v) + r**2 / v))

    def log_likelihoods(self, params: Sequence[dict], noises: Sequence[dict]) -> np.ndarray:
        """:meth:`log_likelihood` at each of P (params, noise) pairs: (P,).

        For linear models of force and release recordings the sets are evaluated together
        (:meth:`BeamModel.simulate_batch`: one inverse FFT per batch; the force noise's latent
        columns by :meth:`BandProjection.project_shifted` and their marginalisation by stacked
        solves), in chunks of :attr:`batch_size`; otherwise set by set. An exception from any set
        (a model that cannot be evaluated there) propagates: see :meth:`LogPosterior.terms_batch`.
        """
        if len(params) != len(noises):
            raise ValueError(f"{len(params)} parameter sets but {len(noises)} noise sets")
        if self.free_decay or not self.model.batches or not self._shared_effect_values(params):
            return np.array([self.log_likelihood(p, n) for p, n in zip(params, noises)], dtype=float)
        v = np.stack([self.variance(n) for n in noises]) if len(noises) else np.empty((0,) + self.z_data.shape)
        size = self.batch_size
        return np.concatenate([self._batch(params[i:i + size], v[i:i + size])
                               for i in range(0, len(params), size)] or [np.empty(0)])

    @cached_property
    def batch_size(self) -> int:
        """Parameter sets per chunk of :meth:`log_likelihoods`: their spectra, signals and latent
        columns take about 32 MB (a few sets for the full band of a 4 s record at 2048 Hz, dozens
        at 150 Hz)."""
        proj, c = self.projection, len(self.channels)
        k = 0 if self.force_noise is None else self.force_noise.size
        columns = 0 if self.force_noise is None else (k + 1) * proj.n_blocks * proj.n_bins
        inputs = 0 if self.force_noise is None or self.force_noise.mixing is None else 2 * k * self.model.grid.n_fft
        per_set = 16 * c * (3 * columns + 4 * self.model.grid.n_fft + inputs)
        return max(1, (1 << 25) // per_set)

    def _shared_effect_values(self, params: Sequence[dict]) -> bool:
        """Whether the sets agree on the column effects' own parameters (the batch path builds their
        columns once; they are fixed defaults unless a caller sets them)."""
        names = [p for e in self._column_effects for p in e.parameters]
        return all(q.get(n) == params[0].get(n) for q in params for n in names) if params else True

    def _batch(self, params: Sequence[dict], v: np.ndarray) -> np.ndarray:
        """:meth:`log_likelihoods` of one chunk; ``v`` (P, D, c) the noise variances."""
        return self._densities(*self._band_residuals(params), v)

    def _densities(self, z: np.ndarray, psi: np.ndarray | None, s2: np.ndarray | None, v: np.ndarray) -> np.ndarray:
        """The log likelihood of each set from its band residuals ``z`` (P, D, c), latent columns
        ``psi`` and their prior variances ``s2`` (:meth:`_band_residuals`) at noise variances ``v``
        (P, D, c): (P,)."""
        if psi is None:
            return -0.5 * np.sum(np.log(2 * np.pi * v) + z**2 / v, axis=(1, 2))
        return _marginal_batch(z, psi, s2, v)

    def _band_residuals(self, params: Sequence[dict]):
        """Band coordinates of data minus model for each set, (P, D, c), of the latent columns,
        (J, P, c, D), and their prior variances (J,): the force noise's, then the effects' (the
        columns None without latent terms)."""
        z, psi = self._model_band_residuals(params)
        s2 = None if psi is None else self.force_noise.variance
        if not self._column_effects:
            return z, psi, s2
        _, projected, own_s2 = self._effect_latent(params[0])                            # (D, c, J)
        columns = np.broadcast_to(projected.transpose(2, 1, 0)[:, None],
                                  (projected.shape[2], len(params)) + projected.shape[1::-1])
        if psi is None:
            return z, columns, own_s2
        return z, np.concatenate([psi, columns]), np.concatenate([s2, own_s2])

    def _model_band_residuals(self, params: Sequence[dict]) -> tuple[np.ndarray, np.ndarray | None]:
        """Band coordinates of data minus model for each set, (P, D, c), and of the force noise's
        latent columns, (J, P, c, D) (None without force noise)."""
        proj = self.projection
        if self.force_noise is None:
            return self.z_data - proj.project(self.model.simulate_batch(params)).transpose(1, 0, 2), None
        if self.force_noise.mixing is not None:
            y, columns = self.model.simulate_with_input_batch(params, self._input_spectra)
            z = self.z_data - proj.project(y).transpose(1, 0, 2)
            return z, proj.project_last(columns).transpose(2, 0, 1, 3)                # (K, P, c, D)
        index = self.force_noise.index
        first = proj.i0 - int(index.max())
        lags = np.arange(first, proj.i0 + proj.n_blocks * proj.block - int(index.min()))
        y, unit = self.model.simulate_with_impulse_batch(params, lags)
        z = self.z_data - proj.project(y).transpose(1, 0, 2)                         # (P, D, c)
        return z, proj.project_shifted(unit, first, index)                           # (J, P, c, D)

    @property
    def profiles_in_batches(self) -> bool:
        """Whether :meth:`profiled_log_likelihoods` applies: white noise on a forced or released
        recording of a linear model."""
        return self.noise == "white" and not self.free_decay and self.model.batches

    def profiled_log_likelihoods(self, params: Sequence[dict], clip) -> tuple[np.ndarray, np.ndarray]:
        """What :meth:`profile_noise` and :meth:`log_likelihood` give together, for P sets at once:
        (noise variances (P, c) at their conditional optimum passed through ``clip`` (a callable
        on such an array, e.g. into the priors' support), log likelihoods there (P,)); one model
        evaluation per set serves both. Needs :attr:`profiles_in_batches`."""
        variances, values = [], []
        for i in range(0, len(params), self.batch_size):
            z, psi, s2 = self._band_residuals(params[i:i + self.batch_size])
            v = clip(np.mean(z**2, axis=1) if psi is None else _profiled_variance_batch(z, psi, s2))
            values.append(self._densities(z, psi, s2, np.broadcast_to(v[:, None], z.shape)))
            variances.append(v)
        return np.concatenate(variances), np.concatenate(values)

    def pointwise(self, params: dict, noise: dict) -> np.ndarray:
        """Per-block log-likelihood terms, summed over channels: (n_blocks,).

        With latent terms they are conditional on the latent posterior mean.
        """
        v = self.variance(noise)
        if self.latent:
            _, _, z, psi, s2 = self._latent(params)
            r = z - psi @ _marginal(z, psi, s2, v)[1]
        else:
            r = self.residual(params)
        terms = -0.5 * (np.log(2 * np.pi * v) + r**2 / v)
        return np.bincount(self.projection.blocks, weights=terms.sum(axis=1),
                           minlength=self.projection.n_blocks)

    def predict(self, params: dict, noise: dict | None = None) -> np.ndarray:
        """The model's signals (n_samples, c); latent terms at their posterior mean given the
        noise (``None``: the profiled noise of :meth:`profile_noise`)."""
        if not self.latent:
            return self.model.simulate(params)
        y, basis, z, psi, s2 = self._latent(params, whole=True)
        v = self.variance(noise) if noise is not None else self._profiled_variance(z, psi, s2)
        return y + basis @ _marginal(z, psi, s2, v)[1]

    def profile_noise(self, params: dict) -> dict:
        """Noise parameters at their conditional optimum: each channel's sd the RMS of its band
        residual (after the latent terms' posterior mean), AR(1) phi at 0."""
        if self.latent:
            v = self._profiled_variance(*self._latent(params)[2:])
        else:
            v = np.mean(self.residual(params) ** 2, axis=0, keepdims=True)
        noise = {f"sigma_{c}": float(np.sqrt(v[0, i])) for i, c in enumerate(self.channels)}
        noise.update({n: 0.0 for n in self.noise_names if n.startswith("phi_")})
        return noise

    # ------------------------------------------------------------------ latent terms
    def _latent(self, params, whole: bool = False):
        """(model signals y (n, c), latent columns Psi (n, c, J), the band coordinates of
        data - y (D, c) and of Psi (D, c, J), and the prior variances S^2 (J,)).

        A free decay's y and Psi cover only the projection's window unless ``whole``: the
        likelihood needs no more, and a long record's modes cost in proportion to its length.
        """
        return self._remembered(f"latent, whole={whole}", params, lambda: self._latent_terms(params, whole))

    def _latent_terms(self, params, whole: bool):
        """:meth:`_latent`, computed: the model's latent terms, then the effects' columns."""
        y, basis, z, psi, s2 = self._model_latent_terms(params, whole)
        if not self._column_effects:
            return y, basis, z, psi, s2
        columns, projected, own_s2 = self._effect_latent(params)
        if not whole and self.free_decay:
            columns = columns[self.projection.window]
        return (y, np.concatenate([basis, columns], axis=2), z, np.concatenate([psi, projected], axis=2),
                np.concatenate([s2, own_s2]))

    def _model_latent_terms(self, params, whole: bool):
        """The free decay's or the force noise's latent terms (:meth:`_latent`); none (J = 0)
        for a forced or released recording with a clean force channel."""
        if self.free_decay:
            basis = self.model.free_decay_basis(params, slice(None) if whole else self.projection.window)
            psi = self.projection.project(basis) if whole else self.projection.project_window(basis)
            # Each mode's amplitude has a prior giving its column an RMS of 10x the data's. In
            # units of the column's own RMS that prior is the same for every mode, and a column
            # that moves nothing in the band (a mode overdamped to nothing within the window,
            # RMS 0 or denormal) drops out of the marginal instead of carrying an infinite variance.
            col_rms = np.sqrt(np.mean(psi**2, axis=(0, 1)))
            scale = np.where(col_rms > np.finfo(float).tiny, col_rms, np.inf)
            s2 = np.full(col_rms.size, (LATENT_PRIOR_FACTOR * self._data_rms) ** 2)
            return np.zeros(basis.shape[:2]), basis / scale, self.z_data, psi / scale, s2
        if self.force_noise is None:
            y = self.model.simulate(params)
            n, c = y.shape
            return y, np.zeros((n, c, 0)), self.z_data - self.projection.project(y), np.zeros(self.z_data.shape + (0,)), np.zeros(0)
        if self.force_noise.mixing is None:
            y, basis = self.model.simulate_with_impulses(params, self.force_noise.index)
        else:
            y, basis = self.model.simulate_with_inputs(params, self._input_spectra)
        z = self.z_data - self.projection.project(y)
        return y, basis, z, self.projection.project(basis), self.force_noise.variance

    def _effect_latent(self, params) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The column effects' latent terms at their values in ``params``: columns in time
        (n_samples, c, J), in band coordinates (D, c, J), prior variances (J,). Built once per
        value of the effects' own parameters (mains pickup's are fixed): the columns do not
        depend on the beam's."""
        values = self.model.values(params)
        key = tuple(values[p] for e in self._column_effects for p in e.parameters)
        if self._effect_terms_at is None or self._effect_terms_at[0] != key:
            self._effect_terms_at = (key, self._effect_terms(values))
        return self._effect_terms_at[1]

    def _effect_terms(self, values) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """:meth:`_effect_latent`, computed. The prior is the free decay's wide rule read per
        channel (each column moves one channel): amplitude sd 10 x the RMS of its channel's band
        coordinates of the data over the column's RMS there, so that evidences with and without
        the effect stay comparable and no model chooses its own prior width."""
        rec, proj = self.model.recording, self.projection
        columns = np.concatenate([e.latent_columns(rec.time, values, len(self.channels), proj.max_frequency)
                                  for e in self._column_effects], axis=2)
        projected = proj.project(columns)
        channel = np.argmax(np.sum(projected**2, axis=0), axis=0)                       # (J,)
        col_rms = np.sqrt(np.mean(projected[:, channel, np.arange(channel.size)] ** 2, axis=0))
        data_rms = np.sqrt(np.mean(self.z_data**2, axis=0))[channel]
        scale = np.where(col_rms > np.finfo(float).tiny, col_rms, np.inf)
        return columns / scale, projected / scale, (LATENT_PRIOR_FACTOR * data_rms) ** 2

    @cached_property
    def _input_spectra(self) -> np.ndarray:
        """The force-noise inputs' spectra on the model's grid (n_freq, K): a recorded sample is
        1/factor of a sample of the decimated record (the same impulse, sample x dt)."""
        noise = self.force_noise
        return self.model.sample_spectra(noise.position, noise.mixing / noise.factor)

    def _profiled_variance(self, z, psi, s2, iterations: int = 3) -> np.ndarray:
        """White-noise variance per channel (1, c) at which the latent posterior mean and the
        RMS residual agree: a few fixed-point steps from the RMS of z (each moves it less, as
        the J latent terms absorb a share of order J/D of the residual)."""
        v = np.mean(z**2, axis=0, keepdims=True)
        for _ in range(iterations):
            coef = _marginal(z, psi, s2, np.broadcast_to(v, z.shape))[1]
            v = np.maximum(np.mean((z - psi @ coef) ** 2, axis=0, keepdims=True), np.finfo(float).tiny)
        return np.broadcast_to(v, z.shape)

    @cached_property
    def _data_rms(self) -> float:
        return float(np.sqrt(np.mean(self.z_data**2)))


def _profiled_variance_batch(z: np.ndarray, psi: np.ndarray, s2: np.ndarray, iterations: int = 3) -> np.ndarray:
    """White-noise variance per set and channel (P, c) at which the latent posterior mean and the
    RMS residual agree: a few fixed-point steps from the RMS of z (each moves it less, as the J
    latent terms absorb a share of order J/D of the residual; :meth:`Likelihood._profiled_variance`
    of each set). ``z`` (P, D, c), ``psi`` (J, P, c, D) as in :func:`_marginal_batch`."""
    v = np.mean(z**2, axis=1)
    columns = psi.transpose(1, 3, 2, 0)                                               # (P, D, c, J)
    for _ in range(iterations):
        coef = _marginal_parts(z, psi, s2, np.broadcast_to(v[:, None], z.shape))[3]
        fitted = np.einsum("pdcj,pj->pdc", columns, coef)
        v = np.maximum(np.mean((z - fitted) ** 2, axis=1), np.finfo(float).tiny)
    return v


def _marginal_parts(z, psi, s2, v):
    """(whitened data y (P, D c), A (P, J, J), b (P, J), A^-1 b (P, J)) of :func:`_marginal_batch`."""
    n_sets = z.shape[0]
    w = 1.0 / np.sqrt(v)
    y = (z * w).reshape(n_sets, -1)                                                  # (P, D c)
    p = (psi.transpose(1, 0, 3, 2) * w[:, None]).reshape(n_sets, psi.shape[0], -1)  # (P, J, D c)
    a = p @ p.transpose(0, 2, 1) + np.diag(1.0 / s2)
    b = (p @ y[:, :, None])[:, :, 0]
    return y, a, b, np.linalg.solve(a, b[:, :, None])[:, :, 0]


def _marginal_batch(z: np.ndarray, psi: np.ndarray, s2: np.ndarray, v: np.ndarray) -> np.ndarray:
    """The log density of :func:`_marginal` at each of P sets: ``z`` (P, D, c), ``psi`` (J, P, c, D)
    (the layout of :meth:`BandProjection.project_shifted`), ``s2`` (J,), ``v`` (P, D, c): (P,).

    Stacked J x J Cholesky factors for the determinant, stacked LU solves for A^-1 b.
    """
    y, a, b, coef = _marginal_parts(z, psi, s2, v)
    chol = np.linalg.cholesky(a)
    logdet_a = 2 * np.sum(np.log(np.diagonal(chol, axis1=1, axis2=2)), axis=1)
    return -0.5 * (y.shape[1] * np.log(2 * np.pi) + np.sum(np.log(v), axis=(1, 2)) + np.sum(np.log(s2))
                   + logdet_a + np.sum(y * y, axis=1) - np.sum(b * coef, axis=1))


def _marginal(z: np.ndarray, psi: np.ndarray, s2: np.ndarray, v: np.ndarray) -> tuple[float, np.ndarray]:
    """log N(z; 0, V + Psi S^2 Psi^T) and the latent posterior mean A^-1 b (module docstring).

    ``z`` (D, c) coordinates, ``psi`` (D, c, J) latent columns, ``s2`` (J,) prior variances,
    ``v`` (D, c) noise variances.
    """
    w = 1.0 / np.sqrt(v)
    y = (z * w).ravel()
    p = (psi * w[:, :, None]).reshape(y.size, -1)
    a = np.diag(1.0 / s2) + p.T @ p
    b = p.T @ y
    chol = linalg.cho_factor(a)
    coef = linalg.cho_solve(chol, b)
    logdet_a = 2 * np.sum(np.log(np.diag(chol[0])))
    value = -0.5 * (y.size * np.log(2 * np.pi) + np.sum(np.log(v)) + np.sum(np.log(s2))
                    + logdet_a + y @ y - b @ coef)
    return float(value), coef
