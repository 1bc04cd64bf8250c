"""Recordings: the typed objects, the checking reader and the atomic writer.

The format is the contract of ``docs/format.md``: a directory holding ``beam.toml``
(what was tested, how it was instrumented) and a CSV of uniformly sampled signals.
All quantities are SI; positions are metres from the clamp (x = 0).

The reader either returns a complete :class:`Recording` or raises
:class:`~bayesbeam.io.errors.RecordingError` naming the file, the key or line, and the fix:
nothing downstream ever sees a half-checked recording.
"""

from __future__ import annotations

import csv
import math
import os
import re
import shutil
import tomllib
import uuid
import warnings
from dataclasses import dataclass, field, fields, replace
from datetime import date, datetime
from datetime import time as clock_time
from functools import partial
from pathlib import Path

import numpy as np

from .errors import RecordingError
from .text import (
    COMMENT_PREFIXES,
    MAX_MAGNITUDE,
    STATED_DELIMITERS,
    CellTable,
    check_header,
    find_column,
    print_resolution,
    read_export_cells,
    split_unit,
    time_column,
    time_factor,
)
from .units import SI_UNITS, Unit, known_units, parse_unit

KINDS = ("force", "release", "free_decay")
QUANTITIES = ("acceleration", "velocity", "displacement")
MAX_TIME_JITTER = 1e-6
"""Largest accepted relative deviation of any time step from the mean step."""
MIN_SAMPLES = 256
"""Fewest samples a record may hold. Every channel is the output of the DAQ's anti-alias
low-pass, whose transition from 0.40 to 0.50 fs makes its impulse response last about
+-120 samples: a shorter record cannot hold one band-limited event, and the model's
exponential-window simulation amplifies its rounding errors beyond use."""
#: sampling steps (s) outside this range are refused: no data-acquisition system samples faster
#: than 1 GHz, and a step of days is not a vibration record (the model's frequency grid would
#: otherwise overflow)
STEP_RANGE = (1e-9, 1e5)
DEFAULT_CSV = "recording.csv"
DEFAULT_TIME_COLUMN = "time"

# Keys that `[excitation]` needs for each kind, besides `kind` itself.
_EXCITATION_KEYS = {"force": ("location", "column"), "release": ("tip_load",), "free_decay": ("start",)}
_BEAM_KEYS = ("length", "density", "area", "second_moment", "modulus")
_TIP_KEYS = ("mass", "rotary_inertia")
_SENSOR_KEYS = ("name", "location", "quantity", "column")
_RECORDING_KEYS = ("file", "time_column")
#: [recording] keys for a DAQ's own text export (docs/format.md); any of them sends the file
#: through the text-export reader
_EXPORT_KEYS = ("delimiter", "decimal", "sample_rate", "skip_lines")
#: keys of [[sensor]] and of a force's [excitation] that say how the channel's values become SI
_UNIT_KEYS = ("unit", "sensitivity", "scale")
_KNOWN_TABLES = ("beam", "tip", "excitation", "sensor", "recording", "setup")

# What each key holds, for the "Fix:" sentences.
_MEANING = {
    "length": "l in m",
    "density": "rho in kg/m^3",
    "area": "A in m^2",
    "second_moment": "I in m^4",
    "modulus": "nominal E in Pa",
    "mass": "a mass in kg: m_T in [tip], the sensor's own mass in [[sensor]]",
    "rotary_inertia": "tip rotary inertia J in kg m^2",
    "location": "position in m from the clamp",
    "tip_load": "static tip load in N",
    "start": "time in s from which no force acts",
    "kind": '"force", "release" or "free_decay"',
    "quantity": '"acceleration", "velocity" or "displacement"',
    "name": "a sensor name",
    "column": "a CSV column name",
    "file": "the CSV file name",
    "time_column": "the CSV column holding the time in s",
    "delimiter": '"," ";" "\\t" (tab) or " " (runs of whitespace)',
    "decimal": '"." or ","',
    "sample_rate": "the sampling rate in Hz",
    "skip_lines": "how many lines of the file to skip before its header",
    "unit": "the unit of the channel's values (docs/format.md lists them)",
    "sensitivity": "V per unit of the channel's quantity",
    "scale": "SI units per recorded unit (e.g. m/s^2 per V)",
    "thermal_expansion": "alpha_T in 1/K",
    "temperature": "T0, the beam's temperature in K",
    "specific_heat": "c_p in J/(kg K)",
    "thermal_diffusivity": "chi in m^2/s",
    "thickness": "h, the beam's depth in the plane of bending, in m",
    "material_name": '"steel" or "aluminium"',
    "length_tolerance": "in m: the free length lies within length +- this",
    "location_tolerance": "in m: the sensor, or the hammer in [excitation], sits within location +- this",
    "mass_tolerance": "in kg: the tip mass lies within mass +- this",
    "rotary_inertia_tolerance": "in kg m^2: the tip's rotary inertia lies within rotary_inertia +- this",
    "high_pass_hz": "the sensor's low-frequency corner in Hz from its data sheet (leave it out for a DC-coupled "
                    "sensor)",
    "gain_tolerance": "the sensitivity's calibration uncertainty as a fraction, e.g. 0.02",
    "mains_hz": "the mains frequency in Hz where the test ran, 50 or 60",
}

# Optional keys inside the format's own tables that state what is known about the set-up
# (docs/format.md). The format carries keys it does not name along without refusing them, so
# they are kept verbatim at load (Recording.setup_keys) and checked when read (Recording.setup).
_SETUP_KEYS = {"beam": ("length_tolerance",), "tip": ("mass_tolerance", "rotary_inertia_tolerance"),
               "sensor": ("mass", "location_tolerance", "high_pass_hz", "gain_tolerance"),
               "excitation": ("location_tolerance",), "setup": ("mains_hz",)}

# The optional [material] table (docs/format.md): what the thermoelastic damping mechanism
# predicts its damping from. Named materials supply handbook values of the three constants
# that depend on the material alone; temperature and thickness describe the test and are
# always given.
_MATERIAL_KEYS = ("thermal_expansion", "temperature", "specific_heat", "thermal_diffusivity", "thickness")
MATERIALS = {
    # carbon steel: k = 50 W/(m K), rho = 7850 kg/m^3 -> chi = k / (rho c_p)
    "steel": {"thermal_expansion": 12e-6, "specific_heat": 460.0, "thermal_diffusivity": 1.4e-5},
    # 6061-T6 aluminium: k = 167 W/(m K), rho = 2700 kg/m^3
    "aluminium": {"thermal_expansion": 23e-6, "specific_heat": 896.0, "thermal_diffusivity": 6.9e-5},
}


# --------------------------------------------------------------------------- objects


@dataclass(frozen=True)
class Beam:
    """Nominal properties of the uniform beam, SI units.

    length: l (m); density: rho (kg/m^3); area: A (m^2); second_moment: I (m^4);
    modulus: E (Pa), a nominal value that centres the prior on EI, not a known one.
    """

    length: float
    density: float
    area: float
    second_moment: float
    modulus: float

    @property
    def rho_a(self) -> float:
        """Mass per unit length rho*A, kg/m."""
        return self.density * self.area

    @property
    def nominal_EI(self) -> float:
        """Nominal bending stiffness E*I, N m^2."""
        return self.modulus * self.second_moment


@dataclass(frozen=True)
class TipBody:
    """Rigid body at the free end: mass m_T (kg) and rotary inertia J (kg m^2)."""

    mass: float = 0.0
    rotary_inertia: float = 0.0


