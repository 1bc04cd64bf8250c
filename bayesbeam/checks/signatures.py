r"""Which catalogue effect explains the mismatch? Signatures ranked before anything is fitted ("Name").

The mismatch map (:mod:`bayesbeam.checks.discrepancy`) gives a feature vector of observed errors
:math:`d` (per mode: ln frequency, damping ratio, ln amplitude per sensor, decay curvature, phase
at the excitation) against S replicates of the model. An effect e with parameter :math:`\delta`
added to the best model at its posterior median :math:`\hat\theta` changes the same features by its
*signature* :math:`S_e(\delta) = F(\hat\theta, \delta) - F(\hat\theta, 0)`.

Metric. :math:`W = L^{-1}` whitens the errors, :math:`C = LL^T` the replicates' covariance of the
features within each mode (they share that mode's noise; e.g. a mode's phase and frequency errors
are correlated), shrunk half-way (:data:`SHRINKAGE`) to its diagonal because S replicates estimate
it roughly, and zero between modes.

The baseline re-adjusts. Whatever the model's own parameters can mimic is no evidence for the
effect: with the baseline's Jacobian :math:`N = \partial F/\partial\theta` (central differences in
sampling coordinates), both sides are projected off the span of :math:`WN` (projector :math:`P`),

.. math:: \chi^2_0 = \|P W d\|^2, \qquad \chi^2_e(\delta) = \|P W (d - S_e(\delta))\|^2,
          \qquad \Delta\chi^2_e = \chi^2_0 - \min_\delta \chi^2_e(\delta).

This matters: to first order a compliant root lowers every mode by the same fraction,
:math:`d\ln f_m/d(1/k_\theta) = -2EI/l` for all m (the root moment :math:`EI\varphi_m''(0)` of the
clamped mode works against the spring, and :math:`\varphi_m''(0)^2 \propto \int\varphi_m''^2`), which a
lower EI mimics exactly; a sensor at the tip of a cantilever is the same (:math:`\varphi_m(l)^2`
is the same for every mass-normalised mode). Such effects show only through the second-order
frequency pattern and the changed mode shapes (amplitudes, damping), which the projection keeps.
The re-adjustment can be large and is not linear (EI by several % to absorb a root spring; a
10 g tip sensor needs gamma x2.5 and cdI x0.46 on the paper beam), so chi2_e is *profiled*: at
every evaluated value the baseline's parameters are re-adjusted by :math:`\beta` (sampling
coordinates, within their prior's support) to minimise :math:`\|W(d - S_e(\delta, \beta))\|^2` by
a trust-region least squares with the Jacobian held at :math:`WN` (at most
:data:`PROFILE_EVALUATIONS` evaluations, warm-started from the neighbouring value's
:math:`\beta`), and :math:`\chi^2_e` is the projected residual there. A single linear step from
:math:`\hat\theta` is not enough: it overshoots (for the tip mass, a step of -17 in ln gamma), and
a grid searched before re-adjusting sizes a root spring, a sensor mass and tip friction 3 to 5.5
times off on the test recordings.

Per sensor. The ``sensor_mass`` effect holds a mass per sensor (m_s_<s> when there are several):
each is a candidate of its own, "sensor_mass at <s>", its signature that sensor's mass moved from
its stated value (0 where none is stated) with every other sensor's mass as stated. So the screen
says at which sensor a mass is missing, whatever order the ``[[sensor]]`` tables list them in.
``channel_gain`` is screened the same way, a gain g_<s> per sensor with the others at 0.

An attached body (``attachment``) is screened the same way by its own frequency f_a, its mass and
link damping held at their priors' medians, and by its place (:attr:`Effect.place`): the scan in
f_a is repeated at :data:`PLACES` places along the span and the best kept, which is where the fit
starts (its p-value counts two parameters). The body's pattern over the modes is phi_m(x_a)^2,
and a local search from the tip does not cross the mode shapes' nodes to reach it.

A support resonance (``base_support``) is screened by its frequency f_b, the base's mass and
damping ratio held where its ``absent`` puts them (their priors' medians, 3.16 rho A l and 0.017):
the grid over f_b's five decades walks the base's mode from below mode 1 through the band to far
above it, where it leaves only a translational compliance of the root. With the mass held, the
screen sizes the base's coupled mode rather than f_b itself (a 2 rho A l base at 40 Hz screens at
31 Hz); the fit that follows frees both.

One-parameter least squares, physically admissible sign and range (the default prior's support,
both signs only for the axial load):

* linear effects (root_compliance, sensor_mass, axial_load, measurement_delay, high_pass,
  channel_gain, base_support): the exact model
  (poles for frequency and damping, simulated amplitudes and phases; the decay stays exponential)
  on :data:`GRID_POINTS` values log-spaced over the support, each profiled, then Brent's method in
  log value between the best value's neighbours; the signature is evaluated at finite size, never
  linearised at zero, because the first-order part of some is exactly the EI direction;
* nonlinear effects (quadratic_drag, dry_friction): features through the data's own estimators
  (ERA, envelope, band amplitude, phase) on a noise-free simulation, and the signature's zero is
  the same estimators where the effect vanishes, :math:`\delta = 0` (their bias on the baseline's
  response is no part of the effect; measured from the exact poles instead, it swamps the
  linearisation and hides 80 mN of friction). So is every effect's, linear ones included, against
  a baseline that holds a nonlinear effect; a root spring vanishes only as k_theta -> inf, and its
  zero is the baseline model itself. First linearised, :math:`S_e(\delta) \approx \delta J_e` with J from a probe value
  scaled to change the response by :data:`PROBE_CHANGE` (RMS):
  :math:`\hat\delta = \max(0, \langle PWJ, PWd\rangle/\|PWJ\|^2)`; then, since the effect is far
  from linear at the sizes that matter (50 mN of tip friction: the damping signature grows less
  than linearly, the amplitudes' more), Brent's method on the profiled chi2_e in log value within
  a factor :data:`BRACKET` of :math:`\hat\delta`.

Scores. The sds come from S replicates, so chi-square statistics are referred to F distributions:
:math:`\chi^2_0/\nu \sim F(\nu, S-1)` (:math:`\nu` = features minus rank of N) says whether there is
anything the baseline cannot absorb; :math:`\Delta\chi^2_e \sim F(1, S-1)` (one added parameter; two for a placed effect)
gives each effect's p-value. An effect is *supported* when that p-value is below :data:`ALPHA`
over the number of candidates (Bonferroni) and its value lies inside the prior. Also reported:
the fraction explained :math:`\Delta\chi^2_e/\chi^2_0`, the 90 % interval (:math:`\chi^2_e \le \min +
F_{0.9}(1, S-1)`, from the curvature in log value), the effect's own frequency shifts, and the
predicted feature changes after the baseline re-adjusts, which the reasoning sentence sets against
the observed ones.

Mains pickup (:data:`LINE_EFFECTS`) changes no mode feature: it adds sinusoids to the channels.
Its one candidate is scored on the residual's own lines, :math:`r = y - \hat y(\hat\theta)` (the
map's reference prediction). At each harmonic :math:`h_k = k f_{mains}` in the fitted band
(f_mains fixed at its nominal value, :func:`~bayesbeam.physics.effects.mains_lines.nominal_mains`)
and each channel c, the band coordinates :math:`z_c = B r_c/\sigma_c` (whitened by the map's
noise floor) are projected on those of the harmonic's cos and sin, :math:`Q_{k}`:

.. math:: \Delta\chi^2_{mains} = \sum_{c}\sum_{k:\,\rho_{ck} \ge 0.8} \|Q_{k}^T z_c\|^2,

the amplitudes' least squares, as the likelihood's marginalisation fits them; :math:`\rho_{ck}`
is the line's persistence (:func:`~bayesbeam.checks.discrepancy.line_persistence`: amplitude kept
from the first to the last third of the window). A line that decays like a mode is a mode, not
pickup, and counts nothing. Its p-value refers :math:`\Delta\chi^2/\nu` to :math:`F(\nu, S-1)`
with :math:`\nu = 2 \times` harmonics :math:`\times` channels, the calibration of every score
here; supported below the same Bonferroni level, with at least one persistent line. ``explained``
is its share of the residual's whitened power above the floor, :math:`\Delta\chi^2/(\|z\|^2 - D)`.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy import optimize, stats

from bayesbeam.checks.discrepancy import (
    PERSISTENT,
    Mismatch,
    feature_vector,
    line_persistence,
    mode_amplitudes,
    mode_label,
    mode_phases,
    statistics,
)
from bayesbeam.inference.priors import default_priors
from bayesbeam.model import BeamModel
from bayesbeam.physics import effects as catalogue
from bayesbeam.physics.effects.mains_lines import MainsLines, harmonics_in_band, nominal_mains

#: family-wise level of "supported" over the candidates
ALPHA = 0.01
#: grid values over a linear effect's prior support (a factor ~2 apart over k_theta's 5 decades:
#: the profiled chi2_e is smooth in log value, and Brent's method refines between neighbours)
GRID_POINTS = 17
#: grid values of an effect whose signature has narrow valleys: a support resonance's changes sign as
#: the base's mode crosses each beam mode, and its valley in f_b is about a factor 2 wide (26-60 Hz
#: for a 2 kg, 40 Hz base under the paper beam with the screen's 3.2 kg; 37-54 Hz had it held 1 kg),
#: no wider than the default grid's step; 65 values over f_b's five decades are a factor 1.2 apart.
#: An attached body's f_a is scanned at each of PLACES places: 33 values over six decades, a factor
#: 1.5 apart, give the same best place as 65 values on the concealed-effects study's body (3 % of the
#: beam's mass at 0.6 l, 45 Hz: 0.625 l, Delta chi2 13174.3 against 13174.5) in 30 % less time
DENSE_GRIDS = {"base_support": 65, "attachment": 33}
#: places a placed effect (an attached body) is screened at: x = l k / PLACES, k = 1 .. PLACES. Its
#: signature follows phi_m(x)^2 over the modes, which changes on the scale of the highest in-band
#: mode's half-wavelength (a body at 0.8 l or 0.4 l instead of 0.6 l on the paper beam explains 4-6 %
#: less of the mismatch, and at 0.8 l only as a mass far above the band)
PLACES = 8
#: a nonlinear effect's probe changes the response by this fraction of its RMS
PROBE_CHANGE = 0.01
#: a nonlinear effect's value is searched within this factor of its linearised estimate (which
#: is 0.75-0.93 of the profiled minimum for 15-80 mN of tip friction on the paper beam)
BRACKET = 2.0
#: shrinkage of the replicates' within-mode feature covariance towards its diagonal
SHRINKAGE = 0.5
#: relative tolerance (cost and step) of the baseline's re-adjustment at each evaluated value
PROFILE_TOLERANCE = 1e-3
#: at most this many evaluations per re-adjustment (a screen: chi2_e to a fraction of a unit)
PROFILE_EVALUATIONS = 10
#: a signature this small (whitened norm) is not re-adjusted: the projection's linear step is
#: exact to second order in it, so chi2_e is off by well under a unit
SMALL = 0.3
#: whitened residual given to the re-adjustment where the augmented model cannot be evaluated
FAILED = 1e3
#: step of the baseline's Jacobian in sampling coordinates
JACOBIAN_STEP = 1e-3

#: effects with no mode-feature signature, screened by the residual's own lines instead: mains
#: pickup adds sinusoids to the channels, not to the modes (:func:`_line_candidate`)
LINE_EFFECTS = ("mains_lines",)
#: effects with a parameter per sensor, each screened as a candidate of its own
PER_SENSOR_EFFECTS = ("sensor_mass", "channel_gain")
#: the physics of each effect, one sentence a person can check against the signature
PHYSICS = {
    "root_compliance": "a rotational spring at the clamp lowers every mode by nearly the same fraction to first "
                       "order (d ln f/d(1/k_theta) = -2 EI/l), which a lower EI mimics; what gives it away is the "
                       "extra drop of the low modes at second order and the changed mode shapes (amplitudes)",
    "sensor_mass": "a point mass at a sensor lowers mode m by about m_s phi_m(x_s)^2 / 2 (mass-normalised "
                   "shape): the pattern follows the mode shapes at the sensor (at a cantilever's tip it is the "
                   "same for every mode, like EI) and the amplitudes there change",
    "axial_load": "an axial force adds geometric stiffness P int u_x^2: the relative shift falls about as "
                  "1/(beta_m l)^2 with mode number (mode 1 moves ~6x more than mode 2); tension raises, "
                  "compression lowers",
    "measurement_delay": "every response channel lags the motion by tau: a phase -2 pi f tau at every mode, linear "
                         "in frequency, with no change of frequency, damping or amplitude",
    "root_damping": "a rotational dashpot at a compliant clamp adds the damping c_theta phi_m'(0)^2 / (2 omega_m) to "
                    "mode m (mass-normalised shape) and, to first order, no frequency shift: at a stiff clamp it "
                    "grows with the mode like Kelvin-Voigt damping, at a soft one (k_theta l/EI <~ 1) mode 1 is "
                    "damped most",
    "base_support": "a clamp on a base of mass m_b on a spring and dashpot adds the base's mode near f_b (an extra "
                    "peak, or a mode split in two where it meets a beam mode), pushes the beam's modes away from it "
                    "(those below down, those above up, the nearest most; a stiff base lowers mode m by "
                    "omega_m^4 L_m^2 / k_b in omega^2, L_m the mode's root participation), gives the modes near f_b its damping "
                    "and moves the root, so amplitudes and phases change most there; far above the band it is a "
                    "translational root compliance that lowers the high modes most",
    "high_pass": "the sensor's and DAQ's AC coupling s/(s + 2 pi f_hp) shows each mode with the gain "
                 "f/sqrt(f^2 + f_hp^2) and a phase lead arctan(f_hp/f): an amplitude loss and a lead concentrated "
                 "at the lowest mode, growing as f_hp/f, with no change of frequency or damping",
    "channel_gain": "a calibration error (1 + g) of one channel: a uniform amplitude ratio of that channel against "
                    "the others at every mode, with no change of frequency, damping or phase",
    "mains_lines": "mains pickup adds a sinusoid at each harmonic k f_mains to every response channel, with its own "
                   "amplitude and phase per channel: a line in the residual that keeps its amplitude over the "
                   "record while the beam's modes decay, and no change of any mode",
    "quadratic_drag": "air drag c_q |u_t| u_t dissipates more at large amplitude: the damping falls as the vibration "
                      "decays (decay rate larger at the start than at the end)",
    "dry_friction": "Coulomb friction at the tip takes a fixed amplitude per cycle (a straight-line envelope): "
                    "the damping rises as the vibration decays",
    "attachment": "a body on a spring and dashpot at x_a adds a mode of its own near f_a, lowers the "
                  "modes below it (it moves with the beam: mass) and raises those above (the link yields: "
                  "stiffness), each in proportion to phi_m(x_a)^2, and damps most the modes nearest its own: "
                  "the pattern over the modes is the squared mode shapes at one point of the span",
}


@dataclass
class Candidate:
    """One effect's explanation of the mismatch (see the module docstring)."""

    effect: str
    parameter: str
    unit: str
    value: float | None             # the parameter's least-squares value (None: no admissible value helps)
    interval_90: list | None
    prior: list                     # support of the default prior
    within_prior: bool
    delta_chi2: float
    explained: float                # fraction of the projected mismatch chi2_0
    p_value: float
    supported: bool
    predicted: dict                 # feature -> predicted change after the baseline re-adjusts
    frequency_shift_pct: list       # the effect's own shift of each mode at the value (before EI re-adjusts)
    reasoning: str = ""
    sensor: str | None = None       # the sensor whose mass the candidate moves (sensor_mass), else None
    #: the effect's other parameters where a fit of it may start (the other sensors' stated masses,
    #: within their priors)
    others: dict = field(default_factory=dict)
    #: a placed effect's best place of :data:`PLACES`, {parameter: m from the clamp}; else empty
    place: dict = field(default_factory=dict)

    @property
    def label(self) -> str:
        """The candidate in words: the effect, and for a sensor's mass which sensor ('sensor_mass at mid')."""
        return self.effect if self.sensor is None else f"{self.effect} at {self.sensor}"

    def to_dict(self) -> dict:
        return {k: getattr(self, k) for k in ("effect", "sensor", "label", "parameter", "unit", "value", "interval_90",
                                              "prior", "within_prior", "delta_chi2", "explained", "p_value",
                                              "supported", "frequency_shift_pct", "place", "reasoning")}


