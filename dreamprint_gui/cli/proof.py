"""``dreamprint proof`` (the print rendered physically beside the source) and
``dreamprint evaluate methods`` (the paper's ablations as numbers)."""

from __future__ import annotations

import signal
import sys
import time
from pathlib import Path

import click

from dreamprint_gui.cli.group import cli, evaluate
from dreamprint_gui.cli.options import (
    placement_options,
    print_spec,
    rendering_options,
    size_options,
)
from dreamprint_gui.cli.output import emit_json
from dreamprint_gui.core import progress as core_progress
from dreamprint_gui.core.durations import clock_text
from dreamprint_gui.core.errors import DreamPrintError

# Fixed choices (tests/cli check them against the engine's METHODS and HALFTONE_METHODS; the
# engine modules are not imported here to keep the command line quick to start).
METHOD_CHOICES = ("paper", "no-alignment", "brute-force")
HALFTONE_CHOICES = ("blue-noise", "random")
BACKGROUND_CHOICES = ("clear", "empty")

_STAGES = {"preparing": "preparing", "labels": "labels", "source": "source render",
           "print": "print render (Mitsuba)", "compare": "comparing",
           "gamut floor": "gamut floor", "writing": "writing"}


def _drive(gen, prefix: str = "", quiet: bool = False):
    """Run a proof generator with progress bars on stderr; return its value."""
    from dreamprint_gui.job.plan import JobCancelled

    def on_term(signum, frame):
        raise KeyboardInterrupt()

    old = signal.signal(signal.SIGTERM, on_term)
    tty = sys.stderr.isatty()
    last_line = 0.0
    stage = None
    stage_t0 = time.monotonic()
    shown = False               # the stage's bar is on the terminal's current line
    try:
        while True:
            try:
                p = next(gen)
            except StopIteration as stop:
                if tty and shown:
                    click.echo("", err=True)
                return stop.value
            now = time.monotonic()
            if p.stage != stage:
                if tty and shown:
                    click.echo("", err=True)
                stage, stage_t0, shown = p.stage, now, False
                last_line = 0.0
            if p.stage == "done" or quiet:
                continue
            # preparing: nothing for its first HEARTBEAT_S, so that a bad input (refused while
            # opening the source) stays one line; then its heartbeat like any stage's
            if p.stage == "preparing" and now - stage_t0 < core_progress.HEARTBEAT_S:
                continue
            if p.stage == "iteration":
                click.echo(f"{prefix}{p.message}  elapsed {clock_text(p.elapsed_s)}", err=True)
                continue
            # a log (no terminal) gets the bar's line every HEARTBEAT_S while a stage runs
            if tty or now - last_line >= core_progress.HEARTBEAT_S or p.done == p.total:
                last_line = now
                frac = p.done / p.total if p.total else 0.0
                bar = "#" * int(frac * 30) + "-" * (30 - int(frac * 30))
                line = (f"{prefix}{_STAGES.get(p.stage, p.stage):22s} [{bar}] {p.done}/{p.total}"
                        f"  elapsed {clock_text(p.elapsed_s)}")
                click.echo(("\r" + line) if tty else line, err=True, nl=not tty)
                shown = tty
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
        click.option("--printer", default=None, help="Printer name or .toml (default "
                     "voxelprint-27um)."),
        click.option("--profile", default=None, help="Ink profile JSON (default: built-in)."),
        click.option("--views", type=int, default=4, show_default=True),
        click.option("--resolution", type=int, default=256, show_default=True,
                     help="Image width and height in pixels."),
        click.option("--spp", type=int, default=64, show_default=True,  # runner.DEFAULT_SPP
                     help="Samples per pixel of the print render (64: a noise floor of "
                          "about 0.5 S-CIELAB dE2000)."),
        click.option("--thick-spp", type=int, default=0, show_default=True,
                     help="More samples per pixel on the tiles where the print is optically "
                          "thick (direct transmittance < 0.1), where its render noise is; 0: "
                          "none."),
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
        click.option("--viewing-distance-mm", type=float, default=500.0, show_default=True,
                     help="S-CIELAB: the print seen at its real size from this distance."),
        click.option("--noise-floor/--no-noise-floor", default=True, show_default=True,
                     help="Report the figures' own render noise, from the print's two "
                          "halves of samples (seeds S and S + 1; no extra render)."),
        click.option("--surface", default=None,
                     help="The print's surface: none, glossy or matte (a dielectric boundary, "
                          "n 1.5 unless the profile says). Default: the profile's, else none "
                          "(the built-in K and S were fitted without one)."),
        click.option("--phase", default=None,
                     help="Phase function: isotropic or hg:G (Henyey-Greenstein, reduced "
                          "scattering kept). Default: the profile's, else isotropic."),
        click.option("--sampler", default="independent", show_default=True,
                     help="Mitsuba sampler: independent, stratified, multijitter, orthogonal "
                          "or ldsampler."),
        click.option("--option", "source_options", multiple=True,
                     help="Source reader option KEY=VALUE; repeatable."),
        click.option("--table-size", type=int, default=100, hidden=True),
        click.option("--clear-low-bound", is_flag=True,
                     help="When the profile's Clear is modelled (not measured), render the "
                          "print once more with the Clear at its plausible low bound and "
                          "report the figures at both (one more print render)."),
        click.option("--json", "as_json", is_flag=True, help="Print the report as JSON."),
    ]
    for o in reversed(opts):
        f = o(f)
    return size_options(placement_options(rendering_options(f)))


