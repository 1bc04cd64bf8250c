r"""Units from physics: is each channel in the unit beam.toml says, judged before anything is fitted.

A channel exported in g and read as m/s^2 is 9.81x small, and nothing in its spectrum looks wrong.
The nominal beam (rho A, l, tip body) fixes the size of the response, mode by mode, in a way that
neither the unknown damping nor the nominal E moves:

* the mass-normalised mode shapes phi_m(x) of the clamped-free beam with its tip body depend on
  rho A, l, m_T and J only (the closed form ``phi = (cosh - cos) + B/A (sinh - sin)`` of
  :mod:`bayesbeam.modal.eigen`, normalised so that int rho A phi^2 + m_T phi(l)^2 + J phi'(l)^2 = 1);
* a measured force: the receptance near mode m is ``A_m / (s - p)(s - conj p)`` with the modal
  constant ``A_m = phi_m(x_f) phi_m(x_s)``; its residue at the pole p, ``A_m / (2 i Im p)``, is
  what a one-mode rational fraction fitted around the peak returns, whatever the damping (the
  peak's height goes as 1/zeta, the residue does not). A sensor reading the n-th derivative of the
  deflection multiplies the residue by p^n, which is divided out;
* a release from the static tip load P: mode m starts at ``P phi_m(l) / omega_m^2`` (the static
  deflection's modal expansion), a decaying cosine whose spectrum has the residue half that
  amplitude; omega_m is the fitted pole's, so the nominal E does not enter;
* a free decay: the modal amplitudes are unknown, but every channel rings with the same ones, so
  the channels' residues at one mode stand as the mode shape at their positions (times p^n).

Every spectrum (the force's too) is taken under an exponential window exp(-t / tau): that is the transfer
function at s + 1/tau, which moves the poles and leaves their residues unchanged, and lets a record
that has not died out be fitted as one that has.

The verdict compares the ratio ``measured / nominal`` at each judged mode against the units a
channel could be in (:mod:`bayesbeam.io.units`): a channel recorded in unit u when its table
states u' reads ``factor(u') / factor(u)`` of the nominal, times ``(2 pi f)^(n_u - n_u')`` when u
is of another quantity (a velocity where an acceleration is stated falls as 1/(2 pi f) across
modes, which tells it from a constant factor). What is as stated, or explained by a unit, is found
by trying as the reference the force in each force unit (or the release load; without either,
each channel in turn, as stated) and letting every channel take the unit that leaves it within
:data:`FACTOR` of the model; the reading with the fewest unexplained channels, then the fewest
units named, wins. A mode is not judged at a sensor (or hammer) near one of its nodes (:data:`NODE`).

It sits in ``checks``: it uses the reader's unit table (io), the impact window (response), the
eigenvalues and the rational-fraction fit (modal), and nothing above.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.fft import next_fast_len

from bayesbeam.io.units import parse_unit, units_of
from bayesbeam.modal.eigen import tip_body_betas
from bayesbeam.modal.frf import fit_rational_fraction
from bayesbeam.response.linear import ORDERS
from bayesbeam.response.signals import impact_window

#: a channel is as stated when its ratio to the nominal model lies within this factor over the judged
#: modes (the RMS of its log): the modal constant does not see E at all, and the mode shapes
#: move by less than this for what beam.toml may leave out (unstated sensor masses of a few % of the
#: beam's mass, a compliant clamp: a pinned root moves the mass-normalised tip amplitude of mode 1
#: by 13 %), so the factor leaves room for the fits and the sensors' positions; a unit error is
#: 4.45 (lbf), 9.81 (g), 1000 (mm) or 2 pi f (30-300 at a 5-50 Hz mode), all beyond it
FACTOR = 2.0
#: modes judged: the first this many seen in the spectrum (the closed form is exact to ~1e-9 there)
MAX_MODES = 4
#: a (channel, mode) is not judged where the channel (or the hammer) stands at less than this
#: fraction of the mode shape's largest value: there, a position 1 cm off moves mode m's ratio by
#: up to ~5 % times beta_m l (55 % at mode 4), and closer to a node by more than FACTOR allows
NODE = 0.2
#: the exponential window's time constant is the analysed segment's duration over this (the
#: response is down by e^-5 = 0.7 % at its end, so the cut leaves the residue within ~1 %)
WINDOW_DECAYS = 5.0
#: the fitted band reaches this relative distance either side of the peak (modes lie >= 1.4x apart
#: at modes 4-5 of a bare cantilever, 2.8x at modes 1-2), and halfway to a neighbouring mode at most
BAND = 0.2
#: a fitted band needs this many spectral lines (the zero-padded spectrum has 4 per bin)
MIN_LINES = 16
#: the fitted pole must lie this close to the peak (relative), its windowed damping ratio below the
#: second number: otherwise the fit found noise or a neighbour, and the mode is not judged
POLE_MATCH, MAX_WINDOWED_ZETA = 0.05, 0.3


# ---------------------------------------------------------------------------- nominal modes
@dataclass(frozen=True)
class Modes:
    """Mass-normalised clamped-free mode shapes with the tip body (units 1/sqrt(kg)): ``shape(x)``."""

    betas: np.ndarray     # beta_m l, dimensionless
    ratios: np.ndarray    # B/A of phi = A (cosh - cos) + B (sinh - sin)
    scales: np.ndarray    # A, 1/sqrt(kg)
    length: float

    def shape(self, x) -> np.ndarray:
        """phi_m(x), shape (n_modes, len(x)); x in m from the clamp."""
        bx = self.betas[:, None] * np.atleast_1d(np.asarray(x, float))[None, :] / self.length
        r = self.ratios[:, None]
        return self.scales[:, None] * (np.cosh(bx) - np.cos(bx) + r * (np.sinh(bx) - np.sin(bx)))

    def slope(self, x) -> np.ndarray:
        """phi_m'(x), 1/(m sqrt(kg))."""
        bx = self.betas[:, None] * np.atleast_1d(np.asarray(x, float))[None, :] / self.length
        r = self.ratios[:, None]
        return (self.scales * self.betas / self.length)[:, None] * (
            np.sinh(bx) + np.sin(bx) + r * (np.cosh(bx) - np.cos(bx)))

    def largest(self) -> np.ndarray:
        """max_x |phi_m(x)| over the beam, per mode."""
        return np.max(np.abs(self.shape(np.linspace(0.0, self.length, 401))), axis=1)


