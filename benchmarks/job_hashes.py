"""Hashes of print jobs written from every source kind, to show that a change to the
conversion leaves the slices byte-identical.

For each kind (:mod:`bench_sources`) one job of about ``--voxels`` voxels is converted and
printed as one line: the kind, the grid, the SHA-256 of all slices in order, and the SHA-256
of the manifest's voxel counts, mean concentrations and clamp report. Run it with the code
before and after a change (``PYTHONPATH`` chooses the code) and compare the two outputs.

    PYTHONPATH=$PWD python benchmarks/job_hashes.py > after.txt
    PYTHONPATH=$PWD python benchmarks/job_hashes.py --check     # against BASELINE below

:data:`BASELINE`: the hashes of the kinds made from the sample files (no generated file needed)
at the defaults (3e6 voxels, 2 workers, j850-paper, blue noise, seed 0), with the code of the
commit that last changed slices on purpose. Update it in one commit that says why.
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

# Every hash is taken on the paper's grid (not the default printer), the file's declared box
# and its own axes (not --fit occupied and the automatic up of splats), so that the grids and
# voxel counts of earlier baselines stay comparable.
PRINTER = "j850-paper"
PLACEMENT = {"fit": "box", "up": "z"}
VOXEL = (0.084, 0.028, 0.014)  # j850-paper
# Last changed: issue 25, the table read by tetrahedral instead of trilinear interpolation
# (2026-11-29). Against the code before (bench_label_accuracy.py --old 64e8a28, these jobs):
# labels changed in 0-0.0014 % of the foreground voxels (demo 6 of 616030, inria-sample 1,
# vox 2; the one-colour kinds none), ink counts within 0.02 standard errors, a voxel's intended
# concentration within 7.8e-3 (mean <= 3.8e-6), manifest mean concentrations within 1.2e-6,
# clamp counts identical; lookup vs direct solve p95 0.0156 -> 0.0120 dE2000.
BASELINE = {
    # demo: the procedural planet since issue 46 (a new source, not a change of the conversion)
    "demo": ("dd49e33128b2a16c", "6cc5b7474dca2e01"),
    "openvdb-manta": ("894f4c2fa51efac4", "e1c316c5a7a199d3"),
    "vtk": ("45cd8ba5eb3de2fb", "d668b11b49204a98"),
    "vtk-legacy": ("237e2d52fff92a9a", "149940913b2ff977"),
    "metaimage": ("36f00c08415ee8d8", "a3ecd31b738be69f"),
    "inria-sample": ("0d78544e6d47a24e", "5d5d8292fb1bcf35"),
    "vox": ("edccad7d0f4e9ad1", "63cb0af4e650dff8"),
}
# The manifests of Gaussian-splat jobs on CPUs other than the baseline's (AVX-512 Xeon): the
# slices are the same, the mean concentrations differ in their last digits because numpy
# dispatches float64 log1p/power by CPU (SVML on AVX-512; README, "Speed"). Each entry is the
# manifest hash found on that CPU with the code of the baseline.
MANIFEST_ON_OTHER_CPUS = {
    "inria-sample": {"31c6bef94a733502": "AVX2 (first-generation Zen EPYC)"},
}


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
    from dreamprint_gui.core.generators import drain
    from dreamprint_gui.job.plan import ConvertSettings
    from dreamprint_gui.job.run import run_conversion

    tmp = tempfile.mkdtemp(prefix="dp-hash-")
    try:
        out = os.path.join(tmp, "JOB")
        s = ConvertSettings(source=source, output=out, height_mm=height, workers=workers,
                            slab_layers=slab_layers, scheduler=scheduler, printer=PRINTER,
                            **PLACEMENT)
        gen = run_conversion(s)
        m = drain(gen)
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
    ap.add_argument("--check", action="store_true",
                    help="the BASELINE kinds at the defaults; exit 1 if any differs")
    a = ap.parse_args()
    kinds = list(BASELINE) if a.check else a.kinds.split(",")
    differ = 0
    for kind in kinds:
        src = source_path(kind)
        h = height_for(src, a.voxels)
        grid, sh, mh = job_hash(src, h, a.workers, a.slab_layers)
        verdict = ""
        if a.check:
            base_slices, base_manifest = BASELINE[kind]
            cpu = MANIFEST_ON_OTHER_CPUS.get(kind, {}).get(mh)
            same = sh == base_slices and (mh == base_manifest or cpu is not None)
            differ += not same
            verdict = (f"  DIFFERS from {BASELINE[kind]}" if not same else
                       "  same" if mh == base_manifest else f"  same (the manifest of {cpu})")
        print(f"{kind:>16} {str(tuple(grid)):>18} slices {sh} manifest {mh}{verdict}",
              flush=True)
    if differ:
        sys.exit(1)


if __name__ == "__main__":
    main()
