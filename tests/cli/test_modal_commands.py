"""The modal commands: ema on the paper's data, era -> ema on a shipped recording, UFF in and out."""

import csv
import json
from pathlib import Path

import numpy as np
import pytest
import pyuff

from bayesbeam.cli import main
from bayesbeam.io import load_recording
from bayesbeam.modal.ema import ema_from_table, read_modal_table

ROOT = Path(__file__).resolve().parents[2]
HAMMER = ROOT / "data" / "examples" / "paper_q3_hammer"
PAPER_TABLE = ROOT / "studies" / "paper_reproduction" / "modal_table_used.csv"  # Table 3 + inferred zeta_1
PUBLISHED = ROOT / "data" / "paper" / "table4_damping_estimates.csv"
PAPER_BEAM = """\
[beam]
length = 1.0
density = 1710.0
area = 0.597e-3
second_moment = 1.64e-9
modulus = 2.68e10
"""


@pytest.fixture
def paper_beam(tmp_path):
    path = tmp_path / "beam.toml"
    path.write_text(PAPER_BEAM)
    return path


def test_ema_reproduces_the_papers_table4(tmp_path, paper_beam, capsys):
    out = tmp_path / "ema"
    assert main(["ema", str(PAPER_TABLE), "--beam", str(paper_beam), "--out", str(out)]) == 0
    assert "E = 2.6851e+10 Pa" in capsys.readouterr().out
    doc = json.loads((out / "ema.json").read_text())
    # Eq. (38) prints 2.68e10 Pa; the study reproduces 2.6851e10 with Table 2's rounded
    # eigenvalues, and the exact ones change E by less than 0.01 %.
    assert doc["E"] == pytest.approx(2.6851e10, rel=1e-4)
    assert [row["modes"] for row in doc["successive"]] == [list(range(1, k + 1)) for k in range(2, 10)]
    with PUBLISHED.open() as fh:
        published = list(csv.DictReader(fh))
    for row, paper in zip(doc["successive"], published):
        pairs = [(row["viscous_only"]["gamma"], paper["viscous_only_gamma"]),
                 (row["strain_only"]["c_d"], float(paper["strain_only_c_d_x1e6"]) * 1e6),
                 (row["both"]["c_d"], float(paper["both_c_d_x1e6"]) * 1e6)]
        if paper["modes"] != "1-3":  # the study shows 1-3 both.gamma (printed 0.2014) is a misprint
            pairs.append((row["both"]["gamma"], paper["both_gamma"]))
        # Table 3's 3-digit damping ratios limit the reproduction to 1.3 % of an entry
        # (studies/paper_reproduction); observed differences are at most 0.31 %.
        for ours, printed in pairs:
            assert ours == pytest.approx(float(printed), rel=0.005), paper["modes"]
    with (out / "table4.csv").open() as fh:
        rows = list(csv.DictReader(fh))
    assert rows[0]["modes"] == "1 2" and float(rows[-1]["both_c_d"]) == doc["successive"][-1]["both"]["c_d"]
    assert (out / "ema.png").stat().st_size > 10_000


def test_ema_json_is_the_library_result(tmp_path, paper_beam):
    table = tmp_path / "weighted.csv"
    table.write_text("mode,frequency_hz,damping_ratio,damping_ratio_sd\n"
                     "2,22.8,0.00218,0.0002\n1,3.64,0.00186,0.0001\n3,65.3,0.00227,0.0003\n")
    assert main(["ema", str(table), "--beam", str(paper_beam), "--out", str(tmp_path / "o")]) == 0
    doc = json.loads((tmp_path / "o" / "ema.json").read_text())
    expected = ema_from_table([3.64, 22.8, 65.3], [0.00186, 0.00218, 0.00227], sd=[1e-4, 2e-4, 3e-4],
                              length=1.0, rho_a=1710.0 * 0.597e-3, second_moment=1.64e-9).to_dict()
    assert {k: doc[k] for k in expected} == expected and doc["weighted"]
    assert doc["units"]["gamma"] == "N s/m^2" and doc["units"]["E"] == "Pa"


