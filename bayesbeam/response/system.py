r"""A linear second-order system and its fast transfer-function evaluation.

The Galerkin equations of every linear damping model are, in the Laplace domain,

.. math::

    Z(s)\,W(s) = B\,F(s), \qquad Z(s) = s^2 M + s D + K - \hat G(s)\, K_h ,

with constant symmetric mass, damping and stiffness matrices (Galerkin forms) and, for time
hysteresis, a scalar relaxation transform :math:`\hat G(s)` times :math:`K_h = K_0`. The
transfer matrix :math:`C Z(s)^{-1} B` is evaluated on many frequencies through one of these
exact forms:

``diagonal``
    the undamped modes :math:`\Phi` of :math:`(K, M)` diagonalise :math:`D` and :math:`K_h`
    (air without tip body, strain rate, time hysteresis): one scalar denominator per mode.
``complex``
    no memory term, general :math:`D` (spatial hysteresis, air with a tip body): the complex
    eigenvalues :math:`p_j` of the first-order form give :math:`\sum_j R_j/(s - p_j)`.
``low_rank``
    M and K depart from a pair whose modes diagonalise D and K_h (the bare beam's M_0, K_0 for
    air, strain-rate and time-hysteresis damping) along r directions W (r <= 2 with a memory
    term, else r = 1): a tip body, a sensor mass, a root spring. In the modes of (K, M), D and
    K_h are diagonal plus rank r, and a Woodbury correction of the diagonal form per frequency
    is exact (:meth:`SecondOrderSystem._transfer_low_rank`). Given a :class:`ReferencePair` (a pair
    that M and K depart from along W, with modes the caller cached), the same correction works in
    the reference's modes with M and K's departures added to it: no eigen-solve per call.
``banded``
    any other memory term whose matrices are banded (an axial load's full-rank geometric
    stiffness beside time hysteresis; the B-spline Galerkin forms couple only neighbouring
    splines, a root slope joins after reordering): a symmetric band elimination per frequency,
    vectorised over the frequencies (:meth:`SecondOrderSystem._transfer_banded`; 5-7 times the
    diagonal form per simulation, 6-8 times its work per frequency and degree of freedom: tables
    1 and 1d of benchmarks/effects.py).
``dense``
    the rest (memory beside spatial hysteresis, whose kernel couples every pair of splines):
    a batched solve in modal coordinates per frequency (50-500 times slower).

The first two are sums of real second-order sections (:func:`_sum_sections`), the hot loop of
every simulation: 85 % of ``BeamModel.simulate``.
"""
from __future__ import annotations

import itertools
import threading
from collections.abc import Callable
from dataclasses import dataclass
from functools import cached_property
from typing import NamedTuple

import numpy as np
from scipy.linalg import lapack
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import reverse_cuthill_mckee

_DIAGONAL_TOL = 1e-10
#: largest number of departing directions of the ``low_rank`` form (its per-frequency algebra is
#: written out for r <= 2)
LOW_RANK_MAX = 2
#: sections x frequencies per block of :func:`_sum_sections`: its four float64 temporaries
#: (1 MB) stay in the L2 cache; unblocked they spill and the sum runs 2-3x slower
_BLOCK = 1 << 15
_SCRATCH = threading.local()
#: widest half-bandwidth (after reordering) taken by the ``banded`` form: its elimination costs
#: O(n b^2) per frequency against O(n^3) for the dense solve (measured at the full width of spatial
#: hysteresis, b = n - 1, it is 0.6 to 1.5 times the dense solve's cost)
BAND_MAX = 6
#: frequencies per block of the band elimination (at most): it bounds the reused work buffer (5 MB
#: at N = 16, 13 MB at N = 48). Measured on 8193 frequencies, q2 + axial_load, N = 16/32/48:
#: 4.4/7.2/10.4 ms per simulate in three blocks, 4.2/8.0/11.9 in two, 5.0/9.0/12.6 in five
_BAND_BLOCK = 1 << 12


class BandOrder(NamedTuple):
    """A reordering of the degrees of freedom that makes Z(s) banded (see ``banded``)."""

    perm: np.ndarray        # (n,) new order of the degrees of freedom
    width: int              # half-bandwidth b in that order


class ReferencePair(NamedTuple):
    """A pair (M_r, K_r) that M and K depart from only along the system's ``departures``, whose
    undamped modes (lam, Phi, mass-normalised) diagonalise D and K_h up to those directions: known
    in advance (cached by the caller), they spare the ``low_rank`` form its eigen-solve per call."""

    mass: np.ndarray        # (n, n) M_r (kg in generalised coordinates)
    stiffness: np.ndarray   # (n, n) K_r (N/m)
    lam: np.ndarray         # (n,) omega^2 of (K_r, M_r) (rad^2/s^2)
    phi: np.ndarray         # (n, n) Phi with Phi^T M_r Phi = I, Phi^T K_r Phi = diag(lam)


