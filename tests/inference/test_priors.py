"""Priors: proper densities in their sampling coordinates, the default table, TOML overrides."""
import numpy as np
import pytest
from scipy import integrate, stats

from bayesbeam.inference import load_fit_config
from bayesbeam.inference.fit import prepare
from bayesbeam.inference.priors import Prior, default_priors, prior_from_table
from bayesbeam.model import BeamModel
from bayesbeam.physics.effects import REGISTRY as EFFECTS
from bayesbeam.physics.mechanisms import REGISTRY as MECHANISMS
from tests.inference import cases

EXAMPLES = [Prior("lognormal", 44.28, 0.25), Prior("lognormal", 3e-3, 1.5), Prior("loguniform", 1e-5, 1e2),
            Prior("loguniform", 0.3, 0.31), Prior("uniform", -5.0, 50.0), Prior("uniform", 0.0, 0.005)]


def integral(prior):
    """Integral of exp(log_density) over the sampling coordinate, by adaptive quadrature.

    The log-normal and the normal are integrated over +-12 sd (the mass outside is 4e-33).
    """
    lo, hi = prior.bounds()
    gaussian = prior.kind in ("lognormal", "normal")
    if gaussian:
        mid, sd = prior.median(), prior.b
        lo, hi = mid - 12 * sd, mid + 12 * sd
    value, _ = integrate.quad(lambda z: np.exp(prior.log_density(z)), lo, hi, epsabs=1e-13, epsrel=1e-12,
                                limit=200, points=[prior.median()] if gaussian else None)
    return value


@pytest.mark.parametrize("prior", EXAMPLES, ids=lambda p: p.describe())
def test_density_integrates_to_one_in_its_sampling_coordinate(prior):
    """Normalised to 1e-9 (quadrature of a smooth or piecewise-constant integrand: error ~1e-12)."""
    assert integral(prior) == pytest.approx(1.0, abs=1e-9)


@pytest.mark.parametrize("prior", EXAMPLES, ids=lambda p: p.describe())
def test_density_is_the_documented_distribution_with_its_jacobian(prior):
    """In z = log(value) the density is the physical one times value (the Jacobian): compare with
    scipy.stats' lognorm / loguniform / uniform at interior points (relative 1e-12)."""
    lo, hi = prior.bounds()
    z = np.linspace(lo, hi, 13)[1:-1]
    x = prior.to_value(z)
    if prior.kind == "lognormal":
        reference = stats.lognorm(s=prior.b, scale=prior.a).logpdf(x) + np.log(x)
    elif prior.kind == "loguniform":
        reference = stats.loguniform(prior.a, prior.b).logpdf(x) + np.log(x)
    else:
        reference = stats.uniform(prior.a, prior.b - prior.a).logpdf(x)
    np.testing.assert_allclose([prior.log_density(v) for v in z], reference, rtol=1e-12)
    np.testing.assert_allclose(prior.to_coordinate(x), z, rtol=1e-12, atol=1e-15)


@pytest.mark.parametrize("prior", [p for p in EXAMPLES if p.kind != "lognormal"], ids=lambda p: p.describe())
def test_outside_the_support_is_minus_infinity(prior):
    """Bounded priors: -inf just outside either end, at +-inf and at NaN; never an exception."""
    lo, hi = prior.bounds()
    width = hi - lo
    for z in (lo - 1e-9 * width, hi + 1e-9 * width, -np.inf, np.inf, np.nan):
        assert prior.log_density(z) == -np.inf
    assert np.isfinite(prior.log_density(lo)) and np.isfinite(prior.log_density(hi))


def test_lognormal_tails_are_minus_infinity_at_infinite_coordinates():
    prior = Prior("lognormal", 44.0, 0.25)
    assert prior.log_density(np.inf) == -np.inf and prior.log_density(-np.inf) == -np.inf