def _settings(source, output, method, kw, overwrite=False, compensation=None):
    from dreamprint_gui.proof.runner import ProofSettings

    own = ("views", "resolution", "spp", "max_cells", "layers_per_block", "bands", "max_depth",
           "key_light", "floor", "viewing_distance_mm", "noise_floor", "sampler", "thick_spp",
           "surface", "phase", "clear_low_bound")
    return ProofSettings.from_spec(print_spec(source, kw, compensation), output=output,
                                   method=method, overwrite=overwrite,
                                   **{k: kw[k] for k in own})


def _check_source(source: str) -> None:
    from pathlib import Path

    if source != "demo" and not Path(source).exists():
        raise DreamPrintError("no such file or folder", source)


@cli.command()
@click.argument("source", required=False)
@click.option("-o", "--output", required=True, type=click.Path(),
              help="Folder to create (images, contact_sheet.png, proof.json).")
@click.option("--method", type=click.Choice(METHOD_CHOICES), default="paper", show_default=True,
              help="Labelling method (a source, not a job folder).")
@click.option("--overwrite", is_flag=True, help="Replace an existing output folder.")
@click.option("--compensation", type=click.Path(), default=None,
              help="Label with a correction file (dreamprint compensate) applied.")
@click.option("--chart", "chart", default=None, type=click.Path(dir_okay=False),
              help="Chart proof: a recipes CSV (as calibrate --chart reads); each recipe is "
                   "rendered as a flat patch instead of a SOURCE.")
@click.option("--reflectance", default=None, type=click.Path(dir_okay=False),
              help="Chart proof: the measured reflectance of the chart's patches (any format "
                   "`dreamprint spectra` reads), one spectrum per recipe.")
@click.option("--geometry", default="d:8", show_default=True,
              help="Chart proof: instrument geometry, d:8 (specular included) or 45:0.")
@click.option("--thickness-mm", type=float, default=None,
              help="Chart proof: patch thickness over a black backing (default: optically "
                   "thick).")