@dataclass(frozen=True)
class Material:
    """The thermal constants of the optional ``[material]`` table, SI units.

    thermal_expansion: alpha_T (1/K); temperature: T0 (K); specific_heat: c_p (J/(kg K));
    thermal_diffusivity: chi (m^2/s); thickness: h (m), the depth in the plane of bending.
    """

    thermal_expansion: float
    temperature: float
    specific_heat: float
    thermal_diffusivity: float
    thickness: float


@dataclass(frozen=True)
class SetUp:
    """What ``beam.toml`` states about the set-up beyond the nominal beam, SI units.

    length_tolerance: the free length lies within l +- this (m). tip_mass_tolerance (kg) and
    tip_rotary_inertia_tolerance (kg m^2): m_T and J lie within +- these. sensor_masses: each
    sensor's own mass (kg) in the order of ``Recording.sensors``, None where not stated.
    location_tolerances: each sensor sits within its location +- this (m). high_pass_corners: each
    sensor's stated low-frequency corner (Hz), gain_tolerances: its stated calibration uncertainty
    (a fraction); None where not stated.
    excitation_location_tolerance: the hammer of a force recording hit within its location +- this
    (m); hammer_location: its stated location (m; None unless a force recording). mains_hz: the
    mains frequency where the test ran (Hz; None where not stated). A tolerance of 0
    means the value is taken as stated. sensors: the recording's sensors the per-sensor entries
    refer to (their names and stated locations; not compared by ``==``, which compares what is
    stated about them).
    """

    length_tolerance: float = 0.0
    tip_mass_tolerance: float = 0.0
    tip_rotary_inertia_tolerance: float = 0.0
    sensor_masses: tuple[float | None, ...] = ()
    location_tolerances: tuple[float, ...] = ()
    high_pass_corners: tuple[float | None, ...] = ()
    gain_tolerances: tuple[float | None, ...] = ()
    sensors: tuple[Sensor, ...] = field(default=(), compare=False)
    excitation_location_tolerance: float = 0.0
    hammer_location: float | None = field(default=None, compare=False)
    mains_hz: float | None = None

    @property
    def stated_mass(self) -> float:
        """The stated sensor masses summed, kg (0 when none is stated)."""
        return sum(m for m in self.sensor_masses if m is not None)


@dataclass(frozen=True)
class Excitation:
    """How the beam was set moving.

    kind "force": a measured point force at ``location`` (x_f, m), in CSV ``column`` (N).
    kind "release": free decay from the static deflection under ``tip_load`` (N) at t <= 0.
    kind "free_decay": an unmeasured tap; no force acts from ``start`` (s) on and the
    state at ``start`` is unknown. Fields that do not belong to the kind are None.
    unit: the unit the force was stated in (``"kN"``, ``"lbf"``, ``"N"``; ``"V"`` for a
    ``scale``), None when none was stated; ``Recording.force`` is in N whatever it is.
    """

    kind: str
    location: float | None = None
    column: str | None = None
    tip_load: float | None = None
    start: float | None = None
    unit: str | None = None


@dataclass(frozen=True)
class Sensor:
    """One measured channel: ``quantity`` at ``location`` (m), held in CSV ``column``.

    quantity is "acceleration" (m/s^2), "velocity" (m/s) or "displacement" (m).
    unit: the unit the channel was stated in, in beam.toml or its header cell (``"g"``,
    ``"mm/s"``, ``"m/s^2"``; ``"V"`` for a ``scale``), None when none was stated (SI assumed);
    the recording's signals are SI whatever it is.
    """

    name: str
    location: float
    quantity: str
    column: str
    unit: str | None = None


@dataclass(frozen=True, eq=False)
class Recording:
    """One test of one beam: description plus uniformly sampled signals.

    time: (n,) s. signals: (n, n_sensors) in SI units, columns in the order of ``sensors``.
    force: (n,) N, present exactly when ``excitation.kind == "force"``.
    source: the directory the recording was read from (not compared by ``==``).
    extra: other top-level TOML entries (e.g. a [notes] table), carried along verbatim.
    setup_keys: the set-up keys of the format's own tables as written, e.g.
    ``{"beam": {"length_tolerance": 0.002}, "sensor": [{"mass": 0.006}]}`` (one dict per sensor);
    checked when :attr:`setup` is read.

    The arrays are stored as read-only float64 copies, so a Recording cannot change
    under a fit that holds it. ``==`` compares every field but ``source``, arrays exactly.
    """

    beam: Beam
    tip: TipBody
    excitation: Excitation
    sensors: tuple[Sensor, ...]
    time: np.ndarray
    signals: np.ndarray
    force: np.ndarray | None = None
    source: Path | None = field(default=None, compare=False)
    extra: dict = field(default_factory=dict)
    setup_keys: dict = field(default_factory=dict)

    def __post_init__(self):
        set_field = partial(object.__setattr__, self)  # frozen: only the base setter may assign
        set_field("sensors", tuple(self.sensors))
        set_field("time", _frozen_array(self.time))
        set_field("signals", _frozen_array(self.signals))
        if self.force is not None:
            set_field("force", _frozen_array(self.force))
        self._check_shapes()
        reserved = set(_KNOWN_TABLES) & set(self.extra)
        if reserved:
            raise ValueError(f"extra must not hold the format's own tables: {sorted(reserved)}")

    def _check_shapes(self):
        n = self.time.shape[0] if self.time.ndim == 1 else -1
        if n < 2:
            raise ValueError(f"time must be 1-D with at least 2 samples, got shape {self.time.shape}")
        if self.signals.shape != (n, len(self.sensors)):
            raise ValueError(
                f"signals must have shape (n_samples, n_sensors) = {(n, len(self.sensors))}, "
                f"got {self.signals.shape}"
            )
        if (self.excitation.kind == "force") != (self.force is not None):
            raise ValueError('force must be given exactly when excitation.kind == "force"')
        if self.force is not None and self.force.shape != (n,):
            raise ValueError(f"force must have shape ({n},), got {self.force.shape}")

    def __eq__(self, other):
        if not isinstance(other, Recording):
            return NotImplemented
        return all(
            _same(getattr(self, f.name), getattr(other, f.name)) for f in fields(self) if f.compare
        )

    @property
    def n_samples(self) -> int:
        """Number of samples n."""
        return self.time.shape[0]

    @property
    def dt(self) -> float:
        """Sampling step, s: the mean step over the record, which is robust to printed rounding."""
        return float(self.time[-1] - self.time[0]) / (self.n_samples - 1)

    @property
    def fs(self) -> float:
        """Sampling rate 1/dt, Hz."""
        return 1.0 / self.dt

    def sensor_index(self, name: str) -> int:
        """Column of ``signals`` holding sensor ``name``; KeyError listing the names if absent."""
        for i, sensor in enumerate(self.sensors):
            if sensor.name == name:
                return i
        known = ", ".join(repr(s.name) for s in self.sensors)
        raise KeyError(f"no sensor named {name!r}; this recording has {known}")

    @property
    def material(self) -> Material:
        """The ``[material]`` table, checked (it is optional in the format and stays in ``extra``);
        RecordingError naming the keys to add when it is missing or incomplete."""
        return _read_material(self.extra, (self.source or Path(".")) / "beam.toml", self.beam)

    @property
    def setup(self) -> SetUp:
        """What beam.toml states about the set-up (sensor masses, tolerances), checked;
        RecordingError naming the key and the fix for a non-numeric, negative or non-finite value."""
        return _read_setup(self.setup_keys, self.sensors, self.beam.length,
                           (self.source or Path(".")) / "beam.toml", self.excitation)

    def with_signals(self, signals) -> Recording:
        """A copy with ``signals`` (shape (n_samples, n_sensors)) in place of the measured ones."""
        return replace(self, signals=signals)


