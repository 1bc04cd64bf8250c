"""The quick-look figure of ``bayesbeam check``: what a recording holds, at a glance.

Left: the time history of every channel (the force first, with its hits and spikes marked; the
analysed segment shaded). Right: each sensor's spectral density with the nominal clamped-free
frequencies, the mains lines found and the suggested top of the fitted band marked.
"""
from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np

from bayesbeam.report.plots import COLORS, SIGNAL_UNITS, save


def quicklook_figure(rec, found):
    """The figure for recording ``rec`` and its :class:`~bayesbeam.checks.survey.Survey` ``found``."""
    channels = ([("force", rec.force, "N")] if rec.force is not None else []) + [
        (s.name, rec.signals[:, j], SIGNAL_UNITS[s.quantity]) for j, s in enumerate(rec.sensors)]
    rows = len(channels)
    fig, axes = plt.subplots(rows, 2, figsize=(12, 2.4 * rows + 0.6), squeeze=False,
                             gridspec_kw={"width_ratios": [1.2, 1]})
    for row, (name, x, unit) in enumerate(channels):
        _time_panel(axes[row, 0], rec, found, name, x, unit, COLORS[row % len(COLORS)])
        if name in found.spectra:
            _spectrum_panel(axes[row, 1], found, name, unit, COLORS[row % len(COLORS)])
        else:
            _pulse_panel(axes[row, 1], rec, found)
    axes[-1, 0].set_xlabel("time (s)")
    axes[-1, 1].set_xlabel("frequency (Hz)")
    fig.suptitle(f"bayesbeam check: {rec.source.name if rec.source else 'recording'}")
    fig.tight_layout()
    return fig


def save_quicklook(rec, found, path):
    """Draw :func:`quicklook_figure` and write it to ``path`` atomically."""
    return save(quicklook_figure(rec, found), path)


def _time_panel(ax, rec, found, name, x, unit, color):
    ax.plot(rec.time, x, color=color, lw=0.6)
    i0 = found.segment[0]
    if i0 > 0:
        ax.axvspan(rec.time[0], rec.time[i0], color="0.9", lw=0, label="not analysed")
    force = found.summary["force"]
    if name == "force" and force:
        for p in force["pulses"]:
            marker = "v" if p["kind"] == "hit" else "x"
            ax.plot(p["time_s"], p["peak_N"], marker, color="k", ms=6, label=p["kind"])
        handles, labels = ax.get_legend_handles_labels()
        unique = dict(zip(labels, handles))
        ax.legend(unique.values(), unique.keys(), fontsize=7, loc="upper right")
    ax.set_ylabel(f"{name} ({unit})")


def _spectrum_panel(ax, found, name, unit, color):
    spectrum = found.spectra[name]
    keep = spectrum.frequency > 0
    ax.semilogy(spectrum.frequency[keep], spectrum.density[keep], color=color, lw=0.6)
    summary = found.summary
    for i, f in enumerate(summary["nominal_frequencies_hz"]):
        ax.axvline(f, color="0.4", ls="--", lw=0.7, label="nominal modes" if i == 0 else None)
    for i, f in enumerate(summary["mains_lines"]):
        ax.axvline(f, color="C3", ls=":", lw=1.0, label="mains line" if i == 0 else None)
    ax.axvline(summary["suggested"]["max_frequency_hz"], color="k", lw=1.0, label="suggested --max-frequency")
    ax.set_ylabel(f"PSD ({unit})^2/Hz")
    ax.legend(fontsize=7, loc="upper right")


def _pulse_panel(ax, rec, found):
    """Beside the force: the main hit close up, with the pulse threshold."""
    force = found.summary["force"]
    main = min(force["pulses"], key=lambda p: abs(p["after_impact_s"]))
    near = np.abs(rec.time - main["time_s"]) < 0.02
    ax.plot(1e3 * (rec.time[near] - main["time_s"]), rec.force[near], ".-", color="C0", lw=0.8)
    for sign in (1, -1):
        ax.axhline(sign * force["threshold_N"], color="0.5", ls="--", lw=0.7)
    ax.set_title("main hit (ms from its peak); dashed: pulse threshold", fontsize=8)
    ax.set_ylabel("force (N)")
