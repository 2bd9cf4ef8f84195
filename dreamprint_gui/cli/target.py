"""``dreamprint target wedge``: the translucency target (slabs of each ink at each thickness)."""

from __future__ import annotations

import click

from dreamprint_gui.cli.group import cli
from dreamprint_gui.core.errors import DreamPrintError


@cli.group()
def target() -> None:
    """Print jobs of measurement targets."""


def _list(text: str, what: str) -> list[str]:
    items = [x.strip() for x in text.split(",") if x.strip()]
    if not items:
        raise DreamPrintError(f"{what} is empty")
    return items


@target.command("wedge")
@click.option("-o", "--output", required=True, type=click.Path(),
              help="Job folder to create (slices, manifest.json, wedge-sheet.csv/.png, "
                   "slabs-template.toml).")
@click.option("--inks", default="Cl,W,C,M,Y,K", show_default=True,
              help="Inks, comma-separated (C M Y K W Cl).")
@click.option("--thickness-mm", default="0.5,1,2,4,8", show_default=True,
              help="Slab thicknesses in mm, comma-separated.")
@click.option("--printer", default=None,
              help="Built-in printer name or a printer .toml file (default voxelprint-27um).")
@click.option("--slab-mm", type=float, default=25.0, show_default=True,
              help="Side of each square slab (larger than the instrument's aperture).")
@click.option("--overwrite", is_flag=True, help="Replace an existing job folder.")
def wedge(output: str, inks: str, thickness_mm: str, printer: str | None, slab_mm: float,
          overwrite: bool) -> None:
    """Slabs of each ink at each thickness for measuring K and S (docs/translucency.md)."""
    from dreamprint_gui.core.printer import load_printer
    from dreamprint_gui.core.profile import INKS
    from dreamprint_gui.job.wedge import SET_TEMPLATE, SHEET_CSV, SHEET_PNG, write_wedge

    names = {i.lower(): i for i in INKS}
    ink_list = []
    for x in _list(inks, "--inks"):
        if x.lower() not in names:
            raise DreamPrintError(f"unknown ink '{x}' in --inks; inks are {', '.join(INKS)}")
        ink_list.append(names[x.lower()])
    try:
        ts = [float(x) for x in _list(thickness_mm, "--thickness-mm")]
    except ValueError:
        raise DreamPrintError(f"--thickness-mm must be numbers in mm, got {thickness_mm!r}") \
            from None
    prn = load_printer(printer)
    m = write_wedge(output, ink_list, ts, prn, slab_mm, overwrite)
    nx, ny, nz = m["grid_dimensions"]
    size = " x ".join(f"{v:.1f}" for v in m["physical_size_mm"])
    click.echo(f"wrote {output}: {len(m['wedge']['slabs'])} slabs, {size} mm, {nz} layers "
               f"({prn.display_name})")
    click.echo(f"  sheet: {SHEET_CSV}, {SHEET_PNG}; calibration set to fill in: {SET_TEMPLATE}")
    for row in m["wedge"]["slabs"]:
        click.echo(f"  {row['label']:>10}: {row['layers']} layers = {row['printed_mm']:.3f} mm, "
                   f"centre ({row['centre_x_mm']:.1f}, {row['centre_y_mm']:.1f}) mm")
