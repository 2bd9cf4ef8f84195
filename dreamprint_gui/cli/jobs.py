"""``dreamprint convert`` (volume -> print job) and ``dreamprint evaluate job`` (check a job)."""

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
from dreamprint_gui.cli.progress import step_progress
from dreamprint_gui.core import progress as core_progress
from dreamprint_gui.core.durations import clock_text
from dreamprint_gui.core.errors import DreamPrintError


@cli.command()
@click.argument("source")
@click.option("-o", "--output", "output", required=True, type=click.Path(),
              help="Job folder to create (JOB/slices/NNNNN.png + JOB/manifest.json).")
@click.option("--profile", default=None, help="Ink profile JSON (default: built-in).")
@click.option("--printer", default=None,
              help="Built-in printer name (voxelprint-27um, voxelprint-14um, j850-paper) or a "
                   "printer .toml file. Default voxelprint-27um (GrabCAD Voxel Print, 600 x "
                   "300 dpi, 27 um layers).")
@size_options
@click.option("--density-scale", type=float, default=1.0, show_default=True,
              help="Multiplies the source density (1/mm = source density x scale / mm per unit).")
@click.option("--halftone", type=click.Choice(["blue-noise", "random"]), default="blue-noise",
              show_default=True)
@click.option("--seed", type=int, default=0, show_default=True)
@click.option("--workers", type=int, default=None,
              help="Threads (or processes) on this computer (default: all cores); with a "
                   "cluster, its workers' threads are used.")
@click.option("--scheduler", default=None,
              help="threads (default), processes, sync (one thread), or the address of a Dask "
                   "cluster's scheduler such as tcp://host:8786: every worker must see the "
                   "source and the job's folder at the same paths (docs/cluster.md).")
@click.option("--background", type=click.Choice(["clear", "empty"]), default="clear",
              show_default=True, help="What voxels below the density threshold become.")
@click.option("--density-threshold", type=float, default=None,
              help="Background threshold in 1/mm (default: half the density of pure Clear).")
@click.option("--slab-layers", type=int, default=None, help="Layers per task (default: auto).")
@click.option("--option", "source_options", multiple=True,
              help="Source reader option KEY=VALUE (e.g. grid=density); repeatable.")
@rendering_options
@click.option("--table-size", type=int, default=100, hidden=True,
              help="Colour table nodes per axis (tests use small tables).")
@click.option("--compensation", type=click.Path(), default=None,
              help="Apply a correction file made by 'dreamprint compensate' (made for this "
                   "source, size, placement, printer, profile, background and its threshold, "
                   "objective, intent and content).")
@click.option("--compensate", is_flag=True,
              help="Optimise a correction first (dreamprint compensate's defaults; written "
                   "beside the job as JOB.correction.npz), then convert with it.")
@click.option("--overwrite", is_flag=True,
              help="Replace an existing job folder (or an interrupted run's layers).")
@click.option("--resume", is_flag=True,
              help="Finish the job an interrupted run left (Ctrl-C, kill, power loss, lost "
                   "cluster): only the missing layers are converted; refused if that run was "
                   "for another source, size, profile, printer, settings or version.")
@click.option("--json", "as_json", is_flag=True,
              help="Print the manifest (with the pre-flight estimate and warnings) as JSON.")
@click.option("-q", "--quiet", is_flag=True,
              help="No pre-flight summary, warnings or progress on stderr.")
