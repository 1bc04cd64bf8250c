"""The true parameter values of a simulated recording, from the truth.json beside it.

The simulated examples (data/examples/) carry a truth.json next to their beam.toml; a report of
such a recording marks the truth on its posterior plots. A real record has none.
"""
from __future__ import annotations

import json
from pathlib import Path

#: the file beside a simulated recording's beam.toml that holds its truth
TRUTH_FILE = "truth.json"


def recording_truths(rec) -> dict[str, float]:
    """Parameter name -> true value (SI units) of ``rec`` (a Recording): EI, the damping
    parameters and each concealed effect's parameter; empty when no truth.json lies beside it.
    truth.json stores an effect's value under the effect's name (``root_compliance``), so it is
    returned under the effect's one parameter (``k_theta``)."""
    path = Path(rec.source) / TRUTH_FILE if rec.source else None
    if path is None or not path.is_file():
        return {}
    truth = json.loads(path.read_text(encoding="utf-8"))
    values = {"EI": truth["beam_true"]["EI"], **truth.get("damping", {})}
    return values | _effect_truths(truth.get("effect_parameters", {}))


def _effect_truths(effects: dict) -> dict[str, float]:
    from bayesbeam.physics.effects import resolve

    out = {}
    for name, value in effects.items():
        parameters = resolve([name])[0].parameters
        if len(parameters) == 1 and isinstance(value, (int, float)):
            out[parameters[0]] = float(value)
    return out
