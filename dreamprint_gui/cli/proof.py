"""``dreamprint proof`` (the print rendered physically beside the source) and
``dreamprint evaluate methods`` (the paper's ablations as numbers)."""

from __future__ import annotations

import json
import signal
import sys
import time

import click

from dreamprint_gui.cli import cli, evaluate, placement_options, placement_values
from dreamprint_gui.cli.jobs import _fmt_time, _option_value, _size
from dreamprint_gui.core.errors import DreamPrintError

# Fixed choices (tests/cli check them against the engine's METHODS and HALFTONE_METHODS; the
# engine modules are not imported here to keep the command line quick to start).
METHOD_CHOICES = ("paper", "no-alignment", "brute-force")
HALFTONE_CHOICES = ("blue-noise", "random")
BACKGROUND_CHOICES = ("clear", "empty")

_STAGES = {"preparing": "preparing", "labels": "labels", "source": "source render",
           "print": "print render (Mitsuba)", "compare": "comparing", "writing": "writing"}


def _options(items: tuple[str, ...]) -> tuple[tuple[str, object], ...]:
    out = []
    for kv in items:
        if "=" not in kv:
            raise DreamPrintError(f"--option must be KEY=VALUE, got '{kv}'")
        k, v = kv.split("=", 1)
        out.append((k.strip(), _option_value(v.strip())))
    return tuple(out)


def _drive(gen, prefix: str = ""):
    """Run a proof generator with progress bars on stderr; return its value."""
    from dreamprint_gui.job.plan import JobCancelled

    def on_term(signum, frame):
        raise KeyboardInterrupt()

    old = signal.signal(signal.SIGTERM, on_term)
    tty = sys.stderr.isatty()
    last_line = 0.0
    stage = None
    try:
        while True:
            try:
                p = next(gen)
            except StopIteration as stop:
                if tty and stage is not None:
                    click.echo("", err=True)
                return stop.value
            now = time.monotonic()
            if p.stage != stage:
                if tty and stage is not None:
                    click.echo("", err=True)
                stage = p.stage
                last_line = 0.0
            if p.stage in ("done", "preparing"):  # a bad input stays a one-line error
                continue
            if tty or now - last_line > 10 or p.done == p.total:
                last_line = now
                frac = p.done / p.total if p.total else 0.0
                bar = "#" * int(frac * 30) + "-" * (30 - int(frac * 30))
                line = (f"{prefix}{_STAGES.get(p.stage, p.stage):22s} [{bar}] {p.done}/{p.total}"
                        f"  elapsed {_fmt_time(p.elapsed_s)}")
                click.echo(("\r" + line) if tty else line, err=True, nl=not tty)
    except JobCancelled:
        raise DreamPrintError("cancelled; nothing was written") from None
    finally:
        gen.close()
        signal.signal(signal.SIGTERM, old)


def _common(f, halftones: bool = False):
    """The options ``proof`` and ``evaluate methods`` share; ``halftones``: ``--halftone`` is
    repeatable (one row per choice) instead of one choice."""
    halftone = (click.option("--halftone", "halftone", type=click.Choice(HALFTONE_CHOICES),
                             multiple=True, default=("blue-noise",), show_default=True,
                             help="Halftoning; repeat for one row per choice.") if halftones else
                click.option("--halftone", type=click.Choice(HALFTONE_CHOICES),
                             default="blue-noise", show_default=True))
    opts = [
        click.option("--height-mm", type=float, default=None, help="Height (z) of the print."),
        click.option("--size-mm", default=None, help="Fit into the box X,Y,Z mm."),
        click.option("--printer", default=None, help="Printer name or .toml (default "
                     "voxelprint-27um)."),
        click.option("--profile", default=None, help="Ink profile JSON (default: built-in)."),
        click.option("--views", type=int, default=4, show_default=True),
        click.option("--resolution", type=int, default=256, show_default=True,
                     help="Image width and height in pixels."),
        click.option("--spp", type=int, default=16, show_default=True,
                     help="Samples per pixel of the print render."),
        halftone,
        click.option("--seed", type=int, default=0, show_default=True),
        click.option("--density-scale", type=float, default=1.0, show_default=True),
        click.option("--background", type=click.Choice(BACKGROUND_CHOICES), default="clear",
                     show_default=True,
                     help="What voxels below the density threshold become."),
        click.option("--cells", "max_cells", type=int, default=128, show_default=True,
                     help="Medium cells along the print's longest axis."),
        click.option("--layers-per-block", type=int, default=2, show_default=True,
                     help="Layers read per cell (0: every layer)."),
        click.option("--bands", type=int, default=12, show_default=True,
                     help="Spectral bands rendered."),
        click.option("--max-depth", type=int, default=512, show_default=True),
        click.option("--key-light", type=float, default=0.0, show_default=True,
                     help="Irradiance of a directional key light (the environment's "
                          "radiance is 1)."),
        click.option("--floor", is_flag=True, help="Stand the print on a neutral grey floor."),
        click.option("--option", "source_options", multiple=True,
                     help="Source reader option KEY=VALUE; repeatable."),
        click.option("--table-size", type=int, default=100, hidden=True),
        click.option("--json", "as_json", is_flag=True, help="Print the report as JSON."),
    ]
    for o in reversed(opts):
        f = o(f)
    return placement_options(f)