@pytest.mark.parametrize(
    "table, toml, fragment",
    [
        ("mode,frequency_hz,damping_ratio\n1,3.64,1.86\n2,22.8,2.18\n", PAPER_BEAM, "line 2"),
        ("mode,frequency_hz,damping_ratio\n1,3.64,0.00186\n", PAPER_BEAM, "at least two modes"),
        ("mode,frequency_hz,damping_ratio\n1,3.64,0.00186\n2,22.8,0.00218\n",
         PAPER_BEAM + "[tip]\nmass = 0.05\n", "[tip]: a tip body"),
        ("mode,frequency_hz,damping_ratio\n1,3.64,0.00186\n2,22.8,0.00218\n",
         PAPER_BEAM.replace("density = 1710.0", "density = -1.0"), "[beam] .density"),
    ],
)
def test_ema_refusals_exit_2_naming_file_place_and_fix(tmp_path, capsys, table, toml, fragment):
    (tmp_path / "modes.csv").write_text(table)
    (tmp_path / "beam.toml").write_text(toml)
    code = main(["ema", str(tmp_path / "modes.csv"), "--beam", str(tmp_path / "beam.toml"),
                 "--out", str(tmp_path / "o")])
    err = capsys.readouterr().err
    assert code == 2 and fragment in err and "Fix" in err and str(tmp_path) in err
    assert not (tmp_path / "o" / "ema.json").exists()


def test_era_chains_into_ema_and_writes_uff(tmp_path, capsys):
    out = tmp_path / "modal"
    assert main(["era", str(HAMMER), "--out", str(out), "--uff"]) == 0
    printed = capsys.readouterr().out
    assert "ERA order 28" in printed
    table = read_modal_table(out / "modal.csv")
    truth = json.loads((HAMMER / "truth.json").read_text())["modal_table_true_linear"]
    # The shipped example (q3 damping, 2 % noise on the tip accelerometer): all nine modes
    # below 0.40 fs. A lone accelerometer weighs modes 1-2 by w^2 and leaves them
    # noise-limited (tests/modal/simulated.py): observed errors 8e-4 in f and 13 % in zeta
    # there, so they get 2e-3 in f and no zeta check. Modes 3-9: observed 7e-6 in f and
    # 0.7 % in zeta; bounds 1e-4 and 5 %.
    assert table.modes == tuple(range(1, 10))
    np.testing.assert_allclose(table.frequency_hz[:2], truth["f_natural_hz"][:2], rtol=2e-3)
    np.testing.assert_allclose(table.frequency_hz[2:], truth["f_natural_hz"][2:9], rtol=1e-4)
    np.testing.assert_allclose(table.damping_ratio[2:], truth["zeta"][2:9], rtol=0.05)
    doc = json.loads((out / "era.json").read_text())
    assert [m["mode"] for m in doc["modes"]] == list(range(1, 10))
    assert doc["modes"][0]["shape"] == [{"sensor": "accel_tip", "re": 1.0, "im": 0.0}]
    assert (out / "stabilization.png").stat().st_size > 10_000
    rec = load_recording(HAMMER)
    uff_sets = pyuff.UFF(str(out / "recording.uff")).read_sets()
    np.testing.assert_allclose(uff_sets[-1]["data"], rec.signals[:, 0], rtol=1e-11)
    modes = pyuff.UFF(str(out / "modes.uff")).read_sets()
    assert [s["mode_n"] for s in modes if s["type"] == 55] == list(range(1, 10))
    ema = tmp_path / "ema"
    assert main(["ema", str(out / "modal.csv"), "--beam", str(HAMMER / "beam.toml"), "--out", str(ema)]) == 0
    assert json.loads((ema / "ema.json").read_text())["modes"] == list(range(1, 10))


def test_era_refusals_exit_2(tmp_path, capsys):
    assert main(["era", str(HAMMER), "--out", str(tmp_path / "o"), "--start", "5.0"]) == 2
    assert "--start/--stop" in capsys.readouterr().err
    assert main(["era", str(HAMMER), "--out", str(tmp_path / "o"), "--order", "0"]) == 2
    assert "--order 0" in capsys.readouterr().err
