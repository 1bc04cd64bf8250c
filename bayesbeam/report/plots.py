"""Figures of a fit: corner, trace and the measured signal against the posterior predictive.

Every function takes plain arrays or a FitResult and returns the matplotlib Figure; ``save``
writes it atomically (temporary file, then rename).
"""
from __future__ import annotations

import io
from pathlib import Path

import corner
import matplotlib
import matplotlib.pyplot as plt
import matplotlib.ticker
import numpy as np

from bayesbeam.io.atomic import atomic_write

#: 2-D contour levels of the corner plots: the probability mass inside 1 and 2 "sigma"
#: for a 2-D Gaussian, 1 - exp(-k^2/2) for k = 1, 2
CORNER_LEVELS = (1 - np.exp(-0.5), 1 - np.exp(-2.0))
COLORS = ("C0", "C3", "C2", "C1", "C4", "C5")
#: how every figure is rendered, to a file or for embedding in a report
SAVEFIG = {"dpi": 110, "bbox_inches": "tight"}
#: SI unit of each sensor quantity
SIGNAL_UNITS = {"acceleration": "m/s^2", "velocity": "m/s", "displacement": "m"}


def save(fig, path) -> Path:
    """Write ``fig`` to ``path`` atomically and close it."""
    path = Path(path)
    try:
        return atomic_write(path, lambda p: fig.savefig(p, format=path.suffix.lstrip("."), **SAVEFIG))
    finally:
        plt.close(fig)


def png_bytes(fig) -> bytes:
    """``fig`` as PNG bytes (rendered as by ``save``), then closed."""
    buffer = io.BytesIO()
    fig.savefig(buffer, format="png", **SAVEFIG)
    plt.close(fig)
    return buffer.getvalue()


def _label(name: str, unit: str | None) -> str:
    return f"{name} [{unit}]" if unit and unit != "1" else name


def signal_label(sensor) -> str:
    """Axis label of a sensor's signal: its name and SI unit."""
    return f"{sensor.name} [{SIGNAL_UNITS[sensor.quantity]}]"


def predictive_columns(axes, t, y, lo, med, hi, windows, band_label="posterior predictive 90%"):
    """Measured vs predictive median and 90% band (top row), residual (bottom row), per window.

    ``axes``: (2, len(windows)); ``windows``: (sample slice, title) per column.
    """
    for col, (s, name) in enumerate(windows):
        ax = axes[0, col]
        ax.fill_between(t[s], lo[s], hi[s], color="C1", alpha=0.35, lw=0, label=band_label)
        ax.plot(t[s], y[s], color="k", lw=0.8, label="measured")
        ax.plot(t[s], med[s], color="C1", lw=0.8, ls="--", label="predictive median")
        ax.set_title(name, fontsize=9)
        axes[1, col].plot(t[s], y[s] - med[s], color="C3", lw=0.6)
        axes[1, col].axhline(0, color="k", lw=0.5)
        axes[1, col].set_xlabel("time [s]")
    axes[1, 0].set_ylabel("residual")
    axes[0, 0].legend(fontsize=8, loc="upper right")


def corner_overlay(samples: list[np.ndarray], names: list[str], labels: list[str], *,
                   units: dict | None = None, truths: dict | None = None, title: str = ""):
    """Corner plot of one or several posteriors over the same parameters (physical values).

    ``samples``: one (n_draws, len(names)) array per model; ``labels``: the legend entries.
    """
    units = units or {}
    fig = None
    ranges = _common_ranges(samples)
    for i, (draws, label) in enumerate(zip(samples, labels)):
        fig = corner.corner(draws, fig=fig, labels=[_label(n, units.get(n)) for n in names],
                            levels=CORNER_LEVELS, color=COLORS[i % len(COLORS)], range=ranges,
                            plot_datapoints=False, plot_density=False, fill_contours=False,
                            smooth=1.0, hist_kwargs={"density": True},
                            truths=[truths.get(n) for n in names] if truths and i == 0 else None,
                            truth_color="k", label_kwargs={"fontsize": 9}, max_n_ticks=3)
    for ax in fig.axes:
        plain_ticks(ax)
    handles = [plt.Line2D([], [], color=COLORS[i % len(COLORS)], label=lab) for i, lab in enumerate(labels)]
    if truths:
        handles.append(plt.Line2D([], [], color="k", label="truth"))
    fig.legend(handles=handles, loc="upper right", frameon=False)
    caption = ("contours enclose 39% and 86% of the posterior mass (the 1- and 2-sigma levels of a "
               "2-D Gaussian); diagonal: marginal densities")
    fig.suptitle(f"{title}\n{caption}" if title else caption, fontsize=9, y=1.02)
    return fig


