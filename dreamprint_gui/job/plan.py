"""Stage 1 of a print job, the plan: what to convert, on which grid, with which tables.

Defines
-------
- :class:`ConvertSettings`: everything ``dreamprint convert`` takes.
- :class:`ConvertProgress`: what the conversion yields (layers done/total, voxels, elapsed, ETA).
- :class:`JobContext` and :func:`prepare_job`: resolve settings into the source (turned by
  ``--up`` / ``--rotate`` or its known convention, :mod:`..io.volumes.orient`), the printer
  grid (over the occupied or the declared bounds, ``--fit``; :func:`fitted_bounds`), the colour
  tables (paper section 4.1-4.2), the halftoner and the printer; refuse a job larger than the
  tray before any work. :func:`resized_job`: a prepared job at another size, density scale or
  background, its source and tables kept (the Preview, as a control is dragged).
- :func:`slab_plan`: the slabs of layers ``[z0, z1)`` the job is cut into (the slab plan) for
  :func:`job_workers` workers, and
  :func:`scheduler_kind`: which Dask scheduler runs them (:mod:`.run`).
"""

from __future__ import annotations

import os
import threading
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from dreamprint_gui.core.durations import about_text
from dreamprint_gui.core.errors import DreamPrintError
from dreamprint_gui.core.kernel_cache import compile_notice
from dreamprint_gui.core.print_size import check_print_size
from dreamprint_gui.core.printer import EMPTY_LABEL, PrinterProfile, check_tray, load_printer
from dreamprint_gui.core.profile import INKS, load_profile
from dreamprint_gui.core.progress import percent_reporter
from dreamprint_gui.gamut import get_tables
from dreamprint_gui.gamut.alignment import kernel_table
from dreamprint_gui.gamut.mapping import canonical_intent
from dreamprint_gui.gamut.optimise import canonical_objective
from dreamprint_gui.gamut.tables import build_estimate, resolve_choice
from dreamprint_gui.io.volumes import PrintGrid, grid_for_source, open_source
from dreamprint_gui.io.volumes.orient import (
    FIT_MODES,
    choose_orientation,
    occupied_bounds,
    orient_source,
)
from dreamprint_gui.io.volumes.registry import reader_options
from dreamprint_gui.job.content import CONTENT_MODES, apply_content, choose_content
from dreamprint_gui.job.correction import (
    check_correction,
    load_correction,
    placement_key,
    rendering_key,
)
from dreamprint_gui.job.halftone import HALFTONE_METHODS, Halftoner, mask_build_estimate
from dreamprint_gui.job.prepare_time import (
    compile_estimate,
    machine_slowdown,
    parallel_slowdown,
    source_bytes,
)
from dreamprint_gui.job.spec import HasSpec
from dreamprint_gui.job.write import JobCancelled
from dreamprint_gui.physics.density import scalar_sigma

__all__ = ["ConvertSettings", "ConvertProgress", "JobContext", "prepare_job", "check_settings",
           "JobCancelled", "DEFAULT_SLAB_VOXELS", "source_options_for", "replace_settings",
           "fitted_bounds", "slab_plan", "job_workers", "MAX_SLAB_VOXELS", "profile_for_printer",
           "scheduler_kind", "resized_job", "RESIZABLE"]

DEFAULT_SLAB_VOXELS = 4_000_000  # ~70 MB of working arrays per worker
MAX_SLAB_VOXELS = 32_000_000     # all workers' slabs when a source asks for layers: ~520 MB


