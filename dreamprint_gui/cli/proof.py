"""``dreamprint proof`` (the print rendered physically beside the source) and
``dreamprint evaluate methods`` (the paper's ablations as numbers)."""

from __future__ import annotations

import json
import signal
import sys
import time
from pathlib import Path

import click

from dreamprint_gui.cli import cli, evaluate
from dreamprint_gui.cli.jobs import _fmt_time, _option_value, _size
from dreamprint_gui.core.errors import DreamPrintError

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


def _drive(gen, prefix: str = "", quiet: bool = False):
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
            if p.stage in ("done", "preparing") or quiet:  # a bad input stays one line
                continue
            if p.stage == "iteration":
                click.echo(f"{prefix}{p.message}  elapsed {_fmt_time(p.elapsed_s)}", err=True)
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


def _common(f):
    opts = [
        click.option("--height-mm", type=float, default=None, help="Height (z) of the print."),
        click.option("--size-mm", default=None, help="Fit into the box X,Y,Z mm."),
        click.option("--printer", default=None, help="Printer name or .toml (default "
                     "j850-paper)."),
        click.option("--profile", default=None, help="Ink profile JSON (default: built-in)."),
        click.option("--views", type=int, default=4, show_default=True),
        click.option("--resolution", type=int, default=256, show_default=True,
                     help="Image width and height in pixels."),
        click.option("--spp", type=int, default=16, show_default=True,
                     help="Samples per pixel of the print render."),
        click.option("--halftone", default="blue-noise", show_default=True,
                     help="blue-noise or random."),
        click.option("--seed", type=int, default=0, show_default=True),
        click.option("--density-scale", type=float, default=1.0, show_default=True),
        click.option("--background", default="clear", show_default=True,
                     help="What voxels below the density threshold become: clear or empty."),
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
    return f


def _settings(source, output, method, kw, overwrite=False, compensation=None):
    from dreamprint_gui.proof.runner import ProofSettings

    return ProofSettings(compensation=compensation,
        source=source, output=output, height_mm=kw["height_mm"], size_mm=_size(kw["size_mm"]),
        printer=kw["printer"], profile=kw["profile"], views=kw["views"],
        resolution=kw["resolution"], spp=kw["spp"], method=method, halftone=kw["halftone"],
        seed=kw["seed"], density_scale=kw["density_scale"], background=kw["background"],
        max_cells=kw["max_cells"], layers_per_block=kw["layers_per_block"], bands=kw["bands"],
        max_depth=kw["max_depth"], key_light=kw["key_light"], floor=kw["floor"],
        overwrite=overwrite, table_size=kw["table_size"],
        source_options=_options(kw["source_options"]))


def _check_source(source: str) -> None:
    from pathlib import Path

    if source != "demo" and not Path(source).exists():
        raise DreamPrintError("no such file or folder", source)


@cli.command()
@click.argument("source")
@click.option("-o", "--output", required=True, type=click.Path(),
              help="Folder to create (images, contact_sheet.png, proof.json).")
@click.option("--method", default="paper", show_default=True,
              help="paper, no-alignment or brute-force (a source, not a job folder).")
@click.option("--overwrite", is_flag=True, help="Replace an existing output folder.")
@click.option("--compensation", type=click.Path(), default=None,
              help="Label with a correction file (dreamprint compensate) applied.")
@_common
def proof(source, output, method, overwrite, compensation, **kw) -> None:
    """Render SOURCE (a volume, 'demo', or an exported JOB folder) as printed, beside the
    source, and measure how alike they look."""
    from dreamprint_gui.proof.runner import run_proof

    _check_source(source)
    report = _drive(run_proof(_settings(source, output, method, kw, overwrite, compensation)))
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


@evaluate.command("methods")
@click.argument("source")
@click.option("--methods", "methods", default="paper,no-alignment,brute-force",
              show_default=True, help="Comma-separated methods.")
@click.option("--halftones", default="blue-noise", show_default=True,
              help="Comma-separated halftoning choices (blue-noise, random).")
@click.option("--iterations", type=int, default=4, show_default=True,
              help="The compensated method's iterations.")
@click.option("--training-views", "comp_views", type=int, default=3, show_default=True,
              help="The compensated method's training cameras (not the proof's).")
@_common
def evaluate_methods(source, methods, halftones, iterations, comp_views, **kw) -> None:
    """Proof SOURCE with each method (same cameras, seed, size) and tabulate the figures."""
    from dreamprint_gui.proof.methods import METHODS
    from dreamprint_gui.proof.runner import render_proof

    _check_source(source)
    ctx = click.get_current_context()
    if ctx.get_parameter_source("halftone") is not click.core.ParameterSource.DEFAULT:
        # --halftone (of the shared options) would otherwise be silently replaced per row
        if ctx.get_parameter_source("halftones") is not click.core.ParameterSource.DEFAULT:
            raise DreamPrintError("give --halftones (a list) or --halftone, not both")
        halftones = kw["halftone"]
    ms = [m.strip() for m in methods.split(",") if m.strip()]
    hs = [h.strip() for h in halftones.split(",") if h.strip()]
    known = (*METHODS, "compensated")
    bad = [m for m in ms if m not in known]
    if bad or not ms:
        raise DreamPrintError(f"unknown method(s) {bad or methods!r} (use {', '.join(known)})")
    rows = []
    combos = [(m, h) for m in ms for h in hs]
    tmp = None
    floor = None
    try:
        for k, (m, h) in enumerate(combos):
            kw2 = dict(kw, halftone=h)
            prefix = f"[{k + 1}/{len(combos)} {m}/{h}] "
            corr = None
            if m == "compensated":
                corr, comp = _held_out_correction(source, kw2, prefix, iterations, comp_views)
                tmp = corr
            res = _drive(render_proof(_settings(source, None, "paper" if corr else m, kw2,
                                                compensation=None if corr is None
                                                else str(corr))), prefix=prefix)
            if corr is not None:
                Path(corr).unlink(missing_ok=True)
                tmp = None
            r = res["report"]
            row = {"method": m, "halftone": h, **r["overall"],
                   "seconds": r["timings_s"]["total"]}
            if m == "compensated":
                row["optimise_seconds"] = comp["seconds"]
                row["training"] = comp["figures"]
            rows.append(row)
            floor = floor or r.get("gamut_floor")
    finally:
        if tmp is not None:
            Path(tmp).unlink(missing_ok=True)
    table = {"source": source, "height_mm": kw["height_mm"], "size_mm": kw["size_mm"],
             "views": kw["views"], "resolution": kw["resolution"], "spp": kw["spp"],
             "seed": kw["seed"], "background": kw["background"], "methods": rows,
             "gamut_floor": floor}
    if kw["as_json"]:
        click.echo(json.dumps(table, indent=2))
        return
    click.echo(f"{'method':14s} {'halftone':10s} {'dE mean':>8s} {'dE p95':>8s} {'PSNR':>6s} "
               f"{'SSIM':>6s} {'coverage':>9s}")
    for r in rows:
        click.echo(f"{r['method']:14s} {r['halftone']:10s} {r['mean_de2000']:8.2f} "
                   f"{r['p95_de2000']:8.2f} {r['psnr_db']:6.1f} {r['ssim']:6.3f} "
                   f"{r['coverage_error']:+9.3f}")
    if floor is not None:
        click.echo(f"{'gamut floor':25s} {floor['mean_de2000']:8.2f} {floor['p95_de2000']:8.2f} "
                   f"{floor['psnr_db']:6.1f} {floor['ssim']:6.3f} "
                   f"{floor['coverage_error']:+9.3f}  (the source in the printable colours, "
                   "no light transport)")


def _held_out_correction(source, kw, prefix, iterations, views):
    """The ``compensated`` method: a correction optimised on the training cameras (not the
    proof's) with another halftone and render seed (``--seed`` + 1), in a temporary file."""
    import os
    import tempfile

    from dreamprint_gui.proof.compensate import CompensateSettings, run_compensate

    fd, name = tempfile.mkstemp(suffix=".npz", prefix="dreamprint-correction-")
    os.close(fd)
    cs = CompensateSettings(
        source=source, output=name, height_mm=kw["height_mm"], size_mm=_size(kw["size_mm"]),
        printer=kw["printer"], profile=kw["profile"], views=views, iterations=iterations,
        seed=kw["seed"] + 1, resolution=kw["resolution"], spp=kw["spp"],
        max_cells=kw["max_cells"], halftone=kw["halftone"], density_scale=kw["density_scale"],
        background=kw["background"], bands=kw["bands"], max_depth=kw["max_depth"],
        table_size=kw["table_size"], source_options=_options(kw["source_options"]),
        layers_per_block=kw["layers_per_block"], overwrite=True)
    try:
        report = _drive(run_compensate(cs), prefix=prefix + "optimise: ")
    except BaseException:
        Path(name).unlink(missing_ok=True)
        raise
    return name, report


@cli.command()
@click.argument("source")
@click.option("-o", "--output", required=True, type=click.Path(),
              help="Correction file to write (.npz).")
@click.option("--height-mm", type=float, default=None, help="Height (z) of the print.")
@click.option("--size-mm", default=None, help="Fit into the box X,Y,Z mm.")
@click.option("--printer", default=None, help="Printer name or .toml (default j850-paper).")
@click.option("--profile", default=None, help="Ink profile JSON (default: built-in).")
@click.option("--views", type=int, default=3, show_default=True,
              help="Training cameras (not the proof's).")
@click.option("--iterations", type=int, default=4, show_default=True)
@click.option("--seed", type=int, default=0, show_default=True)
@click.option("--resolution", type=int, default=64, show_default=True)
@click.option("--spp", type=int, default=4, show_default=True)
@click.option("--cells", "max_cells", type=int, default=32, show_default=True,
              help="Proof cells along the print's longest axis.")
@click.option("--field-cells", type=int, default=32, show_default=True,
              help="Correction cells along the print's longest axis.")
@click.option("--halftone", type=click.Choice(["blue-noise", "random"]), default="blue-noise",
              show_default=True)
@click.option("--density-scale", type=float, default=1.0, show_default=True)
@click.option("--background", type=click.Choice(["clear", "empty"]), default="clear",
              show_default=True)
@click.option("--option", "source_options", multiple=True,
              help="Source reader option KEY=VALUE; repeatable.")
@click.option("--table-size", type=int, default=100, hidden=True)
@click.option("--overwrite", is_flag=True, help="Replace an existing correction file.")
@click.option("--json", "as_json", is_flag=True, help="Print the report as JSON.")
def compensate(source, output, height_mm, size_mm, printer, profile, views, iterations, seed,
               resolution, spp, max_cells, field_cells, halftone, density_scale, background,
               source_options, table_size, overwrite, as_json) -> None:
    """Optimise a correction (colour and density factors on a coarse field) so that the proof
    of the print of SOURCE matches its render; apply it with convert --compensation."""
    from dreamprint_gui.proof.compensate import CompensateSettings, run_compensate

    _check_source(source)
    cs = CompensateSettings(
        source=source, output=output, height_mm=height_mm, size_mm=_size(size_mm),
        printer=printer, profile=profile, views=views, iterations=iterations, seed=seed,
        resolution=resolution, spp=spp, max_cells=max_cells, field_cells=field_cells,
        halftone=halftone, density_scale=density_scale, background=background,
        table_size=table_size, source_options=_options(source_options), overwrite=overwrite)
    report = _drive(run_compensate(cs))
    if as_json:
        click.echo(json.dumps(report, indent=2))
        return
    b, a = report["figures"]["before"], report["figures"]["after"]
    click.echo(f"wrote {output}: training dE2000 mean {b['mean_de2000']:.2f} -> "
               f"{a['mean_de2000']:.2f}, coverage error {b['coverage_error']:+.3f} -> "
               f"{a['coverage_error']:+.3f} (iteration {a['iteration']}; "
               f"{report['seconds']:.0f} s)")
