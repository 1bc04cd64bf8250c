r"""UFF (universal file format) in and out: time histories (dataset 58), modes (dataset 55).

Modal-analysis software (LMS Test.Lab, ME'scope, pyuff, MATLAB toolboxes) exchanges
measurements as UFF files. :func:`read_uff58` turns the time histories of one test (dataset
58, function type 1 "time response": a force and the responses, each at a node and
direction, with units) into a :class:`~bayesbeam.io.Recording`; :func:`write_uff58` writes a
recording back out; :func:`write_uff_modes` writes identified modes (dataset 55). All go
through pyuff.

What a file does not say comes from a ``beam.toml`` (:func:`load_beam_description`):
``[beam]`` and ``[tip]`` as in docs/format.md; ``[excitation]`` only for kind ``"release"``
or ``"free_decay"`` (with a force channel the kind is ``"force"`` and its location is the
force channel's node); and optionally ``[nodes]``, node number -> position x (m from the
clamp), e.g. ``3 = 0.75``. Without ``[nodes]`` the positions are the x coordinates of the
file's node datasets (2411 or 15), which therefore must put the clamp at x = 0 with the beam
along +x. ``[[sensor]]`` and ``[recording]`` tables are not used (the channels come from the
file), so a recording's own beam.toml can be passed as it is.

Reading rules (each refusal is a :class:`~bayesbeam.io.RecordingError` naming the dataset):

* Channels: datasets 58 of function type 1; others (FRFs, spectra) are skipped with a warning.
  The quantity is the ordinate's specific data type (8 displacement, 11 velocity,
  12 acceleration, 13 excitation force) or, when that is 0 (unknown), its units label.
  Exactly one force channel or none.
* Units: a recognised ordinate units label (``m/s^2``, ``m/s2``, ``g``, ``mm/s``, ``N``,
  ``kN``, ... see :mod:`bayesbeam.io.units`) converts to SI; a blank or ``NONE`` label means the units of
  dataset 164 (SI without one), converted with its length and force factors. An
  unrecognised label is refused.
* Direction: every channel must measure along one axis (``|dir|`` in 1-3, the bending
  direction); a channel with a negative direction is sign-flipped, so that all are positive
  along that axis.
* Time: all channels must share the first time, the step and the number of samples. The
  format prints the step with 6 significant digits (E13.5); the sampling rate with the
  fewest significant digits that prints the same step is taken, so 4.88281e-04 s reads
  back as 1/2048 s exactly. The first time is likewise limited to 6 digits.
* Names: a channel's name (and its column in a written recording) is its ID line 1, or
  ``"{quantity}_{node}"`` when that is blank; names must be distinct.

Writing: dataset 164 (SI), 2411 (one node per distinct position, numbered 1, 2, ... from the
clamp, :func:`node_numbers`, coordinates (x, 0, 0) in m), then one dataset 58 per channel --
the force first -- along +Z (direction 3), ID line 1 = sensor name (or force column), with
SI units labels. ASCII data are printed with 12 significant digits; ``binary=True`` writes
dataset 58b, whose samples are the float64 values themselves. Files are written to a
temporary name and renamed into place.
"""

from __future__ import annotations

import math
import os
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .atomic import atomic_write
from .channels import checked_table
from .errors import RecordingError
from .recording import (
    _KNOWN_TABLES,
    Beam,
    Excitation,
    Recording,
    Sensor,
    TipBody,
    _number,
    _read_beam,
    _read_excitation,
    _read_tip,
    _read_toml,
    _within_beam,
)
from .table import Channel, ChannelTable
from .units import parse_unit

__all__ = [
    "BeamDescription",
    "load_beam_description",
    "node_numbers",
    "read_uff58",
    "read_uff58_channels",
    "write_uff58",
    "write_uff_modes",
]

#: UFF58 ordinate specific data type -> quantity
SPEC_TYPES = {8: "displacement", 11: "velocity", 12: "acceleration", 13: "force"}
#: the SI label written for each quantity, and its exponents of length and force (dataset 164)
SI_LABELS = {"displacement": "m", "velocity": "m/s", "acceleration": "m/s^2", "force": "N"}
_EXPONENTS = {"displacement": (1, 0), "velocity": (1, 0), "acceleration": (1, 0), "force": (0, 1)}
_TIME_RESPONSE = 1
_Z = 3


# --------------------------------------------------------------------------- beam.toml