@dataclass(frozen=True)
class ConvertSettings(HasSpec):
    """A conversion: the print (the :class:`..spec.PrintSpec` fields, ``.spec``) and the job's
    own options (output, workers, scheduler, threshold, slabs, overwrite)."""

    source: str
    output: str | os.PathLike | None = None
    profile: str | os.PathLike | None = None
    printer: str | os.PathLike | None = None
    height_mm: float | None = None
    size_mm: tuple[float, float, float] | None = None
    density_scale: float = 1.0
    halftone: str = "blue-noise"
    seed: int = 0
    workers: int | None = None            # None: all cores
    scheduler: str | None = None          # None/"threads", "processes", "tcp://host:port"
    background: str = "clear"             # "clear" | "empty"
    density_threshold: float | None = None  # 1/mm; None: half the density of pure Clear
    overwrite: bool = False
    slab_layers: int | None = None        # None: ~DEFAULT_SLAB_VOXELS per slab (slab_plan)
    objective: str | None = None          # gamut table objective (None: profile's/default)
    intent: str | None = None             # rendering intent (None: profile's/colorimetric)
    table_size: int = 100
    source_options: dict[str, Any] = field(default_factory=dict)
    content: str = "auto"                 # "fog" | "solid" | "auto" (job.content)
    sampling: str | None = None           # None: the reader's default; "nearest" | "linear"
    compensation: str | os.PathLike | None = None  # a correction file (job.correction)
    up: str | None = None                 # source axis that becomes +z; None: auto (orient)
    rotate: int = 0                       # degrees about the print's z (quarter turns)
    fit: str = "occupied"                 # "occupied" (non-empty bounds) | "box" (declared)
    resume: bool = False                  # finish an interrupted run's folder (job.resume)


@dataclass(frozen=True)
class ConvertProgress:
    stage: str                 # "preparing", "converting", "finishing", "done"
    layers_done: int
    layers_total: int
    voxels_done: int
    voxels_total: int
    elapsed_s: float
    eta_s: float | None
    message: str = ""
    preflight: Any = None      # job.preflight.Preflight, on the "preflight" stage


# ----------------------------------------------------------------------------- context
_WORKER_CACHE: dict[Any, Any] = {}
_WORKER_LOCK = threading.Lock()


def source_options_for(spec: str, options: dict[str, Any], content: str = "fog",
                       sampling: str | None = None) -> dict[str, Any]:
    """The reader options of a job: ``options`` plus what ``content`` and ``sampling`` imply.

    ``content`` solid or auto opens a level set as a solid (``level_set="solid"``) unless the
    operator chose otherwise; ``sampling`` ("nearest" or "linear") goes to a reader that offers
    it (voxel models); every other reader samples trilinearly, so "nearest" is refused there.
    """

    opts = dict(options)
    takes = reader_options(spec)
    if content != "fog" and "level_set" in takes and "level_set" not in opts:
        opts["level_set"] = "solid"
    if sampling is not None:
        if sampling not in ("nearest", "linear"):
            raise DreamPrintError(f"--sampling must be nearest or linear, not '{sampling}'")
        if "sampling" in takes:
            opts.setdefault("sampling", sampling)
        elif sampling == "nearest":
            raise DreamPrintError("--sampling nearest applies to voxel models (.vox); this "
                                  "source is sampled trilinearly", spec)
    return opts


def _open_source(spec: str, options: dict[str, Any], content: str = "fog",
                 sampling: str | None = None):

    return open_source(spec, **source_options_for(spec, options, content, sampling))


def profile_for_printer(profile, printer=None):
    """The ink profile as a job on ``printer`` uses it: at the printer's layer thickness (the
    density of eq. 9 is per layer), so that the job, the GUI's preview and gamut pages,
    ``lookup`` and ``gamut`` share one set of cached tables. ``profile``: an InkProfile, a
    path or None (built-in); ``printer``: a PrinterProfile, a name, a path or None (the default
    printer)."""
    if not hasattr(profile, "with_settings"):
        profile = load_profile(profile)
    if not isinstance(printer, PrinterProfile):
        printer = load_printer(printer)
    return profile.with_settings(layer_thickness_mm=printer.layer_thickness_mm)