@_common
def proof(source, output, method, overwrite, compensation, chart, reflectance, geometry,
          thickness_mm, **kw) -> None:
    """Render SOURCE (a volume, 'demo', or an exported JOB folder) as printed, beside the
    source, and measure how alike they look; or, with --chart, a printed chart's recipes as
    an instrument would measure them."""
    from dreamprint_gui.proof.clear_report import clear_lines
    from dreamprint_gui.proof.compare import empty_source_note, headline_text
    from dreamprint_gui.proof.runner import run_proof

    if chart is not None or reflectance is not None:
        _chart_proof(source, output, overwrite, chart, reflectance, geometry, thickness_mm, kw)
        return
    if source is None:
        raise DreamPrintError("give a SOURCE (a volume, 'demo' or a job folder), or --chart "
                              "RECIPES.csv")
    _check_source(source)
    report = _drive(run_proof(_settings(source, output, method, kw, overwrite, compensation)))
    if report["renderer"].get("fallback"):     # LLVM asked for, not found: what to install
        click.echo(f"dreamprint: note: {report['renderer']['note']}", err=True)
    if kw["as_json"]:
        emit_json(report)
        return
    o = report["overall"]
    click.echo(f"wrote {output}: {len(report['views'])} views, judged against the source in "
               f"the {report['reference']['intent']} intent; {headline_text(o)}; S-CIELAB at "
               f"{kw['viewing_distance_mm']:g} mm, PSNR {o['psnr_db']:.1f} dB, SSIM "
               f"{o['ssim']:.3f}, coverage {o['source_coverage']:.3f} -> "
               f"{o['print_coverage']:.3f} ({report['timings_s']['total']:.0f} s, "
               f"{report['renderer']['variant']})")
    note = empty_source_note(o)
    if note:
        click.echo(note)
    f = report["noise_floor"]
    if f is not None:
        click.echo(f"noise floor (halves at seeds {f['seeds'][0]}, {f['seeds'][1]}): dE2000 mean "
                   f"{f['mean_de2000']:.2f}, S-CIELAB dE2000 mean "
                   f"{f['mean_scielab_de2000']:.2f}")
    for line in clear_lines(report["clear"]):
        click.echo(line)


def _chart_proof(source, output, overwrite, chart, reflectance, geometry, thickness_mm,
                 kw) -> None:
    from dreamprint_gui.proof.chart import DEFAULT_CHART_SPP, ChartSettings, run_chart_proof

    if source is not None:
        raise DreamPrintError("--chart proofs a chart's recipes: give no SOURCE with it")
    if chart is None:
        raise DreamPrintError("--reflectance needs --chart RECIPES.csv (the recipes measured)")
    if kw["clear_low_bound"]:
        raise DreamPrintError("--clear-low-bound renders a volume's print again; a chart proof "
                              "has no Clear block to bound")
    ctx = click.get_current_context()
    spp_given = ctx.get_parameter_source("spp") is not click.core.ParameterSource.DEFAULT
    s = ChartSettings(recipes=chart, reflectance=reflectance, output=output,
                      profile=kw["profile"], surface=kw["surface"], phase=kw["phase"],
                      geometry=geometry, thickness_mm=thickness_mm,
                      spp=kw["spp"] if spp_given else DEFAULT_CHART_SPP, bands=kw["bands"],
                      seed=kw["seed"], max_depth=kw["max_depth"], overwrite=overwrite)
    from dreamprint_gui.cli.progress import step_progress

    rep = run_chart_proof(s, step_progress("chart proof: render passes (3 bands each)"))
    if kw["as_json"]:
        emit_json(rep)
        return
    msg = (f"wrote {output}: {rep['patches_count']} patches, {rep['geometry']}, surface "
           f"{rep['optics']['surface']}, phase {rep['optics']['phase']}")
    if "de2000" in rep:
        d = rep["de2000"]
        worst = ", ".join(f"{w['patch']} ({w['de2000']:.1f})" for w in d["worst_patches"][:3])
        msg += (f"; dE2000 against the measurements mean {d['mean']:.2f}, p95 {d['p95']:.2f}, "
                f"max {d['max']:.2f}; worst patches {worst}")
    click.echo(msg)


def _common_halftones(f):
    return _common(f, halftones=True)


