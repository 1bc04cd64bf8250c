"""``bayesbeam check``: validate a recording and say what it holds before anything is fitted."""
from __future__ import annotations

import sys
from pathlib import Path

from bayesbeam import __version__
from bayesbeam.checks.survey import report_lines, survey
from bayesbeam.cli.common import output_folder
from bayesbeam.io import load_recording
from bayesbeam.io.provenance import write_json
from bayesbeam.report.quicklook import save_quicklook

HELP = ("validate a recording; print what it read (beam, tip body, excitation, sensors, sampling) and what "
        "it finds (force pulses, noise floors, spectral peaks against the nominal modes, mains lines, "
        "clipping, a suggested --max-frequency and window, each channel's unit judged against the nominal beam); "
        "write OUT/check.json and OUT/quicklook.png")


def add_arguments(p) -> None:
    p.add_argument("recording", help="recording directory (beam.toml + recording.csv)")
    p.add_argument("--out", metavar="DIR",
                   help="output directory for check.json and quicklook.png (default: check_<recording folder name>)")
    p.add_argument("--overwrite", action="store_true",
                   help="write into a non-empty OUT, replacing the files this command writes (other files stay)")


def run(args) -> int:
    rec = load_recording(args.recording)
    if args.out is None:
        args.out = f"check_{Path(rec.source).resolve().name}"
    out = output_folder(args)
    found = survey(rec)
    out.mkdir(parents=True, exist_ok=True)
    summary = {"bayesbeam": __version__, **found.summary}
    json_path = write_json(summary, out / "check.json")
    png_path = save_quicklook(rec, found, out / "quicklook.png")
    print("\n".join(report_lines(found.summary)))
    for finding in found.summary["units"]["findings"]:
        print(f"bayesbeam check: warning: units: {finding}", file=sys.stderr)
    print(f"wrote {json_path}\nwrote {png_path}")
    return 0
