"""Write a diagnosis's outputs: diagnosis.json, report.html and posteriors/<model>.nc (baseline,
every augmented model tried, every model of the damping re-check), each under a temporary name
renamed into place."""
from __future__ import annotations

from pathlib import Path

from bayesbeam.report.compare_outputs import inference_data, posterior_file_name
from bayesbeam.report.diagnosis import write_report
from bayesbeam.report.fit_outputs import write_json, write_netcdf


def write_diagnosis(diagnosis, summary: dict, out_dir) -> list[Path]:
    """Write the outputs of ``diagnosis`` and its summary ``diagnosis.to_dict()``."""
    out = Path(out_dir)
    (out / "posteriors").mkdir(parents=True, exist_ok=True)
    results = fitted_models(diagnosis)
    written = [write_netcdf(inference_data(r), out / "posteriors" / f"{posterior_file_name(m)}.nc")
               for m, r in results.items()]
    written.append(write_report(diagnosis, summary, out / "report.html"))
    written.append(write_json(summary, out / "diagnosis.json"))
    return written


def fitted_models(diagnosis) -> dict:
    """Every model a diagnosis fitted, by name: the baseline, each augmented model tried and each
    model of the damping re-check."""
    recheck = diagnosis.recheck.results.values() if diagnosis.recheck else ()
    return {r.name: r for r in (diagnosis.baseline, *(t.result for t in diagnosis.trials), *recheck)}
