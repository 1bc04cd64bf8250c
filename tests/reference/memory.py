r"""The time-hysteresis kernel as an exact-in-the-limit sum of exponentials.

The paper's kernel (eq. 11) read as a function of the lag :math:`\sigma = -s > 0` is
:math:`g(\sigma) = \alpha e^{-\beta\sigma}\sigma^{-1/2}` (alpha in N m^2 s^-1/2, beta in 1/s, memory
r = infinity). Since :math:`\sigma^{-1/2} = \pi^{-1/2}\int_{-\infty}^{\infty} e^{u/2}\exp(-e^u\sigma)\,du`,
the trapezoidal rule in u (step du, nodes u_k, rates :math:`\lambda_k = e^{u_k}`) gives

.. math:: g(\sigma) \approx \alpha e^{-\beta\sigma}\Big[\sum_k c_k e^{-\lambda_k\sigma}
          + c_{lo}\Big] + \text{(high tail)},\qquad c_k = \frac{du\, e^{u_k/2}}{\sqrt\pi},

whose error falls like :math:`e^{-\pi^2/du}` (the integrand is analytic in a strip of half-width
about pi/2 around the real u axis for the frequencies of a beam). The two tails of the u integral are
kept in closed form instead of being dropped:

* rates below :math:`\lambda_{lo}` act as :math:`e^{-\lambda\sigma} \approx 1`: one more
  exponential of rate beta and weight :math:`c_{lo} = 2\sqrt{\lambda_{lo}/\pi}`;
* rates above :math:`\lambda_{hi}` act instantaneously: :math:`1/(s+\beta+\lambda) \approx
  1/\lambda - (s+\beta)/\lambda^2`, i.e. a stiffness loss :math:`\alpha(\kappa_0 - \beta\kappa_1)`
  and a damping :math:`\alpha\kappa_1` with :math:`\kappa_0 = 2/\sqrt{\pi\lambda_{hi}}`,
  :math:`\kappa_1 = 2/(3\sqrt\pi\,\lambda_{hi}^{3/2})`.

Each tail is scaled by the factor :math:`(k\,du/2)/\sinh(k\,du/2)` by which the midpoint rule
misjudges :math:`\int e^{\mp k u}du` over a half-line (k = 1/2, or 3/2 for kappa_1): the tails
then stand for the midpoint rule's own cells beyond the ends, so the truncated sum keeps the
spectral accuracy of the rule on the whole line (without this its end cells cost
:math:`du^2\sqrt{\lambda_{lo}/|s+\beta|}/48`).

Each exponential becomes one memory state :math:`\zeta_k' = -(\beta+\lambda_k)\zeta_k + q`, so the
integro-differential equation turns into an ordinary linear one that is then integrated exactly.
In the Laplace domain the approximation replaces :math:`\hat G(s) = \alpha\sqrt\pi/\sqrt{s+\beta}`
by :meth:`SumOfExponentials.transform`, which the tests compare over the band.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class SumOfExponentials:
    """sigma^-1/2 on rates [lam_lo, lam_hi] (1/s), trapezoid step du in log-rate."""

    lam_lo: float
    lam_hi: float
    du: float = 0.5

    @classmethod
    def covering(cls, beta: float, omega_max: float, du: float = 0.5) -> SumOfExponentials:
        """Rates from 1e-6 beta to 1e4 omega_max (rad/s): both tails' relative errors stay below
        about 1e-9 for |s + beta| between beta and omega_max."""
        if beta <= 0:
            raise ValueError("time hysteresis with infinite memory needs beta > 0 (1/s): with beta = 0 the "
                             "relaxed stiffness EI - G(0) is minus infinity. Fix: give beta > 0.")
        return cls(1e-6 * beta, 1e4 * max(omega_max, beta), du)

    @property
    def u(self) -> np.ndarray:
        n = int(np.ceil(np.log(self.lam_hi / self.lam_lo) / self.du))
        return np.log(self.lam_lo) + self.du * (np.arange(n) + 0.5)

    @property
    def rates(self) -> np.ndarray:
        """lambda_k (1/s), the extra decay rates on top of beta."""
        return np.exp(self.u)

    @property
    def weights(self) -> np.ndarray:
        """c_k (s^-1/2)."""
        return self.du * np.exp(self.u / 2) / np.sqrt(np.pi)

    @property
    def top(self) -> float:
        """The upper end of the trapezoid's last cell (the high tail starts here)."""
        return float(np.exp(self.u[-1] + self.du / 2))

    def _cells(self, k: float) -> float:
        """The midpoint rule's sum over a half-line of cells of exp(-k u), over its integral."""
        return (k * self.du / 2) / np.sinh(k * self.du / 2)

    @property
    def low_weight(self) -> float:
        return 2 * np.sqrt(self.lam_lo / np.pi) * self._cells(0.5)

    @property
    def kappa(self) -> tuple[float, float]:
        """(kappa_0 in s^-1/2, kappa_1 in s^1/2) of the instantaneous high tail."""
        top = self.top
        return (2 / np.sqrt(np.pi * top) * self._cells(0.5),
                2 / (3 * np.sqrt(np.pi) * top**1.5) * self._cells(1.5))

    def transform(self, s, alpha: float, beta: float) -> np.ndarray:
        """The approximate relaxation transform G(s) (N m^2), to compare with alpha sqrt(pi/(s+beta))."""
        s = np.asarray(s, dtype=complex)[..., None]
        kappa0, kappa1 = self.kappa
        body = np.sum(self.weights / (s + beta + self.rates), axis=-1)
        return alpha * (body + self.low_weight / (s[..., 0] + beta) + kappa0 - kappa1 * (s[..., 0] + beta))
