"""Read a finished print job back and check it against its manifest and its printer.

Defines :func:`check_job` (the report of ``dreamprint evaluate job``) and
:data:`RESIN_DENSITY_G_CM3`.

Against the manifest: per material, the fraction of voxels in the slices vs the intended mean
concentration recorded in the manifest, with a z-score against the binomial bound
sqrt(p(1-p)/N) (halftoning draws each voxel with its concentration as probability, so the
variance of a count is at most that of i.i.d. draws at the mean); slice count and names,
identical image sizes, per-material counts equal to what the slices hold, counts summing to the
grid's voxels.

Against the printer (the manifest's own, or another one to print on): the voxel size; each
slice's image size (grid x by y, or y by x with ``image_columns = "y"``); the dpi its PNG pHYs
chunk states, if it has one (600 x 300 dpi = 23622 x 11811 pixels per metre); that every pixel
is one of the printer's material codes (the manifest's codes equal to the printer's); the layer
count = the job's height / the layer thickness; the job inside the tray.

Per material the volume it fills (voxels x voxel volume) in ml and its mass in grams at the
resin's density (:data:`RESIN_DENSITY_G_CM3`).
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from dreamprint_gui.core.errors import DreamPrintError
from dreamprint_gui.core.printer import PrinterProfile, load_printer, printer_from_dict
from dreamprint_gui.job.encode.png_slices import read_png_labels, read_png_phys
from dreamprint_gui.job.write import MANIFEST, SLICES, slice_name

__all__ = ["check_job", "Z_LIMIT", "RESIN_DENSITY_G_CM3", "RESIN_DENSITY_SOURCE"]

Z_LIMIT = 5.0
_REQUIRED = ("grid_dimensions", "labels", "voxel_counts", "mean_concentration", "slices",
             "voxel_mm", "seed", "halftoning", "software", "source", "printer")
# Cured resin density (g/cm3 = g/ml) per label, the middle of the datasheets' ranges.
RESIN_DENSITY_G_CM3 = {"C": 1.175, "M": 1.175, "Y": 1.175, "K": 1.175, "W": 1.175,
                       "Cl": 1.185, "empty": 0.0}
RESIN_DENSITY_SOURCE = ("Vero colours 1.175 g/cm3, VeroClear 1.185 g/cm3,\n      the "
                        "middles of Stratasys' PolyJet datasheets' polymerized densities "
                        "(Vero 1.17-1.18, VeroClear 1.18-1.19)")


def _printer_of(manifest: dict, mpath: Path) -> PrinterProfile:
    d = dict(manifest["printer"]) if isinstance(manifest.get("printer"), dict) else {}
    d.setdefault("format", "dreamprint-printer")
    d.setdefault("format_version", 1)
    try:
        return printer_from_dict(d, f"<printer of {mpath}>")
    except DreamPrintError as exc:
        raise DreamPrintError(f"the manifest's printer is not a valid printer profile: {exc}",
                              mpath) from None


def _dpi(ppm: float) -> float:
    return ppm * 0.0254


def check_job(job: str | Path, printer: str | PrinterProfile | None = None,
              progress: Callable[..., None] | None = None) -> dict[str, Any]:
    """The report of ``dreamprint evaluate job`` (module doc). ``printer``: the printer to
    check against (a name, a .toml file or a profile; default: the manifest's).
    ``progress(0, 1)`` before reading the slices (a 1e9-voxel job's take minutes),
    ``progress(0, 1, "z of nz slices read")`` after each, ``progress(1, 1)`` when done."""
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
    if not isinstance(manifest, dict):
        raise DreamPrintError("the manifest is not a JSON object", mpath)
    missing = [k for k in _REQUIRED if k not in manifest]
    if missing:
        raise DreamPrintError(f"manifest lacks {', '.join(missing)}", mpath)
    try:
        nx, ny, nz = (int(v) for v in manifest["grid_dimensions"])
        labels = list(manifest["labels"])
        palette = np.array([manifest["labels"][k]["rgb"] for k in labels], dtype=np.uint8)
        width, height = int(manifest["slices"]["width"]), int(manifest["slices"]["height"])
        job_voxel = [float(v) for v in manifest["voxel_mm"]]
    except (TypeError, ValueError, KeyError) as exc:
        raise DreamPrintError(f"malformed manifest field: {exc}", mpath) from None
    if printer is None:
        prn = _printer_of(manifest, mpath)
    elif isinstance(printer, PrinterProfile):
        prn = printer
    else:
        prn = load_printer(printer)
    problems: list[str] = []
    checks: list[dict[str, Any]] = []

    def check(name: str, ok: bool, text: str) -> None:
        checks.append({"check": name, "ok": bool(ok), "text": text})
        if not ok:
            problems.append(f"{name}: {text}")

    count = manifest["slices"].get("count") if isinstance(manifest["slices"], dict) else None
    if count != nz:
        problems.append(f"the manifest lists {count} slices but its grid has {nz} layers")
    # --- against the printer
    pv = prn.voxel_mm
    check("voxel", all(math.isclose(a, b, rel_tol=1e-9) for a, b in zip(job_voxel, pv,
                                                                         strict=True)),
          f"job voxel {' x '.join(f'{v:.5g}' for v in job_voxel)} mm, printer {prn.name} "
          f"{' x '.join(f'{v:.5g}' for v in pv)} mm")
    want_w, want_h = (nx, ny) if prn.image_columns == "x" else (ny, nx)
    check("image size", (width, height) == (want_w, want_h),
          f"manifest slices {width} x {height} px, printer layout (image_columns "
          f"{prn.image_columns}) {want_w} x {want_h} px")
    codes = prn.palette()
    n_codes = min(len(codes), len(palette))
    same = (len(codes) == len(palette) and bool(np.array_equal(codes, palette)))
    check("codes in manifest", same,
          "the manifest's material codes are the printer's" if same else
          "the manifest's material codes differ from the printer's: " + "; ".join(
              f"{labels[i]} {tuple(int(v) for v in palette[i])} vs "
              f"{tuple(int(v) for v in codes[i])}" for i in range(n_codes)
              if not np.array_equal(palette[i], codes[i])))
    height_mm = nz * pv[2]
    phys = manifest.get("physical_size_mm")
    if isinstance(phys, list) and len(phys) == 3:
        want_layers = round(float(phys[2]) / pv[2])
        check("layers", want_layers == nz,
              f"{nz} layers; the job's height {float(phys[2]):.4f} mm / layer "
              f"{pv[2] * 1000:.4g} um = {want_layers}")
    size = [nx * pv[0], ny * pv[1], height_mm]
    check("tray", all(s_ <= t * (1 + 1e-9) for s_, t in zip(size, prn.tray_mm, strict=True)),
          f"job {size[0]:.2f} x {size[1]:.2f} x {size[2]:.2f} mm, tray "
          f"{prn.tray_mm[0]:.0f} x {prn.tray_mm[1]:.0f} x {prn.tray_mm[2]:.0f} mm")
    # --- the slices
    counts = np.zeros(len(codes), np.int64)
    expected = {slice_name(z, nz) for z in range(nz)}
    present = {p.name for p in (job / SLICES).glob("*.png")} if (job / SLICES).is_dir() else set()
    if present - expected:
        problems.append(f"{len(present - expected)} unexpected files in slices/")
    want_ppm = prn.pixels_per_metre()
    phys_seen: set = set()
    bad_codes: list[str] = []
    bad_size = 0
    if progress is not None:
        progress(0, 1)
    for z in range(nz):
        if progress is not None and z:
            progress(0, 1, f"{z} of {nz} slices read")
        name = slice_name(z, nz)
        if name not in present:
            problems.append(f"missing slices/{name}")
            continue
        phys_seen.add(read_png_phys(job / SLICES / name))
        try:
            lab = read_png_labels(job / SLICES / name, codes)
        except DreamPrintError as exc:
            bad_codes.append(f"slices/{name}: {str(exc).split(': ', 1)[-1]}")
            continue
        if lab.shape != (want_h, want_w):
            bad_size += 1
            if bad_size == 1:
                problems.append(f"slices/{name} is {lab.shape[1]} x {lab.shape[0]} px, "
                                f"expected {want_w} x {want_h}")
        counts += np.bincount(lab.ravel(), minlength=len(codes))[: len(codes)]
    if progress is not None:
        progress(1, 1)
    if bad_size > 1:
        problems.append(f"{bad_size} slices have the wrong image size")
    check("codes in slices", not bad_codes,
          f"every pixel is one of the printer's {len(codes)} codes" if not bad_codes else
          f"{len(bad_codes)} slices hold colours that are no code of {prn.name}, first "
          + bad_codes[0])
    if not phys_seen or phys_seen == {None}:
        checks.append({"check": "dpi", "ok": True, "text": "not written (no pHYs chunk)"})
    else:
        stated = sorted((p for p in phys_seen if p is not None), key=str)
        ok = None not in phys_seen and all(
            p[2] == 1 and abs(p[0] - want_ppm[0]) <= 1 and abs(p[1] - want_ppm[1]) <= 1
            for p in stated)
        check("dpi", ok, f"pHYs {_dpi(stated[0][0]):.1f} x {_dpi(stated[0][1]):.1f} dpi"
              + (" (some slices without pHYs)" if None in phys_seen else "")
              + (f" ({len(stated)} different)" if len(stated) > 1 else "")
              + f", printer {_dpi(want_ppm[0]):.1f} x {_dpi(want_ppm[1]):.1f} dpi")
    # --- against the manifest
    total = nx * ny * nz
    # the slices' voxels are the job's: its resin is counted at its own voxel size, whatever
    # printer it is checked against (a mismatch is the voxel check's to say)
    vvox = float(np.prod(job_voxel))
    materials = {}
    for i, k in enumerate(labels[: len(codes)]):
        frac = counts[i] / total
        intended = float(manifest["mean_concentration"].get(k, 0.0))
        sd = math.sqrt(max(intended * (1 - intended), 1e-300) / total)
        z = (frac - intended) / sd if intended * (1 - intended) > 0 else (
            0.0 if frac == intended else math.inf)
        ml = float(counts[i]) * vvox / 1000.0
        materials[k] = {"voxels": int(counts[i]), "fraction": frac, "intended": intended,
                        "difference": frac - intended, "z_score": z, "volume_ml": ml,
                        "density_g_cm3": RESIN_DENSITY_G_CM3.get(k, 0.0),
                        "mass_g": ml * RESIN_DENSITY_G_CM3.get(k, 0.0)}
        if not bad_codes and int(manifest["voxel_counts"].get(k, -1)) != int(counts[i]):
            problems.append(f"{k}: manifest counts {manifest['voxel_counts'].get(k)} voxels, "
                            f"the slices hold {int(counts[i])}")
        if not bad_codes and abs(z) > Z_LIMIT:
            problems.append(f"{k}: fraction {frac:.6f} is {z:+.1f} sigma from the intended "
                            f"{intended:.6f}")
    if (int(counts.sum()) != total and not bad_codes
            and not any(p.startswith("missing") for p in problems)):
        problems.append(f"slices hold {int(counts.sum())} voxels, the grid has {total}")
    resin = [m for m in materials if m != "empty"]
    return {"job": str(job), "grid_dimensions": [nx, ny, nz], "slices_found": len(present),
            "total_voxels": total, "printer": prn.name, "voxel_mm": job_voxel,
            "printer_voxel_mm": list(pv),
            "size_mm": size, "checks": checks, "materials": materials,
            "total_volume_ml": sum(materials[m]["volume_ml"] for m in resin),
            "total_mass_g": sum(materials[m]["mass_g"] for m in resin),
            "density_source": RESIN_DENSITY_SOURCE, "seed": manifest["seed"],
            "halftoning": manifest["halftoning"], "consistent": not problems,
            "problems": problems}
