"""BeamModel: the beam's physics, a damping model and a recording's sensors and excitation.

>>> from bayesbeam import load_recording, BeamModel
>>> rec = load_recording("data/examples/paper_q3_hammer")
>>> model = BeamModel.from_recording(rec, mechanisms="q3", n_intervals=16)
>>> y = model.simulate({"EI": 44.0, "gamma": 0.09, "a": 1e-3, "b": 0.06})   # (n_samples, n_sensors)

Parameters use the paper's names in SI units: EI (N m^2) and those of each mechanism
(gamma N s/m^2, cdI N m^2 s, alpha N m^2 s^-1/2, beta 1/s, r s, a N s, b m). A free length that
beam.toml states with a tolerance adds l (m, :meth:`BeamModel.operators`), a sensor location
stated with a tolerance the sensor's offset dx_<sensor> (m, :meth:`BeamModel.placement`), and the
hammer's location stated with a tolerance its offset dx_hammer (m), to every model. A sensor's own
mass stated in beam.toml is a known point mass at that sensor in every model
(:meth:`BeamModel.carried_mass`).
"""
from __future__ import annotations

from collections.abc import Mapping, Sequence
from functools import cached_property

import numpy as np
from scipy import fft, linalg

from bayesbeam.io import Recording
from bayesbeam.physics import effects as effect_catalogue
from bayesbeam.physics.assembly import BeamOperators
from bayesbeam.physics.basis import SplineBasis, combined_root
from bayesbeam.physics.effects import Setup
from bayesbeam.physics.mechanisms import PRESETS, resolve
from bayesbeam.response.linear import (
    ORDERS,
    STOPBAND,
    FrequencyGrid,
    drive_spectrum,
    force_spectrum,
    lagged_samples,
    release_spectrum,
    static_offset,
    transfer,
    unit_sample_responses,
)
from bayesbeam.response.signals import impact_window
from bayesbeam.response.system import LOW_RANK_MAX, ReferencePair, SecondOrderSystem, undamped_modes

PARAMETER_UNITS = {"EI": "N m^2"}
#: the name of the fitted offset of sensor <s> from its stated location (m), a parameter of every
#: model when beam.toml states the sensor's ``location_tolerance`` (see :meth:`BeamModel.placement`)
SENSOR_OFFSET = "dx_{}"
#: the name of the hammer's fitted offset from its stated location (m), a parameter of every model
#: of a force recording when beam.toml states ``[excitation] location_tolerance``
HAMMER_OFFSET = "dx_hammer"
#: the name of the fitted free length (m), a parameter of every model when beam.toml states
#: ``[beam] length_tolerance`` (see :meth:`BeamModel.operators`)
LENGTH = "l"
#: the set-up's fitted tolerances as ``bayesbeam models`` lists them, with their units
SETUP_PARAMETER_UNITS = {LENGTH: "m", SENSOR_OFFSET.format("<s>"): "m", HAMMER_OFFSET: "m"}
#: reference beams whose modes a model keeps (see :meth:`BeamModel._reference`): a sampler's
#: cloud spans a few grid points, an optimiser's path some more; 32 at N = 48 hold 2.5 MB
REFERENCES_KEPT = 32


def split_model(spec) -> tuple[tuple[str, ...], tuple[str, ...]]:
    """(mechanism names, effect names) of a model named by presets, mechanisms and effects.

    >>> split_model("q3+root_compliance")
    (('air', 'spatial_hysteresis'), ('root_compliance',))
    >>> split_model(["strain_rate", "measurement_delay"])
    (('strain_rate',), ('measurement_delay',))

    Unknown names stay with the mechanisms, whose resolver names the known ones in its error.
    """
    names = PRESETS.get(spec, spec.split("+")) if isinstance(spec, str) else tuple(spec)
    mechanisms, effects = [], []
    for name in filter(None, names):
        if name in PRESETS:
            mechanisms += PRESETS[name]
        elif name in effect_catalogue.REGISTRY:
            effects.append(name)
        else:
            mechanisms.append(name)
    return tuple(mechanisms), tuple(effects)


def join_model(spec: str, effects=()) -> str:
    """The model name of ``spec`` with ``effects`` joined in.

    >>> join_model("q2", ["sensor_mass", "axial_load"])
    'q2+sensor_mass+axial_load'
    """
    return "+".join([spec, *effects])


def resolve_model(spec, effects=None) -> tuple[tuple, tuple]:
    """(mechanism objects, effect objects) of ``spec`` (see :func:`split_model`) plus ``effects``;
    ValueError naming the unknown or repeated names."""
    mechanisms, joined = split_model(spec)
    named = tuple(e.name for e in effect_catalogue.resolve(effects))
    return resolve(mechanisms), effect_catalogue.resolve(joined + named)


def _check_nonlinear(model) -> None:
    """Refuse what the nonlinear integrator (:mod:`bayesbeam.response.nonlinear`) cannot do."""
    nonlinear = [e.name for e in model.effects if not e.linear]
    if not nonlinear:
        return
    if len(nonlinear) > 1:
        raise ValueError(f"one nonlinear effect at a time is supported, got {nonlinear}")
    if model.recording.excitation.kind == "free_decay":
        raise ValueError(f"{nonlinear[0]}: free_decay recordings cannot be simulated with a nonlinear effect: "
                         "the unknown state at `start` does not enter the response linearly; use a force or "
                         "release recording")
    extending = [e.name for e in model.effects if e.extends]
    if extending:
        raise ValueError(f"{nonlinear[0]} cannot be combined with {', '.join(extending)}: the nonlinear integrator "
                         "acts on the beam's degrees of freedom alone, not on an attached body's own")
    memory = [m.name for m in model.mechanisms if m.hereditary]
    if memory:
        raise ValueError(f"{nonlinear[0]} cannot be combined with a memory mechanism ({', '.join(memory)}): "
                         "the nonlinear integrator needs a state-space model")


