"""The print-job conversion (paper Fig. 2 and section 4), streamed slab by slab.

Defines
-------
- :class:`ConvertSettings`: everything ``dreamprint convert`` takes.
- :class:`ConvertProgress`: what the conversion yields (layers done/total, voxels, elapsed, ETA).
- :func:`run_conversion`: a generator driven by the CLI and the GUI alike; yields progress and
  returns the manifest dict once the job folder is complete and renamed into place.
- :func:`prepare_job`: resolve settings into a :class:`JobContext` (source, grid, tables,
  halftoner, printer) and refuse a job larger than the tray before any work.
- :func:`halftone_layer`: the labels (ny, nx) of one layer, for the GUI's slice scrubber
  (byte-identical to the layer in an exported job).

Per slab of layers ``[z0, z1)``: sample the source on the printer grid (density in 1/mm, the
volume source's rule) into the worker thread's reused buffers; then one compiled call
(:func:`.layer_kernel.slab_labels`, nogil) does, layer by layer, the background threshold
(``--background clear|empty``) -> trilinear table lookup of C, M, Y, K, W -> density alignment
(Clear, K/W grey; the code of ``lookup_and_align_into``) -> halftone (the rule of
``halftone.pick_label``) -> label. A dense grid (a source with a ``layer_plan``) is sampled a
layer at a time into one layer's buffers, each labelled at once by the same kernel, in one
compiled call (:mod:`.dense_job`; OpenVDB/NanoVDB fog volumes densified over their leaves:
:mod:`.leaf_grid_job`). Then each layer goes to PNG (:mod:`..io.png_slices`). Only a
slab is ever in memory per worker. Slabs run through Dask: the threaded scheduler (default, all
cores), the multiprocessing scheduler (``scheduler="processes"``), or a ``dask.distributed``
cluster (``scheduler="tcp://host:8786"``) whose workers write the slices into the job's
temporary folder directly, so that folder must be on a path every worker sees
(docs/print-jobs.md). Every label is a function of the voxel's position, the seed and its
concentrations, never of the slab or worker, so the slices are byte-identical whatever the slab
size, worker count or scheduler.
"""

from __future__ import annotations

import hashlib
import math
import os
import queue
import threading
import time
from collections.abc import Generator
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import DreamPrintError
from .content import CONTENT_MODES, apply_content
from .dense_job import dense_slab_labels, window_slab_labels
from .halftone import HALFTONE_METHODS, Halftoner
from .layer_kernel import slab_labels
from .leaf_grid_job import leaf_grid_slab_labels
from .printer import EMPTY_LABEL, PrinterProfile, check_tray, load_printer
from .profile import INKS

__all__ = ["ConvertSettings", "ConvertProgress", "JobContext", "run_conversion", "prepare_job",
           "halftone_layer", "JobCancelled", "DEFAULT_SLAB_VOXELS"]

DEFAULT_SLAB_VOXELS = 4_000_000  # ~70 MB of working arrays per worker
# A source's ``layer_kind`` -> the compiled call that samples and labels its layers (the
# arguments: the source's ``layer_plan``, one layer's rgb and density arrays, z0, the kernel's).
_LAYER_KERNELS = {"dense": dense_slab_labels, "leaf_grid": leaf_grid_slab_labels,
                  "window": window_slab_labels}
_LABELS = (*INKS, "empty")


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
    content: str = "auto"                 # "fog" | "solid" | "auto" (engine.content)
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
    preflight: Any = None      # engine.preflight.Preflight, on the "preflight" stage


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
    from ..io.volumes.base import reader_options

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
    from ..io.volumes import open_source

    return open_source(spec, **source_options_for(spec, options, content, sampling))


def _tables_for(profile_spec, layer_mm: float, objective, size: int, intent=None):
    from .gamut import get_tables
    from .profile import load_profile

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
    content: Any = None  # engine.content.ContentChoice (None: fog)

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
            from .gamut.alignment import kernel_table

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
        key = (s.source, repr(sorted(s.source_options.items())), str(s.profile),
               self.printer.layer_thickness_mm, s.objective, s.table_size, s.content,
               s.sampling, s.intent)
        with _WORKER_LOCK:
            if key not in _WORKER_CACHE:
                from .content import apply_content

                mode = self.content.mode if self.content is not None else "fog"
                src = _open_source(s.source, s.source_options, s.content, s.sampling)
                src, _ = apply_content(src, mode, self.halftoner.threshold)
                _, tables = _tables_for(s.profile, self.printer.layer_thickness_mm,
                                        s.objective, s.table_size, s.intent)
                _WORKER_CACHE.clear()  # one job per worker process at a time
                _WORKER_CACHE[key] = (src, tables)
            return _WORKER_CACHE[key]