@dataclass
class Ranking:
    """Candidates best first, and whether there was anything to explain."""

    candidates: list
    chi2: float                     # chi2_0, the projected mismatch
    dof: int
    p_value: float                  # of chi2_0 under "the baseline is right"
    notes: list = field(default_factory=list)
    #: nothing is left to explain (:func:`rank_effects`' quiet rule): the beam effects were not scanned
    nothing_left: bool = False

    @property
    def best(self) -> Candidate | None:
        return self.candidates[0] if self.candidates and self.candidates[0].supported else None


# ---------------------------------------------------------------------------- entry point
def rank_effects(posterior, draws: np.ndarray, mismatch: Mismatch, effects=None, executor=None,
                 quiet: bool = False) -> Ranking:
    """Rank the catalogue ``effects`` (default: all not already in the model) for ``mismatch``.

    ``executor`` (:mod:`bayesbeam.executors`; None: one after another) fits the candidates side by
    side: each is a scan of its own augmented model, independent of the others, and on a model
    with a nonlinear effect each scan simulates hundreds of times. ``quiet``: the map flags no
    beam-physics region; then, if the projected mismatch is insignificant and no pickup line is
    supported, nothing is left to explain whatever the beam effects' scans give, and they are not
    run (the ranking holds the line candidates alone, at the level the whole screen would set)."""
    model = posterior.likelihood.model
    names = [e for e in (effects or catalogue.REGISTRY) if e not in {x.name for x in model.effects}]
    lines = [e for e in names if e in LINE_EFFECTS]
    names = [e for e in names if e not in LINE_EFFECTS]
    augmented, refused = {}, {}
    for name in names:
        try:
            augmented[name] = _augmented(model, name)
        except ValueError as exc:
            refused[name] = str(exc)
    theta = np.median(draws, axis=0)
    params, _ = posterior.split(theta)
    base = _Evaluator(model, mismatch.setting)
    base_features = base(params)
    space = _Space.build(mismatch, base, posterior, theta, base_features)
    dof = space.dof
    p0 = space.p_value(space.chi2_0, dof)
    screened = [(name, aug, p) for name, aug in augmented.items() for p in _screened(aug, name)]
    level = ALPHA / max(len(screened) + len(lines), 1)
    line_candidates = [_line_candidate(model, mismatch, space, level) for _ in lines]
    if quiet and p0 >= ALPHA and not any(c.supported for c in line_candidates):
        why = (f"the map flags no beam-physics region, the projected mismatch is insignificant and no pickup "
               f"line is supported: nothing is left to explain, and the {len(screened)} beam-effect signature(s) "
               f"were not scanned")
        return Ranking(line_candidates, space.chi2_0, dof, p0, [_mismatch_note(space.chi2_0, dof, p0), why],
                       nothing_left=True)
    jobs = [(name, aug, parameter, posterior, theta, base_features, space, mismatch, level)
            for name, aug, parameter in screened]
    found = list((executor.map if executor is not None else map)(_candidate_job, jobs)) + line_candidates
    found.sort(key=lambda c: (not c.supported, -c.delta_chi2))
    if len(found) > 1 and found[0].predicted:
        found[0].reasoning += _contrast(found[0], found[1], mismatch)
    notes = _ranking_notes(found, space.chi2_0, dof, p0) + [f"{n} not ranked: {why}" for n, why in refused.items()]
    return Ranking(found, space.chi2_0, dof, p0, notes)


