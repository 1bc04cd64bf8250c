"""Synthetic recordings for the effect and nonlinear-response tests (no file I/O)."""
from __future__ import annotations

import numpy as np

from bayesbeam.io import Recording
from bayesbeam.io.recording import Beam, Excitation, Sensor, TipBody

#: the paper's beam (Table 1): l = 1 m, rho*A = 1.02087 kg/m, EI = 44.28 N m^2
PAPER_BEAM = Beam(length=1.0, density=1710.0, area=0.597e-3, second_moment=1.64e-9, modulus=2.7e10)
PAPER_EI = 44.28


def recording(kind: str = "force", *, fs: float = 1024.0, duration: float = 1.0,
              sensors=((1.0, "acceleration"),), beam: Beam = PAPER_BEAM, tip: TipBody | None = None,
              force=None, location: float = 0.75, tip_load: float = 1.0, t0: float = 0.0) -> Recording:
    """A recording whose signals are zeros (only its set-up matters to a model).

    ``force`` is a function of time (s) for kind "force" (default: a 1 ms half-sine of 20 N at
    0.05 s, whose spectrum lies well inside the band); ``sensors`` are (location, quantity).
    """
    n = round(duration * fs)
    tip = TipBody() if tip is None else tip
    time = t0 + np.arange(n) / fs
    if kind == "force":
        if force is None:
            force = half_sine(0.05, 1e-3, 20.0)
        exc = Excitation("force", location=location, column="force")
        f = force(time)
    elif kind == "release":
        exc, f = Excitation("release", tip_load=tip_load), None
    else:
        exc, f = Excitation("free_decay", start=time[n // 4]), None
    chans = tuple(Sensor(f"s{i}", loc, q, f"s{i}") for i, (loc, q) in enumerate(sensors))
    return Recording(beam, tip, exc, chans, time, np.zeros((n, len(chans))), f)


def half_sine(t0: float, width: float, peak: float):
    def f(t):
        t = np.asarray(t, dtype=float)
        inside = (t >= t0) & (t <= t0 + width)
        return np.where(inside, peak * np.sin(np.pi * (t - t0) / width), 0.0)
    return f


def transfer_error(model, system, n_poles: int, f_max: float = 200.0) -> float:
    """max |H_fast - H_direct| / max |H_direct| of ``system``'s fast transfer function against a
    direct solve of Z(s) w = load per frequency, on the model's grid up to ``f_max`` (Hz) and just
    right of the first ``n_poles`` poles (the resonance peaks)."""
    poles = system.poles()[:n_poles]
    s = np.concatenate([model.grid.s[model.grid.freq < f_max], 0.01 * poles.imag + 1j * poles.imag])
    fast = system.transfer(s, model.rows, model.load[:, None])
    direct = np.stack([model.rows @ np.linalg.solve(z, model.load) for z in system.dynamic_stiffness(s)])[:, :, None]
    return float(np.max(np.abs(fast - direct)) / np.max(np.abs(direct)))
