"""The unit check names a channel recorded in the wrong unit, and names nothing on a clean record.

Recordings come from the independent reference simulator (tests/reference: finite elements, exact
stepping, its own DAQ), never from bayesbeam's model: the paper's beam (l = 1 m, rho A = 1.02
kg/m) whose beam.toml states E 15 % above the truth (every nominal frequency 7 % high), an
unstated 5 g sensor at the tip (the simulator's m_s, at the first sensor), q1 damping, 1 %
sensor and 0.5 % force noise, 4 s at 512 Hz (modes 1-4 in the passband). One simulation records
the same test with every sensor the traps need; a trap takes its channels from it and scales one,
as an export in another unit would.

Tolerances. A unit is asserted by name: the check's verdict is discrete, and the names it must
tell apart lie far apart (g 9.81, lbf 4.45, mm 1000, a velocity 2 pi f = 23-800 here) against
its factor 2. The clean record's measured / nominal ratios are asked to lie within 25 % of 1: the
modal constant does not see E, 5 g moves the tip's mass-normalised mode shapes by < 1 %, the
residue fits are within a few % at 1 % noise (0.94-1.03 here), and the position rule keeps the
sensors away from nodes; 25 % is far inside the check's own factor 2, so a nominal gain 10x (or
2x) wrong fails it. Every test asks that modes were judged, so none passes by judging nothing.
"""
import json
from dataclasses import replace
from functools import cache
from pathlib import Path

import numpy as np
import pytest

from bayesbeam.checks.survey import survey
from bayesbeam.checks.units import FACTOR, unit_check
from bayesbeam.cli import main
from bayesbeam.io import Beam, Excitation, Recording, Sensor, load_recording, write_recording
from tests.reference import Hammer, Noise, Release, record

EXAMPLES = Path(__file__).resolve().parents[2] / "data" / "examples"
E_TRUE = 2.68e10
BEAM = Beam(1.0, 1710.0, 0.597e-3, 1.64e-9, 1.15 * E_TRUE)   # beam.toml's nominal E: 15 % high
DAMPING = {"gamma": 0.3, "cdI": 7e-5}
SENSORS = {"accel_tip": Sensor("accel_tip", 1.0, "acceleration", "accel_tip"),
           "accel_mid": Sensor("accel_mid", 0.4, "acceleration", "accel_mid"),
           "vel_tip": Sensor("vel_tip", 1.0, "velocity", "vel_tip"),
           "disp_mid": Sensor("disp_mid", 0.4, "displacement", "disp_mid")}
LBF, G = 4.4482216152605, 9.80665
#: measured / nominal on a clean record (module docstring)
CLEAN = 1.25


@cache
def hammer(**effects) -> Recording:
    """The hammer test at 0.75 m with every sensor; the 5 g sensor mass at the tip (first sensor)."""
    return record(BEAM, DAMPING, excitation=Hammer(0.75), fs=512, duration=4.0, EI=E_TRUE * BEAM.second_moment,
                  effects={"m_s": 0.005, **effects}, sensors=tuple(SENSORS.values()),
                  noise=Noise(sensor=0.01, force=0.005), seed=3)


def channels(rec: Recording, names, scale=(), force: float = 1.0, stated=None, excitation=None) -> Recording:
    """``rec`` with the channels ``names`` (scaled by ``scale``: name -> factor), the force times
    ``force``; ``stated`` (name -> Sensor) describes a channel as something else than it holds."""
    index = [list(SENSORS).index(n) for n in names]
    sensors = tuple((stated or {}).get(n, SENSORS[n]) for n in names)
    signals = rec.signals[:, index] * np.array([dict(scale).get(n, 1.0) for n in names])
    excitation = excitation or rec.excitation
    kept = None if excitation.kind != "force" else rec.force * force
    return Recording(rec.beam, rec.tip, excitation, sensors, rec.time, signals, kept)


def check(rec: Recording) -> dict:
    return unit_check(rec, survey(rec).summary)


def verdicts(units: dict) -> dict:
    return {c["name"]: c for c in units["channels"]}


def judged(channel: dict) -> int:
    return sum(r is not None for r in channel["ratios"])


@pytest.mark.parametrize(("effects", "within"), [({}, CLEAN), ({"k_theta": 1000.0}, 1.5)],
                         ids=["clamped", "compliant clamp"])
def test_clean_hammer_names_nothing(effects, within):
    """E 15 % off, an unstated 5 g sensor, and (second case) a root spring of 1000 N m/rad (~23
    EI/l, mode 1 9 % low): nothing named, each channel as stated at >= 2 modes with every ratio
    within CLEAN of 1, or 1.5 with the root spring: its root rotation changes the mode shapes the
    nominal model takes clamped, by up to 30 % at 0.4 m (0.83-1.30 here), still inside FACTOR."""
    units = check(channels(hammer(**effects), ["accel_tip", "accel_mid", "disp_mid"]))
    assert units["findings"] == [] and units["force"]["verdict"] == "as stated"
    for channel in units["channels"]:
        assert channel["verdict"] == "as stated" and judged(channel) >= 2, channel
        ratios = np.array([r for r in channel["ratios"] if r is not None])
        assert np.all(np.abs(np.log(ratios)) < np.log(within)), channel


