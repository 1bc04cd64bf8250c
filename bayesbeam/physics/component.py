"""What damping mechanisms and missing-physics effects have in common: named SI parameters."""
from __future__ import annotations

from collections.abc import Mapping

import numpy as np


class Component:
    """A named physical ingredient of the model with its parameters (SI units)."""

    name: str = ""
    parameters: tuple[str, ...] = ()
    units: Mapping[str, str] = {}
    #: parameters with a default value, not sampled unless the user asks
    defaults: Mapping[str, float] = {}
    description: str = ""
    #: names of the components this one needs in the same model (a root dashpot needs the root spring)
    requires: tuple[str, ...] = ()

    def bind(self, recording) -> Component:
        """This component for one recording: itself, or a copy holding what it reads from the
        recording's description (the thermoelastic mechanism's [material] constants)."""
        return self

    def check(self, values: Mapping[str, float]) -> None:
        """Raise ValueError if the values are not physical (default: finite, or an infinite
        default such as an unlimited memory, and >= 0)."""
        for key in self.parameters:
            v = values[key]
            if not (np.isfinite(v) or (v == np.inf and key in self.defaults)) or v < 0:
                raise ValueError(f"{self.name}: {key} = {v!r} is not physical (must be finite and >= 0)")