def _clear_sigma(profile) -> float:
    from .density import scalar_sigma

    return float(scalar_sigma(profile.K[INKS.index("Cl")], profile.S[INKS.index("Cl")],
                              profile.layer_thickness_mm, profile.density_t_max_mm,
                              profile.density_samples))


def prepare_job(settings: ConvertSettings) -> JobContext:
    """Open the source, lay out the grid, refuse a job larger than the tray, build the tables."""
    from ..io.volumes import grid_for_source

    s = settings
    if s.halftone not in HALFTONE_METHODS:
        raise DreamPrintError(f"unknown halftoning '{s.halftone}' "
                              f"(use {' or '.join(HALFTONE_METHODS)})")
    if s.objective is not None or s.intent is not None:
        from .gamut.mapping import canonical_intent
        from .gamut.optimise import canonical_objective

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
                     content=content)
    _load_kernels(ctx)
    return ctx


def _load_kernels(ctx: JobContext) -> None:
    """Load the compiled kernels (numba's on-disk cache, ~0.5 s on a first call) now, while
    preparing, rather than in the first slab: the preparation is reported as such and the
    conversion's progress and speed are those of the conversion. The source's sampler is
    loaded by sampling one voxel (a grid of 1 x 1 x 1 at the job grid's corner)."""
    from ..io.png_slices import encode_labels_pngs

    # The same path (fused or general), sampler, types and arrays as the job's slabs.
    one_voxel = replace(ctx.grid, shape_xyz=(1, 1, 1))
    labels = np.empty((1, 1, 1), np.uint8)
    _slab_into(ctx, one_voxel, 0, 1, labels, np.zeros(7, np.int64), np.zeros((1, 7)),
               np.zeros(4))
    encode_labels_pngs(_oriented(ctx, labels), ctx.palette, ctx.printer.png_mode)
    if _scheduler_kind(ctx.settings) != "distributed":
        import dask.threaded  # noqa: F401 - the local scheduler's import, ~0.1 s


# ----------------------------------------------------------------------------- slab work
def _merge_clamped(acc: dict[str, float], add: dict[str, float]) -> None:
    for k, v in add.items():
        if k.startswith("max"):
            acc[k] = max(acc.get(k, 0.0), v)
        else:
            acc[k] = acc.get(k, 0.0) + v


def _labels_of_slab(ctx: JobContext, rgb: np.ndarray, dens: np.ndarray, z0: int,
                    labels: np.ndarray, counts: np.ndarray, sums: np.ndarray,
                    stats: np.ndarray) -> None:
    """Labels (L, ny, nx) of the sampled layers ``z0 .. z0 + L - 1`` (rgb (L, ny, nx, 3), dens
    (L, ny, nx)); accumulates counts, intended concentration sums (``sums`` (L, 7), per layer)
    and the clamp report."""
    n_layers = labels.shape[0]
    rgb = np.ascontiguousarray(rgb.reshape(n_layers, -1, 3), dtype=np.float32)
    d = np.ascontiguousarray(dens.reshape(n_layers, -1), dtype=np.float32)
    # Background voxels skip the lookup: faster, and they are not "clamped" (they become
    # background by choice, not for want of a reachable density).
    slab_labels(rgb, d, z0, *ctx.kernel_args(), labels, counts, sums, stats)


def _slab_into(ctx: JobContext, grid: Any, z0: int, z1: int, labels: np.ndarray,
               counts: np.ndarray, sums: np.ndarray, stats: np.ndarray) -> dict[str, float]:
    """Labels (L, ny, nx) of layers ``[z0, z1)`` of ``grid`` into ``labels`` (counts, sums and
    stats as :func:`_labels_of_slab`); returns the seconds per stage. A source that offers a
    layer plan (a dense grid) is sampled and labelled a layer at a time in one compiled call
    (:mod:`.dense_job`); any other fills the worker's slab buffers, which are then labelled."""
    source, _ = ctx.resources()
    ny, nx = labels.shape[1:]
    scale = ctx.settings.density_scale
    t0 = time.perf_counter()
    planner = getattr(source, "layer_plan", None)
    plan = planner(grid, z0, z1, density_scale=scale) if planner is not None else None
    if plan is not None:
        rgb, dens = _WORKSPACE.samples.take((1, ny, nx))
        kernel = _LAYER_KERNELS[getattr(source, "layer_kind", "dense")]
        kernel(*plan, rgb.reshape(-1, 3), dens.reshape(-1), z0, *ctx.kernel_args(), labels,
               counts, sums, stats)
        return {"sample_lookup_halftone": time.perf_counter() - t0}
    # The kernel reads colour only where the density reaches a positive threshold: the
    # sampler may then leave the colour of empty rows stale instead of zeroing it.
    _WORKSPACE.samples.colour_where_dense = bool(ctx.kernel_args()[0] > 0)
    rgb, dens = source.sample_slab(grid, z0, z1, density_scale=scale, out=_WORKSPACE.samples)
    t1 = time.perf_counter()
    _labels_of_slab(ctx, rgb, dens, z0, labels, counts, sums, stats)
    return {"sample": t1 - t0, "lookup_halftone": time.perf_counter() - t1}


