"""What a recording holds, before any fit: the survey behind ``bayesbeam check``.

It reads the recording's description back (beam, tip body, excitation, sensors, sampling) and
looks at its signals:

- the force pulses, each a hit or an isolated spike (:func:`bayesbeam.response.signals.find_pulses`,
  the rule the force window of every fit uses);
- each channel's noise floor: the median of its spectral density over the DAQ passband (the modes
  hold a few of its thousands of bins), corrected for the median of a periodogram bin being ln 2
  of its mean, and stated as the sd white noise of that density would have;
- spectral peaks standing :data:`PEAK_FACTOR` above that floor, set against the nominal
  clamped-free frequencies of the beam with its tip body (:mod:`bayesbeam.modal.eigen`);
- mains lines: peaks within two bins of a multiple of 50 or 60 Hz that keep their amplitude over the
  record (:func:`bayesbeam.checks.discrepancy.line_persistence`), where a beam mode would decay;
- clipping: a channel's extreme value held by :data:`CLIP_SAMPLES` or more samples (the sampled
  trace of flat runs at the converter's limit: a noisy, unclipped signal reaches its extreme once);
- a suggested top of the fitted band and analysis window;
- each channel's unit judged from physics (:mod:`bayesbeam.checks.units`).

It sits in ``checks`` because it needs the reader (io), the pulse finder (response), the
eigenvalues (modal) and the mains-line test of the discrepancy checks, and nothing above them;
the figure is drawn by :mod:`bayesbeam.report.quicklook` and the command is ``bayesbeam.cli.check``.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from itertools import pairwise

import numpy as np
from scipy import signal

from bayesbeam.checks.discrepancy import PERSISTENT, line_persistence, mains_harmonic
from bayesbeam.checks.units import report_text as units_text
from bayesbeam.checks.units import unit_check
from bayesbeam.inference.fit import DEFAULT_BAND
from bayesbeam.io.units import SI_UNITS
from bayesbeam.modal.eigen import natural_frequencies_hz
from bayesbeam.physics.effects.mains_lines import analysed_span
from bayesbeam.response.linear import PASSBAND
from bayesbeam.response.signals import find_pulses

#: a spectral peak stands this many times above the channel's noise-floor density (15 dB)
PEAK_FACTOR = 30.0
#: peaks listed per channel, the highest first
MAX_PEAKS = 12
#: a peak within this relative distance of a higher one is its side lobe or beat, not a mode of
#: its own (the clamped-free modes lie at least a factor 2.8 apart)
SEPARATION = 0.05
#: a spectral peak within this relative distance of a nominal mode can be that mode (:func:`_modes`):
#: nominal E, an unknown clamp compliance and sensor mass routinely move frequencies by 10-20 %
MODE_MATCH = 0.25
#: this many samples at a channel's maximum (or minimum) value are clipping; a signal with high
#: modes rises to the limit and leaves it within a sample or two, so they need not be consecutive
CLIP_SAMPLES = 3
#: a record is cut into this many segments to find where its response sinks into the noise
SEGMENTS = 40
#: ... which it has done when a segment's RMS is below this many noise sds
END_FACTOR = 3.0
#: the most nominal modes computed
MAX_MODES = 40


@dataclass
class Spectrum:
    """One-sided spectral density (unit^2/Hz) of a channel over the analysed segment (Hann window)."""

    frequency: np.ndarray
    density: np.ndarray


@dataclass
class Survey:
    """The findings of :func:`survey`; ``summary`` is JSON-ready, ``spectra`` feed the figure."""

    summary: dict
    spectra: dict[str, Spectrum] = field(default_factory=dict)
    segment: tuple[int, int] = (0, 0)


def survey(rec) -> Survey:
    """Survey a loaded recording (module docstring); the recording is not changed."""
    i0 = analysed_span(rec).i0
    segment = (i0, rec.n_samples)
    nominal = nominal_frequencies(rec)
    spectra, channels = {}, []
    for j, sensor in enumerate(rec.sensors):
        spectrum = _spectrum(rec.signals[i0:, j], rec.fs)
        spectra[sensor.name] = spectrum
        channels.append(_channel(rec, j, spectrum, nominal))
    summary = {
        "recording": str(rec.source) if rec.source else None,
        "read": describe(rec),
        "force": _force(rec),
        "channels": channels,
        "nominal_frequencies_hz": [float(f) for f in nominal],
        "modes": _modes(nominal, channels),
        "mains_lines": sorted({line["frequency_hz"] for c in channels for line in c["mains_lines"]}),
        "clipping": {c["name"]: c["clipping"] for c in channels + _force_channel(rec) if c["clipping"]},
    }
    summary["suggested"] = _suggestion(rec, summary, i0)
    summary["units"] = unit_check(rec, summary)
    return Survey(summary, spectra, segment)


# ---------------------------------------------------------------------------- what was read
def describe(rec) -> dict:
    """The recording's description as read: beam, tip body, excitation, sensors, sampling (SI), with
    what beam.toml states about the set-up (tolerances, sensor masses: None where not stated).
    RecordingError for a set-up key a fit would refuse."""
    beam, exc, setup = rec.beam, rec.excitation, rec.setup
    excitation = {"kind": exc.kind}
    excitation.update({k: getattr(exc, k) for k in ("location", "column", "tip_load", "start")
                       if getattr(exc, k) is not None})
    if exc.kind == "force":
        excitation["location_tolerance_m"] = setup.excitation_location_tolerance
    return {
        "beam": {"length_m": beam.length, "density_kg_m3": beam.density, "area_m2": beam.area,
                 "second_moment_m4": beam.second_moment, "modulus_Pa": beam.modulus,
                 "EI_N_m2": beam.nominal_EI, "rho_A_kg_m": beam.rho_a, "length_tolerance_m": setup.length_tolerance},
        "tip": {"m_T_kg": rec.tip.mass, "J_kg_m2": rec.tip.rotary_inertia,
                "m_T_tolerance_kg": setup.tip_mass_tolerance, "J_tolerance_kg_m2": setup.tip_rotary_inertia_tolerance},
        "excitation": excitation,
        "sensors": [{"name": s.name, "location_m": s.location, "quantity": s.quantity, "column": s.column,
                     "unit": SI_UNITS[s.quantity], "stated_unit": s.unit, "mass_kg": mass, "location_tolerance_m": tolerance}
                    for s, mass, tolerance in zip(rec.sensors, setup.sensor_masses, setup.location_tolerances)],
        "fs_hz": rec.fs, "n_samples": rec.n_samples, "duration_s": rec.n_samples / rec.fs,
    }


def nominal_frequencies(rec) -> np.ndarray:
    """Nominal clamped-free frequencies (Hz) with the tip body, those below the passband edge."""
    f = natural_frequencies_hz(MAX_MODES, EI=rec.beam.nominal_EI, rho_a=rec.beam.rho_a,
                               length=rec.beam.length, m_T=rec.tip.mass, J=rec.tip.rotary_inertia)
    return f[f < PASSBAND * rec.fs]


# ---------------------------------------------------------------------------- force
def _force(rec) -> dict | None:
    if rec.force is None:
        return None
    found = find_pulses(rec.force)
    main = max(found.hits, key=lambda p: abs(p.peak))
    pulses = [{"kind": "hit" if p.hit else "spike", "time_s": float(rec.time[p.peak_index]),
               "peak_N": p.peak + found.baseline, "width_samples": p.width, "width_ms": 1e3 * p.width / rec.fs,
               "after_impact_s": float(rec.time[p.peak_index] - rec.time[main.peak_index])}
              for p in found.pulses]
    return {"pulses": pulses, "hits": len(found.hits), "spikes": len(found.spikes),
            "threshold_N": found.threshold, "noise_sd_N": found.noise_sd}


def _force_channel(rec) -> list[dict]:
    if rec.force is None:
        return []
    return [{"name": rec.excitation.column, "clipping": clipping(rec.force, rec.fs)}]


# ---------------------------------------------------------------------------- channels
def _spectrum(x: np.ndarray, fs: float) -> Spectrum:
    x = np.asarray(x, float) - np.mean(x)
    window = signal.windows.hann(x.size, sym=False)
    spectrum = np.abs(np.fft.rfft(x * window)) ** 2 * 2 / (fs * np.sum(window**2))
    return Spectrum(np.fft.rfftfreq(x.size, 1 / fs), spectrum)


def noise_floor(spectrum: Spectrum, fs: float) -> float:
    """Noise-floor density (unit^2/Hz): the median over the passband / ln 2 (module docstring)."""
    band = (spectrum.frequency > 0) & (spectrum.frequency < PASSBAND * fs)
    return float(np.median(spectrum.density[band]) / np.log(2))


def _channel(rec, j: int, spectrum: Spectrum, nominal: np.ndarray) -> dict:
    sensor = rec.sensors[j]
    floor = noise_floor(spectrum, rec.fs)
    peaks = spectral_peaks(spectrum, floor, rec.fs)
    x = rec.signals[:, j]
    return {
        "name": sensor.name, "unit": SI_UNITS[sensor.quantity],
        "rms": float(np.sqrt(np.mean((x - x.mean()) ** 2))),
        "noise_floor_density": floor,
        "noise_sd": float(np.sqrt(floor * rec.fs / 2)),
        "peaks_hz": [float(f) for f in peaks],
        "mains_lines": mains_lines(rec, j, spectrum, peaks),
        "clipping": clipping(x, rec.fs),
    }


def spectral_peaks(spectrum: Spectrum, floor: float, fs: float) -> np.ndarray:
    """Frequencies (Hz, ascending) of the MAX_PEAKS highest local maxima PEAK_FACTOR above ``floor``,
    each more than SEPARATION (relative) away from every higher one that is not at a mains
    frequency (a mains line does not hide a mode next to it)."""
    band = spectrum.frequency < PASSBAND * fs
    df = spectrum.frequency[1]
    index, props = signal.find_peaks(spectrum.density[band], height=PEAK_FACTOR * floor)
    chosen: list[float] = []
    for k in index[np.argsort(props["peak_heights"])[::-1]]:
        f = float(spectrum.frequency[k])
        if all(abs(f - g) > SEPARATION * g or mains_harmonic(g, 2 * df) for g in chosen):
            chosen.append(f)
        if len(chosen) == MAX_PEAKS:
            break
    return np.sort(chosen)


def mains_lines(rec, j: int, spectrum: Spectrum, peaks: np.ndarray) -> list[dict]:
    """Peaks at a multiple of 50 or 60 Hz (within two bins) that do not decay over the record."""
    df = spectrum.frequency[1]
    span = analysed_span(rec)
    lines = []
    for f in peaks:
        harmonic = mains_harmonic(f, 2 * df)
        if harmonic is None:
            continue
        kept = line_persistence(rec.signals[:, j], span, float(f))
        if kept >= PERSISTENT:
            k, m = harmonic
            lines.append({"frequency_hz": float(k * m), "peak_hz": float(f), "harmonic": k, "mains_hz": m,
                          "amplitude_kept": kept})
    return lines


def clipping(x: np.ndarray, fs: float) -> dict | None:
    """The samples at the channel's maximum or minimum when CLIP_SAMPLES or more hold one of them
    (None: no clipping): how many, in how many flat runs, the first time, the values."""
    at = np.zeros(x.size, bool)
    for extreme in (np.max(x), np.min(x)):
        if np.count_nonzero(x == extreme) >= CLIP_SAMPLES:
            at |= x == extreme
    if not at.any():
        return None
    runs = np.count_nonzero(np.diff(np.concatenate([[False], at]).astype(np.int8)) == 1)
    return {"samples": int(at.sum()), "runs": int(runs), "first_s": float(np.argmax(at) / fs),
            "values": [float(np.min(x)), float(np.max(x))]}


# ---------------------------------------------------------------------------- modes and suggestion
def _modes(nominal: np.ndarray, channels: list[dict]) -> list[dict]:
    """Each nominal mode with its peak among every channel's (or None); mains lines are not modes.

    A peak is a mode's by ratio, never two modes': each peak is numbered by the nominal mode
    nearest it in ratio (within MODE_MATCH), and a mode two peaks claim keeps the nearer. The
    nominal frequencies are first scaled by the median ratio peak / nominal of a first such
    numbering, so that a stated modulus off by some % (which moves every frequency by the same
    ratio) does not push a high mode's peak toward the next nominal mode (modes 9 and 10 lie only
    1.24 apart); the median ignores mode 1, which a compliant clamp moves most. A nearest-peak
    match per nominal mode instead gave the last peak seen to the nominal mode above it as well.
    ``ratio`` stays peak / nominal: it judges the stated modulus."""
    mains = {line["peak_hz"] for c in channels for line in c["mains_lines"]}
    peaks = np.array(sorted({f for c in channels for f in c["peaks_hz"]} - mains))
    first = _numbered(peaks, nominal)
    scale = float(np.median([f / nominal[k] for k, f in first.items()])) if first else 1.0
    found = _numbered(peaks, scale * nominal)
    return [{"mode": k + 1, "nominal_hz": float(f), "peak_hz": found.get(k),
             "ratio": float(found[k] / f) if k in found else None} for k, f in enumerate(nominal)]


def _numbered(peaks: np.ndarray, expected: np.ndarray) -> dict[int, float]:
    """Mode index -> peak (Hz): each peak at the mode of nearest ``expected`` frequency in ratio,
    within MODE_MATCH; of two peaks at one mode, the nearer."""
    found: dict[int, float] = {}
    if not expected.size:
        return found
    for f in peaks:
        k = int(np.argmin(np.abs(np.log(f / expected))))
        off = abs(np.log(f / expected[k]))
        if abs(f / expected[k] - 1) <= MODE_MATCH and (k not in found or off < abs(np.log(found[k] / expected[k]))):
            found[k] = float(f)
    return found


def _suggestion(rec, summary: dict, i0: int) -> dict:
    """Top of the fitted band and analysis window."""
    found = [m for m in summary["modes"] if m["peak_hz"] is not None]
    nominal = summary["nominal_frequencies_hz"]
    top = DEFAULT_BAND * rec.fs
    reason = f"{DEFAULT_BAND} fs: no mode is seen in the spectrum"
    if found:
        last = found[-1]
        after = [f for f in nominal if f > last["nominal_hz"]]
        # halfway to the next nominal mode, scaled as the seen modes are
        edge = 0.5 * (last["peak_hz"] + after[0] * last["ratio"]) if after else top
        if edge < top:
            top = edge
            reason = (f"halfway from mode {last['mode']} ({last['peak_hz']:.4g} Hz), the highest seen above the "
                      f"noise, to the next nominal mode")
        else:
            reason = f"{DEFAULT_BAND} fs: modes are seen up to the DAQ passband"
    start = float(rec.time[i0])
    stop = _response_end(rec, summary["channels"], i0)
    return {"max_frequency_hz": float(top), "reason": reason, "start_s": start, "stop_s": stop}


def _response_end(rec, channels: list[dict], i0: int) -> float:
    """End (s) of the last segment where some channel's RMS exceeds END_FACTOR noise sds."""
    edges = np.linspace(i0, rec.n_samples, SEGMENTS + 1).astype(int)
    last = edges[1]
    for j, channel in enumerate(channels):
        x = rec.signals[:, j] - np.mean(rec.signals[i0:, j])
        for a, b in pairwise(edges):
            if np.sqrt(np.mean(x[a:b] ** 2)) > END_FACTOR * channel["noise_sd"]:
                last = max(last, b)
    return float(rec.time[last - 1])


