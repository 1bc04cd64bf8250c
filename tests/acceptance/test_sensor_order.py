"""From the lab's own export to the concealed mass, whatever the order of the ``[[sensor]]`` tables.

A hammer test of an aluminium strip (0.5 m x 25 mm x 3 mm) with a 20 g tip block, an accelerometer
at the tip (its 4 g stated in beam.toml) and one at mid-span whose 5 g are not written down; true
damping q3 (air + spatial hysteresis). Made by the independent reference simulator
(:mod:`tests.reference`: both sensors' masses in its mass matrix), 0.5 s at 1024 Hz, 2 % sensor
and 0.5 % force noise, beam.toml's modulus 7 % above the truth. The fitted band is 200 Hz: modes
1-3 (7.0, 48.0 and 148.4 Hz).

The recording reaches bayesbeam as a DAQ's text export: two ``#`` metadata lines, tabs, a header
with units (``Time (s)``, ``Hammer (N)``, ``Accel tip (g)``, ``Accel mid (g)``), accelerations in
g, the time printed with 9 decimals. ``bayesbeam import`` with a beam description that names
neither unit (the header states them) turns it into a recording folder; ``check`` must then name
no channel's unit, and on the same export whose header leaves the units out it must name g for
both accelerometers.

``diagnose`` without a named model (air and q3 compared first, then the screen, the augmented
fits and the damping re-check) on the imported recording whose description lists
the mid-span sensor first must add the sensor mass at the mid-span sensor and end the damping
re-check at q3 + sensor_mass with the 5 g inside the 99 % interval of m_s_mid there. That the
order changes nothing is asserted exactly, not statistically: the log posterior of q3 +
sensor_mass at the same named parameter values is the same number on both orders (to rounding),
and so is the screen's ranking (tests/checks/test_signatures.py names the mid-span sensor in both
orders); every later step of a diagnosis sees the recording only through them.

One round (``rounds = 1``): one effect is concealed, and a second round's fits (three models
here) would double a diagnosis's time without bearing on the order. Two worker processes, as
the suite's other diagnoses.
"""
import warnings
from dataclasses import replace

import numpy as np
import pytest

from bayesbeam.checks.survey import survey
from bayesbeam.checks.units import unit_check
from bayesbeam.comparison import CompareConfig
from bayesbeam.diagnosis import DiagnoseConfig, diagnose
from bayesbeam.inference.fit import FitConfig, prepare
from bayesbeam.io import Sensor, TipBody, load_recording
from bayesbeam.io.importer import import_file
from tests.inference import cases
from tests.reference import Hammer, record
from tests.reference.recordings import ALU_DAMPING, NOISE

#: standard gravity, m/s^2 (CGPM 1901): an export in g holds the acceleration over it
G = 9.80665
TIP_BLOCK = TipBody(mass=0.020, rotary_inertia=4e-7)
#: the tip accelerometer's mass, stated; the mid-span one's, concealed (kg)
TIP_MASS, MID_MASS = 0.004, 0.005
SENSORS = (Sensor("tip", 0.5, "acceleration", "accel_tip"), Sensor("mid", 0.25, "acceleration", "accel_mid"))
#: the export's header cell of each channel, and the column `bayesbeam import` makes of it
HEADER = {"force": "Hammer", "tip": "Accel tip", "mid": "Accel mid"}
COLUMN = {name: cell.replace(" ", "_") for name, cell in HEADER.items()}
#: as tests/acceptance/test_diagnose.py (quintic splines, N chosen automatically, 2 SMC repeats,
#: 20 map replicates), in a 200 Hz band; the damping models air (the first comparison's winner
#: while the mass is unmodelled) and q3 (the truth, which nests air), as ``--models air,q3``:
#: choosing among all five is tests/acceptance/test_compare.py's
CONFIG = DiagnoseConfig(CompareConfig(FitConfig(n_intervals=None, degree=5, max_frequency=200.0), repeats=2,
                                      replicates=20), rounds=1, replicates=20, models=("air", "q3"))


def simulated():
    """The test, in SI: the truth holds both sensors' masses."""
    beam = cases.ALU_BEAM
    return record(replace(beam, modulus=1.07 * beam.modulus), ALU_DAMPING["q3"], EI=beam.nominal_EI, tip=TIP_BLOCK,
                  excitation=Hammer(0.375, peak=5.0, width=1e-3, t0=0.01), fs=1024.0, duration=0.5,
                  effects={"sensor_masses": (TIP_MASS, MID_MASS)}, sensors=SENSORS, noise=NOISE, seed=3,
                  name="alu_q3_concealed_mid_sensor")


def export(rec, path, *, units: bool):
    """``rec`` as the acquisition software writes it (module docstring); ``units=False`` leaves the
    header's units out."""
    unit = {"force": " (N)", "tip": " (g)", "mid": " (g)"} if units else dict.fromkeys(HEADER, "")
    header = ["Time (s)"] + [HEADER[k] + unit[k] for k in ("force", "tip", "mid")]
    lines = ["# Exported by the DAQ, 2026-11-20 14:03:11", f"# Sample rate: {rec.fs:g} Hz", "\t".join(header)]
    for t, f, (tip, mid) in zip(rec.time, rec.force, rec.signals / G):
        lines.append(f"{t:.9f}\t{f:.7g}\t{tip:.8g}\t{mid:.8g}")
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path


