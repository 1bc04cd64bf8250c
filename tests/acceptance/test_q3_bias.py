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

A band that makes the fit decimate. A fitted band below 0.40 fs / 2 makes the fit decimate
(fit.prepare): the record is low-passed with the DAQ passband of the new rate, whose zero-phase
kernel reaches about 128 samples of that rate either side (0.25 s at 512 Hz, 0.31 s at 409.6 Hz).
A hit a few ms after the record's start is spread back before it, and the model, driven by the
decimated force, must be driven by that part too: cut at the record's start, the force lacks a few
% of its in-band content (on a 4 s, 4096 Hz record of this beam fitted to 152 Hz, decimated by 10:
-3 % at DC, +5 % at 127 Hz; an in-band residual at the truth of 4.2 % of the signal, 3 x the
noise), and q3's posterior sits many sd from the truth along its (gamma, a, b) ridge, on the same
side for every noise draw. The fit therefore decimates with a lead of 128 samples of rest before
the record (signals.decimate); the last two tests check it on this set-up fitted to 150 Hz
(decimated by 2), where without the lead three Newton steps move the noise-free peak by 36-120
Fisher sd along the ridge (ln b -120) and are still far from converged.
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
MODEL, SETTING, DEGREE, N, _ = CASES["q3"]


class _NoiseHeld:
    """The log likelihood of the model parameters (sampling coordinates) with the noise sd fixed:
    what :func:`laplace_covariance` and :func:`newton_shift` need of a posterior (their priors are
    the model parameters' log-uniform ones, flat in these coordinates, so they add nothing)."""

    def __init__(self, post, noise_z):
        k = len(post.model_names)
        self.post, self.noise_z, self.priors = post, noise_z, post.priors[:k]

    def __call__(self, model_z):
        return self.post.log_likelihood(np.concatenate([model_z, self.noise_z]))


def _peak_shift(max_frequency: float | None = None):
    """The noise-free likelihood's peak - truth in the sampling coordinates, per model parameter,
    and its Fisher sd at the truth, fitted to ``max_frequency`` (Hz; default: the fit's)."""
    problem = prepare(ac.clean_hammer(MODEL, SETTING), MODEL,
                      FitConfig(n_intervals=N, degree=DEGREE, max_frequency=max_frequency), N)
    # white noise keeps its density in the band: its sd at fs / D is 1 / sqrt(D) of the recorded one
    noise_sd = ac.true_noise_sd(MODEL, SETTING)[0] / np.sqrt(problem.decimation)
    truth = {**ac.hammer(MODEL, SETTING)[1], "sigma_accel_tip": noise_sd}
    post = problem.posterior
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


#: a band that makes the fit decimate the paper_long record (1024 Hz) by 2 (module docstring)
DECIMATING_BAND = 150.0


def test_noise_free_peak_lies_at_the_truth_when_the_fit_decimates():
    """The first test's check on the band of 150 Hz, decimated by 2: same tolerance and reason.
    The peak lies 0.002-0.004 sd from the truth; without the decimation's lead tens of sd."""
    shift, sd = _peak_shift(DECIMATING_BAND)
    shift = {name: shift[name] / sd[name] for name in shift}
    print(f"noise-free peak - truth, in Fisher sd, fitted to {DECIMATING_BAND} Hz: {shift}")
    assert all(abs(s) < TOLERANCE for s in shift.values()), shift


def test_the_decimated_force_keeps_the_in_band_spectrum_of_the_recorded_one():
    """The force the fit's model is driven by, decimated by 2, has the recorded force's spectrum
    (DTFT of the samples / fs) at every Hz of the band to within 1e-5, relative: what is left is the
    force window's cut of the ringing next to the hit, measured 1e-6. Without the lead the decimated
    force is off by up to 2.5 % (module docstring)."""
    rec = ac.clean_hammer(MODEL, SETTING)
    problem = prepare(rec, MODEL, FitConfig(n_intervals=N, degree=DEGREE, max_frequency=DECIMATING_BAND), N)
    assert problem.decimation == 2
    decimated = problem.model.recording
    f = np.arange(0.0, DECIMATING_BAND, 1.0)

    def spectrum(r):
        return np.exp(-2j * np.pi * np.outer(f, r.time)) @ r.force / r.fs

    error = np.abs(spectrum(decimated) - spectrum(rec)) / np.abs(spectrum(rec))
    assert error.max() < 1e-5, error.max()


def test_the_force_noise_latent_samples_follow_the_lead():
    """On a noise draw (force noise 0.5 % of the peak) fitted to 150 Hz, the latent force-noise
    samples are those of the decimated record around the hit: its peak lies among them. Indexed
    from the recording's start instead of the lead's, they would lie 128 samples (0.25 s) early."""
    rec, _ = ac.hammer(MODEL, SETTING, seed=1000)
    problem = prepare(rec, MODEL, FitConfig(n_intervals=N, degree=DEGREE, max_frequency=DECIMATING_BAND), N)
    index = problem.likelihood.force_noise.index
    assert index.min() <= np.argmax(problem.model.recording.force) <= index.max(), index
