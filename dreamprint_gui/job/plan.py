"""Stage 1 of a print job, the plan: what to convert, on which grid, with which tables.

Defines
-------
- :class:`ConvertSettings`: everything ``dreamprint convert`` takes.
- :class:`ConvertProgress`: what the conversion yields (layers done/total, voxels, elapsed, ETA).
- :class:`JobContext` and :func:`prepare_job`: resolve settings into the source, the printer
  grid, the colour tables (paper section 4.1-4.2), the halftoner and the printer; refuse a job
  larger than the tray before any work.
- :func:`_slabs`: the slabs of layers ``[z0, z1)`` the job is cut into (the slab plan), and
  :func:`_scheduler_kind`: which Dask scheduler runs them (:mod:`.run`).
"""

from __future__ import annotations

import os
import threading
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from dreamprint_gui.core.errors import DreamPrintError
from dreamprint_gui.core.printer import EMPTY_LABEL, PrinterProfile, check_tray, load_printer
from dreamprint_gui.core.profile import INKS, load_profile
from dreamprint_gui.gamut import get_tables
from dreamprint_gui.gamut.alignment import kernel_table
from dreamprint_gui.gamut.mapping import canonical_intent
from dreamprint_gui.gamut.optimise import canonical_objective
from dreamprint_gui.io.volumes import grid_for_source, open_source
from dreamprint_gui.io.volumes.registry import reader_options
from dreamprint_gui.job.content import CONTENT_MODES, apply_content
from dreamprint_gui.job.halftone import HALFTONE_METHODS, Halftoner
from dreamprint_gui.physics.density import scalar_sigma

__all__ = ["ConvertSettings", "ConvertProgress", "JobContext", "prepare_job", "JobCancelled",
           "DEFAULT_SLAB_VOXELS", "source_options_for", "replace_settings"]

DEFAULT_SLAB_VOXELS = 4_000_000  # ~70 MB of working arrays per worker


class JobCancelled(Exception):
    """The conversion was cancelled (GUI cancel, Ctrl-C)."""


@dataclass(frozen=True)
class ConvertSettings:
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
    slab_layers: int | None = None        # None: ~DEFAULT_SLAB_VOXELS per slab
    objective: str | None = None          # gamut table objective (None: profile's/default)
    intent: str | None = None             # rendering intent (None: profile's/colorimetric)
    table_size: int = 100
    source_options: dict[str, Any] = field(default_factory=dict)
    content: str = "auto"                 # "fog" | "solid" | "auto" (job.content)
    sampling: str | None = None           # None: the reader's default; "nearest" | "linear"


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


def _tables_for(profile_spec, layer_mm: float, objective, size: int, intent=None):

    profile = load_profile(profile_spec).with_settings(layer_thickness_mm=layer_mm)
    return profile, get_tables(profile, objective=objective, size=size, intent=intent)


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
                    tables.packed.shape[0], tables.brightness_rho_k.astype(np.float64),
                    np.float32(tables.sigma_clear), *ht.kernel_args())
            self.__dict__["_kernel_args"] = args
        return args

    def resources(self):
        if self.source is not None and self.tables is not None:
            return self.source, self.tables
        s = self.settings
        key = (s.source, self.source_stamp, repr(sorted(s.source_options.items())),
               str(s.profile), self.printer.layer_thickness_mm, s.objective, s.table_size,
               s.content, s.sampling, s.intent)
        with _WORKER_LOCK:
            if key not in _WORKER_CACHE:

                mode = self.content.mode if self.content is not None else "fog"
                src = _open_source(s.source, s.source_options, s.content, s.sampling)
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


def prepare_job(settings: ConvertSettings) -> JobContext:
    """Open the source, lay out the grid, refuse a job larger than the tray, build the tables."""

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
    if (s.height_mm is None) == (s.size_mm is None):
        raise DreamPrintError("give exactly one of --height-mm and --size-mm")
    if not (np.isfinite(s.density_scale) and s.density_scale >= 0):
        raise DreamPrintError(f"--density-scale must be >= 0, got {s.density_scale}")
    if s.workers is not None and s.workers < 1:
        raise DreamPrintError(f"--workers must be at least 1, got {s.workers}")
    if s.content not in CONTENT_MODES:
        raise DreamPrintError(f"--content must be fog, solid or auto, not '{s.content}'")
    printer = load_printer(s.printer)
    source = _open_source(s.source, s.source_options, s.content, s.sampling)
    grid = grid_for_source(source, printer.voxel_mm, height_mm=s.height_mm,
                           size_mm=tuple(s.size_mm) if s.size_mm is not None else None)
    shape = tuple(int(v) for v in grid.shape_xyz)
    if min(shape) < 1:
        raise DreamPrintError(f"the job would have no voxels (grid {shape[0]} x {shape[1]} x "
                              f"{shape[2]}); choose a larger size")
    check_tray(shape, printer)  # before any expensive work
    profile, tables = _tables_for(s.profile, printer.layer_thickness_mm, s.objective,
                                  s.table_size, s.intent)
    sigma_clear = getattr(tables, "sigma_clear", None)
    if sigma_clear is None:
        sigma_clear = _clear_sigma(profile)
    thr = s.density_threshold if s.density_threshold is not None else 0.5 * float(sigma_clear)
    bg = INKS.index("Cl") if s.background == "clear" else EMPTY_LABEL
    ht = Halftoner.create(s.halftone, s.seed, printer.voxel_mm, threshold=thr, bg_label=bg)
    source, content = apply_content(source, s.content, thr)
    ctx = JobContext(settings=s, printer=printer, grid=grid, halftoner=ht,
                     palette=printer.palette(), profile_name=profile.name,
                     profile_fingerprint=profile.fingerprint(), source=source, tables=tables,
                     content=content, source_stamp=_stamp(s.source))
    return ctx

# ----------------------------------------------------------------------------- scheduling
def _slabs(ctx: JobContext, workers: int) -> list[tuple[int, int]]:
    nx, ny, nz = ctx.shape_xyz
    if ctx.settings.slab_layers:
        step = int(ctx.settings.slab_layers)
    else:
        step = max(1, DEFAULT_SLAB_VOXELS // max(1, nx * ny))
        # >= 4 slabs per worker to balance, and >= 32 (if there are as many layers) so that
        # the progress moves with the slabs: a slab costs one call and no new memory.
        step = min(step, max(1, -(-nz // max(32, 4 * workers))))
    return [(z, min(nz, z + step)) for z in range(0, nz, step)]


def _scheduler_kind(s: ConvertSettings) -> str:
    sch = (s.scheduler or "threads").strip()
    if sch in ("threads", "sync", "processes"):
        return sch
    if "://" in sch or ":" in sch:
        return "distributed"
    raise DreamPrintError(f"unknown scheduler '{sch}' (threads, processes, or an address like "
                          "tcp://host:8786)")


def replace_settings(settings: ConvertSettings, **changes: Any) -> ConvertSettings:
    return replace(settings, **changes)
