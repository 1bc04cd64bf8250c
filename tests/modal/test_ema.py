"""EMA route (eqs. 25-29): exact recovery on synthetic modal data, weighting, CSV I/O."""

import json

import numpy as np
import pytest

from bayesbeam.modal.eigen import clamped_free_betas, natural_frequencies_hz
from bayesbeam.modal.ema import (
    ModalTable,
    damping_design_matrix,
    damping_ratio_model,
    ema_from_table,
    fit_damping,
    read_modal_table,
    write_modal_table,
)

# A beam that is not the paper's unit-length one, so every l in the formulas matters.
BEAM = {"length": 2.5, "rho_a": 1.7, "second_moment": 3.1e-9}
E_TRUE, GAMMA_TRUE, CD_TRUE = 7.0e10, 0.8, 4.0e4  # Pa, N s/m^2, N s/m^2


def _synthetic(n=7):
    f = natural_frequencies_hz(
        n, EI=E_TRUE * BEAM["second_moment"], rho_a=BEAM["rho_a"], length=BEAM["length"]
    )
    zeta = damping_ratio_model(
        2 * np.pi * f, GAMMA_TRUE, CD_TRUE, E_TRUE, BEAM["second_moment"], BEAM["rho_a"]
    )
    return f, zeta


def test_noise_free_data_give_back_E_gamma_and_cd():
    f, zeta = _synthetic()
    result = ema_from_table(f, zeta, **BEAM)
    # Exact data, exact model: only rounding error (cond(B) ~ 1e4 for 7 modes) remains.
    assert result.E == pytest.approx(E_TRUE, rel=1e-12)
    for row in result.successive:
        assert row.both.gamma == pytest.approx(GAMMA_TRUE, rel=1e-9)
        assert row.both.c_d == pytest.approx(CD_TRUE, rel=1e-9)
        assert row.both.rms_zeta_residual < 1e-15


def test_damping_ratio_model_is_the_dimensionally_correct_eq40():
    omega = np.array([20.0, 400.0, 5000.0])
    zeta = damping_ratio_model(omega, GAMMA_TRUE, CD_TRUE, E_TRUE, 1.0e-9, BEAM["rho_a"])
    expected = GAMMA_TRUE / (2 * BEAM["rho_a"] * omega) + CD_TRUE * omega / (2 * E_TRUE)
    np.testing.assert_allclose(zeta, expected, rtol=1e-14)
    # I cancels: a different second moment gives the same ratios.
    other = damping_ratio_model(omega, GAMMA_TRUE, CD_TRUE, E_TRUE, 5.0e-7, BEAM["rho_a"])
    np.testing.assert_allclose(other, zeta, rtol=1e-14)


def test_single_mechanism_fits_have_their_closed_forms():
    f, zeta = _synthetic(5)
    b = clamped_free_betas(5)
    fits = fit_damping(f, zeta, b, **BEAM)
    z = 4 * np.pi * f * zeta
    beta4 = (b / BEAM["length"]) ** 4
    # One-column least squares: gamma = rho_a mean(z); c_d = rho_a sum(beta^4 z) / (I sum(beta^8)).
    assert fits["viscous_only"].gamma == pytest.approx(BEAM["rho_a"] * z.mean(), rel=1e-13)
    expected_cd = BEAM["rho_a"] * np.sum(beta4 * z) / (BEAM["second_moment"] * np.sum(beta4**2))
    assert fits["strain_only"].c_d == pytest.approx(expected_cd, rel=1e-13)
    assert fits["viscous_only"].c_d is None and fits["strain_only"].gamma is None


def test_weighting_uses_the_propagated_sd_of_z():
    f, zeta = _synthetic(5)
    b = clamped_free_betas(5)
    rng = np.random.default_rng(1)
    noisy = zeta * (1 + 0.05 * rng.standard_normal(5))
    # sd_zeta proportional to 1/omega makes sd_z = 2 omega sd_zeta equal for all modes:
    # the weighted fit must then equal the unweighted one.
    flat = fit_damping(f, noisy, b, sd=1e-3 / f, **BEAM)["both"]
    plain = fit_damping(f, noisy, b, **BEAM)["both"]
    assert flat.gamma == pytest.approx(plain.gamma, rel=1e-12)
    # A mode with a huge sd is effectively ignored: same as fitting without it.
    sd = np.full(5, 1e-4)
    sd[2] = 1e6
    weighted = fit_damping(f, noisy, b, sd=sd, **BEAM)["both"]
    keep = [0, 1, 3, 4]
    dropped = fit_damping(f[keep], noisy[keep], b[keep], sd=sd[keep], **BEAM)["both"]
    assert weighted.c_d == pytest.approx(dropped.c_d, rel=1e-9)


