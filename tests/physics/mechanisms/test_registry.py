"""Registry, presets and the shared interface."""
import numpy as np
import pytest

from bayesbeam.physics.mechanisms import PRESETS, REGISTRY, resolve


def test_presets_are_the_papers_parameter_vectors():
    params = {name: ["EI"] + [p for m in resolve(name) for p in m.parameters if p not in m.defaults]
              for name in PRESETS}
    assert params == {"q1": ["EI", "gamma", "cdI"], "q2": ["EI", "alpha", "beta"],
                      "q3": ["EI", "gamma", "a", "b"]}


def test_resolve_accepts_names_lists_and_plus_strings():
    assert [m.name for m in resolve(["strain_rate"])] == ["strain_rate"]
    assert [m.name for m in resolve("air+time_hysteresis")] == ["air", "time_hysteresis"]


def test_resolve_refuses_unknown_and_repeated_names():
    with pytest.raises(ValueError, match="unknown damping mechanism.*'viscoelastic'.*known"):
        resolve("air+viscoelastic")
    with pytest.raises(ValueError, match="twice"):
        resolve(["air", "air"])


@pytest.mark.parametrize("name", sorted(REGISTRY))
def test_every_mechanism_refuses_negative_parameters(name):
    mech = REGISTRY[name]
    values = {p: 1.0 for p in mech.parameters}
    values[mech.parameters[0]] = -1.0
    with pytest.raises(ValueError, match="not physical"):
        mech.check(values)


@pytest.mark.parametrize("name", sorted(REGISTRY))
def test_every_mechanism_has_units_for_each_parameter(name):
    mech = REGISTRY[name]
    assert set(mech.units) == set(mech.parameters)
    assert mech.description


def test_nan_parameter_is_not_physical():
    with pytest.raises(ValueError):
        REGISTRY["air"].check({"gamma": np.nan})
