"""Files of the modal baseline: ``bayesbeam ema`` and ``bayesbeam era`` outputs.

Every file is written under a temporary name in its directory and renamed into place, so a
reader never sees half a file. Units are SI throughout: E in Pa, gamma and c_d in N s/m^2,
frequencies in Hz, damping ratios as fractions.
"""

from __future__ import annotations

import csv
import io
from pathlib import Path

import numpy as np

from bayesbeam.io.atomic import atomic_write, write_text
from bayesbeam.io.provenance import write_json
from bayesbeam.modal.ema import (
    EmaResult,
    ModalTable,
    damping_ratio_model,
    write_modal_table,
)

__all__ = [
    "EMA_UNITS",
    "ema_document",
    "era_document",
    "plot_successive",
    "table4_rows",
    "write_ema_outputs",
    "write_era_outputs",
]

EMA_UNITS = {"E": "Pa", "gamma": "N s/m^2", "c_d": "N s/m^2", "rms_zeta_residual": "1 (damping ratio)"}
_TABLE4_COLUMNS = (
    "modes", "n_modes", "viscous_only_gamma", "viscous_only_rms_zeta", "strain_only_c_d",
    "strain_only_rms_zeta", "both_gamma", "both_c_d", "both_rms_zeta",
)


def _save_figure(fig, path: Path) -> Path:
    import matplotlib.pyplot as plt

    try:
        return atomic_write(path, lambda p: fig.savefig(p, format="png", dpi=120))
    finally:
        plt.close(fig)


# --------------------------------------------------------------------------- ema


def ema_document(result: EmaResult, *, table_file, beam_file, length, rho_a, second_moment) -> dict:
    """``ema.json``: the result (E, successive fits) plus units and the inputs used."""
    return {
        **result.to_dict(),
        "units": EMA_UNITS,
        "inputs": {
            "modal_table": str(table_file), "beam": str(beam_file), "length_m": length,
            "rho_a_kg_per_m": rho_a, "second_moment_m4": second_moment,
        },
        "method": "Banks & Inman (1989) eqs. (27)-(29), exact clamped-free eigenvalues, successive mode sets",
    }


def table4_rows(result: EmaResult) -> list[list]:
    """Table-4-style rows: mode set, then each model's coefficients and rms zeta misfit."""
    rows = []
    for fit in result.successive:
        rows.append([
            " ".join(map(str, fit.modes)), len(fit.modes),
            fit.viscous_only.gamma, fit.viscous_only.rms_zeta_residual,
            fit.strain_only.c_d, fit.strain_only.rms_zeta_residual,
            fit.both.gamma, fit.both.c_d, fit.both.rms_zeta_residual,
        ])
    return rows


def _table4_csv(result: EmaResult) -> str:
    stream = io.StringIO()
    writer = csv.writer(stream, lineterminator="\n")
    writer.writerow(_TABLE4_COLUMNS)
    writer.writerows([[v if isinstance(v, (str, int)) else repr(v) for v in row] for row in table4_rows(result)])
    return stream.getvalue()


