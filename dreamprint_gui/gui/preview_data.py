"""What the preview shows, computed by the engine on a coarse grid (no Qt here).

Defines :class:`PreviewData`, :func:`job_context` (the export's own ``job.plan.prepare_job``
context, reused while only the size, density scale or background change) and
:func:`compute_preview`: the source sampled on a downsampled, isotropic grid of the job's
physical size (``VolumeSource.sample_slab``), and the predicted print of the same voxels after
table lookup and density alignment (``gamut.predicted_appearance``) and the job's background
rule, both as sRGB colour and density in 1/mm (in chunks, so it reports progress and stops
early when cancelled: :class:`PreviewCancelled`), plus
:func:`opacity_per_voxel` (Beer-Lambert: alpha = 1 - exp(-sigma * voxel size)), which is how the
volume view turns densities into per-voxel opacity.
"""

from __future__ import annotations

import os
import threading
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

__all__ = ["PreviewData", "PreviewCancelled", "compute_preview", "job_context",
           "estimated_context",
           "opacity_per_voxel", "PREVIEW_VOXELS"]

PREVIEW_VOXELS = 96  # voxels along the longest axis of the preview grid (interaction stays smooth)
# Voxels per call of the full model: its float64 temporaries (chunk x wavelengths) then stay in
# cache (measured about twice as fast as one call on the whole grid), the chunks spread over the
# cores (the kernel and numpy release the GIL), and each chunk is a point to report progress
# and to notice a cancel.
PREDICT_CHUNK = 4096
PREDICT_THREADS = max(1, min(4, os.cpu_count() or 1))


class PreviewCancelled(Exception):
    """The preview computation was abandoned (its ``cancel`` event was set)."""


@dataclass
class PreviewData:
    """Source and predicted print on the same preview grid; arrays are (z, y, x[, 3])."""

    source_rgb: NDArray[np.float32]
    source_sigma: NDArray[np.float32]  # 1/mm
    print_rgb: NDArray[np.float32]
    print_sigma: NDArray[np.float32]  # 1/mm
    voxel_mm: float  # isotropic preview voxel edge
    size_mm: tuple[float, float, float]  # physical size x, y, z
    print_shape_xyz: tuple[int, int, int] | None  # the printer grid it stands for
    background: str  # "clear" | "empty"

    @property
    def shape_xyz(self) -> tuple[int, int, int]:
        z, y, x = self.source_sigma.shape
        return (x, y, z)

    def downsample_note(self) -> str:
        nx, ny, nz = self.shape_xyz
        text = f"preview grid {nx} x {ny} x {nz} voxels of {self.voxel_mm * 1000:.0f} um"
        if self.print_shape_xyz is not None:
            px, py, pz = self.print_shape_xyz
            factor = (px * py * pz) / max(1, nx * ny * nz)
            if factor > 1:
                text += (f" (downsampled from the print's {px} x {py} x {pz} voxels, "
                         f"1:{factor:,.0f})")
        return text


def opacity_per_voxel(sigma_per_mm: NDArray, voxel_mm: float) -> NDArray[np.float32]:
    """Opacity of one voxel of edge ``voxel_mm`` in a medium of density sigma (Beer-Lambert)."""
    s = np.clip(np.asarray(sigma_per_mm, dtype=np.float64), 0.0, None)
    return (-np.expm1(-s * voxel_mm)).astype(np.float32)


def estimated_context(settings, previous=None, report: Callable[[str], None] | None = None):
    """(:func:`job_context`, what preparing was estimated to take before it started or None
    when ``previous`` was only resized (``job.plan.resized_job``), the seconds it took):
    ``report`` is told the estimate (``job.prepare_time``'s line) before the work starts."""
    import time as _time

    from dreamprint_gui.job.plan import prepare_job, resized_job
    from dreamprint_gui.job.prepare_time import estimate_preparation

    t0 = _time.perf_counter()
    ctx = None if previous is None else resized_job(previous, settings)
    if ctx is not None:
        return ctx, None, _time.perf_counter() - t0
    est = estimate_preparation(settings)
    if report is not None:
        report(est.describe())
    t0 = _time.perf_counter()
    ctx = prepare_job(settings)
    return ctx, est, _time.perf_counter() - t0