@pytest.mark.parametrize("prior", EXAMPLES, ids=lambda p: p.describe())
def test_draws_lie_in_the_support_with_the_prior_median(prior):
    """5000 draws: all have finite density; their median is the prior median within 4 sd of the
    sample median (sd of a sample median: 1.2533 x scale / sqrt(n) for the normal, width/(2 sqrt(n))
    for the uniform)."""
    rng = np.random.default_rng(4)
    z = prior.draw(rng, 5000)
    assert np.all(np.isfinite([prior.log_density(v) for v in z]))
    lo, hi = prior.bounds()
    sd_median = 1.2533 * prior.b / np.sqrt(5000) if prior.kind == "lognormal" else (hi - lo) / (2 * np.sqrt(5000))
    assert abs(np.median(z) - prior.median()) < 4 * sd_median


# ---------------------------------------------------------------------------- defaults
def all_parameter_names():
    """Every sampled parameter of a model of each registered mechanism and catalogue effect (some
    need another component beside them, or a [material] table: their parameters are read directly)."""
    names = set(BeamModel.from_recording(cases.base_recording(), "q1", 4).parameter_names)
    for component in (*MECHANISMS.values(), *EFFECTS.values()):
        names.update(p for p in component.parameters if p not in component.defaults)
    return sorted(names)


def test_every_parameter_of_the_presets_and_effects_has_a_default_prior():
    """default_priors covers every mechanism and effect, plus a sigma_<sensor> per channel; each default
    is a proper density (integral 1 within 1e-9) that gives positive physical values where the
    parameter must be positive."""
    names = all_parameter_names()
    assert {"EI", "gamma", "cdI", "alpha", "beta", "a", "b"} <= set(names)
    assert len(names) >= 7 + len(EFFECTS)
    beam = cases.PAPER_BEAM
    priors = default_priors(beam, names, {"accel_tip": 2.0, "disp": 1e-4})
    assert set(priors) == set(names) | {"sigma_accel_tip", "sigma_disp"}
    for name, prior in priors.items():
        assert integral(prior) == pytest.approx(1.0, abs=1e-9), name
    assert priors["EI"].kind == "lognormal" and priors["EI"].a == pytest.approx(beam.nominal_EI)
    assert priors["sigma_accel_tip"].bounds() == pytest.approx((np.log(2e-6), np.log(20.0)))
    assert priors["sigma_disp"].bounds() == pytest.approx((np.log(1e-10), np.log(1e-3)))
    p_cr = np.pi**2 * beam.nominal_EI / (4 * beam.length**2)
    if "P" in priors:
        assert priors["P"].bounds() == pytest.approx((-0.5 * p_cr, 10 * p_cr))


def test_a_parameter_without_a_default_is_refused_with_the_fix():
    with pytest.raises(ValueError, match=r"no default prior for parameter 'r'.*\[prior\.r\]"):
        default_priors(cases.PAPER_BEAM, ("EI", "alpha", "beta", "r"), {})


# ---------------------------------------------------------------------------- TOML overrides
FIT_FILE = """
[fit]
n_intervals = 8
noise = "ar1"
max_steps = 1234
walkers = 20
seed = 7
max_frequency = 150.0
effects = ["root_compliance"]

[prior.EI]
kind = "lognormal"
median = 44.0
sigma = 0.1

[prior.gamma]
kind = "loguniform"
low = 1e-3
high = 10.0

[prior.P]
kind = "uniform"
low = -5.0
high = 50
"""


def write(tmp_path, text):
    path = tmp_path / "fit.toml"
    path.write_text(text)
    return path


def test_fit_file_settings_and_prior_overrides_are_read(tmp_path):
    config = load_fit_config(write(tmp_path, FIT_FILE))
    assert (config.n_intervals, config.noise, config.max_steps, config.walkers, config.seed) == (8, "ar1", 1234, 20, 7)
    assert config.max_frequency == 150.0 and config.effects == ("root_compliance",)
    assert config.priors == {"EI": Prior("lognormal", 44.0, 0.1), "gamma": Prior("loguniform", 1e-3, 10.0),
                             "P": Prior("uniform", -5.0, 50.0)}
    # keyword overrides win over the file; None means "keep the file's value"
    again = load_fit_config(write(tmp_path, FIT_FILE), seed=99, walkers=None)
    assert again.seed == 99 and again.walkers == 20


