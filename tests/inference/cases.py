"""Cheap simulated recordings for the inference tests (built with numpy, no files).

The paper's beam (Banks & Inman 1989, Table 1: l = 1 m, rho = 1710 kg/m^3, A = 0.597e-3 m^2,
I = 1.64e-9 m^4, E = 2.7e10 Pa, so EI = 44.28 N m^2), a smooth Gaussian force pulse at 0.75 m
and one tip accelerometer, simulated by ``BeamModel.simulate`` at known parameters with a small
spline grid N (at the fits' default degree), plus seeded white Gaussian noise of a given fraction
of the signal RMS.
"""
from __future__ import annotations

import numpy as np

from bayesbeam.inference.posterior import LogPosterior
from bayesbeam.io import Beam, Excitation, Recording, Sensor, TipBody
from bayesbeam.model import BeamModel

#: the paper's beam; the nominal modulus is the true one (the EI prior is centred on the truth)
PAPER_BEAM = Beam(length=1.0, density=1710.0, area=0.597e-3, second_moment=1.64e-9, modulus=2.7e10)
EI_TRUE = 2.7e10 * 1.64e-9          # 44.28 N m^2

#: true parameters of the cheap cases (modal damping ratios of 0.1-1 %, as in the paper)
TRUTH = {
    "air": {"EI": EI_TRUE, "gamma": 0.3},
    "q1": {"EI": EI_TRUE, "gamma": 0.3, "cdI": 7e-5},
    # memory decay rate between modes 2 and 3 (145 and 407 rad/s): the damping ratios peak at
    # mode 3 (0.016, 0.079, 0.10, 0.086, 0.071 % for modes 1-5), which pins beta down
    "q2": {"EI": EI_TRUE, "alpha": 2.0, "beta": 200.0},
    "q3": {"EI": EI_TRUE, "gamma": 0.12, "a": 0.025, "b": 0.18},
}

#: a second beam: an aluminium strip 0.5 m x 25 mm x 3 mm with a 50 g tip block (EI 3.94 N m^2;
#: modes at 5.7, 47, 145, 297 Hz), and damping of each model giving modal ratios of 0.01-0.5 %
#: in modes 1-4. Its tests strike it with a 1 ms pulse (a hard hammer tip): the paper beam's
#: 4 ms pulse leaves modes 3-4 of this stiffer strip almost unexcited, and then q1 and q3
#: cannot be told apart.
ALU_BEAM = Beam(length=0.5, density=2700.0, area=7.5e-5, second_moment=5.625e-11, modulus=7.0e10)
ALU_TIP = TipBody(mass=0.05, rotary_inertia=2.3e-6)
ALU_TRUTH = {
    "air": {"EI": ALU_BEAM.nominal_EI, "gamma": 0.18},                      # 0.41, 0.13, 0.05, 0.02 %
    "strain_rate": {"EI": ALU_BEAM.nominal_EI, "cdI": 2e-5},                # 0.01, 0.08, 0.23, 0.47 %
    "q1": {"EI": ALU_BEAM.nominal_EI, "gamma": 0.18, "cdI": 2e-5},          # 0.42, 0.20, 0.28, 0.50 %
    # memory decay rate near mode 2 (298 rad/s): the ratios peak at modes 2-3
    "q2": {"EI": ALU_BEAM.nominal_EI, "alpha": 0.3, "beta": 300.0},          # 0.02, 0.13, 0.13, 0.10 %
    "q3": {"EI": ALU_BEAM.nominal_EI, "gamma": 0.1, "a": 5e-3, "b": 0.12},  # 0.23, 0.14, 0.17, 0.20 %
}

SENSOR = Sensor(name="accel_tip", location=1.0, quantity="acceleration", column="accel_tip")


def force_pulse(time, t0=0.02, width=0.004, peak=20.0):
    """A Gaussian hammer pulse: smooth and band-limited (spectrum exp(-(2 pi f width)^2 / 2))."""
    return peak * np.exp(-0.5 * ((time - t0) / width) ** 2)


def base_recording(fs=512.0, duration=1.0, beam=PAPER_BEAM, sensors=None, tip=None, pulse_width=0.004) -> Recording:
    """A force recording with zero signals (fill them with ``with_signals``): the hammer at
    0.75 l (a Gaussian pulse of sd ``pulse_width`` s), by default one accelerometer at the tip."""
    n = round(fs * duration)
    time = np.arange(n) / fs
    if sensors is None:
        sensors = (Sensor(SENSOR.name, beam.length, SENSOR.quantity, SENSOR.column),)
    excitation = Excitation("force", location=0.75 * beam.length, column="force")
    return Recording(beam=beam, tip=tip or TipBody(), excitation=excitation, sensors=tuple(sensors), time=time,
                     signals=np.zeros((n, len(sensors))), force=force_pulse(time, width=pulse_width))


def clean_response(model_name: str, params=None, n_intervals=6, **kwargs) -> tuple[Recording, np.ndarray]:
    """(recording, clean signals) of ``model_name`` at N = ``n_intervals`` and the fits' default
    spline degree: the discretisation these cases' fits use, so that they are exact."""
    from bayesbeam.inference import FitConfig

    rec = base_recording(**kwargs)
    params = TRUTH[model_name] if params is None else params
    return rec, BeamModel.from_recording(rec, model_name, n_intervals, degree=FitConfig.degree).simulate(params)