def _clamp_report(stats: np.ndarray) -> dict[str, float]:
    return {"n_clamped_low": float(stats[0]), "n_clamped_high": float(stats[1]),
            "max_shortfall_low": float(stats[2]), "max_shortfall_high": float(stats[3])}


def _oriented(ctx: JobContext, labels: np.ndarray) -> np.ndarray:
    """The slice image(s) of labels (..., ny, nx): the printer's column axis and row order."""
    img = labels if ctx.printer.image_columns == "x" else labels.swapaxes(-1, -2)
    return img[..., ::-1, :] if ctx.printer.flip_rows else img


def _write_new(path: str, data: bytes) -> None:
    """Write a new file (never an existing one); os-level calls: a slice costs one open, one
    write and one close, which matters for small jobs of many layers."""
    fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_BINARY", 0), 0o666)
    try:
        view = memoryview(data)
        while view:
            view = view[os.write(fd, view):]
    finally:
        os.close(fd)


def _cancelled(slices_dir: str, event: threading.Event | None) -> bool:
    if event is not None and event.is_set():
        return True
    return os.path.exists(os.path.join(os.path.dirname(slices_dir), ".cancelled"))


class _Workspace(threading.local):
    """A worker thread's slab buffers, reused from slab to slab (see ``SlabBuffers``)."""

    def __init__(self) -> None:
        from ..io.volumes.base import SlabBuffers

        self.samples = SlabBuffers()
        self.labels = np.empty((0, 0, 0), np.uint8)

    def labels_for(self, n: int, ny: int, nx: int) -> np.ndarray:
        if self.labels.shape[1:] != (ny, nx) or self.labels.shape[0] < n:
            self.labels = np.empty((n, ny, nx), np.uint8)
        return self.labels[:n]


_WORKSPACE = _Workspace()


def run_slab(ctx: JobContext, z0: int, z1: int, slices_dir: str,
             cancel: threading.Event | None = None) -> dict[str, Any]:
    """Convert layers ``[z0, z1)`` and write their PNGs; returns counts and stage timings."""
    from ..io.job_export import slice_name
    from ..io.png_slices import encode_labels_pngs

    nx, ny, nz = ctx.shape_xyz
    if _cancelled(slices_dir, cancel):
        raise JobCancelled()
    labels = _WORKSPACE.labels_for(z1 - z0, ny, nx)
    counts = np.zeros(7, dtype=np.int64)
    sums = np.zeros((z1 - z0, 7), dtype=np.float64)
    stats = np.zeros(4)
    seconds = _slab_into(ctx, ctx.grid, z0, z1, labels, counts, sums, stats)
    t2 = time.perf_counter()
    pngs = encode_labels_pngs(_oriented(ctx, labels), ctx.palette, ctx.printer.png_mode)
    t3 = time.perf_counter()
    # The cancel marker (other processes, cluster workers) is looked for once per slab here,
    # the in-process event at every layer: a stat per slice cost as much as writing it on
    # tmpfs (~14 us), and a slab's slices are written in milliseconds.
    if _cancelled(slices_dir, cancel):
        raise JobCancelled()
    prefix = os.path.join(slices_dir, "")
    for k, png in enumerate(pngs):
        if cancel is not None and cancel.is_set():
            raise JobCancelled()
        # Never create folders here: after a cancel the job's temporary folder is removed and
        # a straggling task must fail rather than recreate it.
        _write_new(prefix + slice_name(z0 + k, nz), png)
    seconds.update(png=t3 - t2, write=time.perf_counter() - t3)
    return {"z0": z0, "z1": z1, "counts": counts.tolist(), "conc_sums": sums.tolist(),
            "clamped": _clamp_report(stats), "seconds": seconds}


