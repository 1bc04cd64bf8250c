r"""The beam's linear state-space model, assembled from :mod:`tests.reference.fem`.

.. math:: M\ddot w + D\dot w + K w - K_0\int_0^\infty g(\sigma)\,w(t-\sigma)\,d\sigma = b\,f(t)

with :math:`K = EI\,K_0 + P\,G_0 + k_\theta e e^T`, :math:`D = \gamma M_0 + c_dI\,K_0 + D_{sh}(a, b) + c_\theta e e^T`,
:math:`M = \rho A\,M_0` + tip body + sensor masses, and b the load row at the force's position; a
translating base adds :math:`m_b, c_b, k_b` times :math:`r_0 r_0^T` (r_0 the root deflection's row).

Two first-order forms, both integrated exactly by :mod:`tests.reference.integrate`:

* without memory, the full finite-element state :math:`x = (w, \dot w)` (one block);
* with time hysteresis, the undamped modes of (K, M) below a cut-off with states
  :math:`(q, \dot q, \zeta_{lo}, \zeta_1, \dots)` carrying the kernel's sum of exponentials
  (:mod:`tests.reference.memory`): one small block per mode when D and :math:`K_0` are diagonal
  in those modes (time hysteresis alone, with strain rate, a sensor mass or a delay), else one
  block of all modes (with a root spring, an axial load, or air and a tip body), whose size
  m (J + 3) asks for fewer modes or exponentials than the defaults;
* with a literature mechanism relaxing the moment, the internal-variable form of
  :mod:`tests.reference.augmented`.

A block is (A, B, C, F): :math:`\dot x = A x + B f`, outputs :math:`y = C x + F f` where each
sensor row reads the deflection, velocity or acceleration (:math:`C = S_v A`, :math:`F = S_v B`).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy import linalg

from .fem import Mesh
from .memory import SumOfExponentials
from .relaxation import RELAXATION_KEYS

DAMPING_KEYS = ("gamma", "cdI", "alpha", "beta", "r", "a", "b", *(k for keys in RELAXATION_KEYS.values() for k in keys))
EFFECT_KEYS = ("k_theta", "c_theta", "m_s", "sensor_masses", "P", "tau", "F_c", "f_hp", "gains",
               "m_a", "k_a", "c_a", "x_a", "m_b", "k_b", "c_b")
#: an attached body's keys: all four or none
ATTACHMENT_KEYS = ("m_a", "k_a", "c_a", "x_a")
#: a translating base's keys: all three or none
BASE_KEYS = ("m_b", "k_b", "c_b")
#: parameters that come in pairs
PAIRS = (("alpha", "beta"), ("a", "b"), *RELAXATION_KEYS.values())
ORDERS = {"displacement": 0, "velocity": 1, "acceleration": 2}


@dataclass(frozen=True)
class BeamCase:
    """Everything the simulator needs, SI units.

    length l (m), rho_a (kg/m), EI (N m^2), m_T (kg), J (kg m^2); ``damping`` with the paper's
    names (gamma N s/m^2, cdI N m^2 s, alpha N m^2 s^-1/2, beta 1/s, a N s, b m) or the literature's
    (:mod:`tests.reference.relaxation`: c_e N m^2 s and mu 1/s, c_f N m^2 s^nu and nu, Delta and
    tau_T s); ``effects``: k_theta (N m/rad, root spring), c_theta (N m s/rad, a root dashpot beside
    it), m_s (kg, point mass at the first sensor), sensor_masses (kg per sensor, in the order of
    ``sensors``: a point mass at any sensor; beside m_s the first sensor carries both), P (N, axial load, tension positive), tau (s,
    delay of the response channels), F_c (N, Coulomb friction at the tip: :mod:`tests.reference.friction`),
    f_hp (Hz, the response channels' AC coupling) and gains (per sensor, each channel reads 1 + g times
    the motion): :func:`tests.reference.daq.measurement_chain`; m_b (kg), k_b (N/m), c_b (N s/m): the clamp
    on a translating base (all three), the root deflection freed (:func:`_on_base`). ``sensors``:
    (location m, quantity).
    """

    length: float
    rho_a: float
    EI: float
    m_T: float = 0.0
    J: float = 0.0
    damping: dict = field(default_factory=dict)
    effects: dict = field(default_factory=dict)
    sensors: tuple = ((None, "acceleration"),)

    def __post_init__(self):
        for name, given, known in (("damping", self.damping, DAMPING_KEYS), ("effects", self.effects, EFFECT_KEYS)):
            unknown = set(given) - set(known)
            if unknown:
                raise ValueError(f"unknown {name} parameter(s) {sorted(unknown)}; known: {', '.join(known)}")
        scalars = {k: v for k, v in {**self.damping, **self.effects}.items() if k not in ("sensor_masses", "gains")}
        negative = {k: v for k, v in scalars.items() if (not np.isfinite(v) and k != "r") or (v < 0 and k != "P")}
        if negative or min(self.length, self.rho_a, self.EI) <= 0 or min(self.m_T, self.J) < 0:
            raise ValueError(f"parameters must be finite and non-negative (P may be negative), l, rho A and EI "
                             f"positive; got {negative or (self.length, self.rho_a, self.EI, self.m_T, self.J)}")
        unpaired = [pair for pair in PAIRS if (pair[0] in self.damping) != (pair[1] in self.damping)]
        if unpaired:
            raise ValueError(f"damping parameters {unpaired} come in pairs: give both of each")
        if not self.damping.get("nu", 0.5) < 1:
            raise ValueError(f"fractional damping needs nu < 1, got {self.damping['nu']} (nu = 1 is cdI)")
        attached = [k for k in ATTACHMENT_KEYS if k in self.effects]
        if attached and (len(attached) < len(ATTACHMENT_KEYS) or not 0 < self.effects["x_a"] <= self.length):
            raise ValueError(f"an attached body needs all of {', '.join(ATTACHMENT_KEYS)} with 0 < x_a <= l, "
                             f"got {attached}")
        based = [k for k in BASE_KEYS if k in self.effects]
        if based and (len(based) < len(BASE_KEYS) or not min(self.effects["m_b"], self.effects["k_b"]) > 0):
            raise ValueError(f"a translating base needs all of {', '.join(BASE_KEYS)} with m_b, k_b > 0, got {based}")
        if "c_theta" in self.effects and "k_theta" not in self.effects:
            raise ValueError("a root dashpot c_theta needs the root spring k_theta beside it (a rigid clamp has "
                             "no root slope to damp): give k_theta too")
        if self.has_memory and self.relaxes:
            raise ValueError("the reference simulates time hysteresis (alpha, beta) and a relaxing moment "
                             f"({', '.join(k for keys in RELAXATION_KEYS.values() for k in keys)}) separately")
        if self.damping.get("r", np.inf) != np.inf:
            raise ValueError("the reference simulates time hysteresis with infinite memory only: drop r")
        masses = self.effects.get("sensor_masses", (0.0,) * len(self.sensors))
        if len(masses) != len(self.sensors) or not all(np.isfinite(m) and m >= 0 for m in masses):
            raise ValueError(f"sensor_masses {masses!r}: give one finite mass >= 0 (kg) per sensor, "
                             f"{len(self.sensors)} in all")
        gains = self.effects.get("gains", (0.0,) * len(self.sensors))
        if len(gains) != len(self.sensors) or not all(np.isfinite(g) and g > -1 for g in gains):
            raise ValueError(f"gains {gains!r}: give one finite gain > -1 per sensor, {len(self.sensors)} in all")
        located = tuple((self.length if x is None else float(x), q) for x, q in self.sensors)
        object.__setattr__(self, "sensors", located)
        for _, quantity in located:
            if quantity not in ORDERS:
                raise ValueError(f"unknown sensor quantity {quantity!r}; use one of {', '.join(ORDERS)}")

    @property
    def has_memory(self) -> bool:
        return "alpha" in self.damping

    @property
    def relaxes(self) -> bool:
        """A literature mechanism relaxes the bending moment (tests.reference.relaxation)."""
        return any(keys[0] in self.damping for keys in RELAXATION_KEYS.values())

    def mesh(self, n_elements: int) -> Mesh:
        spring, base = "k_theta" in self.effects, "k_b" in self.effects
        root = {(False, False): "clamped", (True, False): "spring", (False, True): "base", (True, True): "spring_base"}
        return Mesh(self.length, n_elements, root[spring, base])


@dataclass(frozen=True)
class Matrices:
    """Mass, damping, stiffness (N/m, N s/m, kg in the dofs), K_0 and the mesh."""

    mesh: Mesh
    M: np.ndarray
    D: np.ndarray
    K: np.ndarray
    K0: np.ndarray


def matrices(case: BeamCase, n_elements: int) -> Matrices:
    """The finite-element matrices of ``case`` on ``n_elements`` elements."""
    mesh, d, e = case.mesh(n_elements), case.damping, case.effects
    M = case.rho_a * mesh.M0 + case.m_T * mesh.point(case.length) + case.J * mesh.point(case.length, 1)
    if "m_s" in e:
        M = M + e["m_s"] * mesh.point(case.sensors[0][0])
    for (x, _), m in zip(case.sensors, e.get("sensor_masses", ())):
        M = M + m * mesh.point(x)
    K = case.EI * mesh.K0 + e.get("P", 0.0) * mesh.G0
    if "k_theta" in e:
        K = K + e["k_theta"] * mesh.root_spring()
    D = d.get("gamma", 0.0) * mesh.M0 + d.get("cdI", 0.0) * mesh.K0
    if "c_theta" in e:   # the dashpot resists the root slope's rate as the spring its angle
        D = D + e["c_theta"] * mesh.root_spring()
    if "a" in d:
        D = D + mesh.spatial_hysteresis(d["a"], d["b"])
    if "k_b" in e:
        M, D, K = _on_base(mesh, e, M, D, K)
    if "m_a" in e:
        return _with_body(mesh, e, M, D, K)
    return Matrices(mesh, M, D, K, mesh.K0)


def _on_base(mesh: Mesh, e: dict, M: np.ndarray, D: np.ndarray, K: np.ndarray):
    """M, D, K with the clamp on a translating base: its kinetic energy m_b w_t(0)^2 / 2, spring
    energy k_b w(0)^2 / 2 and dissipation c_b w_t(0)^2 / 2 (w is the absolute deflection)."""
    at_root = mesh.root_translation()
    return M + e["m_b"] * at_root, D + e["c_b"] * at_root, K + e["k_b"] * at_root


def _with_body(mesh: Mesh, e: dict, M: np.ndarray, D: np.ndarray, K: np.ndarray) -> Matrices:
    """The matrices with an attached body's displacement y as the last dof: kinetic energy
    m_a y_t^2 / 2, the link's energy k_a (u(x_a) - y)^2 / 2 and dissipation c_a (u_t(x_a) - y_t)^2 / 2."""
    n = len(M)
    link = np.concatenate([mesh.rows([e["x_a"]])[0], [-1.0]])
    grown = [np.pad(a, (0, 1)) for a in (M, D, K, mesh.K0)]
    grown[0][n, n] = e["m_a"]
    return Matrices(mesh, grown[0], grown[1] + e["c_a"] * np.outer(link, link),
                    grown[2] + e["k_a"] * np.outer(link, link), grown[3])