@dataclass(frozen=True)
class BeamDescription:
    """What a UFF file cannot say: beam, tip body, a non-force excitation, node positions (m)."""

    file: Path
    beam: Beam
    tip: TipBody
    excitation: Excitation | None
    nodes: dict[int, float]
    extra: dict


def load_beam_description(path: str | os.PathLike) -> BeamDescription:
    """Read ``[beam]``, ``[tip]``, ``[excitation]`` and ``[nodes]`` of a beam.toml (module docstring).

    ``[excitation]`` is optional; when its kind is "force", only an optional ``location`` is
    read (to check the force channel's node against). Other tables but the recording
    format's own go to ``extra``. Raises RecordingError naming the key and the fix.
    """
    file = Path(path)
    if not file.is_file():
        raise RecordingError(file, "file", "no such file", "pass the path of a beam.toml with a [beam] table.")
    doc = _read_toml(file)
    beam = _read_beam(doc, file)
    extra = {k: v for k, v in doc.items() if k not in (*_KNOWN_TABLES, "nodes")}
    return BeamDescription(
        file, beam, _read_tip(doc, file), _excitation(doc, file, beam.length), _nodes(doc, file, beam.length), extra
    )


def _excitation(doc: dict, file: Path, length: float) -> Excitation | None:
    table = doc.get("excitation")
    if table is None:
        return None
    if isinstance(table, dict) and table.get("kind") == "force":
        location = table.get("location")
        if location is not None:
            location = _within_beam(_number(table, "location", "[excitation]", file), "[excitation] .location",
                                    file, length)
        return Excitation("force", location=location)
    return _read_excitation(doc, file, length)


def _nodes(doc: dict, file: Path, length: float) -> dict[int, float]:
    table = doc.get("nodes", {})
    if not isinstance(table, dict):
        raise RecordingError(file, "[nodes]", "is not a table", "write [nodes] followed by lines `3 = 0.75`.")
    nodes = {}
    for key in table:
        if not key.isdigit():
            raise RecordingError(file, f"[nodes] .{key}", "is not a node number",
                                 "use the UFF node numbers as keys, e.g. `3 = 0.75`.")
        nodes[int(key)] = _within_beam(_number(table, key, "[nodes]", file), f"[nodes] .{key}", file, length)
    return nodes


# --------------------------------------------------------------------------- writing


def node_numbers(locations) -> dict[float, int]:
    """Node number of each distinct position (m): 1, 2, ... in increasing distance from the clamp."""
    return {x: k for k, x in enumerate(sorted({float(x) for x in locations}), 1)}


def _atomic_write(path: Path, datasets: list[dict]) -> Path:
    """Write ``datasets`` with pyuff to ``path`` atomically."""
    import pyuff

    return atomic_write(path, lambda p: pyuff.UFF(str(p)).write_sets(datasets, mode="overwrite"))


def _header_sets(nodes: dict[float, int]) -> list[dict]:
    """Dataset 164 (SI units) and 2411 (the nodes, at (x, 0, 0) m)."""
    units = {"type": 164, "units_code": 1, "units_description": "SI", "temp_mode": 1,
             "length": 1.0, "force": 1.0, "temp": 1.0, "temp_offset": 273.15}
    numbers = list(nodes.values())
    geometry = {"type": 2411, "node_nums": numbers, "def_cs": [0] * len(numbers), "disp_cs": [0] * len(numbers),
                "color": [8] * len(numbers), "x": list(nodes), "y": [0.0] * len(numbers), "z": [0.0] * len(numbers)}
    return [units, geometry]


def _dataset58(name: str, quantity: str, node: int, ref_node: int, time, data, binary: bool) -> dict:
    length_exp, force_exp = _EXPONENTS[quantity]
    return {
        "type": 58, "binary": int(binary), "func_type": _TIME_RESPONSE,
        "id1": name, "id2": quantity, "id3": "NONE", "id4": "NONE", "id5": "NONE",
        "rsp_ent_name": "beam", "rsp_node": node, "rsp_dir": _Z,
        "ref_ent_name": "beam", "ref_node": ref_node, "ref_dir": _Z if ref_node else 0,
        "abscissa_spacing": 1, "abscissa_spec_data_type": 17, "abscissa_axis_lab": "Time",
        "abscissa_axis_units_lab": "s",
        "ordinate_spec_data_type": {v: k for k, v in SPEC_TYPES.items()}[quantity],
        "ordinate_len_unit_exp": length_exp, "ordinate_force_unit_exp": force_exp,
        "ordinate_axis_lab": quantity, "ordinate_axis_units_lab": SI_LABELS[quantity],
        "orddenom_spec_data_type": 0, "x": time, "data": np.asarray(data, dtype=float),
    }


