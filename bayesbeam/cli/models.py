"""``bayesbeam models``: the presets, damping mechanisms and missing-physics effects a model is built
from, with their parameters, SI units and default priors (read from the registries and the prior
table, so the listing is what the fits use)."""
from __future__ import annotations

HELP = "list the presets, damping mechanisms and effects with their parameters, units and default priors"


def add_arguments(p) -> None:
    p.add_argument("--beam", metavar="BEAM_TOML",
                   help="evaluate the default priors for this beam.toml (default: priors in terms of the "
                        "beam's EI_0, l, rho A l and P_cr)")


def run(args) -> int:
    print("\n".join(listing(_beam(args.beam))))
    return 0


def _beam(path):
    from bayesbeam.io import load_beam_description

    return load_beam_description(path).beam if path else None


def listing(beam=None) -> list[str]:
    """The lines ``bayesbeam models`` prints; default priors as numbers when ``beam`` is given."""
    from bayesbeam.comparison import MODEL_SETS
    from bayesbeam.inference.priors import NOISE_DEFAULTS, SCALES, SETUP_PRIORS
    from bayesbeam.model import PARAMETER_UNITS, SETUP_PARAMETER_UNITS
    from bayesbeam.physics.effects import REGISTRY as EFFECTS
    from bayesbeam.physics.mechanisms import PRESETS
    from bayesbeam.physics.mechanisms import REGISTRY as MECHANISMS

    lines = ["Presets (--model; the paper's parameter vectors):"]
    lines += [f"  {name:<4} = {' + '.join(mechanisms)}" for name, mechanisms in PRESETS.items()]
    lines += ["", "Model sets (--models NAME in compare and batch):"]
    lines += [f"  {name:<10} = {', '.join(models)}" for name, models in MODEL_SETS.items()]
    lines += ["", "Every model: the beam's bending stiffness"]
    lines += [_parameter_line(name, unit, beam) for name, unit in PARAMETER_UNITS.items()]
    lines += ["", "Damping mechanisms (--model, joined by '+', e.g. air+strain_rate):"]
    for component in MECHANISMS.values():
        lines += _component_lines(component, beam)
    lines += ["", "Missing-physics effects (--effect NAME, repeatable; or joined to --model, e.g. q2+sensor_mass):"]
    for component in EFFECTS.values():
        lines += _component_lines(component, beam) + SENSOR_MASS_NOTE * (component.name == "sensor_mass")
    lines += ["", "Noise, per sensor channel <s> (--noise white: sigma_<s>; --noise ar1: also phi_<s>):"]
    units = {"sigma": "channel unit", "phi": "-"}
    lines += [_parameter_line(f"{name}_<s>", units[name], None, prior_of=name) for name in NOISE_DEFAULTS]
    lines += ["", ("Set-up, fitted by every model where beam.toml states a tolerance > 0 (l: [beam] "
                   "length_tolerance; dx_<s>: [[sensor]] location_tolerance of sensor <s>; dx_hammer: "
                   "[excitation] location_tolerance):")]
    lines += [f"      {name:<11} {unit:<14} {SETUP_PRIORS[name]}" for name, unit in SETUP_PARAMETER_UNITS.items()]
    if beam is None:
        scales = ", ".join(s for s in SCALES if s and s != "RMS")
        lines += ["", (f"Prior scales: {scales} of the beam.toml (RMS: the channel's). --beam BEAM_TOML "
                       "evaluates them; a [prior.NAME] table in a --config fit file replaces a default.")]
    return lines


#: how the sensor_mass effect names its masses, and what a stated mass does
SENSOR_MASS_NOTE = [("      (m_s for a recording's only sensor, m_s_<s> for each sensor <s> of several; a sensor's "
                     "[[sensor]] mass centres its prior, and every model without the effect carries it)")]


def _component_lines(component, beam) -> list[str]:
    lines = [f"  {component.name:<20} {component.description}"]
    for name in component.parameters:
        if name in component.defaults:
            lines.append(f"      {name:<11} {component.units[name]:<14} not sampled: "
                         f"{component.defaults[name]} unless set (simulate --set {name}=VALUE)")
        else:
            lines.append(_parameter_line(name, component.units[name], beam))
    return lines


def _parameter_line(name: str, unit: str, beam, prior_of: str | None = None) -> str:
    return f"      {name:<11} {unit:<14} {_prior(prior_of or name, beam if prior_of is None else None)}"


def _prior(name: str, beam) -> str:
    """The default prior of ``name``: numbers for ``beam``, else in terms of the beam's scales."""
    from bayesbeam.inference.priors import DEFAULTS, NOISE_DEFAULTS, default_priors, describe_default

    if name not in DEFAULTS and name not in NOISE_DEFAULTS:
        return f"no default prior: give [prior.{name}] in a --config fit file"
    return describe_default(name) if beam is None else default_priors(beam, (name,), {})[name].describe()
