"""The diagnosis report: what the damping model missed, the evidence, and how much the fit improved.

One self-contained HTML file (:mod:`bayesbeam.report.html`), in the order a reader asks: the
plain-language summary and what is still unexplained; the mismatch map of the baseline and of the
final model side by side (where in time and frequency the residual stands above the noise floor),
with the phase error and the delay; the per-mode table before and after; the candidates the
signatures ranked and the decisions on the augmented fits; and the added effect's posterior against
the signature screen's estimate. See docs/diagnosis.md for what the map and the screen measure.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.colors import LogNorm
from matplotlib.patches import Rectangle

from bayesbeam.checks.discrepancy import mode_label, share_words
from bayesbeam.comparison import R_HAT_MAX, strength
from bayesbeam.diagnosis import flags, stand_in_clause
from bayesbeam.io.atomic import write_text
from bayesbeam.report.comparison import WIDTH, rhat_text
from bayesbeam.report.html import esc, figure, flag, h2, nav, number, page, table
from bayesbeam.report.markdown import interval_ends, resolving_digits, significant

# plt comes from plots, which puts matplotlib on the Agg backend before importing pyplot
from bayesbeam.report.plots import plt
from bayesbeam.report.truth import recording_truths

#: (anchor, title) of the report's sections, in order
SECTIONS = (("summary", "Summary"), ("map", "Mismatch map"), ("modes", "Per mode"),
            ("candidates", "Candidates and decisions"), ("effect", "Added effect"))
#: the map's colour scale: from this standardized power (below: the darkest) up to at least MAP_TOP
MAP_BOTTOM, MAP_TOP = 0.1, 10.0
#: colour of the outline of a cell above the noise (stands out of the colour map)
OUTLINE = "#00e5ff"
#: per-mode statistic -> (column title, row keys of the error and its sd, format)
MODE_COLUMNS = {"frequency": ("frequency error [%]", "frequency_error_pct", "frequency_error_sd_pct", ".2g"),
                "damping": ("damping error [%]", "damping_error_pct", "damping_error_sd_pct", ".2g"),
                "amplitude": ("amplitude error [%]", "amplitude_error_pct", "amplitude_error_sd_pct", ".2g"),
                "curvature": ("decay shape", None, None, None),
                "phase": ("phase error at the excitation [rad]", "phase_error_rad", "phase_error_sd_rad", ".2g")}


def write_report(d, summary: dict, path) -> Path:
    """Write the report of a diagnosis (:class:`bayesbeam.diagnosis.Diagnosis`) and its
    ``d.to_dict()`` summary to ``path``, atomically."""
    return write_text(path, render(d, summary))


def render(d, summary: dict) -> str:
    """The report's HTML."""
    maps = compared_maps(d)
    body = [_header(d, summary),
            _summary_section(summary),
            _map_section(d, maps),
            _modes_section(maps),
            _candidates_section(d, summary),
            _effect_section(d, summary)]
    return page("bayesbeam diagnosis", body)


def compared_maps(d) -> list[tuple[str, str, object]]:
    """(when, model, Mismatch) of the maps shown: the baseline's ("before") and, when an effect was
    added, the final model's ("after")."""
    maps = [("before", d.baseline.name, d.baseline_mismatch)]
    return maps + [("after", d.final.name, d.final_mismatch)] if d.added else maps


# ---------------------------------------------------------------------------- header and summary
def _header(d, summary) -> str:
    rec = summary["recording"] or "(recording given in memory)"
    chosen = " (best by evidence)" if d.comparison is not None else ""
    row = [esc(rec), esc(d.baseline.name) + chosen, esc(d.final.name), esc(", ".join(d.added) or "nothing"),
           flag("yes", True) if d.unexplained else "no", f"{d.seconds:.0f} s"]
    return ("<h1>What is the damping model missing? Diagnosis</h1>"
            + table(["recording", "baseline model", "final model", "added effects", "unexplained", "run time"],
                    [row], text_columns=5)
            + nav(SECTIONS))


def _summary_section(summary) -> str:
    out = [h2("summary", SECTIONS), f'<p class="verdict">{esc(" ".join(lead(summary)))}</p>']
    steps = next_steps(summary)
    if steps:
        out.append('<p>What to check next:</p><ol class="next">' + "".join(f"<li>{esc(s)}</li>" for s in steps)
                   + "</ol>")
    recheck = summary.get("damping_recheck")
    if recheck and recheck["switched"]:
        out.append(f"<p>With {esc(' and '.join(recheck['effects']))} in every model the damping models were compared "
                   f"again, and the damping verdict changed from {esc(recheck['previous'])} to "
                   f"<b>{esc(recheck['best'])}</b>"
                   + (f"; with it, {esc(' and '.join(recheck['dropped']))} no longer earned a place and "
                      f"{'was' if len(recheck['dropped']) == 1 else 'were'} dropped" if recheck.get("dropped") else "")
                   + ' (see <a href="#candidates">Candidates and decisions</a>).' + _tie_words(recheck) + "</p>")
    out.append('<p>Each candidate tried, the decision on it and why, the models not fitted and why: '
               '<a href="#candidates">Candidates and decisions</a>.</p>')
    if summary["not_beam_physics"]:
        out.append("<h3>Not beam physics (not fitted)</h3><p>Lines in the final model's map that do not decay "
                   "with the beam (pickup): left out of the diagnosis.</p>"
                   + regions_table(summary["not_beam_physics"]))
    if summary["unexplained_regions"]:
        out.append("<h3>Unexplained</h3><p>Where the final model still misses beam physics.</p>"
                   + regions_table(summary["unexplained_regions"]))
    return "".join(out)