def job_context(settings, previous=None):
    """The engine's ``JobContext`` for ``settings`` (``job.plan.prepare_job``).

    When only the size, density scale or background changed since ``previous``
    (``job.plan.resized_job``: everything else the same), the open source, the tables and the
    background threshold are reused and only the printer grid and the background label are
    redone, so dragging a control does not reopen a large file.
    """
    from dreamprint_gui.job.plan import prepare_job, resized_job

    ctx = None if previous is None else resized_job(previous, settings)
    return ctx if ctx is not None else prepare_job(settings)


def compute_preview(ctx, profile, *, n: int = PREVIEW_VOXELS,
                    progress: Callable[[float], None] | None = None,
                    cancel: threading.Event | None = None) -> PreviewData:
    """Sample the job's source on a coarse grid and predict the print (engine calls only).

    ``ctx`` is the job's context (:func:`job_context`): its open source, its colour tables
    (built for ``profile`` at the printer's layer thickness), its background threshold.
    Voxels whose density is below the threshold become Clear (``background="clear"``) or
    nothing (``"empty"``), as the job pipeline labels them. ``progress(fraction)`` is called
    after the sampling and after each chunk of the prediction; when ``cancel`` is set the
    computation stops at the next chunk with :class:`PreviewCancelled`.
    """

    def check() -> None:
        if cancel is not None and cancel.is_set():
            raise PreviewCancelled()

    from dreamprint_gui import gamut
    from dreamprint_gui.core.profile import INKS
    from dreamprint_gui.io.volumes import grid_for_source
    from dreamprint_gui.physics.mixture import predict

    s = ctx.settings
    source = ctx.source
    print_shape = tuple(int(v) for v in ctx.grid.shape_xyz)
    vx, vy, vz = ctx.printer.voxel_mm
    size = (print_shape[0] * vx, print_shape[1] * vy, print_shape[2] * vz)
    v = max(size) / n
    grid = grid_for_source(source, (v, v, v), height_mm=size[2], bounds=ctx.fit_bounds)
    nx, ny, nz = grid.shape_xyz
    rgb, sigma = source.sample_slab(grid, 0, nz, density_scale=s.density_scale)
    rgb = np.asarray(rgb, dtype=np.float32)
    sigma = np.asarray(sigma, dtype=np.float32)
    check()
    if progress is not None:
        progress(0.1)
    below = sigma < ctx.halftoner.threshold
    # Only voxels above the background threshold are printed from the tables; the rest follow
    # the background rule below, so the (full-model) prediction is spent where it matters.
    p_rgb = np.zeros_like(rgb)
    p_sigma = np.zeros_like(sigma)
    inside = ~below
    if inside.any():
        in_rgb, in_sigma = rgb[inside], sigma[inside]
        out_rgb = np.empty_like(in_rgb)
        out_sigma = np.empty_like(in_sigma)
        count = len(in_sigma)

        def chunk(start: int) -> int:
            check()
            part = slice(start, min(count, start + PREDICT_CHUNK))
            a_rgb, a_sigma = gamut.predicted_appearance(ctx.tables, profile, in_rgb[part],
                                                        in_sigma[part])
            out_rgb[part] = np.clip(np.asarray(a_rgb, dtype=np.float32), 0.0, 1.0)
            out_sigma[part] = np.asarray(a_sigma, dtype=np.float32)
            return part.stop - part.start

        done = 0
        pool = ThreadPoolExecutor(PREDICT_THREADS, thread_name_prefix="preview-predict")
        try:
            for n_done in pool.map(chunk, range(0, count, PREDICT_CHUNK)):
                done += n_done
                if progress is not None:
                    progress(0.1 + 0.9 * done / count)
        finally:
            pool.shutdown(wait=True, cancel_futures=True)
        p_rgb[inside] = out_rgb
        p_sigma[inside] = out_sigma
    if s.background == "empty":
        p_sigma[below] = 0.0
    else:
        clear = predict(profile, np.eye(len(INKS))[INKS.index("Cl")])
        p_rgb[below] = np.clip(np.asarray(clear.sRGB, dtype=np.float32), 0, 1)
        p_sigma[below] = float(clear.sigma_per_mm)
    return PreviewData(rgb, sigma, p_rgb, p_sigma, v, (nx * v, ny * v, nz * v), print_shape,
                       s.background)