def halftone_layer(settings: ConvertSettings, layer: int,
                   context: JobContext | None = None) -> np.ndarray:
    """Labels (ny, nx) of one layer (0..5 = INKS, 6 = empty) exactly as the export writes it.

    Pass ``context`` (from :func:`prepare_job`) when scrubbing many layers of one job.
    """
    ctx = context if context is not None else prepare_job(settings)
    nx, ny, nz = ctx.shape_xyz
    if not 0 <= layer < nz:
        raise DreamPrintError(f"layer {layer} is outside the job's 0..{nz - 1}")
    labels = np.empty((1, ny, nx), dtype=np.uint8)
    _slab_into(ctx, ctx.grid, layer, layer + 1, labels, np.zeros(7, np.int64), np.zeros((1, 7)),
               np.zeros(4))
    return labels[0]


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


def _local_results(ctx, slabs, slices_dir, workers, kind, cancel, out_q):
    """Run slabs with Dask's local scheduler; put each result (or the exception) on out_q."""
    from concurrent.futures import ProcessPoolExecutor, ThreadPoolExecutor

    import dask

    stop = threading.Event()

    def pretask(key, dsk, state):
        if stop.is_set() or (cancel is not None and cancel.is_set()):
            raise JobCancelled()

    def posttask(key, result, dsk, state, worker_id):
        if isinstance(key, tuple) and key[0] == "slab":
            out_q.put(("result", result))

    dsk: dict[Any, Any] = {"ctx": ctx}
    keys = []
    for i, (z0, z1) in enumerate(slabs):
        if kind == "processes":
            dsk[("slab", i)] = (run_slab, "ctx", z0, z1, slices_dir)
        else:
            dsk[("slab", i)] = (run_slab, "ctx", z0, z1, slices_dir, cancel)
        keys.append(("slab", i))
    if kind == "processes":
        import multiprocessing as mp

        pool = ProcessPoolExecutor(workers, mp_context=mp.get_context("spawn"))
        get = dask.multiprocessing.get
    else:
        pool = ThreadPoolExecutor(workers)
        get = dask.threaded.get
    # dask.local's callback tuple: (start, start_state, pretask, posttask, finish).
    cb = (None, None, pretask, posttask, None)

    def drive():
        try:
            get(dsk, keys, num_workers=workers, pool=pool, callbacks=[cb])
            out_q.put(("done", None))
        except BaseException as exc:  # noqa: BLE001 - handed to the consuming generator
            out_q.put(("error", exc))
        finally:
            stop.set()
            pool.shutdown(wait=True, cancel_futures=True)  # no task outlives the driver
            out_q.put(("closed", None))

    th = threading.Thread(target=drive, name="dreamprint-dask", daemon=True)
    th.start()
    return th, stop


def _distributed_results(ctx, slabs, slices_dir, address, out_q, cancel):
    from distributed import Client, as_completed

    try:
        client = Client(address, timeout="10s")
    except (OSError, TimeoutError) as exc:
        raise DreamPrintError(f"cannot reach the Dask scheduler at {address}: {exc}") from None
    stop = threading.Event()

    def drive():
        futs = []
        try:
            ctx_f = client.scatter(ctx, broadcast=True, hash=False)
            futs = [client.submit(run_slab, ctx_f, z0, z1, slices_dir, pure=False)
                    for z0, z1 in slabs]
            for f in as_completed(futs):
                if stop.is_set() or (cancel is not None and cancel.is_set()):
                    raise JobCancelled()
                out_q.put(("result", f.result()))
            out_q.put(("done", None))
        except BaseException as exc:  # noqa: BLE001
            out_q.put(("error", exc))
        finally:
            stop.set()
            try:
                if futs:
                    client.cancel(futs)
                client.close()
            finally:
                out_q.put(("closed", None))

    th = threading.Thread(target=drive, name="dreamprint-distributed", daemon=True)
    th.start()
    return th, stop


# ----------------------------------------------------------------------------- driver
def _sha256(path: str) -> str | None:
    p = Path(path)
    if not p.is_file():
        return None
    h = hashlib.sha256()
    with open(p, "rb") as f:
        for block in iter(lambda: f.read(1 << 22), b""):
            h.update(block)
    return h.hexdigest()


