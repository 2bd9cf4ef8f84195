"""Read a finished print job back and check it against its manifest.

Defines :func:`check_job` (the report of ``dreamprint evaluate job``): per material, the
fraction of voxels in the slices vs the intended mean concentration recorded in the manifest,
with a z-score against the binomial bound sqrt(p(1-p)/N) (halftoning draws each voxel with its
concentration as probability, so the variance of a count is at most that of i.i.d. draws at the
mean); and the manifest's consistency: slice count and names, identical image sizes, colour codes,
per-material counts equal to what the slices hold, counts summing to the grid's voxels.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np

from dreamprint_gui.core.errors import DreamPrintError
from dreamprint_gui.job.encode.png_slices import read_png_labels
from dreamprint_gui.job.write import MANIFEST, SLICES, slice_name

__all__ = ["check_job", "Z_LIMIT"]

Z_LIMIT = 5.0
_REQUIRED = ("grid_dimensions", "labels", "voxel_counts", "mean_concentration", "slices",
             "voxel_mm", "seed", "halftoning", "software", "source", "printer")


def check_job(job: str | Path) -> dict[str, Any]:
    job = Path(job)
    mpath = job / MANIFEST
    if not job.is_dir():
        raise DreamPrintError("not a job folder", job)
    try:
        manifest = json.loads(mpath.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise DreamPrintError("no manifest.json: not a finished DreamPrint job", job) from None
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise DreamPrintError(f"unreadable manifest: {exc}", mpath) from None
    missing = [k for k in _REQUIRED if k not in manifest]
    if missing:
        raise DreamPrintError(f"manifest lacks {', '.join(missing)}", mpath)
    try:
        nx, ny, nz = (int(v) for v in manifest["grid_dimensions"])
        labels = list(manifest["labels"])
        palette = np.array([manifest["labels"][k]["rgb"] for k in labels], dtype=np.uint8)
        width, height = int(manifest["slices"]["width"]), int(manifest["slices"]["height"])
    except (TypeError, ValueError, KeyError) as exc:
        raise DreamPrintError(f"malformed manifest field: {exc}", mpath) from None
    problems: list[str] = []
    count = manifest["slices"].get("count") if isinstance(manifest["slices"], dict) else None
    if count != nz:
        problems.append(f"the manifest lists {count} slices but its grid has {nz} layers")
    if {width, height} != {nx, ny}:
        problems.append(f"slice size {width} x {height} does not match the grid {nx} x {ny}")
    counts = np.zeros(len(labels), np.int64)
    expected = {slice_name(z, nz) for z in range(nz)}
    present = {p.name for p in (job / SLICES).glob("*.png")} if (job / SLICES).is_dir() else set()
    if present - expected:
        problems.append(f"{len(present - expected)} unexpected files in slices/")
    for z in range(nz):
        name = slice_name(z, nz)
        if name not in present:
            problems.append(f"missing slices/{name}")
            continue
        lab = read_png_labels(job / SLICES / name, palette)
        if lab.shape != (height, width):
            problems.append(f"slices/{name} is {lab.shape[1]} x {lab.shape[0]}, "
                            f"expected {width} x {height}")
        counts += np.bincount(lab.ravel(), minlength=len(labels))[: len(labels)]
    total = nx * ny * nz
    materials = {}
    for i, k in enumerate(labels):
        frac = counts[i] / total
        intended = float(manifest["mean_concentration"].get(k, 0.0))
        sd = math.sqrt(max(intended * (1 - intended), 1e-300) / total)
        z = (frac - intended) / sd if intended * (1 - intended) > 0 else (
            0.0 if frac == intended else math.inf)
        materials[k] = {"voxels": int(counts[i]), "fraction": frac, "intended": intended,
                        "difference": frac - intended, "z_score": z}
        if int(manifest["voxel_counts"].get(k, -1)) != int(counts[i]):
            problems.append(f"{k}: manifest counts {manifest['voxel_counts'].get(k)} voxels, "
                            f"the slices hold {int(counts[i])}")
        if abs(z) > Z_LIMIT:
            problems.append(f"{k}: fraction {frac:.6f} is {z:+.1f} sigma from the intended "
                            f"{intended:.6f}")
    if int(counts.sum()) != total and not any(p.startswith("missing") for p in problems):
        problems.append(f"slices hold {int(counts.sum())} voxels, the grid has {total}")
    return {"job": str(job), "grid_dimensions": [nx, ny, nz], "slices_found": len(present),
            "total_voxels": total, "materials": materials, "seed": manifest["seed"],
            "halftoning": manifest["halftoning"], "consistent": not problems,
            "problems": problems}