# ---------------------------------------------------------------------------- features of a model
class _Evaluator:
    """The feature vector of a model at given parameters: exact for linear models, through the
    data's estimators (noise-free simulation) when an effect is nonlinear or ``estimators`` is set."""

    def __init__(self, model, setting, estimators: bool = False):
        self.model, self.setting = model, setting
        self.exact = not estimators and all(e.linear for e in model.effects)

    def __call__(self, params) -> np.ndarray:
        s = self.setting
        if not self.exact:
            return feature_vector(statistics(self.simulate(params), s, noisy=False))
        y, poles = self.simulate_with_poles(params)
        m = len(s.f_model)
        poles = _nearest_poles(poles, s.f_model)
        return feature_vector({"frequency": np.log(np.abs(poles) / (2 * np.pi)), "damping": -poles.real / np.abs(poles),
                               "amplitude": mode_amplitudes(y, s.projection, s.bands, 0 * s.sigma),
                               "curvature": np.zeros(m), "phase": mode_phases(y, s)})

    def simulate_with_poles(self, params) -> tuple[np.ndarray, np.ndarray]:
        """(:meth:`simulate`, the model's poles), a forced response and the poles from one system
        (its eigen-decomposition serves both)."""
        if self.model.recording.excitation.kind == "free_decay":
            return self.simulate(params), self.model.poles(params)
        values = self.model.values(params)
        system = self.model.system(params)
        return self.model.linear_response(system, values), system.poles()

    def simulate(self, params) -> np.ndarray:
        """The noise-free signals; a free decay's unknown initial state by least squares (weights
        1/sigma) on the analysed window."""
        if self.model.recording.excitation.kind != "free_decay":
            return self.model.simulate(params)
        s = self.setting
        return self.model.simulate(params, self.model.fit_initial(params, weights=1 / s.sigma, samples=s.projection.window))


