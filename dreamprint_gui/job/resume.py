"""Resumable print jobs: what an interrupted job folder holds, and what ``--resume`` finishes.

Stage 5 of the pipeline (write, paper Fig. 2) made restartable. Hand-written: Dask keeps no
task results beyond its client's life, and result caches (``dask.cache``, graphchain) key
results by task, not by the slices already on disk nor by a job identity to refuse.

A job is written into a hidden temporary folder (:mod:`.write`) laid out as::

    .JOB.partial-<pid>-<id>/
        identity.json        the job's identity (:func:`job_identity`), written before any slab
        slices/NNNNN.png     each slice written under a temporary name, then renamed
        slabs/Z0-Z1.json     one record per finished slab (:func:`write_slab_record`), renamed
                             into place after the slab's slices: the slab's counts, per-layer
                             concentration sums, clamp report and each slice's byte size

A slab is done exactly when its record exists and every slice it names has the recorded size
(a slice that a power cut left short or empty makes its slab run again). ``--resume`` claims
the folder an interrupted run left (client killed, power lost, Ctrl-C, scheduler lost), refuses
it in one line when it was made for another source, size, profile, printer, settings or
DreamPrint version (:func:`check_identity`), and runs only the layers no valid record covers
(:func:`missing_slabs`): every label is a function of the voxel's position, the seed and its
concentrations, so the slices are those of an uninterrupted run. The records' sums stand in
for the finished slabs' results, so the manifest's totals are the same too.
"""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Any

import numpy as np

from dreamprint_gui import __version__
from dreamprint_gui.core.errors import DreamPrintError
from dreamprint_gui.job.write import (
    IDENTITY,
    SLABS,
    SLICES,
    slice_name,
    stale_partials,
    write_atomic,
)

__all__ = ["job_identity", "find_interrupted", "write_identity", "check_identity",
           "write_slab_record", "read_slab_records", "missing_slabs", "layers_in"]

_FORMAT = "dreamprint-partial-job"

# Identity key -> what an operator is told differs.
_WHAT = {"software": "another DreamPrint version", "source": "another source",
         "source_file": "the source file as it was then (it has changed since: size or time)",
         "grid_dimensions": "another size", "placement": "another size or placement",
         "profile": "another ink profile or colour tables", "printer": "another printer",
         "seed": "another seed", "halftoning": "another halftoning",
         "background": "another background", "compensation": "another compensation"}


def job_identity(description: dict[str, Any], source_stamp: tuple) -> dict[str, Any]:
    """What makes a job's slices what they are: the job description's source, profile,
    placement, printer, grid, seed, halftoning, background and compensation
    (:func:`.run.job_description`), the DreamPrint version, and the source file's size and
    modification time (``source_stamp``, :func:`.plan._stamp`). JSON-normalised, so that a
    stamp read back compares equal."""
    ident = {k: description[k] for k in _WHAT if k in description}
    # the profile is known by its fingerprint (its content): the path it was given by may be
    # relative, or absolute when a cluster job made it so
    ident["profile"] = {k: v for k, v in ident.get("profile", {}).items() if k != "path"}
    ident["software"] = {"name": "dreamprint", "version": __version__}
    ident["source_file"] = list(source_stamp)
    return {"format": _FORMAT, **json.loads(json.dumps(ident))}


def _atomic_json(path: Path, data: dict[str, Any]) -> None:
    """``data`` as JSON, renamed into place (:func:`.write.write_atomic`, as the slices: an
    OSError such as a full disk stays one for :class:`.write.JobWriter` to report)."""
    write_atomic(os.fspath(path), json.dumps(data).encode("utf-8"))


def write_identity(folder: Path, identity: dict[str, Any]) -> None:
    """Stamp a job's temporary folder with its identity and make its ``slabs`` folder."""
    (folder / SLABS).mkdir(exist_ok=True)
    _atomic_json(folder / IDENTITY, identity)