@placement_options
def convert(source, output, profile, printer, height_mm, size_mm, density_scale, halftone, seed,
            workers, scheduler, background, density_threshold, slab_layers, source_options,
            content, sampling, objective, intent, table_size, compensation, compensate,
            overwrite, resume, as_json, quiet, up, rotate, fit) -> None:
    """Convert SOURCE (a volume file, or 'demo') into a halftoned PNG slice stack.

    Before any work a pre-flight estimate (grid, slices, disk, material fractions, time) and its
    warnings (mostly Clear, clamping, out of gamut) go to stderr; after the job, how many voxels
    were clamped. --quiet silences both; --json adds them to the printed manifest."""
    from dreamprint_gui.job.cluster import quiet_client_logs
    from dreamprint_gui.job.plan import ConvertSettings, JobCancelled, scheduler_kind
    from dreamprint_gui.job.run import run_conversion

    if resume and overwrite:
        raise DreamPrintError("give --resume (finish the interrupted run) or --overwrite (start "
                              "again), not both")
    spec = print_spec(source, locals(), compensation)
    settings = ConvertSettings.from_spec(
        spec, output=output, workers=workers, scheduler=scheduler,
        density_threshold=density_threshold, overwrite=overwrite, slab_layers=slab_layers,
        resume=resume)
    if compensate and compensation is not None:
        raise DreamPrintError("give --compensate or --compensation, not both")

    def on_term(signum, frame):  # a polite kill cleans up like Ctrl-C
        raise KeyboardInterrupt()

    old = signal.signal(signal.SIGTERM, on_term)
    root = click.get_current_context().find_root()
    if scheduler_kind(settings) == "distributed" and not root.params.get("debug"):
        quiet_client_logs()
    if compensate:  # the export dialog's route: optimise, then convert with the correction
        from dreamprint_gui.proof.compensated import run_compensated_conversion

        gen = run_compensated_conversion(settings)
    else:
        gen = run_conversion(settings)
    progress = _Progress(sys.stderr.isatty(), quiet)
    pf = None
    last = None
    try:
        while True:
            try:
                p = next(gen)
            except StopIteration as stop:
                manifest = stop.value
                break
            if p.stage == "compensating":
                if not quiet:
                    _compensating_line(p)
                continue
            p = getattr(p, "inner", p)  # a compensated job's conversion: its own progress
            if p.stage == "preflight":
                pf = p.preflight
                if not quiet:
                    for line in pf.summary_lines():
                        click.echo(line, err=True)
            elif p.stage == "converting" and p.layers_total:
                progress.update(p)
                last = p
            elif p.message and p.stage not in ("done", "finishing") and not quiet:
                click.echo(p.message, err=True)
    except BaseException as exc:
        if isinstance(exc, JobCancelled):
            raise DreamPrintError("cancelled; the partial job was removed", output) from None
        if isinstance(exc, KeyboardInterrupt) and last is not None and last.layers_done:
            raise KeyboardInterrupt(
                f"at {last.layers_done} of {last.layers_total} layers; the finished layers are "
                "kept: run the same command with --resume to finish the job") from None
        raise
    finally:
        progress.close()
        gen.close()
        signal.signal(signal.SIGTERM, old)
    t = manifest["timings_s"]
    nx, ny, nz = manifest["grid_dimensions"]
    from dreamprint_gui.job.clamp_report import clamp_summary

    clamp_line = clamp_summary(manifest)
    if clamp_line and not quiet:
        click.echo(clamp_line, err=True)
    if manifest.get("compensation") and not quiet:
        click.echo(_compensation_line(manifest["compensation"]), err=True)
    if as_json:
        emit_json(manifest)
    else:
        size = manifest["physical_size_mm"]
        kept = manifest["execution"].get("resumed_layers", 0)
        click.echo(f"wrote {output}: {nz} slices of {nx} x {ny} voxels "
                   f"({size[0]:.2f} x {size[1]:.2f} x {size[2]:.2f} mm), "
                   f"{nx * ny * nz:,} voxels in {t['total']:.1f} s "
                   f"({t['voxels_per_second'] / 1e6:.1f} Mvox/s)"
                   + (f"; {kept} layers kept from the interrupted run" if kept else ""))


def _compensating_line(p) -> None:
    """``--compensate``: the optimiser's iterations (``p.inner``) on stderr."""
    if p.inner.stage == "iteration":
        click.echo(f"[compensate] {p.inner.message}  elapsed {clock_text(p.elapsed_s)}", err=True)
    elif p.inner.stage == "done":
        click.echo(f"[compensate] wrote {p.inner.message}", err=True)


def _compensation_line(comp: dict) -> str:
    """The correction a job used and the optimiser's figures on its training cameras (the
    manifest's ``compensation``)."""
    f = comp.get("proof_figures") or {}
    b, a = f.get("before") or {}, f.get("after") or {}
    line = f"compensation: {comp['path']}"
    if "mean_de2000" in b and "mean_de2000" in a:
        line += (f"; training dE2000 mean {b['mean_de2000']:.2f} -> {a['mean_de2000']:.2f}, "
                 f"coverage error {b['coverage_error']:+.3f} -> {a['coverage_error']:+.3f}")
    if isinstance(comp.get("optimise_seconds"), int | float):
        line += f" (optimised in {clock_text(comp['optimise_seconds'])})"
    return line


