"""``bayesbeam import``: a data-acquisition file (.lvm, .tdms, .mat, .uff/.unv, text) -> a recording.

(The module is ``import_``: ``import`` is a Python keyword.)
"""
from __future__ import annotations

from bayesbeam.cli.common import add_out_options, output_folder

HELP = "turn a DAQ file (LabVIEW .lvm, NI .tdms, MATLAB .mat, UFF58 .uff/.unv, delimited text) into a recording"


def add_arguments(p) -> None:
    from bayesbeam.io.importer import FORMATS

    p.add_argument("file", metavar="FILE", help="the DAQ file; its format from the extension unless --format")
    add_out_options(p, "the new recording", recording=True)
    p.add_argument("--beam", metavar="TOML",
                   help="a beam.toml stating what the file cannot ([beam], [tip], [excitation], [[sensor]] with "
                        "column = a channel) (default: none; beam.toml is then a skeleton to fill in)")
    p.add_argument("--format", choices=FORMATS, help="read FILE as this format (default: from its extension)")
    p.add_argument("--group", help="TDMS: the group to read (default: the first holding numeric channels)")
    p.add_argument("--delimiter", help="text: the cell separator (default: found from the header)")
    p.add_argument("--decimal", help="text: the decimal separator, '.' or ',' (default: found from the data)")
    p.add_argument("--sample-rate", type=float, metavar="HZ",
                   help="the sampling rate in Hz, for a file that states none or states it wrongly "
                        "(default: the file's time or rate)")


def run(args) -> int:
    from bayesbeam.io.importer import detect_format, import_file, placeholders, read_channels, write_import

    out = output_folder(args)
    options = {"group": args.group, "delimiter": args.delimiter, "decimal": args.decimal}
    fmt = detect_format(args.file, args.format)
    if fmt == "uff" and args.beam:  # positions from the UFF file's nodes
        path = import_file(args.file, out, beam=args.beam, format=fmt, overwrite=args.overwrite,
                           sample_rate=args.sample_rate, **options)
        _describe_recording(path)
        return 0
    table = read_channels(args.file, format=fmt, sample_rate=args.sample_rate, **options)
    _describe(table, args.sample_rate)
    path = write_import(table, out, beam=args.beam, overwrite=args.overwrite, sample_rate=args.sample_rate,
                        format=fmt)
    print(f"wrote {path}")
    todo = placeholders(path / "beam.toml")
    if todo:
        print(f"fill in {path / 'beam.toml'} (the lines marked FILL IN): " + ", ".join(todo))
        print(f"then: bayesbeam check {path}")
    return 0


def _describe(table, sample_rate) -> None:
    from bayesbeam.io.importer import uniform_time

    time, _ = uniform_time(table, sample_rate)
    n = time.size
    rate = (n - 1) / (time[-1] - time[0])
    print(f"{table.source}: {len(table.channels)} channel(s), {n} samples at {rate:.6g} Hz, "
          f"{time[-1] - time[0]:.6g} s")
    for channel in table.channels:
        print(f"  {channel.name} ({channel.unit or 'no unit stated'})")


def _describe_recording(path) -> None:
    from bayesbeam.io import load_recording

    rec = load_recording(path)
    force = f"force at {rec.excitation.location} m, " if rec.force is not None else f"{rec.excitation.kind}, "
    print(f"{rec.n_samples} samples at {rec.fs:.6g} Hz; {force}"
          + ", ".join(f"{s.name} ({s.quantity} at {s.location} m)" for s in rec.sensors))
    print(f"wrote {path}")