def lead(summary: dict) -> list[str]:
    """Plain sentences from diagnosis.json (``summary``): first any stand-in (a parameter the
    set-up rules out), then what was missing, how strong the evidence is, and how much the fit
    improved. When something is unexplained, :func:`next_steps` says what to check next."""
    sentences = (_stand_in_sentence(summary), _found_sentence(summary), _evidence_sentence(summary),
                 _improvement_sentence(summary))
    return [s for s in sentences if s]


def stand_ins(summary: dict) -> list[tuple[str, dict]]:
    """(effect in words, its stand-in verdict) of every effect of the final model, added or given,
    whose posterior median there the set-up rules out (diagnosis.json's ``final_stand_ins``:
    parameter, median, allowed, unit, why, label)."""
    return [(v["label"], v) for v in summary["final_stand_ins"].values()]


def _stand_in_sentence(summary) -> str:
    return " ".join(
        f"Not a finding: {effect} is a stand-in. Its {v['parameter']} = {v['median']:.4g} {v['unit']} "
        f"{stand_in_clause(v)} ({v['why']}): it stands in for a structural mismatch the catalogue cannot name."
        for effect, v in stand_ins(summary))


def _found_sentence(summary) -> str:
    base = summary["baseline"]["model"]
    added = [c for c in summary["candidates"] if c["added"]]
    if added:
        final = summary["final"].get("parameters", {})
        found = "; ".join(", ".join([f"{_effect_words(c['effect'])} ({_named(c)})"]
                                    + [_estimate(name, final.get(name, q)) for name, q in c["parameters"].items()])
                          for c in added if c["effect"] not in summary["final_stand_ins"])
        if found:
            return f"What the damping model {base} left out of this recording: {found}."
        return f"No missing physics the set-up allows was found in what the damping model {base} left out."
    if summary["unexplained"]:
        return (f"Something the damping model {base} leaves out shows above the noise, but no effect of the "
                f"catalogue explains it (where: Unexplained, below).")
    return f"Nothing the damping model {base} leaves out shows above the noise: no effect was needed."


#: What to check next, per kind of unexplained region (:func:`region_kinds` reads the kind from
#: the region and the final map's per-mode row): the physical causes that move a cantilever's
#: recording that way, then what to check (``{where}``: the modes or frequencies, ``{sensors}``). A frequency shift at one mode only is local (a mass or
#: a constraint where that mode moves, or a support resonating near it); a shift of every mode the
#: same way is global (the clamp, or the beam's stated stiffness and mass); extra damping at one
#: mode is a dissipation where that mode moves; a line that does not decay is not the beam's.
NEXT_STEPS = {
    "modes_low": ("{where} are each low: a compliant clamp or a mass the set-up does not state. Check the "
                  "clamp's tightness and faces, and weigh what is attached (cables, sensors) against beam.toml."),
    "modes_high": ("{where} are each high: the beam is stiffer or lighter than beam.toml states. Check its "
                   "length, thickness and material, and the stated tip and sensor masses."),
    "mode_low": ("the frequency of {where} is low, not every mode's: something attached near that mode's "
                 "antinode, or a resonance of the support near that frequency. Check what touches the beam "
                 "where that mode moves most (a cable, a bolt), and tap the support."),
    "mode_high": ("the frequency of {where} is high, not every mode's: a constraint near that mode's antinode "
                  "(a cable pulled taut, a guide). Check what holds the beam where that mode moves most."),
    "damping_high": ("the damping of {where} is higher than the model's: a contact or rubbing where that mode "
                     "moves, or a support that dissipates (a dashpot). Check loose cables, the clamp's faces "
                     "and the support's mounting."),
    "damping_low": ("the damping of {where} is lower than the model's: the damping model's law across frequency"
                    " does not fit there. Check the other damping models (bayesbeam compare --models all)."),
    "amplitude": ("the amplitude of {where} on {sensors} is not the model's: a sensor's sensitivity or "
                  "position, or the excitation's position. Check the calibration and the positions in "
                  "beam.toml."),
    "decay_shape": ("the decay of {where} is not exponential: damping that depends on amplitude (friction at "
                    "the clamp, air drag). Check the clamp's tightness, and record at two impact strengths."),
    "line_persistent": ("the residual at {where} on {sensors} does not decay: electrical pickup (mains, a "
                        "switching supply). Check the cable's shield and the ground, with a recording of the "
                        "beam at rest."),
    "line_decaying": ("the residual at {where} on {sensors}, away from every model mode, decays: a mode the "
                      "model lacks (torsion, bending in the other plane, the support's own). Check for a mode "
                      "there with an impact off the beam's centre line."),
    "band_top": ("a misfit at {where}, at a mode near the top of the fitted band where no per-mode statistic is"
                 " computed. Check a fit with --max-frequency above it."),
    "delay": ("the response lags the model: a timing offset between the channels (an anti-alias filter's delay,"
              " a multiplexed DAQ). Check the DAQ's inter-channel delay."),
    "force": ("the response is not driven by the measured force as modelled: a double hit, a clipped or "
              "miscalibrated force channel. Check the force record around the impact and the hammer's "
              "calibration."),
    "other": ("at {where} on {sensors}: {note}. Check that region of the mismatch map."),
}