def simulated(model_name: str, seed: int, noise_fraction=0.02, n_intervals=6, params=None, **kwargs):
    """(recording with noisy signals, noise sd): the truth plus N(0, (fraction x RMS)^2) noise."""
    rec, clean = clean_response(model_name, params, n_intervals, **kwargs)
    sd = noise_fraction * float(np.sqrt(np.mean(clean**2)))
    rng = np.random.default_rng(seed)
    return rec.with_signals(clean + sd * rng.standard_normal(clean.shape)), sd


def fit_case(model_name: str, seed: int, walkers: int, max_steps: int, quantiles=(0.005, 0.05, 0.95, 0.995),
             noise_fraction=0.02) -> dict:
    """Simulate a case, fit it with ``bayesbeam.inference.fit`` and return picklable results.

    Module-level so that a spawned worker process can run it: {"truth", "sd", "summary",
    "quantiles" (name -> the requested posterior quantiles of the physical value), "pit"
    (name -> posterior probability below the truth), "seconds"}.

    numpy's global random state is seeded too: emcee draws its moves from a copy of it, not from
    FitConfig.seed (see test_parallel), and the tests must be reproducible.
    """
    import time

    from bayesbeam.inference import FitConfig, fit

    started = time.perf_counter()
    rec, sd = simulated(model_name, seed, noise_fraction=noise_fraction)
    result = fit(rec, model_name, FitConfig(n_intervals=6, walkers=walkers, max_steps=max_steps, seed=seed))
    out = _posterior_report(result.problem.posterior, result.values(), model_name, sd, quantiles)
    out.update(summary=result.summary, seconds=time.perf_counter() - started)
    return out


def sample_case(model_name: str, seed: int, walkers: int, max_steps: int, quantiles=(0.05, 0.95),
                noise_fraction=0.02) -> dict:
    """The posterior of a case by fit's own stages without its reporting (prepare, find_optimum,
    run_emcee at N = 6; no InferenceData, no discretisation check): cheaper for replications.

    Returns {"truth", "sd", "quantiles", "pit", "tau", "converged", "seconds"}; the quantiles are
    those of build_summary (numpy quantiles of all post-burn-in, thinned draws).
    """
    import time

    from bayesbeam.inference import FitConfig
    from bayesbeam.inference.fit import prepare
    from bayesbeam.inference.sampler import find_optimum, run_emcee

    started = time.perf_counter()
    rec, sd = simulated(model_name, seed, noise_fraction=noise_fraction)
    rng = np.random.default_rng(seed)
    post = prepare(rec, model_name, FitConfig(n_intervals=6), 6).posterior
    optimum = find_optimum(post, rng)
    chains = run_emcee(post, optimum, rng, n_walkers=walkers, max_steps=max_steps)
    values = np.stack([p.to_value(chains.samples[..., i]) for i, p in enumerate(post.priors)], axis=-1)
    out = _posterior_report(post, values, model_name, sd, quantiles)
    out.update(tau=chains.tau.tolist(), converged=chains.converged, seconds=time.perf_counter() - started)
    return out


def _posterior_report(post, values, model_name, sd, quantiles) -> dict:
    truth = {**TRUTH[model_name], "sigma_accel_tip": sd}
    flat = values.reshape(-1, post.ndim)
    return {
        "truth": truth,
        "sd": sd,
        "quantiles": {n: np.quantile(flat[:, i], quantiles).tolist() for i, n in enumerate(post.names)},
        "pit": {n: float(np.mean(flat[:, i] < truth[n])) for i, n in enumerate(post.names)},
    }


def run_in_processes(fn, arg_list, processes: int = 2) -> list:
    """``[fn(*args) for args in arg_list]`` on up to ``processes`` spawned worker processes.

    The suite's budget assumes two cores; with one core it runs the same jobs in turn.
    """
    import concurrent.futures
    import multiprocessing
    import os

    n = max(1, min(processes, os.cpu_count() or 1, len(arg_list)))
    if n == 1:
        return [fn(*args) for args in arg_list]
    with concurrent.futures.ProcessPoolExecutor(n, mp_context=multiprocessing.get_context("spawn")) as pool:
        futures = [pool.submit(fn, *args) for args in arg_list]
        return [f.result() for f in futures]


class CountingLogPosterior(LogPosterior):
    """A LogPosterior that logs every pickling ("pickle <pid>", in the pickling process) and
    unpickling ("unpickle <pid>", in the receiving process) to the file ``log_path``.

    Module-level so that spawned worker processes can import it.
    """

    def __init__(self, likelihood, priors, log_path):
        super().__init__(likelihood, priors)
        self.log_path = str(log_path)

    def __getstate__(self):
        _log_line(self.log_path, "pickle")
        return self.__dict__.copy()

    def __setstate__(self, state):
        self.__dict__.update(state)
        _log_line(self.log_path, "unpickle")


def _log_line(path, text):
    import os

    with open(path, "a") as f:
        f.write(f"{text} {os.getpid()}\n")
