"""The real steel cantilever's free decay: compare the damping models, diagnose the best, write the tables.

    OPENBLAS_NUM_THREADS=1 python studies/real_steel_cantilever/run.py [NAME ...]   # rerun, then the tables
    python studies/real_steel_cantilever/run.py --tables                           # only the tables
    OPENBLAS_NUM_THREADS=1 python studies/real_steel_cantilever/run.py --resume diagnose  # continue a killed diagnosis

Every run is the ``bayesbeam`` command a user would type on ``recording/`` (this folder's set-up
of data/real/ds4-cantilever-freedecay: the accelerometer's own mass, the tolerances and the
material table; its CSV is read from the data folder), on the free decay from 1.12 s to 5.12 s
below 150 Hz. The README's tables come from ``compare/comparison.json`` (every damping model of
the package, the paper's and the literature's, each carrying the accelerometer's mass) and
``diagnose/diagnosis.json`` (what the best of them leaves out); ``compare_structure/comparison.json``
is the same record with the data folder's ``beam.toml``, no set-up stated, a free sensor mass and
axial load standing in for the structural mismatch.
"""
from __future__ import annotations

import json
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))

import study  # the studies' shared runner, next to this folder

RECORDING = "studies/real_steel_cantilever/recording"
#: the data folder's recording: the same CSV, no sensor mass or tolerances stated, the 6 g accelerometer as [tip]
DATA_RECORDING = "data/real/ds4-cantilever-freedecay/recording"
OUT = "studies/real_steel_cantilever"
#: cubic splines, as the committed outputs were computed
BAND = ["--start", "1.12", "--stop", "5.12", "--max-frequency", "150", "--degree", "3"]
WINDOW = [*BAND, "--n-intervals", "16"]
#: the best model of ``compare`` (its comparison.json's ``best``), which the diagnosis starts from
BEST = "exponential"
#: its runner-up there, beside which ``compare_n24`` checks the order on a finer grid
RUNNER_UP = "q2"
COMMANDS = {
    "compare": ["compare", RECORDING, "--models", "all", "--effect", "sensor_mass", *WINDOW,
                "--overwrite", "--out", f"{OUT}/compare"],
    # the first two on a finer grid: does their order hold where the estimates still move with N?
    "compare_n24": ["compare", RECORDING, "--models", f"{BEST},{RUNNER_UP}", "--effect", "sensor_mass",
                    *BAND, "--n-intervals", "24", "--overwrite", "--out", f"{OUT}/compare_n24"],
    "diagnose": ["diagnose", RECORDING, "--model", BEST, "--effect", "sensor_mass", *WINDOW,
                 "--overwrite", "--out", f"{OUT}/diagnose"],
    # the clamp's losses beside the best mechanism and beside q1, which the diagnosis cannot rank alone
    "compare_clamp": ["compare", RECORDING, "--models", f"{BEST},q1", "--effect", "sensor_mass", "--effect",
                      "root_compliance", "--effect", "root_damping", *WINDOW, "--overwrite", "--out", f"{OUT}/compare_clamp"],
    # the record without the stated set-up: the effects free of it
    "diagnose_blind": ["diagnose", DATA_RECORDING, *WINDOW, "--overwrite", "--out", f"{OUT}/diagnose_blind"],
    "diagnose_q1": ["diagnose", DATA_RECORDING, "--model", "q1", *WINDOW, "--executor", "serial",
                    "--overwrite", "--out", f"{OUT}/diagnose_q1"],
    "compare_structure": ["compare", DATA_RECORDING, "--effect", "sensor_mass", "--effect", "axial_load", *WINDOW,
                          "--overwrite", "--out", f"{OUT}/compare_structure"],
}
#: the posterior predictive checks, in the order of the checks table, and their column titles
CHECKS = {"residual_spectrum": "residual spectrum", "ljung_box": "Ljung-Box",
          **{f"zeta_mode{k}": f"zeta {k}" for k in (1, 2, 3)},
          **{f"frequency_mode{k}": f"f {k}" for k in (1, 2, 3)}}


def mode_table(summary: dict, measured_key: str, interval_key: str, scale: float, fmt: str) -> str:
    """Rows: the measurement (ERA), then each model in ranking order; columns: modes. A model's
    cell is its posterior predictive 90 % interval, marked *outside* when the measurement misses it.

    The check takes the ERA pole nearest the model's own mode, so where ERA finds two poles near
    one mode a model can be checked against the other one: its cell then names that measurement."""
    from bayesbeam.report.markdown import markdown_table

    models = summary["models"]
    first = models[summary["ranking"][0]]["modes"]
    head = ["", *(f"mode {row['mode']}" for row in first)]
    rows = [["measured (ERA)", *(f"{row[measured_key] * scale:{fmt}}" for row in first)]]
    for name in summary["ranking"]:
        cells = []
        for row, shown in zip(models[name]["modes"], first):
            if row[interval_key] is None:  # no replicate gave the mode (ERA found none there)
                cells.append("n/a")
                continue
            lo, hi = (v * scale for v in row[interval_key])
            measured = row[measured_key] * scale
            inside = lo <= measured <= hi
            own = "" if row[measured_key] == shown[measured_key] else f" (against the ERA pole at {measured:{fmt}})"
            cells.append(f"{lo:{fmt}}-{hi:{fmt}}" + ("" if inside else " *outside*") + own)
        rows.append([name, *cells])
    return markdown_table(head, rows)