def test_design_matrix_scales_beta_with_length():
    B = damping_design_matrix([2.0], length=2.0, rho_a=2.0, second_moment=3.0)
    np.testing.assert_allclose(B, [[0.5, 1.5]])  # beta = 1/m, so [1, 1 * 3] / 2


def test_result_serialises_with_the_agreed_keys():
    f, zeta = _synthetic(4)
    d = ema_from_table(f, zeta, **BEAM).to_dict()
    json.dumps(d)  # plain types only
    assert d["E"] == pytest.approx(E_TRUE)
    assert [row["modes"] for row in d["successive"]] == [[1, 2], [1, 2, 3], [1, 2, 3, 4]]
    first = d["successive"][0]
    assert set(first["viscous_only"]) == {"gamma", "rms_zeta_residual"}
    assert set(first["strain_only"]) == {"c_d", "rms_zeta_residual"}
    assert set(first["both"]) == {"gamma", "c_d", "rms_zeta_residual"}


def test_modes_out_of_order_and_not_starting_at_one():
    f, zeta = _synthetic(6)
    idx = [4, 1, 3, 2, 5]  # modes 5, 2, 4, 3, 6
    result = ema_from_table(f[idx], zeta[idx], modes=np.array(idx) + 1, **BEAM)
    assert result.modes == [2, 3, 4, 5, 6]
    assert result.successive[-1].both.c_d == pytest.approx(CD_TRUE, rel=1e-9)


def test_modal_table_round_trip(tmp_path):
    table = ModalTable((1, 2, 3), (3.64, 22.8, 65.3), (0.00186, 0.00218, 0.00227), (1e-4, 1.5e-4, 1.6e-4))
    path = tmp_path / "modes.csv"
    write_modal_table(path, table)
    assert path.read_text().splitlines()[0] == "mode,frequency_hz,damping_ratio,damping_ratio_sd"
    assert read_modal_table(path) == table
    bare = ModalTable((1, 2), (3.64, 22.8), (0.00186, 0.00218))
    write_modal_table(path, bare)
    assert read_modal_table(path) == bare


@pytest.mark.parametrize(
    "text, line, fragment",
    [
        ("mode,frequency_hz\n1,3.6\n", 1, "lacks ['damping_ratio']"),
        ("mode,frequency_hz,damping_ratio\n1,3.64,0.002\n2,22.8,0.218%\n", 3, "not a number"),
        ("mode,frequency_hz,damping_ratio\n1,3.64,0.002\n2,22.8,2.18\n", 3, "percentage"),
        ("mode,frequency_hz,damping_ratio\n1,abc,0.002\n", 2, "not a number"),
        ("mode,frequency_hz,damping_ratio\n1,nan,0.002\n", 2, "finite"),
        ("mode,frequency_hz,damping_ratio\n1,3.6,0.002\n1,22.8,0.002\n", 3, "already given on line 2"),
        ("mode,frequency_hz,damping_ratio\n0,3.6,0.002\n", 2, "positive integer"),
        ("mode,frequency_hz,damping_ratio\n1,3.6\n", 2, "2 cells for 3 columns"),
        ("mode,frequency_hz,damping_ratio,damping_ratio_sd\n1,3.6,0.002,-1\n", 2, "not positive"),
        ("mode,frequency_hz,damping_ratio\n", 2, "no modes"),
    ],
)
def test_bad_modal_tables_name_file_line_and_fix(tmp_path, text, line, fragment):
    path = tmp_path / "bad.csv"
    path.write_text(text)
    with pytest.raises(ValueError) as err:
        read_modal_table(path)
    message = str(err.value)
    assert str(path) in message and f"line {line}" in message and "Fix:" in message
    assert fragment in message