def next_steps(summary: dict) -> list[str]:
    """What to check next, one line per kind of cause (:data:`NEXT_STEPS`), for the regions
    diagnosis.json (``summary``) calls unexplained; empty when nothing is. A line names every mode
    or frequency and sensor of its kind."""
    rows = {row["mode"]: row for row in summary.get("maps", {}).get("final", {}).get("modes", [])}
    found: dict[str, dict] = {}
    for r in summary["unexplained_regions"]:
        for kind in region_kinds(r, rows):
            entry = found.setdefault(kind, {"where": [], "sensors": [], "note": r["note"]})
            for key, value in (("where", _place(r, rows)), ("sensors", r["sensor"])):
                entry[key] += [] if value in entry[key] else [value]
    shifted = _shifted_modes(rows) if {"mode_low", "mode_high"} & found.keys() else None
    if shifted:
        kind, modes = shifted
        found = {kind: {"where": [_place({"mode": k}, rows) for k in modes], "sensors": [], "note": ""},
                 **{k: v for k, v in found.items() if k not in ("mode_low", "mode_high")}}
    return [_step(kind, {k: v if k == "note" else " and ".join(v) for k, v in entry.items()})
            for kind, entry in found.items()]


def region_kinds(region: dict, modes: dict) -> list[str]:
    """The kinds (keys of :data:`NEXT_STEPS`) of an unexplained region, from its mode's row of the
    final map (``modes``: mode number -> row): the sign of each flagged frequency and damping
    error, a flagged amplitude or decay shape; for a region at no mode, from its note (a line, the
    delay, the latent force)."""
    row = modes.get(region.get("mode"))
    if row is not None:
        kinds = []
        if "frequency" in row["flags"]:
            kinds.append("mode_low" if row["frequency_error_pct"] < 0 else "mode_high")
        if "damping" in row["flags"]:
            kinds.append("damping_low" if row["damping_error_pct"] < 0 else "damping_high")
        kinds += [k for flag_, k in (("amplitude", "amplitude"), ("curvature", "decay_shape")) if flag_ in row["flags"]]
        return kinds or ["other"]
    note = region["note"]
    for words, kind in (("near the top of the band", "band_top"), ("does not decay", "line_persistent"),
                        ("it decays", "line_decaying"), ("lags the model", "delay"), ("latent terms", "force")):
        if words in note:
            return [kind]
    return ["other"]


def _shifted_modes(modes: dict) -> tuple[str, list[int]] | None:
    """("modes_low" or "modes_high", the modes) when two or more modes' frequencies are flagged and
    all err the same way: a global cause, not one per mode."""
    errors = {k: row["frequency_error_pct"] for k, row in modes.items() if "frequency" in row["flags"]}
    signs = {e < 0 for e in errors.values()}
    if len(errors) < 2 or len(signs) > 1:
        return None
    return ("modes_low" if signs.pop() else "modes_high"), sorted(errors)


def _step(kind: str, values: dict) -> str:
    text = NEXT_STEPS[kind].format(**values)
    return text[0].upper() + text[1:]


def _place(region: dict, modes: dict) -> str:
    """Where a region is: its mode and the model's frequency of it ('mode 2 (41.38 Hz)'), or its
    frequency (its peak, or its band's middle)."""
    if region.get("mode") in modes:
        row = modes[region["mode"]]
        return f"{mode_label(row)} ({row['model_frequency_hz']:.4g} Hz)"
    return f"{region.get('peak_hz') or sum(region['band_hz']) / 2:.4g} Hz"


def _evidence_sentence(summary) -> str:
    added = [c for c in summary["candidates"] if c["added"]]
    if added:
        return ("The evidence is " + " and ".join(
            f"{strength(c['delta_log_evidence'])} for {_named(c)} (the data favour the model with it by a log Bayes "
            f"factor of {c['delta_log_evidence']:.1f} +- {c['delta_log_evidence_sd']:.1f} nats)" for c in added) + ".")
    if summary["candidates"]:
        best = max(summary["candidates"], key=lambda c: c["delta_log_evidence"])
        return (f"No candidate passed: the strongest, {best['effect']}, scored a log Bayes factor of "
                f"{best['delta_log_evidence']:.1f} +- {best['delta_log_evidence_sd']:.1f} nats, "
                + ("but the mismatch map did not improve." if best["decisive"] else "not decisive evidence."))
    return "No candidate effect had a signature worth fitting, so there is no evidence to weigh."


