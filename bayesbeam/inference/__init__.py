"""What the data say: likelihood, priors, sampling and the fit that ties them together."""
from bayesbeam.inference.fit import FitConfig, FitResult, fit, load_fit_config

__all__ = ["FitConfig", "FitResult", "fit", "load_fit_config"]