def _tables_for(profile_spec, layer_mm: float, objective, size: int, intent=None,
                notify: Callable[[str], None] | None = None):
    """The profile at the printer's layer and its tables; a first-use build is announced with
    its estimated time and its progress through ``notify`` (and, first, numba compiling its
    kernels, :func:`..gamut.tables.get_tables`)."""

    profile = load_profile(profile_spec).with_settings(layer_thickness_mm=layer_mm)
    progress = None
    est = build_estimate(profile, objective, size, intent) if notify is not None else None
    if est is not None:
        est *= parallel_slowdown()         # the machine now, as the pre-flight's estimate
        obj, how = resolve_choice(profile, objective, intent)
        notify(f"building colour tables ({obj}, {how}, {size}^3) for this profile and "
               f"{layer_mm * 1000:g} um layers: first use, {about_text(est)}; cached after")
        progress = percent_reporter(lambda pct: notify(f"building colour tables: {pct:3d} %"))

    # a build's kernels not yet compiled: announced and their compile's heartbeat relayed
    return profile, get_tables(profile, objective=objective, size=size, intent=intent,
                               progress=progress, notify=notify)


# A source file at least this large is announced before it is read (reading takes seconds).
OPENING_NOTICE_BYTES = 50_000_000



@dataclass
class JobContext:
    """Everything a slab task needs. Pickles without the source and the tables: a process or
    cluster worker reopens them (the tables from the on-disk cache) once per process."""

    settings: ConvertSettings
    printer: PrinterProfile
    grid: Any
    halftoner: Halftoner
    palette: np.ndarray
    profile_name: str = ""
    profile_fingerprint: str = ""
    source: Any = None
    tables: Any = None
    content: Any = None  # job.content.ContentChoice (None: fog)
    # the source file's size and mtime when the job was planned (:func:`_stamp`): part of a
    # worker's cache key, so a long-lived worker reopens a source edited since its last job
    source_stamp: tuple = ()
    # job.correction.Correction applied to the samples before the table lookup (None: none);
    # a small read-only field that pickles with the context to every worker
    correction: Any = None
    orientation: Any = None  # io.volumes.orient.Orientation (resolved: never "auto")
    fit: dict = field(default_factory=dict)  # placement_json()'s "fit"
    # measured seconds of preparing: opening and placing the source, loading or building the
    # tables (what .prepare_time estimates before; the manifest's timings_s.prepare_parts)
    prepare_timings: dict = field(default_factory=dict)

    @property
    def fit_bounds(self):
        """The bounds the grid covers: the occupied ones (``--fit occupied``), or None for the
        source's declared box."""
        return self.fit.get("bounds") if self.fit.get("mode") == "occupied" else None

    def placement_json(self) -> dict[str, Any]:
        """The orientation and fit of the job (manifest ``placement``, pre-flight)."""
        o = self.orientation
        return {"orientation": o.to_json() if o is not None else None,
                "orientation_text": o.describe() if o is not None else "up = source z",
                "fit": dict(self.fit), "object_size_mm": list(self.grid.size_mm)}

    @property
    def shape_xyz(self) -> tuple[int, int, int]:
        return tuple(int(v) for v in self.grid.shape_xyz)

    def __getstate__(self) -> dict:
        d = dict(self.__dict__)
        d["source"] = None
        d["tables"] = None
        d.pop("_kernel_args", None)
        return d

    def kernel_args(self) -> tuple:
        """The per-job arguments of :func:`.layer_kernel.slab_labels` (built once per process)."""
        args = self.__dict__.get("_kernel_args")
        if args is None:

            _, tables = self.resources()
            ht = self.halftoner
            args = (np.float32(ht.threshold), ht.bg_label, kernel_table(tables),
                    tables.packed.shape[0], np.float32(tables.sigma_clear), *ht.kernel_args())
            self.__dict__["_kernel_args"] = args
        return args

    def resources(self):
        if self.source is not None and self.tables is not None:
            return self.source, self.tables
        s = self.settings
        o = self.orientation
        key = (s.source, self.source_stamp, repr(sorted(s.source_options.items())),
               str(s.profile), self.printer.layer_thickness_mm, s.objective, s.table_size,
               s.content, s.sampling, s.intent, None if o is None else (o.up, o.rotate))
        with _WORKER_LOCK:
            if key not in _WORKER_CACHE:

                mode = self.content.mode if self.content is not None else "fog"
                src = _open_source(s.source, s.source_options, s.content, s.sampling)
                if self.orientation is not None:
                    src = orient_source(src, self.orientation)
                src, _ = apply_content(src, mode, self.halftoner.threshold)
                _, tables = _tables_for(s.profile, self.printer.layer_thickness_mm,
                                        s.objective, s.table_size, s.intent)
                _WORKER_CACHE.clear()  # one job per worker process at a time
                _WORKER_CACHE[key] = (src, tables)
            return _WORKER_CACHE[key]


