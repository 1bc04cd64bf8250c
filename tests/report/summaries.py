"""Hand-made diagnosis.json summaries for the report's and the command line's wording tests.

The wording under test (stand-ins first, shares over 100 %, what to check next) needs findings a
cheap diagnosis does not produce, so these summaries carry them directly, in diagnosis.json's
layout (bayesbeam.diagnosis.summarise): an added axial load the set-up rules out (P = 104 N where
it allows +-1.5 N), and unexplained regions at modes 1 and 2 and a line at 87 Hz.
"""
from __future__ import annotations

#: the stand-in verdict of the axial load (diagnose.stand_in's layout)
STAND_IN = {"parameter": "P", "median": 104.2, "allowed": [-1.483, 1.483], "unit": "N",
            "why": "beyond the weight of beam, tip body and stated sensors"}


def mode_row(mode, f, flags=(), frequency_error=0.0, damping_error=0.0, sensor="accel_tip", label=None) -> dict:
    """A per-mode row of a mismatch map (checks.discrepancy): errors in % of the model's; ``label``
    (default "mode <mode>") names it."""
    return {"mode": mode, "label": label or f"mode {mode}", "model_frequency_hz": f, "sensor": sensor,
            "flags": list(flags), "frequency_error_pct": frequency_error, "damping_error_pct": damping_error}


def region(note, share, mode=None, peak=None, sensor="accel_tip", band=(80.0, 90.0)) -> dict:
    """An unexplained map region (checks.discrepancy's layout)."""
    return {"band_hz": list(band), "time_s": [0.0, 1.0], "sensor": sensor, "note": note, "peak_hz": peak,
            "mode": mode, "beam_physics": True, "misfit_share": share, "practically_significant": True}


def model_entry(name, log_z, rms, flags) -> dict:
    return {"model": name, "log_evidence": log_z, "log_evidence_sd": 0.1, "rms_standardized_residual": rms,
            "flags": flags, "n_intervals": 8}


def unexplained_summary(regions=None, modes=None) -> dict:
    """A diagnosis that added an axial-load stand-in and still leaves ``regions`` unexplained
    (default: mode 1 damped more than the model (share 0.36), mode 2 low (share 3.56) and a
    decaying line at 87 Hz); ``modes``: the final map's per-mode rows."""
    modes = modes if modes is not None else [mode_row(1, 3.6, ["damping"], damping_error=40.0),
                                             mode_row(2, 22.5, ["frequency"], frequency_error=-2.0),
                                             mode_row(3, 63.0)]
    regions = regions if regions is not None else [
        region("mode 1: its damping ratio is 40% higher than the model's", 0.36, mode=1, band=(3.0, 4.0)),
        region("mode 2 is 2% low", 3.56, mode=2, band=(21.0, 24.0)),
        region("residual line at 87 Hz, away from every model mode; it decays (9% kept over the window)", 0.05,
               peak=87.0)]
    candidate = {"effect": "axial_load", "label": "axial_load", "added": True, "stand_in": STAND_IN,
                 "parameters": {"P": {"mean": 104.0, "q05": 103.0, "q50": 104.2, "q95": 105.0, "unit": "N"}},
                 "delta_log_evidence": 40.0, "delta_log_evidence_sd": 0.2, "decisive": True}
    return {"recording": "rec", "baseline": model_entry("q1", -100.0, 3.0, 20),
            "final": {**model_entry("q1+axial_load", -60.0, 2.0, 12), "parameters": {}},
            "candidates": [candidate], "added": ["axial_load"], "stand_ins": ["axial_load"],
            "final_stand_ins": {"axial_load": {**STAND_IN, "label": "axial_load"}},
            "unexplained": bool(regions), "unexplained_regions": regions, "not_beam_physics": [],
            "maps": {"final": {"modes": modes}}, "damping_recheck": None,
            "summary": "The diagnosis's own paragraph."}
