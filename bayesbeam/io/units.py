"""The units a recorded channel may be stated in, and their factors to SI.

A hand table, not pint: a recording needs some twenty units of six quantities, and two of them
mean something else in a general unit library ("g" is gram there, but standard gravity on every
accelerometer's data sheet; "lbf" needs its exact definition stated anyway). A table that shows
each factor beside its unit is easier to check than a library's conventions, and adds no
dependency. Spellings are normalised first (``m/s²``, ``m s^-2``, ``m/s/s``, ``µm``) so the table
holds each unit once.
"""
from __future__ import annotations

import re
from dataclasses import dataclass

STANDARD_GRAVITY = 9.80665
"""g_n, m/s^2 (exact by definition, CGPM 1901)."""
POUND_FORCE = 4.4482216152605
"""lbf in N: the avoirdupois pound (0.45359237 kg, exact) times g_n."""
INCH = 0.0254
"""m (exact)."""

#: the SI unit of each quantity a channel of a recording may hold
SI_UNITS = {"acceleration": "m/s^2", "velocity": "m/s", "displacement": "m", "force": "N", "time": "s",
            "voltage": "V"}


@dataclass(frozen=True)
class Unit:
    """A unit of a recorded quantity: its canonical ``symbol``, the ``quantity`` it measures
    (a key of SI_UNITS) and ``factor``, the SI value of one of it (9.80665 for g)."""

    symbol: str
    quantity: str
    factor: float

    @property
    def si(self) -> str:
        """The SI unit of the same quantity."""
        return SI_UNITS[self.quantity]


_TABLE = (
    Unit("m/s^2", "acceleration", 1.0),
    Unit("mm/s^2", "acceleration", 1e-3),
    Unit("g", "acceleration", STANDARD_GRAVITY),
    Unit("in/s^2", "acceleration", INCH),
    Unit("m/s", "velocity", 1.0),
    Unit("mm/s", "velocity", 1e-3),
    Unit("um/s", "velocity", 1e-6),
    Unit("in/s", "velocity", INCH),
    Unit("m", "displacement", 1.0),
    Unit("mm", "displacement", 1e-3),
    Unit("um", "displacement", 1e-6),
    Unit("in", "displacement", INCH),
    Unit("N", "force", 1.0),
    Unit("kN", "force", 1e3),
    Unit("lbf", "force", POUND_FORCE),
    Unit("s", "time", 1.0),
    Unit("ms", "time", 1e-3),
    Unit("us", "time", 1e-6),
    Unit("V", "voltage", 1.0),
    Unit("mV", "voltage", 1e-3),
)
UNITS = {unit.symbol: unit for unit in _TABLE}
#: other names of the same units (after normalisation)
_ALIASES = {"gn": "g", "g0": "g", "G": "g", "m/sec^2": "m/s^2", "m/sec": "m/s", "sec": "s", "micron": "um",
            "mu": "um", "mus": "us"}


def normalise(text: str) -> str:
    """``text`` with the spellings of one unit made one: µ/μ -> u, ² -> ^2, ``m s^-2`` -> ``m/s^2``,
    ``m/s/s`` -> ``m/s^2``, ``m/s2`` -> ``m/s^2``, spaces dropped."""
    text = text.strip().replace("\u207b\u00b2", "^-2").replace("\u207b\u00b9", "^-1")
    text = text.translate({0xB5: "u", 0x3BC: "u", 0xB2: "^2", 0xB3: "^3"}).replace("**", "^")
    text = re.sub(r"\s*/\s*", "/", text)
    # a negative power of s written as a product: "m s^-2", "m*s-2", "m.s^-1", "m·s⁻²"
    text = re.sub(r"[\s*.·]+s\^?-([12])$", lambda m: "/s" + ("^2" if m[1] == "2" else ""), text)
    text = re.sub(r"/s/s$", "/s^2", text)
    text = re.sub(r"/s2$", "/s^2", text)
    return text.replace(" ", "")


def parse_unit(text: str | None, *, ignore_case: bool = False) -> Unit | None:
    """The unit ``text`` names (any spelling ``normalise`` knows), None when it names none in the table.
    ``ignore_case`` takes ``N``, ``n`` and ``KN`` alike, for file formats that print labels in one case
    (UFF), where a prefix's case says nothing (the table has no two units that differ only in case)."""
    if text is None:
        return None
    key = normalise(text)
    unit = UNITS.get(_ALIASES.get(key, key))
    if unit is None and ignore_case:
        folded = {symbol.lower(): u for symbol, u in UNITS.items()}
        unit = folded.get(_ALIASES.get(key, key).lower())
    return unit


def units_of(*quantities: str) -> tuple[Unit, ...]:
    """The table's units of these quantities, in the table's order."""
    return tuple(u for u in _TABLE if u.quantity in quantities)


def known_units(quantity: str) -> str:
    """The table's symbols for ``quantity``, comma-separated, for refusals."""
    return ", ".join(u.symbol for u in _TABLE if u.quantity == quantity)