def _stamp(spec: str) -> tuple:
    """Size and modification time of a source file, or of a source folder's entries (taken
    once, when the job is planned)."""
    try:
        st = os.stat(spec)
        if not os.path.isdir(spec):
            return (st.st_size, st.st_mtime_ns)
        with os.scandir(spec) as it:
            return tuple(sorted((e.name, _stamp(e.path)) for e in it))
    except OSError:
        return ()  # "demo", or a path that cannot be read (opening it says so)


def _clear_sigma(profile) -> float:

    return float(scalar_sigma(profile.K[INKS.index("Cl")], profile.S[INKS.index("Cl")],
                              profile.layer_thickness_mm, profile.density_t_max_mm,
                              profile.density_samples))


def fitted_bounds(source, fit: str) -> tuple[Any, dict[str, Any]]:
    """The bounds a job's grid covers for ``--fit`` (``occupied``: the source's non-empty
    bounds, :func:`..io.volumes.orient.occupied_bounds`; ``box``: its declared bounds) and
    the manifest's ``fit`` record (mode, both boxes in print-frame source units, and what
    happened when nothing is occupied)."""
    declared = [list(source.bounds[0]), list(source.bounds[1])]
    if fit == "box":
        return None, {"mode": "box", "bounds": declared, "declared_bounds": declared}
    occ = occupied_bounds(source)
    if occ is None:
        return None, {"mode": "box", "requested": "occupied", "bounds": declared,
                      "declared_bounds": declared,
                      "note": "nothing occupied: the file's declared box is used"}
    return occ, {"mode": "occupied", "bounds": [list(occ[0]), list(occ[1])],
                 "declared_bounds": declared}


def check_settings(settings: ConvertSettings) -> None:
    """The checks of a job's settings that need no file: a bad or missing choice (a missing
    --height-mm / --size-mm included) is reported before the source is opened or any message
    says it is being opened."""
    s = settings
    if s.halftone not in HALFTONE_METHODS:
        raise DreamPrintError(f"unknown halftoning '{s.halftone}' "
                              f"(use {' or '.join(HALFTONE_METHODS)})")
    if s.objective is not None or s.intent is not None:
        try:
            canonical_objective(s.objective, "cielab")
            canonical_intent(s.intent)
        except ValueError as exc:
            raise DreamPrintError(str(exc)) from None
    if s.background not in ("clear", "empty"):
        raise DreamPrintError(f"--background must be clear or empty, not '{s.background}'")
    check_print_size(s.height_mm, s.size_mm)
    if not (np.isfinite(s.density_scale) and s.density_scale >= 0):
        raise DreamPrintError(f"--density-scale must be >= 0, got {s.density_scale}")
    if s.workers is not None and s.workers < 1:
        raise DreamPrintError(f"--workers must be at least 1, got {s.workers}")
    if s.content not in CONTENT_MODES:
        raise DreamPrintError(f"--content must be fog, solid or auto, not '{s.content}'")
    if s.fit not in FIT_MODES:
        raise DreamPrintError(f"--fit must be occupied or box, not '{s.fit}'")


def _compile_notices(source) -> list[str]:
    """Announcements of the kernels numba has not compiled yet (:func:`.prepare_time.
    compile_estimate`): the first run after an install or upgrade, or of a source kind."""
    import sys

    reader = sys.modules.get(type(source).__module__)
    out = []
    for what, sec in compile_estimate(reader).items():
        why = ("first use of this source kind" if what.endswith("reader's kernels")
               else "first run after an install or upgrade")
        out.append(compile_notice(what, why, sec))
    return out


