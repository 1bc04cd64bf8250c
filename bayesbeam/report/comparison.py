"""The model-comparison report: one self-contained HTML file a reviewer reads on a laptop.

Sections, in the order a reader asks the questions: the verdict (which mechanism, how sure) with
the evidence and the cheap screens; damping per mode, measured against each model's predictive
interval (where the paper's argument shows: air damping in low modes, internal damping in high
ones); the time-history fits; residual spectra against the noise level; the posterior predictive
p-values; the posteriors; and the convergence diagnostics that say whether to trust the numbers.

Figures are PNGs embedded as base64 data and the CSS is inline, so the file opens anywhere without
a network (:mod:`bayesbeam.report.html`). A small inline script records on
``<body data-figures-loaded="ok/total">`` how many images decoded, so a headless browser can check
every figure.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from bayesbeam.checks.ppc import LJUNG_BOX_LAGS, PASS_P_VALUE, SPECTRUM_BANDS
from bayesbeam.comparison import EVIDENCE_SD_MAX, R_HAT_MAX, described, strength, unsettled_evidence
from bayesbeam.io.atomic import write_text
from bayesbeam.report.html import esc, figure, flag, h2, nav, number, page, table
from bayesbeam.report.markdown import interval_ends, markdown_table, median_and_interval, resolving_digits, significant

# plt comes from plots, which puts matplotlib on the Agg backend before importing pyplot
from bayesbeam.report.plots import (
    COLORS,
    SIGNAL_UNITS,
    corner_overlay,
    plt,
    predictive_columns,
    signal_label,
)
from bayesbeam.report.truth import recording_truths

#: (anchor, title) of the report's sections, in order
SECTIONS = (("verdict", "Verdict"), ("modes", "Damping per mode"), ("fits", "Time histories"),
            ("spectra", "Residual spectra"), ("checks", "Posterior predictive checks"),
            ("posteriors", "Posteriors"), ("convergence", "Convergence"))
#: why a per-mode cell is empty: the mode is not measured, the model has no interval for it, or
#: the model has no such mode in the fitted band (checks.ppc.mode_table)
NO_MEASUREMENT = "not identified: ERA found no pole near the mode in the recording's free decay"
NO_INTERVAL = "not identified: ERA found the mode in none of the model's replicated recordings"
OUTSIDE_BAND = "outside the band: the model has no such mode below the fitted band's top"
#: the time-history zoom: at most this long (a quarter second shows the impact and the first
#: cycles of the low modes) and at most a fifth of the fitted window
ZOOM_SECONDS = 0.25
#: figure width in inches: 990 px at the 110 dpi of ``plots.SAVEFIG``, within a laptop screen
WIDTH = 9.0
#: corner sizes its figures at 2 in per parameter; 1.5 in still keeps the tick labels apart and
#: fits up to five parameters (q3 with effects) on a laptop screen
CORNER_SHRINK = 0.75

def write_report(results: dict, summary: dict, path) -> Path:
    """Write the report of a comparison (``compare()``'s results and summary) to ``path``, atomically."""
    return write_text(path, render(results, summary))


def render(results: dict, summary: dict) -> str:
    """The report's HTML."""
    colors = model_colors(summary)
    body = [_header(summary),
            _verdict_section(summary),
            _modes_section(summary, colors),
            _fits_section(results, summary),
            _spectra_section(results, summary),
            _checks_section(results, summary),
            _posteriors_section(results, summary),
            _convergence_section(results, summary)]
    return page("bayesbeam model comparison", body)


def model_colors(summary) -> dict:
    """One colour per model, in ranking order (the same in every figure)."""
    return {m: COLORS[i % len(COLORS)] for i, m in enumerate(summary["ranking"])}


# ---------------------------------------------------------------------------- sections
def _header(summary) -> str:
    rec = summary.get("recording") or "(recording given in memory)"
    return (f"<h1>Which damping mechanism? Model comparison</h1><p class=\"meta\">Recording: {esc(rec)}. "
            f"{len(summary['ranking'])} models compared in {summary['seconds']:.0f} s"
            f"{_left_out(summary)}.</p>{nav(SECTIONS)}")


def _left_out(summary) -> str:
    """The header's note of models left out of the comparison (why: in the verdict)."""
    left = summary.get("left_out") or {}
    return f"; left out: {esc(', '.join(left))} (why and the fix: Verdict)" if left else ""


def _verdict_section(summary) -> str:
    caveats = _caveats(summary)
    caveat_html = ("<p>Caveats:</p><ul class=\"caveats\">" + "".join(f"<li>{esc(c)}</li>" for c in caveats)
                   + "</ul>") if caveats else ""
    return (h2("verdict", SECTIONS) + f'<p class="verdict">{esc(summary["verdict"])}</p>' + caveat_html
            + "<h3>Evidence</h3>" + _evidence_table(summary)
            + "<p>log Z: the log marginal likelihood (nats) by sequential Monte Carlo, mean of independent "
              "repeats &plusmn; its standard error. Probabilities assume equal prior probabilities of the "
              "models. Strength: Kass &amp; Raftery (1995) for the best model against each other one.</p>"
            + "<h3>Cheap screens</h3>" + _screens_table(summary)
            + "<p>Each screen approximates what the evidence or a predictive score measures, under the "
              "assumption printed under its name; where they disagree with the SMC evidence, trust the "
              "evidence.</p>")


def _caveats(summary) -> list[str]:
    """What should make a reader less sure, in plain words; the numbers behind each (R-hat, the
    shift with the grid) are in the Convergence section."""
    out = []
    models = summary["models"]
    # one definition of "not settled", compare.py's: the verdict, these caveats and the
    # Convergence section's flags agree
    unconverged = [m for m in summary["ranking"] if unsettled_evidence(models[m])]
    if unconverged:
        out.append(f"The estimates of {', '.join(unconverged)} are not settled: independent runs of the sampler "
                   f"disagree. Rerun with more --particles or --repeats before quoting them closely "
                   f"(details under Convergence).")
    checks = {m: models[m]["discretisation_check"] for m in summary["ranking"]}
    rough = [m for m, c in checks.items() if c.get("stalled")]
    if rough:
        out.append(f"The optima of {', '.join(rough)} move by about as much at each finer beam model as at the "
                   f"one before: not the discretisation's error, which shrinks as the model is refined, but a "
                   f"likelihood with many sharp local maxima; their N was kept (details under Convergence).")
    coarse = [m for m, c in checks.items() if not c["passed"] and not c.get("stalled")]
    if coarse:
        out.append(f"The estimates of {', '.join(coarse)} still move when the beam model is made finer: their "
                   f"last digits depend on the model's resolution; fix a finer one with --n-intervals to check "
                   f"(details under Convergence).")
    best = summary["best"]
    missed = [str(row["mode"]) for row in summary["models"][best]["modes"]
              if _outside(row["measured_damping_ratio"], row["predicted_damping_ratio_90"])]
    if missed:
        out.append(f"The measured damping of mode(s) {', '.join(missed)} is outside what {best} predicts "
                   f"(its 90% interval): {best} does not explain the damping of that mode (Damping per mode).")
    unchecked = [str(row["mode"]) for row in summary["models"][best]["modes"]
                 if row["predicted_damping_ratio_90"] is None or row["measured_damping_ratio"] is None]
    if unchecked:
        out.append(f"The damping of mode(s) {', '.join(unchecked)} is not checked against {best}: ERA did not "
                   f"identify the mode in the recording or in {best}'s replicates (each empty cell under "
                   f"Damping per mode says which).")
    return out


def _evidence_table(summary) -> str:
    models, best = summary["models"], summary["best"]
    rows = []
    for m in summary["ranking"]:
        s = models[m]
        lbf = s["log_bayes_factor_vs_best"]
        sd = np.hypot(s["log_evidence_sd"], models[best]["log_evidence_sd"])
        rows.append([esc(m), esc(described(s)), f"{s['log_evidence']:.2f} &plusmn; {s['log_evidence_sd']:.2f}",
                     "&mdash;" if m == best else f"{lbf:.2f} &plusmn; {sd:.2f}", _probability(s["probability"]),
                     "best" if m == best else esc(strength(-lbf))])
    head = ["model", "mechanisms", "log Z [nats]", "log Bayes factor vs best", "probability",
            "evidence for the best"]
    return table(head, rows, text_columns=2, highlight_first=True)


def _screens_table(summary) -> str:
    models = summary["models"]
    first = models[summary["ranking"][0]]["screens"]
    labels = {"bic": "BIC log Z", "laplace": "Laplace log Z", "psis_lfo": "PSIS-LFO elpd",
              "psis_loo": "PSIS-LOO elpd"}
    head = ["model", "SMC log Z<small>reference: no approximation beyond Monte Carlo error</small>"]
    head += [f"{labels[k]}<small>assumes {esc(first[k]['assumes'])}</small>" for k in labels]
    rows = []
    for m in summary["ranking"]:
        s = models[m]["screens"]
        lfo, loo = s["psis_lfo"], s["psis_loo"]
        rows.append([esc(m), f"{models[m]['log_evidence']:.1f}", number(s["bic"]["log_evidence"], ".1f"),
                     number(s["laplace"]["log_evidence"], ".1f"),
                     (f"{lfo['elpd']:.1f}<br><small>{lfo['unreliable_steps']} of {lfo['predicted_blocks']} "
                      f"steps k &gt; 0.7</small>"),
                     f"{loo['elpd']:.1f}<br><small>{loo['unreliable_blocks']} blocks k &gt; 0.7</small>"])
    return table(head, rows)


def _modes_section(summary, colors) -> str:
    z_table = _mode_table(summary, "measured_damping_ratio", "predicted_damping_ratio_90", 100.0, ".3g")
    f_table = _mode_table(summary, "measured_frequency_hz", "predicted_frequency_hz_90", 1.0, ".6g")
    caption = ("Damping ratio of each mode: measured (black) and each model's posterior predictive 90% "
               "interval (bars), both identified by ERA on the free decay after the excitation. "
               "Air damping falls with frequency, strain-rate damping rises with it.")
    return (h2("modes", SECTIONS)
            + "<p>Measured modal damping ratio and frequency (ERA on the recording) against each model's "
              "90% interval of the same quantity on its replicated recordings. Cells outside the interval "
              "are highlighted.</p>"
            + "<h3>Damping ratio &zeta; [%]</h3>" + z_table + "<h3>Frequency f [Hz]</h3>" + f_table
            + figure(mode_plot(summary, colors), "damping ratio against mode frequency", caption))


def _mode_table(summary, measured_key, interval_key, scale, fmt) -> str:
    """Rows: modes; columns: the measurement, then each model's 90% interval (flagged when it misses)."""
    ranking, models = summary["ranking"], summary["models"]
    rows_by_model = {m: {row["mode"]: row for row in models[m]["modes"]} for m in ranking}
    modes = sorted({k for rows in rows_by_model.values() for k in rows})
    rows = []
    for k in modes:
        measured = next((r[k][measured_key] for r in rows_by_model.values()
                         if k in r and r[k][measured_key] is not None), None)
        cells = [str(k), _missing(NO_MEASUREMENT) if measured is None else f"{measured * scale:{fmt}}"]
        for m in ranking:
            row = rows_by_model[m].get(k)
            cells.append(_interval_cell(row, measured_key, interval_key, scale, fmt, measured))
        rows.append(cells)
    return table(["mode", "measured"] + [esc(m) for m in ranking], rows)


def _interval_cell(row, measured_key, interval_key, scale, fmt, shown) -> str:
    """A model's 90 % interval, flagged when its measurement misses it. The check takes the ERA
    pole nearest the model's mode: where ERA finds two near one mode and this model's is not the
    one in the measured column (``shown``), the cell names it."""
    if row is None:
        return _missing(OUTSIDE_BAND)
    if row[interval_key] is None:
        return _missing(NO_INTERVAL)
    lo, hi = interval_ends(*(v * scale for v in row[interval_key]), int(fmt.strip(".g")))
    text = f"{lo}&ndash;{hi}"
    if row[measured_key] is not None and shown is not None and row[measured_key] != shown:
        text += f"<br><small>against {row[measured_key] * scale:{fmt}}</small>"
    return flag(text, _outside(row[measured_key], row[interval_key]))


def mode_plot(summary, colors):
    """zeta against mode frequency (log-log): measured points and each model's 90% interval."""
    ranking = summary["ranking"]
    fig, ax = plt.subplots(figsize=(WIDTH * 0.75, 3.8))
    # models side by side around each mode: small multiplicative offsets on the log axis
    offsets = 1 + 0.035 * (np.arange(len(ranking)) - (len(ranking) - 1) / 2)
    measured = {}
    for i, m in enumerate(ranking):
        rows = [r for r in summary["models"][m]["modes"] if r["predicted_damping_ratio_90"] is not None]
        f = np.array([r["model_frequency_hz"] for r in rows]) * offsets[i]
        lo, hi = np.array([r["predicted_damping_ratio_90"] for r in rows]).reshape(-1, 2).T
        ax.vlines(f, lo, hi, color=colors[m], lw=5, alpha=0.7, label=f"{m} (90% predictive)")
        measured.update({r["mode"]: (r["measured_frequency_hz"], r["measured_damping_ratio"])
                         for r in summary["models"][m]["modes"]
                         if r["mode"] not in measured and r["measured_damping_ratio"] is not None})
    f_obs, z_obs = np.array(list(measured.values())).reshape(-1, 2).T
    ax.plot(f_obs, z_obs, "k_", ms=16, mew=2, label="measured")
    ax.set(xscale="log", yscale="log", xlabel="mode frequency f [Hz]", ylabel="damping ratio ζ")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8, loc="best")
    fig.tight_layout()
    return fig