TRAPS = {
    # name: (channels, scale, force factor, stated, the channel named, its unit, its quantity)
    "tip in g": (["accel_tip", "accel_mid"], {"accel_tip": 1 / G}, 1.0, None, "accel_tip", "g", "acceleration"),
    "mid in g": (["accel_tip", "accel_mid"], {"accel_mid": 1 / G}, 1.0, None, "accel_mid", "g", "acceleration"),
    "tip in mm/s^2": (["accel_tip", "accel_mid"], {"accel_tip": 1e3}, 1.0, None, "accel_tip", "mm/s^2",
                      "acceleration"),
    "mid in mm/s^2": (["accel_tip", "accel_mid"], {"accel_mid": 1e3}, 1.0, None, "accel_mid", "mm/s^2",
                      "acceleration"),
    "velocity stated as acceleration": (["vel_tip", "accel_mid"], {}, 1.0,
                                        {"vel_tip": replace(SENSORS["vel_tip"], quantity="acceleration")},
                                        "vel_tip", "m/s", "velocity"),
    "displacement in mm": (["accel_tip", "disp_mid"], {"disp_mid": 1e3}, 1.0, None, "disp_mid", "mm", "displacement"),
    "displacement in um": (["accel_tip", "disp_mid"], {"disp_mid": 1e6}, 1.0, None, "disp_mid", "um", "displacement"),
}


@pytest.mark.parametrize("trap", TRAPS)
def test_a_channel_in_another_unit_is_named(trap):
    """The trapped channel, and only it, is named with its unit (and quantity); the sentence names
    the channel, the unit and the key to state."""
    names, scale, force, stated, wrong, unit, quantity = TRAPS[trap]
    units = check(channels(hammer(), names, scale, force, stated))
    found = verdicts(units)
    assert (found[wrong]["verdict"], found[wrong]["unit"], found[wrong]["quantity"]) == ("unit", unit, quantity)
    assert judged(found[wrong]) >= 2
    assert all(c["verdict"] == "as stated" for name, c in found.items() if name != wrong)
    (finding,) = units["findings"]
    assert f"channel {wrong} " in finding and f'unit = "{unit}"' in finding


def test_velocity_is_told_from_a_constant_factor_by_its_trend():
    """A velocity where an acceleration is stated reads 1/(2 pi f) of the model: 23x low at mode 1
    (3.7 Hz) and ~800x at mode 4 (127 Hz); each judged ratio within 25 % of 1 / (2 pi f_peak) (the
    fits' few % and the 5 g sensor), and the sentence says the ratio falls across modes."""
    stated = {"vel_tip": replace(SENSORS["vel_tip"], quantity="acceleration")}
    units = check(channels(hammer(), ["vel_tip", "accel_mid"], stated=stated))
    ratios = np.array([np.nan if r is None else r for r in verdicts(units)["vel_tip"]["ratios"]])
    expected = 1 / (2 * np.pi * np.array(units["frequency_hz"]))
    ok = np.isfinite(ratios)
    assert ok.sum() >= 2 and np.all(np.abs(np.log(ratios[ok] / expected[ok])) < np.log(CLEAN))
    assert "falls as (2 pi f)^1" in units["findings"][0] and 'quantity = "velocity"' in units["findings"][0]


def test_force_in_lbf_is_named_on_the_force():
    """Every channel reads 4.45x high: the force is named (lbf, in [excitation]), no channel is."""
    units = check(channels(hammer(), ["accel_tip", "accel_mid"], force=1 / LBF))
    assert units["force"] == {"verdict": "unit", "unit": "lbf"}
    assert all(c["verdict"] == "as stated" for c in units["channels"])
    (finding,) = units["findings"]
    assert 'unit = "lbf"' in finding and "[excitation]" in finding


def test_an_unexplained_factor_is_reported_as_such():
    """A channel 3x high (a wrong sensitivity, say): beyond FACTOR, no unit is 3x: "unexplained"."""
    units = check(channels(hammer(), ["accel_tip", "accel_mid"], {"accel_mid": 3.0}))
    assert verdicts(units)["accel_mid"]["verdict"] == "unexplained"
    assert verdicts(units)["accel_tip"]["verdict"] == "as stated"
    assert "unexplained" in units["findings"][0] and FACTOR < 3.0


