r"""A linear second-order system and its fast transfer-function evaluation.

The Galerkin equations of every linear damping model are, in the Laplace domain,

.. math::

    Z(s)\,W(s) = B\,F(s), \qquad Z(s) = s^2 M + s D + K - \hat G(s)\, K_h ,

with constant mass, damping and stiffness matrices and, for time hysteresis, a scalar
relaxation transform :math:`\hat G(s)` times :math:`K_h = K_0`. The transfer matrix
:math:`C Z(s)^{-1} B` is evaluated on many frequencies through one of three exact modal forms:

``diagonal``
    the undamped modes :math:`\Phi` of :math:`(K, M)` diagonalise :math:`D` and :math:`K_h`
    (air without tip body, strain rate, time hysteresis): one scalar denominator per mode.
``complex``
    no memory term, general :math:`D` (spatial hysteresis, air with a tip body): the complex
    eigenvalues :math:`p_j` of the first-order form give :math:`\sum_j R_j/(s - p_j)`.
``dense``
    memory term and non-diagonal damping: a batched solve in modal coordinates per frequency.
"""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from functools import cached_property

import numpy as np
from scipy import linalg

_DIAGONAL_TOL = 1e-10


@dataclass(frozen=True, eq=False)
class SecondOrderSystem:
    """M w'' + D w' + K w - (g * K_h w)(t) = B f  with relaxation transform g^(s) (or none)."""

    M: np.ndarray
    D: np.ndarray
    K: np.ndarray
    relaxation: Callable[[np.ndarray], np.ndarray] | None = None
    K_h: np.ndarray | None = None

    @property
    def size(self) -> int:
        return self.M.shape[0]

    @cached_property
    def undamped(self) -> tuple[np.ndarray, np.ndarray]:
        """Undamped eigenpairs (omega^2, mass-normalised Phi) of K phi = omega^2 M phi."""
        lam, phi = linalg.eigh(self.K, self.M)
        return lam, phi

    def _modal(self, a: np.ndarray) -> np.ndarray:
        phi = self.undamped[1]
        return phi.T @ a @ phi

    @cached_property
    def form(self) -> str:
        """Which modal form evaluates the transfer function exactly (see module docstring)."""
        diag_ok = _is_diagonal(self._modal(self.D))
        if self.relaxation is None:
            return "diagonal" if diag_ok else "complex"
        return "diagonal" if diag_ok and _is_diagonal(self._modal(self.K_h)) else "dense"

    def static_stiffness(self) -> np.ndarray:
        """Stiffness at equilibrium, K - G(0) K_h (N/m in generalised coordinates)."""
        if self.relaxation is None:
            return self.K
        return self.K - np.real(self.relaxation(np.array([0.0])))[0] * self.K_h

    def check_stable(self) -> None:
        """Raise ValueError if the relaxed stiffness is not positive definite."""
        try:
            np.linalg.cholesky(self.static_stiffness())
        except np.linalg.LinAlgError:
            raise ValueError(
                "the relaxed (static) stiffness is not positive definite: the memory term "
                "removes more stiffness than EI provides"
            ) from None

    # ----------------------------------------------------------------- transfer functions
    def transfer(self, s: np.ndarray, C: np.ndarray, B: np.ndarray) -> np.ndarray:
        """C Z(s)^-1 B for every s: array (len(s), n_out, n_in) (m/N for displacement rows)."""
        s = np.asarray(s, dtype=complex)
        shape = (s.size, C.shape[0], B.shape[1])
        if self.form == "complex":
            return self._transfer_complex(s, C, B).reshape(shape)
        phi = self.undamped[1]
        cphi, phib = C @ phi, phi.T @ B
        if self.form == "diagonal":
            weights = (cphi[:, :, None] * phib[None, :, :]).transpose(1, 0, 2).reshape(self.size, -1)
            return (self._inverse_denominator(s) @ weights.astype(complex)).reshape(shape)
        z = self._modal_dynamic_stiffness(s)
        return np.einsum("om,fmi->foi", cphi, np.linalg.solve(z, np.broadcast_to(phib, (s.size,) + phib.shape)))

    def _inverse_denominator(self, s: np.ndarray) -> np.ndarray:
        """1/(s^2 + c_m s + k_m - G(s) h_m) per mode: array (len(s), n). In place: this is the hot loop."""
        den = np.multiply.outer(s, np.diag(self._modal(self.D)).astype(complex))
        den += (s * s)[:, None]
        den += self.undamped[0]
        if self.relaxation is not None:
            den -= np.multiply.outer(self.relaxation(s), np.diag(self._modal(self.K_h)))
        return np.reciprocal(den, out=den)

    def _transfer_complex(self, s: np.ndarray, C: np.ndarray, B: np.ndarray) -> np.ndarray:
        """Sum over complex modes, conjugate pairs folded into real second-order sections.

        R/(s-p) + conj(R)/(s-conj(p)) = (2 Re(R) s - 2 Re(R conj(p))) / (s^2 - 2 Re(p) s + |p|^2).
        """
        poles, left, right = self._complex_modes(C, B)
        res = (left.T[:, :, None] * right[:, None, :]).reshape(poles.size, -1)
        upper = poles.imag > 1e-12 * np.abs(poles)
        real = np.abs(poles.imag) <= 1e-12 * np.abs(poles)
        p, r = poles[upper], res[upper]
        den = np.multiply.outer(s, -2 * p.real + 0j)
        den += (s * s)[:, None]
        den += np.abs(p) ** 2
        np.reciprocal(den, out=den)
        # complex @ complex: numpy has no BLAS path for complex @ float (ten times slower)
        out = s[:, None] * (den @ (2 * r.real).astype(complex))
        out += den @ (-2 * (r * p.conj()[:, None]).real).astype(complex)
        if np.any(real):
            out += (1.0 / (s[:, None] - poles[real].real[None, :])) @ res[real].real.astype(complex)
        return out

    def _modal_dynamic_stiffness(self, s: np.ndarray) -> np.ndarray:
        lam = self.undamped[0]
        d_m, kh_m = self._modal(self.D), self._modal(self.K_h)
        eye = np.eye(self.size)
        return (s[:, None, None] ** 2 * eye + s[:, None, None] * d_m + np.diag(lam)
                - self.relaxation(s)[:, None, None] * kh_m)

    def _complex_modes(self, C: np.ndarray, B: np.ndarray):
        poles, vec = self.state_modes
        n = self.size
        vinv = np.linalg.inv(vec)
        minv_b = np.linalg.solve(self.M, B)
        left = C @ vec[:n, :]
        right = vinv[:, n:] @ minv_b
        return poles, left, right

    @cached_property
    def state_modes(self) -> tuple[np.ndarray, np.ndarray]:
        """Eigenvalues and eigenvectors of the first-order state matrix (no memory term)."""
        n = self.size
        minv_k = np.linalg.solve(self.M, self.K)
        minv_d = np.linalg.solve(self.M, self.D)
        a = np.block([[np.zeros((n, n)), np.eye(n)], [-minv_k, -minv_d]])
        return np.linalg.eig(a)

    # ----------------------------------------------------------------- poles
    def poles(self) -> np.ndarray:
        """Oscillatory poles p = -zeta w + i w sqrt(1-zeta^2), Im p > 0, sorted by |p| (rad/s).

        With a memory term the poles are roots of det Z(s) = 0, found by Newton's method per
        mode (diagonal form) or by freezing G(s) at each pole and iterating (dense form).
        """
        if self.relaxation is None:
            p = self.state_modes[0]
        elif self.form == "diagonal":
            p = self._poles_diagonal()
        else:
            p = self._poles_frozen_kernel()
        p = p[p.imag > 0]
        return p[np.argsort(np.abs(p))]

    def _poles_diagonal(self) -> np.ndarray:
        lam = self.undamped[0]
        d_m, kh_m = np.diag(self._modal(self.D)), np.diag(self._modal(self.K_h))
        s = 1j * np.sqrt(lam.astype(complex))
        for _ in range(60):
            g = self.relaxation(s)
            ds = 1e-7 * np.abs(s)
            dg = (self.relaxation(s + ds) - self.relaxation(s - ds)) / (2 * ds)
            f = s**2 + s * d_m + lam - g * kh_m
            step = f / (2 * s + d_m - dg * kh_m)
            s = s - step
            if np.all(np.abs(step) <= 1e-13 * np.abs(s)):
                break
        return s

    def _poles_frozen_kernel(self) -> np.ndarray:
        out = []
        for guess in 1j * np.sqrt(self.undamped[0].astype(complex)):
            s = guess
            for _ in range(60):
                # freeze the (complex) memory stiffness at s and take the nearest eigenvalue
                z_k = self.K - self.relaxation(np.array([s]))[0] * self.K_h
                cand = _quadratic_eigenvalues(self.M, self.D, z_k)
                new = cand[np.argmin(np.abs(cand - s))]
                converged = abs(new - s) <= 1e-12 * abs(s)
                s = new
                if converged:
                    break
            out.append(s)
        return np.array(out)


def _quadratic_eigenvalues(M, D, K) -> np.ndarray:
    n = M.shape[0]
    a = np.block([[np.zeros((n, n)), np.eye(n)], [-np.linalg.solve(M, K), -np.linalg.solve(M, D)]])
    return np.linalg.eigvals(a)


def _is_diagonal(a: np.ndarray) -> bool:
    off = a - np.diag(np.diag(a))
    scale = np.max(np.abs(np.diag(a))) if a.size else 0.0
    return bool(np.max(np.abs(off), initial=0.0) <= _DIAGONAL_TOL * max(scale, np.finfo(float).tiny))