def padded(a: np.ndarray | None, size: int) -> np.ndarray | None:
    """Rows (or a vector) on the beam's degrees of freedom, extended by zeros to ``size``: the
    sensors, the load and the memory term do not act on an effect's own degrees of freedom."""
    if a is None or a.shape[-1] == size:
        return a
    return np.pad(a, [(0, 0)] * (a.ndim - 1) + [(0, size - a.shape[-1])])


def _check_requirements(model) -> None:
    """Refuse a component without those it needs (the root dashpot without the root spring)."""
    names = [c.name for c in model.components]
    for c in model.components:
        missing = [r for r in c.requires if r not in names]
        if missing:
            raise ValueError(f"{c.name} needs {', '.join(missing)} in the same model: "
                             f"use {'+'.join(names + missing)}")


def _fitted_offsets(recording: Recording) -> dict[str, int]:
    """{``dx_<s>``: sensor index} of the sensors whose location beam.toml states with a tolerance > 0."""
    tolerances = recording.setup.location_tolerances
    return {SENSOR_OFFSET.format(s.name): i for i, (s, tol) in enumerate(zip(recording.sensors, tolerances))
            if tol > 0}


def _stated_masses(recording: Recording) -> dict[int, float]:
    """{sensor index: mass (kg)} of the sensors whose own mass beam.toml states (> 0)."""
    return {i: m for i, m in enumerate(recording.setup.sensor_masses) if m}


def _differ(a: np.ndarray | None, b: np.ndarray | None) -> bool:
    """Whether two optional matrices differ (None and None do not)."""
    return (a is None) != (b is None) or (a is not None and not np.array_equal(a, b))


