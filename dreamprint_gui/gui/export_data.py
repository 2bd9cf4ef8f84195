"""The export dialog's data: the choices as the engine's settings, the scheduler address, the
job's summary and pre-flight as the dialog shows them; no Qt (the dialog, :mod:`.export`, keeps
the widgets), as :mod:`.preview_data` and :mod:`.gamut_data` are for their views.

Defines :func:`convert_settings` (the GUI's choices as the engine's ``ConvertSettings``, the
same object ``dreamprint convert`` builds; the Preview's too), :func:`same_job` (a pre-flight
of one is the pre-flight of the other), :data:`SCHEDULERS` and :func:`check_scheduler_address`
(where the slabs run: this computer's threads or processes, or a ``dask.distributed`` cluster
by address), :func:`manifest_summary`, :func:`compensation_row`, :func:`time_text`,
:func:`preflight_html` and
:func:`printer_file_name`.
"""

from __future__ import annotations

import os
from pathlib import Path

from dreamprint_gui.core.durations import measured_text
from dreamprint_gui.core.errors import DreamPrintError
from dreamprint_gui.gui.names import background_name, gui_wording, printer_name

__all__ = ["SCHEDULERS", "check_scheduler_address", "convert_settings", "same_job",
           "time_text", "manifest_summary", "compensation_row",
           "preflight_html", "printer_file_name"]


# (settings value, label); "distributed" takes an address (ConvertSettings.scheduler).
SCHEDULERS = (("threads", "this computer, threads (default)"),
              ("processes", "this computer, processes"),
              ("distributed", "Dask cluster (dask.distributed)"))


def check_scheduler_address(address: str) -> str:
    """A dask.distributed scheduler address as the engine takes it (``tcp://host:port``)."""
    a = address.strip()
    if not a:
        raise DreamPrintError("give the Dask scheduler's address, e.g. tcp://host:8786")
    if "://" not in a:
        a = "tcp://" + a  # what dask.distributed assumes for host:port
    scheme, _, rest = a.partition("://")
    host, _, port = rest.rpartition(":")
    if scheme in ("tcp", "tls", "ws", "wss"):
        ok = bool(host) and port.isdigit() and 0 < int(port) < 65536
    else:  # an in-process cluster, or UCX: no port to check
        ok = scheme in ("inproc", "ucx") and bool(rest)
    if not ok:
        raise DreamPrintError(f"'{address}' is not a Dask scheduler address "
                              "(like tcp://host:8786)")
    return a


def convert_settings(source_path: str, profile_path: str | None, printer, *,
                     height_mm: float | None = None,
                     size_mm: tuple[float, float, float] | None = None,
                     density_scale: float = 1.0, background: str = "clear",
                     halftone: str = "blue-noise", seed: int = 0,
                     output: str | os.PathLike | None = None, overwrite: bool = False,
                     workers: int | None = None, scheduler: str | None = None,
                     table_size: int | None = None, content: str = "auto",
                     sampling: str | None = None, intent: str | None = None,
                     up: str | None = None, rotate: int = 0, fit: str = "occupied",
                     source_options: dict | None = None):
    """The engine's ``ConvertSettings`` for the GUI's choices (printer: name, path or profile;
    ``content`` fog, solid or auto; ``sampling`` None for the reader's own, or "linear";
    ``intent`` the rendering intent, None for the profile's; ``up`` the source axis that
    becomes +z, None or "auto" for the source's convention; ``rotate`` quarter turns about z
    in degrees; ``fit`` "occupied" or "box"; ``source_options`` the reader's options, as the
    CLI's ``--option``)."""
    from dreamprint_gui.core.printer import printer_choice
    from dreamprint_gui.job.plan import ConvertSettings

    printer = printer_choice(printer)
    extra = {} if table_size is None else {"table_size": int(table_size)}
    if intent is not None:
        extra["intent"] = intent
    return ConvertSettings(source=str(source_path), output=output, profile=profile_path,
                           printer=printer, height_mm=height_mm,
                           size_mm=None if size_mm is None else tuple(size_mm),
                           density_scale=float(density_scale), halftone=halftone,
                           seed=int(seed), workers=workers, scheduler=scheduler,
                           background=background, content=content, sampling=sampling,
                           overwrite=overwrite, up=None if up in (None, "auto") else up,
                           rotate=int(rotate), fit=fit,
                           source_options=dict(source_options or {}), **extra)