def nominal_modes(rec, n: int) -> Modes:
    """The first ``n`` modes of ``rec``'s nominal beam with its tip body (module docstring)."""
    rho_a, length, m_T, J = rec.beam.rho_a, rec.beam.length, rec.tip.mass, rec.tip.rotary_inertia
    b = tip_body_betas(n, rho_a=rho_a, length=length, m_T=m_T, J=J)
    mu = m_T / (rho_a * length)
    c, s, C, S = np.cos(b), np.sin(b), np.cosh(b), np.sinh(b)
    # the shear condition at the tip, EI phi''' = -m_T omega^2 phi; its denominator is > 0 for b > 0
    ratios = -((S - s) + mu * b * (C - c)) / ((C + c) + mu * b * (S - s))
    unit = Modes(b, ratios, np.ones_like(b), length)
    nodes, weights = np.polynomial.legendre.leggauss(96)
    x = 0.5 * length * (nodes + 1)
    mass = (rho_a * 0.5 * length * np.sum(weights * unit.shape(x) ** 2, axis=1)
            + m_T * unit.shape(length)[:, 0] ** 2 + J * unit.slope(length)[:, 0] ** 2)
    return Modes(b, ratios, 1.0 / np.sqrt(mass), length)


# ---------------------------------------------------------------------------- measured residues
def _spectra(rec) -> tuple[np.ndarray, np.ndarray]:
    """(frequency Hz, transfer (n_f, n_sensors)) under the exponential window, zero-padded 4x: the
    response over the force for kind = "force", else the response's Laplace transform at i omega
    + 1/tau (the DFT times dt), from the release (t = 0) or the free decay's start."""
    i0 = _start(rec)
    n = rec.n_samples - i0
    tau = n / rec.fs / WINDOW_DECAYS
    window = np.exp(-np.arange(n) / rec.fs / tau)
    x = np.array(rec.signals[i0:], float)
    if rec.excitation.kind == "free_decay":
        x = x - x.mean(axis=0)
    n_fft = next_fast_len(4 * n)
    X = np.fft.rfft(x * window[:, None], n_fft, axis=0) / rec.fs
    if rec.excitation.kind == "force":
        f = (rec.force - np.median(rec.force)) * impact_window(rec.force)
        X = X / (np.fft.rfft(f * window, n_fft) / rec.fs)[:, None]
    return np.fft.rfftfreq(n_fft, 1 / rec.fs), X