def _improvement_sentence(summary) -> str:
    before, after = summary["baseline"], summary["final"]
    rms = (f"RMS standardized residual (1 when only noise is left) from {before['rms_standardized_residual']:.2f} "
           f"to {after['rms_standardized_residual']:.2f}, flags in the mismatch map from {before['flags']} to "
           f"{after['flags']}")
    if before["model"] == after["model"]:
        return (f"The fit is unchanged: {before['model']}'s RMS standardized residual is "
                f"{before['rms_standardized_residual']:.2f} (1 when only noise is left) with {before['flags']} "
                f"flag(s) in the mismatch map.")
    return (f"The fit improved from {before['model']} to {after['model']}: {rms}, log evidence from "
            f"{before['log_evidence']:.1f} to {after['log_evidence']:.1f}.")


def _named(candidate: dict) -> str:
    """A diagnosis.json candidate's effect, with the sensor a sensor mass sits at ('sensor_mass at mid')."""
    return candidate.get("label") or candidate["effect"]


def _effect_words(name: str) -> str:
    """The catalogue's description of an effect up to its first comma ("rotational spring at the clamp")."""
    from bayesbeam.physics.effects import resolve

    return resolve([name])[0].description.split(",")[0]


def _estimate(name: str, q: dict) -> str:
    unit = f" {q['unit']}" if q["unit"] else ""
    return f"{name} = {q['mean']:.4g}{unit} (90% interval {_interval([q['q05'], q['q95']])})"


def regions_table(regions) -> str:
    """Map regions: band, time window, sensor, the finding and the size of the misfit in words
    (``misfit_share``, which exceeds 1 where the model puts little signal: see ``share_words``)."""
    rows = [[f"{r['band_hz'][0]:.4g}&ndash;{r['band_hz'][1]:.4g}", f"{r['time_s'][0]:.3g}&ndash;{r['time_s'][1]:.3g}",
             esc(r["sensor"]), esc(r["note"]),
             esc(share_words(r["misfit_share"])) if r.get("misfit_share") is not None else "n/a"] for r in regions]
    return table(["band [Hz]", "time [s]", "sensor", "note", "misfit"], rows, text_columns=(2, 3, 4))


# ---------------------------------------------------------------------------- the map
def _map_section(d, maps) -> str:
    intro = ("<p>Standardized residual power per time block and frequency bin: the recording minus the fitted "
             "model's predictions (posterior draws), over the noise floor of the cells the model does fit "
             "(1 where the model explains the recording down to its noise; see docs/diagnosis.md). Cells "
             "standing above the noise (Holm's procedure, family-wise) are outlined; dashed lines are the "
             "model's mode frequencies.")
    intro += ("" if d.added else " Nothing was added, so there is no &ldquo;after&rdquo;: the baseline's map "
                                 "only.") + "</p>"
    names = " and ".join(f"{when} ({name})" for when, name, _ in maps)
    caption = (f"Mismatch map {names}, on one logarithmic colour scale (1: the noise floor; "
               f"{MAP_BOTTOM:g} and below darkest); outlined: cells above the noise; dashed: model mode frequencies.")
    out = [h2("map", SECTIONS), intro, _map_table(maps), figure(mismatch_map_plot(maps), f"mismatch map {names}",
                                                                 caption)]
    out += [f"<h3>Regions of the {when} map ({esc(name)})</h3>"
            + (regions_table(m.regions) if m.regions else "<p>None: nothing stands above the noise.</p>")
            for when, name, m in maps]
    return "".join(out) + _phase_part(maps)


def _map_table(maps) -> str:
    rows = []
    for when, name, m in maps:
        inflation = ", ".join(f"{esc(c)} {v['inflation']:.2f}" for c, v in m.noise.items())
        rows.append([when, esc(name), f"{m.rms_standardized_residual:.3f}", str(int(m.spectrogram.significant.sum())),
                     str(sum(len(r["flags"]) for r in m.modes)), _delay_cell(m.phase), str(flags(m)), inflation])
    head = ["map", "model", "RMS standardized residual<small>1: nothing but noise</small>", "flagged cells",
            "per-mode flags", "delay [ms]", "flags in all", "fitted noise sd / floor"]
    return table(head, rows, text_columns=2)


def _delay_cell(phase) -> str:
    if phase["delay_s"] is None:
        return "n/a"
    text = _ms(phase["delay_s"], phase["delay_sd_s"])
    return flag(text + " (significant)", True) if phase["significant"] else text


def mismatch_map_plot(maps):
    """Standardized residual power (time block x frequency bin), one panel per sensor (rows) and map
    (columns), on one logarithmic colour scale; significant cells outlined, the model's mode
    frequencies dashed."""
    channels = maps[0][2].channels
    norm = LogNorm(MAP_BOTTOM, max(MAP_TOP, *(float(np.max(m.spectrogram.power)) for *_, m in maps)))
    fig, axes = _panels(len(channels), len(maps), 2.8)
    for col, (when, name, m) in enumerate(maps):
        for c, sensor in enumerate(channels):
            mesh = _map_panel(axes[c, col], m, c, norm)
            axes[c, col].set_title(f"{when}: {name}, {sensor}", fontsize=9)
    for ax in axes[-1]:
        ax.set_xlabel("time [s]")
    for ax in axes[:, 0]:
        ax.set_ylabel("frequency [Hz]")
    fig.colorbar(mesh, ax=axes, label="standardized residual power (1: noise)")
    handles = [plt.Line2D([], [], color="w", ls="--", lw=0.8, label="model mode frequency"),
               Rectangle((0, 0), 1, 1, fill=False, ec=OUTLINE, lw=1.5, label="cell above the noise")]
    fig.legend(handles=handles, loc="outside lower center", ncols=2, fontsize=8, facecolor="0.6")
    return fig


