r"""The paper's experimental-modal-analysis (EMA) route to E, gamma and c_d.

Banks & Inman (1989), section V. For the uniform clamped-free beam without tip body,
viscous (air) damping ``gamma`` and Kelvin-Voigt (strain-rate) damping ``c_d``
commute with the stiffness operator, and each mode obeys (eq. 23)

    a_m'' + (gamma / rho_a + c_d I beta_m^4 / rho_a) a_m' + (EI / rho_a) beta_m^4 a_m = f_m.

Matching with the single-degree-of-freedom form ``a'' + 2 zeta w a' + w^2 a = f``:

    (25)  beta_m^4 EI / rho_a = w_m^2,
    (26)  gamma / rho_a + c_d I beta_m^4 / rho_a = 2 zeta_m w_m = z_m.

Here ``beta_m = b_m / l`` with ``b_m`` the dimensionless root ``beta l`` (Table 2);
the paper takes l = 1 m so the two coincide. Units: w in rad/s, rho_a = rho A in kg/m,
I in m^4, E in Pa, gamma in N s/m^2, c_d in N s/m^2 (so c_d I is in N m^2 s).

Eq. (27) averages the per-mode solutions of (25) for E; eqs. (28)-(29) solve (26) for
``[gamma, c_d]`` in the least-squares sense, ``B [gamma, c_d]^T = z`` with rows
``B_m = [1, beta_m^4 I] / rho_a``. Table 4 of the paper repeats that fit for the mode
sets 1-2, 1-3, ..., 1-K with gamma alone, c_d alone and both.
"""

from __future__ import annotations

import csv
import math
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

from bayesbeam.modal.eigen import clamped_free_betas

__all__ = [
    "DampingFit",
    "EmaResult",
    "ModalTable",
    "SuccessiveFit",
    "damping_design_matrix",
    "damping_ratio_model",
    "ema_from_table",
    "fit_damping",
    "modulus_from_frequencies",
    "read_modal_table",
    "write_modal_table",
]

_COLUMNS = ("mode", "frequency_hz", "damping_ratio")
_SD_COLUMN = "damping_ratio_sd"


@dataclass(frozen=True)
class ModalTable:
    """Measured modal data: mode numbers (1 = first bending mode), f in Hz, zeta as a fraction."""

    modes: tuple[int, ...]
    frequency_hz: tuple[float, ...]
    damping_ratio: tuple[float, ...]
    damping_ratio_sd: tuple[float, ...] | None = None


@dataclass(frozen=True)
class DampingFit:
    """Least-squares damping coefficients for one mode set (None = not in that model).

    ``gamma`` in N s/m^2, ``c_d`` in N s/m^2; ``rms_zeta_residual`` is the rms misfit of
    the damping ratios the fit predicts (dimensionless).
    """

    gamma: float | None
    c_d: float | None
    rms_zeta_residual: float


@dataclass(frozen=True)
class SuccessiveFit:
    """Table-4 row: the three damping models fitted to one set of modes."""

    modes: list[int]
    viscous_only: DampingFit
    strain_only: DampingFit
    both: DampingFit


@dataclass(frozen=True)
class EmaResult:
    """E (Pa) from eq. (27) and the successive damping fits; ``to_dict`` serialises it."""

    E: float
    E_per_mode: list[float]
    E_sd: float
    modes: list[int]
    weighted: bool
    successive: list[SuccessiveFit] = field(default_factory=list)

    def to_dict(self) -> dict:
        """Plain dict in SI units; models absent from a fit drop their None entries."""
        out = asdict(self)
        for row in out["successive"]:
            for key in ("viscous_only", "strain_only", "both"):
                row[key] = {k: v for k, v in row[key].items() if v is not None}
        return out


