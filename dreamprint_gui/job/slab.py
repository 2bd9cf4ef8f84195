"""Stages 2-5 of a print job for one slab of layers: sample -> label -> encode -> write.

Per slab of layers ``[z0, z1)``: sample the source on the printer grid (density in 1/mm, the
volume source's rule) into the worker thread's reused buffers; then one compiled call
(:func:`.sample_label.layer_kernel.slab_labels`, nogil) does, layer by layer, the background
threshold (``--background clear|empty``) -> tetrahedral table lookup of C, M, Y, K, W -> density
alignment (Clear, K/W grey; paper section 4.2) -> halftone (the rule of
:func:`.halftone.pick_label`, section 4.3) -> label. A dense grid (a source with a
``layer_plan``) is sampled a layer at a time into one layer's buffers, each labelled at once by
the same kernel, in one compiled call (:mod:`.sample_label.dense_job`; OpenVDB/NanoVDB fog
volumes densified over their leaves: :mod:`.sample_label.leaf_grid_job`). Then each layer is
encoded to PNG (:mod:`.encode.png_slices`) and written into the job's slices folder.

Defines :func:`run_slab` (one slab task, what :mod:`.run` schedules), :func:`encode_slab` (its
work before the files are written, which the pre-flight times) and :func:`halftone_layer`
(the labels (ny, nx) of one layer, for the GUI's slice scrubber, byte-identical to the layer in
an exported job).
"""

from __future__ import annotations

import os
import threading
import time
from dataclasses import replace
from typing import Any

import numpy as np

from dreamprint_gui.core.errors import DreamPrintError
from dreamprint_gui.io.volumes.base import SlabBuffers
from dreamprint_gui.job.correction import apply_correction
from dreamprint_gui.job.encode.png_slices import encode_labels_pngs
from dreamprint_gui.job.plan import (
    ConvertSettings,
    JobCancelled,
    JobContext,
    prepare_job,
    scheduler_kind,
)
from dreamprint_gui.job.resume import write_slab_record
from dreamprint_gui.job.sample_label.dense_job import dense_slab_labels, window_slab_labels
from dreamprint_gui.job.sample_label.layer_kernel import slab_labels
from dreamprint_gui.job.sample_label.leaf_grid_job import (
    leaf_grid_colour_slab_labels,
    leaf_grid_slab_labels,
)
from dreamprint_gui.job.write import CANCEL_MARKER, slice_name, write_atomic

__all__ = ["run_slab", "encode_slab", "halftone_layer"]

# A source's ``layer_kind`` -> the compiled call that samples and labels its layers (the
# arguments: the source's ``layer_plan``, one layer's rgb and density arrays, z0, the kernel's).
_LAYER_KERNELS = {"dense": dense_slab_labels, "leaf_grid": leaf_grid_slab_labels,
                  "leaf_grid_colour": leaf_grid_colour_slab_labels, "window": window_slab_labels}


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
    (:mod:`.sample_label.dense_job`); any other fills the worker's slab buffers, which are
    then labelled."""
    source, _ = ctx.resources()
    ny, nx = labels.shape[1:]
    scale = ctx.settings.density_scale
    t0 = time.perf_counter()
    corr = ctx.correction
    if corr is not None and corr.is_identity:
        corr = None
    planner = getattr(source, "layer_plan", None)
    # A correction is applied between sampling and labelling: the fused sample+label calls
    # have no such step, so a corrected job takes the general path (bench_compensate.py)
    plan = (planner(grid, z0, z1, density_scale=scale)
            if planner is not None and corr is None else None)
    if plan is not None:
        rgb, dens = _WORKSPACE.samples.take((1, ny, nx))
        kernel = _LAYER_KERNELS[getattr(source, "layer_kind", "dense")]
        kernel(*plan, rgb.reshape(-1, 3), dens.reshape(-1), z0, *ctx.kernel_args(), labels,
               counts, sums, stats)
        return {"sample_lookup_halftone": time.perf_counter() - t0}
    # The kernel reads colour only where the density reaches a positive threshold: the
    # sampler may then leave the colour of empty rows stale instead of zeroing it.
    threshold = ctx.kernel_args()[0]
    _WORKSPACE.samples.colour_where_dense = bool(threshold > 0)
    # ... and not below the background threshold, unless a correction changes the density
    # between sampling and labelling
    _WORKSPACE.samples.colour_threshold = np.float32(threshold if corr is None else 0.0)
    rgb, dens = source.sample_slab(grid, z0, z1, density_scale=scale, out=_WORKSPACE.samples)
    if corr is not None:
        rgb = np.ascontiguousarray(rgb, np.float32)
        dens = np.ascontiguousarray(dens, np.float32)
        if not (rgb.flags.writeable and dens.flags.writeable):
            rgb, dens = rgb.copy(), dens.copy()
        apply_correction(corr.gain, ctx.shape_xyz, z0, rgb, dens)
    t1 = time.perf_counter()
    _labels_of_slab(ctx, rgb, dens, z0, labels, counts, sums, stats)
    return {"sample": t1 - t0, "lookup_halftone": time.perf_counter() - t1}


def _clamp_report(stats: np.ndarray) -> dict[str, float]:
    return {"n_clamped_low": float(stats[0]), "n_clamped_high": float(stats[1]),
            "max_shortfall_low": float(stats[2]), "max_shortfall_high": float(stats[3])}


def _oriented(ctx: JobContext, labels: np.ndarray) -> np.ndarray:
    """The slice image(s) of labels (..., ny, nx): the printer's column axis and row order."""
    return ctx.printer.slice_images(labels)


