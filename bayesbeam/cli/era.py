"""``bayesbeam era``: a recording's modal table by ERA, with a stabilization diagram."""
from __future__ import annotations

from bayesbeam.cli.common import UsageError, add_out_options, output_folder
from bayesbeam.io import load_recording

HELP = "modal table of a recording by ERA (frequencies, damping ratios, shapes at the sensors)"


def add_arguments(era) -> None:
    era.add_argument("recording", help="recording directory (beam.toml + recording.csv)")
    era.add_argument("--order", type=int, help="ERA model order (default: 3 x the nominal modes in the band)")
    era.add_argument("--max-order", type=int, help="highest order in the stabilization diagram (default: 2 x order)")
    era.add_argument("--rows", type=int, help="Hankel block rows (default: min(n/3, max(20, 300/channels)))")
    era.add_argument("--modes", type=int, metavar="N", help="keep bending modes 1..N only (default: every mode "
                                                             "identified in the band)")
    era.add_argument("--start", type=float, help="start of the free decay (s; default: after the force, "
                                                 "release or free_decay start, plus 128 samples)")
    era.add_argument("--stop", type=float, help="end of the free decay (s; default: end of the record)")
    era.add_argument("--max-frequency", type=float, help="top of the band kept (Hz; default: 0.40 fs)")
    era.add_argument("--min-emac", type=float, default=0.8, help="drop poles with EMAC below this")
    era.add_argument("--uff", action="store_true",
                     help="also write the input time histories (recording.uff, UFF58) and the modes (modes.uff, UFF55)")
    add_out_options(era, "modal.csv, era.json, stabilization.png")


def _check(args) -> None:
    for name in ("order", "max_order", "rows", "modes"):
        value = getattr(args, name)
        if value is not None and value < 1:
            raise UsageError(f"--{name.replace('_', '-')} {value}: must be a positive integer")


def run(args) -> int:
    from bayesbeam.io.uff import write_uff58, write_uff_modes
    from bayesbeam.modal.decay import identify_modes
    from bayesbeam.modal.outputs import write_era_outputs

    _check(args)
    out = output_folder(args)
    rec = load_recording(args.recording)
    modes = identify_modes(rec, order=args.order, n_rows=args.rows, start=args.start, stop=args.stop,
                           max_frequency=args.max_frequency, n_modes=args.modes, min_emac=args.min_emac,
                           diagram_orders=lambda n: range(2, (args.max_order or 2 * n) + 1, 2))
    if not modes.modes:
        raise ValueError(f"{rec.source}: ERA kept no bending mode below {modes.max_frequency_hz:.4g} Hz. Fix: check "
                         "the free-decay segment (--start/--stop), raise --order or lower --min-emac.")
    paths = write_era_outputs(out, modes, rec)
    if args.uff:
        paths.append(write_uff58(rec, out / "recording.uff"))
        paths.append(write_uff_modes(out / "modes.uff", [s.location for s in rec.sensors], modes.modes,
                                     modes.frequencies_hz, modes.damping_ratios, modes.shapes))
    print(f"ERA order {modes.order}, {modes.n_rows} block rows, free decay {modes.segment[0]:.4g}-"
          f"{modes.segment[1]:.4g} s, band 0-{modes.max_frequency_hz:.4g} Hz")
    print(f"{'mode':>4}  {'f (Hz)':>10}  {'zeta (%)':>9}  {'EMAC':>5}  {'MPC':>5}")
    for m, f, z, e, p in zip(modes.modes, modes.frequencies_hz, modes.damping_ratios, modes.emac, modes.mpc):
        print(f"{m:>4}  {f:>10.4f}  {100 * z:>9.4f}  {e:>5.3f}  {p:>5.3f}")
    if modes.missing:
        print(f"not identified: mode(s) {', '.join(map(str, modes.missing))} of the nominal beam")
    for pole in modes.unassigned:
        print(f"left out: pole at {pole['frequency_hz']:.4g} Hz (zeta {100 * pole['damping_ratio']:.3g} %), "
              f"a weaker claimant to mode {pole['nearest_mode']}")
    print(f"wrote {', '.join(p.name for p in paths)} in {out}")
    return 0