def modulus_from_frequencies(frequencies_hz, betas_l, *, length, rho_a, second_moment):
    """Eq. (27): ``E = (1/K) sum_m 4 pi^2 rho_a f_m^2 / (I beta_m^4)``.

    Returns ``(E, E_per_mode)`` in Pa, where ``E_per_mode`` solves (25) mode by mode and
    ``beta_m = b_m / length``. The mean of the per-mode values is what eq. (27) prints;
    it weighs every mode equally, unlike a least-squares fit of w^2 against beta^4,
    which the highest mode would dominate.
    """
    f, b = np.asarray(frequencies_hz, float), np.asarray(betas_l, float)
    per_mode = 4 * np.pi**2 * rho_a * f**2 / (second_moment * (b / length) ** 4)
    return float(per_mode.mean()), per_mode


def damping_design_matrix(betas_l, *, length, rho_a, second_moment):
    """Eq. (29): rows ``[1, beta_m^4 I] / rho_a`` with ``beta_m = b_m / length``.

    Column 0 multiplies gamma (N s/m^2), column 1 multiplies c_d (N s/m^2); the product
    is ``z_m = 2 zeta_m w_m`` in 1/s.
    """
    beta4 = (np.asarray(betas_l, float) / length) ** 4
    return np.column_stack([np.ones_like(beta4), beta4 * second_moment]) / rho_a


def _lstsq_fit(B, z, weights, zeta_scale, columns):
    """Weighted least squares on the chosen columns; returns (coefficients, rms zeta misfit)."""
    Bc = B[:, columns]
    coef = np.linalg.lstsq(Bc * weights[:, None], z * weights, rcond=None)[0]
    rms = float(np.sqrt(np.mean(((Bc @ coef - z) / zeta_scale) ** 2)))
    return coef, rms


def fit_damping(frequencies_hz, damping_ratios, betas_l, *, length, rho_a, second_moment, sd=None):
    """Eq. (28) for one mode set: viscous only, strain only and both.

    ``z_m = 2 zeta_m w_m`` with ``w_m = 2 pi f_m`` the *measured* frequency (this is what
    reproduces the paper's Table 4, see studies/paper_reproduction).

    Weighting: if ``sd`` (standard deviations of the damping ratios, fractions) is given,
    each row of ``B x = z`` is divided by ``sd_z,m = 2 w_m sd_zeta,m`` -- first-order
    propagation of the zeta scatter into z with the frequency taken as exact, because
    measured frequencies scatter far less (relatively) than damping ratios. This is the
    maximum-likelihood fit for independent Gaussian errors in zeta. Without ``sd`` all
    rows count equally in z, as the paper's generalized inverse does.
    """
    f, zeta = np.asarray(frequencies_hz, float), np.asarray(damping_ratios, float)
    omega = 2 * np.pi * f
    z = 2 * zeta * omega
    B = damping_design_matrix(betas_l, length=length, rho_a=rho_a, second_moment=second_moment)
    weights = np.ones_like(z) if sd is None else 1.0 / (2 * omega * np.asarray(sd, float))
    fits = {}
    for name, columns in (("viscous_only", [0]), ("strain_only", [1]), ("both", [0, 1])):
        coef, rms = _lstsq_fit(B, z, weights, 2 * omega, columns)
        values = dict(zip(columns, coef))
        fits[name] = DampingFit(
            gamma=float(values[0]) if 0 in values else None,
            c_d=float(values[1]) if 1 in values else None,
            rms_zeta_residual=rms,
        )
    return fits