class _Progress:
    """The conversion's progress on stderr: a click progress bar on a terminal (layers, percent,
    Mvox/s, time left), else a line once ``core.progress.HEARTBEAT_S`` passed since the last
    (was 10 s); it moves as each slab finishes."""

    def __init__(self, tty: bool, quiet: bool) -> None:
        self.tty = tty
        self.quiet = quiet
        self.bar = None
        self.done = 0
        self.last = 0.0
        self.rate = 0.0
        self.eta: float | None = None
        self.start: float | None = None
        self.first = 0

    def _info(self, _item=None) -> str:
        return f"{self.rate / 1e6:.1f} Mvox/s, {clock_text(self.eta)} left"

    def update(self, p) -> None:
        if self.quiet:
            return
        if self.start is None:  # the conversion's own rate, without the preparation (nor
            self.start = p.elapsed_s  # the layers a resumed job found done)
            self.first = p.voxels_done
        self.rate = (p.voxels_done - self.first) / max(p.elapsed_s - self.start, 1e-9)
        self.eta = p.eta_s
        if self.tty:
            if self.bar is None:
                self.bar = click.progressbar(length=p.layers_total, label="converting",
                                             file=sys.stderr, show_eta=False, show_pos=True,
                                             item_show_func=self._info, width=30)
                self.bar.__enter__()
            self.bar.update(p.layers_done - self.done, current_item=p)
            self.done = p.layers_done
            return
        now = time.monotonic()
        if p.layers_done and (now - self.last >= core_progress.HEARTBEAT_S
                              or p.layers_done == p.layers_total):
            self.last = now
            click.echo(f"converting: {p.layers_done}/{p.layers_total} layers "
                       f"({100 * p.layers_done / p.layers_total:.0f} %), {self._info()}",
                       err=True)

    def close(self) -> None:
        if self.bar is not None:
            self.bar.__exit__(None, None, None)
            self.bar = None


@evaluate.command("job")
@click.argument("job", type=click.Path())
@click.option("--printer", default=None,
              help="Check against this printer (built-in name or .toml file) instead of the "
                   "one the manifest records, e.g. the one you will print on.")
@click.option("--json", "as_json", is_flag=True, help="Print the report as JSON.")
@click.option("-q", "--quiet", is_flag=True, help="No progress on stderr.")
def evaluate_job(job, printer, as_json, quiet) -> None:
    """Read a finished JOB back and check it against its printer (voxel size, image size,
    dpi, material codes, layer count, tray) and its manifest (counts; fractions vs intended
    concentrations); report each material's volume (ml) and mass (g)."""
    from dreamprint_gui.job.check import Z_LIMIT, check_job

    report = check_job(Path(job), printer,
                       progress=step_progress(f"{job}: reading the slices back", quiet))
    if as_json:
        emit_json(report)
    else:
        click.echo(_job_report_text(job, report, Z_LIMIT))
    if not report["consistent"]:
        raise DreamPrintError("the job is not consistent with its manifest and printer", job)


def _job_report_text(job: str, report: dict, z_limit: float) -> str:
    nx, ny, nz = report["grid_dimensions"]
    sx, sy, sz = report["size_mm"]
    lines = [f"{job}: {report['slices_found']} slices of {nx} x {ny} voxels, "
             f"{sx:.2f} x {sy:.2f} x {sz:.2f} mm (x, y, z); printer {report['printer']}"]
    for c in report["checks"]:
        lines.append(f"  {'ok ' if c['ok'] else 'BAD'}  {c['check']}: {c['text']}")
    lines.append(f"  {'material':8s} {'voxels':>13s} {'fraction':>9s} {'intended':>9s} "
                 f"{'z':>7s} {'volume ml':>10s} {'mass g':>8s}")
    for m, r in report["materials"].items():
        z = r["z_score"]
        lines.append(f"  {m:8s} {r['voxels']:13,d} {r['fraction']:9.5f} {r['intended']:9.5f} "
                     f"{z:+7.2f} {r['volume_ml']:10.4f} {r['mass_g']:8.4f}")
    lines.append(f"  {'resin':8s} {'':13s} {'':9s} {'':9s} {'':7s} "
                 f"{report['total_volume_ml']:10.4f} {report['total_mass_g']:8.4f}")
    lines += [
        "  columns: voxels = voxels of the material in the slices; fraction = voxels / all "
        f"{report['total_voxels']:,} voxels;",
        "    intended = the mean concentration the colour tables asked for (manifest); z = "
        "(fraction - intended) / sqrt(intended (1 - intended) / N),",
        f"    a halftone's count is within +-{z_limit:g} of it; volume ml = voxels x the "
        f"job's voxel volume ({' x '.join(f'{v:.5g}' for v in report['voxel_mm'])} mm) / 1000;",
        "    mass g = volume x cured resin density: " + report["density_source"] + "."]
    for p in report["problems"]:
        lines.append(f"  problem: {p}")
    return "\n".join(lines)