def _nearest_poles(poles: np.ndarray, f_model) -> np.ndarray:
    """The pole nearest each baseline mode's frequency f_model (Hz), as the data's ERA picks its
    (:func:`bayesbeam.checks.ppc.era_modes`): an effect that adds a mode of its own (a support
    resonance) leaves each baseline mode matched to the pole that moved from it, not shifted by one."""
    f = np.abs(poles) / (2 * np.pi)
    return poles[[int(np.argmin(np.abs(np.log(f / fk)))) for fk in f_model]]


@dataclass
class _Space:
    """The whitened feature space with the baseline's parameters projected out (module docstring)."""

    used: np.ndarray                # features that enter
    whiten: np.ndarray              # W (used, used): W C W^T = I
    basis: np.ndarray               # orthonormal basis of W N
    jacobian: np.ndarray            # N (used, k)
    d: np.ndarray                   # W d (used,)
    rank: int
    replicates: int                 # S: the sds' degrees of freedom are S - 1
    setting: object                 # the map's estimator setting

    @classmethod
    def build(cls, mismatch, base, posterior, theta, base_features):
        f = mismatch.features
        jac = _jacobian(base, posterior, theta, base_features)
        used = np.isfinite(f.observed) & np.isfinite(f.sd) & (f.sd > 0) & np.all(np.isfinite(jac), axis=1)
        whiten = _whitening(f, used)
        u, sv, _ = np.linalg.svd(whiten @ jac[used], full_matrices=False)
        keep = sv > 1e-8 * sv.max() if sv.size else np.zeros(0, bool)
        return cls(used, whiten, u[:, keep], jac[used], whiten @ f.observed[used], int(keep.sum()),
                   len(f.replicated), mismatch.setting)

    @property
    def dof(self) -> int:
        return int(self.used.sum()) - self.rank

    def p_value(self, chi2: float, dof: int) -> float:
        """Pr(chi2 or more) when the error's sds come from S replicates: chi2/dof ~ F(dof, S - 1)."""
        return float(stats.f.sf(chi2 / max(dof, 1), max(dof, 1), max(self.replicates - 1, 1)))

    @property
    def interval_level(self) -> float:
        """chi2 above its minimum at the ends of the 90 % interval: F(1, S - 1) quantile."""
        return float(stats.f.ppf(0.9, 1, max(self.replicates - 1, 1)))

    def project(self, x: np.ndarray) -> np.ndarray:
        return x - self.basis @ (self.basis.T @ x)

    @property
    def chi2_0(self) -> float:
        r = self.project(self.d)
        return float(r @ r)

    def weighted(self, signature: np.ndarray) -> np.ndarray:
        return self.whiten @ np.nan_to_num(signature[self.used])

    def chi2(self, signature: np.ndarray) -> float:
        r = self.project(self.d - self.weighted(signature))
        return float(r @ r)

    def beta(self, signature: np.ndarray) -> np.ndarray:
        """The baseline parameters' linear re-adjustment (sampling coordinates) given the signature."""
        return np.linalg.lstsq(self.whiten @ self.jacobian, self.d - self.weighted(signature), rcond=None)[0]

    def adjusted(self, signature: np.ndarray) -> np.ndarray:
        """Signature plus the baseline's best linear re-adjustment to the observed errors (used features)."""
        return np.nan_to_num(signature[self.used]) + self.jacobian @ self.beta(signature)