def damping_ratio_model(omega, gamma, c_d, E, I, rho_a):
    r"""Modal damping ratio of mode with circular frequency ``omega`` (rad/s).

    Derivation (replaces the paper's eq. 40, which is dimensionally wrong as printed):
    from (25), ``beta_m^4 = rho_a w_m^2 / (E I)``; put into (26),

        2 zeta_m w_m = gamma / rho_a + (c_d I / rho_a) rho_a w_m^2 / (E I)
                     = gamma / rho_a + c_d w_m^2 / E,

    so

        zeta_m = gamma / (2 rho_a w_m) + c_d w_m / (2 E).

    Both terms are dimensionless: [N s/m^2] / ([kg/m] [1/s]) and [Pa s] [1/s] / [Pa].
    The printed (40), ``gamma / (2 w) + c_d w / (2 E^2 I)``, drops rho_a in the first term
    (numerically harmless there, rho_a = 1.02 kg/m) and has E^2 I in place of E in the
    second (units 1/(Pa m^4), off by a factor E I = 44 N m^2 for the paper's beam).
    The air term falls as 1/w, the strain-rate term grows as w.

    Computed as eq. (26) with beta^4 from eq. (25), so ``I`` cancels exactly.
    """
    omega = np.asarray(omega, float)
    beta4 = rho_a * omega**2 / (E * I)
    return (gamma + c_d * I * beta4) / (2 * rho_a * omega)


def ema_from_table(
    frequencies_hz,
    damping_ratios,
    *,
    length: float,
    rho_a: float,
    second_moment: float,
    sd=None,
    modes=None,
    betas_l=None,
) -> EmaResult:
    """E by eq. (27) and the successive damping fits of Table 4, from a modal table.

    Parameters
    ----------
    frequencies_hz, damping_ratios : sequences of length K
        Measured natural frequencies (Hz) and damping ratios (fractions, not %).
    length, rho_a, second_moment : float
        Beam length l (m), mass per unit length rho A (kg/m), second moment I (m^4).
    sd : sequence, optional
        Standard deviations of the damping ratios (fractions); if given, the damping
        fits are weighted (see ``fit_damping``). E is never weighted.
    modes : sequence of int, optional
        Mode numbers (1 = first bending mode); default 1..K. They pick the eigenvalues.
    betas_l : sequence, optional
        Dimensionless eigenvalues ``beta l`` for these modes; default: the exact
        clamped-free roots. Pass Table 2's 3-decimal values to mimic the paper.

    The successive fits use the first 2, 3, ..., K modes in ascending mode order.
    """
    f, zeta = np.asarray(frequencies_hz, float), np.asarray(damping_ratios, float)
    modes = np.arange(1, len(f) + 1) if modes is None else np.asarray(modes, int)
    if not (len(f) == len(zeta) == len(modes)) or len(f) < 2:
        raise ValueError("need at least two modes with one frequency, damping ratio and mode number each")
    if sd is not None and len(sd) != len(f):
        raise ValueError("sd must give one standard deviation per mode")
    order = np.argsort(modes)
    if betas_l is None:
        betas_l = clamped_free_betas(int(modes.max()))[modes - 1]
    betas_l = np.asarray(betas_l, float)
    if len(betas_l) != len(f):
        raise ValueError("betas_l must give one eigenvalue per mode")
    f, zeta, modes, betas_l = f[order], zeta[order], modes[order], betas_l[order]
    sd = None if sd is None else np.asarray(sd, float)[order]
    beam = {"length": length, "rho_a": rho_a, "second_moment": second_moment}
    E, per_mode = modulus_from_frequencies(f, betas_l, **beam)
    rows = []
    for k in range(2, len(f) + 1):
        fits = fit_damping(f[:k], zeta[:k], betas_l[:k], sd=None if sd is None else sd[:k], **beam)
        rows.append(SuccessiveFit(modes=[int(m) for m in modes[:k]], **fits))
    return EmaResult(
        E=E,
        E_per_mode=[float(e) for e in per_mode],
        E_sd=float(per_mode.std(ddof=1)),
        modes=[int(m) for m in modes],
        weighted=sd is not None,
        successive=rows,
    )


# --------------------------------------------------------------------------- modal-table CSV


def _fail(path, line, problem, fix):
    raise ValueError(f"{path}, line {line}: {problem}. Fix: {fix}.")


def _number(path, line, column, text):
    try:
        value = float(text)
    except ValueError:
        _fail(path, line, f"column '{column}' holds {text!r}, not a number", "write a plain decimal number")
    if not math.isfinite(value):
        _fail(path, line, f"column '{column}' is {text!r}", "replace it with a finite measured value")
    return value


