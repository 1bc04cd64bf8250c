"""The benchmarks' results and their blocks in benchmarks/README.md.

Each benchmark script ends in :func:`run`: it runs the benchmark, keeping what it prints, and
writes ``benchmarks/results/<name>.json`` (the command, its printed tables, the numbers it passed
to :func:`record`, the wall time and the provenance), then renders the README's
``<!-- begin: <name> -->`` block from that file. ``--tables`` re-renders the block from the
committed JSON without running anything. A benchmark with no committed result gets a block that
says which command produces it, never numbers of another run.
"""
from __future__ import annotations

import contextlib
import io
import json
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
RESULTS = HERE / "results"
README = HERE / "README.md"
#: the benchmarks with a block in README.md, in its order
NAMES = ("forward", "effects", "sampling", "batch", "compare", "compare_full", "diagnose",
         "diagnose_paper_quadratic_drag", "diagnose_paper_dry_friction", "from_comparison", "from_comparison_root_spring",
         "catalogue", "basis", "ppc", "nonlinear_long", "chain_file")
#: results kept under another name than their script's (name -> script): the same benchmark at another setting
SCRIPTS = {"compare_full": "compare", "diagnose_paper_quadratic_drag": "diagnose",
           "diagnose_paper_dry_friction": "diagnose", "from_comparison_root_spring": "from_comparison"}
#: the arguments that make a script produce the result of that name (none: its default run)
ARGUMENTS = {"compare": ["--max-frequency", "150"],
             "diagnose_paper_quadratic_drag": ["--concealed", "paper_quadratic_drag"],
             "diagnose_paper_dry_friction": ["--concealed", "paper_dry_friction"],
             "from_comparison_root_spring": ["--k-theta", "4000"], "nonlinear_long": ["--compare", "--diagnose"]}

sys.path.insert(0, str(HERE.parent))          # the working tree's bayesbeam, even if another copy is installed


def command(name: str, argv: list[str]) -> str:
    return " ".join(["python", f"benchmarks/{SCRIPTS.get(name, name)}.py", *argv])


def render(name: str) -> str:
    """The README block of benchmark ``name``, from benchmarks/results/<name>.json."""
    path = RESULTS / f"{name}.json"
    if not path.exists():
        return (f"Not measured yet: this table is produced by `{command(name, ARGUMENTS.get(name, []))}` (see above), which writes "
                f"`benchmarks/results/{name}.json`; nothing is shown here until it has been run.")
    result = json.loads(path.read_text())
    return (f"Output of `{result['command']}` ({result['seconds']:.0f} s wall time; "
            f"`benchmarks/results/{name}.json`):\n\n```text\n{result['output'].strip()}\n```")


#: the timed jobs with a wall-time target: (result name, prefix of its measured keys) -> what it runs
TARGETS = {("compare", ""): "`compare`, five default models, 150 Hz",
           ("compare_full", ""): "`compare`, five default models, default band",
           ("diagnose", ""): "`diagnose`, no `--model`, paper_rootcomp_hammer",
           ("diagnose_paper_quadratic_drag", ""): "`diagnose`, concealed drag (paper beam, 3 s at 1024 Hz)",
           ("diagnose_paper_dry_friction", ""): "`diagnose`, concealed tip friction (paper beam, 3 s at 1024 Hz)",
           ("from_comparison", "compare_"): "`compare`, two accelerometers, 4 s at 4096 Hz, 150 Hz",
           ("from_comparison", ""): "`diagnose --from-comparison` of that comparison (baseline: fitting its own)",
           ("from_comparison_root_spring", "compare_"): "`compare`, the same with a root spring concealed",
           ("from_comparison_root_spring", ""): "`diagnose --from-comparison` of it (baseline: fitting its own)",
           **{("catalogue", f"{name}_"): f"`diagnose --model`, {name}, whole catalogue (target: 1.5 x baseline)"
              for name in ("alu_q1_release", "paper_q3_hammer", "paper_rootcomp_hammer")}}


def targets() -> str:
    """The wall-time targets against the committed results: baseline and current path of one run each."""
    head = ("| job | baseline (s) | current (s) | ratio | target (s) | met | same answer |\n"
            "|---|---|---|---|---|---|---|")
    rows = [head]
    for (name, key), job in TARGETS.items():
        path = RESULTS / f"{name}.json"
        measured = json.loads(path.read_text())["measured"] if path.exists() else {}
        if key + "target_seconds" not in measured:
            rows.append(f"| {job} | not measured: `{command(name, ARGUMENTS.get(name, []))}` | | | | | |")
            continue
        m = {k[len(key):]: v for k, v in measured.items() if k.startswith(key)}
        same = m.get("rankings_agree", m.get("diagnoses_agree"))
        rows.append(f"| {job} | {m['baseline_seconds']:.1f} | {m['current_seconds']:.1f} | {m['wall_ratio']:.2f} | "
                    f"{m['target_seconds']:.0f} | {'yes' if m['current_seconds'] <= m['target_seconds'] else 'NO'} | "
                    f"{'yes' if same else 'no'} |")
    return "\n".join(rows)


def blocks() -> dict[Path, dict[str, str]]:
    return {README: {"targets": targets(), **{name: render(name) for name in NAMES}}}


def write_table(name: str) -> Path:
    from bayesbeam.report.markdown import write_blocks

    return write_blocks(README, {name: render(name), "targets": targets()})


#: what the running benchmark measured, as numbers (:func:`record`), saved beside its printed output
MEASURED: dict = {}


def record(**measured) -> None:
    """Keep numbers the running benchmark measured; :func:`run` saves them as ``measured`` in its JSON
    (the printed tables stay the README's text; these are for anything that quotes a number)."""
    MEASURED.update(measured)


def run(name: str, main, argv: list[str] | None = None) -> int:
    """Run ``main(argv)`` of benchmark ``name``, save what it printed and render its block.

    With ``--tables`` in ``argv``: only re-render the block from the committed result.
    """
    from bayesbeam.io.provenance import write_json

    argv = list(sys.argv[1:] if argv is None else argv)
    if "--tables" in argv:
        print(f"wrote {write_table(name)}")
        return 0
    printed = io.StringIO()
    MEASURED.clear()
    started = time.perf_counter()
    with contextlib.redirect_stdout(_Tee(sys.stdout, printed)):
        status = main(argv)
    seconds = time.perf_counter() - started
    if status:
        print(f"{name}: exit status {status}; results not saved", file=sys.stderr)
        return status
    RESULTS.mkdir(exist_ok=True)
    write_json({"command": command(name, argv), "seconds": round(seconds, 1), "output": printed.getvalue(),
                "measured": dict(MEASURED)}, RESULTS / f"{name}.json")
    print(f"wrote {RESULTS / f'{name}.json'} and {write_table(name)}")
    return 0


class _Tee(io.TextIOBase):
    """A text stream writing to two others: the terminal and the record."""

    def __init__(self, *streams):
        self.streams = streams

    def write(self, text: str) -> int:
        for stream in self.streams:
            stream.write(text)
        return len(text)

    def flush(self) -> None:
        for stream in self.streams:
            stream.flush()


if __name__ == "__main__":
    from bayesbeam.report.markdown import write_files

    for path in write_files(blocks()):
        print(f"wrote {path}")