def _panels(rows, columns, height):
    """A grid of panels, a sensor per row and a map per column (half the width for one map)."""
    return plt.subplots(rows, columns, figsize=(WIDTH * (0.5 + 0.5 * (columns > 1)), height * rows + 0.9),
                        squeeze=False, sharex=True, sharey=True, layout="constrained")


def _map_panel(ax, m, c, norm):
    s = m.spectrogram
    df = s.frequencies_hz[1] - s.frequencies_hz[0]
    t_edges = np.append(s.block_times_s, s.block_times_s[-1] + s.block_duration_s)
    f_edges = np.append(s.frequencies_hz - df / 2, s.frequencies_hz[-1] + df / 2)
    power = np.clip(s.power[:, :, c].T, norm.vmin, norm.vmax)
    mesh = ax.pcolormesh(t_edges, f_edges, power, norm=norm, cmap="magma", shading="flat")
    for block, k in np.argwhere(s.significant[:, :, c]):
        ax.add_patch(Rectangle((s.block_times_s[block], s.frequencies_hz[k] - df / 2), s.block_duration_s, df,
                               fill=False, ec=OUTLINE, lw=1.5))
    for row in m.modes:
        ax.axhline(row["model_frequency_hz"], color="w", ls="--", lw=0.8)
    ax.set_ylim(0, f_edges[-1])
    return mesh


def _phase_part(maps) -> str:
    """The phase error against frequency and the delay, when any bin or mode has a phase."""
    has_phase = any(np.isfinite(m.phase["phase_rad"]).any() or m.phase["delay_s"] is not None for *_, m in maps)
    if not has_phase:
        return "<h3>Phase and delay</h3><p>No bin has a coherent phase: no phase figure, no delay estimate.</p>"
    caption = ("Phase of the cross-spectrum of the recording and the model's prediction per bin (points, +- 1 sd; "
               "bins with coherent signal-to-noise of at least 10), each mode's phase error at the excitation "
               "(diamonds: the delay is estimated from these, since a frequency error also tilts the per-bin "
               "phase), and the phase -2 pi f tau of the estimated delay (line). Negative: the data lag the model.")
    return ("<h3>Phase and delay</h3><p>" + "<br>".join(_delay_text(when, name, m.phase) for when, name, m in maps)
            + "</p>" + figure(phase_plot(maps), "phase error against frequency", caption))


def _delay_text(when, name, phase) -> str:
    if phase["delay_s"] is None:
        return (f"{when} ({esc(name)}): no delay estimate (no mode's phase at the excitation: too few cycles above "
                f"the noise, or a free decay).")
    linear = phase["linear_p_value"]
    shape = "" if linear is None else f"; linearity of the per-mode phase errors p = {linear:.2g}"
    verdict = "significant" if phase["significant"] else "not significant"
    return (f"{when} ({esc(name)}): the data lag the model by {_ms(phase['delay_s'], phase['delay_sd_s'])} ms "
            f"({verdict}, from {phase['n_modes']} modes{shape}).")


def phase_plot(maps):
    """Phase error (rad) against frequency, a sensor per row and a map per column: the cross-spectrum's
    per bin, the modes' at the excitation and the line of the estimated delay."""
    channels = maps[0][2].channels
    fig, axes = _panels(len(channels), len(maps), 2.4)
    for col, (when, name, m) in enumerate(maps):
        for c, ax in enumerate(axes[:, col]):
            _phase_panel(ax, m, c)
            ax.set_title(f"{when}: {name}, {channels[c]}", fontsize=9)
            ax.axhline(0, color="k", lw=0.5)
            ax.grid(True, alpha=0.3)
        axes[-1, col].set_xlabel("frequency [Hz]")
    for ax in axes[:, 0]:
        ax.set(ylabel="phase error [rad]", ylim=(-np.pi, np.pi))
    handles = [plt.Line2D([], [], color="C0", marker=".", ls="", label="per bin (+- 1 sd)"),
               plt.Line2D([], [], color="C3", marker="D", mec="k", ls="", label="mode, at the excitation"),
               plt.Line2D([], [], color="C2", label="estimated delay"),
               plt.Line2D([], [], color="k", ls="--", lw=0.6, label="model mode frequency")]
    fig.legend(handles=handles, loc="outside lower center", ncols=4, fontsize=8, frameon=False)
    return fig


def _phase_panel(ax, m, c):
    p = m.phase
    f = np.asarray(p["frequency_hz"])
    ax.errorbar(f, p["phase_rad"][:, c], p["phase_sd_rad"][:, c], fmt=".", ms=3, lw=0.6, color="C0", alpha=0.7)
    rows = [r for r in m.modes if r["phase_error_rad"] is not None and r["sensor"] == m.channels[c]]
    if rows:
        ax.errorbar([r["model_frequency_hz"] for r in rows], [r["phase_error_rad"] for r in rows],
                    [r["phase_error_sd_rad"] for r in rows], fmt="D", ms=6, color="C3", mec="k", zorder=3)
    if p["delay_s"] is not None:
        ax.plot(f, np.angle(np.exp(-2j * np.pi * f * p["delay_s"])), color="C2", lw=1.2)
    for r in m.modes:
        ax.axvline(r["model_frequency_hz"], color="k", ls="--", lw=0.6)


