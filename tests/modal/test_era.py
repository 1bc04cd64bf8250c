"""ERA on synthetic free decays: sums of damped sinusoids with known modes."""

import matplotlib

matplotlib.use("Agg")

import numpy as np
import pytest

from bayesbeam.modal.era import era, hankel_svd, mac, plot_stabilization, stabilization

F_HZ = np.array([5.0, 23.0, 61.0])  # well separated
ZETA = np.array([0.005, 0.002, 0.01])  # 0.1-1 %, as in the paper's beam
SHAPES = np.array([[1.0, 0.6, -0.3], [0.5, -1.0, 0.8], [0.2, 0.7, 1.0]])  # channels x modes
AMP = np.array([1.0, 0.5, 0.3])
PHASE = np.array([0.3, 1.2, -0.7])
DT, N = 1 / 500, 1500


def _free_decay(n=N):
    t = np.arange(n)[:, None] * DT
    wn = 2 * np.pi * F_HZ
    modal = AMP * np.exp(-ZETA * wn * t) * np.cos(wn * np.sqrt(1 - ZETA**2) * t + PHASE)
    return modal @ SHAPES.T


def _nearest(found, truth):
    return np.array([np.argmin(np.abs(found - f)) for f in truth])


def test_noise_free_decay_is_recovered_exactly():
    y = _free_decay()
    modes = era(y, DT, n_rows=40)
    assert modes.order == 6  # automatic: the singular values drop to round-off after 6
    # Exact data and an exact model: only round-off remains, far below the 1e-6 asked.
    np.testing.assert_allclose(modes.frequencies_hz, F_HZ, rtol=1e-6)
    np.testing.assert_allclose(modes.damping_ratios, ZETA, rtol=1e-6)
    # Shapes scaled to 1 at their largest component; the true ones are real.
    expected = SHAPES / SHAPES[np.argmax(np.abs(SHAPES), axis=0), range(3)]
    np.testing.assert_allclose(modes.mode_shapes, expected, atol=1e-6)
    # Complex amplitude: y_i = 2 Re(phi_i a e^{st}) with a = (peak shape) * AMP e^{i phase} / 2.
    peak = SHAPES[np.argmax(np.abs(SHAPES), axis=0), range(3)]
    np.testing.assert_allclose(modes.amplitudes, peak * AMP * np.exp(1j * PHASE) / 2, atol=1e-6)
    np.testing.assert_allclose(modes.emac, 1, atol=1e-6)
    np.testing.assert_allclose(modes.mpc, 1, atol=1e-6)
    np.testing.assert_allclose(modes.reconstruct(N, DT), y, atol=1e-8)


@pytest.mark.parametrize("noise", [0.01, 0.02])
@pytest.mark.parametrize("seed", [0, 1])
def test_noisy_decay_within_tolerance(noise, seed):
    # 1-2 % white noise (of each channel's rms). Asked: f within 0.1 %, zeta within 5 %.
    # ERA's worst case over 20 seeds of this set-up is 0.014 % and 2.4 %, so the bounds
    # keep a margin of 7x and 2x and the test is not fragile to the seed.
    y = _free_decay()
    rng = np.random.default_rng(seed)
    y = y + noise * y.std(axis=0) * rng.standard_normal(y.shape)
    modes = era(y, DT, n_rows=40)
    assert len(modes.frequencies_hz) == 3  # the filters leave exactly the physical modes
    np.testing.assert_allclose(modes.frequencies_hz, F_HZ, rtol=1e-3)
    np.testing.assert_allclose(modes.damping_ratios, ZETA, rtol=0.05)
    assert np.all(modes.emac > 0.9)
    if noise < 0.02:
        return
    # Over-specified order: extra noise poles are filtered or stay apart from the modes.
    big = era(y, DT, order=20, n_rows=40)
    k = _nearest(big.frequencies_hz, F_HZ)
    np.testing.assert_allclose(big.frequencies_hz[k], F_HZ, rtol=1e-3)
    np.testing.assert_allclose(big.damping_ratios[k], ZETA, rtol=0.05)


def test_single_channel_1d_input():
    y = _free_decay()[:, 0]
    modes = era(y, DT, n_rows=120)
    np.testing.assert_allclose(modes.frequencies_hz, F_HZ, rtol=1e-6)
    assert modes.mode_shapes.shape == (1, 3) and np.all(modes.mpc == 1)