def description(rec, path, order):
    """A beam description naming each channel's column but no unit; the sensors in ``order``."""
    beam, exc = rec.beam, rec.excitation
    text = [(f"[beam]\nlength = {beam.length!r}\ndensity = {beam.density!r}\narea = {beam.area!r}\n"
             f"second_moment = {beam.second_moment!r}\nmodulus = {beam.modulus!r}\n"),
            f"[tip]\nmass = {TIP_BLOCK.mass!r}\nrotary_inertia = {TIP_BLOCK.rotary_inertia!r}\n",
            f'[excitation]\nkind = "force"\nlocation = {exc.location!r}\ncolumn = "{COLUMN["force"]}"\n']
    for name in order:
        sensor = next(s for s in SENSORS if s.name == name)
        mass = f"mass = {TIP_MASS!r}\n" if name == "tip" else ""
        text.append(f'[[sensor]]\nname = "{name}"\nlocation = {sensor.location!r}\nquantity = "acceleration"\n'
                    f'column = "{COLUMN[name]}"\n{mass}')
    path.write_text("\n".join(text), encoding="utf-8")
    return path


@pytest.fixture(scope="module")
def lab(tmp_path_factory):
    """{name: imported recording}: "tip_first" and "mid_first" from the export with units, and
    "no_units" (tip first) from the one without; no warning raised on the way."""
    rec, folder = simulated(), tmp_path_factory.mktemp("lab")
    out = {}
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        for name, units, order in (("tip_first", True, ("tip", "mid")), ("mid_first", True, ("mid", "tip")),
                                   ("no_units", False, ("tip", "mid"))):
            source = export(rec, folder / f"export_{units}.txt", units=units)
            imported = import_file(source, folder / name, beam=description(rec, folder / f"{name}.toml", order))
            out[name] = load_recording(imported)
    return out


@pytest.fixture(scope="module")
def diagnosed(lab, executor):
    return diagnose(lab["mid_first"], None, CONFIG, executor)


def test_the_import_reads_the_export_in_si(lab):
    """The imported channels are the simulated SI signals to the export's 8 printed digits (5e-9
    relative of each sample, 1e-7 of the peak with the factor's rounding), in the stated order."""
    rec = simulated()
    tip_first, mid_first = lab["tip_first"], lab["mid_first"]
    assert [s.name for s in tip_first.sensors] == ["tip", "mid"] and [s.unit for s in tip_first.sensors] == ["g"] * 2
    np.testing.assert_allclose(tip_first.signals, rec.signals, rtol=0, atol=1e-7 * np.abs(rec.signals).max())
    np.testing.assert_array_equal(mid_first.signals, tip_first.signals[:, ::-1])
    np.testing.assert_array_equal(tip_first.time, np.arange(rec.n_samples) / rec.fs)


def test_check_names_no_unit_when_stated_and_g_when_left_out(lab):
    stated = unit_check(lab["tip_first"], survey(lab["tip_first"]).summary)
    assert [c["verdict"] for c in stated["channels"]] == ["as stated"] * 2, stated
    left_out = unit_check(lab["no_units"], survey(lab["no_units"]).summary)
    assert [(c["name"], c["unit"]) for c in left_out["channels"]] == [("tip", "g"), ("mid", "g")], left_out


def test_the_order_of_the_sensors_does_not_change_the_posterior(lab):
    """q3 + sensor_mass on both orders, at N = 8 quintic: the same parameter names, and at 20 sets of
    values drawn around the truth the two log posteriors agree to 1e-9 relative (the channels' sums
    are taken in another order: rounding only). The values of m_s_tip and m_s_mid swapped (a mass
    read by position, not by name) cost far more than 100 nats: the comparison has power."""
    config = FitConfig(degree=5, max_frequency=200.0, effects=("sensor_mass",))
    tip_first, mid_first = (prepare(lab[order], "q3", config, 8).posterior for order in ("tip_first", "mid_first"))
    assert sorted(tip_first.names) == sorted(mid_first.names)
    rng = np.random.default_rng(5)
    truth = {"EI": cases.ALU_BEAM.nominal_EI, **ALU_DAMPING["q3"], "m_s_tip": TIP_MASS, "m_s_mid": MID_MASS}
    for _ in range(20):
        values = {n: truth.get(n, p.to_value(p.median())) * np.exp(0.05 * rng.standard_normal())
                  for n, p in zip(tip_first.names, tip_first.priors)}
        a, b = tip_first(tip_first.coordinates(values)), mid_first(mid_first.coordinates(values))
        assert np.isfinite(a) and abs(a - b) <= 1e-9 * abs(a), (values, a, b)
    swapped = {**values, "m_s_tip": values["m_s_mid"], "m_s_mid": values["m_s_tip"]}
    assert mid_first(mid_first.coordinates(swapped)) < a - 100


@pytest.mark.slow
@pytest.mark.long
def test_the_concealed_mass_is_found_at_the_mid_span_sensor(diagnosed):
    """Added: sensor_mass, at the mid-span sensor; the damping re-check ends at q3 with the mass,
    and there the concealed 5 g lie inside m_s_mid's 99 % interval. The interval is the final
    model's: the mass first fitted beside the first comparison's damping model (air) is biased by
    that model's wrong damping."""
    summary = diagnosed.to_dict()
    assert diagnosed.added == ["sensor_mass"], summary["summary"]
    assert summary["added_labels"] == ["sensor_mass at mid"], summary["summary"]
    assert summary["final"]["model"] == "q3+sensor_mass", summary["summary"]
    draws = diagnosed.final.values()[..., diagnosed.final.problem.posterior.names.index("m_s_mid")]
    interval = np.quantile(draws, [0.005, 0.995])
    assert interval[0] <= MID_MASS <= interval[1], (interval, summary["summary"])