def _settings(source, output, method, kw, overwrite=False):
    from dreamprint_gui.proof.runner import ProofSettings

    return ProofSettings(
        source=source, output=output, height_mm=kw["height_mm"], size_mm=_size(kw["size_mm"]),
        printer=kw["printer"], profile=kw["profile"], views=kw["views"],
        resolution=kw["resolution"], spp=kw["spp"], method=method, halftone=kw["halftone"],
        seed=kw["seed"], density_scale=kw["density_scale"], background=kw["background"],
        max_cells=kw["max_cells"], layers_per_block=kw["layers_per_block"], bands=kw["bands"],
        max_depth=kw["max_depth"], key_light=kw["key_light"], floor=kw["floor"],
        overwrite=overwrite, table_size=kw["table_size"],
        source_options=_options(kw["source_options"]),
        up=placement_values(kw["up"], kw["rotate"])[0],
        rotate=placement_values(kw["up"], kw["rotate"])[1], fit=kw["fit"])


def _check_source(source: str) -> None:
    from pathlib import Path

    if source != "demo" and not Path(source).exists():
        raise DreamPrintError("no such file or folder", source)


@cli.command()
@click.argument("source")
@click.option("-o", "--output", required=True, type=click.Path(),
              help="Folder to create (images, contact_sheet.png, proof.json).")
@click.option("--method", type=click.Choice(METHOD_CHOICES), default="paper", show_default=True,
              help="Labelling method (a source, not a job folder).")
@click.option("--overwrite", is_flag=True, help="Replace an existing output folder.")
@_common
def proof(source, output, method, overwrite, **kw) -> None:
    """Render SOURCE (a volume, 'demo', or an exported JOB folder) as printed, beside the
    source, and measure how alike they look."""
    from dreamprint_gui.proof.runner import run_proof

    _check_source(source)
    report = _drive(run_proof(_settings(source, output, method, kw, overwrite)))
    if report["renderer"]["variant"].startswith("scalar"):
        click.echo(f"dreamprint: note: {report['renderer']['note']}", err=True)
    if kw["as_json"]:
        click.echo(json.dumps(report, indent=2))
        return
    o = report["overall"]
    click.echo(f"wrote {output}: {len(report['views'])} views; dE2000 mean "
               f"{o['mean_de2000']:.2f} p95 {o['p95_de2000']:.2f}, PSNR {o['psnr_db']:.1f} dB, "
               f"SSIM {o['ssim']:.3f}, coverage {o['source_coverage']:.3f} -> "
               f"{o['print_coverage']:.3f} ({report['timings_s']['total']:.0f} s, "
               f"{report['renderer']['variant']})")


def _common_halftones(f):
    return _common(f, halftones=True)


@evaluate.command("methods")
@click.argument("source")
@click.option("--method", "methods", type=click.Choice(METHOD_CHOICES), multiple=True,
              default=METHOD_CHOICES, show_default=True,
              help="Labelling method; repeat for several (default: all three).")
@_common_halftones
def evaluate_methods(source, methods, **kw) -> None:
    """Proof SOURCE with each method and halftoning (same cameras, seed, size) and tabulate the
    figures: one row per --method x --halftone."""
    from dreamprint_gui.proof.runner import render_proof

    _check_source(source)
    ms = list(dict.fromkeys(methods))
    hs = list(dict.fromkeys(kw["halftone"]))
    rows = []
    combos = [(m, h) for m in ms for h in hs]
    for k, (m, h) in enumerate(combos):
        kw2 = dict(kw, halftone=h)
        res = _drive(render_proof(_settings(source, None, m, kw2)),
                     prefix=f"[{k + 1}/{len(combos)} {m}/{h}] ")
        r = res["report"]
        rows.append({"method": m, "halftone": h, **r["overall"],
                     "seconds": r["timings_s"]["total"]})
    table = {"source": source, "height_mm": kw["height_mm"], "size_mm": kw["size_mm"],
             "views": kw["views"], "resolution": kw["resolution"], "spp": kw["spp"],
             "seed": kw["seed"], "background": kw["background"], "methods": rows}
    if kw["as_json"]:
        click.echo(json.dumps(table, indent=2))
        return
    click.echo(f"{'method':14s} {'halftone':10s} {'dE mean':>8s} {'dE p95':>8s} {'PSNR':>6s} "
               f"{'SSIM':>6s} {'coverage':>9s}")
    for r in rows:
        click.echo(f"{r['method']:14s} {r['halftone']:10s} {r['mean_de2000']:8.2f} "
                   f"{r['p95_de2000']:8.2f} {r['psnr_db']:6.1f} {r['ssim']:6.3f} "
                   f"{r['coverage_error']:+9.3f}")
