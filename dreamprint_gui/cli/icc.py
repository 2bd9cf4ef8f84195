"""``dreamprint icc``: the ICC output profile of the printer and inks (issue 48)."""

from __future__ import annotations

import click

from dreamprint_gui.cli.group import cli
from dreamprint_gui.cli.options import INTENT_HELP, INTENTS, OBJECTIVE_HELP, OBJECTIVES
from dreamprint_gui.cli.output import emit_json
from dreamprint_gui.cli.progress import notice, progress_bar


@cli.command()
@click.option("-o", "--output", required=True, type=click.Path(dir_okay=False),
              help="The ICC profile to write (e.g. PRINTER.icc).")
@click.option("--profile", "profile_path", default=None,
              help="Ink profile JSON (default: built-in).")
@click.option("--printer", default=None,
              help="Built-in printer name (voxelprint-27um, voxelprint-14um, j850-paper) or a "
                   "printer .toml file; named in the profile's description. Default "
                   "voxelprint-27um.")
@click.option("--intent", type=INTENTS, default=None, help=INTENT_HELP + " The profile "
              "describes the print of RGB through the table of this intent.")
@click.option("--objective", type=OBJECTIVES, default=None, help=OBJECTIVE_HELP)
@click.option("--size", type=click.IntRange(2, 200), default=100, show_default=True,
              help="Nodes per axis of DreamPrint's colour table (as convert uses).")
@click.option("--icc-version", type=click.Choice(["2", "4"]), default="2", show_default=True,
              help="ICC version: 2 (2.4, lut16 tables; Debian's ArgyllCMS reads only this) or 4 "
                   "(4.3, the current standard).")
@click.option("--grid", type=click.IntRange(9, 65), default=33, show_default=True,
              help="Nodes per axis of the profile's A2B and B2A tables.")
@click.option("--cgats", type=click.Path(dir_okay=False), default=None,
              help="Also write a CGATS characterisation file (RGB -> predicted XYZ, Lab, "
                   "spectra): ArgyllCMS layout for a .ti3 name, i1Profiler CGATS.17 otherwise.")
@click.option("--patches", type=click.IntRange(2, 17), default=9, show_default=True,
              help="The characterisation file's RGB lattice: PATCHES^3 colours.")
@click.option("--json", "as_json", is_flag=True, help="Print the report as JSON.")
def icc(output, profile_path, printer, intent, objective, size, icc_version, grid, cgats,
        patches, as_json) -> None:
    """Write an ICC output profile of the print: device RGB (what a job takes) -> the colour
    DreamPrint predicts it prints, for soft proofs in Photoshop, GIMP, Krita, darktable..."""
    from dreamprint_gui.core.printer import load_printer
    from dreamprint_gui.core.profile import load_profile
    from dreamprint_gui.gamut import get_tables
    from dreamprint_gui.gamut.icc_export import check_outputs, export_icc
    from dreamprint_gui.gamut.tables import resolve_choice
    from dreamprint_gui.job.plan import profile_for_printer

    check_outputs(output, cgats)
    printer_profile = load_printer(printer)
    # the profile as a job on this printer uses it: the job's (and lookup's) cached tables
    profile = profile_for_printer(load_profile(profile_path), printer_profile)
    objective, intent = resolve_choice(profile, objective, intent)
    tables = get_tables(profile, objective, size, intent=intent,
                        progress=progress_bar(f"{objective}, {intent}"), notify=notice)
    report = export_icc(output, profile, tables, printer=printer_profile.display_name,
                        version=int(icc_version), a2b_grid=grid, b2a_grid=grid, cgats=cgats,
                        patches=patches, progress=lambda msg: click.echo(msg, err=True))
    if as_json:
        emit_json(report)
        return
    a, r = report["check"]["a2b_dE2000"], report["check"]["round_trip_dE2000"]
    click.echo(f"wrote {report['path']}: ICC {report['icc_version']} output profile, "
               f"{report['bytes'] // 1024} kB, RGB -> CIELAB D50, tables {grid}^3; "
               f"\"{report['description']}\"")
    click.echo(f"read back by Little CMS over {report['check']['colours']} colours (9^3 RGB "
               f"cube and the demo's): A2B vs DreamPrint's print dE2000 mean {a['mean']:.3f}, "
               f"p95 {a['p95']:.3f}, max {a['max']:.3f}; B2A then A2B of their prints mean "
               f"{r['mean']:.3f}, p95 {r['p95']:.3f}, max {r['max']:.3f}")
    if "cgats" in report:
        c = report["cgats"]
        click.echo(f"wrote {c['path']}: {c['patches']} patches, {c['layout']} layout")
