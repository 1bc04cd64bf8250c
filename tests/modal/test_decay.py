"""ERA on recordings: simulated beams give back the model's modes; segments; mode numbering."""

from dataclasses import replace

import numpy as np
import pytest

from bayesbeam.io import Beam, Excitation
from bayesbeam.modal.decay import (
    _assign,
    decay_segment,
    identify_modes,
    nominal_frequencies,
)
from bayesbeam.response.signals import EDGE
from tests.modal.simulated import hammer_with_vibrometer, with_noise


def test_noise_free_simulation_gives_the_model_modes():
    rec, _, f, zeta = hammer_with_vibrometer()
    found = identify_modes(rec)
    # All nine modes below 0.40 fs = 819 Hz, numbered 1-9. (The order, 28, leaves ten states
    # to fit round-off; a pole of those may pass the filters and is then reported unassigned.)
    assert found.modes == tuple(range(1, 10)) and not found.missing
    # Once the force and the DAQ filter are past, the simulation is exactly a sum of damped
    # modes, so only round-off remains (observed 1e-11 in f, 7e-9 in zeta): bounds 1e-9, 1e-6.
    np.testing.assert_allclose(found.frequencies_hz, f, rtol=1e-9)
    np.testing.assert_allclose(found.damping_ratios, zeta, rtol=1e-6)
    # Both channels sit at the tip: converted to displacement (velocity / s, acceleration
    # / s^2) they must give the same shape component, 1 after scaling (observed 5e-10).
    np.testing.assert_allclose(found.shapes, 1.0, atol=1e-7)


@pytest.mark.parametrize("seed", [0, 1])
def test_era_recovers_model_modes_at_realistic_noise(seed):
    # The cross-check: 1 % noise (of each channel's RMS), first 6 modes, frequencies
    # within 0.1 % and damping ratios within 5 % of BeamModel.natural_frequencies /
    # modal_damping_ratios. Over 20 seeds the worst errors are 6.2e-5 in f (16x margin)
    # and 2.1 % in zeta (mode 2, 2.4x margin), so the bounds hold for any seed while a
    # systematic error (a wrong channel scaling, segment or pole conversion) breaks them.
    rec, _, f, zeta = hammer_with_vibrometer()
    found = identify_modes(with_noise(rec, seed), n_modes=6)
    assert found.modes == (1, 2, 3, 4, 5, 6)
    np.testing.assert_allclose(found.frequencies_hz, f[:6], rtol=1e-3)
    np.testing.assert_allclose(found.damping_ratios, zeta[:6], rtol=0.05)
    assert np.all(found.emac > 0.9)


def test_segment_starts_after_the_force_and_the_filter():
    rec, *_ = hammer_with_vibrometer()
    last = np.flatnonzero(np.abs(rec.force) >= 0.05 * np.abs(rec.force).max())[-1]
    assert decay_segment(rec) == (last + 1 + EDGE, rec.n_samples)
    assert decay_segment(rec, start=1.0, stop=2.0) == (2048, 4097)  # 2048 Hz: t = 1.0 and 2.0 s included
    release = replace(rec, excitation=Excitation("release", tip_load=1.0), force=None)
    assert decay_segment(release)[0] == EDGE  # the record starts at t = 0
    tapped = replace(rec, excitation=Excitation("free_decay", start=0.5), force=None)
    assert decay_segment(tapped)[0] == 1024 + EDGE
    with pytest.raises(ValueError, match="Fix: pass --start/--stop"):
        decay_segment(rec, start=3.0, stop=2.0)


def test_numbering_survives_a_wrong_nominal_modulus_and_reports_gaps():
    rec, *_ = hammer_with_vibrometer()
    nominal = nominal_frequencies(rec, 800.0)
    true = nominal * np.sqrt(0.7)  # the beam is 30 % softer than beam.toml says
    # Mode 3 missing, a weak spurious pole next to mode 5: numbers 1, 2, 4, 5 and a loser.
    poles = np.array([true[0], true[1], true[3], true[4] * 1.02, true[4]])
    weights = np.array([1.0, 1.0, 1.0, 0.01, 1.0])
    nearest, numbers = _assign(poles, weights, nominal)
    np.testing.assert_array_equal(nearest, [1, 2, 4, 5, 5])
    np.testing.assert_array_equal(numbers, [1, 2, 4, 0, 5])
    # Plain nearest-neighbour numbering without the scale would be fooled at 30 %:
    assert np.argmin(np.abs(np.log(true[6] / nominal))) + 1 != 7


def test_expected_modes_without_a_pole_are_reported_missing():
    rec, *_ = hammer_with_vibrometer()
    # A nominal E 30 % low puts mode 10 (nominal 801 Hz) inside the band, where the
    # record (true mode 10 at ~933 Hz) cannot show it.
    soft = replace(rec, beam=replace(rec.beam, modulus=rec.beam.modulus * 0.7))
    found = identify_modes(soft, diagram_orders=lambda n: range(2, n + 1, 2))
    assert found.modes == tuple(range(1, 10)) and found.missing == (10,)
    # The default order is 3 x 10 nominal modes in the band; the diagram comes from the same
    # SVD, so its top order holds the kept poles exactly.
    assert found.order == 30 and found.diagram.orders == list(range(2, 31, 2))
    assert np.all(np.isin(found.frequencies_hz, found.diagram.poles[-1].frequencies_hz))


def test_nominal_frequencies_cover_the_band():
    rec, *_ = hammer_with_vibrometer()
    f = nominal_frequencies(rec, 500.0)
    assert f[-2] <= 500.0 < f[-1]
    bare = replace(rec, beam=Beam(1.0, 1710.0, 0.597e-3, 1.64e-9, 2.68e10))
    assert nominal_frequencies(bare, 10.0)[0] == pytest.approx(3.6, rel=0.02)  # Table 3: 3.64 Hz