def read_identity(folder: Path) -> dict[str, Any] | None:
    try:
        return json.loads((folder / IDENTITY).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None


def check_identity(folder: Path, identity: dict[str, Any]) -> None:
    """Refuse, in one line naming the folder, a folder left by a run of another job."""
    old = read_identity(folder)
    if old is None or old.get("format") != _FORMAT:
        raise DreamPrintError("the interrupted run left no readable job identity; cannot "
                              "resume it (use --overwrite to start again)", folder)
    for key, what in _WHAT.items():
        if old.get(key) != identity.get(key):
            extra = ""
            if key == "software":
                extra = (f" ({old.get(key, {}).get('version')}, this is "
                         f"{identity[key]['version']})")
            raise DreamPrintError(f"the interrupted run was made from {what}{extra}; refusing "
                                  "to resume it (use --overwrite to start again)", folder)


def write_slab_record(job_folder: str, record: dict[str, Any], sizes: list[int]) -> None:
    """Mark a slab done (after its slices are in place): ``slabs/Z0-Z1.json``, renamed in."""
    z0, z1 = record["z0"], record["z1"]
    _atomic_json(Path(job_folder) / SLABS / f"{z0:06d}-{z1:06d}.json",
                 {**record, "slice_bytes": sizes})


def _sound(rec: dict[str, Any], z0: int, z1: int, layer_voxels: int | None) -> bool:
    """Whether a record holds what the job's totals add (:func:`.slab.run_slab`'s result):
    7 voxel counts summing to the slab's voxels, (layers, 7) finite concentration sums, the
    clamp report's numbers. A record edited or damaged otherwise would change the manifest's
    totals silently, or stop the resumed job with a traceback."""
    try:
        counts = np.asarray(rec["counts"])
        sums = np.asarray(rec["conc_sums"], dtype=np.float64)
        clamped = rec["clamped"]
        ok = (counts.shape == (7,) and counts.dtype.kind in "iu" and bool(np.all(counts >= 0))
              and sums.shape == (z1 - z0, 7) and bool(np.all(np.isfinite(sums)))
              and isinstance(clamped, dict)
              and all(isinstance(v, int | float) and np.isfinite(v) for v in clamped.values()))
    except (KeyError, TypeError, ValueError):
        return False
    return ok and (layer_voxels is None or int(counts.sum()) == (z1 - z0) * layer_voxels)


def read_slab_records(folder: Path, n_layers: int, layer_voxels: int | None = None
                      ) -> list[dict[str, Any]]:
    """The valid slab records of a job folder: readable, inside the job's layers, holding
    sound totals (:func:`_sound`; ``layer_voxels``: a layer's voxels, when known), every slice
    named present with its recorded size; sorted by first layer, overlaps dropped."""
    out: list[dict[str, Any]] = []
    for p in sorted((folder / SLABS).glob("*.json")):
        try:
            rec = json.loads(p.read_text(encoding="utf-8"))
            z0, z1, sizes = int(rec["z0"]), int(rec["z1"]), rec["slice_bytes"]
            if not (0 <= z0 < z1 <= n_layers) or len(sizes) != z1 - z0:
                continue
        except (OSError, ValueError, KeyError, TypeError):
            continue
        if not _sound(rec, z0, z1, layer_voxels):
            continue
        try:
            ok = all(os.stat(folder / SLICES / slice_name(z, n_layers)).st_size == size
                     for z, size in zip(range(z0, z1), sizes, strict=True))
        except OSError:
            ok = False
        if ok:
            out.append(rec)
    out.sort(key=lambda r: r["z0"])
    kept: list[dict[str, Any]] = []
    for rec in out:
        if not kept or rec["z0"] >= kept[-1]["z1"]:
            kept.append(rec)
    return kept


def find_interrupted(target: str | os.PathLike) -> tuple[Path, int, int] | None:
    """The folder an interrupted run of ``target`` left, with finished slabs to keep: (folder,
    layers done, layers of the job), the newest if several; None when there is none."""
    for folder in stale_partials(target):
        ident = read_identity(folder)
        if ident is None or "grid_dimensions" not in ident:
            continue
        try:
            nx, ny, nz = (int(n) for n in ident["grid_dimensions"])
        except (TypeError, ValueError):
            continue
        done = layers_in(read_slab_records(folder, nz, nx * ny))
        if done:
            return folder, done, nz
    return None


def layers_in(records: list[dict[str, Any]]) -> int:
    return sum(r["z1"] - r["z0"] for r in records)


def missing_slabs(slabs: list[tuple[int, int]], records: list[dict[str, Any]]
                  ) -> list[tuple[int, int]]:
    """The parts of the planned ``slabs`` that no record covers (records do not overlap)."""
    done = sorted((r["z0"], r["z1"]) for r in records)
    out = []
    for z0, z1 in slabs:
        z = z0
        for d0, d1 in done:
            if d1 <= z or d0 >= z1:
                continue
            if d0 > z:
                out.append((z, d0))
            z = max(z, d1)
        if z < z1:
            out.append((z, z1))
    return out
