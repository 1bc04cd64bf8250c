"""Recordings and diagnoses shared by the diagnosis and checks tests (computed once per pytest run).

Claims (a map that locates, a signature that names, a diagnosis that adds) are tested on the
independent reference simulator's recordings (:func:`reference`, never
:class:`bayesbeam.model.BeamModel`), in the setting of ``tests/acceptance/cases.py``: the paper's
beam (beam.toml's modulus 7 % above the truth), q1 damping, a 4 ms Gaussian hammer pulse at
0.75 m, a tip accelerometer, 1 s at 512 Hz, 2 % sensor noise. The force channel is clean, so the
map's phase and the signatures see a delay directly (with force noise the latent force absorbs
it: tests/acceptance/test_diagnose.py). They are fitted with quintic splines at N = 8: the N the
automatic choice takes on these recordings (tests/acceptance/test_compare.py: it passes the
discretisation check for every true model), fixed so that no test pays for the refinement ladder.

Plumbing (diagnosis.json's layout, the report, the command line, the diagnosis's bookkeeping)
needs a recording and a diagnosis, not a true one: :func:`recording` and :func:`diagnosed` are
the inference tests' cheap BeamModel-made case (tests/inference/cases.py, N = 6), diagnosed
blind against q1 with 2 SMC repeats and 20 map replicates, which cost a third of a reference one.
"""
from __future__ import annotations

from dataclasses import replace
from functools import cache

import numpy as np

from bayesbeam.comparison import CompareConfig
from bayesbeam.diagnosis import DiagnoseConfig, diagnose
from bayesbeam.inference.fit import FitConfig
from tests.acceptance import cases as ac
from tests.inference import cases
from tests.reference import Noise, Numerics, record
from tests.reference.recordings import NOISE

#: spline intervals and degree of the fits to reference recordings (see the module docstring)
N_INTERVALS, DEGREE = 8, 5
FIT = FitConfig(n_intervals=N_INTERVALS, degree=DEGREE)
#: a diagnosis of a reference recording
REFERENCE_CONFIG = DiagnoseConfig(CompareConfig(FIT, repeats=2, replicates=20), replicates=20)
#: a diagnosis of a plumbing recording (made and fitted at N = 6)
CONFIG = DiagnoseConfig(CompareConfig(FitConfig(n_intervals=6), repeats=2, replicates=20), replicates=20)
#: concealed effects and their true values in the reference's names: a root spring of 100 EI/l
#: (mode 1 1.9 % low), a 0.5 ms delay, a 10 g sensor at the tip, a 5 N tension (mode 1 2 % high),
#: 50 mN of tip friction (8 % of the signal's RMS)
CONCEALED = {"root_compliance": {"k_theta": 100 * cases.EI_TRUE}, "measurement_delay": {"tau": 5e-4},
             "sensor_mass": {"m_s": 0.01}, "axial_load": {"P": 5.0}, "dry_friction": {"F_c": 0.05}}
#: 2 % sensor noise, a clean force channel
SENSOR_NOISE = Noise(sensor=NOISE.sensor)
#: fine steps per sample with tip friction (tests/reference/friction.py: the accelerometer's
#: reading of the friction force is first order in the step)
FRICTION_NUMERICS = Numerics(oversample=256)
#: plumbing recordings' concealed effects (the reference's names are BeamModel's)
PLUMBING_EFFECTS = {name: CONCEALED[name] for name in ("root_compliance", "measurement_delay")}


@cache
def reference(effects: tuple = (), damping: tuple = (), seed: int = 3, model: str = "q1"):
    """The paper beam's hammer test from the reference simulator: (Recording, clean Recording).

    model: whose damping (tests/acceptance/cases.py's values); effects, damping: (name, value)
    pairs in the reference's names (``damping`` overrides the model's). The clean recording (no
    noise) is what a test needs to state a noise level or a signal share.
    """
    s = ac._setting("paper")
    arguments = {"beam": ac._nominal(s["beam"]), "damping": {**ac.DAMPING["paper"][model], **dict(damping)},
                 "EI": s["beam"].nominal_EI, "excitation": s["excitation"], "fs": s["fs"], "duration": 1.0,
                 "effects": dict(effects), "numerics": FRICTION_NUMERICS if dict(effects).get("F_c") else Numerics()}
    return record(**arguments, noise=SENSOR_NOISE, seed=seed), record(**arguments)


def recording(effect: str | None, seed: int = 3):
    """plumbing: the cheap BeamModel-made q1 recording with ``effect`` (a key of
    :data:`PLUMBING_EFFECTS`) concealed (None: no effect)."""
    params = {**cases.TRUTH["q1"], **PLUMBING_EFFECTS.get(effect, {})}
    return cases.simulated("q1" + (f"+{effect}" if effect else ""), seed, params=params)[0]


def free_decay(rec, start: float):
    """``rec`` cut to a free decay from ``start`` (s): no force channel, the state at ``start`` unknown."""
    from bayesbeam.io.recording import Excitation

    return replace(rec, excitation=Excitation(kind="free_decay", start=start), force=None)


@cache
def diagnosed(effect: str | None, seed: int = 3):
    """plumbing: the Diagnosis of :func:`recording` against q1 (serial: the tests' processes are the cores)."""
    return diagnose(recording(effect, seed), "q1", CONFIG)


def rms(signals) -> float:
    """Root mean square of all of ``signals``."""
    return float(np.sqrt(np.mean(np.asarray(signals) ** 2)))