def prepare_job(settings: ConvertSettings,
                notify: Callable[[str], None] | None = None) -> JobContext:
    """Open the source, lay out the grid, refuse a job larger than the tray, build the tables.

    ``notify(message)`` is told of each first-use build (compiled kernels, colour tables,
    blue-noise mask) before it starts, with its estimated time, and of the tables' progress;
    of a large source file (``OPENING_NOTICE_BYTES``) before it is read, and of any source
    that took more than 2 s to open, with the time it took."""
    import time

    s = settings
    check_settings(s)
    printer = load_printer(s.printer)
    name = os.path.basename(str(s.source).rstrip("/")) or str(s.source)
    if notify is not None and source_bytes(str(s.source)) >= OPENING_NOTICE_BYTES:
        notify(f"opening the source {name} ({source_bytes(str(s.source)) / 1e6:.0f} MB) ...")
    t_open = t_source = time.perf_counter()
    source = _open_source(s.source, s.source_options, s.content, s.sampling)
    t_open = time.perf_counter() - t_open
    if notify is not None and t_open > 2.0:   # a slow source: its placement samples it too
        notify(f"opened the source {name} in {t_open:.1f} s; placing it (its up axis, its "
               "occupied bounds) ...")
    if notify is not None:
        for msg in _compile_notices(source):
            notify(msg)
    orientation = choose_orientation(source, s.up, s.rotate)
    source = orient_source(source, orientation)
    bounds, fit = fitted_bounds(source, s.fit)
    t_source = time.perf_counter() - t_source
    grid = _job_grid(source, printer, s, bounds)  # the tray checked before any expensive work
    shape = tuple(int(v) for v in grid.shape_xyz)
    t_tables = time.perf_counter()
    profile, tables = _tables_for(s.profile, printer.layer_thickness_mm, s.objective,
                                  s.table_size, s.intent, notify)
    t_tables = time.perf_counter() - t_tables
    sigma_clear = getattr(tables, "sigma_clear", None)
    if sigma_clear is None:
        sigma_clear = _clear_sigma(profile)
    thr = s.density_threshold if s.density_threshold is not None else 0.5 * float(sigma_clear)
    if notify is not None and s.halftone == "blue-noise":
        est = mask_build_estimate(printer.voxel_mm)
        if est is not None:
            est *= machine_slowdown()
            vx, vy, vz = (1000 * v for v in printer.voxel_mm)
            notify(f"building the blue-noise mask for {vx:g} x {vy:g} x {vz:g} um voxels: "
                   f"first use, {about_text(est)}; cached after")
    ht = _job_halftoner(s, printer, thr)
    oriented = source
    source, content = apply_content(source, s.content, thr)
    ctx = JobContext(settings=s, printer=printer, grid=grid, halftoner=ht,
                     palette=printer.palette(), profile_name=profile.name,
                     profile_fingerprint=profile.fingerprint(), source=source, tables=tables,
                     content=content, source_stamp=_stamp(s.source), orientation=orientation,
                     fit=fit, prepare_timings={"source": t_source, "tables": t_tables})
    if s.compensation is not None:
        corr = load_correction(s.compensation)
        auto = content.mode if content.requested == "auto" else choose_content(oriented)[0]
        check_correction(corr, s.compensation, source=s.source,
                         print_size_mm=tuple(n * v for n, v in zip(shape, printer.voxel_mm,
                                                                    strict=True)),
                         printer=printer.name, profile_fingerprint=ctx.profile_fingerprint,
                         background=s.background, placement=placement_key(ctx),
                         rendering=rendering_key(ctx),
                         default_rendering=dict(zip(("objective", "intent"),
                                                    resolve_choice(profile, None, None),
                                                    strict=True), content=auto),
                         density_threshold=thr, default_density_threshold=0.5 * float(sigma_clear))
        ctx.correction = corr
    return ctx


#: What a prepared job can change without opening its source or building its tables again: the
#: printer grid's size and the background label (:func:`resized_job`).
RESIZABLE = ("height_mm", "size_mm", "density_scale", "background")


