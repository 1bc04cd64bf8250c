r"""Time hysteresis, the paper's eqs. (10)-(12): a weakly singular memory of the curvature.

The bending moment is :math:`EI\,u_{xx}(t) - \int_{-r}^0 g(s)\,u_{xx}(t+s)\,ds` with

.. math:: g(s) = \alpha\, e^{\beta s} / \sqrt{-s}, \qquad -r \le s < 0,

alpha in N m^2 s^-1/2, beta in 1/s, r in s (default: infinite memory). In weak form the memory
term is :math:`-\int_0^r g(-\sigma) K_0 w(t-\sigma)\,d\sigma`, whose Laplace transform is a scalar
times :math:`K_0`:

.. math::

    \hat G(s) = \alpha \int_0^r e^{-(\beta + s)\sigma} \sigma^{-1/2}\, d\sigma
              = \alpha \sqrt{\pi}\; \frac{\operatorname{erf}\sqrt{(\beta+s) r}}{\sqrt{\beta + s}},
    \qquad \hat G(s) \xrightarrow{r\to\infty} \frac{\alpha\sqrt{\pi}}{\sqrt{s + \beta}} .

The history is therefore represented *exactly* (no sum-of-exponentials truncation) by the
frequency-domain solver of :mod:`bayesbeam.response.linear`; the time-domain verification in the
tests is an independent product-integration (convolution quadrature) of the same equation.

Physical admissibility: the relaxed (static) stiffness :math:`EI - \hat G(0)` must stay positive,
:math:`\hat G(0) = \alpha\sqrt{\pi/\beta}\,\operatorname{erf}\sqrt{\beta r}` (or
:math:`2\alpha\sqrt r` for beta = 0).
"""
import numpy as np
from scipy.special import erf

from bayesbeam.physics.mechanisms.base import Mechanism


def relaxation_transform(s, alpha: float, beta: float, r: float = np.inf):
    """G(s) = alpha * int_0^r exp(-(beta+s) t) / sqrt(t) dt for Re(s + beta) > 0 (N m^2)."""
    z = np.sqrt(np.asarray(s, dtype=complex) + beta)
    if np.isinf(r):
        return alpha * np.sqrt(np.pi) / z
    return alpha * np.sqrt(np.pi) * erf(z * np.sqrt(r)) / z


def static_relaxation(alpha: float, beta: float, r: float = np.inf) -> float:
    """G(0): the stiffness lost at equilibrium (N m^2)."""
    if beta == 0:
        return np.inf if np.isinf(r) else 2 * alpha * np.sqrt(r)
    return float(alpha * np.sqrt(np.pi / beta) * (1.0 if np.isinf(r) else erf(np.sqrt(beta * r))))


def memory_kernel(sigma, alpha: float, beta: float, r: float = np.inf):
    """g(-sigma) = alpha exp(-beta sigma)/sqrt(sigma) on 0 < sigma <= r, else 0 (N m^2 / s)."""
    sigma = np.asarray(sigma, dtype=float)
    inside = (sigma > 0) & (sigma <= r)
    safe = np.where(inside, sigma, 1.0)
    return np.where(inside, alpha * np.exp(-beta * safe) / np.sqrt(safe), 0.0)


class TimeHysteresis(Mechanism):
    name = "time_hysteresis"
    parameters = ("alpha", "beta", "r")
    units = {"alpha": "N m^2 s^-1/2", "beta": "1/s", "r": "s"}
    defaults = {"r": np.inf}
    hereditary = True
    description = "time hysteresis, kernel g(s) = alpha exp(beta s)/sqrt(-s) on [-r, 0]"

    def check(self, values):
        super().check(values)
        if not values["r"] > 0:
            raise ValueError(f"time_hysteresis: r = {values['r']!r} must be > 0 s")
        if values["beta"] == 0 and np.isinf(values["r"]):
            raise ValueError("time_hysteresis: beta = 0 with an infinite history r loses infinite "
                             "static stiffness (G(0) = inf): give beta > 0 1/s or a finite r")

    def relaxation(self, values):
        alpha, beta, r = values["alpha"], values["beta"], values["r"]
        return lambda s: relaxation_transform(s, alpha, beta, r)

    def static_loss(self, values) -> float:
        """G(0), the equilibrium stiffness loss (N m^2)."""
        return static_relaxation(values["alpha"], values["beta"], values["r"])