@dataclass(frozen=True)
class Blocks:
    """Independent linear blocks, stacked: A (nb, ns, ns), B (nb, ns), C (nb, n_out, ns); y = sum C x + F f."""

    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    F: np.ndarray

    def poles(self) -> np.ndarray:
        """Eigenvalues of every block (1/s), sorted by |Im| then Re."""
        lam = np.concatenate([linalg.eigvals(a) for a in self.A])
        return lam[np.lexsort((lam.real, np.abs(lam.imag)))]

    def equilibrium(self, load: float) -> np.ndarray:
        """The resting state (nb, ns) under a constant input ``load``: A x + B load = 0."""
        return np.stack([-np.linalg.solve(a, b * load) for a, b in zip(self.A, self.B)])


def on_dofs(rows: np.ndarray, n: int) -> np.ndarray:
    """Mesh rows (k, n_mesh) on all n dofs: zeros on an attached body's (sensors and the load act on the beam)."""
    return np.pad(rows, ((0, 0), (0, n - rows.shape[1])))


def _readout(case: BeamCase, mesh: Mesh, A: np.ndarray, B: np.ndarray, disp: np.ndarray, vel: np.ndarray):
    """Sensor matrices C (n_out, ns), F (n_out,) from state->deflection and state->velocity maps."""
    rows = on_dofs(mesh.rows([x for x, _ in case.sensors]), disp.shape[0])
    C, F = [], []
    for r, (_, quantity) in zip(rows, case.sensors):
        order = ORDERS[quantity]
        C.append(r @ disp if order == 0 else r @ vel if order == 1 else r @ vel @ A)
        F.append(0.0 if order < 2 else float(r @ vel @ B))
    return np.array(C), np.array(F)


