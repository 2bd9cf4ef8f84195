"""The Gaussian-splat rasteriser on a print job's own grid: CPU cost and accuracy (issue 25).

For each splat kind of :mod:`bench_sources` (default: ``inria``, the generated 1e6-Gaussian
scene, and ``inria-sample``, the 9k-Gaussian INRIA sample) the job's grid of about ``--voxels``
voxels is laid out as ``bench_convert.py`` lays it (j850-paper, the file's box, up = z) and cut
into the job's slabs (2 workers); ``--slabs`` of them, evenly spaced over the height, are
sampled by ``GaussianCloud.sample_slab`` into reused slab buffers, timed by the thread's CPU
clock (best of ``--repeat`` per slab: the machine is shared). Printed: CPU ns per voxel, the
whole job's rasterising CPU seconds extrapolated from the sampled share, and that per Gaussian
(ns), and the rate two busy cores would rasterise at.

``--reference REV`` also rasterises the same slabs with ``dreamprint_gui/io/volumes/
splats/raster.py`` (``splat_raster.py`` before) as it is at git revision REV (e.g. the commit
before a rasteriser change), timed the same way, and compares the fields: density relative
difference ``|d - d_ref| / d_ref`` (max and p99 over voxels where both are non-zero), the
voxels non-zero in one field only (the cut-off's rounding at the support's edge) with their
largest density relative to the job's largest, and colour's largest absolute difference (0..1
per channel) where the density is above 1e-3 of the field's maximum (where the printer's
threshold can see it).

    PYTHONPATH=. python benchmarks/bench_splat_raster.py                        # 1e9 voxels
With ``--job-voxels N`` it then converts a job of N voxels per kind (2 workers, the file's
box, j850-paper, as ``job_hashes.py``) with each rasteriser and compares the slices' labels:
voxels labelled differently, each label's share of the job and its largest change over
blocks of 8 layers x 64 x 64 voxels, and the mean concentrations.

    PYTHONPATH=. python benchmarks/bench_splat_raster.py --reference 2b4547c --voxels 1e8
    PYTHONPATH=. python benchmarks/bench_splat_raster.py --reference 2b4547c --job-voxels 3e7
"""

from __future__ import annotations

import argparse
import contextlib
import importlib.util
import inspect
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

from bench_sources import source_path  # noqa: E402
from job_hashes import VOXEL, height_for  # noqa: E402

from dreamprint_gui.io.volumes import grid_for_source, open_source  # noqa: E402
from dreamprint_gui.io.volumes.base import SlabBuffers, voxel_centres  # noqa: E402
from dreamprint_gui.io.volumes.splats.cloud import GaussianCloud  # noqa: E402


def job_slabs(shape_xyz: tuple[int, int, int], workers: int = 2,
              src: object = None) -> list[tuple[int, int]]:
    """The job's slabs (``job.plan.slab_plan`` with default settings, for ``src``)."""
    from types import SimpleNamespace

    from dreamprint_gui.job.plan import slab_plan
    return slab_plan(SimpleNamespace(shape_xyz=shape_xyz, source=src,
                                  settings=SimpleNamespace(slab_layers=None)), workers)


def reference_raster(rev: str):
    """``rasterise_splats`` of the splat rasteriser at git revision ``rev``, as its own module."""
    for path in ("splats/raster.py", "splat_raster.py"):  # the file before io/volumes/splats/
        got = subprocess.run(["git", "show", f"{rev}:dreamprint_gui/io/volumes/{path}"],
                             capture_output=True, text=True, cwd=HERE.parent)
        if got.returncode == 0:
            break
    else:
        raise SystemExit(f"no splat rasteriser at git revision {rev}")
    text = got.stdout
    d = Path(tempfile.mkdtemp(prefix="dp-raster-ref-"))
    path = d / f"splat_raster_ref_{rev[:10]}.py"
    path.write_text(text)
    spec = importlib.util.spec_from_file_location(path.stem, path)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod.rasterise_splats


def _packed(raster) -> bool:
    """Whether ``raster`` takes packed Gaussians (since issue 25), not voxel centres."""
    return "gaussians" in inspect.signature(raster).parameters


@contextlib.contextmanager
def rasteriser(raster):
    """The splat module's ``rasterise_splats`` (packed signature) is ``raster`` inside: one
    thread at a time (a job's workers must not each swap and restore it)."""
    from dreamprint_gui.io.volumes.splats import cloud as splats

    plain = splats.rasterise_splats
    splats.rasterise_splats = raster
    try:
        yield
    finally:
        splats.rasterise_splats = plain