def _whitening(f, used) -> np.ndarray:
    """W = L^-1, C = L L^T = diag(s) R diag(s): R the replicates' correlation within each mode (the
    features of one mode share its noise), zero between modes, shrunk half-way to the identity (S
    replicates estimate it roughly); s the errors' sds."""
    mode = np.array([_label(n)[2] for n, u in zip(f.names, used) if u])
    r = np.nan_to_num(f.replicated[:, used])
    with np.errstate(invalid="ignore", divide="ignore"):
        corr = np.nan_to_num(np.atleast_2d(np.corrcoef(r, rowvar=False))) if len(r) > 1 else np.eye(mode.size)
    corr = (1 - SHRINKAGE) * corr * (mode[:, None] == mode[None, :]) + SHRINKAGE * np.eye(mode.size)
    np.fill_diagonal(corr, 1.0)
    sd = f.sd[used]
    return np.linalg.inv(np.linalg.cholesky(corr * np.outer(sd, sd)))


def _jacobian(base: _Evaluator, posterior, theta, f0) -> np.ndarray:
    """dF/d(theta_k) for the model parameters (sampling coordinates): (n_features, k).

    The step is JACOBIAN_STEP in log coordinates and that fraction of the prior's width in linear
    ones (a delay's 1e-3 would be a whole millisecond); one-sided where the central difference
    would leave the prior's support (a delay near zero).
    """
    k = len(posterior.model_names)
    cols = []
    for i in range(k):
        prior = posterior.priors[i]
        lo, hi = prior.bounds()
        h = JACOBIAN_STEP * (1.0 if prior.log_scale else hi - lo)
        up, down = min(h, hi - theta[i]), min(h, theta[i] - lo)
        step = np.zeros_like(theta)
        step[i] = 1.0
        plus, minus = (base(posterior.split(theta + d * step)[0]) for d in (up, -down))
        cols.append((plus - minus) / (up + down))
    return np.array(cols).T if cols else np.zeros((f0.size, 0))


# ---------------------------------------------------------------------------- one candidate
def _effect(aug: BeamModel, name: str):
    """The augmented model's effect ``name``, bound to its recording (a mass per sensor)."""
    return next(e for e in aug.effects if e.name == name)


def _screened(aug: BeamModel, name: str) -> tuple[str, ...]:
    """The parameters of effect ``name`` screened one at a time: every sensor's of an effect of
    :data:`PER_SENSOR_EFFECTS`, the first (only) parameter of any other effect."""
    parameters = _effect(aug, name).parameters
    return parameters if name in PER_SENSOR_EFFECTS else parameters[:1]


def _sensor_of(aug: BeamModel, name: str, parameter: str) -> str | None:
    """The sensor whose mass or gain ``parameter`` is (an effect of :data:`PER_SENSOR_EFFECTS` on a
    recording of several sensors), else None."""
    if name not in PER_SENSOR_EFFECTS or len(aug.recording.sensors) == 1:
        return None
    return aug.recording.sensors[_effect(aug, name).parameters.index(parameter)].name


def _candidate_job(args) -> Candidate:
    """:func:`_candidate` of one job's arguments (for an executor's map)."""
    return _candidate(*args)


def _candidate(name, aug, parameter, posterior, theta, base_features, space, mismatch, level) -> Candidate:
    model = posterior.likelihood.model
    effect = _effect(aug, name)
    priors = default_priors(model.recording.beam, effect.parameters, {}, model.recording.setup)
    support = _support(priors[parameter])
    # the effect's other parameters stay where it vanishes: the other sensors' masses as stated;
    # a placed effect's place at each of PLACES, the best kept
    fixed, (value, interval, chi2, best) = min(
        ((fixed, _fit_one(effect, aug, parameter, posterior, theta, base_features, space, support, fixed))
         for fixed in _held(effect, parameter, model.recording.beam.length)),
        key=lambda pair: pair[1][2])
    delta = max(space.chi2_0 - chi2, 0.0)
    p = space.p_value(delta, 1 if effect.place is None else 2)
    inside = value is not None and support[0] <= value <= support[1]
    params = {**posterior.split(theta)[0], **fixed}
    cand = Candidate(name, parameter, effect.units[parameter], value, interval, support, bool(inside), delta,
                     delta / space.chi2_0 if space.chi2_0 > 0 else 0.0, p, bool(p < level and inside),
                     _predicted(space, best, mismatch), _frequency_shift(aug, model, params, parameter, value),
                     sensor=_sensor_of(aug, name, parameter),
                     others={p: float(np.clip(v, *_support(priors[p]))) for p, v in fixed.items()},
                     place={} if effect.place is None else {effect.place: fixed[effect.place]})
    cand.reasoning = _reasoning(cand, mismatch)
    return cand


def _held(effect, parameter: str, length: float) -> list[dict]:
    """The values the effect's other parameters are held at while ``parameter`` is scanned: where
    it vanishes (``absent``), and for a placed effect each of :data:`PLACES` in turn."""
    held = {p: v for p, v in effect.absent.items() if p != parameter}
    if effect.place is None:
        return [held]
    return [{**held, effect.place: length * k / PLACES} for k in range(PLACES, 0, -1)]


def _fit_one(effect, aug, parameter, posterior, theta, base_features, space, support, fixed) -> tuple:
    """(value, 90 % interval, chi2_e, signature) of ``parameter``'s least squares, ``fixed`` held."""
    sig = _Signature(aug, parameter, posterior, theta, base_features, space, effect.absent[parameter], fixed)
    if not effect.linear:
        return _linearised_fit(sig, space, support)
    return _grid_fit(sig, space, _grid(support, DENSE_GRIDS.get(effect.name, GRID_POINTS)), support)


