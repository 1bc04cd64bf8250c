"""The README's first-run block is what its first command prints on a fresh run.

The block is rendered from the committed studies/model_comparison/paper_q3_hammer/comparison.json
(tests/studies/test_generated_tables.py checks that text against that JSON); this test reruns the
README's own command line, parsed from its bash block (default executor, into a temporary folder),
and compares what it prints with the block:

- the same table header, the same ranking, and the same verdict with its numbers masked (the
  favoured model, the runner-up, the models stopped early, the checks' outcome);
- every model's log Z, and its ln B vs best, within TOLERANCE_SDS combined standard errors of the
  block's: |fresh - block| <= 4 x hypot(sd_block, sd_fresh), each sd taken as at least SD_FLOOR.

Why 4 sd and the floor: a log Z is the mean of independent SMC repeats and its sd their standard
error (bayesbeam/inference/evidence.py, combine_runs). Models stopped early have two repeats
(bayesbeam/comparison.py, FIRST_WAVE), so their sd is estimated from one degree of freedom and falls
below a quarter of the true standard error about one time in five (|N(0, 1)| < 0.25); the leader's
three repeats give two. The reported sd alone would fail a correct README too often. On this
recording the committed standard errors are 0.03-0.14 nats (repeats of one model spread by up to
0.20 nats, q2): flooring each sd at SD_FLOOR = 0.15 nats bounds the true standard error, so two
correct runs (independent draws at worst: a change of the random stream redraws them) differ by
more than 4 x hypot(0.15, 0.15) = 0.85 nats with probability below 1e-4, while a log Z off by
1 nat ("positive" evidence, Kass & Raftery) fails. ln B vs best is log Z minus the best's, so its sd
is hypot(sd, sd_best) on each side, as in the verdict: at least 0.21 nats, a tolerance of at least
1.2 nats. The sd column itself is not compared: two repeats do not pin it down. The probabilities
follow from the log Z.
"""
from __future__ import annotations

import contextlib
import io
import re
import shlex
from pathlib import Path

import numpy as np
import pytest

from bayesbeam.cli import main
from bayesbeam.report.markdown import read_block

ROOT = Path(__file__).resolve().parents[2]
#: the markdown whose first bash block holds the command and whose first-run block its output
README = ROOT / "README.md"
BLOCK = "first-run"
#: a difference within this many combined standard errors is the evidence's own scatter
TOLERANCE_SDS = 4.0
#: nats: the least standard error a log Z is taken to have (module docstring: why)
SD_FLOOR = 0.15
#: a number standing alone (not the 1 of q1)
_NUMBER = re.compile(r"(?<![\w.])[-+]?\d+(\.\d+)?")


def readme_command(text: str) -> list[str]:
    """The arguments of the ``bayesbeam compare`` command of the README's first bash block."""
    bash = re.search(r"```bash\n(.*?)```", text, re.DOTALL)
    assert bash, f"{README}: no ```bash block"
    commands = [part.strip() for line in bash.group(1).splitlines() for part in line.split("&&")]
    (compare,) = [c for c in commands if c.startswith("bayesbeam compare ")]
    return shlex.split(compare)[1:]


def parse_printed(text: str) -> dict:
    """The ranking table and verdict ``bayesbeam compare`` prints (bayesbeam/cli/compare.py,
    format_ranking): {"header", "rows": {model: (log Z, sd, ln B vs best, probability)},
    "ranking", "verdict"}."""
    lines = text.strip("\n").removeprefix("```text\n").splitlines()
    blank = lines.index("")
    rows = {}
    for line in lines[1:blank]:
        name, *numbers = line.split()
        rows[name] = tuple(float(x) for x in numbers)
    return {"header": lines[0], "rows": rows, "ranking": list(rows), "verdict": lines[blank + 1]}


def masked(verdict: str) -> str:
    return _NUMBER.sub("#", verdict)


def sd(value: float) -> float:
    return max(value, SD_FLOOR)


def disagreements(block: dict, fresh: dict) -> list[str]:
    """What of the fresh run differs from the block beyond the evidence's uncertainty (module
    docstring: the rule), in words; empty when they agree."""
    out = []
    for key in ("header", "ranking"):
        if block[key] != fresh[key]:
            out.append(f"{key}: README {block[key]}, fresh run {fresh[key]}")
    if masked(block["verdict"]) != masked(fresh["verdict"]):
        out.append(f"verdict: README {block['verdict']!r}, fresh run {fresh['verdict']!r}")
    best_block, best_fresh = block["rows"][block["ranking"][0]], fresh["rows"][fresh["ranking"][0]]
    for model in set(block["rows"]) & set(fresh["rows"]):
        (z0, s0, b0, _), (z1, s1, b1, _) = block["rows"][model], fresh["rows"][model]
        checks = {"log Z": (z0, z1, np.hypot(sd(s0), sd(s1))),
                  "ln B vs best": (b0, b1, np.hypot(np.hypot(sd(s0), sd(best_block[1])),
                                                    np.hypot(sd(s1), sd(best_fresh[1]))))}
        for what, (old, new, combined) in checks.items():
            if abs(new - old) > TOLERANCE_SDS * combined:
                out.append(f"{model} {what}: README {old:.2f}, fresh run {new:.2f}, more than "
                           f"{TOLERANCE_SDS:g} x {combined:.2f} nats apart")
    return out


@pytest.fixture(scope="module")
def printed(tmp_path_factory):
    """(the README's block, what its command prints), both parsed."""
    text = README.read_text(encoding="utf-8")
    args = readme_command(text)
    i = args.index("--out")
    args[i + 1] = str(tmp_path_factory.mktemp("first_run") / args[i + 1])
    stdout = io.StringIO()
    with pytest.MonkeyPatch.context() as patch, contextlib.redirect_stdout(stdout):
        patch.chdir(ROOT)  # the README runs from the repository's root: its paths are relative to it
        assert main(args) == 0, f"{README}: {shlex.join(args)} failed"
    return parse_printed(read_block(text, BLOCK, str(README))), parse_printed(stdout.getvalue())


def test_the_readme_runs_the_studys_command():
    """The block is rendered from studies/model_comparison's paper_q3_hammer run: the README's command
    must be that run's but for where it writes, or the block is another command's output."""
    import importlib.util

    spec = importlib.util.spec_from_file_location("model_comparison_run", ROOT / "studies/model_comparison/run.py")
    study = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(study)

    def without_out(args):
        return [a for i, a in enumerate(args) if a not in ("--out", "--overwrite") and args[i - 1] != "--out"]

    assert without_out(readme_command(README.read_text(encoding="utf-8"))) == without_out(
        study.COMMANDS["paper_q3_hammer"])


@pytest.mark.slow  # a five-model comparison: ~20 s on two idle cores
def test_a_fresh_run_prints_the_readme_block(printed):
    block, fresh = printed
    assert not disagreements(block, fresh), "\n".join(
        disagreements(block, fresh) + ["Fix: rerun studies/model_comparison/run.py paper_q3_hammer"])