def same_job(a, b) -> bool:
    """Whether two ``ConvertSettings`` describe the same job (where it goes and who runs it
    aside): a pre-flight of one is the pre-flight of the other."""
    from dataclasses import replace

    if a is None or b is None:
        return False
    where = {"output": None, "overwrite": False, "workers": None, "scheduler": None,
             "resume": False}
    return replace(a, **where) == replace(b, **where)


def _manifest_printer_name(printer: dict) -> str:
    from dreamprint_gui.core.printer import PRINTER_NAMES

    name = str(printer.get("name", ""))
    return str(printer.get("title") or PRINTER_NAMES.get(name, name))


def _num(v, fmt: str = ",.0f") -> str:
    return format(v, fmt) if isinstance(v, int | float) else str(v)


def time_text(timings: dict, elapsed_s: float | None = None) -> str:
    """The job's time as measured: ``elapsed_s`` (the dialog's clock, from Export to the
    finished job) when given, else the manifest's total; then where it went."""
    total = timings.get("total")
    head = (f"{measured_text(elapsed_s)} from Export to the finished job" if elapsed_s is not None
            else (f"{measured_text(total)}" if isinstance(total, int | float) else "-"))
    parts = [f"{what} {measured_text(timings[key])}" for key, what in (
        ("prepare", "preparing"), ("preflight", "of which pre-flight"),
        ("convert", "converting")) if isinstance(timings.get(key), int | float)
        and (key != "preflight" or timings[key] >= 0.05)]
    return head + (f" ({', '.join(parts)})" if parts else "")


def manifest_summary(manifest: dict, target: str, elapsed_s: float | None = None) -> str:
    """HTML summary of a finished job from its manifest: everything the operator checks
    (where, what from, which printer, size, halftoning, background, materials, clamping,
    time), with human names for the printer and the background (the ids stay in the file).
    ``elapsed_s``: the job's wall-clock time as the dialog measured it (else the manifest's)."""
    from html import escape

    nx, ny, nz = manifest["grid_dimensions"]
    sx, sy, sz = manifest["physical_size_mm"]
    total = max(1, int(manifest.get("total_voxels", nx * ny * nz)))
    pr = manifest.get("printer", {})
    vx, vy, vz = (1000 * v for v in manifest.get("voxel_mm", pr.get("voxel_mm", (0, 0, 0))))
    src = manifest.get("source", {})
    prof = manifest.get("profile", {})
    ht = manifest.get("halftoning", {})
    bg = manifest.get("background", {})
    bg_mode = bg.get("mode", "") if isinstance(bg, dict) else str(bg)
    labels = manifest.get("labels", {})
    mean = manifest.get("mean_concentration", {})
    rows = []
    for lab, n in manifest.get("voxel_counts", {}).items():
        info = labels.get(lab, {})
        rgb = info.get("rgb") or pr.get("empty_rgb")
        swatch = (f"<td bgcolor='#{rgb[0]:02x}{rgb[1]:02x}{rgb[2]:02x}'>&nbsp;&nbsp;&nbsp;</td>"
                  if rgb else "<td></td>")
        conc = mean.get(lab)
        rows.append(f"<tr>{swatch}<td>{escape(lab)}</td><td>{escape(info.get('material', ''))}"
                    f"</td><td align=right>{n:,}</td><td align=right>{100 * n / total:.2f} %"
                    f"</td><td align=right>{'' if conc is None else f'{conc:.4f}'}</td></tr>")
    from dreamprint_gui.job.clamp_report import clamp_summary

    clamp_line = clamp_summary(manifest)
    clamp_text = ("none" if clamp_line is None
                  else escape(gui_wording(clamp_line.removeprefix("clamped: "))))
    t = manifest.get("timings_s", {})
    ex = manifest.get("execution") or {}
    run_on = (f"; run on {ex.get('scheduler', 'threads')}"
              + (f", {ex['workers']} workers" if ex.get("workers") else "")
              + (f", {ex['slabs']} slabs" if ex.get("slabs") else "")) if ex else ""
    content = src.get("content") or manifest.get("content")
    content_text = ""
    if isinstance(content, dict) and content.get("mode"):
        content_text = (f", content {escape(str(content['mode']))}"
                        + (f" ({escape(str(content['reason']))})" if content.get("reason")
                           else ""))
    threshold = bg.get("density_threshold_per_mm") if isinstance(bg, dict) else None
    pf = manifest.get("preflight") or {}
    warnings = [w.get("message", "") for w in pf.get("warnings", []) if isinstance(w, dict)]
    warn_html = ("<p><b>Pre-flight warnings</b></p><ul style='margin-left: -20px'>"
                 + "".join(f"<li>{escape(gui_wording(m))}</li>" for m in warnings) + "</ul>"
                 if warnings else "")
    sl = manifest.get("slices", {})
    return (
        f"<p><b>Job complete</b>: {escape(target)}</p>"
        "<table cellspacing=3>"
        f"<tr><td><b>Source</b></td><td>{escape(str(src.get('path', '')))}, density scale "
        f"{_num(src.get('density_scale', 1.0), 'g')}{content_text}</td></tr>"
        f"<tr><td><b>Printer</b></td><td>{escape(_manifest_printer_name(pr))} "
        f"(voxel {vx:.0f} x {vy:.0f} x {vz:.0f} um, {escape(str(pr.get('png_mode', '')))} "
        "PNG)</td></tr>"
        f"<tr><td><b>Size</b></td><td>{sx:.2f} x {sy:.2f} x {sz:.2f} mm: {nz} slices of "
        f"{nx} x {ny} voxels ({total:,} voxels)"
        + (f", {escape(str(sl.get('first', '')))} .. {escape(str(sl.get('last', '')))}"
           if sl.get("first") else "") + "</td></tr>"
        f"<tr><td><b>Ink profile</b></td><td>{escape(str(prof.get('name', '')))}, table "
        f"{prof.get('table_size', '')}<sup>3</sup> ({escape(str(prof.get('objective', '')))})"
        "</td></tr>"
        f"<tr><td><b>Halftoning</b></td><td>{escape(str(ht.get('method', '')))}, seed "
        f"{manifest.get('seed')}</td></tr>"
        f"<tr><td><b>Background</b></td><td>{escape(background_name(bg_mode))}"
        + (f" below {threshold:.3g} /mm" if isinstance(threshold, float) else "")
        + "</td></tr>"
        + compensation_row(manifest.get("compensation")) +
        f"<tr><td><b>Clamped densities</b></td><td>{clamp_text}</td></tr>"
        f"<tr><td><b>Time</b></td><td>{time_text(t, elapsed_s)}"
        + (f", {t['voxels_per_second']:,.0f} voxels/s" if "voxels_per_second" in t else "")
        + run_on + "</td></tr></table>"
        "<p><b>Materials</b></p>"
        "<table cellspacing=4><tr><th></th><th>label</th><th>material</th><th>voxels</th>"
        f"<th>share</th><th>mean conc.</th></tr>{''.join(rows)}</table>" + warn_html)