def plain_ticks(ax) -> None:
    """Tick labels of ``ax`` written out in full, to as many significant digits as write its ticks
    exactly, so matplotlib draws no offset or multiplier text ("+4.428e1") beside the axis, where a
    corner plot's axis label sits over it."""
    for axis in (ax.xaxis, ax.yaxis):
        if not isinstance(axis.get_major_formatter(), matplotlib.ticker.ScalarFormatter):
            continue                   # labels corner hid (inner panels) stay hidden
        ticks = axis.get_ticklocs()
        step = float(np.min(np.diff(ticks))) if len(ticks) > 1 else 1.0
        # the fewest digits that write every tick exactly (to a millionth of the tick spacing)
        digits = next((d for d in range(1, 9) if all(abs(float(f"{t:.{d}g}") - t) <= 1e-6 * step for t in ticks)), 9)
        axis.set_major_formatter(matplotlib.ticker.FuncFormatter(lambda x, _pos, d=digits: f"{x:.{d}g}"))


def _common_ranges(samples):
    stacked = np.concatenate(samples)
    lo, hi = np.quantile(stacked, [0.001, 0.999], axis=0)
    pad = 0.05 * (hi - lo) + 1e-12 * np.abs(hi)
    return [(a - p, b + p) for a, b, p in zip(lo, hi, pad)]


def corner_plot(result, truths: dict | None = None):
    """Corner plot of a fit's model parameters."""
    post = result.problem.posterior
    k = len(post.model_names)
    draws = result.values()[..., :k].reshape(-1, k)
    return corner_overlay([draws], list(post.model_names), [result.summary.get("model", "")],
                          units=result.problem.model.units, truths=truths,
                          title=f"posterior of {result.problem.model.name}")


def trace_plot(result):
    """Walker traces of every parameter after burn-in (and thinning)."""
    post = result.problem.posterior
    values = result.values()
    n = post.ndim
    fig, axes = plt.subplots(n, 1, figsize=(8, 1.5 * n + 0.5), sharex=True)
    axes = np.atleast_1d(axes)
    steps = result.chains.burn + result.chains.thin * np.arange(values.shape[1])
    noise = result.summary["noise"]
    units = {**result.problem.model.units,
             **{n: noise[n]["unit"] for n in result.problem.likelihood.noise_names}}
    for i, ax in enumerate(axes):
        ax.plot(steps, values[:, :, i].T, lw=0.5, alpha=0.5, color="C0")
        ax.set_ylabel(_label(post.names[i], units.get(post.names[i])), fontsize=8)
    status = "converged" if result.converged else "NOT converged"
    axes[0].set_title(f"walker traces after burn-in ({result.chains.burn} steps), thinned by "
                      f"{result.chains.thin}; max tau {np.max(result.chains.tau):.0f} steps; {status}",
                      fontsize=9)
    axes[-1].set_xlabel("step")
    fig.tight_layout()
    return fig


def fit_plot(result, channel: int = 0):
    """Measured signal, posterior-predictive median and 90% band: start, late window, residuals."""
    rec = result.problem.model.recording
    proj = result.problem.likelihood.projection
    replicates = np.asarray(result.idata.posterior_predictive["signals"].values)[0][:, :, channel]
    lo, med, hi = np.quantile(replicates, [0.05, 0.5, 0.95], axis=0)
    t, y = rec.time, rec.signals[:, channel]
    sensor = rec.sensors[channel]
    i0, i1 = proj.i0, proj.i0 + proj.n_blocks * proj.block
    span = max(min(400, (i1 - i0) // 3), 1)  # two distinct zooms: the first and the last span
    windows = [(slice(i0, i0 + span), "start of the fitted window"), (slice(i1 - span, i1), "late window")]
    fig, axes = plt.subplots(2, 2, figsize=(11, 5.5), sharex="col", gridspec_kw={"height_ratios": [3, 1.3]})
    predictive_columns(axes, t, y, lo, med, hi, windows)
    axes[0, 0].set_ylabel(signal_label(sensor))
    fig.suptitle(f"{result.problem.model.name}: measured vs posterior predictive "
                 f"(band 0-{proj.max_frequency:.0f} Hz fitted)", fontsize=10)
    fig.tight_layout()
    return fig
