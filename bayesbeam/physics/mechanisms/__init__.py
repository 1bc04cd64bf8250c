"""Damping mechanisms: one module each, one registry, the paper's presets.

Adding a mechanism touches its module, one line of ``REGISTRY`` and its tests.
"""
from bayesbeam.physics.mechanisms.air import Air
from bayesbeam.physics.mechanisms.base import Mechanism
from bayesbeam.physics.mechanisms.exponential import Exponential
from bayesbeam.physics.mechanisms.fractional import Fractional
from bayesbeam.physics.mechanisms.spatial_hysteresis import SpatialHysteresis
from bayesbeam.physics.mechanisms.strain_rate import StrainRate
from bayesbeam.physics.mechanisms.thermoelastic import Thermoelastic
from bayesbeam.physics.mechanisms.time_hysteresis import TimeHysteresis

REGISTRY: dict[str, Mechanism] = {
    m.name: m for m in (Air(), StrainRate(), TimeHysteresis(), SpatialHysteresis(),
                        Fractional(), Exponential(), Thermoelastic())
}

#: the paper's parameter vectors q1, q2, q3 (eqs. 16-18)
PRESETS: dict[str, tuple[str, ...]] = {
    "q1": ("air", "strain_rate"),
    "q2": ("time_hysteresis",),
    "q3": ("air", "spatial_hysteresis"),
}


def resolve(mechanisms) -> tuple[Mechanism, ...]:
    """Mechanism objects from a preset name, a '+'-joined string or a list of names.

    >>> [m.name for m in resolve("q3")]
    ['air', 'spatial_hysteresis']
    >>> [m.name for m in resolve("air+strain_rate")]
    ['air', 'strain_rate']
    """
    if isinstance(mechanisms, str):
        names = PRESETS.get(mechanisms) or tuple(n for n in mechanisms.split("+") if n)
    else:
        names = tuple(mechanisms)
    unknown = [n for n in names if n not in REGISTRY]
    if unknown:
        raise ValueError(
            f"unknown damping mechanism(s) {unknown}; known mechanisms: {sorted(REGISTRY)}, "
            f"presets: {sorted(PRESETS)}"
        )
    if len(set(names)) != len(names):
        raise ValueError(f"mechanism listed twice in {list(names)}")
    return tuple(REGISTRY[n] for n in names)


__all__ = ["Mechanism", "REGISTRY", "PRESETS", "resolve"]