def compensation_row(comp: dict | None) -> str:
    """The summary's row of a compensated job: the correction file and the optimiser's
    figures on its training cameras (empty without a correction)."""
    from html import escape

    if not comp:
        return ""
    f = comp.get("proof_figures") or {}
    b, a = f.get("before") or {}, f.get("after") or {}
    figs = (f"; on its training cameras dE2000 mean {b['mean_de2000']:.2f} -> "
            f"{a['mean_de2000']:.2f}, coverage error {b['coverage_error']:+.3f} -> "
            f"{a['coverage_error']:+.3f}" if "mean_de2000" in b and "mean_de2000" in a else "")
    sec = comp.get("optimise_seconds")
    took = f"; optimised in {measured_text(sec)}" if isinstance(sec, int | float) else ""
    return (f"<tr><td><b>Compensation</b></td><td>{escape(Path(comp['path']).name)}"
            f"{figs}{took}</td></tr>")


def preflight_html(pf) -> str:
    """The engine's pre-flight summary (``Preflight.summary_lines``) as the dialog shows it:
    the figures, then the warnings in bold, command-line options named as the controls in
    both."""
    from html import escape

    lines = [ln for ln in pf.summary_lines() if not ln.startswith("warning: ")]
    body = "".join(f"<li>{escape(gui_wording(ln))}</li>" for ln in lines)
    warn = "".join(f"<li><b>{escape(gui_wording(w.message))}</b></li>" for w in pf.warnings)
    return (f"<ul style='margin-left: -20px'>{body}</ul>"
            + (f"<p><b>Warnings</b></p><ul style='margin-left: -20px'>{warn}</ul>" if warn
               else "<p>No warnings.</p>"))


def printer_file_name(path: str) -> str:
    from dreamprint_gui.core.printer import load_printer

    try:
        return printer_name(load_printer(path))
    except DreamPrintError:
        return Path(path).stem  # the dialog says what is wrong with it