# ---------------------------------------------------------------------------- per mode
def _modes_section(maps) -> str:
    names = "; ".join(f"{when}: {esc(name)}" for when, name, _ in maps)
    return (h2("modes", SECTIONS) + f"<p>Maps: {names}.</p>"
            + "<p>Each mode's frequency, damping ratio and amplitude (on the sensor where the mode is strongest), "
              "decay shape and phase at the excitation, measured on the recording and on the model's replicated "
              "recordings by the same estimators: the error is the recording's minus the replicates' median "
              "&plusmn; its sd. Highlighted: errors beyond the noise (Bonferroni over all per-mode tests). "
              "n/a: too few cycles above the noise after the impact to measure.</p>"
            + per_mode_table(maps))


def per_mode_table(maps) -> str:
    """One row per mode of each map, the maps' rows of a mode next to each other: the beam's modes
    by number, an effect's own mode after the beam's modes below it."""
    rows = sorted(((place, i, when, r) for i, (when, _, m) in enumerate(maps) for place, r in _placed(m.modes)),
                  key=lambda x: x[:2])
    head = ["mode", "map", "sensor", "model f [Hz]"] + [v[0] for v in MODE_COLUMNS.values()] + ["finding"]
    return table(head, [_mode_cells(when, r) for _, _, when, r in rows],
                 text_columns=(0, 1, 2, len(head) - 2, len(head) - 1))


def _placed(rows) -> list[tuple[float, dict]]:
    """(place, row): k for the beam's mode k, k + 1/2 for an effect's own mode above beam mode k."""
    out, k = [], 0
    for row in rows:
        own = not mode_label(row).startswith("mode ")
        k += not own
        out.append((k + 0.5 * own, row))
    return out


def _mode_cells(when, row) -> list[str]:
    label = mode_label(row)
    cells = [esc(label.removeprefix("mode ")), when, esc(row["sensor"]), f"{row['model_frequency_hz']:.5g}"]
    for stat, (_, key, sd_key, fmt) in MODE_COLUMNS.items():
        text = _decay(row) if key is None else _pm(row[key], row[sd_key], fmt)
        cells.append(flag(text, stat in row["flags"]))
    cells.append(esc(row["note"]) if row["flags"] else "&mdash;")
    return cells


def _pm(value, sd, fmt) -> str:
    if value is None:
        return "n/a"
    return f"{value:+{fmt}} &plusmn; {number(sd, fmt)}"


# ---------------------------------------------------------------------------- candidates and decisions
def _candidates_section(d, summary) -> str:
    chain = d.chain()
    out = [h2("candidates", SECTIONS),
           ("<p>Name: each catalogue effect's signature (the change it makes to the per-mode errors after the "
            "model's own parameters re-adjust) fitted to the observed errors, ranked before anything is fitted "
            "(docs/diagnosis.md).</p>")]
    out += [_ranking_part(i + 1, chain[i][0].name, r) for i, r in enumerate(d.rankings)]
    out.append("<h3>Augmented fits</h3>" + (trials_table(d) if d.trials else
               "<p>No augmented model was fitted: the baseline's map flags no beam physics and the projected "
               "mismatch is insignificant.</p>"))
    if summary.get("not_fitted"):
        out.append("<h3>Not fitted</h3>" + table(
            ["round", "model", "why"], [["re-check" if n["round"] == 0 else str(n["round"]), esc(n["model"]),
                                         esc(n["reason"])] for n in summary["not_fitted"]], text_columns=3))
    out.append(_decision_rule(summary["decision_rule"]))
    out.append(f"<h3>The decisions in words</h3><p>{esc(summary['summary'])}</p>")
    if summary["baseline_comparison"]:
        out.append("<h3>Baseline chosen by evidence</h3>" + _comparison_table(summary["baseline_comparison"]))
    if summary.get("left_out"):
        out.append("<h3>Damping models left out</h3><ul>" + "".join(
            f"<li><b>{esc(m)}</b>: {esc(why)}</li>" for m, why in summary["left_out"].items()) + "</ul>")
    recheck = summary.get("damping_recheck")
    if recheck:
        out.append(f"<h3>Damping re-checked with {esc(' and '.join(recheck['effects']))}</h3>"
                   "<p>The first comparison could not see the missing physics; the damping models of the baseline comparison are "
                   f"compared again, each with the added effects. Final damping: <b>{esc(recheck['best'] if recheck['switched'] else recheck['previous'])}</b>"
                   f"{' (switched: decisive evidence)' if recheck['switched'] else ''}.{_tie_words(recheck)}</p>"
                   + _comparison_table(recheck["models"]))
    if recheck and recheck.get("pruning"):
        out.append("<h3>Added effects judged again with the new damping model</h3><p>Each added effect left out in "
                   "turn; one whose log Bayes factor is not decisive is dropped (final model: "
                   f"<b>{esc(recheck['final'])}</b>).</p>" + _pruning_table(recheck["pruning"]))
    return "".join(out)