def plot_successive(result: EmaResult, table: ModalTable, *, second_moment: float, rho_a: float):
    """Three panels: gamma and c_d against the number of modes used; zeta against f.

    The last panel shows the measured damping ratios and the damping ratio of the "both"
    fit to all modes, ``zeta = gamma / (2 rho_a w) + c_d w / (2 E)`` (corrected eq. 40).
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    n = [len(fit.modes) for fit in result.successive]
    fig, axes = plt.subplots(1, 3, figsize=(13, 4), constrained_layout=True)
    pick = {"viscous only": lambda f: f.viscous_only, "both": lambda f: f.both, "strain only": lambda f: f.strain_only}
    for name in ("viscous only", "both"):
        axes[0].plot(n, [pick[name](f).gamma for f in result.successive], "o-", label=name)
    for name in ("strain only", "both"):
        axes[1].plot(n, [pick[name](f).c_d for f in result.successive], "o-", label=name)
    if all(f.both.c_d > 0 for f in result.successive):
        axes[1].set_yscale("log")
    axes[0].set(xlabel="modes used (lowest K)", ylabel="gamma (N s/m^2)")
    axes[1].set(xlabel="modes used (lowest K)", ylabel="c_d (N s/m^2)")
    _plot_zeta(axes[2], result, table, second_moment, rho_a)
    for ax in axes:
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    fig.suptitle("Successive least-squares damping coefficients (Banks & Inman 1989, Table 4)")
    return fig


def _plot_zeta(ax, result, table, second_moment, rho_a):
    f = np.asarray(table.frequency_hz)
    ax.plot(f, 100 * np.asarray(table.damping_ratio), "ko", label="measured")
    both = result.successive[-1].both
    grid = np.geomspace(f.min() / 1.5, f.max() * 1.5, 200)
    fitted = damping_ratio_model(2 * np.pi * grid, both.gamma, both.c_d, result.E, second_moment, rho_a)
    ax.plot(grid, 100 * fitted, "-", label=f"both, modes {result.modes[0]}-{result.modes[-1]}")
    ax.set(xscale="log", xlabel="frequency (Hz)", ylabel="damping ratio (%)")


def write_ema_outputs(out_dir, result: EmaResult, table: ModalTable, document: dict, *,
                      second_moment: float, rho_a: float) -> list[Path]:
    """``ema.json``, ``table4.csv`` and ``ema.png`` in ``out_dir`` (created if needed)."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    return [
        write_json(document, out / "ema.json"),
        write_text(out / "table4.csv", _table4_csv(result)),
        _save_figure(plot_successive(result, table, second_moment=second_moment, rho_a=rho_a), out / "ema.png"),
    ]


# --------------------------------------------------------------------------- era


def era_document(modes, rec) -> dict:
    """``era.json``: settings, the modes with their shapes at the sensors, and what was left out."""
    shapes = [
        [{"sensor": s.name, "re": float(v.real), "im": float(v.imag)} for s, v in zip(rec.sensors, modes.shapes[:, k])]
        for k in range(len(modes.modes))
    ]
    return {
        "recording": str(rec.source),
        "segment_s": list(modes.segment),
        "order": modes.order,
        "n_rows": modes.n_rows,
        "max_frequency_hz": modes.max_frequency_hz,
        "channel_scaling": "each channel divided by its RMS over the segment",
        "sensors": [{"name": s.name, "location_m": s.location, "quantity": s.quantity} for s in rec.sensors],
        "shape_convention": "displacement at the sensors (channel / s^q), largest component 1",
        "modes": [
            {"mode": m, "frequency_hz": float(f), "damping_ratio": float(z), "emac": float(e), "mpc": float(p),
             "shape": shape}
            for m, f, z, e, p, shape in zip(modes.modes, modes.frequencies_hz, modes.damping_ratios,
                                            modes.emac, modes.mpc, shapes)
        ],
        "nominal_frequencies_hz": [float(f) for f in modes.nominal_hz],
        "missing_modes": list(modes.missing),
        "unassigned_poles": modes.unassigned,
    }


def write_era_outputs(out_dir, modes, rec) -> list[Path]:
    """``modal.csv``, ``era.json`` and ``stabilization.png`` (of ``modes.diagram``) in ``out_dir``."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from bayesbeam.modal.era import plot_stabilization

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    fig, ax = plt.subplots(figsize=(8, 5), constrained_layout=True)
    plot_stabilization(modes.diagram, ax)
    for f in modes.frequencies_hz:
        ax.axvline(f, color="tab:blue", lw=0.6, alpha=0.5)
    ax.set_xlim(0, modes.max_frequency_hz)
    ax.set_title(f"{Path(str(rec.source)).name}: ERA stabilization (lines: modes kept at order {modes.order})", fontsize=9)
    return [
        atomic_write(out / "modal.csv", lambda p: write_modal_table(p, modes.table())),
        write_json(era_document(modes, rec), out / "era.json"),
        _save_figure(fig, out / "stabilization.png"),
    ]
