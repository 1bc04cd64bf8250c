"""Write a fit's outputs: posterior.nc, summary.json, corner.png, trace.png, fit.png.

Each file is written under a temporary name in the output directory and renamed into place, so
a reader never sees a half-written file; the emcee chain file (chains.h5) is the run's working
file and is written by the sampler itself, so that an interrupted run can resume.
"""
from __future__ import annotations

import warnings
from pathlib import Path

from bayesbeam.io.atomic import atomic_write
from bayesbeam.io.provenance import write_json
from bayesbeam.report.plots import corner_plot, fit_plot, save, trace_plot

__all__ = ["write_fit", "write_json", "write_netcdf"]


def write_netcdf(idata, path) -> Path:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return atomic_write(path, lambda p: idata.to_netcdf(str(p), engine="h5netcdf"))


def write_fit(result, out_dir, truths: dict | None = None) -> list[Path]:
    """All outputs of a fit into ``out_dir`` (created if needed); returns the paths written."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    written = [write_netcdf(result.idata, out / "posterior.nc"),
               write_json(result.summary, out / "summary.json"),
               save(corner_plot(result, truths), out / "corner.png"),
               save(trace_plot(result), out / "trace.png")]
    for i, sensor in enumerate(result.problem.model.recording.sensors):
        name = "fit.png" if i == 0 else f"fit_{sensor.name}.png"
        written.append(save(fit_plot(result, i), out / name))
    return written