def _check_names(rec: Recording) -> None:
    names = [s.name for s in rec.sensors] + ([rec.excitation.column] if rec.force is not None else [])
    if max(map(len, names)) > 80:
        raise ValueError(f"{rec.source}: channel names {names} do not fit UFF's 80-character ID line. "
                         "Fix: shorten the sensor names.")


def write_uff58(rec: Recording, path: str | os.PathLike, *, binary: bool = False) -> Path:
    """Write ``rec``'s force (if any) and sensor channels as UFF58 time histories (module docstring).

    Returns the path written. ``binary=True`` writes dataset 58b (exact float64 samples).
    """
    _check_names(rec)
    locations = [s.location for s in rec.sensors]
    if rec.force is not None:
        locations.append(rec.excitation.location)
    nodes = node_numbers(locations)
    time = rec.time[0] + rec.dt * np.arange(rec.n_samples)  # pyuff takes the step from x[1] - x[0]
    ref = nodes[float(rec.excitation.location)] if rec.force is not None else 0
    sets = _header_sets(nodes)
    if rec.force is not None:
        sets.append(_dataset58(rec.excitation.column, "force", ref, ref, time, rec.force, binary))
    for j, sensor in enumerate(rec.sensors):
        sets.append(_dataset58(sensor.name, sensor.quantity, nodes[float(sensor.location)], ref, time,
                               rec.signals[:, j], binary))
    return _atomic_write(Path(path), sets)


def write_uff_modes(path: str | os.PathLike, locations, modes, frequencies_hz, damping_ratios, shapes) -> Path:
    """Write identified modes as dataset 55 (complex modes, analysis type 3), with 164 and 2411.

    ``locations`` (m) of the shape components, ``modes`` (mode numbers), ``frequencies_hz``
    (undamped, Hz), ``damping_ratios`` (fractions), ``shapes`` complex (n_locations, n_modes),
    displacement along +Z. Components at one position are averaged. The eigenvalue written is
    ``s = w (-zeta + i sqrt(1 - zeta^2))`` in rad/s; the format prints 6 significant digits.
    """
    nodes = node_numbers(locations)
    where = np.array([nodes[float(x)] for x in locations])
    numbers = np.array(list(nodes.values()))
    sets = _header_sets(nodes)
    for k, (mode, f, zeta) in enumerate(zip(modes, frequencies_hz, damping_ratios)):
        shape = np.array([np.mean(np.asarray(shapes)[where == n, k]) for n in numbers], dtype=complex)
        w = 2 * np.pi * f
        sets.append({
            "type": 55, "id1": f"bayesbeam ERA mode {mode}", "id2": f"f = {float(f)!r} Hz, zeta = {float(zeta)!r}",
            "model_type": 1, "analysis_type": 3, "data_ch": 2, "spec_data_type": 8,
            "load_case": 1, "mode_n": int(mode), "eig": w * complex(-zeta, math.sqrt(1 - zeta**2)),
            "node_nums": numbers, "r1": np.zeros_like(shape), "r2": np.zeros_like(shape), "r3": shape,
        })
    return _atomic_write(Path(path), sets)


# --------------------------------------------------------------------------- reading


@dataclass(frozen=True)
class _Channel:
    index: int  # position of the dataset in the file, 0-based
    name: str
    quantity: str
    node: int
    axis: int
    data: np.ndarray
    start: float
    step: float


def _fail(file, k: int, dset: dict, problem: str, fix: str):
    label = str(dset.get("id1", "")).strip()
    raise RecordingError(file, f"dataset #{k + 1} (58, {label!r})", problem, fix)


def _read_sets(file: Path) -> list[dict]:
    import pyuff

    if not file.is_file():
        raise RecordingError(file, "file", "no such file", "pass the path of a UFF file (.uff or .unv).")
    try:
        sets = pyuff.UFF(str(file)).read_sets()
    except Exception as err:  # pyuff raises bare Exception for any malformed block
        raise RecordingError(file, "file", f"not a readable UFF file ({err})",
                             "export the time histories as UFF dataset 58 (ASCII or 58b).") from err
    return [sets] if isinstance(sets, dict) else list(sets)


def _unit_factors(sets: list[dict]) -> tuple[float, float]:
    """Length and force factors of dataset 164 (SI = value / factor); (1, 1) without one."""
    units = [s for s in sets if s.get("type") == 164]
    return (float(units[0]["length"]), float(units[0]["force"])) if units else (1.0, 1.0)


