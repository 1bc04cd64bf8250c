"""``bayesbeam check`` on the shipped examples, the real record and broken copies.

The facts asserted come from outside the survey: the paper's clamped-free eigenvalues (Table 2),
the example generator's truth.json (its independent simulator's modal table, noise sds and pulse),
the real record's source and README (its peaks and a 2 x 60 Hz line), and signals planted here.
"""
import json
import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from bayesbeam.cli import main
from bayesbeam.io import load_recording, write_recording

ROOT = Path(__file__).resolve().parents[2]
EXAMPLES = ROOT / "data" / "examples"
HAMMER = EXAMPLES / "paper_q3_hammer"
RELEASE = EXAMPLES / "alu_q1_release"
REAL = ROOT / "data" / "real" / "ds4-cantilever-freedecay" / "recording"
TABLE2 = ROOT / "data" / "paper" / "table2_eigenvalues.csv"


def check(recording, out, capsys):
    """Run the command; (exit code, check.json or None, printed text)."""
    code = main(["check", str(recording), "--out", str(out)])
    text = capsys.readouterr()
    summary = json.loads((out / "check.json").read_text()) if (out / "check.json").exists() else None
    return code, summary, text.out + text.err


def truth(directory):
    return json.loads((directory / "truth.json").read_text())


def test_paper_hammer_example(tmp_path, capsys):
    """Nominal frequencies: (beta l)^2 / (2 pi l^2) sqrt(E I / rho A) with Table 2's beta l, printed
    to 3 decimals (relative error <= 3e-4, doubled by the square: 1e-3). Spectral peaks: within one
    bin (0.25 Hz in 4 s) of the generator's damped frequencies, the peak bin being within half a bin
    unless noise lifts its neighbour. Noise floor: within 10 % of the generator's sensor noise sd
    (the median of ~3000 periodogram bins scatters by ~3 %, the modes' skirts lift it a little).
    The hit: at the half-sine's centre within one sample; no spike, no mains line, no clipping."""
    code, summary, text = check(HAMMER, tmp_path / "out", capsys)
    assert code == 0
    rec, known = load_recording(HAMMER), truth(HAMMER)
    beta_l = np.loadtxt(TABLE2, delimiter=",", skiprows=1)[:5, 1]
    paper = beta_l**2 / (2 * np.pi) * math.sqrt(rec.beam.nominal_EI / rec.beam.rho_a)
    np.testing.assert_allclose(summary["nominal_frequencies_hz"][:5], paper, rtol=1e-3)
    found = [m["peak_hz"] for m in summary["modes"][:5]]
    np.testing.assert_allclose(found, known["modal_table_true_linear"]["f_damped_hz"][:5], atol=0.25)
    (channel,) = summary["channels"]
    assert channel["noise_sd"] == pytest.approx(known["noise"]["accel_tip_sigma"], rel=0.10)
    force = summary["force"]
    assert force["hits"] == 1 and force["spikes"] == 0
    pulse = known["excitation"]
    assert force["pulses"][0]["time_s"] == pytest.approx(pulse["t0"] + pulse["width"] / 2, abs=1 / rec.fs)
    assert force["noise_sd_N"] == pytest.approx(known["noise"]["force_sigma_N"], rel=0.10)
    assert summary["mains_lines"] == [] and summary["clipping"] == {}
    assert 0 < summary["suggested"]["max_frequency_hz"] < rec.fs / 2
    assert "8192 samples at 2048 Hz" in text and "hit at" in text and "--max-frequency" in text
    assert sorted(p.name for p in (tmp_path / "out").iterdir()) == ["check.json", "quicklook.png"]
    assert (tmp_path / "out" / "quicklook.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_release_example_with_tip_body(tmp_path, capsys):
    """The aluminium strip with its 50 g tip block: each seen peak within one bin (1/3 Hz in 3 s) of
    the generator's damped frequencies; the nominal modes, computed with the nominal E = 0.95 E_true,
    are the true ones times sqrt(0.95) (frequencies scale as sqrt(EI); damping moves them < 1e-4),
    checked to 1e-3. Both channels' noise floors within 10 % of the generator's noise sds."""
    code, summary, text = check(RELEASE, tmp_path / "out", capsys)
    assert code == 0
    known = truth(RELEASE)
    true_f = np.array(known["modal_table_true_linear"]["f_damped_hz"][:4])
    np.testing.assert_allclose(summary["nominal_frequencies_hz"][:4], true_f * math.sqrt(known["E_nominal_over_true"]),
                               rtol=1e-3)
    np.testing.assert_allclose([m["peak_hz"] for m in summary["modes"][:4]], true_f, atol=1 / 3)
    for channel in summary["channels"]:
        assert channel["noise_sd"] == pytest.approx(known["noise"][f"{channel['name']}_sigma"], rel=0.10)
    assert summary["force"] is None and "m_T = 0.05 kg" in text and "release from a static tip load" in text
    assert summary["suggested"]["max_frequency_hz"] < 0.4 * summary["read"]["fs_hz"]


def test_root_compliance_example(tmp_path, capsys):
    """The concealed root spring lowers every mode; the survey still pairs each generator mode with a
    peak within one bin (0.25 Hz)."""
    directory = EXAMPLES / "paper_rootcomp_hammer"
    code, summary, _ = check(directory, tmp_path / "out", capsys)
    assert code == 0
    true_f = truth(directory)["modal_table_true_linear"]["f_damped_hz"][:5]
    np.testing.assert_allclose([m["peak_hz"] for m in summary["modes"][:5]], true_f, atol=0.25)


def test_real_record(tmp_path, capsys):
    """ds4: its source lists 6.62, 41.4 and 117.5 Hz; the README's own spectrum puts them at 6.64,
    41.45, 116.8 Hz (1.5 % covers both) and finds a small line at 120.0 Hz, probably 2 x 60 Hz mains.
    The analysis starts where the free decay does (beam.toml start = 1.12 s)."""
    code, summary, text = check(REAL, tmp_path / "out", capsys)
    assert code == 0
    found = np.array([m["peak_hz"] for m in summary["modes"][:3]])
    np.testing.assert_allclose(found, [6.62, 41.4, 117.5], rtol=0.015)
    assert summary["mains_lines"] == [120.0]
    assert summary["suggested"]["start_s"] == pytest.approx(1.12, abs=1 / summary["read"]["fs_hz"])
    assert "unmeasured tap; free decay from 1.12 s" in text and "mains lines: 120 Hz" in text


def planted(tmp_path, **changes):
    rec = load_recording(HAMMER)
    return write_recording(replace(rec, extra={}, **changes), tmp_path / "planted")


def test_planted_double_hit_and_spike(tmp_path, capsys):
    """A second hit 0.300 s after the impact (Gaussian, sd 1 ms, 20 N: pulse-shaped) and a lone
    one-sample 10 N spike at 3.5 s: two hits, the second within a sample of 0.300 s after the
    first; one spike at 3.5 s, reported as not a hit."""
    rec = load_recording(HAMMER)
    t_hit = rec.time[np.argmax(rec.force)] + 0.300
    force = rec.force + 20 * np.exp(-0.5 * ((rec.time - t_hit) / 1e-3) ** 2)
    spike = int(3.5 * rec.fs)
    force[spike] += 10.0
    code, summary, text = check(planted(tmp_path, force=force), tmp_path / "out", capsys)
    assert code == 0
    pulses = summary["force"]["pulses"]
    hits = [p for p in pulses if p["kind"] == "hit"]
    spikes = [p for p in pulses if p["kind"] == "spike"]
    assert len(hits) == 2 and hits[1]["after_impact_s"] == pytest.approx(0.300, abs=1 / rec.fs)
    assert len(spikes) == 1 and spikes[0]["time_s"] == pytest.approx(rec.time[spike])
    assert "2 hits" in text and "isolated spike" in text


def test_planted_mains_line_and_clipping(tmp_path, capsys):
    """A 50 Hz sinusoid of the sensor noise's amplitude (its periodogram peak stands ~1000 x the
    floor) is found as a mains line, and no beam mode is called one; the accelerometer clipped at
    +-300 m/s^2 (its early ring-down reaches 600) is reported as clipping."""
    rec = load_recording(HAMMER)
    accel = rec.signals[:, 0] + 1.0 * np.sin(2 * np.pi * 50.0 * rec.time)
    clipped = np.clip(accel, -300.0, 300.0)
    code, summary, text = check(planted(tmp_path, signals=clipped[:, None]), tmp_path / "out", capsys)
    assert code == 0
    assert summary["mains_lines"] == [50.0]
    assert summary["clipping"]["accel_tip"]["samples"] >= 3
    assert "mains lines: 50 Hz" in text and "accel_tip:" in text.split("clipping:")[1]


@pytest.mark.parametrize("breakage, named", [
    (lambda text: text.replace(",", "|"), "cannot tell how the columns are separated"),
    (lambda text: "\n".join(text.splitlines()[:4]) + "\n", "data row(s)"),
])
def test_broken_copies_exit_2(tmp_path, capsys, breakage, named):
    """A '|'-separated CSV and a 3-sample record: exit 2, the error names the file and the fault,
    and nothing is written."""
    broken = tmp_path / "broken"
    broken.mkdir()
    (broken / "beam.toml").write_text((HAMMER / "beam.toml").read_text())
    (broken / "recording.csv").write_text(breakage((HAMMER / "recording.csv").read_text()))
    code, summary, text = check(broken, tmp_path / "out", capsys)
    assert code == 2 and summary is None
    assert "recording.csv" in text and named in text and "Fix:" in text
    assert not (tmp_path / "out").exists()


def test_zero_force_channel_exits_2(tmp_path, capsys):
    rec = load_recording(HAMMER)
    code, _, text = check(planted(tmp_path, force=np.zeros(rec.n_samples)), tmp_path / "out", capsys)
    assert code == 2 and 'column "force"' in text and "zero in every sample" in text


def test_out_refused_when_not_empty_and_default_name(tmp_path, capsys, monkeypatch):
    """A non-empty --out is refused (exit 2) unless --overwrite; without --out the folder is
    check_<recording folder name> in the working directory."""
    out = tmp_path / "out"
    out.mkdir()
    (out / "keep.txt").write_text("x")
    assert main(["check", str(HAMMER), "--out", str(out)]) == 2
    assert "--overwrite" in capsys.readouterr().err
    monkeypatch.chdir(tmp_path)
    assert main(["check", str(RELEASE)]) == 0
    assert (tmp_path / "check_alu_q1_release" / "check.json").is_file()