def _fits_section(results, summary) -> str:
    intro = ("<p>The measured signal against the median and 90% band of the noiseless prediction over "
             "posterior draws (noise not added), in the fitted window: a zoom on its start and the whole; "
             "below, the residual measured minus median.</p>")
    parts = [h2("fits", SECTIONS), intro]
    for m in summary["ranking"]:
        sensors = results[m].problem.model.recording.sensors
        for c, sensor in enumerate(sensors):
            parts.append(figure(_time_history_plot(results[m], summary["models"][m], c),
                                f"time history fit of {m}, {sensor.name}", ""))
    return "".join(parts)


def _time_history_plot(result, model_summary, channel):
    band = result.check.band
    rec = result.problem.model.recording
    t = band["time"]
    y, lo, med, hi = (band[k][:, channel] for k in ("observed", "q05", "q50", "q95"))
    span = max(min(len(t) // 5, round(ZOOM_SECONDS * rec.fs)), 2)
    windows = [(slice(0, span), f"first {span / rec.fs:.2f} s"), (slice(None), "whole fitted window")]
    fig, axes = plt.subplots(2, 2, figsize=(WIDTH, 3.9), sharex="col", gridspec_kw={"height_ratios": [3, 1.3],
                                                                                      "width_ratios": [1, 1.6]})
    predictive_columns(axes, t, y, lo, med, hi, windows, band_label="prediction 90%")
    axes[0, 0].set_ylabel(signal_label(rec.sensors[channel]))
    fig.suptitle(_title(result.name, model_summary), fontsize=10)
    fig.tight_layout()
    return fig


def _spectra_section(results, summary) -> str:
    caption = ("Amplitude of the Hann-windowed spectrum of the band-limited residual (measured minus the "
               "predictive median), per channel, against the RMS level the model's noise (posterior median "
               "sigma) has there (dashed): a residual standing above the dashed line is signal the model "
               "leaves out.")
    return (h2("spectra", SECTIONS)
            + figure(_spectra_plot(results, summary), "residual spectra against the noise level", caption))


def _spectra_plot(results, summary):
    ranking = summary["ranking"]
    ncols = min(2, len(ranking))
    nrows = -(-len(ranking) // ncols)
    fig, axes = plt.subplots(nrows, ncols, figsize=(WIDTH, 2.3 * nrows + 0.4), sharex=True, sharey=True,
                             squeeze=False)
    for ax, m in zip(axes.flat, ranking):
        band, rec = results[m].check.band, results[m].problem.model.recording
        f, amplitude = band["residual_frequency_hz"], band["residual_amplitude"]
        for c, sensor in enumerate(rec.sensors):
            post = summary["models"][m]["posterior"]
            phi = post.get(f"phi_{sensor.name}", {}).get("q50", 0.0)
            level = noise_level(f, post[f"sigma_{sensor.name}"]["q50"], len(band["time"]), rec.fs, phi)
            color = COLORS[c % len(COLORS)]
            ax.semilogy(f, amplitude[:, c], color=color, lw=0.7, label=f"residual {sensor.name}")
            ax.semilogy(f, level, color=color, ls="--", lw=1.2, label=f"noise level {sensor.name}")
        ax.set_title(m, fontsize=9)
    for ax in axes.flat[len(ranking):]:
        ax.set_visible(False)
    for ax in axes[-1]:
        ax.set_xlabel("frequency [Hz]")
    units = sorted({SIGNAL_UNITS[s.quantity] for s in results[ranking[0]].problem.model.recording.sensors})
    for ax in axes[:, 0]:
        ax.set_ylabel(f"residual amplitude [{', '.join(units)}]")
    axes[0, 0].legend(fontsize=7, loc="upper right")
    fig.tight_layout()
    return fig


def noise_level(frequency, sigma, n, fs, phi=0.0) -> np.ndarray:
    r"""RMS amplitude of the noise model in the Hann-windowed rfft of n samples, per frequency.

    White noise of sd sigma has :math:`E|X_k|^2 = \sigma^2 \sum_j w_j^2` in every bin (w the Hann
    window); AR(1) noise with coefficient phi is that shaped by :math:`1/|1 - \phi e^{-2\pi i f/f_s}|`.
    """
    white = sigma * np.sqrt(np.sum(np.hanning(n) ** 2))
    return white / np.abs(1 - phi * np.exp(-2j * np.pi * np.asarray(frequency) / fs))


def _checks_section(results, summary) -> str:
    ranking, models = summary["ranking"], summary["models"]
    names = list(dict.fromkeys(k for m in ranking for k in models[m]["ppc"]))
    replicates = len(next(iter(results[ranking[0]].check.statistics.values()))["replicated"])
    rows = []
    for name in names:
        cells = [esc(name)]
        for m in ranking:
            p = models[m]["ppc"].get(name, {}).get("p_value")
            cells.append("n/a" if p is None else flag(f"{p:.2g}", p < PASS_P_VALUE))
        rows.append(cells)
    return (h2("checks", SECTIONS)
            + f"<p>Posterior predictive p-values: how often the model's {replicates} replicated recordings are "
              f"at least as extreme as the measured one (so p is resolved to 1/{replicates}). p &lt; {PASS_P_VALUE} "
              f"(highlighted) says the recording is unlike the model's own replicates. residual_spectrum: "
              f"largest residual power over the noise variance in {SPECTRUM_BANDS} frequency bands; "
              f"ljung_box: residual autocorrelation (Ljung-Box Q, {LJUNG_BOX_LAGS} lags); zeta_mode&lt;m&gt;, "
              f"frequency_mode&lt;m&gt;: damping ratio and frequency of mode m by ERA (two-sided). n/a: the "
              f"mode was not identified.</p>"
            + table(["statistic"] + [esc(m) for m in ranking], rows))


def _posteriors_section(results, summary) -> str:
    corners = "".join(figure(_corner(results[m], summary["models"][m]), f"corner plot of {m}", "")
                      for m in summary["ranking"])
    return (h2("posteriors", SECTIONS)
            + "<p>Posterior median and 90% interval of every parameter (SI units).</p>"
            + _posterior_table(summary)
            + "<p>Corner plots of the model parameters: contours enclose 39% and 86% of the posterior mass "
              "(the 1- and 2-sigma levels of a 2-D Gaussian); the diagonal shows the marginal densities. On a "
              "simulated recording (a truth.json beside it) black lines mark the true values.</p>"
            + f'<div class="grid">{corners}</div>')


def _posterior_table(summary) -> str:
    ranking, models = summary["ranking"], summary["models"]
    names = list(dict.fromkeys(k for m in ranking for k in models[m]["posterior"]))
    rows = []
    for name in names:
        unit = next(models[m]["posterior"][name]["unit"] for m in ranking if name in models[m]["posterior"])
        cells = [esc(name), esc(unit)]
        for m in ranking:
            q = models[m]["posterior"].get(name)
            cells.append("&mdash;" if q is None else posterior_cell(q))
        rows.append(cells)
    return table(["parameter", "unit"] + [esc(m) for m in ranking], rows, text_columns=2)


def posterior_cell(q: dict) -> str:
    """A posterior summary's median over its 90% interval, to the digits that resolve the interval
    and tell its ends apart."""
    digits = resolving_digits(q)
    lo, hi = interval_ends(q["q05"], q["q95"], digits)
    return f"{significant(q['q50'], digits)}<br><small>{lo}&ndash;{hi}</small>"


def _corner(result, model_summary):
    post = result.problem.posterior
    k = len(post.model_names)
    draws = result.values()[..., :k].reshape(-1, k)
    model = result.problem.model
    fig = corner_overlay([draws], list(post.model_names), [result.name], units=model.units,
                         truths=recording_truths(model.recording))
    # the contour caption is the section's, once, and one model needs no legend: a short title
    # keeps small corners two to a row
    fig.suptitle(_title(result.name, model_summary), fontsize=10, y=1.02)
    fig.legends.clear()
    fig.set_size_inches(fig.get_size_inches() * CORNER_SHRINK)
    # corner places axis labels 0.3 panel widths out; keep that distance in inches, clear of the
    # tick labels, now that the panels are smaller
    pad = 0.3 / CORNER_SHRINK
    for ax in fig.axes:
        ax.xaxis.set_label_coords(0.5, -pad)
        ax.yaxis.set_label_coords(-pad, 0.5)
    return fig


def _convergence_section(results, summary) -> str:
    ranking, models = summary["ranking"], summary["models"]
    method = models[ranking[0]]["evidence"]["method"]
    return (h2("convergence", SECTIONS)
            + f"<p>Evidence: {esc(method)}. Each repeat is an independent run; the final particles of all "
              f"repeats are the posterior draws, and R-hat compares the repeats. A model's evidence has not "
              f"settled (flagged) when its repeats spread by more than {EVIDENCE_SD_MAX:g} nats (sd) or its "
              f"R-hat exceeds {R_HAT_MAX:g}. Acceptance: the mean fraction of accepted moves per tempering stage (its range over "
              f"stages).</p>" + _smc_table(results, summary)
            + "<h3>Discretisation check</h3><p>The optimum at the spline grid N used against the next finer "
              "grid; a shift above the tolerance (in posterior sd) means the grid limits the estimates, a change "
              "of the log posterior at the optimum above its tolerance (in nats) that it biases the log evidence.</p>"
            + _discretisation_table(summary))


def _smc_table(results, summary) -> str:
    rows = []
    for m in summary["ranking"]:
        s = summary["models"][m]
        runs = results[m].evidence.runs
        acceptance = np.concatenate([r.acceptance for r in runs])
        name, worst = _worst_rhat(s)
        spread = ", ".join(f"{z:.2f}" for z in s["evidence"]["repeats"]) + f"<br><small>sd {s['log_evidence_sd']:.2f}</small>"
        rows.append([esc(m), flag(spread, s["log_evidence_sd"] > EVIDENCE_SD_MAX),
                     ", ".join(str(n) for n in s["evidence"]["stages"]),
                     f"{acceptance.min():.2f}&ndash;{acceptance.max():.2f}",
                     flag(f"{rhat_text(worst)} ({esc(name)})", worst > R_HAT_MAX),
                     f"{s['evidence']['evaluations']:,}", f"{s['evidence']['seconds']:.1f}"])
    head = ["model", "log Z per repeat", "stages per repeat", "acceptance", "max R-hat", "evaluations",
            "seconds"]
    return table(head, rows)


def _discretisation_table(summary) -> str:
    rows = []
    for m in summary["ranking"]:
        d = summary["models"][m]["discretisation_check"]
        name = max(d["shift_sd"], key=d["shift_sd"].get)
        level = f"{d['level_change_nats']:+.3g} (tolerance {d['level_tolerance_nats']:g})" if "level_change_nats" in d else ""
        rows.append([esc(m), str(d["n_intervals"]) + (" (chosen)" if d["automatic"] else " (given)"),
                     str(d["refined_n_intervals"]), f"{d['max_shift_sd']:.3g} ({esc(name)})",
                     str(d["tolerance_sd"]), level, flag(_check_word(d), not d["passed"])])
    return table(["model", "N", "finer N", "largest shift [sd]", "tolerance [sd]",
                  "log posterior change at the optimum [nats]", "check"], rows)


def _check_word(check: dict) -> str:
    if check["passed"]:
        return "passed"
    return "failed: stalled (the error does not shrink with N)" if check.get("stalled") else "failed"


# ---------------------------------------------------------------------------- markdown
def ranking_markdown(summary) -> str:
    """The ranking as a markdown table (for the studies' pages), from comparison.json: evidence, the
    spline grid N, the smallest posterior predictive p-value and every parameter's posterior median
    with its 90% interval."""
    models = summary["models"]
    rows = []
    for m in summary["ranking"]:
        s = models[m]
        p_values = [v["p_value"] for v in s["ppc"].values() if v["p_value"] is not None]
        rows.append([_title(m, s), f"{s['log_evidence']:.1f}", f"{s['log_evidence_sd']:.2f}",
                     "best" if m == summary["best"] else f"{s['log_bayes_factor_vs_best']:.1f}",
                     str(s["discretisation_check"]["n_intervals"]),
                     f"{min(p_values):.2g}" if p_values else "n/a",
                     "; ".join(f"{name} {median_and_interval(q)}" for name, q in s["posterior"].items())])
    head = ["model", "log Z", "sd", "ln B vs best", "N", "smallest predictive p",
            "posterior median [90% interval], SI units"]
    return markdown_table(head, rows)


# ---------------------------------------------------------------------------- helpers
def _worst_rhat(model_summary) -> tuple[str, float]:
    """(parameter, R-hat) of the least converged parameter."""
    return max(((k, v["r_hat"]) for k, v in model_summary["posterior"].items()), key=lambda kv: kv[1])


def rhat_text(value: float) -> str:
    """R-hat to three decimals, or as many more as keep a value beyond :data:`R_HAT_MAX` from
    reading as the threshold itself (1.0501 is flagged: not "1.050")."""
    digits = 3
    while digits < 8 and (value > R_HAT_MAX) != (round(value, digits) > R_HAT_MAX):
        digits += 1
    return f"{value:.{digits}f}"


def _probability(p) -> str:
    return f"{p:.3f}" if p >= 1e-3 else f"{p:.1e}"


def _title(name, model_summary) -> str:
    """A model's name, with its mechanisms when the name does not already say them."""
    mechanisms = described(model_summary)
    return name if mechanisms == name else f"{name} ({mechanisms})"





def _missing(reason: str) -> str:
    """An empty cell that says why it is empty."""
    return f"n/a<br><small>{esc(reason)}</small>"


def _outside(value, interval) -> bool:
    return value is not None and interval is not None and not interval[0] <= value <= interval[1]