def _frozen_array(values) -> np.ndarray:
    # Copy before freezing so the caller's own array stays writable.
    array = np.array(values, dtype=np.float64)
    array.setflags(write=False)
    return array


def _same(a, b) -> bool:
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        return a is not None and b is not None and np.array_equal(a, b)
    return a == b


# --------------------------------------------------------------------------- reading beam.toml


def load_recording(path: str | os.PathLike) -> Recording:
    """Read and check a recording: its directory, or the path of its ``beam.toml``.

    ``[tip]`` may be omitted (no tip body), as may its keys (0.0). ``[recording]`` may be
    omitted, as may its keys: ``file`` defaults to "recording.csv", ``time_column`` to "time".
    Keys this reader does not use inside the format's own tables are ignored with a
    warning (they are usually typos); other top-level tables go to ``Recording.extra``. The
    set-up keys (sensor masses, tolerances) go to ``Recording.setup_keys`` unchecked, and are
    checked when ``Recording.setup`` is read.

    Raises RecordingError for anything the format refuses (see docs/format.md).
    """
    toml_path = _toml_path(Path(path))
    doc = _read_toml(toml_path)
    beam = _read_beam(doc, toml_path)
    tip = _read_tip(doc, toml_path)
    excitation = _read_excitation(doc, toml_path, beam.length)
    sensors = _read_sensors(doc, toml_path, beam.length)
    scalings = _read_scalings(doc, toml_path, excitation, sensors)
    source = _read_recording_table(doc, toml_path)
    _warn_unused(_table(doc, "setup", toml_path, required=False), _SETUP_KEYS["setup"], "[setup]", toml_path)
    _check_distinct_columns(toml_path, _claims(excitation, sensors, source.time_column or DEFAULT_TIME_COLUMN))
    table, stated_rate = _read_data(toml_path.parent / source.file, source)
    cells = _resolve_columns(toml_path, table, excitation, sensors, source, stated_rate)
    time = _read_time(toml_path, table, cells.get(None), source)
    _check_start(toml_path, excitation, time)
    force = None
    if excitation.kind == "force":
        force = table.column(cells[excitation.column])
        _check_force(table, excitation, force)
        force, unit = _to_si(toml_path, table, cells[excitation.column], force, scalings[0])
        excitation = replace(excitation, unit=unit)
    channels = [_to_si(toml_path, table, cells[s.column], table.column(cells[s.column]), scaling)
                for s, scaling in zip(sensors, scalings[1:])]
    sensors = tuple(replace(s, unit=unit) for s, (_, unit) in zip(sensors, channels))
    signals = np.column_stack([values for values, _ in channels])
    extra = {key: value for key, value in doc.items() if key not in _KNOWN_TABLES}
    return Recording(beam, tip, excitation, sensors, time, signals, force, toml_path.parent, extra,
                     _stated_setup(doc))


def _toml_path(path: Path) -> Path:
    # A path that is neither a file nor named *.toml is taken for the directory.
    toml_path = path if path.is_file() or path.suffix == ".toml" else path / "beam.toml"
    if not toml_path.is_file():
        raise RecordingError(
            toml_path, "file", "no such file",
            "pass a recording directory that holds beam.toml, or the path of beam.toml itself.",
        )
    return toml_path


def _read_toml(file: Path) -> dict:
    try:
        # utf-8-sig: some Windows editors start a text file with a byte-order mark.
        return tomllib.loads(file.read_bytes().decode("utf-8-sig"))
    except UnicodeDecodeError as err:
        raise RecordingError(
            file, "file", f"not UTF-8 text ({err.reason})", "save beam.toml as UTF-8."
        ) from err
    except tomllib.TOMLDecodeError as err:
        # tomllib ends its message with "(at line L, column C)" or "(at end of document)".
        match = re.fullmatch(r"(.*) \(at (.*)\)", str(err))
        problem, where = match.groups() if match else (str(err), "TOML syntax")
        raise RecordingError(
            file, where, f"invalid TOML: {problem}",
            'correct the syntax there (key = value, strings in "double quotes", tables as [name]).',
        ) from err


def _table(doc: dict, name: str, file: Path, *, required: bool) -> dict:
    if name not in doc:
        if required:
            raise RecordingError(
                file, f"[{name}]", "table missing", f"add a [{name}] table as in docs/format.md."
            )
        return {}
    if not isinstance(doc[name], dict):
        raise RecordingError(
            file, f"[{name}]", "is not a table", f"write [{name}] as a table header followed by its keys."
        )
    return doc[name]


def _default_or_missing(default, key: str, label: str, file: Path):
    """``default`` for an absent key, or the 'missing' refusal when there is none."""
    if default is not None:
        return default
    raise RecordingError(file, f"{label} .{key}", "missing", f"add `{key} = <{_MEANING[key]}>` to {label}.")


def _number(table: dict, key: str, label: str, file: Path, default: float | None = None) -> float:
    """The finite number ``table[key]``; ``default`` when absent, unless that is None."""
    where = f"{label} .{key}"
    if key not in table:
        return _default_or_missing(default, key, label, file)
    value = table[key]
    # bool is an int subclass in Python, but `true` is not a length.
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise RecordingError(
            file, where, f"{value!r} is not a number", f"write {key} as a bare number ({_MEANING[key]})."
        )
    try:
        value = float(value)
    except OverflowError:
        value = math.inf
    if not math.isfinite(value):
        raise RecordingError(
            file, where, f"{table[key]!r} is not finite", f"give {key} a finite value ({_MEANING[key]})."
        )
    if not _plausible(value):
        raise RecordingError(
            file, where, f"{table[key]!r} is beyond the magnitudes a recording can hold "
            f"({MAX_MAGNITUDE:g} down to {1 / MAX_MAGNITUDE:g})",
            f"give {key} in SI units ({_MEANING[key]}).",
        )
    return value


def _plausible(value) -> np.ndarray | bool:
    """True where ``value`` is 0 or has a magnitude within [1/MAX_MAGNITUDE, MAX_MAGNITUDE]."""
    magnitude = np.abs(value)
    return (magnitude == 0) | ((magnitude <= MAX_MAGNITUDE) & (magnitude >= 1 / MAX_MAGNITUDE))


def _text(table: dict, key: str, label: str, file: Path, default: str | None = None) -> str:
    """The non-empty string ``table[key]``; ``default`` when absent, unless that is None."""
    where = f"{label} .{key}"
    if key not in table:
        return _default_or_missing(default, key, label, file)
    value = table[key]
    if not isinstance(value, str) or not value:
        raise RecordingError(
            file, where, f"{value!r} is not a non-empty string",
            f'write {key} as a quoted string ({_MEANING[key]}), e.g. {key} = "...".',
        )
    return value


def _choice(table: dict, key: str, label: str, file: Path, choices: tuple[str, ...]) -> str:
    value = _text(table, key, label, file)
    if value not in choices:
        raise RecordingError(
            file, f"{label} .{key}", f"unknown {key} {value!r}", f"set {key} to {_MEANING[key]}."
        )
    return value


def _within_beam(value: float, where: str, file: Path, length: float) -> float:
    if not 0.0 <= value <= length:
        raise RecordingError(
            file, where, f"{value!r} m is outside the beam [0, {length!r}] m",
            f"give a position between 0 and the length {length!r} m, measured from the clamp.",
        )
    return value