def test_overrides_replace_the_defaults_in_the_posterior(tmp_path, air_case):
    """prepare() uses the file's priors for the parameters it names and the defaults elsewhere."""
    rec, _ = air_case
    text = FIT_FILE.replace('noise = "ar1"', 'noise = "white"').replace('effects = ["root_compliance"]', "")
    text = text[: text.index("[prior.P]")]
    config = load_fit_config(write(tmp_path, text))
    post = prepare(rec, "air", config, 6).posterior
    priors = dict(zip(post.names, post.priors))
    assert priors["EI"] == Prior("lognormal", 44.0, 0.1)
    assert priors["gamma"] == Prior("loguniform", 1e-3, 10.0)
    rms = post.likelihood.channel_rms["accel_tip"]
    assert priors["sigma_accel_tip"] == Prior("loguniform", 1e-6 * rms, 10 * rms)


@pytest.mark.parametrize("table, message", [
    ('kind = "gaussian"\nlow = 1\nhigh = 2', r"\[prior\.gamma\] kind = 'gaussian': expected one of"),
    ("low = 1\nhigh = 2", r"\[prior\.gamma\] kind = None: expected one of"),
    ('kind = "loguniform"\nlow = 1e-3', r"\[prior\.gamma\] needs \['high'\] for kind = 'loguniform'.*Fix: add high"),
    ('kind = "lognormal"\nmean = 1.0\nsd = 0.1', r"needs \['median', 'sigma'\].*Fix: add median = <number> and sigma"),
    ('kind = "loguniform"\nlow = 10.0\nhigh = 1.0', r"\[prior\.gamma\].*0 < low < high.*Fix"),
    ('kind = "loguniform"\nlow = -1.0\nhigh = 1.0', r"\[prior\.gamma\].*0 < low < high"),
    ('kind = "uniform"\nlow = 2.0\nhigh = 2.0', r"\[prior\.gamma\].*low < high"),
    ('kind = "uniform"\nlow = "a"\nhigh = 2.0', r"\[prior\.gamma\].*Fix: give numbers"),
    ('kind = "lognormal"\nmedian = 0.0\nsigma = 0.1', r"median > 0 and sigma > 0"),
    ('kind = "lognormal"\nmedian = 1.0\nsigma = nan', r"finite numbers"),
])
def test_bad_prior_tables_are_clear_value_errors(tmp_path, table, message):
    """Each names the file and the table, what is wrong, and (where it can) the fix."""
    path = write(tmp_path, f"[prior.gamma]\n{table}\n")
    with pytest.raises(ValueError, match=message) as info:
        load_fit_config(path)
    assert str(path) in str(info.value)


def test_unknown_fit_keys_are_refused_with_the_known_ones(tmp_path):
    path = write(tmp_path, "[fit]\nwalker = 12\nmax_step = 10\n")
    with pytest.raises(ValueError, match=r"unknown key\(s\) \['max_step', 'walker'\].*Fix: use only.*'walkers'"):
        load_fit_config(path)


def test_bad_noise_model_missing_file_and_bad_syntax_are_value_errors(tmp_path):
    with pytest.raises(ValueError, match=r"noise = 'pink': expected one of \('white', 'ar1'\)"):
        load_fit_config(write(tmp_path, '[fit]\nnoise = "pink"\n'))
    with pytest.raises(ValueError, match="fit file not found"):
        load_fit_config(tmp_path / "missing.toml")
    with pytest.raises(ValueError, match="Fix: correct the TOML syntax"):
        load_fit_config(write(tmp_path, "[fit\nseed = 1\n"))


def test_prior_from_table_accepts_integers_and_names_the_default_file():
    assert prior_from_table("P", {"kind": "uniform", "low": -5, "high": 50}) == Prior("uniform", -5.0, 50.0)
    with pytest.raises(ValueError, match=r"^fit file: \[prior\.P\]"):
        prior_from_table("P", {"kind": "uniform", "low": 5})


def test_a_zero_bound_is_written_without_its_scale():
    """`bayesbeam models` shows the attached body's place as uniform over [0, l], not '0 l'."""
    from bayesbeam.inference.priors import describe_default

    assert describe_default("x_a") == "uniform(low=0, high=l)"
    assert describe_default("b") == "loguniform(low=0.001 l, high=l)"