def _start(rec) -> int:
    if rec.excitation.kind == "free_decay":
        return int(np.searchsorted(rec.time, rec.excitation.start))
    if rec.excitation.kind == "release":
        return int(np.searchsorted(rec.time, 0.0))
    return 0


def residue(frequency: np.ndarray, transfer: np.ndarray, peak_hz: float, band: tuple[float, float]):
    """(pole p in rad/s, residue at p) of a one-mode rational fraction fitted to ``transfer`` over
    ``band`` (Hz) around ``peak_hz``; None when the band is too narrow or the pole strays (POLE_MATCH,
    MAX_WINDOWED_ZETA)."""
    inside = (frequency > band[0]) & (frequency <= band[1])
    if np.count_nonzero(inside) < MIN_LINES or not np.all(np.isfinite(transfer[inside])):
        return None
    fit = fit_rational_fraction(frequency, transfer, 1, band=band)
    poles = np.roots(fit.denominator[::-1])
    poles = poles[poles.imag > 0]
    if poles.size == 0:
        return None
    p = poles[np.argmin(np.abs(np.abs(poles) - peak_hz * 2 * np.pi / fit.omega_scale))]
    d_den = np.polyval(np.polyder(fit.denominator[::-1]), p)
    r = fit.omega_scale * np.polyval(fit.numerator[::-1], p) / d_den
    p = p * fit.omega_scale
    if abs(abs(p) / (2 * np.pi) / peak_hz - 1) > POLE_MATCH or -p.real / abs(p) > MAX_WINDOWED_ZETA:
        return None
    return p, r


def _bands(peaks: list[float]) -> list[tuple[float, float]]:
    """Each peak's fitted band: BAND either side, but no further than halfway (geometric) to the
    neighbouring peaks."""
    out = []
    for k, f in enumerate(peaks):
        lo, hi = f * (1 - BAND), f * (1 + BAND)
        if k > 0:
            lo = max(lo, np.sqrt(f * peaks[k - 1]))
        if k + 1 < len(peaks):
            hi = min(hi, np.sqrt(f * peaks[k + 1]))
        out.append((lo, hi))
    return out


# ---------------------------------------------------------------------------- observations
@dataclass
class Observations:
    """log(measured / nominal) per (channel, judged mode), NaN where not judged; frequencies in Hz.

    ``absolute``: a force or a release load sets the scale (the reference channel reads 0 at every
    mode); otherwise only the channels' differences at each mode mean something."""

    modes: list[int]
    frequency_hz: np.ndarray
    log_ratio: np.ndarray     # (n_sensors, n_modes)
    absolute: bool


def observe(rec, summary: dict) -> Observations:
    """Fit each channel's residue at each judged mode of the survey ``summary`` and set it against
    the nominal model (module docstring)."""
    seen = [m for m in summary["modes"] if m["peak_hz"] is not None][:MAX_MODES]
    absolute = rec.excitation.kind != "free_decay"
    out = np.full((len(rec.sensors), len(seen)), np.nan)
    if not seen:
        return Observations([], np.zeros(0), out, absolute)
    index = [m["mode"] - 1 for m in seen]
    peaks = [m["peak_hz"] for m in seen]
    modes = nominal_modes(rec, max(index) + 1)
    phi = modes.shape([s.location for s in rec.sensors])[index]            # (n_modes, n_sensors)
    hammer = rec.excitation.location if rec.excitation.kind == "force" else rec.beam.length
    phi_f = modes.shape(hammer)[index, 0]       # the hammer's point, or the tip a release loads
    largest = modes.largest()[index, None]
    usable = (np.abs(phi) >= NODE * largest) & (np.abs(phi_f)[:, None] >= NODE * largest)
    frequency, transfer = _spectra(rec)
    for j, sensor in enumerate(rec.sensors):
        own = summary["channels"][j]["peaks_hz"]
        for k, (f, band) in enumerate(zip(peaks, _bands(peaks))):
            if not usable[k, j] or not any(abs(g - f) <= POLE_MATCH * f for g in own):
                continue
            fitted = residue(frequency, transfer[:, j], f, band)
            if fitted is not None:
                measured, nominal = _amplitudes(rec, *fitted, ORDERS[sensor.quantity], phi[k, j], phi_f[k])
                if measured > 0 and nominal > 0:
                    out[j, k] = np.log(measured / nominal)
    return Observations([m["mode"] for m in seen], np.array(peaks), out, absolute)


