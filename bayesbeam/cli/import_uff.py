"""``bayesbeam import-uff``: UFF58 time histories (force and responses) -> a recording."""
from __future__ import annotations

from bayesbeam.cli.common import add_out_options, output_folder

HELP = "turn UFF dataset-58 time histories into a recording (beam and set-up from a beam.toml)"


def add_arguments(imp) -> None:
    imp.add_argument("uff", help="UFF file (.uff/.unv) with dataset-58 time histories, ASCII or binary")
    imp.add_argument("--beam", required=True,
                     help="beam.toml: [beam], optional [tip], [excitation] (release/free_decay only) and [nodes]")
    add_out_options(imp, "the new recording", recording=True)


def run(args) -> int:
    from bayesbeam.io import write_recording
    from bayesbeam.io.uff import read_uff58

    output_folder(args)
    rec = read_uff58(args.uff, args.beam)
    path = write_recording(rec, args.out, overwrite=args.overwrite)
    force = f"force at {rec.excitation.location} m, " if rec.force is not None else f"{rec.excitation.kind}, "
    print(f"{rec.n_samples} samples at {rec.fs:.6g} Hz; {force}"
          + ", ".join(f"{s.name} ({s.quantity} at {s.location} m)" for s in rec.sensors))
    print(f"wrote {path}")
    return 0