class BeamModel:
    """A cantilever with tip body, damping mechanisms, and one recording's test set-up.

    Parameters
    ----------
    recording : Recording
        Supplies the beam (length, rho*A), tip body (m_T, J), excitation, sensors and time grid.
    mechanisms : str or sequence of str
        A preset (``"q1"``, ``"q2"``, ``"q3"``), a ``+``-joined string or a list of names; effect
        names may be joined in too (``"q3+root_compliance"``, see :func:`split_model`).
    n_intervals : int
        Spline grid intervals N (the model has N + degree - 2 degrees of freedom).
    force_window : bool or None
        Apply the impact force window (:func:`bayesbeam.response.signals.impact_window`) to a
        measured force; ``None`` (default) means on for ``kind = "force"`` recordings.
    effects : str or sequence of str, optional
        Missing-physics effects (:mod:`bayesbeam.physics.effects`) added to the damping model.
    degree : int
        Polynomial degree of the B-splines: 3 (cubic, the paper's) or higher; quintic splines
        reach a given eigenvalue accuracy with fewer degrees of freedom
        (:mod:`bayesbeam.physics.basis`).
    """

    def __init__(self, recording: Recording, mechanisms="q1", n_intervals: int = 16,
                 force_window: bool | None = None, effects=None, *, degree: int = 3):
        self.recording = recording
        # bound to the recording: a mechanism may read its description (thermoelastic: [material])
        self.mechanisms, self.effects = (tuple(c.bind(recording) for c in group)
                                         for group in resolve_model(mechanisms, effects))
        _check_requirements(self)
        self.n_intervals, self.degree = int(n_intervals), int(degree)
        beam, tip = recording.beam, recording.tip
        root = combined_root(e.root for e in self.effects)     # a spring and a base together: "free"
        self.ops = BeamOperators(SplineBasis(beam.length, self.n_intervals, root, self.degree), beam.rho_a,
                                 tip.mass, tip.rotary_inertia)
        exc = recording.excitation
        self.setup = Setup(tuple(s.location for s in recording.sensors),
                           exc.location if exc.kind == "force" else None)
        self.rows = self.ops.rows([s.location for s in recording.sensors])
        self.offsets = _fitted_offsets(recording)
        self.fits_length = recording.setup.length_tolerance > 0
        self.fits_hammer = exc.kind == "force" and recording.setup.excitation_location_tolerance > 0
        self.stated_masses = _stated_masses(recording)
        self._stretched: tuple[float, BeamOperators] | None = None    # the last length's operators
        self.orders = np.array([ORDERS[s.quantity] for s in recording.sensors])
        _check_nonlinear(self)
        self.grid = FrequencyGrid(recording.n_samples, recording.dt)
        self.force = self._conditioned_force(force_window)
        self.load, self.drive = self._input()
        self._references: dict[tuple, tuple[np.ndarray, ...]] = {}

    @classmethod
    def from_recording(cls, recording: Recording, mechanisms="q1", n_intervals: int = 16,
                       force_window: bool | None = None, effects=None, *, degree: int = 3) -> BeamModel:
        """The model of ``recording`` under ``mechanisms`` and ``effects`` (see the class docstring)."""
        return cls(recording, mechanisms, n_intervals, force_window, effects, degree=degree)

    # ------------------------------------------------------------------ parameters
    @property
    def name(self) -> str:
        return "+".join(c.name for c in self.components) or "undamped"

    @property
    def components(self) -> tuple:
        """The damping mechanisms, then the effects."""
        return self.mechanisms + self.effects

    @cached_property
    def parameter_names(self) -> tuple[str, ...]:
        """Names of the free parameters, in order: EI, each mechanism's, each effect's, then the
        free length ``l`` when beam.toml states its tolerance, the offset ``dx_<s>`` of each
        sensor whose location it states with a tolerance, and the hammer's ``dx_hammer`` when it
        states the hammer's."""
        names = ["EI"]
        for c in self.components:
            names += [p for p in c.parameters if p not in c.defaults]
        return (tuple(names) + ((LENGTH,) if self.fits_length else ()) + tuple(self.offsets)
                + ((HAMMER_OFFSET,) if self.fits_hammer else ()))

    @cached_property
    def units(self) -> dict[str, str]:
        out = dict(PARAMETER_UNITS)
        for c in self.components:
            out.update(c.units)
        out.update(dict.fromkeys(self.offsets, "m"))
        out.update({name: "m" for name, fitted in ((LENGTH, self.fits_length), (HAMMER_OFFSET, self.fits_hammer))
                    if fitted})
        return out

    def values(self, params: Mapping[str, float] | Sequence[float]) -> dict[str, float]:
        """Complete, checked parameter dict (defaults filled in); ValueError if not physical."""
        if not isinstance(params, Mapping):
            params = dict(zip(self.parameter_names, np.asarray(params, dtype=float), strict=True))
        known = set(self.parameter_names)
        for c in self.components:
            known.update(c.parameters)
        unknown = sorted(set(params) - known)
        if unknown:
            raise ValueError(f"unknown parameter(s) {unknown} for model {self.name}; "
                             f"it takes {sorted(known)}")
        missing = [p for p in self.parameter_names if p not in params]
        if missing:
            listed = ", ".join(f"{p} ({self.units[p]})" for p in missing)
            raise ValueError(f"model {self.name} needs parameter(s) {listed}")
        out = {k: float(v) for k, v in params.items()}
        for c in self.components:
            for key, default in c.defaults.items():
                out.setdefault(key, default)
            c.check(out)
        if not (np.isfinite(out["EI"]) and out["EI"] > 0):
            raise ValueError(f"EI = {out['EI']!r} N m^2 is not physical (must be finite and > 0)")
        self._check_positions(out)
        return out

    def _check_positions(self, v: dict[str, float]) -> None:
        """ValueError when the fitted length or a fitted sensor or hammer offset puts a sensor or
        the hammer off the beam."""
        if not self._moves:
            return
        if self.fits_length and not (np.isfinite(v[LENGTH]) and v[LENGTH] > 0):
            raise ValueError(f"{LENGTH} = {v[LENGTH]!r} m is not physical (must be finite and > 0)")
        length, setup = self._length(v), self._setup_at(v)
        placed = [(f"sensor {s.name!r}", x) for s, x in zip(self.recording.sensors, setup.sensor_locations)]
        if setup.force_location is not None:
            placed.append(("the hammer", setup.force_location))
        fitted = ", ".join(f"{n} = {v[n]!r} m" for n in self.parameter_names[-self._n_placing:])
        for what, x in placed:
            if not (np.isfinite(x) and 0.0 <= x <= length):
                raise ValueError(f"{fitted} put {what} at {x!r} m, off the beam [0, {length!r}] m")

    @property
    def _moves(self) -> bool:
        """Whether some fitted parameter moves a sensor or the hammer (a length, an offset)."""
        return bool(self.offsets or self.fits_length or self.fits_hammer)

    @property
    def _n_placing(self) -> int:
        """How many of the last :attr:`parameter_names` place the beam, the sensors and the hammer."""
        return int(self.fits_length) + len(self.offsets) + int(self.fits_hammer)

    def _length(self, v: dict[str, float]) -> float:
        """The free length at these values (m): the fitted ``l``, else the stated one."""
        return v[LENGTH] if self.fits_length else self.ops.length

    def operators(self, v: dict[str, float]) -> BeamOperators:
        """The Galerkin forms of the beam at values checked by :meth:`values`: the model's own
        (:attr:`ops`) at the stated length, else those of the free length ``l``
        (:meth:`BeamOperators.at_length`: the same grid N stretched to l, exact scaling).

        ``l`` is nearly degenerate with EI: without a tip body the frequencies are
        (beta_m l)^2 sqrt(EI / (rho_a l^4)) / (2 pi), so only EI / l^4 is seen, apart from where
        the sensors and the hammer sit and the tip body's share; its prior (the stated tolerance)
        carries it.
        """
        if not self.fits_length:
            return self.ops
        length = v[LENGTH]
        if self._stretched is None or self._stretched[0] != length:
            self._stretched = (length, self.ops.at_length(length))
        return self._stretched[1]

    def placement(self, v: dict[str, float]) -> tuple[np.ndarray, Setup]:
        """(point rows of the sensors, the :class:`Setup` the effects see) at values checked by
        :meth:`values`: the sensors sit at their stated locations plus the fitted offsets
        ``dx_<s>``, the hammer at its stated location plus ``dx_hammer``, and a mass placed at a
        sensor (the sensor's own mass, stated or fitted) moves with it.

        With a fitted free length l, the clamp is taken to grip an uncertain length of the bar:
        every sensor and the hammer keep their stated distance from the free end (each moves by
        l - l_stated from the clamp), so a sensor stated at the tip stays at the tip.

        Without fitted offsets or length both are the model's own, built once (:attr:`rows`,
        :attr:`setup`); a fitted hammer offset alone leaves the sensors' rows as they are.
        """
        if not self._moves:
            return self.rows, self.setup
        setup = self._setup_at(v)
        if not (self.offsets or self.fits_length):
            return self.rows, setup
        return self.operators(v).rows(setup.sensor_locations), setup

    def _setup_at(self, v: dict[str, float]) -> Setup:
        """The :class:`Setup` of :meth:`placement` alone (no rows evaluated)."""
        if not self._moves:
            return self.setup
        shift = self._length(v) - self.ops.length
        locations = [x + shift for x in self.setup.sensor_locations]
        for name, index in self.offsets.items():
            locations[index] += v[name]
        force = self.setup.force_location
        if force is not None:
            force += shift + (v[HAMMER_OFFSET] if self.fits_hammer else 0.0)
        return Setup(tuple(locations), force)

    def load_at(self, v: dict[str, float]) -> np.ndarray | None:
        """The load vector at values checked by :meth:`values`: the hammer's point row (where
        :meth:`placement` puts it) or the tip row of a release; the model's own (:attr:`load`)
        at the stated length and hammer location."""
        if not (self.fits_length or self.fits_hammer) or self.load is None:
            return self.load
        ops, exc = self.operators(v), self.recording.excitation
        return ops.rows([self._setup_at(v).force_location])[0] if exc.kind == "force" else ops.tip_value

    # ------------------------------------------------------------------ physics
    def system(self, params) -> SecondOrderSystem:
        """The Galerkin system M w'' + D w' + K w - (memory) = B f at these parameters."""
        return self._system(self.values(params))

    def _system(self, v: dict[str, float]) -> SecondOrderSystem:
        """:meth:`system` at values already checked by :meth:`values`."""
        damping, relaxation = self._damping(v)
        mass, stiffness, modes = self._mass_stiffness(v)
        memory = self.operators(v).K0 if relaxation else None
        if self._extends:
            mass, damping, stiffness, memory = self._extended(v, mass, damping, stiffness, memory)
            modes = None
        reference = self._reference(v) if modes is None and self._departures is not None else None
        system = SecondOrderSystem(mass, damping, stiffness, relaxation, memory, modes, self._departures, reference)
        if relaxation is not None:
            system.check_stable()
        return system

    @cached_property
    def _extends(self) -> bool:
        """Whether some effect brings degrees of freedom of its own (:meth:`Effect.extend`)."""
        return any(e.extends for e in self.effects)

    def _extended(self, v: dict[str, float], mass, damping, stiffness, memory):
        """The matrices with every effect's own degrees of freedom appended (:meth:`Effect.extend`),
        and the memory term's matrix padded to their size: hysteresis acts on the beam's strain alone."""
        ops, setup = self.operators(v), self._setup_at(v)
        for e in self.effects:
            mass, damping, stiffness = e.extend(ops, v, setup, mass, damping, stiffness)
        return mass, damping, stiffness, None if memory is None else padded(padded(memory, len(mass)).T, len(mass))

    def _damping(self, v: dict[str, float]):
        """The mechanisms' and effects' summed damping matrix and the relaxation transform (None
        without memory)."""
        ops = self.operators(v)
        damping = np.zeros((ops.size, ops.size))
        relaxations = []
        for m in self.mechanisms:
            d = m.damping(ops, v)
            if d is not None:
                damping = damping + d
            g = m.relaxation(v)
            if g is not None:
                relaxations.append(g)
        setup = self._setup_at(v)
        for e in self.effects:
            d = e.damping(ops, v, setup)
            if d is not None:
                damping = damping + d
        relaxation = None
        if relaxations:
            relaxation = relaxations[0] if len(relaxations) == 1 else (
                lambda s: sum(g(s) for g in relaxations))
        return damping, relaxation

    def _mass_stiffness(self, v: dict[str, float]):
        """M and K with the effects' additions, and the undamped modes when known in advance.

        Without added mass or stiffness (none, or zero at these values) M is parameter-free and
        K = EI K0, whose modes are (EI omega_0^2, Phi_0) of (K0, M): computed once per model,
        not once per call, and the same for a model with a vanishing effect as without it. With
        a fitted length M and K change with l, and with a stated sensor mass at a fitted sensor
        position M changes with it: the system finds their modes on each call.
        """
        ops, setup = self.operators(v), self._setup_at(v)
        mass, stiffness, added = self._with_effects([v] * len(self.effects), self.carried_mass(ops, setup),
                                                    v["EI"] * ops.K0, setup, ops)
        if added or self.fits_length or self._mass_follows_sensors:
            return mass, stiffness, None
        lam0, phi0 = self._unit_modes
        return mass, stiffness, (v["EI"] * lam0, phi0)

    def carried_mass(self, ops: BeamOperators, setup: Setup) -> np.ndarray:
        """The mass matrix every model carries: the beam's and the tip body's (``ops.M``) plus the
        masses beam.toml states on the sensors, a point mass m_j r_j r_j^T at each sensor's
        placement in ``setup`` (kg in generalised coordinates). Without stated masses it is
        ``ops.M`` itself. The ``sensor_mass`` effect replaces these by its fitted masses (it adds
        their differences, :mod:`bayesbeam.physics.effects.sensor_mass`)."""
        mass = ops.M
        for index, m in self.stated_masses.items():
            mass = mass + m * ops.point_matrix(setup.sensor_locations[index])
        return mass

    @cached_property
    def _mass_follows_sensors(self) -> bool:
        """Whether a stated sensor mass sits at a sensor whose position is fitted (an offset)."""
        return any(SENSOR_OFFSET.format(self.recording.sensors[i].name) in self.offsets for i in self.stated_masses)

    def _with_effects(self, points, mass: np.ndarray, stiffness: np.ndarray, setup: Setup, ops: BeamOperators):
        """``mass`` and ``stiffness`` plus each effect's added matrices at its values in ``points``
        (one dict per effect), on the beam of ``ops`` with sensors placed as in ``setup``, and
        whether any effect added a nonzero matrix."""
        added = False
        for e, p in zip(self.effects, points, strict=True):
            added_mass, added_stiffness = e.mass(ops, p, setup), e.stiffness(ops, p, setup)
            if added_mass is not None and np.any(added_mass):
                mass, added = mass + added_mass, True
            if added_stiffness is not None and np.any(added_stiffness):
                stiffness, added = stiffness + added_stiffness, True
        return mass, stiffness, added

    @cached_property
    def _departures(self) -> np.ndarray | None:
        """Orthonormal directions (n, r) along which M and K depart from rho_a M_0 and EI K_0: the
        tip body's and the effects' (see :attr:`SecondOrderSystem.departures`); an effect's damping
        (the root dashpot) departs from a combination of M_0 and K_0 along its own directions too.

        Each effect's matrix scales with its parameter, so the directions are parameter-free:
        found once, with every effect at unit values. None when some mechanism's damping is not
        a combination of M_0 and K_0 (then the bare modes do not diagonalise it), when nothing
        departs, when the rank exceeds what the ``low_rank`` form takes (an axial load's
        geometric stiffness has full rank), when an effect brings degrees of freedom of its own
        (the system is then larger than the beam), when an effect's matrices move with a fitted sensor
        position (the sensor's own mass), or a stated sensor mass does: then the directions change
        with the parameters, or when the length is fitted: the reference beam's modes would change
        with it.
        """
        if (not all(m.bare_modal for m in self.mechanisms) or self.fits_length or self._extends
                or self._effects_follow_sensors or self._mass_follows_sensors):
            return None
        ops, unit = self.ops, self._unit_values
        blocks = [self.carried_mass(ops, self.setup) - ops.rho_a * ops.M0]
        for e in self.effects:
            blocks += [b for b in (e.mass(ops, unit, self.setup), e.stiffness(ops, unit, self.setup),
                                   e.damping(ops, unit, self.setup)) if b is not None]
        u, sv, _ = np.linalg.svd(np.hstack(blocks), full_matrices=False)
        rank = int(np.sum(sv > 1e-12 * sv[0])) if sv[0] > 0 else 0
        return u[:, :rank] if 0 < rank <= LOW_RANK_MAX else None

    @cached_property
    def _effects_follow_sensors(self) -> bool:
        """Whether some effect's matrices change when the fitted sensor offsets move the sensors
        (found by moving every fitted sensor towards mid-span by half its tolerance, at most a
        quarter of the length, so that it stays on the beam)."""
        if not self.offsets or not self.effects:
            return False
        tolerances = self.recording.setup.location_tolerances
        half_span = 0.5 * self.ops.length
        moved = self._setup_at({LENGTH: self.ops.length, HAMMER_OFFSET: 0.0,
                                **{name: np.copysign(0.5 * min(tolerances[i], half_span),
                                                     half_span - self.setup.sensor_locations[i])
                                   for name, i in self.offsets.items()}})
        unit = self._unit_values
        return any(_differ(form(self.ops, unit, self.setup), form(self.ops, unit, moved))
                   for e in self.effects for form in (e.mass, e.stiffness, e.damping))

    @cached_property
    def _unit_values(self) -> dict[str, float]:
        """Each effect's parameters one unit away from where the effect vanishes (1 where it
        vanishes at 0 or only in a limit), at which its matrices show their directions."""
        absent = {p: a for e in self.effects for p, a in e.absent.items() if np.isfinite(a)}
        return {p: 1.0 + absent.get(p, 0.0) for e in self.effects for p in e.parameters}

    def _reference(self, v: dict[str, float]) -> ReferencePair:
        """The reference beam (M_r, EI K_1) near these values that the effects depart from along
        :attr:`_departures` (see :meth:`Effect.reference`), with its modes (EI omega^2 per unit EI,
        Phi). Its matrices and modes are cached per grid point (the last
        :data:`REFERENCES_KEPT`), so the ``low_rank`` form solves an eigenproblem only when the
        parameters reach a new one."""
        points = [e.reference(v) for e in self.effects]
        key = tuple(sorted(item for p in points for item in p.items()))
        cached = self._references.pop(key, None)
        if cached is None:
            m_r, k_1, _ = self._with_effects(points, self._carried, self.ops.K0, self.setup, self.ops)
            cached = (m_r, k_1, *undamped_modes(k_1, m_r))
            if len(self._references) >= REFERENCES_KEPT:
                del self._references[next(iter(self._references))]     # the least recently used
        self._references[key] = cached
        m_r, k_1, lam_1, phi_1 = cached
        return ReferencePair(m_r, v["EI"] * k_1, v["EI"] * lam_1, phi_1)

    @cached_property
    def _unit_modes(self) -> tuple[np.ndarray, np.ndarray]:
        """Undamped modes of (K0, M): omega^2 per unit EI and Phi, M with the stated sensor masses."""
        return undamped_modes(self.ops.K0, self._carried)

    @cached_property
    def _carried(self) -> np.ndarray:
        """:meth:`carried_mass` with every sensor at its stated location."""
        return self.carried_mass(self.ops, self.setup)

    def poles(self, params) -> np.ndarray:
        """Oscillatory poles (rad/s), Im > 0, sorted by natural frequency."""
        return self.system(params).poles()

    def natural_frequencies(self, params, n_modes: int | None = None) -> np.ndarray:
        """Undamped-equivalent natural frequencies |p|/(2 pi) (Hz), lowest first."""
        return np.abs(self.poles(params))[:n_modes] / (2 * np.pi)

    def mode_labels(self, params) -> list[str]:
        """Each oscillatory pole's name (:meth:`poles`' order): "mode k", k numbering the beam's modes
        alone, or the ``own_mode`` words of the effect whose own mass carries more than half of that
        mode's kinetic energy (an attached body's, a base's).

        The share is phi^T M_e phi of the undamped mode phi (mass-normalised) nearest the pole,
        M_e the effect's mass: a body far below the beam's first mode carries nearly all of its
        mode's energy and the beam's first mode stays "mode 1"; a body tuned to a beam mode shares
        the pair's energy about equally, and the pair is named by which side of 1/2 each falls.
        """
        v = self.values(params)
        system = self._system(v)
        poles = system.poles()
        owned = self._own_masses(v, system.size)
        owners = [None] * len(poles)
        if owned:
            w, phi = np.sqrt(np.abs(system.undamped[0])), system.undamped[1]
            nearest = np.argmin(np.abs(w[None] - np.abs(poles)[:, None]), axis=1)
            shares = {e: np.einsum("ij,ik,kj->j", phi, m, phi)[nearest] for e, m in owned.items()}
            owners = [next((e for e, share in shares.items() if share[i] > 0.5), None) for i in range(len(poles))]
        beam_modes = np.cumsum([owner is None for owner in owners])
        words = {e.name: e.own_mode for e in self.effects}
        return [f"mode {k}" if owner is None else words[owner] for owner, k in zip(owners, beam_modes)]

    def _own_masses(self, v: dict[str, float], size: int) -> dict:
        """Each effect with an ``own_mode``: its mass matrix (size, size) alone, the one it adds
        (:meth:`Effect.mass`) and that of the degrees of freedom it appends (:meth:`Effect.extend`)."""
        ops, setup = self.operators(v), self._setup_at(v)
        out, grown = {}, ops.size
        for e in self.effects:
            zero = np.zeros((grown, grown))
            appended = e.extend(ops, v, setup, zero, zero, zero)[0]
            if e.own_mode:
                own = np.pad(appended, (0, size - len(appended)))
                added = e.mass(ops, v, setup)
                if added is not None:
                    own[: ops.size, : ops.size] += added
                out[e.name] = own
            grown = len(appended)
        return out

    def modal_damping_ratios(self, params, n_modes: int | None = None) -> np.ndarray:
        """Modal damping ratios zeta = -Re(p)/|p| (fraction, not %), lowest mode first."""
        p = self.poles(params)[:n_modes]
        return -p.real / np.abs(p)

    # ------------------------------------------------------------------ response
    def simulate(self, params, initial: np.ndarray | None = None) -> np.ndarray:
        """Sensor signals (n_samples, n_sensors) in SI units on the recording's time grid.

        For ``free_decay`` recordings pass ``initial``, the coefficients of
        :meth:`free_decay_basis` (see :meth:`fit_initial`); samples before ``start`` are zero.
        """
        if any(not e.linear for e in self.effects):
            from bayesbeam.response.nonlinear import simulate_nonlinear
            return simulate_nonlinear(self, params, initial)
        exc = self.recording.excitation
        if exc.kind == "free_decay":
            if initial is None:
                raise ValueError("free_decay recording: the state at `start` is unknown; pass "
                                 "initial= (coefficients of free_decay_basis, e.g. from fit_initial)")
            return self.free_decay_basis(params) @ np.asarray(initial, dtype=float)
        # one check of the parameters per call: simulate sits in the sampler's inner loop
        values = self.values(params)
        return self.linear_response(self._system(values), values)

    def linear_response(self, system: SecondOrderSystem, values: dict[str, float]) -> np.ndarray:
        """The linear system's response to the recording's input (n_samples, n_sensors).

        ``values`` (checked by :meth:`values`) supply the delay; the nonlinear integrator adds
        its nonlinear part to this.
        """
        return self._output(*self._placed_transfer(system, values), values)

    def _placed_transfer(self, system: SecondOrderSystem, values: dict[str, float]):
        """(the transfer function on the grid, a release's static offset (n_sensors,) or None) at
        values checked by :meth:`values`, with the sensors and the load placed once for both."""
        rows, load = padded(self.placement(values)[0], system.size), padded(self.load_at(values), system.size)
        exc = self.recording.excitation
        static = static_offset(system, rows, self.orders, load, exc.tip_load) if exc.kind == "release" else None
        return transfer(system, self.grid, rows, load), static

    def _output(self, h: np.ndarray, static: np.ndarray | None, values: dict[str, float]) -> np.ndarray:
        """:meth:`linear_response` from :meth:`_placed_transfer`'s transfer function and offset."""
        y = self.grid.samples(h * self._delayed(self.drive, values))
        if static is not None:
            # the rest before release is DC: the chain passes it with its response at s = 0
            y += self._dc_gain(values) * static[None, :]
        return y

    def simulate_with_impulses(self, params, index: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(:meth:`simulate`, responses (n_samples, n_sensors, K) to a unit force sample (N) at
        each sample of ``index``) for a measured-force recording.

        The columns are the sensitivity of the response to the force samples, which the
        likelihood needs to marginalise the force channel's noise. For a linear model both
        come from one evaluation of the transfer function. With a nonlinear effect the columns
        are those of its linear part (the effect linearised about rest; the force noise drives
        a response a hundred times smaller than the signal, so its own nonlinearity is
        negligible).
        """
        y, unit = self._with_unit_response(params)
        return y, unit_sample_responses(self.grid, unit, index)

    def sample_spectra(self, position: np.ndarray, weights: np.ndarray) -> np.ndarray:
        """Input spectra (n_freq, K) on the grid of K force inputs, input k being the samples
        ``weights[:, k]`` (N, in samples of this record) at the fractional sample ``position``
        (J,): a sample between two of the record is a band-limited impulse at its own time."""
        delays = np.stack([self.grid.delay(p * self.recording.dt) for p in position], axis=1)
        return delays @ weights

    def simulate_with_inputs(self, params, spectra: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(:meth:`simulate`, responses (n_samples, n_sensors, K) to the force inputs of
        :meth:`sample_spectra`) for a measured-force recording; :meth:`simulate_with_impulses`
        for inputs between the record's samples (its notes on nonlinear effects hold)."""
        y, unit = self._with_unit_response(params)
        return y, self.grid.samples(unit[:, :, None] * spectra[:, None, :])

    def _with_unit_response(self, params) -> tuple[np.ndarray, np.ndarray]:
        """(:meth:`simulate`, the spectrum (n_freq, n_sensors) of the response to a unit force
        sample at t = 0) from one evaluation of the transfer function."""
        if self.recording.excitation.kind != "force":
            raise ValueError("force-sample responses need a recording with a measured force")
        values = self.values(params)
        h, static = self._placed_transfer(self._system(values), values)
        y = self.simulate(values) if any(not e.linear for e in self.effects) else self._output(h, static, values)
        return y, h * self._delayed(self._unit_drive, values)

    def _delayed(self, drive: np.ndarray, values: dict[str, float]) -> np.ndarray:
        """``drive`` with the response channels' delay e^{-s tau} and the measurement chain's
        response (:meth:`channel_response`) applied."""
        tau, chain = self._delay(values), self.channel_response(values, self.grid.s)
        out = drive if tau == 0 else drive * self.grid.delay(tau)[:, None]
        return out if chain is None else out * chain

    def channel_response(self, values: dict[str, float], s: np.ndarray) -> np.ndarray | None:
        """The response channels' measurement chain at complex frequencies ``s`` (1/s), every effect's
        :meth:`~bayesbeam.physics.effects.Effect.channel_response` multiplied, (len(s), n_sensors);
        None where no effect filters the channels. ``values`` checked by :meth:`values`."""
        chain = None
        for effect in self.effects:
            part = effect.channel_response(values, s)
            if part is not None:
                chain = np.broadcast_to(part, (len(s), len(self.orders))) if chain is None else chain * part
        return chain

    def _dc_gain(self, values: dict[str, float]) -> np.ndarray | float:
        """The measurement chain at s = 0, per sensor (1 without one)."""
        chain = self.channel_response(values, np.zeros(1))
        return 1.0 if chain is None else chain[0].real

    def _chain_transient(self, values: dict[str, float], poles: np.ndarray) -> list[tuple[complex, np.ndarray]]:
        """[(q_k, weight (n_sensors, n_modes))] for each own pole q_k of the measurement chain: a mode
        e^{p t} seen from rest through the chain H adds the residue of H(s)/(s - p) at q_k times
        e^{q_k t}, i.e. r_k / (q_k - p) times the other effects' response at q_k
        (:meth:`~bayesbeam.physics.effects.Effect.channel_poles`)."""
        terms = []
        for effect in self.effects:
            for q, r in zip(*effect.channel_poles(values)):
                rest = np.ones((1, len(self.orders)), dtype=complex)
                for other in self.effects:
                    part = other.channel_response(values, np.array([q])) if other is not effect else None
                    rest = rest if part is None else rest * part
                terms.append((q, rest[0][:, None] * (r / (q - poles))[None, :]))
        return terms

    @cached_property
    def _unit_drive(self) -> np.ndarray:
        """The drive of a unit force sample at t = 0 (:func:`drive_spectrum` of a flat spectrum)."""
        return drive_spectrum(self.grid, self.orders, np.ones(self.grid.freq.size))

    def delay(self, params) -> float:
        """Total delay of the response channels behind the motion (s)."""
        return self._delay(self.values(params))

    def _delay(self, v: dict[str, float]) -> float:
        return float(sum(e.delay(v) for e in self.effects))

    @cached_property
    def fit_mask(self) -> np.ndarray:
        """Samples that carry information about the model (all but those before a free decay)."""
        exc = self.recording.excitation
        time = self.recording.time
        return time >= exc.start if exc.kind == "free_decay" else np.ones(time.size, bool)

    def free_decay_basis(self, params, samples: slice = slice(None)) -> np.ndarray:
        """Free-decay responses as a linear map of the unknown state: (n, n_sensors, 2 n_modes),
        at the recording's samples ``samples`` (default all).

        The free response from ``start`` is a sum of damped modes,
        ``y_s(t) = Re sum_j c_sj p_j^q A_j exp(p_j (t - start))`` with complex amplitudes A_j;
        the columns are the responses to Re A_j = 1 and Im A_j = 1 for every mode below the
        DAQ stopband (0.5 fs). c_sj is the mode shape (null vector of Z(p_j)) at sensor s.
        Exact for models without memory; with time hysteresis it keeps the pole part and omits
        the small non-oscillatory creep of the memory's branch cut. A measurement chain
        (:meth:`channel_response`, e.g. the ``high_pass`` effect) multiplies mode j by H(p_j) and
        adds its own poles' terms, the chain taken at rest at ``start`` (:meth:`_chain_transient`).
        """
        values = self.values(params)
        system = self._system(values)
        poles = system.poles(below=2 * np.pi * STOPBAND * self.recording.fs)
        shapes = system.mode_shapes(poles)
        tau, mask = self.recording.time[samples] - self.recording.excitation.start, self.fit_mask[samples]
        waves = np.exp(np.outer(np.where(mask, tau, 0.0), poles))
        waves[~mask] = 0.0
        shown = (padded(self.placement(values)[0], system.size) @ shapes) * poles[None, :] ** self.orders[:, None]
        delay = self._delay(values)
        gain = shown * np.exp(-poles * delay)[None, :]
        chain = self.channel_response(values, poles)
        resp = waves[:, None, :] * (gain if chain is None else gain * chain.T)[None, :, :]
        # the chain's own poles, charged by each mode's step where the (delayed) decay starts
        for q, weight in self._chain_transient(values, poles):
            charge = np.where(mask, np.exp(q * (np.where(mask, tau, 0.0) - delay)), 0.0)
            resp = resp + charge[:, None, None] * (shown * weight)[None, :, :]
        return np.concatenate([resp.real, -resp.imag], axis=2)

    def fit_initial(self, params, signals: np.ndarray | None = None,
                    weights: np.ndarray | None = None, samples: slice = slice(None)) -> np.ndarray:
        """Least-squares coefficients of :meth:`free_decay_basis` for ``signals`` (variable projection).

        ``weights`` (n_sensors,) scale each channel's residual, e.g. 1/noise sd; default 1/RMS.
        ``samples``: the samples fitted (default all; those before ``start`` never count), e.g.
        the window a likelihood analyses: a record that runs on past it may decay differently
        there (a non-stationary damping, or a model whose damping is wrong), and fitted over
        all of it the amplitudes would not be the window's.
        """
        y = (self.recording.signals if signals is None else signals)[samples]
        mask = self.fit_mask[samples]
        if weights is None:
            weights = 1.0 / np.sqrt(np.mean(y[mask] ** 2, axis=0))
        basis = self.free_decay_basis(params, samples)[mask] * weights[None, :, None]
        a = basis.reshape(-1, basis.shape[-1])
        coef, *_ = linalg.lstsq(a, (y[mask] * weights[None, :]).ravel())
        return coef

    # ------------------------------------------------------------------ batches of parameter sets
    @property
    def batches(self) -> bool:
        """Whether :meth:`simulate_batch` evaluates its parameter sets together (linear models of
        force and release recordings); otherwise it calls :meth:`simulate` for each."""
        return self.recording.excitation.kind != "free_decay" and all(e.linear for e in self.effects)

    def simulate_batch(self, params: Sequence) -> np.ndarray:
        """:meth:`simulate` at each of P parameter sets: (n_samples, P, n_sensors).

        Each set's transfer function is its own; the inverse FFT is one for the batch.
        """
        if not self.batches:
            return np.stack([self.simulate(p) for p in params], axis=1)
        return self._batch(params)[0]

    def simulate_with_impulse_batch(self, params: Sequence, lags: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(:meth:`simulate_batch`, the response (len(lags), P, n_sensors) to a unit force sample (N)
        at t = 0, at the integer sample ``lags``) of a linear model of a measured-force recording.

        Column k of :meth:`simulate_with_impulses` is that response at lags n - index[k]
        (:func:`~bayesbeam.response.linear.unit_sample_responses`); ``lags`` lie in
        (-(n_fft - n), n).
        """
        if self.recording.excitation.kind != "force" or not self.batches:
            raise ValueError("batched force-sample responses need a linear model of a recording with a "
                             "measured force")
        y, unit = self._unit_batch(params)
        return y, lagged_samples(self.grid, fft.irfft(unit, self.grid.n_fft, axis=0), np.asarray(lags))

    def simulate_with_input_batch(self, params: Sequence, spectra: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(:meth:`simulate_batch`, responses (P, n_sensors, K, n_samples) to the force inputs of
        :meth:`sample_spectra`, time last) of a linear model of a measured-force recording."""
        if self.recording.excitation.kind != "force" or not self.batches:
            raise ValueError("batched force-input responses need a linear model of a recording with a "
                             "measured force")
        y, unit = self._unit_batch(params)
        return y, self.grid.samples_last(unit.transpose(1, 2, 0)[:, :, None, :] * spectra.T)

    def _batch(self, params: Sequence):
        """(outputs (n, P, c), the transfer functions (n_freq, P, c), the checked values of each set)."""
        values = [self.values(p) for p in params]
        systems = [self._system(v) for v in values]
        placed = [self._placed_transfer(s, v) for s, v in zip(systems, values)]
        h = np.stack([h_set for h_set, _ in placed], axis=1)                          # (n_freq, P, c)
        y = self.grid.samples(h * self._delayed_batch(self.drive, values))
        if self.recording.excitation.kind == "release":
            y += np.stack([self._dc_gain(v) * static for v, (_, static) in zip(values, placed)])[None]
        return y, h, values

    def _unit_batch(self, params: Sequence) -> tuple[np.ndarray, np.ndarray]:
        """(outputs (n, P, c), the spectra (n_freq, P, c) of the response to a unit force sample at t = 0)."""
        y, h, values = self._batch(params)
        return y, h * self._delayed_batch(self._unit_drive, values)

    def _delayed_batch(self, drive: np.ndarray, values: Sequence[dict]) -> np.ndarray:
        """:meth:`_delayed` for each set (n_freq, P, c); ``drive`` broadcast when no set is delayed."""
        if all(self._delay(v) == 0 and self.channel_response(v, self.grid.s[:1]) is None for v in values):
            return drive[:, None, :]
        return np.stack([self._delayed(drive, v) for v in values], axis=1)

    # ------------------------------------------------------------------ input
    def _input(self):
        """Load vector and the parameter-free drive spectrum (computed once per model)."""
        exc = self.recording.excitation
        if exc.kind == "force":
            load = self.ops.rows([exc.location])[0]
            spectrum = force_spectrum(self.grid, self.force)
        elif exc.kind == "release":
            load = self.ops.tip_value
            spectrum = release_spectrum(self.grid, exc.tip_load, t0=float(self.recording.time[0]))
        else:
            return None, None
        return load, drive_spectrum(self.grid, self.orders, spectrum)

    def _conditioned_force(self, force_window: bool | None) -> np.ndarray | None:
        rec = self.recording
        if rec.excitation.kind != "force":
            return None
        use = True if force_window is None else bool(force_window)
        return rec.force * impact_window(rec.force) if use else rec.force