def _warn_unused(table: dict, used: tuple[str, ...], label: str, file: Path, why: str = "") -> None:
    # Not refused: the format carries unknown content along. Warned: a typo such as
    # `mas = 0.05` in [tip] would otherwise silently mean "no tip mass".
    for key in table:
        if key not in used:
            reason = why or f"{label} uses only {', '.join(used)}"
            warnings.warn(f"{file}: {label} .{key}: ignored ({reason})", stacklevel=2)


def _read_beam(doc: dict, file: Path) -> Beam:
    table = _table(doc, "beam", file, required=True)
    values = {key: _number(table, key, "[beam]", file) for key in _BEAM_KEYS}
    for key, value in values.items():
        if value <= 0.0:
            raise RecordingError(
                file, f"[beam] .{key}", f"{value!r} is not positive",
                f"give {key} a positive value ({_MEANING[key]}).",
            )
    _warn_unused(table, (*_BEAM_KEYS, *_SETUP_KEYS["beam"]), "[beam]", file)
    return Beam(**values)


def _read_tip(doc: dict, file: Path) -> TipBody:
    table = _table(doc, "tip", file, required=False)
    values = {key: _number(table, key, "[tip]", file, default=0.0) for key in _TIP_KEYS}
    for key, value in values.items():
        if value < 0.0:
            raise RecordingError(
                file, f"[tip] .{key}", f"{value!r} is negative",
                f"give {key} a value >= 0 ({_MEANING[key]}), or 0 for no tip body.",
            )
    _warn_unused(table, (*_TIP_KEYS, *_SETUP_KEYS["tip"]), "[tip]", file)
    return TipBody(**values)


def _read_material(doc: dict, file: Path, beam: Beam | None = None) -> Material:
    if "material" not in doc:
        raise RecordingError(
            file, "[material]", "table missing (the thermoelastic mechanism needs the beam's thermal constants)",
            f"add a [material] table with {', '.join(_MATERIAL_KEYS)}, or name = \"steel\" or \"aluminium\" "
            "(handbook values of the first three, docs/format.md) with temperature and thickness.",
        )
    table = _table(doc, "material", file, required=True)
    named = {}
    if "name" in table:
        value = _text(table, "name", "[material]", file)
        if value not in MATERIALS:
            raise RecordingError(file, "[material] .name", f"unknown material {value!r}",
                                 f"set name to {_MEANING['material_name']}, or give every constant.")
        named = MATERIALS[value]
    values = {key: _number(table, key, "[material]", file, default=named.get(key)) for key in _MATERIAL_KEYS}
    for key, value in values.items():
        if value <= 0.0:
            raise RecordingError(file, f"[material] .{key}", f"{value!r} is not positive",
                                 f"give {key} a positive value ({_MEANING[key]}).")
    _warn_unused(table, ("name", *_MATERIAL_KEYS), "[material]", file)
    if beam is not None:
        _warn_thickness(values["thickness"], beam, file)
    return Material(**values)


#: relative disagreement of [material] thickness with [beam]'s rectangular depth sqrt(12 I / A)
#: past which it is warned (the stated I and A of a measured strip agree with h to ~1 %)
THICKNESS_TOLERANCE = 0.02


def _warn_thickness(thickness: float, beam: Beam, file: Path) -> None:
    # Warned, not refused: a section that is not a rectangle (a tube, an I-beam) has its own
    # sqrt(12 I / A); for the rectangular strip the thermoelastic mechanism assumes, a mismatch is
    # a typo in one of three keys, and tau = h^2 / (pi^2 chi) moves as its square.
    depth = float(np.sqrt(12.0 * beam.second_moment / beam.area))
    if abs(thickness / depth - 1.0) > THICKNESS_TOLERANCE:
        warnings.warn(f"{file}: [material] .thickness: {thickness:.4g} m, while [beam]'s second_moment and area "
                      f"give a rectangular section sqrt(12 I / A) = {depth:.4g} m deep ({thickness / depth - 1:+.1%}); "
                      "the thermoelastic relaxation time goes as thickness^2. Check thickness, second_moment and "
                      "area (a section that is not a rectangle may differ)", stacklevel=4)


def _stated_setup(doc: dict) -> dict:
    """The set-up keys of beam.toml's [beam], [tip] and [[sensor]] tables, verbatim (only those
    present; one dict per sensor); the tables themselves have been checked."""
    stated = {}
    for name in ("beam", "tip", "excitation", "setup"):
        table = doc.get(name, {})
        if keys := {key: table[key] for key in _SETUP_KEYS[name] if key in table}:
            stated[name] = keys
    sensors = [{key: table[key] for key in _SETUP_KEYS["sensor"] if key in table} for table in doc.get("sensor", [])]
    if any(sensors):
        stated["sensor"] = sensors
    return stated


def _read_setup(stated: dict, sensor_list: tuple[Sensor, ...], length: float, file: Path,
                excitation: Excitation | None = None) -> SetUp:
    n_sensors = len(sensor_list)
    beam, tip = stated.get("beam", {}), stated.get("tip", {})
    sensors = list(stated.get("sensor", []))
    sensors += [{}] * (n_sensors - len(sensors))
    length_tolerance = _non_negative(beam, "length_tolerance", "[beam]", file)
    if length_tolerance >= length:
        raise RecordingError(file, "[beam] .length_tolerance", f"{length_tolerance!r} m is not below the length "
                             f"{length!r} m", "give the free length's tolerance in m, smaller than the length.")
    labels = [f"[[sensor]] #{i}" for i in range(1, n_sensors + 1)]
    return SetUp(
        length_tolerance=length_tolerance,
        tip_mass_tolerance=_non_negative(tip, "mass_tolerance", "[tip]", file),
        tip_rotary_inertia_tolerance=_non_negative(tip, "rotary_inertia_tolerance", "[tip]", file),
        sensor_masses=tuple(_non_negative(table, "mass", label, file) if "mass" in table else None
                            for table, label in zip(sensors, labels)),
        location_tolerances=tuple(_non_negative(table, "location_tolerance", label, file)
                                  for table, label in zip(sensors, labels)),
        high_pass_corners=_stated_positive(sensors, "high_pass_hz", labels, file),
        gain_tolerances=_stated_positive(sensors, "gain_tolerance", labels, file),
        sensors=tuple(sensor_list),
        excitation_location_tolerance=_hammer_tolerance(stated.get("excitation", {}), sensor_list, sensors,
                                                        excitation, file),
        hammer_location=excitation.location if excitation is not None else None,
        mains_hz=_stated_positive([stated.get("setup", {})], "mains_hz", ["[setup]"], file)[0],
    )


def _hammer_tolerance(table: dict, sensor_list: tuple[Sensor, ...], sensors: list[dict],
                      excitation: Excitation | None, file: Path) -> float:
    """``[excitation] location_tolerance`` of a force recording (m; 0 for other kinds, whose
    reader warns about the key as unused); refused beside a sensor named "hammer" with a
    location tolerance, whose offset would take the hammer's parameter name dx_hammer."""
    if excitation is None or excitation.kind != "force":
        return 0.0
    tolerance = _non_negative(table, "location_tolerance", "[excitation]", file)
    clash = [i for i, (sensor, keys) in enumerate(zip(sensor_list, sensors), 1)
             if sensor.name == "hammer" and _non_negative(keys, "location_tolerance", f"[[sensor]] #{i}", file) > 0]
    if tolerance > 0 and clash:
        raise RecordingError(file, f"[[sensor]] #{clash[0]} .name", 'a sensor named "hammer" with a location '
                             "tolerance beside [excitation] location_tolerance: both offsets would be dx_hammer",
                             "rename the sensor.")
    return tolerance


