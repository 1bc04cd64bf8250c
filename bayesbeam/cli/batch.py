"""``bayesbeam batch``: compare models on a campaign of recordings, resuming what finished.

Each recording's comparison goes to ``OUT/<recording name>/`` (as ``bayesbeam compare`` writes
it); with ``--resume``, a recording whose ``comparison.json`` exists is not run again. At the end
``OUT/batch.csv`` and ``OUT/batch.json`` hold one row per recording and model: evidence,
probability, rank and the posterior mean and 90 % interval of every parameter.
"""
from __future__ import annotations

import csv
import io
import json
from pathlib import Path

from bayesbeam.cli.common import UsageError, add_out_options, job_executor, output_folder
from bayesbeam.cli.compare import add_comparison_options, comparison_config, model_list
from bayesbeam.io import load_recording
from bayesbeam.io.atomic import write_text

HELP = "compare models on many recordings (local processes, MPI or a Dask cluster), one table out"


def add_arguments(p) -> None:
    p.add_argument("recordings", nargs="+", help="recording directories")
    add_comparison_options(p)
    add_out_options(p, "one subdirectory per recording, batch.csv, batch.json",
                    resume="continue a campaign: skip the recordings already compared in OUT")


def run(args) -> int:
    from bayesbeam.comparison import compare
    from bayesbeam.progress import Progress
    from bayesbeam.report.compare_outputs import write_comparison
    from bayesbeam.report.fit_outputs import write_json

    out = output_folder(args)
    models = model_list(args.models, args.effect)
    config = comparison_config(args)
    targets = _targets(args.recordings, out)
    say = Progress(enabled=not args.quiet)
    executor = job_executor(args)
    try:
        for source, target in targets:
            if args.resume and (target / "comparison.json").exists():
                say(f"{source}: already compared in {target}, skipped")
                continue
            say(f"{source}: comparing {len(models)} models")
            results, summary = compare(load_recording(source), models, config, executor, log=say)
            write_comparison(results, summary, target)
    finally:
        executor.close()
    rows = [row for _, target in targets for row in table_rows(target)]
    write_json({"models": models, "rows": rows}, out / "batch.json")
    _write_csv(rows, out / "batch.csv")
    print(f"{len(targets)} recordings x {len(models)} models: wrote batch.csv and batch.json in {out}")
    return 0


def _targets(recordings, out: Path):
    targets, seen = [], {}
    for source in recordings:
        path = Path(source)
        if not path.exists():
            raise UsageError(f"{source}: no such recording directory")
        name = path.name if path.name != "beam.toml" else path.parent.name
        seen[name] = seen.get(name, 0) + 1
        targets.append((source, out / (name if seen[name] == 1 else f"{name}_{seen[name]}")))
    return targets


def table_rows(target: Path) -> list[dict]:
    """One row per model of a written comparison."""
    summary = json.loads((target / "comparison.json").read_text())
    rows = []
    for rank, model in enumerate(summary["ranking"], start=1):
        s = summary["models"][model]
        row = {"recording": summary["recording"], "model": model, "rank": rank, "best": model == summary["best"],
               "log_evidence": s["log_evidence"], "log_evidence_sd": s["log_evidence_sd"],
               "probability": s["probability"]}
        for name, p in s["posterior"].items():
            row.update({f"{name}_mean": p["mean"], f"{name}_q05": p["q05"], f"{name}_q95": p["q95"]})
        rows.append(row)
    return rows


def _write_csv(rows, path: Path) -> None:
    columns = list(dict.fromkeys(k for row in rows for k in row))
    buffer = io.StringIO()
    writer = csv.DictWriter(buffer, fieldnames=columns)
    writer.writeheader()
    writer.writerows(rows)
    write_text(path, buffer.getvalue())