def test_growing_and_overdamped_poles_are_filtered():
    t = np.arange(N) * DT
    y = _free_decay()[:, 0] + 0.2 * np.exp(+0.3 * t) * np.cos(2 * np.pi * 40 * t)  # zeta < 0
    modes = era(y, DT, order=8, n_rows=120, min_emac=0.0)
    assert not np.any(np.isclose(modes.frequencies_hz, 40, rtol=1e-2))
    everything = era(y, DT, order=8, n_rows=120, min_emac=0.0, max_damping=np.inf)
    assert np.all(everything.damping_ratios > 0)  # criterion 2 holds regardless


def test_stabilization_diagram_flags_the_physical_modes():
    rng = np.random.default_rng(3)
    y = _free_decay()
    y = y + 0.01 * y.std(axis=0) * rng.standard_normal(y.shape)
    diagram = stabilization(y, DT, range(4, 31, 2), n_rows=40)
    assert diagram.orders == list(range(4, 31, 2))
    for n, modes, ok in zip(diagram.orders, diagram.poles, diagram.stable):
        if n >= 8:  # two orders past the true 6, every physical mode is stable
            k = _nearest(modes.frequencies_hz, F_HZ)
            assert np.all(ok[k]), n
            np.testing.assert_allclose(modes.frequencies_hz[k], F_HZ, rtol=1e-3)
    ax = plot_stabilization(diagram)
    assert ax.get_xlabel() == "frequency (Hz)"


def test_mac_is_scale_and_phase_invariant():
    phi = np.array([1.0, -0.5, 0.25])
    assert mac(phi, 3j * phi) == pytest.approx(1.0)
    assert mac(phi, np.array([0.5, 1.0, 0.0])) == pytest.approx(0.0, abs=1e-15)


def test_rejects_too_short_records():
    with pytest.raises(ValueError, match="needs"):
        era(np.ones((10, 2)), DT, n_rows=8, n_cols=8)


def test_leading_triplets_match_the_full_svd():
    """``hankel_svd(rank=k)`` (Gram matrix route) against the full SVD, on a noisy 3-channel decay
    with the order over-specified (20 for 3 modes: 14 directions in the noise floor, where the
    singular values crowd and the subspace is least well conditioned). The Gram route perturbs
    the subspace by about eps * sigma_1^2 / (sigma_k^2 - sigma_(k+1)^2); the full SVD's own
    answers move by about 1e-11 between LAPACK drivers on such decays (benchmarks/ppc.py), so
    1e-8 relative on frequencies and damping ratios is round-off with a wide margin, while a
    wrong subspace (an index off by one, a missing Rayleigh-Ritz rotation) moves poles by the
    noise's own scale, 1e-4 or more."""
    rng = np.random.default_rng(4)
    y = _free_decay()
    y = y + 0.02 * y.std(axis=0) * rng.standard_normal(y.shape)
    full, leading = hankel_svd(y, n_rows=40), hankel_svd(y, n_rows=40, rank=20)
    assert leading.S.shape == (20,) and leading.Vt.shape == (20, full.Vt.shape[1])
    np.testing.assert_allclose(leading.S, full.S[:20], rtol=1e-10)
    # the factors reproduce H(0) on the subspace: U^T H = S Vt, U orthonormal
    np.testing.assert_allclose(leading.U.T @ leading.U, np.eye(20), atol=1e-12)
    a, b = era(full, DT, order=20), era(leading, DT, order=20)
    assert len(a.frequencies_hz) == len(b.frequencies_hz) >= 3
    np.testing.assert_allclose(b.frequencies_hz, a.frequencies_hz, rtol=1e-8)
    np.testing.assert_allclose(b.damping_ratios, a.damping_ratios, rtol=1e-8)


def test_leading_triplets_fall_back_to_the_full_svd_below_the_gram_floor():
    """Noise-free decay, 3 modes: singular values 7 onwards are round-off, which H H^T cannot
    resolve (its eigenvalues carry errors of eps * sigma_1^2), so rank 20 takes the full SVD:
    every singular value, the same as without ``rank``."""
    full, leading = hankel_svd(_free_decay(), n_rows=40), hankel_svd(_free_decay(), n_rows=40, rank=20)
    np.testing.assert_array_equal(leading.S, full.S)
    np.testing.assert_allclose(era(leading, DT, order=6).frequencies_hz, F_HZ, rtol=1e-6)