@evaluate.command("methods")
@click.argument("source")
@click.option("--method", "methods", type=click.Choice((*METHOD_CHOICES, "compensated")),
              multiple=True, default=METHOD_CHOICES, show_default=True,
              help="Labelling method; repeat for several (default: the paper's three); "
                   "compensated: optimised (dreamprint compensate) on other cameras and "
                   "another seed, then proofed.")
@click.option("--iterations", type=int, default=4, show_default=True,
              help="The compensated method's iterations.")
@click.option("--training-views", "comp_views", type=int, default=None,
              help="The compensated method's training cameras (not the proof's; default: "
                   "dreamprint compensate's).")
@_common_halftones
def evaluate_methods(source, methods, iterations, comp_views, **kw) -> None:
    """Proof SOURCE with each method and halftoning (same cameras, seed, size) and tabulate the
    figures: one row per --method x --halftone."""
    from dreamprint_gui.proof.clear_report import clear_lines
    from dreamprint_gui.proof.compare import (
        SIGNIFICANCE_FACTOR,
        SIGNIFICANCE_KEYS,
        headline,
        mark_significance,
    )
    from dreamprint_gui.proof.runner import render_proof

    _check_source(source)
    ms = list(dict.fromkeys(methods))
    hs = list(dict.fromkeys(kw["halftone"]))
    rows = []
    combos = [(m, h) for m in ms for h in hs]
    gfloor = None
    for k, (m, h) in enumerate(combos):
        kw2 = dict(kw, halftone=h)
        prefix = f"[{k + 1}/{len(combos)} {m}/{h}] "
        corr = comp = None
        if m == "compensated":
            corr, comp = _held_out_correction(source, kw2, prefix, iterations, comp_views)
        try:
            res = _drive(render_proof(_settings(source, None, "paper" if corr else m, kw2,
                                                compensation=corr)), prefix=prefix)
        finally:
            if corr is not None:
                Path(corr).unlink(missing_ok=True)
        r = res["report"]
        row = {"method": m, "halftone": h, **r["overall"], "noise_floor": r["noise_floor"],
               "clear": r["clear"], "seconds": r["timings_s"]["total"]}
        if comp is not None:
            row["optimise_seconds"] = comp["seconds"]
            row["training"] = comp["figures"]
        rows.append(row)
        gfloor = gfloor or r.get("gamut_floor")
    # the headline: inside the source (compare.headline); all object pixels beside it
    mark_significance(rows, keys=(*SIGNIFICANCE_KEYS, "mean_de2000", "mean_scielab_de2000"))
    table = {"source": source, "height_mm": kw["height_mm"], "size_mm": kw["size_mm"],
             "views": kw["views"], "resolution": kw["resolution"], "spp": kw["spp"],
             "seed": kw["seed"], "background": kw["background"],
             "viewing_distance_mm": kw["viewing_distance_mm"],
             "significance": f"a row's difference from the best row is significant when it "
                             f"exceeds {SIGNIFICANCE_FACTOR:g} x the larger noise floor of the "
                             "two (vs_best)", "methods": rows, "gamut_floor": gfloor,
             "headline": "inside the source: each row's inside_source_* figures, over the "
                         "object pixels where the source has coverage; the keys without the "
                         "prefix are over all object pixels, as before"}
    if kw["as_json"]:
        emit_json(table)
        return
    click.echo("inside the source (object pixels where the source has coverage); all object "
               "pixels and the share where the source is empty (the Clear block's body) beside; "
               "-noise: the dE2000 mean less the render's noise")
    click.echo(f"{'method':14s} {'halftone':10s} {'dE mean':>9s} {'-noise':>6s} {'dE p95':>8s} "
               f"{'S-CIELAB':>9s} {'floor':>11s} {'coverage':>9s} | {'all: dE':>8s} "
               f"{'S-CIELAB':>9s} {'coverage':>9s} {'PSNR':>6s} {'SSIM':>6s} {'empty':>6s}")

    mark = noise_mark
    for r in rows:
        f = r["noise_floor"]
        inside = "inside_source_mean_de2000" in (f or {})
        floor = (f"{f['inside_source_mean_de2000']:.2f}/"
                 f"{f['inside_source_mean_scielab_de2000']:.2f}" if inside else
                 f"{f['mean_de2000']:.2f}/{f['mean_scielab_de2000']:.2f}" if f else "-")
        click.echo(f"{r['method']:14s} {r['halftone']:10s} "
                   f"{r['inside_source_mean_de2000']:8.2f}"
                   f"{mark(r, 'inside_source_mean_de2000')} "
                   f"{r.get('inside_source_nc_mean_de2000', float('nan')):6.2f} "
                   f"{r['inside_source_p95_de2000']:8.2f} "
                   f"{r['inside_source_mean_scielab_de2000']:8.2f}"
                   f"{mark(r, 'inside_source_mean_scielab_de2000')} {floor:>11s} "
                   f"{r['inside_source_coverage_error']:+9.3f} | {r['mean_de2000']:7.2f}"
                   f"{mark(r, 'mean_de2000')} {r['mean_scielab_de2000']:8.2f}"
                   f"{mark(r, 'mean_scielab_de2000')} {r['coverage_error']:+9.3f} "
                   f"{r['psnr_db']:6.1f} {r['ssim']:6.3f} "
                   f"{100 * r['empty_source_fraction']:5.0f}%")
    for line in noise_legend(rows, kw["spp"]):
        click.echo(line)
    for r in rows:
        lines = clear_lines(r["clear"]) if r["clear"].get("figures") else []
        if lines:
            click.echo(f"{r['method']}/{r['halftone']}: " + lines[0])
            for line in lines[1:]:
                click.echo(line)
    if rows and rows[0]["clear"].get("figures") is None and rows[0]["clear"].get("note"):
        click.echo(f"Clear: {rows[0]['clear']['origin']} ({rows[0]['clear']['note']})")
    if gfloor is not None:
        g = headline(gfloor)
        click.echo(f"{'gamut floor':25s} {g['mean_de2000']:8.2f} {'-':>6s} {g['p95_de2000']:9.2f} "
                   f"{g['mean_scielab_de2000']:8.2f} {'':>12s} {g['coverage_error']:+9.3f} | "
                   f"{gfloor['mean_de2000']:7.2f}  {gfloor['mean_scielab_de2000']:8.2f}  "
                   f"{gfloor['coverage_error']:+9.3f}  (the source in the printable colours, "
                   "no light transport)")