class LowRankSplit(NamedTuple):
    """Z(s) in the modes Phi as diagonal plus rank r along V (see ``low_rank``)."""

    lam: np.ndarray         # (n,) diagonal of Phi^T K Phi - V S_K V^T
    phi: np.ndarray         # (n, n) the modes (Phi^T M Phi - V S_M V^T = I)
    v: np.ndarray           # (n, r) Phi^T W
    s_m: np.ndarray | None  # (r, r) W^T (M - M_r) W; None for zero (so in the modes of (K, M))
    s_k: np.ndarray | None  # (r, r) W^T (K - K_r) W; likewise
    s_d: np.ndarray         # (r, r)
    d: np.ndarray           # (n,) diagonal of Phi^T D Phi - V S_D V^T
    s_h: np.ndarray         # (r, r)
    h: np.ndarray           # (n,) diagonal of Phi^T K_h Phi - V S_H V^T

    def coupling(self, s: np.ndarray, g: np.ndarray | None) -> np.ndarray:
        """T(s) = s^2 S_M + s S_D + S_K - G(s) S_H for every s: (len(s), r, r). Terms that vanish
        are skipped: each costs a pass over the frequencies."""
        s = s[:, None, None]
        t = s * self.s_d if self.s_m is None else s * (s * self.s_m + self.s_d)
        if self.s_k is not None:
            t = t + self.s_k
        if g is not None and np.any(self.s_h):
            t = t - g[:, None, None] * self.s_h
        return t

    def coupling_and_slope(self, s: np.ndarray, g: np.ndarray, dg: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """T(s) (:meth:`coupling`) and T'(s) = 2 s S_M + S_D - G'(s) S_H: (len(s), r, r) each."""
        dt = self.s_d - dg[:, None, None] * self.s_h
        if self.s_m is not None:
            dt = dt + 2 * s[:, None, None] * self.s_m
        return self.coupling(s, g), dt


@dataclass(frozen=True, eq=False)
class SecondOrderSystem:
    """M w'' + D w' + K w - (g * K_h w)(t) = B f  with relaxation transform g^(s) (or none)."""

    M: np.ndarray
    D: np.ndarray
    K: np.ndarray
    relaxation: Callable[[np.ndarray], np.ndarray] | None = None
    K_h: np.ndarray | None = None
    #: the undamped eigenpairs (omega^2, Phi) when the caller already knows them
    modes: tuple[np.ndarray, np.ndarray] | None = None
    #: W (n, r): directions along which M and K depart from a pair whose undamped modes
    #: diagonalise D and K_h, when the caller knows them (see ``low_rank``; verified here)
    departures: np.ndarray | None = None
    #: a pair that M and K depart from only along :attr:`departures`, with its modes (see
    #: :class:`ReferencePair`): the ``low_rank`` form then needs no eigen-solve
    reference: ReferencePair | None = None

    @property
    def size(self) -> int:
        return self.M.shape[0]

    @cached_property
    def undamped(self) -> tuple[np.ndarray, np.ndarray]:
        """Undamped eigenpairs (omega^2, mass-normalised Phi): :attr:`modes` or :func:`undamped_modes`."""
        return self.modes if self.modes is not None else undamped_modes(self.K, self.M)

    def _modal(self, a: np.ndarray) -> np.ndarray:
        phi = self.undamped[1]
        return phi.T @ a @ phi

    @cached_property
    def modal_damping(self) -> np.ndarray:
        """The damping matrix in the mass-normalised undamped modes, Phi^T D Phi (1/s); diagonal
        where the modes diagonalise D (the ``diagonal`` form), each mode's 2 zeta_m omega_m."""
        return self._modal(self.D)

    @cached_property
    def _modal_memory(self) -> np.ndarray:
        return self._modal(self.K_h)

    @cached_property
    def form(self) -> str:
        """Which modal form evaluates the transfer function exactly (see module docstring)."""
        if self._in_reference_modes:
            return "low_rank"
        if self._diagonal:
            return "diagonal"
        if self._low_rank is not None:
            return "low_rank"
        if self.relaxation is None:
            return "complex"
        return "dense" if self._band is None else "banded"

    @cached_property
    def _diagonal(self) -> bool:
        """Do the undamped modes diagonalise D and K_h (the ``diagonal`` form)?"""
        return _is_diagonal(self.modal_damping) and (self.relaxation is None or _is_diagonal(self._modal_memory))

    @cached_property
    def _proportional_to_stiffness(self) -> bool:
        """D and K_h are multiples of K, so the modes of (K, M) diagonalise them whatever M is (q2
        with a sensor mass): there one eigen-solve and one modal sum cost less than the ``low_rank``
        form's four sums and Woodbury algebra, so the ``diagonal`` form is kept."""
        return all(a is None or not np.any(a) or _multiple(a, self.K) for a in (self.D, self.K_h))

    @cached_property
    def _low_rank(self) -> LowRankSplit | None:
        """The split in the undamped modes of (K, M) (S_M = S_K = 0), or None (see :meth:`_split`)."""
        if not self._admits_low_rank:
            return None
        return self._split(*self.undamped, None, None, self.modal_damping,
                           None if self.relaxation is None else self._modal_memory)

    @cached_property
    def _reference_split(self) -> LowRankSplit | None:
        """The split in the :attr:`reference` modes: S_M = W^T (M - M_r) W and S_K = W^T (K - K_r) W,
        or None when there is no reference or M and K depart from it outside the span of W."""
        ref, w = self.reference, self.departures
        if ref is None or not self._admits_low_rank:
            return None
        s_m, s_k = (_departure(a, a_r, w) for a, a_r in ((self.M, ref.mass), (self.K, ref.stiffness)))
        if s_m is None or s_k is None:
            return None
        s_m, s_k = (s if np.any(s) else None for s in (s_m, s_k))     # None: the term is skipped
        return self._split(ref.lam, ref.phi, s_m, s_k, ref.phi.T @ self.D @ ref.phi,
                           None if self.relaxation is None else ref.phi.T @ self.K_h @ ref.phi)

    @cached_property
    def _in_reference_modes(self) -> bool:
        """Does the ``low_rank`` form work in the :attr:`reference`'s modes (no eigen-solve)? Not
        where the ``diagonal`` form is possible whatever M is (see :attr:`_proportional_to_stiffness`)."""
        return self.reference is not None and not self._proportional_to_stiffness and self._reference_split is not None

    @property
    def _modal_split(self) -> LowRankSplit | None:
        """The split the ``low_rank`` form and its poles use: in the reference's modes or in those of
        (K, M)."""
        return self._reference_split if self._in_reference_modes else self._low_rank

    @cached_property
    def _admits_low_rank(self) -> bool:
        """Departures are given within the rank the form takes: :data:`LOW_RANK_MAX`, or rank 1
        without memory (there the complex modes cost less than the rank-2 algebra, 5 against
        9-12 ms on the aluminium strip's tip body)."""
        w = self.departures
        return w is not None and 0 < w.shape[1] <= (LOW_RANK_MAX if self.relaxation is not None else 1)

    def _split(self, lam, phi, s_m, s_k, modal_damping, modal_memory) -> LowRankSplit | None:
        """V = Phi^T W, S_D and S_H with Phi^T D Phi - V S_D V^T = diag(d), Phi^T K_h Phi - V S_H V^T
        = diag(h) (S_H, h zero without memory; ``modal_damping``, ``modal_memory`` = Phi^T D Phi,
        Phi^T K_h Phi); None when they are not both diagonal plus rank r along V."""
        v = phi.T @ self.departures
        damping = _diagonal_plus_low_rank(modal_damping, v)
        if damping is None:
            return None
        memory = ((np.zeros_like(damping[0]), np.zeros(self.size)) if modal_memory is None
                  else _diagonal_plus_low_rank(modal_memory, v))
        return None if memory is None else LowRankSplit(lam, phi, v, s_m, s_k, *damping, *memory)

    @cached_property
    def _band(self) -> BandOrder | None:
        """The order in which M, D, K and K_h together have a half-bandwidth of at most
        :data:`BAND_MAX`: the given one, else reverse Cuthill-McKee's (a root
        slope numbered last couples to the first splines); None when neither has, or a matrix is
        not symmetric (the elimination relies on Z = L diag(d) L^T)."""
        mats = [a for a in (self.M, self.D, self.K, self.K_h) if a is not None]
        if any(np.max(np.abs(a - a.T), initial=0.0) > 1e-13 * np.max(np.abs(a), initial=0.0) for a in mats):
            return None
        pattern = sum(np.abs(a) for a in mats) > 0
        for perm in (np.arange(self.size), None):
            if perm is None:
                perm = reverse_cuthill_mckee(csr_matrix(pattern), symmetric_mode=True).astype(int)
            i, j = np.nonzero(pattern[np.ix_(perm, perm)])
            width = int(np.max(np.abs(i - j), initial=0))
            if width <= BAND_MAX:
                return BandOrder(perm, width)
        return None

    def static_stiffness(self) -> np.ndarray:
        """Stiffness at equilibrium, K - G(0) K_h (N/m in generalised coordinates)."""
        if self.relaxation is None:
            return self.K
        return self.K - np.real(self.relaxation(np.array([0.0])))[0] * self.K_h

    def check_stable(self) -> None:
        """Raise ValueError if the relaxed stiffness is not finite and positive definite."""
        with np.errstate(invalid="ignore"):
            static = self.static_stiffness()
        if not np.all(np.isfinite(static)):
            # numpy's Cholesky returns NaN rather than raising on a NaN matrix
            raise ValueError("the memory kernel's static relaxation G(0) is not finite: "
                             "beta must be > 0 when the history r is infinite")
        try:
            np.linalg.cholesky(static)
        except np.linalg.LinAlgError:
            raise ValueError(
                "the relaxed (static) stiffness is not positive definite: the memory term "
                "removes more stiffness than EI provides"
            ) from None

    # ----------------------------------------------------------------- transfer functions
    def transfer(self, s: np.ndarray, C: np.ndarray, B: np.ndarray) -> np.ndarray:
        """C Z(s)^-1 B for every s: array (len(s), n_out, n_in) (m/N for displacement rows)."""
        s = np.asarray(s, dtype=complex).ravel()
        shape = (s.size, C.shape[0], B.shape[1])
        if self.form == "dense":
            return self._transfer_dense(s, C, B)
        if self.form == "banded":
            return self._transfer_banded(s, C, B)
        if self.form == "low_rank":
            return self._transfer_low_rank(s, C, B)
        sections = self._diagonal_sections if self.form == "diagonal" else self._complex_sections
        den, beta, alpha = sections(C, B)
        g = None if self.relaxation is None else self.relaxation(s)
        return _sum_sections(s, den, beta, alpha, g).reshape(shape)

    def _diagonal_sections(self, C: np.ndarray, B: np.ndarray):
        """Per undamped mode m: den [1, c_m, omega_m^2] (and h_m), numerator (C phi_m)(phi_m^T B)."""
        lam, phi = self.undamped
        cphi, phib = C @ phi, phi.T @ B
        beta = (cphi.T[:, :, None] * phib[:, None, :]).reshape(self.size, -1)
        den = [np.ones(self.size), np.diag(self.modal_damping), lam]
        if self.relaxation is not None:
            den.append(np.diag(self._modal_memory))
        return np.stack(den, axis=1), beta, None

    def _complex_sections(self, C: np.ndarray, B: np.ndarray):
        r"""The complex modes as real sections: conjugate pairs folded, real poles first-order.

        .. math:: \frac{R}{s-p} + \frac{\bar R}{s-\bar p}
                  = \frac{2\,\mathrm{Re}R\; s - 2\,\mathrm{Re}(R\bar p)}{s^2 - 2\,\mathrm{Re}p\; s + |p|^2},

        and a real pole q is the section R/(0 s^2 + 1 s - q).
        """
        poles = self._modal_state_modes[0]
        tiny = 1e-12 * np.abs(poles)
        upper, real = poles.imag > tiny, np.abs(poles.imag) <= tiny
        kept, res = self._residues(upper | real, C, B)
        pair = upper[upper | real]
        p, r, q, rq = kept[pair], res[pair], kept[~pair].real, res[~pair].real
        den = np.vstack([np.stack([np.ones(p.size), -2 * p.real, np.abs(p) ** 2], axis=1),
                         np.stack([np.zeros(q.size), np.ones(q.size), -q], axis=1)])
        beta = np.vstack([-2 * (r * p.conj()[:, None]).real, rq])
        alpha = np.vstack([2 * r.real, np.zeros_like(rq)])
        return den, beta, alpha

    def _residues(self, keep: np.ndarray, C: np.ndarray, B: np.ndarray):
        r"""The poles selected by ``keep`` and the residues there of C Z(s)^-1 B, (k, n_out n_in).

        For symmetric M, D, K (Galerkin forms) and simple poles, with mode shapes w_j,

        .. math:: Z(s)^{-1} = \sum_j \frac{w_j w_j^T}{(s - p_j)\, w_j^T (2 p_j M + D)\, w_j},

        evaluated in the undamped modal coordinates (M = I, D = D_m): the eigenvectors serve as
        left and right ones, and no inverse of the eigenvector matrix is needed.
        """
        poles, vec = self._modal_state_modes
        p, u = poles[keep], vec[: self.size, keep]
        norm = 2 * p * np.einsum("ij,ij->j", u, u) + np.einsum("ij,ij->j", u, self.modal_damping @ u)
        phi = self.undamped[1]
        left, right = (C @ phi) @ u, (u.T @ (phi.T @ B)) / norm[:, None]
        return p, (left.T[:, :, None] * right[:, None, :]).reshape(p.size, -1)

    def _transfer_dense(self, s: np.ndarray, C: np.ndarray, B: np.ndarray) -> np.ndarray:
        """A batched solve per frequency in the undamped modal coordinates."""
        phi = self.undamped[1]
        cphi, phib = C @ phi, phi.T @ B
        z = self._modal_dynamic_stiffness(s)
        return np.einsum("om,fmi->foi", cphi, np.linalg.solve(z, np.broadcast_to(phib, (s.size,) + phib.shape)))

    def _transfer_banded(self, s: np.ndarray, C: np.ndarray, B: np.ndarray) -> np.ndarray:
        r"""C Z(s)^-1 B by a band elimination of Z(s) = L(s) diag(d(s)) L(s)^T per frequency.

        Z is complex symmetric (Galerkin forms), so

        .. math:: C Z^{-1} B = (L^{-1} C^T)^T\, \mathrm{diag}(d)^{-1} (L^{-1} B)
                  = \sum_k \frac{\tilde c_k \tilde b_k^T}{d_k} :

        one forward elimination carries the rows of C and the columns of B along, and no back
        substitution is needed. Without pivoting: on the grid s = sigma + i omega (sigma > 0,
        omega >= 0), Im Z = 2 sigma omega M + omega D - Im G(s) K_h is positive definite for
        omega > 0 (M > 0, D >= 0, K_h >= 0, and -Im G >= 0 for a positive kernel that decreases,
        truncated or not: its sine transform is a sum of alternating, shrinking lobes), and
        at omega = 0 Z is real and positive definite (as the relaxed stiffness is), so every
        leading block is nonsingular and no pivot d_k vanishes. Accuracy: against 30-digit solves
        at the resonance peaks (tests/response/test_system.py).

        Vectorised over the frequencies: per pivot, a few array operations on the lower triangle
        of the b x b window it updates, O(n b^2) per frequency; blocks of :data:`_BAND_BLOCK`
        frequencies bound the memory.
        """
        perm, b = self._band
        n = self.size
        terms = [(self.M, s * s), (self.D, s), (self.K, np.ones_like(s))]
        if self.relaxation is not None:
            terms.append((self.K_h, -self.relaxation(s)))
        terms = [(a, c) for a, c in terms if np.any(a)]
        # the band's orientation that starts the outputs' and inputs' elimination latest
        perm = max((perm, perm[::-1]), key=lambda p: sum(_first_nonzero(x) for x in (C[:, p].T, B[p])))
        band = np.stack([_lower_band(a[np.ix_(perm, perm)], b) for a, _ in terms], axis=-1).reshape(-1, len(terms))
        coef = np.array([c for _, c in terms])
        out = np.empty((s.size, C.shape[0], B.shape[1]), dtype=complex)
        edges = np.linspace(0, s.size, -(-s.size // _BAND_BLOCK) + 1).astype(int)
        shapes = [((n + b) * (b + 1),), (n + b, C.shape[0]), (n + b, B.shape[1])]
        work = _scratch(2 * int(np.max(np.diff(edges))) * sum(int(np.prod(x)) for x in shapes))
        rows_in, cols_in = C[:, perm].T[:, :, None], B[perm][:, :, None]
        for lo, hi in itertools.pairwise(edges):
            z, rows, cols = _complex_parts(work, [x + (hi - lo,) for x in shapes])
            # real band times complex coefficients: one real product on the interleaved parts
            np.matmul(band, coef[:, lo:hi].copy().view(float), out=z[:n * (b + 1)].view(float))
            z[n * (b + 1):] = 0.0
            rows[n:], cols[n:] = 0.0, 0.0
            rows[:n], cols[:n] = rows_in, cols_in
            out[lo:hi] = _eliminate(z, rows, cols, b).transpose(2, 0, 1)
        return out

    def _transfer_low_rank(self, s: np.ndarray, C: np.ndarray, B: np.ndarray) -> np.ndarray:
        r"""The diagonal form plus a rank-r Woodbury correction, in modal coordinates.

        In modes Phi with :math:`\Phi^T M \Phi = I + V S_M V^T`, :math:`\Phi^T K \Phi =
        \mathrm{diag}(\lambda) + V S_K V^T`, :math:`\Phi^T D \Phi = \mathrm{diag}(d) + V S_D V^T`
        and :math:`\Phi^T K_h \Phi = \mathrm{diag}(h) + V S_H V^T` (:attr:`_reference_split` in a
        cached reference's modes, else :attr:`_low_rank` in those of (K, M), where S_M = S_K = 0),

        .. math:: Z(s) = Z_0(s) + V T(s) V^T, \quad Z_0 = \mathrm{diag}\big(s^2 + s\,d_m
                  + \lambda_m - \hat G(s)\, h_m\big), \quad T = s^2 S_M + s\,S_D + S_K - \hat G(s)\, S_H,

        .. math:: C Z^{-1} B = C Z_0^{-1} B - (C Z_0^{-1} V)\, T\, (I + V^T Z_0^{-1} V\, T)^{-1}
                  (V^T Z_0^{-1} B) .

        T stands on the right of the small solve so that it is never inverted (in the modes of
        (K, M) it vanishes with the damping and the memory). The four modal sums are real sections of the diagonal form
        (:func:`_sum_sections`); the r x r algebra per frequency is written out (r <= 2: numpy's
        batched solve of 8000 tiny systems costs milliseconds).
        """
        split = self._modal_split
        lam, phi, v, d, h = split.lam, split.phi, split.v, split.d, split.h
        cphi, phib = C @ phi, phi.T @ B
        g = None if self.relaxation is None else self.relaxation(s)
        den = np.stack([np.ones(self.size), d, lam] + ([] if g is None else [h]), axis=1)
        pairs = [(cphi.T, phib), (cphi.T, v), (v, phib), (v, v)]
        beta = np.hstack([(left[:, :, None] * right[:, None, :]).reshape(self.size, -1) for left, right in pairs])
        parts = np.split(_sum_sections(s, den, beta, None, g),
                         np.cumsum([a.shape[1] * b.shape[1] for a, b in pairs])[:-1], axis=1)
        h, p, q, rr = (x.reshape(s.size, a.shape[1], b.shape[1]) for x, (a, b) in zip(parts, pairs))
        if v.shape[1] == 1:                 # scalars per frequency: h - p q t / (1 + rr t)
            t = split.coupling(s, g)[:, 0, 0]
            t /= 1.0 + rr[:, 0, 0] * t
            return h - (p * t[:, None, None]) * q
        t = split.coupling(s, g)
        capacitance = _small_product(rr, t)
        capacitance[:, np.arange(v.shape[1]), np.arange(v.shape[1])] += 1.0
        return h - _small_product(p, _small_product(t, _small_solve(capacitance, q)))

    def _modal_dynamic_stiffness(self, s: np.ndarray) -> np.ndarray:
        """Z(s) in undamped modal coordinates, s^2 I + s D_m + diag(omega^2) - G(s) K_h,m: (len(s), n, n)."""
        return self._modal_stack(s[:, None] ** 2 + self.undamped[0], s, self.relaxation(s))

    def _modal_stack(self, diagonal: np.ndarray, c_d: np.ndarray, c_h: np.ndarray) -> np.ndarray:
        """diag(diagonal_k) + c_d,k D_m - c_h,k K_h,m for every k: (k, n, n), in two passes over the
        stack (one without damping) where the sum of broadcast terms took five."""
        out = -c_h[:, None, None] * self._modal_memory
        if np.any(self.modal_damping):
            out += c_d[:, None, None] * self.modal_damping
        idx = np.arange(self.size)
        out[:, idx, idx] += diagonal
        return out

    @cached_property
    def _modal_state_modes(self) -> tuple[np.ndarray, np.ndarray]:
        """Eigenpairs of the first-order form in undamped modal coordinates x = [q; q'], w = Phi q.

        q'' + D_m q' + diag(omega^2) q = Phi^T B f: the same poles, and no solve with M.
        """
        n = self.size
        a = np.block([[np.zeros((n, n)), np.eye(n)], [-np.diag(self.undamped[0]), -self.modal_damping]])
        return np.linalg.eig(a)

    @cached_property
    def state_modes(self) -> tuple[np.ndarray, np.ndarray]:
        """Eigenvalues and eigenvectors [w; w'] of the first-order state matrix (no memory term)."""
        poles, vec = self._modal_state_modes
        phi, n = self.undamped[1], self.size
        return poles, np.vstack([phi @ vec[:n], phi @ vec[n:]])

    # ----------------------------------------------------------------- poles
    def poles(self, below: float | None = None) -> np.ndarray:
        """Oscillatory poles p = -zeta w + i w sqrt(1-zeta^2), Im p > 0, sorted by |p| (rad/s);
        with ``below`` (rad/s) only those with |p| < below.

        With a memory term the poles are roots of det Z(s) = 0 near each undamped mode: by
        Newton's method on each modal denominator (diagonal form), on the secular function of the
        ``low_rank`` form (:meth:`_poles_secular`, in the reference's modes when there is one: no
        eigen-solve) or on the Rayleigh functional (the other forms,
        :meth:`_poles_rayleigh`); with ``below`` only for the modes that can reach it (see
        :meth:`_tracked_modes`).
        """
        if self.relaxation is None:
            p = self.state_modes[0]
        elif not self._in_reference_modes and self._diagonal:
            p = self._poles_diagonal()
        else:
            p = self._poles_with_memory(self._tracked_modes(below))
            if below is not None and p.size < self.size and np.max(np.abs(p), initial=0.0) < below:
                p = self._poles_with_memory(self.size)  # the margin is not shown: follow every mode
        p = p[(p.imag > 0) & (np.abs(p) < (np.inf if below is None else below))]
        return p[np.argsort(np.abs(p))]

    def dynamic_stiffness(self, s: np.ndarray) -> np.ndarray:
        """Z(s) = s^2 M + s D + K - G(s) K_h for every s: (len(s), n, n) (N/m)."""
        s = np.asarray(s, dtype=complex)[:, None, None]
        z = s * s * self.M + s * self.D + self.K
        return z if self.relaxation is None else z - self.relaxation(s[:, 0, 0])[:, None, None] * self.K_h

    def mode_shapes(self, poles: np.ndarray) -> np.ndarray:
        """The right null vector of Z(p) for every pole p, scaled to unit largest entry: (n, len(poles)).

        One step of inverse iteration, Z(p) x = b for a fixed b with no symmetry: at a pole
        accurate to rounding, Z(p) is singular to rounding and x its null vector to the same
        accuracy, for an LU solve instead of an SVD (a tenth of the cost). An SVD where the solve
        fails (an exactly zero pivot) or leaves a residual above 1e-8 |Z| |x|.
        """
        z = self.dynamic_stiffness(poles)
        b = np.cos(1.3 * np.arange(self.size) + 0.7)
        try:
            x = np.linalg.solve(z, np.broadcast_to(b, (len(poles), self.size))[:, :, None])[:, :, 0]
        except np.linalg.LinAlgError:
            x = np.full((len(poles), self.size), np.nan, dtype=complex)
        for k in range(len(poles)):
            residual = np.linalg.norm(z[k] @ x[k]) if np.all(np.isfinite(x[k])) else np.inf
            if not residual <= 1e-8 * np.linalg.norm(z[k]) * np.linalg.norm(x[k]):
                x[k] = np.linalg.svd(z[k])[2][-1].conj()
        x /= x[np.arange(len(poles)), np.argmax(np.abs(x), axis=1)][:, None]
        return x.T

    def _tracked_modes(self, below: float | None) -> int:
        """How many of the lowest undamped modes to follow for the poles under ``below``: those with
        omega_m < 2 below. A pole lies within its mode's softening of omega_m, and the softening by a
        memory (|G| falls with frequency) or a compressive load (P k^2 against EI k^4) shrinks up the
        spectrum, so :meth:`poles` checks the highest followed pole: above ``below``, no higher mode,
        softened less, can fall under it; else every mode is followed."""
        if below is None:
            return self.size
        split = self._modal_split
        lam = self.undamped[0] if split is None else split.lam
        return int(np.count_nonzero(lam < (2.0 * below) ** 2))

    def _relaxation_slope(self, s: np.ndarray) -> np.ndarray:
        """G'(s) by a central difference (relative step 1e-7): the pole iterations' derivative, which
        sets their convergence, not the root they converge to."""
        ds = 1e-7 * np.abs(s)
        return (self.relaxation(s + ds) - self.relaxation(s - ds)) / (2 * ds)

    def _poles_diagonal(self) -> np.ndarray:
        """Newton's method on each modal denominator; the modes whose iteration converged
        (:func:`_converged`)."""
        lam = self.undamped[0]
        d_m, kh_m = np.diag(self.modal_damping), np.diag(self._modal_memory)
        s = 1j * np.sqrt(lam.astype(complex))
        for _ in range(60):
            g = self.relaxation(s)
            dg = self._relaxation_slope(s)
            f = s**2 + s * d_m + lam - g * kh_m
            step = f / (2 * s + d_m - dg * kh_m)
            s = s - step
            if np.all(np.abs(step) <= 1e-13 * np.abs(s)):
                break
        return s[_converged(step, s)]

    def _poles_with_memory(self, count: int) -> np.ndarray:
        """The poles of the ``count`` lowest modes of a non-diagonal memory model."""
        p = None if self._modal_split is None else self._poles_secular(count)
        return self._poles_rayleigh(count) if p is None else p

    def _poles_secular(self, count: int) -> np.ndarray | None:
        r"""The poles of the ``count`` lowest modes of the ``low_rank`` form by Newton's method on
        its secular function: O(n r^2) per mode and step where the Rayleigh iteration solves n x n.

        With :math:`Z = \mathrm{diag}(z) + V T V^T` (:meth:`_transfer_low_rank`),
        :math:`\det Z = \prod_k z_k \det(I + T R)`, :math:`R = \sum_k v_k v_k^T / z_k`. Mode m's
        term makes :math:`\det(I + T R)` blow up at the root of :math:`z_m`; removed by the matrix
        determinant lemma, with :math:`A = I + T R_{-m}` (R without mode m),

        .. math:: g_m(s) = z_m \det(I + T R) = z_m \det A + v_m^T \mathrm{adj}(A)\, T\, v_m ,

        analytic near :math:`i\omega_m`, where Newton's method starts; :math:`g_m = \det Z /
        \prod_{k \ne m} z_k`, so its roots are roots of det Z. :math:`g_m'` analytically from
        z', T' and R' (G'(s) by :meth:`_relaxation_slope`). None
        when an iteration has not converged in 60 steps or two modes reach one root: then
        :meth:`poles` takes the Rayleigh iteration.
        """
        split = self._modal_split
        lam, v, d, h = split.lam, split.v, split.d, split.h
        r, modes = v.shape[1], np.arange(count)
        outer = (v[:, :, None] * v[:, None, :]).reshape(self.size, r * r)

        def newton_step(s):
            """g_m(s) / g_m'(s) for every followed mode m."""
            g = self.relaxation(s)
            dg = self._relaxation_slope(s)
            z = s[:, None] ** 2 + s[:, None] * d + lam - g[:, None] * h
            dz = 2 * s[:, None] + d - dg[:, None] * h
            t, dt = split.coupling_and_slope(s, g, dg)
            inv = 1.0 / z
            inv[modes, modes] = 0.0                                       # R without mode m
            rr, drr = ((w @ outer).reshape(count, r, r) for w in (inv, -inv * inv * dz))
            a = np.eye(r) + t @ rr
            det, ddet, adj, dadj = _det_adj(a, dt @ rr + t @ drr)
            vm = v[:count, :, None]
            q = (vm.transpose(0, 2, 1) @ adj @ t @ vm)[:, 0, 0]
            dq = (vm.transpose(0, 2, 1) @ (dadj @ t + adj @ dt) @ vm)[:, 0, 0]
            zm, dzm = z[modes, modes], dz[modes, modes]
            return (zm * det + q) / (dzm * det + zm * ddet + dq)

        s = 1j * np.sqrt(lam[:count].astype(complex))
        for _ in range(60):
            step = newton_step(s)
            s = s - step
            if np.all(np.abs(step) <= 1e-13 * np.abs(s)):
                ordered = np.sort_complex(s)
                return s if np.all(np.abs(np.diff(ordered)) > 1e-8 * np.abs(ordered[1:])) else None
        return None

    def _poles_rayleigh(self, count: int) -> np.ndarray:
        r"""The poles of the ``count`` lowest modes by Rayleigh functional iteration, all at once.

        In undamped modal coordinates, from :math:`s = i\omega_m`, :math:`x = e_m`:

        .. math:: x \leftarrow Z(s)^{-1} Z'(s)\, x, \qquad
                  s \leftarrow s - \frac{x^T Z(s)\, x}{x^T Z'(s)\, x},

        inverse iteration for the mode shape and a Newton step on :math:`x^T Z(s) x = 0`
        (transposes, not conjugates: Z is complex symmetric, so x serves as left and right
        vector and the iteration converges cubically). The fixed point is a root of det Z:
        Z(s) x = 0. G'(s) by :meth:`_relaxation_slope`. Only the modes whose iteration converged
        are returned (:func:`_converged`).
        """
        lam = self.undamped[0][:count]
        s = 1j * np.sqrt(lam.astype(complex))
        x = np.eye(self.size, dtype=complex)[:count, :, None]    # mode m's shape, a column
        for _ in range(60):
            dg = self._relaxation_slope(s)
            z = self._modal_dynamic_stiffness(s)
            dz = self._modal_stack(np.broadcast_to(2 * s[:, None], (count, self.size)), np.ones(count), dg)
            try:
                x = np.linalg.solve(z, dz @ x)
            except np.linalg.LinAlgError:                        # Z(s) singular: s is a root
                break
            x /= np.linalg.norm(x, axis=1)[:, None]
            xt = x.transpose(0, 2, 1)
            step = (xt @ z @ x)[:, 0, 0] / (xt @ dz @ x)[:, 0, 0]
            s = s - step
            if np.all(np.abs(step) <= 1e-13 * np.abs(s)):
                break
        else:
            return s[_converged(step, s)]
        return s


def _converged(step: np.ndarray, s: np.ndarray) -> np.ndarray:
    """Which pole iterations converged: a last Newton step below 1e-8 of the pole.

    A mode under a memory term whose loss factor exceeds 1 (fractional damping with c_f omega^nu
    several times EI) has no pole near its undamped frequency: its root, if any, lies far off
    (for s^2 + omega^2 (1 + c s^nu) = 0 with c omega^nu >> 1, at |s| ~ (c omega^2)^(1/(2 - nu)),
    several times omega, decaying within a few periods), and the iteration from i omega wanders
    without converging, even into the right half-plane, where a passive model has no pole. Such
    a mode is left out rather than reported at a point that solves nothing: a free decay's
    basis must hold only solutions of the model."""
    return np.abs(step) <= 1e-8 * np.abs(s)


def undamped_modes(K: np.ndarray, M: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    r"""Eigenpairs (omega^2, Phi) of :math:`K\varphi = \omega^2 M\varphi`, Phi mass-normalised.

    LAPACK's eigenvalues carry absolute errors of order :math:`\epsilon\,\omega_{max}^2`,
    1e-8 relative on the first mode at N = 32, and a resonance amplifies that by
    :math:`1/(2\zeta)` in H. The Rayleigh quotients :math:`\varphi^T K\varphi / \varphi^T M\varphi`
    of the computed vectors err only to second order in the vectors' error. Against 40-digit
    solves of Z(s) on the example recording (q1, q2 and q3, resonance peaks included), the
    transfer function's max |H - H_exact| / max |H| is 6e-11 instead of 2e-9 to 4e-8 at N = 32,
    and 4e-13 instead of 4e-12 to 3e-11 at N = 16.
    """
    # LAPACK's dsygv directly: scipy.linalg.eigh's argument checks and dispatch cost 30 us, a third
    # of the call at N = 16 (paid on every likelihood call by a model whose effects change M or K)
    _, phi, info = lapack.dsygv(K, M)
    if info != 0:
        raise np.linalg.LinAlgError(f"generalised eigenproblem K phi = w^2 M phi failed (LAPACK dsygv info {info}): "
                                    "M must be positive definite")
    lam = np.einsum("ij,ij->j", phi, K @ phi) / np.einsum("ij,ij->j", phi, M @ phi)
    return lam, phi


def _small_product(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a @ b for stacks (k, m, r) and (k, r, c) with small r, as r broadcast products (numpy's
    batched matmul of tiny matrices is slower)."""
    return sum(a[:, :, j, None] * b[:, None, j, :] for j in range(a.shape[2]))


def _small_solve(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Solve the stack of (k, 2, 2) systems a x = b by Cramer's rule (rank one never gets here:
    :meth:`SecondOrderSystem._transfer_low_rank` divides by scalars)."""
    det = a[:, 0, 0] * a[:, 1, 1] - a[:, 0, 1] * a[:, 1, 0]
    x0 = (a[:, 1, 1, None] * b[:, 0] - a[:, 0, 1, None] * b[:, 1]) / det[:, None]
    x1 = (a[:, 0, 0, None] * b[:, 1] - a[:, 1, 0, None] * b[:, 0]) / det[:, None]
    return np.stack([x0, x1], axis=1)


def _det_adj(a: np.ndarray, da: np.ndarray):
    """Determinant and adjugate of a stack of (k, r, r) matrices, r <= 2, and their derivatives
    along ``da``: (det, det', adj, adj'). For r = 2 the adjugate is linear: adj' = adj(da)."""
    if a.shape[1] == 1:
        return a[:, 0, 0], da[:, 0, 0], np.ones_like(a), np.zeros_like(a)

    def adj(x):                                   # [[d, -b], [-c, a]] of [[a, b], [c, d]]
        return x[:, ::-1, ::-1].transpose(0, 2, 1) * np.array([[1.0, -1.0], [-1.0, 1.0]])

    det = a[:, 0, 0] * a[:, 1, 1] - a[:, 0, 1] * a[:, 1, 0]
    ddet = da[:, 0, 0] * a[:, 1, 1] + a[:, 0, 0] * da[:, 1, 1] - da[:, 0, 1] * a[:, 1, 0] - a[:, 0, 1] * da[:, 1, 0]
    return det, ddet, adj(a), adj(da)


def _diagonal_plus_low_rank(a: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
    r"""(S, d): symmetric S (r, r) with a - v S v^T = diag(d) (to the tolerance of :func:`_is_diagonal`),
    or None.

    S minimises :math:`\sum_{i\ne j} (a_{ij} - v_i^T S v_j)^2` (rows :math:`v_i` of v), whose
    normal equations :math:`G S G - \sum_i w_i S w_i = V^T A_{off} V` (:math:`G = V^T V`,
    :math:`w_i = v_i v_i^T`) are, row-major, the r^2 x r^2 system
    :math:`(G \otimes G - U^T U)\,\mathrm{vec}\,S = \mathrm{vec}(V^T A_{off} V)` with rows
    :math:`v_i \otimes v_i` of U: O(n^2 r) work, no n^2-row least squares.
    """
    n, r = v.shape
    off = _off_diagonal(a)
    if not np.any(off):                 # already diagonal (no damping, say): S = 0
        return np.zeros((r, r)), a.diagonal().copy()
    g = v.T @ v
    if r == 1:                          # the scalar normal equation (numpy's solve costs 20 us)
        s = (v.T @ off @ v) / (g * g - np.sum(v**4))
    else:
        u = (v[:, :, None] * v[:, None, :]).reshape(n, r * r)
        kron = (g[:, None, :, None] * g[None, :, None, :]).reshape(r * r, r * r)     # G (x) G
        s = np.linalg.solve(kron - u.T @ u, (v.T @ off @ v).ravel()).reshape(r, r)
        s = 0.5 * (s + s.T)
    rest = a - v @ s @ v.T
    # a matrix wholly along v (a root dashpot's damping) leaves only rounding: a zero diagonal
    negligible = np.max(np.abs(rest)) <= _DIAGONAL_TOL * np.max(np.abs(a))
    return (s, rest.diagonal().copy()) if negligible or _is_diagonal(rest) else None


def _multiple(a: np.ndarray, b: np.ndarray) -> bool:
    """Is a = c b for a scalar c (to 1e-12 of max |a|)?"""
    k = np.abs(b).argmax()
    return bool(np.abs(a - (a.flat[k] / b.flat[k]) * b).max() <= 1e-12 * np.abs(a).max())


def _departure(a: np.ndarray, a_r: np.ndarray, w: np.ndarray) -> np.ndarray | None:
    """S = W^T (a - a_r) W when a - a_r = W S W^T (W orthonormal) to 1e-10 of max |a|, else None."""
    diff = a - a_r
    s = w.T @ diff @ w
    return s if np.max(np.abs(diff - w @ s @ w.T)) <= 1e-10 * np.max(np.abs(a)) else None


def _off_diagonal(a: np.ndarray) -> np.ndarray:
    off = a.copy()
    np.fill_diagonal(off, 0.0)
    return off


def _is_diagonal(a: np.ndarray) -> bool:
    scale = np.max(np.abs(a.diagonal()), initial=0.0)
    return bool(np.max(np.abs(_off_diagonal(a)), initial=0.0) <= _DIAGONAL_TOL * max(scale, np.finfo(float).tiny))


def _lower_band(a: np.ndarray, b: int) -> np.ndarray:
    """Lower band storage (n, b + 1) of a symmetric a: [i, o] holds a[i, i - o] (zero outside a)."""
    n = a.shape[0]
    cols = np.arange(n)[:, None] - np.arange(b + 1)[None, :]
    return np.where(cols >= 0, a[np.arange(n)[:, None], np.clip(cols, 0, None)], 0.0)


def _first_nonzero(a: np.ndarray) -> int:
    """Index of the first row of ``a`` (n, k) with a nonzero entry (n if none)."""
    nonzero = np.flatnonzero(np.any(a != 0, axis=1))
    return int(nonzero[0]) if nonzero.size else a.shape[0]


def _eliminate(z: np.ndarray, rows: np.ndarray, cols: np.ndarray, b: int) -> np.ndarray:
    """sum_k rows_k cols_k^T / d_k over the symmetric elimination of ``z``: (n_out, n_in, f).

    ``z`` ((n + b) (b + 1), f): the lower band storage of Z, row i (b + 1) + o holding
    Z[i, i - o] per frequency, with b rows of padding so that every pivot's window stays inside
    the array (they stay zero: so do their multipliers). ``rows`` (n + b, n_out, f) and ``cols``
    (n + b, n_in, f): C^T and B, eliminated in place, each from its first nonzero entry on
    (before it the elimination leaves zeros zero: a tip sensor's rows cost nothing until the
    tip). In this storage every set of entries the elimination touches together is a strided
    slice of z's rows.
    """
    n, f, w = rows.shape[0] - b, z.shape[1], b + 1
    starts = [_first_nonzero(y[:n, :, 0]) for y in (rows, cols)]
    acc = np.zeros((rows.shape[1], cols.shape[1], f), dtype=complex)
    inv, mult, update = np.empty(f, dtype=complex), np.empty((b, f), dtype=complex), np.empty((b, f), dtype=complex)
    carried = np.empty((b, max(rows.shape[1], cols.shape[1]), f), dtype=complex)
    term = np.empty(acc.shape, dtype=complex)
    for k in range(n):
        top = k * w
        column = z[top + w + 1:top + w * w + 1:w + 1]            # Z[k+q, k], q = 1..b (= Z[k, k+q])
        np.divide(1.0, z[top], out=inv)
        np.multiply(column, inv, out=mult)                        # L[k+q, k]
        for d in range(b):                                        # Z[k+q, k+q-d] -= L[k+q, k] Z[k, k+q-d]
            part = update[:b - d]
            np.multiply(mult[d:], column[:b - d], out=part)
            z[top + (d + 1) * w + d:top + w * w + d:w] -= part
        for y, start in zip((rows, cols), starts):
            if k >= start:
                part = carried[:, :y.shape[1]]
                np.multiply(mult[:, None], y[k][None], out=part)
                y[k + 1:k + 1 + b] -= part
        if k >= max(starts):
            np.multiply(rows[k][:, None], cols[k][None], out=term)
            term *= inv
            acc += term
    return acc


def _sum_sections(s: np.ndarray, den: np.ndarray, beta: np.ndarray, alpha: np.ndarray | None,
                  g: np.ndarray | None) -> np.ndarray:
    r"""Sum of real sections for every s: array (len(s), r).

    .. math:: H(s) = \sum_m \frac{\alpha_m s + \beta_m}{d_m(s)}, \qquad
              d_m(s) = e_m s^2 + c_m s + k_m - h_m G(s),

    ``den`` rows [e, c, k] (and h with a memory transform ``g`` = G(s)), ``beta`` and ``alpha``
    (n_sections, r) (``alpha`` None for zero). With a = Re d and b = -Im d, small products of
    the section coefficients and per-frequency rows ([Re s^2, Re s, 1, -Re G] and
    [Im s^2, Im s, -Im G]), :math:`1/d = (a + i b)/(a^2 + b^2)`: real arithmetic only, in fewer
    passes over the (section, frequency) arrays than numpy's complex division. Without ``alpha``
    the numerator products write the real and imaginary parts of H in place; with it see
    :func:`_with_alpha`.
    """
    re_rows, im_rows, den_im = _section_rows(s, den, g)
    r, m = beta.shape[1], den.shape[0]
    num = beta if alpha is None else np.hstack([beta, alpha])
    out = np.empty((s.size, r), dtype=complex)
    parts = out.view(float).reshape(s.size, r, 2)
    step = max(1, _BLOCK // m)
    work = _scratch(4 * m * step + (0 if alpha is None else 4 * r * step))
    for i in range(0, s.size, step):
        blk = slice(i, i + step)
        n = min(step, s.size - i)
        a, b, t, u = (work[k * m * n:(k + 1) * m * n].reshape(m, n) for k in range(4))
        np.matmul(den, re_rows[:, blk], out=a)
        np.matmul(den_im, im_rows[:, blk], out=b)
        np.square(a, out=t)
        np.square(b, out=u)
        t += u
        np.reciprocal(t, out=t)
        a *= t
        b *= t
        if alpha is None:
            np.matmul(a.T, num, out=parts[blk, :, 0])
            np.matmul(b.T, num, out=parts[blk, :, 1])
        else:
            _with_alpha(parts[blk], a, b, num, s[blk], work[4 * m * step:4 * m * step + 4 * r * n].reshape(2, n, 2 * r))
    return out


def _with_alpha(parts, a, b, num, s, scratch) -> None:
    """H = (a + i b)^T (beta + s alpha) for one block, written into ``parts`` (re, im).

    The products go to contiguous scratch first: written straight into the interleaved real and
    imaginary parts of H, the matmuls run with strided output and the q3 sum took 25 % longer.
    """
    r = num.shape[1] // 2
    re, im = scratch
    np.matmul(a.T, num, out=re)
    np.matmul(b.T, num, out=im)
    x, y = s.real[:, None], s.imag[:, None]
    parts[:, :, 0] = re[:, :r] + x * re[:, r:] - y * im[:, r:]
    parts[:, :, 1] = im[:, :r] + x * im[:, r:] + y * re[:, r:]


def _section_rows(s: np.ndarray, den: np.ndarray, g: np.ndarray | None):
    """Per-frequency rows and section coefficients whose products are Re d and -Im d."""
    ss = s * s
    re_rows, im_rows, im_cols = [ss.real, s.real, np.ones(s.size)], [ss.imag, s.imag], [0, 1]
    if g is not None:
        re_rows.append(-g.real)
        im_rows.append(-g.imag)
        im_cols.append(3)
    return np.array(re_rows), np.array(im_rows), -den[:, im_cols]


def _complex_parts(work: np.ndarray, shapes: list[tuple[int, ...]]) -> list[np.ndarray]:
    """Consecutive complex arrays of the given shapes laid out in the float buffer ``work``."""
    parts, at = [], 0
    for shape in shapes:
        size = 2 * int(np.prod(shape))
        parts.append(work[at:at + size].view(complex).reshape(shape))
        at += size
    return parts


def _scratch(size: int) -> np.ndarray:
    """A float64 work buffer of ``size`` elements, reused by every call in this thread.

    Fresh block temporaries of a few 100 kB are mapped and page-faulted anew on every call when
    the allocator returns them to the system: 340 page faults, 0.5 ms of system time per
    simulate at N = 16, a quarter of its time.
    """
    buf = getattr(_SCRATCH, "buf", None)
    if buf is None or buf.size < size:
        buf = _SCRATCH.buf = np.empty(size)
    return buf[:size]
