"""``dreamprint spectra FILE``: what a spectral measurement file holds, as DreamPrint reads it."""

from __future__ import annotations

import click

from dreamprint_gui.cli.group import cli
from dreamprint_gui.cli.output import emit_json

_QUANTITIES = ["reflectance", "transmittance", "absorbance", "spd"]
SUMMARY_SAMPLES = 12  # more samples than this: the text lists the first SUMMARY_HEAD only
SUMMARY_HEAD = 8


@cli.command()
@click.argument("file", type=click.Path(dir_okay=False))
@click.option("--json", "as_json", is_flag=True, help="Print a JSON object.")
@click.option("--quantity", type=click.Choice(_QUANTITIES),
              help="Read as this quantity (absorbance <-> transmittance converted).")
@click.option("--file-quantity", type=click.Choice(_QUANTITIES + ["log_epsilon"]),
              help="What the file holds, when the file does not say.")
@click.option("--scale", type=click.Choice(["auto", "fraction", "percent"]), default="auto",
              show_default=True, help="Scale of reflectance/transmittance values.")
@click.option("--all", "show_all", is_flag=True,
              help=f"List every sample (a file of more than {SUMMARY_SAMPLES} samples is "
                   "summarised: the first ones and the range of the rest; --json has all).")
def spectra(file: str, as_json: bool, quantity: str | None, file_quantity: str | None,
            scale: str, show_all: bool) -> None:
    """Show the format, quantity, unit conversion and samples of a spectral FILE.

    Reads CGATS.17 (i1Profiler, ArgyllCMS, X-Rite), Agilent Cary CSV, JCAMP-DX, IES TM-27-14
    and plain CSV. Physically impossible values are listed as problems.
    """
    from dreamprint_gui.io.spectra import read_spectra

    sf = read_spectra(file, quantity=quantity, file_quantity=file_quantity, value_scale=scale)
    summary = sf.summary()
    if as_json:
        emit_json(summary)
        return
    click.echo(f"file: {sf.path}")
    click.echo(f"format: {sf.format}")
    basis = summary.get("quantity_basis")
    click.echo(f"quantity: {sf.quantity}" + (f" ({basis})" if basis else ""))
    click.echo(f"conversion: {sf.conversion}")
    click.echo(f"samples: {len(sf.samples)}")
    samples = summary["samples"]
    shown = samples if show_all or len(samples) <= SUMMARY_SAMPLES else samples[:SUMMARY_HEAD]
    width = min(max(len(s["name"]) for s in shown), 32)
    for s in shown:
        lo, hi = s["wavelengths_nm"]
        step = f"step {s['step_nm']:g} nm" + ("" if s["uniform"] else " (median, uneven)")
        rng = ("" if s["min"] is None else f"  values {s['min']:.4g} to {s['max']:.4g}")
        own = f"  [{s['quantity']}]" if sf.quantity == "mixed" else ""
        click.echo(f"  {s['name'][:32]:<{width}}  {lo:g}-{hi:g} nm  {step}  "
                   f"{s['points']} points{rng}{own}")
    rest = samples[len(shown):]
    if rest:
        lo = min(s["wavelengths_nm"][0] for s in rest)
        hi = max(s["wavelengths_nm"][1] for s in rest)
        vals = [v for s in rest for v in (s["min"], s["max"]) if v is not None]
        rng = f", values {min(vals):.4g} to {max(vals):.4g}" if vals else ""
        click.echo(f"  ... and {len(rest)} more samples ({rest[0]['name'][:24]} to "
                   f"{rest[-1]['name'][:24]}: {lo:g}-{hi:g} nm{rng}); --all lists every one")
    if sf.problems:
        click.echo(f"problems: {len(sf.problems)}")
        for p in sf.problems:
            click.echo(f"  {p}")