def _manifest(ctx: JobContext, totals: dict, timings: dict, started: float) -> dict[str, Any]:
    from .. import __version__

    s = ctx.settings
    nx, ny, nz = ctx.shape_xyz
    n = nx * ny * nz
    counts = totals["counts"]
    src_path = s.source if Path(s.source).is_file() else None
    return {
        "format": "dreamprint-job",
        "format_version": 1,
        "software": {"name": "dreamprint", "version": __version__},
        "created": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
        "source": {"path": str(Path(src_path).absolute()) if src_path else s.source,
                   "sha256": totals["source_sha256"], "options": s.source_options,
                   "density_scale": s.density_scale, "sampling": s.sampling,
                   "content": (ctx.content.to_json() if ctx.content is not None else
                               {"mode": "fog", "requested": s.content, "reason": ""})},
        "profile": {"name": ctx.profile_name, "fingerprint": ctx.profile_fingerprint,
                    "path": None if s.profile is None else str(s.profile),
                    "objective": getattr(ctx.tables, "objective", s.objective),
                    "intent": getattr(ctx.tables, "intent", s.intent),
                    "table_size": s.table_size},
        "printer": ctx.printer.to_json_dict(),
        "physical_size_mm": [nx * ctx.printer.voxel_mm[0], ny * ctx.printer.voxel_mm[1],
                             nz * ctx.printer.voxel_mm[2]],
        "voxel_mm": list(ctx.printer.voxel_mm),
        "grid_dimensions": [nx, ny, nz],
        "requested_size": {"height_mm": s.height_mm,
                           "size_mm": None if s.size_mm is None else list(s.size_mm)},
        "seed": s.seed,
        "halftoning": ctx.halftoner.describe(),
        "background": {"mode": s.background, "density_threshold_per_mm":
                       ctx.halftoner.threshold},
        "slices": {"folder": "slices", "count": nz, "width": nx if ctx.printer.image_columns
                   == "x" else ny, "height": ny if ctx.printer.image_columns == "x" else nx,
                   "first": "slices/" + _slice(0, nz), "last": "slices/" + _slice(nz - 1, nz),
                   "png_mode": ctx.printer.png_mode},
        "labels": {lab: {"material": (ctx.printer.material_names[i] if i < 6 else "none"),
                         "rgb": ctx.palette[i].tolist()} for i, lab in enumerate(_LABELS)},
        "voxel_counts": {lab: int(counts[i]) for i, lab in enumerate(_LABELS)},
        "mean_concentration": {lab: totals["conc_sums"][i] / n for i, lab in enumerate(_LABELS)},
        "total_voxels": n,
        "clamped_density": totals["clamped"],
        "timings_s": {"total": time.perf_counter() - started, **timings},
        "execution": {"scheduler": s.scheduler or "threads", "workers": totals["workers"],
                      "slabs": totals["slabs"]},
    }


def _slice(z: int, nz: int) -> str:
    from ..io.job_export import slice_name

    return slice_name(z, nz)