def _stated_positive(tables: list[dict], key: str, labels: list[str], file: Path) -> tuple[float | None, ...]:
    """Each table's finite ``key`` > 0, None where it is not stated."""
    out = []
    for table, label in zip(tables, labels):
        value = _non_negative(table, key, label, file) if key in table else None
        if value == 0.0:
            raise RecordingError(file, f"{label} .{key}", "0 is not a value it can take",
                                 f"give {key} a value > 0 ({_MEANING[key]}), or leave the key out.")
        out.append(value)
    return tuple(out)


def _non_negative(table: dict, key: str, label: str, file: Path) -> float:
    """The finite number ``table[key]`` >= 0 (0.0 when absent)."""
    value = _number(table, key, label, file, default=0.0)
    if value < 0.0:
        raise RecordingError(file, f"{label} .{key}", f"{value!r} is negative",
                             f"give {key} a value >= 0 ({_MEANING[key]}), or leave the key out.")
    return value


def _read_excitation(doc: dict, file: Path, length: float) -> Excitation:
    label = "[excitation]"
    table = _table(doc, "excitation", file, required=True)
    kind = _choice(table, "kind", label, file, KINDS)
    if kind == "force":
        location = _number(table, "location", label, file)
        values = {
            "location": _within_beam(location, f"{label} .location", file, length),
            "column": _text(table, "column", label, file),
        }
    elif kind == "release":
        values = {"tip_load": _number(table, "tip_load", label, file)}
    else:
        values = {"start": _number(table, "start", label, file)}
    used = ("kind", *_EXCITATION_KEYS[kind], *(_SETUP_KEYS["excitation"] + _UNIT_KEYS if kind == "force" else ()))
    _warn_unused(table, used, label, file, why=f'kind = "{kind}" uses only {", ".join(used)}')
    return Excitation(kind=kind, **values)


def _read_sensors(doc: dict, file: Path, length: float) -> tuple[Sensor, ...]:
    tables = doc.get("sensor")
    if isinstance(tables, dict):
        raise RecordingError(
            file, "[sensor]", "a single [sensor] table",
            "write each channel as a [[sensor]] table (double brackets).",
        )
    if not isinstance(tables, list) or not tables:
        raise RecordingError(
            file, "[[sensor]]", "no sensor table",
            "add one [[sensor]] table per measured channel with name, location, quantity and column.",
        )
    sensors = tuple(
        _read_sensor(table, f"[[sensor]] #{i}", file, length) for i, table in enumerate(tables, 1)
    )
    for i, sensor in enumerate(sensors, 1):
        if sensor.name in (s.name for s in sensors[: i - 1]):
            raise RecordingError(
                file, f"[[sensor]] #{i} .name", f"sensor name {sensor.name!r} is used twice",
                "give every [[sensor]] a distinct name.",
            )
    return sensors


def _read_sensor(table, label: str, file: Path, length: float) -> Sensor:
    if not isinstance(table, dict):
        raise RecordingError(file, label, "is not a table", "write the sensor as a [[sensor]] table.")
    location = _number(table, "location", label, file)
    sensor = Sensor(
        name=_text(table, "name", label, file),
        location=_within_beam(location, f"{label} .location", file, length),
        quantity=_choice(table, "quantity", label, file, QUANTITIES),
        column=_text(table, "column", label, file),
    )
    _warn_unused(table, (*_SENSOR_KEYS, *_UNIT_KEYS, *_SETUP_KEYS["sensor"]), label, file)
    return sensor


@dataclass(frozen=True)
class _Source:
    """The [recording] table: the data file, its time column (None: not stated, "time" or a
    column named as a time), and how to read a text export (None: sniffed)."""

    file: str
    time_column: str | None
    delimiter: str | None = None
    decimal: str | None = None
    sample_rate: float | None = None
    skip_lines: int = 0

    @property
    def export(self) -> bool:
        """Whether a key of a text export is stated, so the file is read as one."""
        return (self.delimiter, self.decimal, self.sample_rate) != (None, None, None) or self.skip_lines > 0


def _read_recording_table(doc: dict, file: Path) -> _Source:
    label = "[recording]"
    table = _table(doc, "recording", file, required=False)
    keys = {"file": _text(table, "file", label, file, default=DEFAULT_CSV)}
    keys["time_column"] = _text(table, "time_column", label, file) if "time_column" in table else None
    if "delimiter" in table:
        keys["delimiter"] = _choice(table, "delimiter", label, file, tuple(STATED_DELIMITERS))
    if "decimal" in table:
        keys["decimal"] = _choice(table, "decimal", label, file, (".", ","))
        if keys["decimal"] == "," == keys.get("delimiter"):
            raise RecordingError(file, f"{label} .decimal", "a comma cannot be both the delimiter and the decimal mark",
                                 'state the delimiter the file uses (";", "\\t" or " ") with decimal = ",".')
    if "sample_rate" in table:
        rate = _number(table, "sample_rate", label, file)
        if not 1 / STEP_RANGE[1] <= rate <= 1 / STEP_RANGE[0]:
            raise RecordingError(file, f"{label} .sample_rate", f"{rate!r} Hz is not a sampling rate",
                                 f"give the rate in Hz, between {1 / STEP_RANGE[1]:g} and {1 / STEP_RANGE[0]:g}.")
        keys["sample_rate"] = rate
    if "skip_lines" in table:
        skip = table["skip_lines"]
        if isinstance(skip, bool) or not isinstance(skip, int) or skip < 0:
            raise RecordingError(file, f"{label} .skip_lines", f"{skip!r} is not a count of lines",
                                 "write skip_lines as a whole number >= 0.")
        keys["skip_lines"] = skip
    _warn_unused(table, (*_RECORDING_KEYS, *_EXPORT_KEYS), label, file)
    return _Source(**keys)


def _claims(excitation: Excitation, sensors, time_column: str | None) -> list[tuple[str, str]]:
    """(key, column) for the time (unless None), the force and each sensor, in that order."""
    claims = [("[recording] .time_column", time_column)] if time_column is not None else []
    if excitation.kind == "force":
        claims.append(("[excitation] .column", excitation.column))
    return claims + [(f"[[sensor]] #{i} .column", s.column) for i, s in enumerate(sensors, 1)]


def _check_distinct_columns(file: Path, claims: list[tuple[str, str]]) -> None:
    # Two channels read from one column would count the same data twice in a likelihood.
    owners = {}
    for where, column in claims:
        if column in owners:
            raise RecordingError(
                file, where, f"column {column!r} is already read by {owners[column]}",
                "give every channel its own CSV column.",
            )
        owners[column] = where


def _resolve_columns(file: Path, table: CellTable, excitation, sensors, source: _Source,
                     stated_rate: float | None) -> dict:
    """The header cell each column of beam.toml names (``column = "Accel tip"`` reads the cell
    ``Accel tip (g)``), and under the key None the time column's (None when the time is rebuilt
    from ``sample_rate`` and the file has none); RecordingError for a column the file lacks."""
    cells = {None: _time_cell(file, table, source, stated_rate)}
    claims = _claims(excitation, sensors, None)
    for where, column in claims:
        cells[column] = _header_cell(file, table, where, column, source.file)
    time_claim = [("[recording] .time_column", cells[None])] if cells[None] is not None else []
    _check_distinct_columns(file, time_claim + [(where, cells[column]) for where, column in claims])
    return cells


def _header_cell(file: Path, table: CellTable, where: str, column: str, csv_name: str, fix: str = "") -> str:
    found = find_column(table.header, column)
    if not found:
        raise RecordingError(
            file, where, f"{csv_name} has no column {column!r} (its columns: {', '.join(table.header)})",
            f"name one of those columns here, or add a {column!r} column to {csv_name}{fix}.",
        )
    if len(found) > 1:
        raise RecordingError(file, where, f"{column!r} names {len(found)} columns of {csv_name}: {', '.join(found)}",
                             "write the header cell in full, unit included.")
    return found[0]