def _tie_words(recheck: dict) -> str:
    """The damping models the re-check could not rank below its best (diagnosis.json's ``tied``), in words."""
    tied = recheck.get("tied", ())
    if not tied:
        return ""
    return (f" Not decisively behind {esc(recheck['best'])}: {esc(', '.join(tied))}; the recording does not decide "
            "between these damping models.")


def _pruning_table(pruning: dict) -> str:
    rows = [[esc(spec), esc(v["without"]), f"{v['log_bayes_factor']:.1f} &plusmn; {v['sd']:.1f}", _yes(v["needed"])]
            for spec, v in pruning.items()]
    return table(["model", "effect left out", "ln B of keeping it [nats]", "needed"], rows, text_columns=2)


def _ranking_part(round_, model, ranking) -> str:
    notes = "".join(f"<li>{esc(n)}</li>" for n in ranking.notes)
    shown = [c for c in ranking.candidates if c.supported] or ranking.candidates[:1]
    reasoning = "".join(f"<p>{esc(c.reasoning)}</p>" for c in shown if c.reasoning)
    return (f"<h3>Round {round_}: signatures against {esc(model)}</h3><ul>{notes}</ul>"
            + candidates_table(ranking)
            + ("<p>Reasoning of the supported candidate(s):</p>" if ranking.best else
               "<p>No candidate is supported; the top one's reasoning:</p>") + reasoning)


def candidates_table(ranking) -> str:
    """The signature screen's candidates, best first (the first highlighted when supported)."""
    rows = [[esc(c.label), esc(c.parameter), _value(c.value, c.unit), _interval(c.interval_90),
             _interval(c.prior), f"{c.delta_chi2:.3g}", f"{100 * c.explained:.0f}%", f"{c.p_value:.2g}",
             "yes" if c.supported else "no"] for c in ranking.candidates]
    head = ["effect", "parameter", "value", "90% interval", "prior support", "&Delta;&chi;&sup2;", "explained",
            "p-value", "supported"]
    return table(head, rows, text_columns=2, highlight_first=ranking.best is not None)


def trials_table(d) -> str:
    """Every augmented model fitted, against the model it augments: evidence, map, decision."""
    chain = d.chain()
    rows = []
    for t in d.trials:
        parent, before = chain[t.round - 1]
        rows.append([str(t.round), esc(t.result.name), esc(parent.name),
                     flag(f"{t.log_bayes_factor:.1f} &plusmn; {t.log_bayes_factor_sd:.1f}", not t.decisive),
                     f"{before.rms_standardized_residual:.3f} &rarr; {t.mismatch.rms_standardized_residual:.3f}",
                     f"{flags(before)} &rarr; {flags(t.mismatch)}", _yes(t.decisive), _yes(t.improved),
                     _added_cell(t)])
    head = ["round", "model", "against", "ln B [nats]", "RMS standardized residual", "flags", "decisive",
            "map improved", "added"]
    return table(head, rows, text_columns=3)


def _decision_rule(rule) -> str:
    return (f"<p>Decision rule: an effect is added when its log Bayes factor against the model it augments "
            f"exceeds {rule['log_bayes_factor_above']:g} nats by more than {rule['by_standard_errors']:g} "
            f"standard errors (decisive) and the map improves ({esc(rule['map_must_improve'])}); of several, the "
            f"one with the largest log Bayes factor. The map's family-wise false-alarm level is "
            f"{rule['alpha']:g}.</p>")


def _comparison_table(models) -> str:
    rows = [[esc(m), f"{v['log_evidence']:.2f} &plusmn; {v['log_evidence_sd']:.2f}", f"{v['probability']:.3g}"]
            for m, v in sorted(models.items(), key=lambda kv: -kv[1]["log_evidence"])]
    return table(["model", "log Z [nats]", "probability"], rows, highlight_first=True)


# ---------------------------------------------------------------------------- the added effect
def _effect_section(d, summary) -> str:
    out = [h2("effect", SECTIONS)]
    added = [t for t in d.trials if t.effect in d.added]
    if not added:
        out.append("<p>No effect was added.</p>")
    for t in added:
        signature, parameters = d.signature(t), summary["candidates"][d.trials.index(t)]["parameters"]
        caption = ("Posterior of the added effect's parameter in the augmented model (all SMC particles): median "
                   "(solid) and 90% interval (shaded), against the signature screen's value and 90% interval "
                   "(marker and bar), estimated before the model was fitted; on a simulated recording (a "
                   "truth.json beside it) the true value (dotted).")
        name = _named(summary["candidates"][d.trials.index(t)])
        # an effect with nothing sampled (mains pickup: f_mains fixed, amplitudes marginalised) has no posterior to draw
        shown = (figure(effect_posterior_plot(t, parameters, signature), f"posterior of {t.effect}", caption)
                 if parameters else "<p>Its parameters are held fixed and its amplitudes marginalised: nothing "
                 "sampled to show.</p>")
        out.append(f"<h3>{esc(name)} (round {t.round}, {esc(t.result.name)})</h3>" + shown)
    if d.trials:
        out.append("<h3>Effect parameters of every augmented fit</h3>" + effect_table(d, summary))
    if d.recheck is not None and d.recheck.switched:
        out.append(f"<h3>Final model {esc(d.final.name)} (after the damping re-check)</h3>"
                   "<p>The effect's estimate in the augmented model above was made with the damping model the "
                   "first comparison chose; with the damping the re-check chose, it reads:</p>"
                   + parameter_table(summary["final"]["parameters"]))
    return "".join(out)