def _file_nodes(sets: list[dict]) -> dict[int, float]:
    """Node number -> x coordinate from datasets 2411 or 15."""
    nodes = {}
    for s in sets:
        if s.get("type") in (15, 2411):
            nodes.update({int(n): float(x) for n, x in zip(s["node_nums"], s["x"])})
    return nodes


def _label(dset: dict) -> str:
    text = str(dset.get("ordinate_axis_units_lab", "")).strip().lower().replace(" ", "").replace("**", "^")
    return "" if text == "none" else text.replace("sec", "s").replace("µ", "u").replace("²", "^2")


def _quantity_and_factor(file, k, dset, factors) -> tuple[str, float]:
    label = _label(dset)
    quantity = SPEC_TYPES.get(int(dset.get("ordinate_spec_data_type", 0)))
    unit = parse_unit(label, ignore_case=True) if label else None
    if unit is not None and unit.quantity in SI_LABELS:
        unit_quantity, factor = unit.quantity, unit.factor
        if quantity not in (None, unit_quantity):
            _fail(file, k, dset, f"units {label!r} do not fit the data type {quantity}",
                  f"label the units of a {quantity} in SI ({SI_LABELS[quantity]}) or fix the data type.")
        return unit_quantity, factor
    if label or quantity is None:
        _fail(file, k, dset, f"units label {label!r} with data type {dset.get('ordinate_spec_data_type')} "
              "is not a known displacement, velocity, acceleration or force",
              f"export in SI units (labels {', '.join(SI_LABELS.values())}) or set the ordinate data type "
              "(8 displacement, 11 velocity, 12 acceleration, 13 force).")
    length_exp, force_exp = _EXPONENTS[quantity]
    return quantity, 1.0 / (factors[0] ** length_exp * factors[1] ** force_exp)


def _sample_step(step: float) -> float:
    """The step with the shortest sampling rate that prints as ``step`` does in E13.5."""
    printed = f"{step:.5e}"
    for digits in range(1, 7):
        rate = float(f"{1.0 / step:.{digits}g}")
        if f"{1.0 / rate:.5e}" == printed:
            return 1.0 / rate
    return step


def _channel(file, k: int, dset: dict, factors) -> _Channel:
    quantity, factor = _quantity_and_factor(file, k, dset, factors)
    direction = int(dset["rsp_dir"])
    if not 1 <= abs(direction) <= 3:
        _fail(file, k, dset, f"direction {direction} is not a translation",
              "export the bending (translational) direction, 1-3 or -1 to -3.")
    if int(dset.get("abscissa_spacing", 1)) != 1:
        _fail(file, k, dset, "uneven abscissa spacing", "export uniformly sampled time histories.")
    name = str(dset.get("id1", "")).strip()
    data = np.asarray(dset["data"], dtype=float) * factor * np.sign(direction)
    return _Channel(k, name if name and name.upper() != "NONE" else f"{quantity}_{int(dset['rsp_node'])}",
                    quantity, int(dset["rsp_node"]), abs(direction), data,
                    float(dset["abscissa_min"]), _sample_step(float(dset["abscissa_inc"])))


def _time_channels(file: Path, sets: list[dict]) -> list[_Channel]:
    factors = _unit_factors(sets)
    channels, skipped = [], []
    for k, dset in enumerate(sets):
        if dset.get("type") != 58:
            continue
        if int(dset.get("func_type", 0)) != _TIME_RESPONSE:
            skipped.append(k + 1)
            continue
        channels.append(_channel(file, k, dset, factors))
    if skipped:
        warnings.warn(f"{file}: datasets {skipped} are not time histories (function type 1): skipped",
                      stacklevel=3)
    if not channels:
        raise RecordingError(file, "file", "no dataset 58 with function type 1 (time response)",
                             "export the measured time histories, not FRFs or spectra.")
    return channels


def _check_channels(file: Path, sets: list[dict], channels: list[_Channel]) -> None:
    first = channels[0]
    for c in channels[1:]:
        same = (c.axis, c.data.size, c.start, c.step) == (first.axis, first.data.size, first.start, first.step)
        if not same:
            _fail(file, c.index, sets[c.index],
                  f"axis {c.axis}, {c.data.size} samples from {c.start!r} s every {c.step!r} s differ from "
                  f"dataset #{first.index + 1}'s axis {first.axis}, {first.data.size} from {first.start!r} "
                  f"every {first.step!r}", "export all channels of one test, sampled together, along one axis.")
        if c.name in [d.name for d in channels[: channels.index(c)]]:
            _fail(file, c.index, sets[c.index], f"channel name {c.name!r} is used twice",
                  "give every channel a distinct ID line 1.")
    if sum(c.quantity == "force" for c in channels) > 1:
        raise RecordingError(file, "file", "more than one force channel", "keep the one force of this test.")
    if all(c.quantity == "force" for c in channels):
        raise RecordingError(file, "file", "no response channel", "export the responses along with the force.")


