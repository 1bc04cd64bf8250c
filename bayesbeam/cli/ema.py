"""``bayesbeam ema``: E, gamma and c_d from a modal table by the paper's eqs. (27)-(29), as in its Table 4."""
from __future__ import annotations

from bayesbeam.cli.common import add_out_options, output_folder
from bayesbeam.io import RecordingError, load_beam_description

HELP = "E, gamma and c_d from a modal table (Banks & Inman eqs. 27-29, successive mode sets)"


def add_arguments(ema) -> None:
    ema.add_argument("table", help="modal table CSV: mode,frequency_hz,damping_ratio[,damping_ratio_sd] "
                                   "(damping ratio and sd as fractions, not %%)")
    ema.add_argument("--beam", required=True, help="beam.toml whose [beam] gives l, rho, A and I (no tip body)")
    add_out_options(ema, "ema.json, table4.csv, ema.png")


def _bare_beam(path):
    """The beam of ``path``; refused with a tip body, for which eqs. (23)-(29) do not hold."""
    desc = load_beam_description(path)
    if desc.tip.mass or desc.tip.rotary_inertia:
        raise RecordingError(
            desc.file, "[tip]", "a tip body: the EMA route (eqs. 23-29) holds only for a bare clamped-free "
            "beam, where air damping acts on every mode alike",
            "remove [tip] for a bare beam, or identify the damping of this beam with `bayesbeam fit`.")
    return desc


def run(args) -> int:
    from bayesbeam.modal.ema import ema_from_table, read_modal_table
    from bayesbeam.modal.outputs import ema_document, write_ema_outputs

    out = output_folder(args)
    table = read_modal_table(args.table)
    if len(table.modes) < 2:
        raise ValueError(f"{args.table}: holds {len(table.modes)} mode. Fix: give at least two modes "
                         "(Table 4 starts with modes 1-2).")
    desc = _bare_beam(args.beam)
    beam = {"length": desc.beam.length, "rho_a": desc.beam.rho_a, "second_moment": desc.beam.second_moment}
    result = ema_from_table(table.frequency_hz, table.damping_ratio, sd=table.damping_ratio_sd,
                            modes=table.modes, **beam)
    document = ema_document(result, table_file=args.table, beam_file=desc.file, **beam)
    paths = write_ema_outputs(out, result, table, document, second_moment=beam["second_moment"],
                              rho_a=beam["rho_a"])
    print(f"E = {result.E:.5g} Pa (eq. 27, modes {result.modes}; sd of the per-mode values {result.E_sd:.3g} Pa)")
    print(f"{'modes':>10}  {'gamma (visc.)':>13}  {'c_d (strain)':>12}  {'gamma (both)':>12}  {'c_d (both)':>12}"
          "   [N s/m^2]" + ("  weighted by damping_ratio_sd" if result.weighted else ""))
    for fit in result.successive:
        label = f"{fit.modes[0]}-{fit.modes[-1]}" if len(fit.modes) == fit.modes[-1] - fit.modes[0] + 1 \
            else ",".join(map(str, fit.modes))
        print(f"{label:>10}  {fit.viscous_only.gamma:>13.5g}  {fit.strain_only.c_d:>12.5g}  "
              f"{fit.both.gamma:>12.5g}  {fit.both.c_d:>12.5g}")
    print(f"wrote {', '.join(p.name for p in paths)} in {paths[0].parent}")
    return 0
