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
    parameters and each concealed effect's parameters; empty when no truth.json lies beside it.
    truth.json may give EI in ``beam_true`` or at its top, and an effect's value under the effect's
    name (``root_compliance``: returned under its one parameter, ``k_theta``) or its parameters
    under their own names (``f_a``, ``m_a``, ...); entries of neither kind are not truths of a
    fitted parameter and are left out."""
    path = Path(rec.source) / TRUTH_FILE if rec.source else None
    if path is None or not path.is_file():
        return {}
    truth = json.loads(path.read_text(encoding="utf-8"))
    ei = truth.get("beam_true", {}).get("EI", truth.get("EI"))
    values = ({} if ei is None else {"EI": ei}) | truth.get("damping", {})
    return values | _effect_truths(truth.get("effect_parameters", {}))


def _effect_truths(effects: dict) -> dict[str, float]:
    from bayesbeam.physics.effects import REGISTRY

    parameters = {p for effect in REGISTRY.values() for p in effect.parameters}
    out = {}
    for key, value in effects.items():
        if not isinstance(value, (int, float)):
            continue
        if key in REGISTRY and len(REGISTRY[key].parameters) == 1:
            out[REGISTRY[key].parameters[0]] = float(value)
        elif key in parameters:
            out[key] = float(value)
    return out