def _location(file: Path, sets, c: _Channel, nodes: dict[int, float], desc: BeamDescription) -> float:
    if c.node not in nodes:
        _fail(file, c.index, sets[c.index], f"node {c.node} has no position",
              f"add `{c.node} = <x in m from the clamp>` to [nodes] in {desc.file}.")
    if c.node in desc.nodes:  # already checked against the beam by load_beam_description
        return desc.nodes[c.node]
    return _within_beam(nodes[c.node], f"node {c.node} (dataset 2411 or 15)", file, desc.beam.length)


def _recording_excitation(desc: BeamDescription, force: _Channel | None, location: float | None) -> Excitation:
    given = desc.excitation
    if force is None:
        if given is None or given.kind == "force":
            raise RecordingError(desc.file, "[excitation]", "the UFF file has no force channel",
                                 'set kind = "release" (with tip_load) or "free_decay" (with start).')
        return given
    if given is not None and given.kind != "force":
        raise RecordingError(desc.file, "[excitation] .kind", f'"{given.kind}" but the UFF file has a force channel',
                             'remove [excitation] or set kind = "force".')
    if given is not None and given.location is not None and not math.isclose(given.location, location):
        raise RecordingError(desc.file, "[excitation] .location",
                             f"{given.location!r} m, but force node {force.node} is at {location!r} m",
                             "correct the location or the node position.")
    return Excitation("force", location=location, column=force.name)


def read_uff58(uff_path: str | os.PathLike, beam_path: str | os.PathLike) -> Recording:
    """The recording held by a UFF file's time histories; beam and set-up from ``beam_path``.

    See the module docstring for what is read and refused. ``Recording.source`` is the UFF
    file; ``extra`` holds beam.toml's other tables.
    """
    file = Path(uff_path)
    desc = load_beam_description(beam_path)
    sets = _read_sets(file)
    channels = _time_channels(file, sets)
    _check_channels(file, sets, channels)
    nodes = {**_file_nodes(sets), **desc.nodes}
    located = [(c, _location(file, sets, c, nodes, desc)) for c in channels]
    force = next(((c, x) for c, x in located if c.quantity == "force"), (None, None))
    sensors = [(Sensor(c.name, x, c.quantity, c.name), c.data) for c, x in located if c.quantity != "force"]
    excitation = _recording_excitation(desc, *force)
    first = channels[0]
    time = first.start + first.step * np.arange(first.data.size)
    if excitation.kind == "free_decay" and not time[0] <= excitation.start < time[-1]:
        raise RecordingError(desc.file, "[excitation] .start", f"{excitation.start!r} s is outside the record "
                             f"[{time[0]!r}, {time[-1]!r}] s", "set start inside the UFF record.")
    return Recording(desc.beam, desc.tip, excitation, tuple(s for s, _ in sensors), time,
                     np.column_stack([d for _, d in sensors]), None if force[0] is None else force[0].data,
                     file, desc.extra)


def read_uff58_channels(uff_path: str | os.PathLike) -> ChannelTable:
    """A UFF file's time histories as named channels, without a beam description.

    Read and refused as :func:`read_uff58` reads them (module docstring): each channel is in SI
    (its unit the SI label of its quantity) and sign-flipped along +axis; the metadata give each
    channel's node (``node <name>``) and the node's x coordinate (m) when the file has one.
    """
    file = Path(uff_path)
    sets = _read_sets(file)
    channels = _time_channels(file, sets)
    _check_channels(file, sets, channels)
    nodes = _file_nodes(sets)
    first = channels[0]
    metadata = {f"node {c.name}": f"{c.node}" + (f" (x = {nodes[c.node]!r} m)" if c.node in nodes else "")
                for c in channels}
    return checked_table(file, [Channel(c.name, SI_LABELS[c.quantity], c.data) for c in channels],
                         time=first.start + first.step * np.arange(first.data.size), sample_rate=1.0 / first.step,
                         metadata=metadata)
