"""Shared checks of the hereditary mechanisms: a numerical Kramers-Kronig transform, the bare
beam's models, and the closed-form roots of a mode's characteristic polynomial."""
from __future__ import annotations

import numpy as np
from scipy import integrate, linalg

from bayesbeam import BeamModel
from bayesbeam.response.linear import FrequencyGrid, force_response
from bayesbeam.response.system import SecondOrderSystem
from tests.galerkin_reference import EI, gaussian, paper_operators
from tests.physics.effects.helpers import PAPER_EI, recording


def kramers_kronig_real(imag, w0: float) -> float:
    r"""Re K(i w0) from Im K(i w) alone, for the Laplace transform K of a real causal kernel with
    Re K -> 0 as w -> inf (Hilbert transform, folded onto w > 0 with K(-i w) = conj K(i w)):

    .. math:: \mathrm{Re}\,K(i\omega_0) = -\frac{2}{\pi}\, P\!\!\int_0^\infty
              \frac{\omega\, \mathrm{Im}\,K(i\omega)}{\omega^2 - \omega_0^2}\, d\omega .

    (the sign of s = i w: K(s) = 1/(s + a) gives Re K(0) = 1/a > 0 from Im K < 0). The principal
    value on [0, 2 w0] by QUADPACK's Cauchy weight (QAWC), the rest by QAGI.
    """
    opts = {"epsabs": 0.0, "epsrel": 1e-10, "limit": 400}
    # w Im K(i w) -> 0 as w -> 0 for every kernel here (Im K bounded, or ~ w^(nu-1) for D^nu)
    near = integrate.quad(lambda w: w * imag(w) / (w + w0) if w > 0 else 0.0, 0.0, 2 * w0,
                          weight="cauchy", wvar=w0, **opts)[0]
    far = integrate.quad(lambda w: w * imag(w) / (w * w - w0 * w0), 2 * w0, np.inf, **opts)[0]
    return -2 / np.pi * (near + far)


def bare_model(spec: str, extra: dict | None = None, n_intervals: int = 16) -> BeamModel:
    """The paper's beam without a tip body (its modes diagonalise K_0), a force recording."""
    rec = recording("force")
    if extra:
        from dataclasses import replace
        rec = replace(rec, extra=extra)
    return BeamModel(rec, spec, n_intervals)


def modes_and_poles(model: BeamModel, values: dict, count: int = 5):
    """(omega_m^2 of the undamped bare beam at EI, the model's oscillatory poles), lowest ``count``."""
    lam = model.system(values).undamped[0][:count]
    return lam, model.poles(values)[:count]


def oscillatory_root(coefficients, lam: float) -> complex:
    """The root with Im > 0 nearest i sqrt(lam) of the polynomial (highest power first)."""
    roots = np.roots(coefficients)
    roots = roots[roots.imag > 0]
    return complex(roots[np.argmin(np.abs(roots - 1j * np.sqrt(lam)))])


def damping_ratio(p):
    return -np.real(p) / np.abs(p)


def relative_rms(x, reference) -> float:
    """RMS of x relative to the RMS of ``reference``."""
    return float(np.sqrt(np.mean(np.square(x)) / np.mean(np.square(reference))))


class PulseCase:
    """The time-response set-up: the paper beam (N = 6, no tip body) struck at 0.75 m by a Gaussian
    force pulse (std 4 samples, centre 40 samples: its spectrum is exp(-50) at 0.4 fs, so the band-
    limited interpolant of its samples is the Gaussian itself), 1 s at 256 Hz, tip displacement."""

    def __init__(self):
        self.ops = paper_operators(6)
        self.dt = 1 / 256.0
        self.t = self.dt * np.arange(256)
        self.load = self.ops.rows([0.75])[0]

    def force(self, t):
        return gaussian(t, 40 * self.dt, 4 * self.dt)

    def fft_response(self, relaxation) -> np.ndarray:
        """Tip displacement by the code under test: the exact frequency-domain solver with
        Z(s) = s^2 M + EI K_0 - G(s) K_0."""
        ops = self.ops
        system = SecondOrderSystem(ops.M, 0 * ops.M, EI * ops.K0, relaxation, ops.K0)
        return force_response(system, FrequencyGrid(self.t.size, self.dt), ops.tip_value[None, :], [0], self.load,
                              self.force(self.t))[:, 0]


def single_pole_response(mod, g: float, a: float, force, t: np.ndarray) -> np.ndarray:
    r"""Modal displacements q (len(t), modes) from rest of the Galerkin system with the memory
    transform :math:`\hat G(s) = -g\,s/(s + a)` (exponential relaxation, Zener), integrated in the
    time domain through its internal variable: :math:`\hat G` is the Laplace transform of the
    moment r with :math:`\dot r = -a r + g \dot q`, so each mode of ``mod`` obeys

    .. math:: \ddot q + \lambda q + \kappa r = p f(t), \qquad \dot r = -a r + g \dot q,

    a linear ODE :math:`\dot x = A x + b f`. Stepped exactly on the grid ``t`` (uniform):
    :math:`x_{k+1} = e^{Ah} x_k + \int_0^h e^{A(h-\sigma)} b f(t_k + \sigma) d\sigma`, the
    integral by 12-point Gauss-Legendre (a smooth force varying over several steps: error far below
    1e-12). Nothing in the Laplace domain. ``force`` is a function of time (N).
    """
    n, h = mod.lam.size, t[1] - t[0]
    zero, eye = np.zeros((n, n)), np.eye(n)
    a_matrix = np.block([[zero, eye, zero],
                         [-np.diag(mod.lam), zero, -np.diag(mod.kappa)],
                         [zero, g * eye, -a * eye]])
    drive = np.concatenate([np.zeros(n), mod.p, np.zeros(n)])
    nodes, weights = np.polynomial.legendre.leggauss(12)
    sigma = 0.5 * h * (nodes + 1)
    kicks = np.stack([linalg.expm(a_matrix * (h - s)) @ drive for s in sigma], axis=1) * (0.5 * h * weights)
    step = linalg.expm(a_matrix * h)
    x = np.zeros((t.size, 3 * n))
    for k in range(t.size - 1):
        x[k + 1] = step @ x[k] + kicks @ force(t[k] + sigma)
    return x[:, :n]

__all__ = ["EI", "PAPER_EI", "PulseCase", "bare_model", "damping_ratio", "kramers_kronig_real", "modes_and_poles",
           "oscillatory_root", "relative_rms", "single_pole_response"]