def _line_candidate(model, mismatch: Mismatch, space: _Space, level: float) -> Candidate:
    """Mains pickup's candidate: the persistent lines' own chi2 in the baseline's residual at its
    posterior median, on 2 x (harmonics x channels) degrees of freedom (module docstring)."""
    rec, s = model.recording, mismatch.setting
    f_mains = nominal_mains(rec)
    harmonics = harmonics_in_band(f_mains, s.projection.max_frequency)
    residual = rec.signals - s.reference
    kept = np.array([[line_persistence(residual[:, c], s.projection, h) >= PERSISTENT for c in range(len(s.sigma))]
                     for h in harmonics], bool).reshape(len(harmonics), len(s.sigma))
    z = s.projection.project(residual) / s.sigma
    waves = s.projection.project(MainsLines().latent_columns(rec.time, {"f_mains": f_mains}, 1,
                                                             s.projection.max_frequency)[:, 0])
    delta, dof = line_chi2(z, waves, kept), 2 * kept.size
    p = space.p_value(delta, dof) if dof else 1.0
    excess = float(np.sum(z**2)) - z.size
    cand = Candidate("mains_lines", "f_mains", "Hz", f_mains, [f_mains, f_mains], [f_mains, f_mains], True, delta,
                     min(delta / excess, 1.0) if excess > 0 else 0.0, p, bool(p < level and kept.any()), {}, [])
    cand.reasoning = _line_reasoning(cand, harmonics, kept, mismatch.channels)
    return cand


def line_chi2(z: np.ndarray, waves: np.ndarray, kept: np.ndarray) -> float:
    """The lines' chi2: per channel c, the whitened residual's band coordinates z[:, c] projected on
    the span of the kept harmonics' cos and sin columns; ``waves`` (D, 2K): the band coordinates of
    each harmonic's cos (first K) and sin (last K), ``kept`` (K, c): which (harmonic, channel) count.
    Without noise at the lines it is chi2 with 2 x kept.sum() degrees of freedom: the amplitudes'
    least squares, as the likelihood's marginalisation fits them."""
    total = 0.0
    for c in range(z.shape[1]):
        columns = np.flatnonzero(np.tile(kept[:, c], 2))
        if columns.size:
            q = np.linalg.qr(waves[:, columns])[0]
            total += float(np.sum((q.T @ z[:, c]) ** 2))
    return total


def _line_reasoning(c: Candidate, harmonics, kept, channels) -> str:
    """The mains candidate's case in words: the physics, which lines persist, the chi2, the verdict."""
    persistent = [f"{h:.4g} Hz on {name}" for i, h in enumerate(harmonics) for j, name in enumerate(channels)
                  if kept[i, j]]
    return (f"{c.label}: {PHYSICS[c.effect]}. At the harmonics of f_mains = {c.value:g} Hz (fixed: [setup] mains_hz, "
            f"else the record's persistent lines, else 50 Hz) in the fitted band, {len(persistent)} of {kept.size} "
            f"(harmonic, channel) lines of the residual keep {PERSISTENT:.0%} of their amplitude from the first to "
            f"the last third of the window ({'; '.join(persistent) or 'none'}); a line that decays is a mode, not "
            f"pickup, and is left out. The persistent lines' chi2 against the noise floor is {c.delta_chi2:.3g} on "
            f"{2 * kept.size} degrees of freedom (p = {c.p_value:.2g}), {c.explained:.0%} of the residual's power "
            f"above the floor: {'supported' if c.supported else 'not supported'}.")


def _support(prior) -> list[float]:
    """A prior's support in values (SI units)."""
    return [float(np.exp(v)) if prior.log_scale else float(v) for v in prior.bounds()]


class _Signature:
    """S_e(delta) = F(theta, delta) - F(theta, 0), and its profile: the baseline's parameters
    re-adjusted to the observed errors with the effect at delta (nonlinear least squares within
    their prior's support), so that a large re-adjustment (EI absorbing a root spring's uniform
    shift, the damping parameters a sensor mass's redistribution) is neither linearised nor
    extrapolated from the baseline's Jacobian."""

    def __init__(self, aug, parameter, posterior, theta, base_features, space, absent: float, fixed: dict):
        self.evaluate = _Evaluator(aug, space.setting)
        self.parameter, self.posterior, self.theta, self.fixed = parameter, posterior, theta, fixed
        self.space = space
        # a nonlinear model's features come from the data's estimators, whose bias on a noise-free
        # response (ERA's, the envelope's) is no part of the effect: its zero is the same estimators
        # where the effect vanishes, not the baseline's exact poles. Where it vanishes only in a
        # limit (a root spring's k_theta -> inf, the clamp), that is the baseline model itself.
        params = self.params(theta)
        if self.evaluate.exact:
            self.base = base_features
        elif np.isfinite(absent):
            self.base = self.evaluate({**params, parameter: absent})
        else:
            self.base = _Evaluator(posterior.likelihood.model, space.setting, estimators=True)(posterior.split(theta)[0])
        k = space.jacobian.shape[1]
        support = np.array([posterior.priors[i].bounds() for i in range(k)]).reshape(k, 2)
        # the posterior median may lie past a log-normal prior's +-4 sd support: never exclude it
        self.bounds = (np.minimum(support[:, 0] - theta[:k], 0.0), np.maximum(support[:, 1] - theta[:k], 0.0))

    def params(self, theta) -> dict:
        """The baseline's parameters at ``theta`` with the effect's other parameters held fixed."""
        return {**self.posterior.split(theta)[0], **self.fixed}

    def __call__(self, value, beta=None):
        theta = self.theta.copy()
        if beta is not None:
            theta[: len(beta)] += beta
        try:
            return self.evaluate({**self.params(theta), self.parameter: value}) - self.base
        except (ValueError, np.linalg.LinAlgError, FloatingPointError, RuntimeError):   # e.g. drag's Newton
            return None

    def profile(self, value, start=None):
        """(signature, beta) with the baseline re-adjusted by beta (sampling coordinates) to
        minimise |W (d - S)|^2 at ``value``, from ``start`` (default: no re-adjustment); (None,
        start) when the model cannot be evaluated there.

        The Jacobian is the baseline's W N, already computed, held fixed: the trust region keeps
        the steps where it predicts well, and the projected chi2_e removes what a last linear step
        would. (A nonlinear model's own Jacobian, through the estimators, converges no faster.)"""
        lo, hi = self.bounds
        beta0 = np.zeros(lo.size) if start is None else np.clip(start, lo, hi)
        seen = {}

        def residual(beta):
            # least squares evaluates its start again, and may revisit a point: each is simulated once
            key = beta.tobytes()
            if key not in seen:
                seen[key] = self(value, beta)
            s = seen[key]
            # least squares needs finite residuals: a failed evaluation fits worse than any other
            return self.space.d - self.space.weighted(s) if s is not None else np.full(self.space.d.size, FAILED)

        r = residual(beta0)
        if seen[beta0.tobytes()] is None or not lo.size or np.linalg.norm(r - self.space.d) < SMALL:
            return seen[beta0.tobytes()], beta0
        jac = -self.space.whiten @ self.space.jacobian
        beta = optimize.least_squares(residual, beta0, jac=lambda _: jac, bounds=(lo, hi),
                                      ftol=PROFILE_TOLERANCE, xtol=PROFILE_TOLERANCE,
                                      max_nfev=PROFILE_EVALUATIONS).x
        return seen[beta.tobytes()] if beta.tobytes() in seen else self(value, beta), beta

    def chi2(self, value, start=None):
        """(chi2_e at ``value`` with the baseline profiled, beta)."""
        s, beta = self.profile(value, start)
        return (self.space.chi2(s) if s is not None else np.inf), beta