def _cancelled(slices_dir: str, event: threading.Event | None) -> bool:
    if event is not None and event.is_set():
        return True
    return os.path.exists(os.path.join(os.path.dirname(slices_dir), CANCEL_MARKER))


class _Workspace(threading.local):
    """A worker thread's slab buffers, reused from slab to slab (see ``SlabBuffers``)."""

    def __init__(self) -> None:

        self.samples = SlabBuffers()
        self.labels = np.empty((0, 0, 0), np.uint8)

    def labels_for(self, n: int, ny: int, nx: int) -> np.ndarray:
        if self.labels.shape[1:] != (ny, nx) or self.labels.shape[0] < n:
            self.labels = np.empty((n, ny, nx), np.uint8)
        return self.labels[:n]


_WORKSPACE = _Workspace()


def encode_slab(ctx: JobContext, z0: int, z1: int
                ) -> tuple[list[bytes], np.ndarray, np.ndarray, np.ndarray, dict[str, float]]:
    """The PNG slices of layers ``[z0, z1)`` (labelled into this thread's reused buffer), the
    labels' counts, per-layer concentration sums and clamp stats (as :func:`_labels_of_slab`),
    and the seconds per stage (``png`` included): a slab's work before its files are written,
    as the job and the pre-flight's timing do it."""
    nx, ny, _ = ctx.shape_xyz
    labels = _WORKSPACE.labels_for(z1 - z0, ny, nx)
    counts = np.zeros(7, dtype=np.int64)
    sums = np.zeros((z1 - z0, 7), dtype=np.float64)
    stats = np.zeros(4)
    seconds = _slab_into(ctx, ctx.grid, z0, z1, labels, counts, sums, stats)
    t2 = time.perf_counter()
    pngs = encode_labels_pngs(_oriented(ctx, labels), ctx.palette, ctx.printer.png_mode,
                              ctx.printer.pixels_per_metre())
    seconds["png"] = time.perf_counter() - t2
    return pngs, counts, sums, stats, seconds


def run_slab(ctx: JobContext, z0: int, z1: int, slices_dir: str,
             cancel: threading.Event | None = None) -> dict[str, Any]:
    """Convert layers ``[z0, z1)`` and write their PNGs; returns counts and stage timings.

    Idempotent: each slice is renamed into place, then the slab's record (:mod:`.resume`), so a
    slab run twice (its worker killed, a resumed job) leaves the same files."""

    nz = ctx.shape_xyz[2]
    if _cancelled(slices_dir, cancel):
        raise JobCancelled()
    pngs, counts, sums, stats, seconds = encode_slab(ctx, z0, z1)
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
        # a straggling task must fail rather than recreate it. Renamed into place: a slab run
        # again after its worker died replaces identical bytes.
        write_atomic(prefix + slice_name(z0 + k, nz), png)
    result = {"z0": z0, "z1": z1, "counts": counts.tolist(), "conc_sums": sums.tolist(),
              "clamped": _clamp_report(stats)}
    write_slab_record(os.path.dirname(slices_dir), result, [len(png) for png in pngs])
    seconds["write"] = time.perf_counter() - t3
    return {**result, "seconds": seconds}


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


def load_kernels(ctx: JobContext) -> None:
    """Load the compiled kernels (numba's on-disk cache, ~0.5 s on a first call) now, while
    preparing, rather than in the first slab: the preparation is reported as such and the
    conversion's progress and speed are those of the conversion. The source's sampler is
    loaded by sampling one voxel (a grid of 1 x 1 x 1 at the job grid's corner)."""
    # The same path (fused or general), sampler, types and arrays as the job's slabs.
    one_voxel = replace(ctx.grid, shape_xyz=(1, 1, 1))
    labels = np.empty((1, 1, 1), np.uint8)
    _slab_into(ctx, one_voxel, 0, 1, labels, np.zeros(7, np.int64), np.zeros((1, 7)),
               np.zeros(4))
    encode_labels_pngs(_oriented(ctx, labels), ctx.palette, ctx.printer.png_mode,
                       ctx.printer.pixels_per_metre())
    if scheduler_kind(ctx.settings) != "distributed":
        import dask.threaded  # noqa: F401 - the local scheduler's import, ~0.1 s