def run_conversion(settings: ConvertSettings, cancel: threading.Event | None = None,
                   context: JobContext | None = None, preflight: Any = True
                   ) -> Generator[ConvertProgress, None, dict[str, Any]]:
    """Convert ``settings.source`` into the job folder ``settings.output``.

    Yields :class:`ConvertProgress`; returns the manifest dict (also written to
    ``manifest.json``). Setting ``cancel`` (or closing the generator, or Ctrl-C) stops the work
    and removes the partial job; nothing is ever left under the final name unless complete.
    ``preflight``: True estimates the job first (:func:`.preflight.preflight`, yielded once
    with stage "preflight"), a :class:`.preflight.Preflight` already made is used as is, False
    skips it; the manifest records its estimate and warnings (``preflight``).
    """
    from ..io.job_export import JobWriter, check_target

    started = time.perf_counter()
    if settings.output is None:
        raise DreamPrintError("no output folder given (-o JOB)")
    check_target(settings.output, settings.overwrite)  # before any work
    yield ConvertProgress("preparing", 0, 0, 0, 0, 0.0, None, "opening the source and tables")
    ctx = context if context is not None else prepare_job(settings)
    pf = None
    t_pf = 0.0
    if preflight is True:
        from .preflight import preflight as estimate

        t0 = time.perf_counter()
        pf = estimate(ctx, seed=settings.seed)
        t_pf = time.perf_counter() - t0
    elif preflight is not False and preflight is not None:
        pf = preflight
    if pf is not None:
        yield ConvertProgress("preflight", 0, 0, 0, 0, time.perf_counter() - started, None,
                              pf.short_line(), preflight=pf)
    t_prep = time.perf_counter() - started
    kind = _scheduler_kind(settings)
    workers = settings.workers or os.cpu_count() or 1
    slabs = _slabs(ctx, workers)
    nx, ny, nz = ctx.shape_xyz
    # Per-layer sums, added exactly (math.fsum) once all are in: the total is then the same
    # whatever the slab size, the number of workers or the order in which slabs finish.
    layer_sums = np.zeros((nz, 7))
    totals: dict[str, Any] = {"counts": np.zeros(7, np.int64),
                              "clamped": {}, "workers": workers, "slabs": len(slabs)}
    stage_t = {"sample": 0.0, "lookup_halftone": 0.0, "sample_lookup_halftone": 0.0, "png": 0.0,
               "write": 0.0}
    with JobWriter(settings.output, settings.overwrite) as writer:
        sha_box: dict[str, str | None] = {}
        sha_th = threading.Thread(target=lambda: sha_box.update(v=_sha256(settings.source)),
                                  daemon=True)
        sha_th.start()  # hashing a big source overlaps the conversion
        yield ConvertProgress("converting", 0, nz, 0, nx * ny * nz,
                              time.perf_counter() - started, None)
        out_q: queue.Queue = queue.Queue()
        slices_dir = str(writer.slices_dir)
        if kind == "distributed":
            th, stop = _distributed_results(ctx, slabs, slices_dir, settings.scheduler, out_q,
                                            cancel)
        elif kind == "sync":
            th, stop = _local_results(ctx, slabs, slices_dir, 1, "threads", cancel, out_q)
        else:
            th, stop = _local_results(ctx, slabs, slices_dir, workers, kind, cancel, out_q)
        error: BaseException | None = None
        layers = 0
        t_conv = time.perf_counter()
        try:
            while True:
                try:
                    what, payload = out_q.get(timeout=0.2)
                except queue.Empty:
                    if cancel is not None and cancel.is_set():
                        writer.request_cancel()
                        stop.set()
                    continue
                if what == "result":
                    totals["counts"] += np.asarray(payload["counts"], np.int64)
                    layer_sums[payload["z0"]:payload["z1"]] = payload["conc_sums"]
                    _merge_clamped(totals["clamped"], payload["clamped"])
                    for k, v in payload["seconds"].items():
                        stage_t[k] += v
                    layers += payload["z1"] - payload["z0"]
                    el = time.perf_counter() - started
                    rate = layers / max(1e-9, time.perf_counter() - t_conv)
                    yield ConvertProgress("converting", layers, nz, layers * nx * ny,
                                          nx * ny * nz, el, (nz - layers) / rate)
                elif what == "error":
                    error = payload
                elif what == "closed":
                    break
        except BaseException:
            # GeneratorExit (closed by the GUI), KeyboardInterrupt: stop the tasks, wait for
            # them, then JobWriter removes the partial folder.
            writer.request_cancel()
            stop.set()
            th.join()
            raise
        th.join()
        if error is not None:
            if isinstance(error, JobCancelled) or (cancel is not None and cancel.is_set()):
                raise JobCancelled("the conversion was cancelled") from None
            raise error
        if cancel is not None and cancel.is_set():
            raise JobCancelled("the conversion was cancelled")
        yield ConvertProgress("finishing", nz, nz, nx * ny * nz, nx * ny * nz,
                              time.perf_counter() - started, 0.0, "writing the manifest")
        sha_th.join()
        totals["source_sha256"] = sha_box.get("v")
        timings = {"prepare": t_prep, "preflight": t_pf, "convert": time.perf_counter() - t_conv,
                   "worker_stage_sum": stage_t}
        conc_sums = [math.fsum(layer_sums[:, i]) for i in range(7)]
        manifest = _manifest(ctx, {**totals, "counts": totals["counts"].tolist(),
                                   "conc_sums": conc_sums},
                             timings, started)
        manifest["timings_s"]["voxels_per_second"] = (nx * ny * nz) / max(
            1e-9, manifest["timings_s"]["total"])
        if pf is not None:
            manifest["preflight"] = pf.to_json()
            manifest["warnings"] = [w.to_json() for w in pf.warnings]
        writer.commit(manifest)
    from .preflight import record_rate

    record_rate(nx * ny * nz, timings["convert"])
    yield ConvertProgress("done", nz, nz, nx * ny * nz, nx * ny * nz,
                          time.perf_counter() - started, 0.0, str(writer.target))
    return manifest


def replace_settings(settings: ConvertSettings, **changes: Any) -> ConvertSettings:
    return replace(settings, **changes)
