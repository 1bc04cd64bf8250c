"""Benchmark: what the larger catalogue costs a diagnosis of the shipped examples, both cores.

    OPENBLAS_NUM_THREADS=1 python benchmarks/catalogue.py

On each of ``data/examples`` (``--model`` its truth's damping model, 150 Hz band, the defaults otherwise)
the **baseline** path is the diagnosis whose screen ranks the catalogue of the linear and
nonlinear beam and chain effects without the effects of the world around the beam
(:data:`AROUND`: the attached body, the base, mains pickup), run first in the same process; the
current one ranks the whole catalogue. Printed: both wall times, their ratio, and whether the two
diagnoses agree (added effects and final model: the examples conceal none of the three). Target:
the current path within 1.5 times the baseline's.
"""
from __future__ import annotations

import json
import os
import platform
import sys
from dataclasses import replace
from pathlib import Path

import tables  # benchmarks/tables.py: the script's folder is first on sys.path
from diagnose import timed_diagnose

from bayesbeam.comparison import CompareConfig
from bayesbeam.diagnosis import DiagnoseConfig
from bayesbeam.inference.fit import FitConfig
from bayesbeam.io import load_recording
from bayesbeam.physics.effects import REGISTRY

EXAMPLES = Path(__file__).resolve().parents[1] / "data" / "examples"
#: the catalogue's effects of the world around the beam, left out of the baseline path's screen
AROUND = ("attachment", "base_support", "mains_lines")
#: the current path's wall time may be this many times the baseline's
TARGET_RATIO = 1.5
MAX_FREQUENCY = 150.0


def main(argv=None) -> int:
    current = DiagnoseConfig(CompareConfig(FitConfig(max_frequency=MAX_FREQUENCY)))
    baseline = replace(current, catalogue=tuple(name for name in REGISTRY if name not in AROUND))
    print(f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores, load {os.getloadavg()}")
    print(f"baseline catalogue: {', '.join(baseline.catalogue)}; current adds {', '.join(AROUND)}")
    for example in sorted(p for p in EXAMPLES.iterdir() if (p / "truth.json").exists()):
        rec = load_recording(example)
        model = json.loads((example / "truth.json").read_text())["damping_model"].split()[0]     # "q1 (air + ...)"
        walls, outcomes = {}, {}
        for name, config in (("baseline", baseline), ("current", current)):
            summary, walls[name] = timed_diagnose(rec, model, config)
            outcomes[name] = summary
            print(f"{example.name} {name}: {walls[name]:.1f} s; baseline {summary['baseline']['model']}, added "
                  f"{summary['added'] or 'nothing'}, final {summary['final']['model']}, unexplained "
                  f"{summary['unexplained']}; load {os.getloadavg()}")
        base, new = outcomes["baseline"], outcomes["current"]
        same = base["added"] == new["added"] and base["final"]["model"] == new["final"]["model"]
        ratio = walls["current"] / walls["baseline"]
        print(f"{example.name}: current / baseline wall time {ratio:.2f} (target <= {TARGET_RATIO:g}); "
              f"diagnoses {'agree' if same else 'DIFFER'}")
        tables.record(**{f"{example.name}_{k}": v for k, v in {
            "baseline_seconds": walls["baseline"], "current_seconds": walls["current"], "wall_ratio": 1 / ratio,
            "target_seconds": TARGET_RATIO * walls["baseline"], "diagnoses_agree": same}.items()})
    return 0


if __name__ == "__main__":
    sys.exit(tables.run("catalogue", main))