def _augmented(model, name) -> BeamModel:
    """The same model (mechanisms, grid, force conditioning) with effect ``name`` added."""
    rec = model.recording
    windowed = model.force is not None and not np.array_equal(model.force, rec.force)
    return BeamModel.from_recording(rec, [m.name for m in model.mechanisms], model.n_intervals, windowed,
                                    [e.name for e in model.effects] + [name], degree=model.degree)


def _grid(support, points: int = GRID_POINTS) -> np.ndarray:
    """Log-spaced grid of ``points`` values over the support; both signs when it straddles zero (axial load)."""
    lo, hi = support
    if lo > 0:
        return np.geomspace(lo, hi, points)
    if lo == 0:
        return np.geomspace(1e-4 * hi, hi, points)
    half = points // 2
    reach = max(-lo, hi)
    neg = -np.geomspace(1e-5 * reach, -lo, half)[::-1]
    return np.concatenate([neg, np.geomspace(1e-5 * reach, hi, points - half)])


def _grid_fit(sig: _Signature, space, grid, support):
    """Least squares over ``grid`` with the baseline profiled at every value, then Brent's method
    in log |value| between the grid minimum's neighbours of the same sign; 90 % interval from the
    curvature there, within ``support``."""
    chi2, start = _profiled_grid(sig, grid)
    if not np.isfinite(chi2).any():
        return None, None, space.chi2_0, None
    i = int(np.argmin(chi2))
    sign = np.sign(grid[i])
    near = [j for j in (i - 1, i, i + 1) if 0 <= j < len(grid) and np.sign(grid[j]) == sign]
    return _refine(sig, space, np.log(np.abs(grid[near])), sign, start[i], support)


def _refine(sig: _Signature, space, logs, sign, start, support):
    """Brent's method on the profiled chi2_e in log |value| between min(logs) and max(logs), each
    re-adjustment started from the last one's (Brent's steps are short); the 90 % interval from
    the curvature at the minimum, within ``support``: (value, interval, chi2_e, signature)."""
    last = [start]

    def refined(x):
        c, last[0] = sig.chi2(sign * np.exp(x), last[0])
        return c

    res = optimize.minimize_scalar(refined, bounds=(min(logs), max(logs)), method="bounded",
                                   options={"xatol": 0.01})
    x, c_min = float(res.x), float(res.fun)
    value = float(sign * np.exp(x))
    interval = _interval(refined, x, c_min, sign, support, space.interval_level)
    return value, interval, c_min, sig.profile(value, last[0])[0]


def _profiled_grid(sig: _Signature, grid):
    """chi2_e and the baseline's re-adjustment at each grid value, in order of |value| on each
    side, each re-adjustment started from the previous value's (neighbouring values need nearby
    re-adjustments, so the least squares is short)."""
    chi2, start = np.full(grid.size, np.inf), [None] * grid.size
    for side in (grid < 0, grid > 0):
        previous = None
        for j in np.flatnonzero(side)[np.argsort(np.abs(grid[side]))]:
            chi2[j], start[j] = sig.chi2(grid[j], previous)
            previous = start[j] if np.isfinite(chi2[j]) else previous
    return chi2, start


def _interval(refined, x, c_min, sign, support, level) -> list:
    """chi2 <= min + level from the parabola through x +- 0.1 (log value), within the support."""
    h = 0.1
    curvature = (refined(x + h) + refined(x - h) - 2 * c_min) / (2 * h * h)
    # a flat chi2 gives the whole support; the log-width is capped so exp() cannot overflow
    half = min(np.sqrt(level / curvature), 700.0 - abs(x)) if curvature > 0 else 700.0 - abs(x)
    ends = sorted(float(sign * np.exp(x + d)) for d in (-half, half))
    return [max(ends[0], support[0]), min(ends[1], support[1])]


def _linearised_fit(sig: _Signature, space, support):
    """delta J fitted by least squares with delta >= 0, J from a probe scaled to PROBE_CHANGE;
    then, because the effect is not linear at the sizes that matter, Brent's method on the
    profiled chi2_e in log value within a factor BRACKET of that estimate."""
    probe = _probe(sig.evaluate, sig.params(sig.theta), sig.parameter, support)
    s_probe = sig(probe)
    if s_probe is None:
        return None, [0.0, 0.0], space.chi2_0, None
    j = space.project(space.weighted(s_probe / probe))
    norm2 = float(j @ j)
    value = max(0.0, float(j @ space.project(space.d)) / norm2) if norm2 > 0 else 0.0
    if value == 0.0:
        half = np.sqrt(space.interval_level / norm2) if norm2 > 0 else np.inf
        return 0.0, [0.0, float(half)], space.chi2_0, np.zeros_like(s_probe)
    with np.errstate(divide="ignore"):     # a support from zero
        logs = np.clip(np.log(value) + np.log(BRACKET) * np.array([-1, 1]), *np.log(support))
    return _refine(sig, space, logs, 1.0, None, support)