# ---------------------------------------------------------------------------- text
def report_lines(summary: dict) -> list[str]:
    """What ``bayesbeam check`` prints: what it read, then what it found."""
    read = summary["read"]
    beam, tip, exc = read["beam"], read["tip"], read["excitation"]
    lines = [f"recording {summary['recording']}", "read:",
             (f"  beam: l = {beam['length_m']:g} m, rho = {beam['density_kg_m3']:g} kg/m^3, A = {beam['area_m2']:g} m^2, "
              f"I = {beam['second_moment_m4']:g} m^4, E = {beam['modulus_Pa']:g} Pa (nominal EI = {beam['EI_N_m2']:.5g} N m^2)"),
             "  tip body: " + ("none" if not (tip["m_T_kg"] or tip["J_kg_m2"])
                               else f"m_T = {tip['m_T_kg']:g} kg, J = {tip['J_kg_m2']:g} kg m^2"),
             "  excitation: " + _excitation_text(exc)]
    lines += [f"  sensor {s['name']}: {s['quantity']} at x = {s['location_m']:g} m, column {s['column']!r} ({_unit_text(s)})"
              + _stated_text(s) for s in read["sensors"]]
    stated = [f"{label} +- {value:g} {unit}" for label, value, unit in (
        ("length", beam.get("length_tolerance_m"), "m"), ("m_T", tip.get("m_T_tolerance_kg"), "kg"),
        ("J", tip.get("J_tolerance_kg_m2"), "kg m^2"), ("hammer location", exc.get("location_tolerance_m"), "m"))
        if value]
    if stated:
        lines.append("  stated tolerances: " + ", ".join(stated))
    lines += [f"  sampling: {read['n_samples']} samples at {read['fs_hz']:.6g} Hz, {read['duration_s']:.4g} s", "found:"]
    lines += _force_lines(summary["force"])
    for c in summary["channels"]:
        lines.append(f"  {c['name']}: rms {c['rms']:.3g} {c['unit']}, noise floor {c['noise_sd']:.3g} {c['unit']} "
                     f"(white-noise sd of the median spectral density), peaks at "
                     + (", ".join(f"{f:.4g}" for f in c["peaks_hz"]) + " Hz" if c["peaks_hz"] else "none"))
    lines.append("  modes (nominal clamped-free with the tip body -> its spectral peak):")
    lines += [f"    {m['mode']:>2}  {m['nominal_hz']:9.4g} Hz  -> "
              + (f"{m['peak_hz']:.4g} Hz (x{m['ratio']:.3f})" if m["peak_hz"] else "not seen")
              for m in summary["modes"]]
    lines.append("  mains lines: " + (", ".join(f"{f:g} Hz" for f in summary["mains_lines"]) or "none"))
    lines.append("  clipping: " + ("; ".join(f"{name}: {c['samples']} samples in {c['runs']} flat run(s) at its "
                                            f"extremes, first at {c['first_s']:.4g} s"
                                            for name, c in summary["clipping"].items()) or "none"))
    s = summary["suggested"]
    lines.append(f"  suggested: --max-frequency {s['max_frequency_hz']:.4g} ({s['reason']}); "
                 f"window --start {s['start_s']:.4g} --stop {s['stop_s']:.4g} (until the response sinks into the noise)")
    return lines + units_text(summary["units"])