def sample_with(raster, src: GaussianCloud, grid, z0: int, z1: int, out: SlabBuffers | None,
                density_scale: float = 1.0):
    """``src.sample_slab`` with ``raster`` in place of the module's rasteriser (either
    signature). Packed Gaussians (since issue 25): exactly as ``sample_slab`` calls it, the
    cloud's own records in its height order (until 2026-11-29 this packed every Gaussian in
    the file's order for each slab, which read the rasteriser against itself as 3.9x faster on
    a 1e6-Gaussian scene). Voxel centres ``xs, ys, zs`` (before issue 25): the Gaussians in
    the file's order, as that rasteriser had them."""
    if _packed(raster):
        with rasteriser(raster):
            return src.sample_slab(grid, z0, z1, density_scale=density_scale, out=out)
    zs = voxel_centres(grid, 2, z0, z1)
    mz, hz = src.mean[:, 2], src.half[:, 2]
    cand = np.flatnonzero((mz - hz <= zs[-1]) & (mz + hz >= zs[0]))   # in file order
    return raster(cand, src.mean, src.inv_cov, src.peak, src.rgb, src.half,
                  voxel_centres(grid, 0), voxel_centres(grid, 1), zs,
                  density_scale / grid.mm_per_unit, out)


def job_labels(path: str, height: float) -> tuple[np.ndarray, dict]:
    """Labels (z, rows, columns) and manifest of a job converted from ``path`` (2 workers,
    j850-paper, the file's box, up = z, as ``job_hashes.py``)."""
    from job_hashes import PLACEMENT, PRINTER

    from dreamprint_gui.core.generators import drain
    from dreamprint_gui.job.encode.png_slices import read_png_labels
    from dreamprint_gui.job.plan import ConvertSettings
    from dreamprint_gui.job.run import run_conversion

    tmp = tempfile.mkdtemp(prefix="dp-raster-job-")
    try:
        out = os.path.join(tmp, "JOB")
        gen = run_conversion(ConvertSettings(source=path, output=out, height_mm=height,
                                             workers=2, printer=PRINTER, **PLACEMENT))
        m = drain(gen)
        palette = np.array([m["labels"][k]["rgb"] for k in m["labels"]], np.uint8)
        files = sorted(Path(out, "slices").iterdir())
        return np.stack([read_png_labels(f, palette) for f in files]), m
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