def _probe(evaluate: _Evaluator, params, parameter, support) -> float:
    """A value that changes the noise-free response by PROBE_CHANGE of its RMS (linear regime)."""
    y0 = evaluate.simulate({**params, parameter: 0.0})
    value = float(np.sqrt(support[0] * support[1]))
    for _ in range(3):
        change = np.sqrt(np.mean((evaluate.simulate({**params, parameter: value}) - y0) ** 2) / np.mean(y0**2))
        if not change > 0:
            break
        value *= PROBE_CHANGE / change
        if abs(np.log(change / PROBE_CHANGE)) < 0.5:
            break
    return value


def _frequency_shift(aug, model, params, parameter, value) -> list:
    """The effect's own relative shift of each in-band mode (%) at ``value``, EI unchanged."""
    if value is None:
        return []
    f0 = model.natural_frequencies({k: v for k, v in params.items() if k in model.parameter_names})
    try:
        f1 = aug.natural_frequencies({**params, parameter: value})
    except (ValueError, np.linalg.LinAlgError):
        return []
    m = min(len(f0), len(f1))
    return [float(v) for v in 100 * (f1[:m] / f0[:m] - 1)]


# ---------------------------------------------------------------------------- words
def _predicted(space, signature, mismatch) -> dict:
    names = [n for n, u in zip(mismatch.features.names, space.used) if u]
    if signature is None:
        return {}
    return dict(zip(names, space.adjusted(signature).tolist()))


def _label(name: str, modes=None) -> tuple[str, str, int]:
    """(words, kind, mode) of a feature name: 'ln_A2_tip' -> ('mode 2 amplitude at tip', 'ln_A', 2);
    with the map's per-mode rows ``modes`` the mode is named by its row's label."""
    for kind, words in (("ln_f", "frequency"), ("zeta", "damping ratio"), ("ln_A", "amplitude"),
                        ("curvature", "decay curvature"), ("phase", "phase at the excitation")):
        if name.startswith(kind):
            mode, _, sensor = name[len(kind):].partition("_")
            named = f"mode {mode}" if modes is None else mode_label(modes[int(mode) - 1])
            return f"{named} {words}" + (f" at {sensor}" if sensor else ""), kind, int(mode)
    raise ValueError(f"unknown feature {name!r}")


def _format(kind: str, value: float, zeta: float | None, sign: str = "+") -> str:
    """A feature's value in its reading unit: % for frequency, amplitude and damping, else 1/s or rad."""
    if kind in ("ln_f", "ln_A"):
        return f"{100 * np.expm1(value):{sign}.2g}%"
    if kind == "zeta":
        return f"{100 * value / zeta:{sign}.2g}%" if zeta else f"{value:{sign}.2g}"
    return f"{value:{sign}.2g} {'1/s' if kind == 'curvature' else 'rad'}"


def _reasoning(c: Candidate, mismatch) -> str:
    """The candidate's case in words: physics, what it predicts against what is seen, the verdict."""
    f = mismatch.features
    index = {n: i for i, n in enumerate(f.names)}
    pulls = sorted(c.predicted, key=lambda n: -abs(c.predicted[n]) / f.sd[index[n]])[:3]
    seen = []
    for n in pulls:
        words, kind, mode = _label(n, mismatch.modes)
        zeta = mismatch.modes[mode - 1]["replicated_damping_ratio"]
        seen.append(f"{words} {_format(kind, f.observed[index[n]], zeta)} +- {_format(kind, f.sd[index[n]], zeta, '')}"
                    f" observed, {_format(kind, c.predicted[n], zeta)} predicted")
    shift = ", ".join(f"{v:+.2g}" for v in c.frequency_shift_pct[: len(mismatch.modes)])
    own = f"; on its own (EI fixed) it shifts modes 1-{len(mismatch.modes)} by {shift}%" if shift and \
        any(abs(v) > 1e-3 for v in c.frequency_shift_pct) else ""
    value = "no admissible value helps" if not c.value else \
        (f"needs {c.parameter} = {c.value:.3g} {c.unit} (90%: {c.interval_90[0]:.3g} to {c.interval_90[1]:.3g}), "
         f"{'inside' if c.within_prior else 'outside'} the prior [{c.prior[0]:.3g}, {c.prior[1]:.3g}]"
         + "".join(f", at {p} = {x:.3g} m (the best of {PLACES} places)" for p, x in c.place.items()))
    return (f"{c.label}: {PHYSICS[c.effect]}{own}. Where its signature is strongest (after the model's own "
            f"parameters re-adjust): {'; '.join(seen) or 'nowhere'}. It explains {c.explained:.0%} of the mismatch "
            f"(delta chi2 = {c.delta_chi2:.3g}, p = {c.p_value:.2g}); {value}: "
            f"{'supported' if c.supported else 'not supported'}.")


def _contrast(best: Candidate, other: Candidate, mismatch) -> str:
    """The runner-up at the best candidate's strongest feature: the check that tells them apart."""
    f = mismatch.features
    index = {n: i for i, n in enumerate(f.names)}
    name = max(best.predicted, key=lambda n: abs(best.predicted[n]) / f.sd[index[n]])
    words, kind, mode = _label(name, mismatch.modes)
    zeta = mismatch.modes[mode - 1]["replicated_damping_ratio"]
    there = f" (it predicts {_format(kind, other.predicted[name], zeta)} for the {words})" \
        if name in other.predicted else ""
    return (f" The next candidate, {other.label}, explains {other.explained:.0%} "
            f"(delta chi2 = {other.delta_chi2:.3g}){there}.")


def _mismatch_note(chi2_0, dof, p0) -> str:
    return f"projected mismatch chi2 = {chi2_0:.3g} on {dof} degrees of freedom (p = {p0:.2g})"


def _ranking_notes(found, chi2_0, dof, p0) -> list[str]:
    notes = [_mismatch_note(chi2_0, dof, p0)]
    if any(c.supported for c in found):
        best = found[0]
        notes.append(f"best candidate: {best.label} ({best.explained:.0%} of the mismatch)")
    elif p0 < ALPHA:
        notes.append("no catalogue effect explains the mismatch: unexplained")
    else:
        notes.append("the per-mode features show nothing the baseline's own parameters cannot absorb, and no "
                     "effect's signature stands out: no effect is needed")
    return notes