def _unit_text(sensor: dict) -> str:
    """The sensor's unit as stated, and the SI unit it was converted to when they differ ("g -> m/s^2")."""
    stated, si = sensor.get("stated_unit"), sensor["unit"]
    return si if stated in (None, si) else f"{stated} -> {si}"


def _stated_text(sensor: dict) -> str:
    """The sensor's stated mass and position tolerance, as a suffix of its line ('' when none)."""
    mass, tolerance = sensor.get("mass_kg"), sensor.get("location_tolerance_m")
    return ((f", own mass {mass:g} kg" if mass is not None else "")
            + (f", position +- {tolerance:g} m" if tolerance else ""))


def _excitation_text(exc: dict) -> str:
    if exc["kind"] == "force":
        return f"measured force at x = {exc['location']:g} m, column {exc['column']!r} (N)"
    if exc["kind"] == "release":
        return f"release from a static tip load of {exc['tip_load']:g} N"
    return f"unmeasured tap; free decay from {exc['start']:g} s"


def _force_lines(force: dict | None) -> list[str]:
    if force is None:
        return []
    lines = [f"  force: noise sd {force['noise_sd_N']:.3g} N; pulses stand {force['threshold_N']:.3g} N off the baseline"]
    for p in force["pulses"]:
        what = "hit" if p["kind"] == "hit" else "isolated spike (not a hit: left out of the force window)"
        lines.append(f"    {what} at {p['time_s']:.4g} s ({p['after_impact_s']:+.4g} s from the impact): "
                     f"peak {p['peak_N']:.3g} N, {p['width_samples']} samples = {p['width_ms']:.3g} ms above the threshold")
    if force["hits"] > 1:
        lines.append(f"    {force['hits']} hits: a second hit while the beam rings; every hit stays in the force window")
    return lines
