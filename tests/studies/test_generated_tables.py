"""Every generated block of the project's markdown equals what its script renders from the
committed outputs: no table or number in a marker block has drifted from its JSON.

The scripts' ``blocks()`` read the committed JSON only (nothing is recomputed), so this is cheap.
Markdown checked: README.md, studies/*/README.md, studies/*/results.md, benchmarks/README.md.
Equality is exact: the block is text the script writes, so any difference is drift.
"""
from __future__ import annotations

import importlib.util
from pathlib import Path

import pytest

from bayesbeam.report.markdown import block_names, read_block

ROOT = Path(__file__).resolve().parents[2]
#: the scripts that render marker blocks; each has ``blocks() -> {markdown path: {name: body}}``
RENDERERS = ("studies/concealed_effects/run.py", "studies/fit_examples/run.py", "studies/model_comparison/run.py",
             "studies/paper_reproduction/reproduce.py", "studies/real_steel_cantilever/run.py",
             "benchmarks/tables.py")
MARKDOWN = sorted({ROOT / "README.md", ROOT / "benchmarks" / "README.md", *ROOT.glob("studies/*/README.md"),
                   *ROOT.glob("studies/*/results.md")})


def _load(script: str):
    path = ROOT / script
    spec = importlib.util.spec_from_file_location(f"rendered_{path.parent.name}_{path.stem}", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _rendered() -> dict[Path, dict[str, str]]:
    """{markdown file: {block name: body}} over all renderers; a block rendered twice is an error."""
    out: dict[Path, dict[str, str]] = {}
    for script in RENDERERS:
        for path, blocks in _load(script).blocks().items():
            mine = out.setdefault(Path(path).resolve(), {})
            twice = set(mine) & set(blocks)
            assert not twice, f"{script} renders {sorted(twice)} of {path}, which another script renders too"
            mine.update(blocks)
    return out


RENDERED = _rendered()


def _name(path: Path) -> str:
    return str(path.relative_to(ROOT))


@pytest.mark.parametrize("markdown", MARKDOWN, ids=_name)
def test_every_block_in_the_file_has_a_renderer_and_every_rendered_block_a_place(markdown):
    in_file = block_names(markdown.read_text(encoding="utf-8"))
    assert len(in_file) == len(set(in_file)), f"{_name(markdown)}: a block is marked twice"
    rendered = RENDERED.get(markdown.resolve(), {})
    assert sorted(in_file) == sorted(rendered), (
        f"{_name(markdown)}: blocks without a renderer {sorted(set(in_file) - set(rendered))}, "
        f"rendered blocks without markers {sorted(set(rendered) - set(in_file))}")


@pytest.mark.parametrize("markdown, name", [(path, name) for path, blocks in RENDERED.items() for name in blocks],
                         ids=lambda x: _name(x) if isinstance(x, Path) else x)
def test_block_equals_its_rendering_from_the_committed_json(markdown, name):
    text = markdown.read_text(encoding="utf-8")
    assert read_block(text, name, _name(markdown)) == RENDERED[markdown][name].strip("\n"), (
        f"{_name(markdown)} block '{name}' differs from its rendering: run the script that renders it "
        f"with --tables")


def test_rendered_files_are_the_ones_checked():
    """A renderer writing into a file outside the checked set would escape the drift check."""
    assert set(RENDERED) <= {p.resolve() for p in MARKDOWN}


@pytest.mark.parametrize("script", [s for s in RENDERERS if s.endswith("run.py") and "concealed" not in s])
def test_the_commands_a_study_reruns_are_valid_command_lines(script):
    """Each study's COMMANDS parse with the bayesbeam parser (nothing is run): a renamed or removed
    flag fails here, not half-way through a rerun."""
    from bayesbeam.cli import build_parser

    parser = build_parser()
    for name, arguments in _load(script).COMMANDS.items():
        parsed = parser.parse_args(arguments)
        assert parsed.command == arguments[0] and parsed.out, (script, name)


def test_the_real_record_study_extends_the_models_its_comparison_ranked_first_and_second():
    """studies/real_steel_cantilever names the best model of its compare (BEST: the diagnosis and
    the finer-grid and clamp comparisons start from it) and the runner-up (RUNNER_UP); both must be
    what the committed comparison.json ranks, or the study's later runs extend the wrong model."""
    import json

    study = _load("studies/real_steel_cantilever/run.py")
    ranking = json.loads((ROOT / "studies/real_steel_cantilever/compare/comparison.json").read_text())["ranking"]
    assert ranking[:2] == [f"{study.BEST}+sensor_mass", f"{study.RUNNER_UP}+sensor_mass"]
