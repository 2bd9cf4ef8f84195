"""Where the proof's labels come from: the engine's own labelling of a job, or a job's slices.

Defines
-------
- :class:`EngineLabels`: a print job prepared exactly as ``dreamprint convert`` prepares it
  (:func:`...job.plan.prepare_job`), labelled a layer at a time by :func:`...job.slab.
  halftone_layer` (byte-identical to the exported slice).
- :class:`JobFolderLabels`: the labels of an exported job, read back from its PNG slices with
  the manifest's palette and slice layout; the folder is checked first (manifest fields, every
  slice present, slice size equal to the grid's), so a bad folder is a one-line error.

Both give ``shape_xyz``, ``voxel_mm``, ``profile`` (the ink profile the job was made with),
``source`` with ``grid`` and ``density_scale`` (for the source render) and ``layer(z)``.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from dreamprint_gui.core.errors import DreamPrintError
from dreamprint_gui.core.profile import load_profile
from dreamprint_gui.io.volumes import grid_for_source, open_source
from dreamprint_gui.io.volumes.orient import Orientation, orient_source
from dreamprint_gui.job.content import apply_content
from dreamprint_gui.job.encode.png_slices import read_png_labels
from dreamprint_gui.job.plan import prepare_job
from dreamprint_gui.job.slab import halftone_layer
from dreamprint_gui.job.write import MANIFEST, SLICES, slice_name

__all__ = ["EngineLabels", "JobFolderLabels", "is_job_folder"]

_PNG_END = b"\x00\x00\x00\x00IEND\xaeB`\x82"  # the empty IEND chunk that ends every PNG


def is_job_folder(path: str) -> bool:
    p = Path(path)
    return p.is_dir() and ((p / "manifest.json").exists() or (p / "slices").is_dir())


class EngineLabels:
    """Labels of a job made from ``settings`` (:class:`...job.plan.ConvertSettings`)."""

    def __init__(self, settings: Any) -> None:

        self.settings = settings
        self.ctx = prepare_job(settings)
        self.shape_xyz = self.ctx.shape_xyz
        self.voxel_mm = tuple(self.ctx.printer.voxel_mm)
        self.grid = self.ctx.grid
        self.source = self.ctx.source
        self.density_scale = float(settings.density_scale)
        self.profile = load_profile(settings.profile).with_settings(
            layer_thickness_mm=self.ctx.printer.layer_thickness_mm)
        self.halftoning = self.ctx.halftoner.describe()

    def layer(self, z: int) -> NDArray[np.uint8]:

        return halftone_layer(self.settings, int(z), context=self.ctx)


class JobFolderLabels:
    """Labels of an exported job folder (``JOB/manifest.json`` + ``JOB/slices/*.png``)."""

    def __init__(self, job: str | Path, profile: str | None = None) -> None:

        job = Path(job)
        mpath = job / MANIFEST
        try:
            m = json.loads(mpath.read_text(encoding="utf-8"))
        except FileNotFoundError:
            raise DreamPrintError("no manifest.json: not a finished DreamPrint job",
                                  job) from None
        except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
            raise DreamPrintError(f"unreadable manifest: {exc}", mpath) from None
        try:
            nx, ny, nz = (int(v) for v in m["grid_dimensions"])
            self.voxel_mm = tuple(float(v) for v in m["voxel_mm"])
            names = list(m["labels"])
            self.palette = np.array([m["labels"][k]["rgb"] for k in names], np.uint8)
            pr = m["printer"]
            self.columns = pr.get("image_columns", "x")
            self.flip = bool(pr.get("flip_rows", False))
            width, height = int(m["slices"]["width"]), int(m["slices"]["height"])
            src = m["source"]
            req = m["requested_size"]
        except (KeyError, TypeError, ValueError) as exc:
            raise DreamPrintError(f"manifest lacks or has a malformed field: {exc}",
                                  mpath) from None
        if len(names) != 7 or len(self.voxel_mm) != 3:
            raise DreamPrintError("manifest labels or voxel size do not match this version",
                                  mpath)
        expect = (nx, ny) if self.columns == "x" else (ny, nx)
        if (width, height) != expect:
            raise DreamPrintError(f"manifest slice size {width} x {height} does not match its "
                                  f"grid {nx} x {ny} x {nz}", mpath)
        folder = job / SLICES
        present = {p.name for p in folder.glob("*.png")} if folder.is_dir() else set()
        missing = [slice_name(z, nz) for z in range(nz) if slice_name(z, nz) not in present]
        if missing:
            raise DreamPrintError(f"{len(missing)} of {nz} slices missing (first: slices/"
                                  f"{missing[0]})", job)
        # only some layers are decoded (--layers-per-block), so check every slice's end: a
        # truncated or half-written PNG lacks its final IEND chunk
        for z in range(nz):
            path = folder / slice_name(z, nz)
            try:
                with open(path, "rb") as fh:
                    fh.seek(max(path.stat().st_size - 12, 0))
                    complete = fh.read(12) == _PNG_END
            except OSError as exc:
                raise DreamPrintError(f"unreadable slice: {exc.strerror}", path) from None
            if not complete:
                raise DreamPrintError("truncated or not a PNG slice (no IEND chunk)", path)
        self.job = job
        self.folder = folder
        self.nz = nz
        self.slice_size = (height, width)
        self.shape_xyz = (nx, ny, nz)
        self.manifest = m
        self.density_scale = float(src.get("density_scale", 1.0))
        self.halftoning = m.get("halftoning", {})
        prof_path = profile if profile is not None else m.get("profile", {}).get("path")
        self.profile = load_profile(prof_path).with_settings(layer_thickness_mm=self.voxel_mm[2])
        fp = m.get("profile", {}).get("fingerprint")
        if fp and profile is None and self.profile.fingerprint() != fp:
            raise DreamPrintError("the job was made with another ink profile than the one "
                                  "found at its recorded path; give --profile", mpath)
        self.source = open_source(src["path"], **(src.get("options") or {}))
        # the job's placement: its orientation and the bounds its grid covers (--fit)
        place = m.get("placement") or {}
        bounds = None
        if place.get("orientation"):
            o = place["orientation"]
            self.source = orient_source(self.source, Orientation(
                o["up"], int(o["rotate_deg"]), bool(o.get("auto")), o.get("reason", "")))
        if (place.get("fit") or {}).get("mode") == "occupied":
            bounds = place["fit"]["bounds"]
        if (src.get("content") or {}).get("mode") == "solid":  # as the job sampled it
            thr = float((m.get("background") or {}).get("density_threshold_per_mm") or 0.0)
            self.source, _ = apply_content(self.source, "solid", thr)
        size = req.get("size_mm")
        self.grid = grid_for_source(self.source, self.voxel_mm, height_mm=req.get("height_mm"),
                                    size_mm=None if size is None else tuple(size),
                                    bounds=bounds)
        if tuple(self.grid.shape_xyz) != (nx, ny, nz):
            raise DreamPrintError(f"the manifest's grid {nx} x {ny} x {nz} does not match its "
                                  f"source at the recorded size ({self.grid.shape_xyz})", mpath)

    def layer(self, z: int) -> NDArray[np.uint8]:

        path = self.folder / slice_name(int(z), self.nz)
        try:
            img = read_png_labels(path, self.palette)
        except DreamPrintError:
            raise
        except Exception as exc:  # noqa: BLE001 - a damaged slice is the operator's problem
            raise DreamPrintError(f"unreadable slice: {exc}", path) from None
        if img.shape != self.slice_size:
            raise DreamPrintError(f"slice is {img.shape[1]} x {img.shape[0]}, the manifest says "
                                  f"{self.slice_size[1]} x {self.slice_size[0]}", path)
        if self.flip:
            img = img[::-1]
        if self.columns == "y":
            img = img.T
        return np.ascontiguousarray(img)