def noise_mark(row: dict, key: str) -> str:
    """"~" after a methods-table figure whose difference from the best row is within the
    noise (:func:`..proof.compare.mark_significance`), else a blank."""
    sig = row["vs_best"][key]["significant"]
    return " " if sig is None or sig or row["vs_best"][key]["difference"] == 0 else "~"


def noise_legend(rows: list[dict], spp: int) -> list[str]:
    """The lines under a methods table: what "~" means and, when a figure is marked, what
    tells the rows apart (more samples per pixel: 4 x halve the render noise)."""
    from dreamprint_gui.proof.compare import SIGNIFICANCE_FACTOR

    if not any(r["noise_floor"] for r in rows):
        return []
    out = [f"~: within {SIGNIFICANCE_FACTOR:g} x the noise floor of the best row (not "
           "significant); floor: mean dE2000 / S-CIELAB between two seeds"]
    if any(noise_mark(r, k) == "~" for r in rows for k in r.get("vs_best", {})):
        out.append(f"to tell the ~ rows apart, raise --spp (now {spp}): 4 x the samples "
                   f"halve the render noise (--spp {4 * spp})")
    return out


def _held_out_correction(source, kw, prefix, iterations, views):
    """The ``compensated`` method: a correction optimised on the training cameras (not the
    proof's) with another halftone and render seed (``--seed`` + 1), in a temporary file."""
    import os
    import tempfile

    from dreamprint_gui.proof.compensate import CompensateSettings, run_compensate

    fd, name = tempfile.mkstemp(suffix=".npz", prefix="dreamprint-correction-")
    os.close(fd)
    spec = print_spec(source, dict(kw, seed=kw["seed"] + 1))
    # the optimiser's own cameras, pixels and samples unless given (dreamprint compensate's)
    cs = CompensateSettings.from_spec(
        spec, output=name, iterations=iterations, max_cells=kw["max_cells"],
        bands=kw["bands"], max_depth=kw["max_depth"], layers_per_block=kw["layers_per_block"],
        overwrite=True, **({} if views is None else {"views": views}))
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
@size_options
@click.option("--printer", default=None, help="Printer name or .toml (default voxelprint-27um).")
@click.option("--profile", default=None, help="Ink profile JSON (default: built-in).")
@click.option("--views", type=int, default=6, show_default=True,
              help="Training cameras (not the proof's).")
