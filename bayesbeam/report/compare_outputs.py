"""Write a comparison's outputs: comparison.json, posteriors/<model>.nc, report.html and
damping_per_mode.png (the report's per-mode figure on its own, for papers and slides).

Every file is written under a temporary name and renamed into place (see fit_outputs).
"""
from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np

from bayesbeam.comparison import posterior_file_name
from bayesbeam.inference.results import with_units
from bayesbeam.report.comparison import mode_plot, model_colors, write_report
from bayesbeam.report.fit_outputs import write_json, write_netcdf
from bayesbeam.report.plots import save


def inference_data(result):
    """arviz InferenceData of one model's SMC posterior: one chain per repeat, one draw per particle."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", FutureWarning)
        import arviz as az
    names = result.problem.posterior.names
    values = result.values()
    runs = result.evidence.runs
    rec = result.problem.model.recording
    return with_units(az.from_dict(
        posterior={n: values[..., i] for i, n in enumerate(names)},
        sample_stats={"log_likelihood_total": np.stack([r.log_likelihood for r in runs]),
                      "log_prior": np.stack([r.log_prior for r in runs])},
        observed_data={"signals": np.asarray(rec.signals)},
        coords={"time": rec.time, "sensor": [s.name for s in rec.sensors]},
        dims={"signals": ["time", "sensor"]},
        attrs={"model": result.name, "log_evidence": result.evidence.log_z,
               "log_evidence_sd": result.evidence.log_z_sd},
    ), result.problem.model)


def write_comparison(results: dict, summary: dict, out_dir) -> list[Path]:
    out = Path(out_dir)
    (out / "posteriors").mkdir(parents=True, exist_ok=True)
    written = [write_netcdf(inference_data(r), out / "posteriors" / f"{posterior_file_name(m)}.nc") for m, r in results.items()]
    written.append(save(mode_plot(summary, model_colors(summary)), out / "damping_per_mode.png"))
    written.append(write_report(results, summary, out / "report.html"))
    written.append(write_json(summary, out / "comparison.json"))
    return written