def _time_cell(file: Path, table: CellTable, source: _Source, stated_rate: float | None) -> str | None:
    """The time column's header cell: the one stated, else "time", else one named as a time."""
    if source.time_column is None and not find_column(table.header, DEFAULT_TIME_COLUMN):
        recognised = time_column(table.header)
        if recognised is not None or source.sample_rate is not None:
            return recognised
    stated = f" (the file states {stated_rate:.6g} Hz)" if stated_rate else ""
    return _header_cell(file, table, "[recording] .time_column", source.time_column or DEFAULT_TIME_COLUMN,
                        source.file, f", or state [recording] sample_rate (Hz) to rebuild the time{stated}")


def _check_start(file: Path, excitation: Excitation, time: np.ndarray) -> None:
    if excitation.kind != "free_decay":
        return
    first, last = float(time[0]), float(time[-1])
    if not first <= excitation.start < last:
        raise RecordingError(
            file, "[excitation] .start",
            f"{excitation.start!r} s is outside the record, which runs from {first!r} to {last!r} s",
            "set start to the time (s) from which no force acts; the record must continue after it.",
        )


def _check_force(table: CellTable, excitation: Excitation, force: np.ndarray | None) -> None:
    # A force recording is defined by its measured force: a channel of zeros holds no impact.
    if force is None or np.any(force != 0.0):
        return
    raise RecordingError(
        table.path, f'column "{excitation.column}"', "the force channel is zero in every sample",
        "check that [excitation] column names the force channel and that the hammer's sensor was "
        'connected; for an unmeasured tap use kind = "free_decay" with a start time.',
    )


# --------------------------------------------------------------------------- reading the data file


def _read_data(path: Path, source: _Source) -> tuple[CellTable, float | None]:
    """The cells of the data file, and the sample rate (Hz) a text export states (else None).

    A plain comma CSV (docs/format.md) is read as it always was; a file with comment or metadata
    lines, another delimiter, or a [recording] key of a text export goes to the text-export reader.
    """
    if not source.export and _is_plain_csv(path):
        return _read_csv(path), None
    export = read_export_cells(path, delimiter=source.delimiter, decimal=source.decimal,
                               skip_lines=source.skip_lines)
    rows = export.cells.rows
    if len(rows) < MIN_SAMPLES:
        raise RecordingError(
            path, "file", f"{len(rows)} data row(s); at least {MIN_SAMPLES} samples are needed (the "
            "anti-alias filter's own response is longer than a shorter record)",
            "supply the full record: one header line, then one row per sample.",
        )
    return export.cells, export.sample_rate


def _is_plain_csv(path: Path) -> bool:
    """Whether the file starts as a recording CSV: a header of two or more comma-separated cells,
    no comment mark, tab or semicolon in it (a missing or empty file is left to _read_csv's refusal)."""
    if not path.is_file():
        return True
    with path.open(encoding="utf-8-sig", errors="replace", newline="") as stream:
        first = stream.readline().rstrip("\r\n")
    if not first.strip():
        return True
    return not first.lstrip().startswith(COMMENT_PREFIXES) and "\t" not in first and ";" not in first \
        and len(next(csv.reader([first]), [])) >= 2


def _read_csv(path: Path) -> CellTable:
    if not path.is_file():
        raise RecordingError(
            path, "file", "no such file",
            "put the CSV next to beam.toml, or correct [recording] file in beam.toml.",
        )
    try:
        # utf-8-sig: spreadsheet programs often start a CSV with a byte-order mark.
        with path.open(newline="", encoding="utf-8-sig") as stream:
            reader = csv.reader(stream)
            try:
                header = _read_header(path, reader)
                rows, lines = _read_rows(path, reader, len(header))
            except csv.Error as err:
                raise RecordingError(
                    path, f"line {reader.line_num}", f"malformed CSV ({err})",
                    "write plain comma-separated values there.",
                ) from None
    except UnicodeDecodeError as err:
        raise RecordingError(
            path, "file", f"not UTF-8 text ({err.reason})", "save the CSV as UTF-8."
        ) from None
    if len(rows) < MIN_SAMPLES:
        raise RecordingError(
            path, "file", f"{len(rows)} data row(s); at least {MIN_SAMPLES} samples are needed (the "
            "anti-alias filter's own response is longer than a shorter record)",
            "supply the full record: one header line, then one row per sample.",
        )
    return CellTable(path, header, rows, lines)


def _read_header(path: Path, reader) -> tuple[str, ...]:
    row = next(reader, None)
    if not row:
        raise RecordingError(
            path, "line 1", "no header line",
            "start the file with a header naming the columns, e.g. time,accel_tip.",
        )
    header = tuple(name.strip() for name in row)
    check_header(path, header, 1)
    return header


def _read_rows(path: Path, reader, width: int) -> tuple[list[list[str]], list[int]]:
    rows, lines, blank_line = [], [], None
    for row in reader:
        if not row:
            blank_line = blank_line or reader.line_num  # trailing blank lines are harmless
            continue
        if blank_line is not None:
            raise RecordingError(
                path, f"line {blank_line}", "blank line inside the data", "delete the blank line."
            )
        if len(row) != width:
            raise RecordingError(
                path, f"line {reader.line_num}", f"{len(row)} cells where the header names {width} columns",
                "give every row exactly one value per header column.",
            )
        rows.append(row)
        lines.append(reader.line_num)
    return rows, lines


def _read_time(file: Path, table: CellTable, cell: str | None, source: _Source) -> np.ndarray:
    """The time in s: the time column (its unit converted; rebuilt as t0 + i dt when only the
    print's rounding makes it uneven), or t0 + i / sample_rate when beam.toml states the rate."""
    factor = 1.0 if cell is None else time_factor(table.path, cell)
    read = None if cell is None else table.column(cell)
    read = read if factor == 1.0 or read is None else read * factor
    if source.sample_rate is None:
        return _uniform_time(table, cell, read, factor)
    step, n = 1.0 / source.sample_rate, len(table.rows)
    if read is None:
        return np.arange(n) * step
    mean = float(read[-1] - read[0]) / (n - 1)
    if not abs(mean - step) <= 0.01 * step:
        raise RecordingError(
            file, "[recording] .sample_rate",
            f"{source.sample_rate!r} Hz disagrees with the time column {cell!r}, whose mean step is "
            f"{mean!r} s ({1 / mean if mean > 0 else math.inf:.6g} Hz)",
            "correct sample_rate, or leave it out to take the time from the column.",
        )
    return read[0] + np.arange(n) * step