def full_blocks(case: BeamCase, mats: Matrices, load_at: float) -> Blocks:
    """One block, the whole finite-element state (w, w_t); input: a unit force at ``load_at`` (m)."""
    n = len(mats.M)
    minv_k, minv_d = np.linalg.solve(mats.M, mats.K), np.linalg.solve(mats.M, mats.D)
    A = np.block([[np.zeros((n, n)), np.eye(n)], [-minv_k, -minv_d]])
    B = np.concatenate([np.zeros(n), np.linalg.solve(mats.M, on_dofs(mats.mesh.rows([load_at]), n)[0])])
    disp, vel = np.eye(n, 2 * n), np.eye(n, 2 * n, n)
    C, F = _readout(case, mats.mesh, A, B, disp, vel)
    return Blocks(A[None], B[None], C[None], F)


def undamped_modes(mats: Matrices) -> tuple[np.ndarray, np.ndarray]:
    """(omega (rad/s), mass-normalised mode shapes (n_dof, n_modes)) of (K, M), ascending."""
    lam, phi = linalg.eigh(mats.K, mats.M)
    return np.sqrt(lam), phi


#: largest coupled memory block (states) the stepping handles in seconds
MAX_COUPLED_STATES = 1200


def _is_diagonal(matrix: np.ndarray) -> bool:
    off = matrix - np.diag(np.diag(matrix))
    return np.max(np.abs(off), initial=0.0) <= 1e-8 * max(np.max(np.abs(np.diag(matrix))), 1e-300)