def _amplitudes(rec, p: complex, r: complex, order: int, phi_s: float, phi_f: float) -> tuple[float, float]:
    """(measured, nominal) size of one mode at one sensor from the fitted pole p (rad/s, windowed:
    its imaginary part is the damped omega_m) and residue r (module docstring): the modal constant
    for a force (phi_f at the hammer), the initial modal deflection for a release (phi_f at the
    tip), the mode's amplitude at the sensor for a free decay (its nominal: phi_s alone)."""
    deflection = abs(r / p**order)              # the residue of the deflection
    if rec.excitation.kind == "force":
        return deflection * 2 * p.imag, abs(phi_s * phi_f)
    if rec.excitation.kind == "release":
        return 2 * deflection, abs(phi_s * phi_f * rec.excitation.tip_load) / p.imag**2
    return 2 * deflection, abs(phi_s)


# ---------------------------------------------------------------------------- readings
@dataclass(frozen=True)
class Reading:
    """What a channel holds when it is in ``unit`` (a symbol of :mod:`bayesbeam.io.units`) of
    ``quantity``: the ratio measured / nominal is ``factor (2 pi f)^power``."""

    unit: str
    quantity: str
    factor: float
    power: int

    def log_ratio(self, frequency_hz: np.ndarray) -> np.ndarray:
        return np.log(self.factor) + self.power * np.log(2 * np.pi * frequency_hz)


AS_STATED = Reading("as stated", "", 1.0, 0)
#: the quantities a channel may hold (a force is read only as a force)
_MOTION = ("displacement", "velocity", "acceleration")


def _stated_factor(quantity: str, unit: str | None) -> float:
    """SI per stated unit: the factor the reader applied (1 when no unit is stated, or one of
    another quantity: the reader refuses those)."""
    stated = parse_unit(unit)
    return stated.factor if stated is not None and stated.quantity == quantity else 1.0


def readings(quantity: str, unit: str | None = None) -> list[Reading]:
    """Every way a channel stated as ``quantity`` in ``unit`` (None: SI) could be recorded instead:
    another unit of it, or another quantity (a force: another force unit)."""
    stated = _stated_factor(quantity, unit)
    out = []
    for other in units_of("force") if quantity == "force" else units_of(*_MOTION):
        if other.quantity == quantity and np.isclose(other.factor, stated):
            continue
        power = ORDERS.get(other.quantity, 0) - ORDERS.get(quantity, 0)
        out.append(Reading(other.symbol, other.quantity, stated / other.factor, power))
    return out


# ---------------------------------------------------------------------------- verdict
@dataclass(frozen=True)
class Verdict:
    """One channel's reading against a reference: ``reading`` (AS_STATED, a unit, or None when no
    unit explains it), ``misfit`` (the RMS over modes of the log ratio the reading leaves), ``ratios``
    (measured / nominal per mode, NaN where not judged), the other readings that fit as well."""

    reading: Reading | None
    misfit: float
    ratios: np.ndarray
    also: tuple[Reading, ...] = ()


def judge(log_ratio: np.ndarray, frequency_hz: np.ndarray, options: list[Reading]) -> Verdict | None:
    """The channel's verdict (None: no mode judged): as stated when the RMS of its log ratios is
    within log FACTOR, else the reading that leaves it closest to the model, if within FACTOR, else
    unexplained. The RMS, not the median: a unit must explain every judged mode (in/s where m/s^2
    is stated matches g at one mode and misses the others by 10x)."""
    ok = np.isfinite(log_ratio)
    if not ok.any():
        return None
    z, f = log_ratio[ok], frequency_hz[ok]
    misfits = [float(np.sqrt(np.mean((z - r.log_ratio(f)) ** 2))) for r in [AS_STATED, *options]]
    limit = np.log(FACTOR)
    if misfits[0] <= limit:
        return Verdict(AS_STATED, misfits[0], np.exp(log_ratio))
    order = np.argsort(misfits[1:])
    fitting = [options[i] for i in order if misfits[1 + i] <= limit]
    if not fitting:
        return Verdict(None, misfits[0], np.exp(log_ratio))
    return Verdict(fitting[0], misfits[1 + order[0]], np.exp(log_ratio), tuple(fitting[1:3]))


