"""Hashes of print jobs written from every source kind, to show that a change to the
conversion leaves the slices byte-identical.

For each kind (:mod:`bench_sources`) one job of about ``--voxels`` voxels is converted and
printed as one line: the kind, the grid, the SHA-256 of all slices in order, and the SHA-256
of the manifest's voxel counts, mean concentrations and clamp report. Run it with the code
before and after a change (``PYTHONPATH`` chooses the code) and compare the two outputs.

    PYTHONPATH=$PWD python benchmarks/job_hashes.py > after.txt
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import shutil
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_sources import KINDS, source_path  # noqa: E402

VOXEL = (0.084, 0.028, 0.014)  # j850-paper


def height_for(source: str, n_voxels: float, options: dict | None = None) -> float:
    """The height (mm) that gives a job of about ``n_voxels`` voxels for this source."""
    from dreamprint_gui.io.volumes import open_source

    lo, hi = (list(map(float, b)) for b in open_source(source, **(options or {})).bounds)
    ext = [h - lo_ for lo_, h in zip(lo, hi, strict=True)]
    # N = prod(ext * mpu / vox), mpu = height / ext_z
    mpu = (n_voxels * VOXEL[0] * VOXEL[1] * VOXEL[2] / (ext[0] * ext[1] * ext[2])) ** (1 / 3)
    return ext[2] * mpu


def job_hash(source: str, height: float, workers: int, slab_layers: int | None,
             scheduler: str | None = None) -> tuple[list[int], str, str]:
    from dreamprint_gui.job.plan import ConvertSettings
    from dreamprint_gui.job.run import run_conversion

    tmp = tempfile.mkdtemp(prefix="dp-hash-")
    try:
        out = os.path.join(tmp, "JOB")
        s = ConvertSettings(source=source, output=out, height_mm=height, workers=workers,
                            slab_layers=slab_layers, scheduler=scheduler)
        gen = run_conversion(s)
        while True:
            try:
                next(gen)
            except StopIteration as stop:
                m = stop.value
                break
        h = hashlib.sha256()
        for f in sorted(Path(out, "slices").iterdir()):
            h.update(f.read_bytes())
        keep = {k: m[k] for k in ("voxel_counts", "mean_concentration", "clamped_density")}
        mh = hashlib.sha256(json.dumps(keep, sort_keys=True).encode()).hexdigest()
        return m["grid_dimensions"], h.hexdigest()[:16], mh[:16]
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--kinds", default=",".join(KINDS))
    ap.add_argument("--voxels", type=float, default=3e6)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--slab-layers", type=int, default=None)
    a = ap.parse_args()
    for kind in a.kinds.split(","):
        src = source_path(kind)
        h = height_for(src, a.voxels)
        grid, sh, mh = job_hash(src, h, a.workers, a.slab_layers)
        print(f"{kind:>16} {str(tuple(grid)):>18} slices {sh} manifest {mh}", flush=True)


if __name__ == "__main__":
    main()