@click.option("--iterations", type=int, default=4, show_default=True)
@click.option("--seed", type=int, default=0, show_default=True)
@click.option("--resolution", type=int, default=128, show_default=True,
              help="Pixels a side of the training renders.")
@click.option("--spp", type=int, default=32, show_default=True,
              help="Samples per pixel of the training renders.")
@click.option("--cells", "max_cells", type=int, default=128, show_default=True,
              help="Proof cells along the print's longest axis of the training renders "
                   "(the proof's).")
@click.option("--field-cells", type=int, default=32, show_default=True,
              help="Correction cells along the print's longest axis (the coarse field).")
@click.option("--fine-cells", type=int, default=64, show_default=True,
              help="The fine field's cells along the longest axis, where the camera sees the "
                   "object's surface (no finer than --cells); 0: the coarse field alone.")
@click.option("--occlusion", type=float, default=1.0, show_default=True,
              help="A solid's (voxel model's) start against its shading by its own shape under "
                   "the proof's light: concave steps lightened, edges darkened; 0: none.")
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
@placement_options
@rendering_options
def compensate(source, output, height_mm, size_mm, printer, profile, views, iterations, seed,
               resolution, spp, max_cells, field_cells, fine_cells, occlusion, halftone,
               density_scale, background,
               source_options, table_size, overwrite, as_json, up, rotate, fit,
               **rendering) -> None:
    """Optimise a correction (colour and density factors on a coarse field) so that the proof
    of the print of SOURCE matches its render; apply it with convert --compensation."""
    from dreamprint_gui.proof.compare import empty_source_note, headline
    from dreamprint_gui.proof.compensate import CompensateSettings, run_compensate

    _check_source(source)
    cs = CompensateSettings.from_spec(
        print_spec(source, {**locals(), **rendering}), output=output, views=views,
        iterations=iterations, resolution=resolution, spp=spp, max_cells=max_cells,
        field_cells=field_cells, fine_cells=fine_cells, occlusion=occlusion,
        overwrite=overwrite)
    report = _drive(run_compensate(cs))
    if as_json:
        emit_json(report)
        return
    b, a = report["figures"]["before"], report["figures"]["after"]
    hb, ha = headline(b), headline(a)
    click.echo(f"wrote {output}: on the training cameras, {hb['where']}, dE2000 mean "
               f"{hb['mean_de2000']:.2f} -> {ha['mean_de2000']:.2f}, S-CIELAB "
               f"{hb['mean_scielab_de2000']:.2f} -> {ha['mean_scielab_de2000']:.2f}, coverage "
               f"error {hb['coverage_error']:+.3f} -> {ha['coverage_error']:+.3f} (iteration "
               f"{a['iteration']}; {report['seconds']:.0f} s)")
    note = empty_source_note(b)
    if note:
        click.echo(f"on the training cameras, {note}")