def test_a_stated_unit_is_taken_as_converted():
    """A sensor stated in g whose (loaded, SI) signal is right is as stated; one stated in g whose
    file held m/s^2 (the reader multiplied it by 9.81) is named m/s^2."""
    stated = {"accel_mid": replace(SENSORS["accel_mid"], unit="g")}
    units = check(channels(hammer(), ["accel_tip", "accel_mid"], stated=stated))
    assert units["findings"] == []
    units = check(channels(hammer(), ["accel_tip", "accel_mid"], {"accel_mid": G}, stated=stated))
    assert verdicts(units)["accel_mid"]["unit"] == "m/s^2"


# ---------------------------------------------------------------------------- without a force
FREE = Excitation("free_decay", start=0.05)


@pytest.mark.parametrize("wrong", [None, "accel_tip", "accel_mid"])
def test_free_decay_channels_against_one_another(wrong):
    """After the hit (from 0.05 s) as an unmeasured tap: the channels' ratios at each mode against
    the mode shapes' ratios. Clean: nothing named; one channel in g: that one is named, not the
    other (whose ratio to it reads 9.81x high, which no unit explains)."""
    scale = {wrong: 1 / G} if wrong else {}
    units = check(channels(hammer(), ["accel_tip", "accel_mid"], scale, excitation=FREE))
    found = verdicts(units)
    assert units["reference"] is not None and "against one another" in units["note"]
    named = {name: c["unit"] for name, c in found.items() if c["verdict"] not in ("as stated", "reference")}
    assert named == ({wrong: "g"} if wrong else {})
    assert sum(judged(c) for c in found.values() if c["ratios"]) >= 2


def test_one_channel_without_a_force_is_not_judged():
    """A free decay with one channel has nothing to set its scale: said plainly, nothing named."""
    units = check(channels(hammer(), ["accel_tip"], {"accel_tip": 1 / G}, excitation=FREE))
    assert units["findings"] == [] and units["basis"] is None
    assert units["note"].startswith("not judged: one channel")


@cache
def release() -> Recording:
    """A release from 2 N at the tip, tip accelerometer and mid displacement, same beam and set-up."""
    return record(BEAM, DAMPING, excitation=Release(2.0), fs=512, duration=4.0, EI=E_TRUE * BEAM.second_moment,
                  effects={"m_s": 0.005}, sensors=(SENSORS["accel_tip"], SENSORS["disp_mid"]),
                  noise=Noise(sensor=0.01), seed=4)


def _release(scale: dict) -> Recording:
    rec = release()
    signals = rec.signals * np.array([scale.get(s.name, 1.0) for s in rec.sensors])
    return Recording(rec.beam, rec.tip, rec.excitation, rec.sensors, rec.time, signals)


def test_release_load_sets_the_scale():
    """With the tip load, one channel's unit is judged on its own: clean, every judged ratio within
    CLEAN of 1; the tip accelerometer in g is named even though the displacement is right, and
    a displacement in mm too."""
    units = check(_release({}))
    assert units["findings"] == []
    ratios = [r for c in units["channels"] for r in c["ratios"] if r is not None]
    assert len(ratios) >= 2 and np.all(np.abs(np.log(ratios)) < np.log(CLEAN))
    assert verdicts(check(_release({"accel_tip": 1 / G})))["accel_tip"]["unit"] == "g"
    assert verdicts(check(_release({"disp_mid": 1e3})))["disp_mid"]["unit"] == "mm"


# ---------------------------------------------------------------------------- shipped examples
@pytest.mark.parametrize("example", ["paper_q3_hammer", "paper_rootcomp_hammer", "alu_q1_release"])
def test_shipped_examples_name_nothing(example):
    """The examples (another independent generator; E 4 % off, a compliant root, a 50 g tip body
    and rotary inertia): nothing named, some mode judged."""
    units = check(load_recording(EXAMPLES / example))
    assert units["findings"] == []
    assert any(c["ratios"] and judged(c) for c in units["channels"])


def test_check_command_warns_and_writes_the_findings(tmp_path, capsys):
    """``bayesbeam check`` on a written recording with the mid channel in g: the warning on stderr,
    the finding in check.json and the verdicts in the printed report."""
    write_recording(channels(hammer(), ["accel_tip", "accel_mid"], {"accel_mid": 1 / G}), tmp_path / "rec")
    assert main(["check", str(tmp_path / "rec"), "--out", str(tmp_path / "out")]) == 0
    printed = capsys.readouterr()
    assert "bayesbeam check: warning: units: channel accel_mid" in printed.err and 'unit = "g"' in printed.err
    assert "accel_mid: unit -> acceleration in g" in printed.out
    summary = json.loads((tmp_path / "out" / "check.json").read_text())
    assert verdicts(summary["units"])["accel_mid"]["unit"] == "g" and len(summary["units"]["findings"]) == 1