def _uniform_time(table: CellTable, name: str, time: np.ndarray, factor: float) -> np.ndarray:
    """``time`` when strictly increasing and uniform; rebuilt as t0 + i dt when every uneven step
    is within the print's rounding; otherwise RecordingError.

    A step may differ from the mean step dt by MAX_TIME_JITTER relative, or by the rounding of
    its two printed cells (half a unit in the last printed digit of each, ``print_resolution``)
    plus the float64 rounding of the values: a time column printed with 9 decimals at 4096 Hz is
    uneven by 4e-6 relative from its printing alone.
    """
    steps = np.diff(time)
    falls = np.flatnonzero(steps <= 0.0)
    if falls.size:
        k = falls[0] + 1
        raise RecordingError(
            table.path, f'line {table.lines[k]}, column "{name}"',
            f"time {float(time[k])!r} s does not increase on the previous sample ({float(time[k - 1])!r} s)",
            "sort the rows by time and remove repeated samples.",
        )
    dt = (time[-1] - time[0]) / (time.size - 1)
    if not STEP_RANGE[0] <= dt <= STEP_RANGE[1]:
        raise RecordingError(
            table.path, f'column "{name}"',
            f"the mean sampling step {float(dt)!r} s is outside {STEP_RANGE[0]:g} to {STEP_RANGE[1]:g} s",
            "write the time in seconds.",
        )
    jitter = np.abs(steps - dt) / dt
    if jitter.max() <= MAX_TIME_JITTER:
        return time
    resolution = print_resolution(table.cells(name)) * factor
    rounding = 0.5 * (resolution[:-1] + resolution[1:]) + 4 * np.finfo(float).eps * np.max(np.abs(time))
    uneven = (jitter > MAX_TIME_JITTER) & (np.abs(steps - dt) > rounding)
    if not uneven.any():
        return time[0] + np.arange(time.size) * dt
    # Name the worst step: a dropped sample shifts the mean step, so the first step
    # over the limit can lie far before the gap that causes it.
    k = int(np.argmax(np.where(uneven, jitter, 0.0))) + 1
    raise RecordingError(
        table.path, f'line {table.lines[k]}, column "{name}"',
        f"the step to here, {float(steps[k - 1])!r} s, differs from the mean step {float(dt)!r} s "
        f"by {jitter[k - 1]:.3g} relative, the worst of {np.count_nonzero(uneven)} steps over the limit "
        f"{MAX_TIME_JITTER:g} and the print's rounding",
        "resample the record onto a uniform time grid (no gaps) or print the time with more digits; if "
        "the samples are uniform and only the time column is not, state [recording] sample_rate = "
        f"{_rounded_rate(1 / dt)} in beam.toml to rebuild the time from the rate",
    )


def _rounded_rate(rate: float) -> str:
    """``rate`` (Hz) to 6 significant digits, as a whole number when it is one to 1e-6."""
    whole = round(rate)
    return str(whole) if whole and abs(rate - whole) <= 1e-6 * rate else f"{rate:.6g}"


# --------------------------------------------------------------------------- units


@dataclass(frozen=True)
class _Scaling:
    """How one channel's values become SI: beam.toml's ``unit`` (None: not stated), and for a
    channel recorded in volts its ``sensitivity`` (V per unit) or ``scale`` (SI per recorded unit)."""

    label: str
    quantity: str
    unit: Unit | None = None
    sensitivity: float | None = None
    scale: float | None = None


def _read_scalings(doc: dict, file: Path, excitation: Excitation, sensors) -> list[_Scaling | None]:
    """The force's scaling (None unless kind "force"), then each sensor's."""
    force = None
    if excitation.kind == "force":
        force = _read_scaling(doc["excitation"], "[excitation]", file, "force")
    return [force, *(_read_scaling(table, f"[[sensor]] #{i}", file, s.quantity)
                     for i, (table, s) in enumerate(zip(doc["sensor"], sensors), 1))]


def _read_scaling(table: dict, label: str, file: Path, quantity: str) -> _Scaling:
    unit = None
    if "unit" in table:
        text = _text(table, "unit", label, file)
        unit = parse_unit(text)
        volts = ("; for a channel recorded in volts state sensitivity (V per unit) with the unit of the "
                 f"{quantity}, or scale ({SI_UNITS[quantity]} per V)")
        if unit is None or unit.quantity != quantity:
            problem = f"unknown unit {text!r}" if unit is None else f"{text!r} is a unit of {unit.quantity}, not of {quantity}"
            raise RecordingError(file, f"{label} .unit", problem, f"write a unit of {quantity}: one of "
                                 f"{known_units(quantity)} (docs/format.md lists the spellings){volts}.")
    factors = {key: _number(table, key, label, file) for key in ("sensitivity", "scale") if key in table}
    for key, value in factors.items():
        if value == 0.0:
            raise RecordingError(file, f"{label} .{key}", "is zero", f"give {key} ({_MEANING[key]}).")
    if len(factors) == 2 or ("scale" in factors and unit is not None):
        raise RecordingError(file, f"{label} .scale", "scale converts the recorded values to SI by itself",
                             "give either sensitivity (V per unit) with unit, or scale alone (SI units per V).")
    return _Scaling(label, quantity, unit, factors.get("sensitivity"), factors.get("scale"))


def _to_si(file: Path, table: CellTable, cell: str, values: np.ndarray, scaling: _Scaling) -> tuple[np.ndarray, str | None]:
    """The channel's values in SI, and the unit stated for them (None when none was).

    The header cell's unit (``Accel tip (g)``) and beam.toml's ``unit`` must agree; either alone
    is used. A header unit this reader does not know is ignored with a warning.
    """
    stated = split_unit(cell)[1]
    header = parse_unit(stated)
    where, quantity, si = f"{scaling.label} .column", scaling.quantity, SI_UNITS[scaling.quantity]
    if stated is not None and header is None and scaling.unit is None:
        warnings.warn(f"{table.path}: column {cell!r}: {stated!r} is not a unit bayesbeam knows; the values are "
                      f"taken as {si} (state {scaling.label} unit to be sure)", stacklevel=3)
    if scaling.sensitivity is not None or scaling.scale is not None:
        if header is not None and header.quantity != "voltage":
            raise RecordingError(file, where, f"column {cell!r} is in {header.symbol}, not volts, but "
                                 f"{scaling.label} states a sensitivity or scale",
                                 "leave sensitivity and scale out for a channel recorded in physical units.")
        volts = values * header.factor if header is not None else values
        if scaling.scale is not None:
            return volts * scaling.scale, header.symbol if header is not None else "V"
        unit = scaling.unit or parse_unit(si)
        return volts / scaling.sensitivity * unit.factor, unit.symbol
    if header is not None and header.quantity == "voltage":
        raise RecordingError(file, where, f"column {cell!r} is recorded in {header.symbol}",
                             f"state {scaling.label} sensitivity (V per unit, with unit) or scale ({si} per V).")
    if header is not None and header.quantity != quantity:
        raise RecordingError(file, where, f"column {cell!r} is in {header.symbol}, a unit of {header.quantity}, "
                             f"not of {quantity}", f"name the column holding the {quantity}, or correct the quantity.")
    if header is not None and scaling.unit is not None and header.symbol != scaling.unit.symbol:
        raise RecordingError(
            file, f"{scaling.label} .unit", f"unit {scaling.unit.symbol!r} disagrees with the unit {header.symbol!r} "
            f"of {table.path.name}'s header cell {cell!r}",
            f"make the two agree: correct {scaling.label} unit, or the header cell if it is the one that is wrong.",
        )
    unit = scaling.unit or header
    if unit is None:
        return values, None
    return (values if unit.factor == 1.0 else values * unit.factor), unit.symbol


# --------------------------------------------------------------------------- writing


def write_recording(rec: Recording, out_dir: str | os.PathLike, *, overwrite: bool = False) -> Path:
    """Write ``rec`` as ``out_dir/beam.toml`` and ``out_dir/recording.csv``; return ``out_dir``.

    Atomic: both files are written into a hidden directory next to ``out_dir``, which is then
    renamed into place, so a reader never sees half a recording. An existing non-empty
    ``out_dir`` is refused (FileExistsError) unless ``overwrite``; then it is replaced as a
    whole (files in it that are not part of the recording, e.g. truth.json, are dropped).
    Numbers are printed with repr(), so reading the result back gives identical arrays.
    """
    out_dir = Path(os.path.abspath(out_dir))
    _check_target(out_dir, overwrite)
    out_dir.parent.mkdir(parents=True, exist_ok=True)
    columns = _csv_columns(rec)
    staging = _sibling(out_dir, "tmp")
    # os.mkdir rather than tempfile.mkdtemp: mkdtemp's 0700 mode would survive the rename.
    staging.mkdir()
    try:
        (staging / "beam.toml").write_text(_beam_toml(rec, columns[0]), encoding="utf-8")
        _write_csv(staging / DEFAULT_CSV, rec, columns)
        _move_into_place(staging, out_dir)
    except BaseException:
        shutil.rmtree(staging, ignore_errors=True)
        raise
    return out_dir