def checks_table(summary: dict) -> str:
    """Each model's posterior predictive p-values (a check fails below 0.01, docs/comparison.md)."""
    from bayesbeam.report.markdown import markdown_table

    rows = [[name, *(f"{summary['models'][name]['ppc'][key]['p_value']:.2g}" for key in CHECKS)]
            for name in summary["ranking"]]
    return markdown_table(["model", *CHECKS.values()], rows)


def diagnosis_table(d: dict) -> str:
    """Every augmented model the diagnosis fitted: its evidence against the model it extends, the
    added effect's estimate, the map's RMS and flags, the decision and whether it is a stand-in."""
    from bayesbeam.diagnosis import stand_in_words
    from bayesbeam.report.markdown import markdown_table, median_and_interval

    rows = [["baseline", d["baseline"]["model"], "", "", f"{d['baseline']['rms_standardized_residual']:.2f}",
             str(d["baseline"]["flags"]), "", ""]]
    for c in d["candidates"]:
        estimate = "; ".join(f"{name} {median_and_interval(q)} {q['unit']}" for name, q in c["parameters"].items())
        rows.append([str(c["round"]), c["model"], f"{c['delta_log_evidence']:.1f} +- {c['delta_log_evidence_sd']:.2g}",
                     estimate, f"{c['rms_standardized_residual']:.2f}", str(c["flags"]),
                     "added" if c["added"] else ("not decisive" if not c["decisive"] else "map not improved"),
                     stand_in_words(c["stand_in"])])
    head = ["round", "model", "ln B vs the model it extends", "effect's posterior median [90 %]", "RMS", "flags",
            "decision", "stand-in"]
    return markdown_table(head, rows)


def setup_table(summary: dict) -> str:
    """Each model's fitted set-up: m_s against the range the stated set-up allows a sensor mass
    (the diagnosis's stand-in rule, :func:`bayesbeam.diagnosis.allowed_by_setup`, on this folder's
    ``recording/``), and the free length l and the sensor's offset dx_tip, whose priors are
    uniform over the stated tolerances (an interval reaching a bound is marked)."""
    from bayesbeam.diagnosis import allowed_by_setup
    from bayesbeam.io import load_recording
    from bayesbeam.report.markdown import markdown_table, median_and_interval

    rec = load_recording(HERE / "recording")
    low, high = allowed_by_setup("sensor_mass", rec)["m_s"]
    length, tolerance = rec.beam.length, rec.setup.length_tolerance
    rows = []
    for name in summary["ranking"]:
        post = summary["models"][name]["posterior"]
        m_s, l, dx = post["m_s"], post["l"], post["dx_tip"]
        at_bound = l["q95"] > length + 0.99 * tolerance or l["q05"] < length - 0.99 * tolerance
        rows.append([name, median_and_interval(m_s), "yes" if low <= m_s["q50"] <= high else "no",
                     median_and_interval(l) + (" *at a bound*" if at_bound else ""), median_and_interval(dx)])
    return markdown_table(["model", "m_s posterior median [90 %], kg", f"m_s within {low:.4f}-{high:.4f} kg",
                           f"l, m (stated {length:g} +- {tolerance:g})", "dx_tip, m"], rows)


def command_block(*names: str) -> str:
    """The shell lines of the named runs, as a user would type them."""
    lines = [f"OPENBLAS_NUM_THREADS=1 bayesbeam {' '.join(COMMANDS[n])}" for n in names]
    return "```bash\n" + "\n".join(lines) + "\n```"


def blocks() -> dict[Path, dict[str, str]]:
    from bayesbeam.report.comparison import ranking_markdown

    summary = json.loads((HERE / "compare" / "comparison.json").read_text())
    diagnosis = json.loads((HERE / "diagnose" / "diagnosis.json").read_text())
    return {HERE / "README.md": {
        "real-steel-command-compare": command_block("compare"),
        "real-steel-command-compare_n24": command_block("compare_n24"),
        "real-steel-command-diagnose": command_block("diagnose"),
        "real-steel-command-compare_clamp": command_block("compare_clamp"),
        "real-steel-command-structure": command_block("diagnose_blind", "diagnose_q1", "compare_structure"),
        "real-steel-compare": ranking_markdown(summary),
        "real-steel-compare_n24": ranking_markdown(json.loads((HERE / "compare_n24" / "comparison.json").read_text())),
        "real-steel-damping": mode_table(summary, "measured_damping_ratio", "predicted_damping_ratio_90", 100.0, ".3f"),
        "real-steel-frequency": mode_table(summary, "measured_frequency_hz", "predicted_frequency_hz_90", 1.0, ".2f"),
        "real-steel-checks": checks_table(summary),
        "real-steel-setup": setup_table(summary),
        "real-steel-diagnose": diagnosis_table(diagnosis),
        "real-steel-compare_clamp": ranking_markdown(json.loads((HERE / "compare_clamp" / "comparison.json").read_text())),
        "real-steel-compare_structure": ranking_markdown(json.loads((HERE / "compare_structure" / "comparison.json")
                                                                    .read_text())),
    }}


if __name__ == "__main__":
    sys.exit(study.main(__doc__.splitlines()[0], COMMANDS, blocks))