def _cost(verdicts) -> tuple:
    """Fewest unexplained channels, then fewest units named, then the smallest misfit."""
    judged = [v for v in verdicts if v is not None]
    return (sum(v.reading is None for v in judged), sum(v.reading not in (None, AS_STATED) for v in judged),
            sum(v.misfit for v in judged))


def explain(rec, obs: Observations) -> tuple[str | None, Reading | None, list]:
    """(the reference's name, its reading, each channel's Verdict or None) of the reading with the
    lowest :func:`_cost`: the force (or release load) as stated or in another force unit when the
    scale is absolute, else each channel in turn taken as stated."""
    channels = [readings(s.quantity, getattr(s, "unit", None)) for s in rec.sensors]
    f = obs.frequency_hz
    best = None
    if obs.absolute:
        force = rec.excitation.kind == "force"
        name = rec.excitation.column if force else "tip_load"
        for ref in [AS_STATED, *(readings("force", getattr(rec.excitation, "unit", None)) if force else [])]:
            verdicts = [judge(z + ref.log_ratio(f), f, options) for z, options in zip(obs.log_ratio, channels)]
            cost = _cost(verdicts) + (ref is not AS_STATED,)
            if best is None or cost < best[0]:
                best = (cost, name, ref, verdicts)
        return best[1:]
    for k, sensor in enumerate(rec.sensors):
        verdicts = [None if j == k else judge(z - obs.log_ratio[k], f, options)
                    for j, (z, options) in enumerate(zip(obs.log_ratio, channels))]
        cost = _cost(verdicts)
        if any(v is not None for v in verdicts) and (best is None or cost < best[0]):
            best = (cost, sensor.name, AS_STATED, verdicts)
    return (None, None, [None] * len(rec.sensors)) if best is None else best[1:]


# ---------------------------------------------------------------------------- findings
BASIS = {"force": "the force gain: each channel's modal constant against phi_m(x_f) phi_m(x_s)",
         "release": "the release: each channel's modal amplitude against P phi_m(l) phi_m(x_s) / omega_m^2",
         "free_decay": "the channels against one another: their amplitude ratios at each mode against the "
                       "mode shapes' ratios"}


def unit_check(rec, summary: dict) -> dict:
    """Judge each channel's unit from the survey's ``summary`` (its "modes" and "channels"): JSON-ready
    {basis, factor, modes, frequency_hz, reference, channels: [{name, verdict, unit, quantity,
    ratios, alternatives}], force, findings: [sentences], note}. verdict is "as stated", "unit"
    (another unit or quantity: ``unit``, ``quantity``), "unexplained" or "not judged"."""
    out = {"basis": BASIS[rec.excitation.kind], "factor": FACTOR, "modes": [], "frequency_hz": [],
           "reference": None, "channels": [], "force": None, "findings": [], "note": None}
    relative = rec.excitation.kind == "free_decay"
    if relative and len(rec.sensors) < 2:
        out["basis"] = None
        out["note"] = ("not judged: one channel and no measured force or release load, so nothing sets the "
                       "response's scale")
        return out
    obs = observe(rec, summary)
    out["modes"], out["frequency_hz"] = obs.modes, [float(f) for f in obs.frequency_hz]
    reference, ref_reading, verdicts = explain(rec, obs)
    out["reference"] = reference
    against = f"the mode shapes' ratio to {reference}" if relative else "the nominal model"
    for sensor, verdict in zip(rec.sensors, verdicts):
        out["channels"].append(_channel_entry(sensor.name, verdict, reference if relative else None))
        if verdict is not None and verdict.reading is not AS_STATED:
            out["findings"].append(_finding(sensor.name, verdict, obs.modes, against))
    if ref_reading is not None and ref_reading is not AS_STATED:
        out["force"] = {"verdict": "unit", "unit": ref_reading.unit}
        out["findings"].insert(0, _force_finding(ref_reading, obs.modes))
    elif rec.excitation.kind == "force":
        out["force"] = {"verdict": "as stated", "unit": None}
    out["note"] = _note(out, relative)
    return out