def _check_target(out_dir: Path, overwrite: bool) -> None:
    if out_dir.exists() and not out_dir.is_dir():
        raise FileExistsError(f"{out_dir}: exists and is not a directory. Fix: choose another output path.")
    if out_dir.is_dir() and any(out_dir.iterdir()) and not overwrite:
        raise FileExistsError(
            f"{out_dir}: directory exists and is not empty. "
            "Fix: choose a new directory, or pass overwrite=True."
        )


def _sibling(out_dir: Path, purpose: str) -> Path:
    # Same parent directory, hence same file system, so the final rename is atomic.
    return out_dir.with_name(f".{out_dir.name}.{uuid.uuid4().hex[:12]}.{purpose}")


def _move_into_place(staging: Path, out_dir: Path) -> None:
    if not out_dir.exists():
        os.replace(staging, out_dir)
        return
    # An existing directory cannot be renamed over portably: set it aside first, and put
    # it back if the rename fails, so out_dir always holds a complete recording.
    old = _sibling(out_dir, "old")
    os.replace(out_dir, old)
    try:
        os.replace(staging, out_dir)
    except BaseException:
        os.replace(old, out_dir)
        raise
    shutil.rmtree(old, ignore_errors=True)


def _csv_columns(rec: Recording) -> list[str]:
    """Column names: time first, then force (kind "force"), then the sensors in order."""
    channels = [_written_column(s.column, s.quantity) for s in rec.sensors]
    if rec.force is not None:
        channels.insert(0, _written_column(rec.excitation.column, "force"))
    if len(set(channels)) != len(channels):
        raise ValueError(f"two channels share a CSV column: {channels}")
    time_column = DEFAULT_TIME_COLUMN
    while time_column in channels:  # a channel may itself be called "time"
        time_column += "_s"
    return [time_column, *channels]


def _write_csv(path: Path, rec: Recording, columns: list[str]) -> None:
    blocks = [rec.time[:, None], rec.signals]
    if rec.force is not None:
        blocks.insert(1, rec.force[:, None])
    with path.open("w", newline="", encoding="utf-8") as stream:
        csv.writer(stream, lineterminator="\n").writerow(columns)
        # repr() is the shortest text that reads back to the same float: exact round trip.
        stream.writelines(",".join(map(repr, row)) + "\n" for row in np.hstack(blocks).tolist())


def _beam_toml(rec: Recording, time_column: str) -> str:
    scalars = {key: value for key, value in rec.extra.items() if not isinstance(value, dict)}
    tables = {key: value for key, value in rec.extra.items() if isinstance(value, dict)}
    lines = ["# Recording description; the format is documented in docs/format.md."]
    lines += _toml_pairs(scalars)  # top-level keys must precede every table header
    stated = rec.setup_keys
    lines += _toml_table(["beam"], {key: getattr(rec.beam, key) for key in _BEAM_KEYS} | stated.get("beam", {}))
    lines += _toml_table(["tip"], {key: getattr(rec.tip, key) for key in _TIP_KEYS} | stated.get("tip", {}))
    lines += _toml_table(["excitation"], _excitation_keys(rec.excitation) | stated.get("excitation", {}))
    if stated.get("setup"):
        lines += _toml_table(["setup"], stated["setup"])
    stated_sensors = [*stated.get("sensor", []), *[{}] * len(rec.sensors)]
    for sensor, stated_keys in zip(rec.sensors, stated_sensors):
        keys = {key: getattr(sensor, key) for key in _SENSOR_KEYS} | _written_unit(sensor, sensor.quantity)
        keys = keys | stated_keys
        lines += ["", "[[sensor]]", *_toml_pairs(keys)]
    lines += _toml_table(["recording"], {"file": DEFAULT_CSV, "time_column": time_column})
    for key, table in tables.items():
        lines += _toml_table([key], table)
    return "\n".join(lines) + "\n"


def _excitation_keys(excitation: Excitation) -> dict:
    values = {"kind": excitation.kind}
    for key in _EXCITATION_KEYS[excitation.kind]:
        values[key] = getattr(excitation, key)
        if values[key] is None:
            raise ValueError(f'excitation kind "{excitation.kind}" needs {key}, which is None')
    return values | (_written_unit(excitation, "force") if excitation.kind == "force" else {})


def _written_column(column: str, quantity: str) -> str:
    """The CSV column a channel is written to: its name as read, less a header unit other than
    SI (the values written are SI: ``Accel tip (g)`` is written as ``Accel tip``)."""
    name, stated = split_unit(column)
    unit = parse_unit(stated)
    return name if unit is not None and unit.symbol != SI_UNITS[quantity] else column


def _written_unit(channel: Sensor | Excitation, quantity: str) -> dict:
    """``column`` as written and, for a channel whose unit was stated, ``unit``: the SI unit of
    its quantity, since the values written are SI."""
    written = {"column": _written_column(channel.column, quantity)}
    return written | ({"unit": SI_UNITS[quantity]} if channel.unit is not None else {})


def _toml_table(path: list[str], table: dict) -> list[str]:
    """``[a.b]`` followed by its key = value lines, then its sub-tables."""
    lines = ["", "[" + ".".join(map(_toml_key, path)) + "]"]
    lines += _toml_pairs({key: value for key, value in table.items() if not isinstance(value, dict)})
    for key, value in table.items():
        if isinstance(value, dict):
            lines += _toml_table([*path, key], value)
    return lines


def _toml_pairs(table: dict) -> list[str]:
    return [f"{_toml_key(key)} = {_toml_value(value)}" for key, value in table.items()]


def _toml_key(key: str) -> str:
    return key if re.fullmatch(r"[A-Za-z0-9_-]+", key) else _toml_string(key)


def _toml_value(value) -> str:
    if isinstance(value, (bool, np.bool_)):
        return "true" if value else "false"
    if isinstance(value, (int, np.integer)):
        return str(int(value))
    if isinstance(value, (float, np.floating)):
        return repr(float(value))  # e.g. 5.6250000000000006e-11, inf, nan: all valid TOML
    if isinstance(value, str):
        return _toml_string(value)
    if isinstance(value, (datetime, date, clock_time)):
        return value.isoformat()
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(map(_toml_value, value)) + "]"
    if isinstance(value, dict):
        return "{" + ", ".join(f"{_toml_key(k)} = {_toml_value(v)}" for k, v in value.items()) + "}"
    raise TypeError(f"cannot write {type(value).__name__} value {value!r} to TOML")


_TOML_ESCAPES = {code: f"\\u{code:04X}" for code in [*range(0x20), 0x7F]} | {
    ord("\\"): "\\\\", ord('"'): '\\"', ord("\b"): "\\b", ord("\t"): "\\t",
    ord("\n"): "\\n", ord("\f"): "\\f", ord("\r"): "\\r",
}


def _toml_string(text: str) -> str:
    """A TOML basic string: quotes, backslashes and control characters escaped."""
    return '"' + text.translate(_TOML_ESCAPES) + '"'