def _memory_block(case: BeamCase, mesh: Mesh, soe: SumOfExponentials, omega, phi, damping, curvature, load):
    """(A, B, C, F) of the modes ``phi`` (n_dof, m) together: state (q, q', zeta_lo, zeta_1, ...), each m long,
    with damping Phi' D Phi and curvature Phi' K_0 Phi (m, m) and the kernel's exponentials ``soe``."""
    alpha, beta = case.damping.get("alpha", 0.0), case.damping.get("beta", 1.0)
    kappa0, kappa1 = soe.kappa
    rates = np.concatenate([[beta], beta + soe.rates])
    weights = np.concatenate([[soe.low_weight], soe.weights])
    m, n_rates = omega.size, rates.size
    ns = m * (2 + n_rates)
    A = np.zeros((ns, ns))
    A[:m, m : 2 * m] = np.eye(m)
    A[m : 2 * m, :m] = -(np.diag(omega**2) - alpha * (kappa0 - kappa1 * beta) * curvature)
    A[m : 2 * m, m : 2 * m] = -(damping + alpha * kappa1 * curvature)
    A[m : 2 * m, 2 * m :] = np.hstack([alpha * w * curvature for w in weights])
    A[2 * m :, :m] = np.tile(np.eye(m), (n_rates, 1))
    A[2 * m :, 2 * m :] = -np.diag(np.repeat(rates, m))
    B = np.zeros(ns)
    B[m : 2 * m] = load
    disp = np.hstack([phi, np.zeros((phi.shape[0], ns - m))])
    vel = np.hstack([np.zeros((phi.shape[0], m)), phi, np.zeros((phi.shape[0], ns - 2 * m))])
    return (A, B, *_readout(case, mesh, A, B, disp, vel))


def modal_blocks(case: BeamCase, mats: Matrices, load_at: float, omega_cut: float, du: float = 0.5,
                 coupled: bool | None = None) -> Blocks:
    """The undamped modes below ``omega_cut`` (rad/s) with the memory's exponentials: one block per
    mode when D and K_0 are diagonal in the modes, else (or with ``coupled=True``) one block of all."""
    omega, phi = undamped_modes(mats)
    keep = omega <= omega_cut
    omega, phi = omega[keep], phi[:, keep]
    damping, curvature = phi.T @ mats.D @ phi, phi.T @ mats.K0 @ phi
    if coupled is None:
        coupled = not (_is_diagonal(damping) and _is_diagonal(curvature))
    soe = SumOfExponentials.covering(case.damping.get("beta", 1.0), omega[-1], du)
    if coupled and omega.size * (3 + soe.rates.size) > MAX_COUPLED_STATES:
        raise ValueError(f"time hysteresis with modes coupled by damping, a root spring or an axial load needs one "
                         f"block of {omega.size * (3 + soe.rates.size)} states, over {MAX_COUPLED_STATES}. Fix: keep "
                         "fewer modes or exponentials, e.g. Numerics(omega_cut=2 * pi * 2000, du=0.7).")
    groups = [np.arange(omega.size)] if coupled else [np.array([k]) for k in range(omega.size)]
    load = phi.T @ on_dofs(mats.mesh.rows([load_at]), len(mats.M))[0]
    blocks = [_memory_block(case, mats.mesh, soe, omega[g], phi[:, g], damping[np.ix_(g, g)],
                            curvature[np.ix_(g, g)], load[g]) for g in groups]
    A, B, C, F = (np.stack(parts) for parts in zip(*blocks))
    return Blocks(A, B, C, F.sum(axis=0))