def _channel_entry(name: str, verdict: Verdict | None, reference: str | None) -> dict:
    if name == reference or verdict is None:
        return {"name": name, "verdict": "reference" if name == reference else "not judged", "unit": None,
                "quantity": None, "ratios": None, "alternatives": []}
    reading = verdict.reading
    kind = "as stated" if reading is AS_STATED else "unexplained" if reading is None else "unit"
    named = reading not in (None, AS_STATED)
    return {"name": name, "verdict": kind, "unit": reading.unit if named else None,
            "quantity": reading.quantity if named else None,
            "ratios": [None if np.isnan(r) else float(r) for r in verdict.ratios],
            "alternatives": [r.unit for r in verdict.also]}


def _reads(ratios: np.ndarray, modes: list[int], against: str) -> str:
    """'reads 9.81x below ... at modes 1-3' or, when the ratio moves across modes, mode by mode."""
    judged = [(m, r) for m, r in zip(modes, ratios) if np.isfinite(r)]
    values = np.array([r for _, r in judged])
    if values.max() / values.min() < FACTOR:
        median = float(np.exp(np.median(np.log(values))))
        which = [m for m, _ in judged]
        return f"reads {_size(median)} {against} at mode{'s' * (len(which) > 1)} {_span(which)}"
    (m0, r0), *rest = judged
    return f"reads {_size(r0)} {against} at mode {m0}" + "".join(f", {_size(r)} at mode {m}" for m, r in rest)


def _size(ratio: float) -> str:
    return f"{1 / ratio:.3g}x below" if ratio < 1 else f"{ratio:.3g}x above"


def _span(modes: list[int]) -> str:
    return str(modes[0]) if len(modes) == 1 else (f"{modes[0]}-{modes[-1]}" if modes == list(range(modes[0], modes[-1] + 1))
                                                   else ", ".join(map(str, modes)))


def _finding(name: str, verdict: Verdict, modes: list[int], against: str) -> str:
    text = f"channel {name} {_reads(verdict.ratios, modes, against)}"
    reading = verdict.reading
    if reading is None:
        return (f"{text}: off by more than the factor {FACTOR:g} that nominal E, unstated masses and the clamp "
                f"allow, and no unit explains it (unexplained); check its sensitivity, its column and its location")
    also = f" (or in {' or '.join(r.unit for r in verdict.also)})" if verdict.also else ""
    if reading.power == 0:
        return f'{text}: it looks recorded in {reading.unit}{also}; state `unit = "{reading.unit}"` in its [[sensor]] table'
    trend = "grows" if reading.power > 0 else "falls"
    return (f"{text}, and the ratio {trend} as (2 pi f)^{abs(reading.power)} across modes: it looks like a "
            f"{reading.quantity} in {reading.unit}{also}; state `quantity = \"{reading.quantity}\"` and "
            f"`unit = \"{reading.unit}\"` in its [[sensor]] table")


def _force_finding(reading: Reading, modes: list[int]) -> str:
    return (f"every channel reads {1 / reading.factor:.3g}x {'above' if reading.factor < 1 else 'below'} the nominal "
            f"model at modes {_span(modes)}: the force looks recorded in {reading.unit}; state "
            f'`unit = "{reading.unit}"` in [excitation]')


def _note(out: dict, relative: bool) -> str | None:
    judged = [c for c in out["channels"] if c["verdict"] not in ("not judged", "reference")]
    if not judged:
        return ("not judged: no mode stands above the noise in a channel away from the mode's nodes"
                + (" in two channels at once" if relative else ""))
    if relative:
        return ("the channels are judged against one another only: a unit shared by all of them is not seen "
                "(no measured force or release load sets the scale)")
    return None


def report_text(units: dict) -> list[str]:
    """The lines ``bayesbeam check`` prints for the unit check."""
    head = f"  units (factor {units['factor']:g}; {units['basis'] or 'no basis'}):"
    lines = [head]
    for c in units["channels"]:
        if c["verdict"] == "reference":
            lines.append(f"    {c['name']}: the reference")
        elif c["ratios"] is None:
            lines.append(f"    {c['name']}: not judged")
        else:
            ratios = ", ".join("-" if r is None else f"{r:.3g}" for r in c["ratios"])
            named = f" -> {c['quantity']} in {c['unit']}" if c["unit"] else ""
            lines.append(f"    {c['name']}: {c['verdict']}{named} (measured / nominal at modes {units['modes']}: {ratios})")
    if units["force"] is not None:
        lines.append(f"    force: {units['force']['verdict']}" + (f" -> {units['force']['unit']}" if units["force"]["unit"] else ""))
    lines += [f"    {units['note']}"] if units["note"] else []
    return lines
