"""The figures' axes and the truth they mark: tick labels without offset text, truth.json read."""
import json
from types import SimpleNamespace

import numpy as np
import pytest

from bayesbeam.report.plots import corner_overlay, plt
from bayesbeam.report.truth import recording_truths


def test_corner_ticks_carry_no_offset_text_and_say_the_tick_values():
    """A posterior of EI 44.28 +- 0.002 N m^2 (and cdI near 7e-5): matplotlib would write its ticks
    as offsets from 44.28 with a '+4.428e1' beside the axis, under corner's axis label; the ticks
    are written out instead, each to within a millionth of the tick spacing."""
    rng = np.random.default_rng(1)
    draws = np.column_stack([44.28 + 0.002 * rng.standard_normal(4000), 7e-5 * (1 + 0.01 * rng.standard_normal(4000))])
    fig = corner_overlay([draws], ["EI", "cdI"], ["q1"], units={"EI": "N m^2", "cdI": "N m^2 s"})
    fig.canvas.draw()
    for ax in fig.axes:
        for axis in (ax.xaxis, ax.yaxis):
            assert axis.get_offset_text().get_text() == ""
            labels = [t for t in axis.get_ticklabels() if t.get_text()]
            ticks = axis.get_ticklocs()
            for label in labels:
                value = float(label.get_text().replace("\u2212", "-"))
                assert min(abs(ticks - value)) <= 1e-6 * np.min(np.diff(ticks)), label.get_text()
    assert [t.get_text() for t in fig.axes[2].get_xticklabels() if t.get_text()]      # EI's ticks are shown
    plt.close(fig)


def test_truths_are_read_from_the_truth_json_beside_the_recording(tmp_path):
    """EI from beam_true, the damping parameters, and a concealed effect's value under its one
    parameter (root_compliance -> k_theta); nothing for a recording without a truth.json."""
    (tmp_path / "truth.json").write_text(json.dumps({"beam_true": {"EI": 43.952}, "damping": {"gamma": 0.3, "cdI": 7e-5},
                                                     "effect_parameters": {"root_compliance": 3500.0}}))
    assert recording_truths(SimpleNamespace(source=tmp_path)) == pytest.approx(
        {"EI": 43.952, "gamma": 0.3, "cdI": 7e-5, "k_theta": 3500.0}, rel=0)
    assert recording_truths(SimpleNamespace(source=tmp_path / "elsewhere")) == {}
    assert recording_truths(SimpleNamespace(source=None)) == {}


def test_truths_keyed_by_parameter_and_a_top_level_EI_are_read_too(tmp_path):
    """The study recordings' truth.json: EI at the top, an effect's parameters under their own names
    (an attached body's f_a, m_a, zeta_a, x_a); a simulator's own names (k_a) are no fitted
    parameter's truth and are left out."""
    (tmp_path / "truth.json").write_text(json.dumps({"EI": 44.28, "damping": {"gamma": 0.3},
                                                     "effect_parameters": {"f_a": 45.0, "m_a": 0.03, "k_a": 2448.0}}))
    assert recording_truths(SimpleNamespace(source=tmp_path)) == pytest.approx(
        {"EI": 44.28, "gamma": 0.3, "f_a": 45.0, "m_a": 0.03}, rel=0)
