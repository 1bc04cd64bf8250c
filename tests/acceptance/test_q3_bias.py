"""No model error biases q3 on the calibration's reference set-up ("paper_long", test_calibration.py).

The reference simulator's noise-free recording is fitted by the likelihood with the noise sd held
at its truth: where the likelihood peaks is where the fits of its noise draws centre on average,
so the peak's distance from the truth is the bias that any difference between bayesbeam and the
reference (the spatial-hysteresis kernel and its quadrature, gamma's units, the force pulse, the
DAQ filter, the band) causes. The peak is found by Newton steps from the truth (Nelder-Mead to
convergence lands within 0.001 sd of it) and measured in the noise-free Fisher sd at the truth,
the posterior sd without force noise: about 1/1.5 of the fitted posterior's (which the force
noise widens), so the check is stricter than the posterior's own scale. The priors of gamma, a
and b are flat in the sampling coordinates (log-uniform), so this peak is also the posterior's.

Tolerance 0.1 sd for every parameter: a bias of 0.1 Fisher sd (0.07 posterior sd) moves the mean
PIT u of test_calibration.py by 0.02 (E[u] = Phi(bias / sqrt 2) for a Gaussian posterior), below
what its 20 draws resolve (sd 0.065). The measured peak lies 0.02-0.06 sd from the truth (gamma
+0.03, against the low lean of gamma's u), and that is the reference's own numerical accuracy at
this information content (EI known to 2 ppm, gamma to 5 %): simulated on 180 elements its peak
lies 0.06-0.10 sd away, with 16 instead of 8 Gauss points per element 0.03 sd further (its modal
damping ratios of the first six modes agree to 1e-10 between the two), while bayesbeam's next N
(24) moves the peak by at most 0.04 sd. A defect of the size that would matter is caught: air
damping 1 % too strong in bayesbeam (gamma scaled by 1.01 in its damping matrix) moves the peak
by ln(1.01) / sd(ln gamma) = 0.18 sd, which the second test checks the Newton steps recover.
"""
import numpy as np
import pytest

from bayesbeam.inference import FitConfig
from bayesbeam.inference.fit import prepare
from bayesbeam.inference.sampler import laplace_covariance, newton_shift
from bayesbeam.physics.mechanisms.air import Air
from tests.acceptance import cases as ac
from tests.acceptance.test_calibration import CASES

TOLERANCE = 0.1
#: Newton steps to the peak: the last moves it by < 0.001 sd (asserted)
NEWTON_STEPS = 3
MODEL, SETTING, DEGREE, N = CASES["q3"]


class _NoiseHeld:
    """The log likelihood of the model parameters (sampling coordinates) with the noise sd fixed:
    what :func:`laplace_covariance` and :func:`newton_shift` need of a posterior (their priors are
    the model parameters' log-uniform ones, flat in these coordinates, so they add nothing)."""

    def __init__(self, post, noise_z):
        k = len(post.model_names)
        self.post, self.noise_z, self.priors = post, noise_z, post.priors[:k]

    def __call__(self, model_z):
        return self.post.log_likelihood(np.concatenate([model_z, self.noise_z]))


def _peak_shift():
    """The noise-free likelihood's peak - truth in the sampling coordinates, per model parameter,
    and its Fisher sd at the truth."""
    truth = {**ac.hammer(MODEL, SETTING)[1], "sigma_accel_tip": ac.true_noise_sd(MODEL, SETTING)[0]}
    post = prepare(ac.clean_hammer(MODEL, SETTING), MODEL, FitConfig(n_intervals=N, degree=DEGREE), N).posterior
    assert not post.likelihood.latent       # a clean force channel: nothing is marginalised
    k = len(post.model_names)
    truth_z = post.coordinates(truth)
    likelihood = _NoiseHeld(post, truth_z[k:])
    sd = np.sqrt(np.diag(laplace_covariance(likelihood, truth_z[:k])))
    peak = truth_z[:k]
    for _ in range(NEWTON_STEPS):
        step = newton_shift(likelihood, peak, laplace_covariance(likelihood, peak))
        peak = peak + step
    assert np.all(np.abs(step) < 1e-3 * sd), step / sd
    return dict(zip(post.model_names, peak - truth_z[:k])), dict(zip(post.model_names, sd))


def test_noise_free_peak_lies_at_the_truth():
    shift, sd = _peak_shift()
    shift = {name: shift[name] / sd[name] for name in shift}
    print(f"noise-free peak - truth, in Fisher sd: {shift}")
    assert all(abs(s) < TOLERANCE for s in shift.values()), shift


def test_the_peak_moves_by_a_known_air_damping_defect(monkeypatch):
    """Air damping 1 % too strong in the model: the fitted gamma falls by exactly ln(1.01) in the
    sampling coordinate ln(gamma) (gamma enters only through it), the other parameters stay.
    Tolerance 0.01 sd: the Newton step's error on this near-quadratic peak (module docstring)."""
    baseline, sd = _peak_shift()
    damping = Air.damping
    monkeypatch.setattr(Air, "damping", lambda self, ops, values: 1.01 * damping(self, ops, values))
    defect, _ = _peak_shift()
    moved = {name: (defect[name] - baseline[name]) / sd[name] for name in sd}
    expected = {name: -np.log(1.01) / sd["gamma"] if name == "gamma" else 0.0 for name in sd}
    assert abs(expected["gamma"]) > TOLERANCE       # a defect the first test would catch
    assert moved == pytest.approx(expected, abs=0.01), (moved, expected)