def parameter_table(parameters: dict) -> str:
    """Posterior summary of every parameter of a model (diagnosis.json's ``final.parameters``)."""
    rows = [[esc(name), esc(q["unit"]), *_posterior_cells(q)] for name, q in parameters.items()]
    return table(["parameter", "unit", "posterior median", "90% interval", "mean &plusmn; sd", "R-hat"], rows,
                 text_columns=2)


def effect_posterior_plot(trial, summary: dict, signature):
    """Histogram of each of the effect's parameters over the posterior draws, its median and 90%
    interval (``summary``: the trial's effect parameters in diagnosis.json), and the signature
    screen's value and 90% interval for comparison."""
    names = list(trial.result.problem.posterior.names)
    fig, axes = plt.subplots(len(summary), 1, figsize=(WIDTH * 0.8, 3.0 * len(summary)), squeeze=False,
                             layout="constrained")
    values = trial.result.values()
    truths = recording_truths(trial.result.problem.model.recording)
    for ax, (name, q) in zip(axes[:, 0], summary.items()):
        ax.hist(values[..., names.index(name)].ravel(), bins=30, density=True, color="C0", alpha=0.6,
                label="posterior draws")
        ax.axvspan(q["q05"], q["q95"], color="C0", alpha=0.15, label="posterior 90%")
        ax.axvline(q["q50"], color="C0", lw=1.5, label=f"posterior median {q['q50']:.4g}")
        if signature is not None and signature.parameter == name and signature.value is not None:
            _mark_signature(ax, signature)
        if name in truths:
            ax.axvline(truths[name], color="k", lw=1.5, ls=":", label=f"truth {truths[name]:.4g} (truth.json)")
        ax.set(xlabel=f"{name} [{q['unit']}]" if q["unit"] else name, ylabel="density")
        ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.02, 1))
    return fig


def _mark_signature(ax, c):
    y = 0.92 * ax.get_ylim()[1]
    lo, hi = c.interval_90 if c.interval_90 else (c.value, c.value)
    ax.errorbar([c.value], [y], xerr=[[c.value - lo], [hi - c.value]], fmt="v", color="C3", ms=8, capsize=4,
                label=f"signature screen {c.value:.4g} (90%)")


def effect_table(d, summary) -> str:
    """Posterior summary of each augmented model's effect parameters, with the screen's estimate."""
    rows = []
    for t, entry in zip(d.trials, summary["candidates"]):
        c = d.signature(t)
        for name, q in entry["parameters"].items():
            screen = c is not None and c.parameter == name
            rows.append([esc(t.effect), esc(name), esc(q["unit"]), *_posterior_cells(q),
                         _value(c.value, "") if screen else "n/a", _interval(c.interval_90) if screen else "n/a",
                         _added_cell(t)])
    head = ["effect", "parameter", "unit", "posterior median", "90% interval", "mean &plusmn; sd", "R-hat",
            "signature screen", "screen 90% interval", "added"]
    return table(head, rows, text_columns=3)


# ---------------------------------------------------------------------------- formatting
def _posterior_cells(q: dict) -> list[str]:
    """Median, 90% interval, mean +- sd and R-hat (flagged) of one parameter's posterior summary."""
    return [significant(q["q50"], resolving_digits(q)), _interval([q["q05"], q["q95"]], resolving_digits(q)), f"{q['mean']:.4g} &plusmn; {q['sd']:.2g}",
            flag(rhat_text(q["r_hat"]), q["r_hat"] > R_HAT_MAX)]


def _added_cell(trial) -> str:
    """The decision on a trial in a table cell: added, added and dropped after the re-check, or no."""
    return "added, then dropped" if trial.dropped else "<b>added</b>" if trial.added else "no"


def _value(value, unit) -> str:
    return "n/a" if value is None else f"{value:.4g}" + (f" {esc(unit)}" if unit else "")


def _interval(interval, digits: int = 4) -> str:
    """'low to high', to ``digits`` significant digits or as many more as tell the ends apart."""
    return "n/a" if not interval else " to ".join(interval_ends(*interval, digits))


def _ms(value, sd) -> str:
    """A delay (s) and its sd in ms, the value to the sd's second significant digit."""
    digits = max(0, 1 - int(np.floor(np.log10(sd * 1e3)))) if sd and sd > 0 else 3
    return f"{value * 1e3:.{digits}f} &plusmn; {sd * 1e3:.2g}" if sd else f"{value * 1e3:.3g}"


def _decay(row) -> str:
    """The decay shape in words, n/a where the curvature could not be measured."""
    return "n/a" if row["p_values"]["curvature"] is None else esc(row["decay"])


def _yes(value) -> str:
    return "yes" if value else "no"
