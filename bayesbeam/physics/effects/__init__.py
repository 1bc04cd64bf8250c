"""Missing-physics effects: one module each, one registry.

Adding an effect touches its module, one line of ``REGISTRY`` and its tests.
"""
from bayesbeam.physics.effects.attachment import Attachment
from bayesbeam.physics.effects.axial_load import AxialLoad
from bayesbeam.physics.effects.base import Effect, Setup
from bayesbeam.physics.effects.base_support import BaseSupport
from bayesbeam.physics.effects.channel_gain import ChannelGain
from bayesbeam.physics.effects.dry_friction import DryFriction
from bayesbeam.physics.effects.high_pass import HighPass
from bayesbeam.physics.effects.mains_lines import MainsLines
from bayesbeam.physics.effects.measurement_delay import MeasurementDelay
from bayesbeam.physics.effects.quadratic_drag import QuadraticDrag
from bayesbeam.physics.effects.root_compliance import RootCompliance
from bayesbeam.physics.effects.root_damping import RootDamping
from bayesbeam.physics.effects.sensor_mass import SensorMass

REGISTRY: dict[str, Effect] = {
    e.name: e for e in (RootCompliance(), SensorMass(), AxialLoad(), MeasurementDelay(),
                        QuadraticDrag(), DryFriction(), RootDamping(), HighPass(), ChannelGain(),
                        Attachment(), MainsLines(), BaseSupport())
}


def resolve(effects) -> tuple[Effect, ...]:
    """Effect objects from a name, a '+'-joined string or a list of names (empty: none)."""
    if effects is None:
        return ()
    names = tuple(n for n in effects.split("+") if n) if isinstance(effects, str) else tuple(effects)
    unknown = [n for n in names if n not in REGISTRY]
    if unknown:
        raise ValueError(f"unknown effect(s) {unknown}; known effects: {sorted(REGISTRY)}")
    if len(set(names)) != len(names):
        raise ValueError(f"effect listed twice in {list(names)}")
    return tuple(REGISTRY[n] for n in names)


__all__ = ["Effect", "Setup", "REGISTRY", "resolve"]