def compare_jobs(kind: str, n_voxels: float, ref, block=(8, 64, 64)) -> None:
    """The job's labels with this rasteriser and with ``ref``: voxels whose label differs,
    each label's share of the job and its largest change over blocks of ``block`` voxels
    (layers, rows, columns)."""
    path = source_path(kind)
    height = height_for(path, n_voxels)
    new, m = job_labels(path, height)
    # patched once around the whole job, here, not by each of its worker threads
    plain = GaussianCloud.sample_slab
    if not _packed(ref):
        GaussianCloud.sample_slab = (lambda self, grid, z0, z1, *, density_scale=1.0, out=None:
                                     sample_with(ref, self, grid, z0, z1, out, density_scale))
    try:
        with rasteriser(ref) if _packed(ref) else contextlib.nullcontext():
            old, m_ref = job_labels(path, height)
    finally:
        GaussianCloud.sample_slab = plain
    names = list(m["labels"])
    differ = int(np.count_nonzero(new != old))
    shape = tuple(s // b * b for s, b in zip(new.shape, block, strict=True))
    worst = 0.0
    for lab in range(len(names)):
        f = [(a[: shape[0], : shape[1], : shape[2]] == lab).reshape(
            shape[0] // block[0], block[0], shape[1] // block[1], block[1],
            shape[2] // block[2], block[2]).mean((1, 3, 5)) for a in (new, old)]
        worst = max(worst, float(np.abs(f[0] - f[1]).max(initial=0.0)))
    share = {k: m["voxel_counts"][k] / m["total_voxels"] for k in names}
    dshare = max(abs(m["voxel_counts"][k] - m_ref["voxel_counts"][k]) / m["total_voxels"]
                 for k in names)
    dconc = max(abs(m["mean_concentration"][k] - m_ref["mean_concentration"][k])
                for k in names)
    print(f"-- {kind} job ({new.size:,} voxels, {new.shape[0]} layers): {differ:,} voxels "
          f"labelled differently ({differ / new.size:.1e}); label shares "
          + ", ".join(f"{k} {v:.4f}" for k, v in share.items() if v > 0)
          + f"; largest change of a share: job {dshare:.1e}, per {block} block {worst:.1e}; "
          f"of a mean concentration {dconc:.1e}", flush=True)


def timed(fn, repeat: int) -> tuple[float, tuple[np.ndarray, np.ndarray]]:
    best = np.inf
    res = None
    for _ in range(repeat):
        t = time.thread_time()
        res = fn()
        best = min(best, time.thread_time() - t)
    return best, res


def run_kind(kind: str, n_voxels: float, n_slabs: int, repeat: int, ref) -> None:
    path = source_path(kind)
    src = open_source(path)
    grid = grid_for_source(src, VOXEL, height_mm=height_for(path, n_voxels))
    nx, ny, nz = (int(v) for v in grid.shape_xyz)
    slabs = job_slabs((nx, ny, nz), src=src)
    pick = sorted(set(np.linspace(0, len(slabs) - 1, min(n_slabs, len(slabs))).round()
                      .astype(int).tolist()))
    buf = SlabBuffers()
    ref_buf = SlabBuffers()
    src.sample_slab(grid, *slabs[pick[0]], out=buf)          # compile / warm up
    if ref is not None:
        sample_with(ref, src, grid, *slabs[pick[0]], ref_buf)
    cpu = ref_cpu = 0.0
    voxels = 0
    dens_rel: list[np.ndarray] = []
    edge = 0
    edge_max = 0.0
    nonzero = 0
    col_max = 0.0
    dmax = 0.0
    for p in pick:
        z0, z1 = slabs[p]
        s, (rgb, d) = timed(lambda z0=z0, z1=z1: src.sample_slab(grid, z0, z1, out=buf), repeat)
        cpu += s
        voxels += d.size
        if ref is None:
            continue
        s, (rgb_r, d_r) = timed(lambda z0=z0, z1=z1: sample_with(ref, src, grid, z0, z1,
                                                               ref_buf), repeat)
        ref_cpu += s
        both = (d > 0) & (d_r > 0)
        one = (d > 0) != (d_r > 0)
        nonzero += int(np.count_nonzero(d_r > 0))
        dens_rel.append(np.abs(d[both].astype(np.float64) - d_r[both]) / d_r[both])
        edge += int(np.count_nonzero(one))
        if one.any():
            edge_max = max(edge_max, float(np.maximum(d, d_r)[one].max()))
        dmax = max(dmax, float(d_r.max(initial=0.0)))
        seen = both & (d_r > 1e-3 * max(dmax, 1e-30))
        if seen.any():
            col_max = max(col_max, float(np.abs(rgb[seen] - rgb_r[seen]).max()))
    total = nx * ny * nz
    ns = cpu / voxels * 1e9
    n_g = len(src.mean)
    print(f"-- {kind}: {Path(path).name}, {n_g:,} Gaussians, grid {nx} x {ny} x {nz} "
          f"({total:.3g} voxels), {len(pick)} of {len(slabs)} slabs of "
          f"{slabs[0][1] - slabs[0][0]} layers")
    print(f"   rasterise: {ns:6.2f} CPU ns/voxel, job {ns * total * 1e-9:6.2f} CPU s, "
          f"{ns * total / n_g:8.0f} CPU ns/Gaussian; two busy cores: "
          f"{2e3 / ns:6.1f} Mvox/s", flush=True)
    if ref is None:
        return
    rns = ref_cpu / voxels * 1e9
    rel = np.concatenate(dens_rel) if dens_rel else np.zeros(1)
    print(f"   reference: {rns:6.2f} CPU ns/voxel, job {rns * total * 1e-9:6.2f} CPU s, "
          f"{rns * total / n_g:8.0f} CPU ns/Gaussian; speed-up {rns / ns:.2f}x")
    print(f"   density vs reference: relative difference max {rel.max():.2e}, p99 "
          f"{np.percentile(rel, 99):.2e} over {rel.size:,} voxels; {edge:,} voxels non-zero in "
          f"one only (of {nonzero:,}), their density <= {edge_max / max(dmax, 1e-30):.1e} of "
          f"the maximum; colour max abs difference {col_max:.2e}", flush=True)


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--kinds", default="inria,inria-sample")
    ap.add_argument("--voxels", type=float, default=1e9)
    ap.add_argument("--slabs", type=int, default=16, help="slabs sampled (evenly spaced)")
    ap.add_argument("--repeat", type=int, default=2)
    ap.add_argument("--reference", default=None, help="git revision of the reference "
                    "rasteriser to compare with")
    ap.add_argument("--job-voxels", type=float, default=0.0, help="with --reference: also "
                    "convert a job of this many voxels per kind with both rasterisers and "
                    "compare the labels")
    a = ap.parse_args()
    ref = reference_raster(a.reference) if a.reference else None
    print(f"load {os.getloadavg()[0]:.1f} ({os.cpu_count()} cores); CPU times per thread")
    for kind in a.kinds.split(","):
        run_kind(kind, a.voxels, a.slabs, a.repeat, ref)
    if ref is not None and a.job_voxels:
        for kind in a.kinds.split(","):
            compare_jobs(kind, a.job_voxels, ref)


if __name__ == "__main__":
    main()