def resized_job(previous: JobContext, settings: ConvertSettings) -> JobContext | None:
    """``previous`` (a :func:`prepare_job` context) for ``settings`` when they differ from its
    own only in :data:`RESIZABLE`: the open source, its orientation and fitted bounds, the
    tables and the background threshold are kept; the grid (and the tray check) and the
    halftoner's background label are redone, and the settings checked, as :func:`prepare_job`
    does them. None when any other setting differs, or when a correction is applied (it is
    checked against the size): then the job must be prepared again. The Preview calls it as a
    control is dragged."""
    same = replace(previous.settings, **{k: getattr(settings, k) for k in RESIZABLE})
    if same != settings or settings.compensation is not None:
        return None
    check_settings(settings)  # what prepare_job refuses (a negative density, no size, ...)
    grid = _job_grid(previous.source, previous.printer, settings, previous.fit_bounds)
    return replace(previous, settings=settings, grid=grid,
                   halftoner=_job_halftoner(settings, previous.printer,
                                            previous.halftoner.threshold))


def _job_grid(source, printer, s: ConvertSettings, bounds) -> PrintGrid:
    """The printer grid of the job ``s`` over ``bounds`` (:func:`fitted_bounds`), refused when
    empty or larger than the printer's tray."""
    grid = grid_for_source(source, printer.voxel_mm, height_mm=s.height_mm,
                           size_mm=tuple(s.size_mm) if s.size_mm is not None else None,
                           bounds=bounds)
    shape = tuple(int(v) for v in grid.shape_xyz)
    if min(shape) < 1:
        raise DreamPrintError(f"the job would have no voxels (grid {shape[0]} x {shape[1]} x "
                              f"{shape[2]}); choose a larger size")
    check_tray(shape, printer)
    return grid


def _job_halftoner(s: ConvertSettings, printer, threshold: float) -> Halftoner:
    """The job's halftoner: its method and seed, the background below ``threshold`` (1/mm)
    printed as Clear or left empty (``s.background``)."""
    bg = INKS.index("Cl") if s.background == "clear" else EMPTY_LABEL
    return Halftoner.create(s.halftone, s.seed, printer.voxel_mm, threshold=threshold,
                            bg_label=bg)


# ----------------------------------------------------------------------------- scheduling
def job_workers(settings: ConvertSettings) -> int:
    """The workers a job's slabs are cut for (``--workers``, else every core)."""
    return int(settings.workers or os.cpu_count() or 1)


def slab_plan(ctx: JobContext, workers: int) -> list[tuple[int, int]]:
    nx, ny, nz = ctx.shape_xyz
    if ctx.settings.slab_layers:
        step = int(ctx.settings.slab_layers)
    else:
        step = max(1, DEFAULT_SLAB_VOXELS // max(1, nx * ny))
        # >= 4 slabs per worker to balance, and >= 32 (if there are as many layers) so that
        # the progress moves with the slabs: a slab costs one call and no new memory.
        step = min(step, max(1, -(-nz // max(32, 4 * workers))))
        # A sampler that works a few layers at a time (Gaussian splats: set up once per slab,
        # walked 8 layers together) gets them where layers are big and in short jobs (fewer
        # than 32 slabs then), with >= 4 slabs per worker and all workers' slabs together
        # within MAX_SLAB_VOXELS (or DEFAULT_SLAB_VOXELS each, as by size, on many workers)
        want = int(getattr(ctx.source, "slab_layers", 1))
        if want > step:
            cap = max(DEFAULT_SLAB_VOXELS, MAX_SLAB_VOXELS // workers)
            step = max(step, min(want, cap // max(1, nx * ny), nz // (4 * workers)))
    return [(z, min(nz, z + step)) for z in range(0, nz, step)]


def scheduler_kind(s: ConvertSettings) -> str:
    """The kind of scheduler ``--scheduler`` names: threads, sync, processes or distributed
    (an address); anything else is refused in one line."""
    sch = (s.scheduler or "threads").strip()
    if sch in ("threads", "sync", "processes"):
        return sch
    if "://" in sch or ":" in sch:
        return "distributed"
    raise DreamPrintError(f"unknown scheduler '{sch}' (threads, processes, or an address like "
                          "tcp://host:8786)")


def replace_settings(settings: ConvertSettings, **changes: Any) -> ConvertSettings:
    return replace(settings, **changes)