def _check_header(path, header):
    if header is None:
        _fail(path, 1, "the file is empty", f"start with the header line '{','.join(_COLUMNS)}'")
    names = [h.strip() for h in header]
    missing = [c for c in _COLUMNS if c not in names]
    unknown = [c for c in names if c not in (*_COLUMNS, _SD_COLUMN)]
    if missing or unknown:
        _fail(
            path,
            1,
            f"header {names} lacks {missing} or has unknown columns {unknown}",
            f"use the columns {','.join(_COLUMNS)}[,{_SD_COLUMN}]",
        )
    return names


def _parse_row(path, line, names, cells):
    if len(cells) != len(names):
        _fail(path, line, f"{len(cells)} cells for {len(names)} columns", "give one value per column")
    row = dict(zip(names, (c.strip() for c in cells)))
    if not row["mode"].isdigit() or int(row["mode"]) < 1:
        _fail(path, line, f"mode {row['mode']!r} is not a positive integer", "number modes 1, 2, 3, ...")
    f = _number(path, line, "frequency_hz", row["frequency_hz"])
    zeta = _number(path, line, "damping_ratio", row["damping_ratio"])
    if f <= 0:
        _fail(path, line, f"frequency {f} Hz is not positive", "give the natural frequency in Hz")
    if not 0 < zeta < 1:
        hint = (
            "it looks like a percentage: divide by 100"
            if 1 <= zeta < 100
            else "give zeta as a fraction in (0, 1)"
        )
        _fail(path, line, f"damping ratio {zeta} is outside (0, 1)", hint)
    sd = None
    if _SD_COLUMN in row:
        sd = _number(path, line, _SD_COLUMN, row[_SD_COLUMN])
        if sd <= 0:
            _fail(
                path,
                line,
                f"standard deviation {sd} is not positive",
                "give the sd of zeta as a positive fraction",
            )
    return int(row["mode"]), f, zeta, sd


def read_modal_table(path) -> ModalTable:
    """Read ``mode,frequency_hz,damping_ratio[,damping_ratio_sd]`` (zeta and sd as fractions).

    Raises ``ValueError`` naming the file, the line and the fix for: a missing or wrong
    header, a wrong number of cells, non-numeric/NaN/infinite values, a non-positive
    frequency or sd, a damping ratio outside (0, 1) (with a hint when it looks like a
    percentage), repeated mode numbers, and a table with no rows.
    """
    path = Path(path)
    with path.open(newline="") as fh:
        reader = csv.reader(fh)
        names = _check_header(path, next(reader, None))
        rows, seen = [], {}
        for cells in reader:
            if not any(c.strip() for c in cells):
                continue
            line = reader.line_num
            row = _parse_row(path, line, names, cells)
            if row[0] in seen:
                _fail(
                    path, line, f"mode {row[0]} already given on line {seen[row[0]]}", "keep one row per mode"
                )
            seen[row[0]] = line
            rows.append(row)
    if not rows:
        _fail(path, 2, "the table has a header but no modes", "add one row per measured mode")
    modes, f, zeta, sd = zip(*sorted(rows))
    return ModalTable(modes, f, zeta, None if _SD_COLUMN not in names else sd)


def write_modal_table(path, table: ModalTable) -> None:
    """Write a ``ModalTable`` in the format ``read_modal_table`` reads (full float precision)."""
    with_sd = table.damping_ratio_sd is not None
    with Path(path).open("w", newline="") as fh:
        writer = csv.writer(fh, lineterminator="\n")
        writer.writerow([*_COLUMNS, _SD_COLUMN] if with_sd else _COLUMNS)
        for k, mode in enumerate(table.modes):
            row = [mode, repr(float(table.frequency_hz[k])), repr(float(table.damping_ratio[k]))]
            if with_sd:
                row.append(repr(float(table.damping_ratio_sd[k])))
            writer.writerow(row)
