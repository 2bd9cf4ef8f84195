"""An appearance correction: a smooth field of colour and density factors a job applies.

Defines :class:`Correction`, :func:`save_correction`, :func:`load_correction`,
:func:`check_correction`, :func:`source_fingerprint` and :func:`apply_correction` (the step
inside the job's sampling, before the table lookup).

The field ``gain`` (gz, gy, gx, 4) holds, per cell of a coarse grid laid over the print grid
(cell centres at ``(c + 0.5) / g`` of each axis, in the print grid's normalised coordinates),
a factor of the source's linear RGB (3) and of its density (1). At a voxel of the print grid
(centre ``(i + 0.5) / n``) the factors are trilinear between cell centres (clamped at the
outer half cells), and the sampled values become::

    v     = g_rgb * decode(rgb)                        (sRGB transfer function, IEC 61966-2-1)
    rgb'  = encode(v / max(1, max_c v_c))
    sigma' = g_sigma * sigma          (except a solid voxel's sigma, SOLID_TARGET: it stays
                                       solid, its colour's undiluted mixture)

A colour pushed above the top is scaled down as a whole, not clipped per channel: it keeps the
chromaticity the optimiser asked for. At the gamut's top (a white fog: the print's white is
darker and yellower than the source's) clipping would leave white white, and the print's tint
could never be corrected; scaled, it becomes the slightly bluish white that prints neutral
(Blender smoke, bench_compensate.py: dE2000 5.21 -> 5.41 clipped, 4.67 scaled).

A factor of exactly 1 leaves its value untouched (no transfer-function round trip), so an
identity correction gives the job's slices byte for byte. The optimiser that makes a correction
is :mod:`dreamprint_gui.proof.compensate` (the proof layer; this module only reads and applies).

File (``.npz``, numpy's zip of arrays, no pickles): ``gain`` float32, and ``meta`` a JSON
string: format, version, the source (path and fingerprint: file size and modification time, or
those of a folder's entries), the print size in mm, the printer, the ink profile's fingerprint,
the background and its threshold (1/mm, as resolved for the job: below it a voxel is
background), the placement, the rendering (colour table objective, rendering intent and content
mode, as resolved for the job: :func:`rendering_key`) and the optimiser's report (figures before
and after). A job refuses, in one line, a file that is not a correction, or one made for another
source, size, printer, profile, placement, background, background threshold, objective, intent
or content.

A file written before the rendering was recorded (no ``rendering`` in its meta) is read as made
under the defaults (content auto, the profile's objective and intent): every such file was
trained through the proof, whose settings then carried none of the three, so the defaults are
what it was made under, not a guess; a job with other choices refuses it. Likewise a file
that records no background threshold was made under the default one (half the density of pure
Clear): the optimiser labelled the source with it whatever the job's ``--density-threshold``.
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import zipfile
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numba import njit
from numpy.typing import NDArray

from dreamprint_gui.core.errors import DreamPrintError
from dreamprint_gui.gamut.alignment import SOLID_TARGET

__all__ = ["Correction", "save_correction", "load_correction", "check_correction",
           "source_fingerprint", "apply_correction", "axis_weights", "placement_key",
           "rendering_key", "RENDERING_FIELDS", "FORMAT", "VERSION", "MAX_CELLS"]

FORMAT = "dreamprint-correction"
VERSION = 1
MAX_CELLS = 128
# what a correction is trained under besides the placement, as the job resolved it
RENDERING_FIELDS = ("objective", "intent", "content")


@dataclass(frozen=True)
class Correction:
    gain: NDArray[np.float32]                 # (gz, gy, gx, 4): R, G, B (linear), density
    source: str = ""
    source_fingerprint: str = ""
    print_size_mm: tuple[float, float, float] = (0.0, 0.0, 0.0)
    printer: str = ""
    profile_fingerprint: str = ""
    background: str = "clear"
    report: dict[str, Any] = field(default_factory=dict)
    placement: str = ""                       # the job's orientation and fit (JSON text)
    # the job's objective, intent and content (rendering_key); None: a file from before they
    # were recorded, made under the defaults
    rendering: dict[str, str] | None = None
    # the job's background threshold in 1/mm; None: a file from before it was recorded, made
    # under the default one
    density_threshold: float | None = None

    @property
    def is_identity(self) -> bool:
        return bool(np.all(self.gain == 1.0))

    def meta(self) -> dict[str, Any]:
        return {"format": FORMAT, "version": VERSION, "source": self.source,
                "source_fingerprint": self.source_fingerprint,
                "print_size_mm": [float(v) for v in self.print_size_mm],
                "printer": self.printer, "profile_fingerprint": self.profile_fingerprint,
                "background": self.background, "placement": self.placement,
                "rendering": self.rendering,
                "density_threshold_per_mm": self.density_threshold,
                "cells_xyz": list(self.gain.shape[2::-1]),
                "report": self.report}

    def describe(self) -> dict[str, Any]:
        g = self.gain
        return {"cells_xyz": list(g.shape[2::-1]),
                "rgb_gain_range": [float(g[..., :3].min()), float(g[..., :3].max())],
                "density_gain_range": [float(g[..., 3].min()), float(g[..., 3].max())]}


def source_fingerprint(spec: str) -> str:
    """A short fingerprint of a source: its file's size and modification time (a folder: its
    entries'), hashed; "demo" for the built-in demo."""
    if spec == "demo":
        return "demo"

    def stamp(p: str):
        st = os.stat(p)
        if not os.path.isdir(p):
            return [st.st_size, st.st_mtime_ns]
        with os.scandir(p) as it:
            return sorted([e.name, stamp(e.path)] for e in it)

    try:
        s = stamp(spec)
    except OSError as exc:
        raise DreamPrintError(f"cannot read the source: {exc.strerror}", spec) from None
    return hashlib.sha256(json.dumps(s).encode()).hexdigest()[:16]


def _check_gain(gain: NDArray, where: str | os.PathLike) -> None:
    if gain.ndim != 4 or gain.shape[3] != 4 or min(gain.shape[:3]) < 1 \
            or max(gain.shape[:3]) > MAX_CELLS:
        raise DreamPrintError(f"the correction field has shape {gain.shape}, not "
                              f"(gz, gy, gx, 4) of 1..{MAX_CELLS} cells", where)
    if not np.all(np.isfinite(gain)) or gain.min() < 0:
        raise DreamPrintError("the correction field holds negative or non-finite factors",
                              where)


def save_correction(corr: Correction, path: str | os.PathLike) -> None:
    """Write ``corr`` to ``path`` (.npz) atomically (a temporary sibling renamed)."""
    p = Path(path)
    _check_gain(corr.gain, p)
    if not p.absolute().parent.is_dir():
        raise DreamPrintError("the folder to write into does not exist", p.absolute().parent)
    tmp = p.absolute().parent / f".{p.name}.tmp-{os.getpid()}"
    try:
        with open(tmp, "wb") as fh:
            np.savez_compressed(fh, gain=np.asarray(corr.gain, np.float32),
                                meta=np.array(json.dumps(corr.meta())))
        os.replace(tmp, p)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise


def load_correction(path: str | os.PathLike) -> Correction:
    """Read a correction file; a file that is not one is a one-line :class:`DreamPrintError`."""
    p = Path(path)
    if not p.is_file():
        raise DreamPrintError("no such correction file", p)
    try:
        with np.load(p, allow_pickle=False) as z:
            gain = np.array(z["gain"], np.float32)
            meta = json.loads(str(z["meta"]))
    except (OSError, ValueError, KeyError, zipfile.BadZipFile, json.JSONDecodeError,
            EOFError) as exc:
        raise DreamPrintError(f"not a DreamPrint correction file ({type(exc).__name__})",
                              p) from None
    if not isinstance(meta, dict) or meta.get("format") != FORMAT:
        raise DreamPrintError("not a DreamPrint correction file", p)
    if meta.get("version") != VERSION:
        raise DreamPrintError(f"correction file version {meta.get('version')}, this "
                              f"DreamPrint reads version {VERSION}", p)
    _check_gain(gain, p)
    try:
        size = tuple(float(v) for v in meta["print_size_mm"])
        corr = Correction(gain, str(meta["source"]), str(meta["source_fingerprint"]),
                          size, str(meta["printer"]), str(meta["profile_fingerprint"]),
                          str(meta.get("background", "clear")), dict(meta.get("report") or {}),
                          str(meta.get("placement", "")), _rendering(meta.get("rendering")),
                          _threshold(meta.get("density_threshold_per_mm")))
    except (KeyError, TypeError, ValueError) as exc:
        raise DreamPrintError(f"correction file lacks or has a malformed field: {exc}",
                              p) from None
    if len(size) != 3:
        raise DreamPrintError("correction file's print size is not X,Y,Z", p)
    return corr


def _threshold(value: Any) -> float | None:
    if value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise ValueError(f"density_threshold_per_mm is {value!r}, not a number")
    return float(value)


def _rendering(value: Any) -> dict[str, str] | None:
    if value is None:
        return None
    if not isinstance(value, dict):
        raise TypeError(f"rendering is {type(value).__name__}, not an object")
    return {k: str(value[k]) for k in RENDERING_FIELDS}


def check_correction(corr: Correction, path: str | os.PathLike, *, source: str,
                     print_size_mm: tuple[float, float, float], printer: str,
                     profile_fingerprint: str, background: str, placement: str = "",
                     rendering: dict[str, str] | None = None,
                     default_rendering: dict[str, str] | None = None,
                     density_threshold: float | None = None,
                     default_density_threshold: float | None = None) -> None:
    """Refuse (one line) a correction made for another source, size, printer, profile,
    placement, background, background threshold (1/mm) or rendering (:func:`rendering_key`)
    than the job's.

    ``default_rendering``, ``default_density_threshold``: what the defaults resolve to for this
    job, the rendering and threshold of a file that records none (see the module docstring)."""
    fp = source_fingerprint(source)
    if corr.source_fingerprint != fp:
        raise DreamPrintError(f"the correction was made for another source "
                              f"({Path(corr.source).name or corr.source}, or this file changed "
                              f"since)", path)
    if not all(math.isclose(a, b, rel_tol=1e-6, abs_tol=1e-9)
               for a, b in zip(corr.print_size_mm, print_size_mm, strict=True)):
        got = " x ".join(f"{v:.2f}" for v in corr.print_size_mm)
        want = " x ".join(f"{v:.2f}" for v in print_size_mm)
        raise DreamPrintError(f"the correction was made for a print of {got} mm, this job is "
                              f"{want} mm", path)
    if corr.printer != printer:
        raise DreamPrintError(f"the correction was made for printer '{corr.printer}', this "
                              f"job prints on '{printer}'", path)
    if corr.profile_fingerprint != profile_fingerprint:
        raise DreamPrintError("the correction was made with another ink profile", path)
    if corr.placement != placement:
        raise DreamPrintError("the correction was made for another orientation or fit of the "
                              "source (--up, --rotate, --fit)", path)
    if corr.background != background:
        raise DreamPrintError(f"the correction was made with --background {corr.background}, "
                              f"this job has {background}", path)
    made_thr = corr.density_threshold if corr.density_threshold is not None \
        else default_density_threshold
    if density_threshold is not None and made_thr is not None \
            and not math.isclose(made_thr, density_threshold, rel_tol=1e-9):
        old = "" if corr.density_threshold is not None else " (the default: the file predates " \
            "recorded thresholds)"
        raise DreamPrintError(f"the correction was made with a background threshold of "
                              f"{made_thr:.4g}/mm{old}, this job has {density_threshold:.4g}/mm "
                              f"(convert --density-threshold)", path)
    made = corr.rendering if corr.rendering is not None else default_rendering
    if rendering is not None and made is not None:
        for k in RENDERING_FIELDS:
            if made[k] != rendering[k]:
                old = "" if corr.rendering is not None else \
                    " (the defaults: the file predates recorded choices)"
                raise DreamPrintError(f"the correction was made with --{k} {made[k]}{old}, "
                                      f"this job has {rendering[k]}", path)


def placement_key(ctx: Any) -> str:
    """The orientation and fit of a job (:class:`..plan.JobContext`) as the text a correction
    records."""
    pj = ctx.placement_json() if hasattr(ctx, "placement_json") else {}
    return json.dumps({"orientation": pj.get("orientation"),
                       "fit": (pj.get("fit") or {}).get("mode")}, sort_keys=True)


def rendering_key(ctx: Any) -> dict[str, str]:
    """The colour table objective, rendering intent and content mode a job (a prepared
    :class:`..plan.JobContext`) resolved: what a correction records and is checked against."""
    return {"objective": str(ctx.tables.objective), "intent": str(ctx.tables.intent),
            "content": ctx.content.mode if ctx.content is not None else "fog"}


def axis_weights(n: int, g: int, start: int = 0, count: int | None = None
                 ) -> tuple[NDArray[np.int64], NDArray[np.float32]]:
    """For voxels ``start .. start + count - 1`` of an axis of ``n`` voxels: the lower cell
    index (of ``g`` cells) and the weight of the upper one (trilinear between cell centres,
    clamped at the ends)."""
    count = n - start if count is None else count
    i = np.arange(start, start + count, dtype=np.float64)
    u = (i + 0.5) / n * g - 0.5
    u = np.clip(u, 0.0, g - 1.0)
    i0 = np.minimum(np.floor(u).astype(np.int64), max(g - 2, 0))
    w = (u - i0).astype(np.float32)
    if g == 1:
        w[:] = 0.0
    return i0, w


@njit(cache=True, nogil=True, inline="always")
def _decode(c):
    if c <= 0.04045:
        return c / 12.92
    return ((c + 0.055) / 1.055) ** 2.4


@njit(cache=True, nogil=True, inline="always")
def _encode(v):
    if v <= 0.0:
        return 0.0
    if v >= 1.0:
        return 1.0
    if v <= 0.0031308:
        return 12.92 * v
    return 1.055 * v ** (1.0 / 2.4) - 0.055


_SOLID = np.float32(SOLID_TARGET)


@njit(cache=True, nogil=True)
def _apply(gain, iz, wz, iy, wy, ix, wx, rgb, dens):
    L, ny, nx = dens.shape
    gz, gy, gx = gain.shape[0], gain.shape[1], gain.shape[2]
    g = np.empty(4)
    v = np.empty(3)
    for k in range(L):
        z0 = iz[k]
        z1 = min(z0 + 1, gz - 1)
        fz = wz[k]
        for j in range(ny):
            y0 = iy[j]
            y1 = min(y0 + 1, gy - 1)
            fy = wy[j]
            for i in range(nx):
                d = dens[k, j, i]
                if not d > 0.0:
                    continue  # empty (or NaN): no colour is read there
                x0 = ix[i]
                x1 = min(x0 + 1, gx - 1)
                fx = wx[i]
                for c in range(4):
                    a = (gain[z0, y0, x0, c] * (1 - fx) + gain[z0, y0, x1, c] * fx) * (1 - fy) \
                        + (gain[z0, y1, x0, c] * (1 - fx) + gain[z0, y1, x1, c] * fx) * fy
                    b = (gain[z1, y0, x0, c] * (1 - fx) + gain[z1, y0, x1, c] * fx) * (1 - fy) \
                        + (gain[z1, y1, x0, c] * (1 - fx) + gain[z1, y1, x1, c] * fx) * fy
                    g[c] = a * (1 - fz) + b * fz
                if g[3] != 1.0 and d < _SOLID:  # a solid voxel stays solid (undiluted)
                    dens[k, j, i] = d * g[3]
                if g[0] == 1.0 and g[1] == 1.0 and g[2] == 1.0:
                    continue
                top = 1.0
                for c in range(3):
                    v[c] = g[c] * _decode(float(rgb[k, j, i, c]))
                    top = max(top, v[c])
                for c in range(3):
                    rgb[k, j, i, c] = _encode(v[c] / top)


def apply_correction(gain: NDArray[np.float32], shape_xyz: tuple[int, int, int], z0: int,
                     rgb: NDArray[np.float32], dens: NDArray[np.float32]) -> None:
    """Apply the field ``gain`` in place to the sampled layers ``z0 .. z0 + L - 1`` of a print
    grid of ``shape_xyz`` voxels: ``rgb`` (L, ny, nx, 3) sRGB-encoded, ``dens`` (L, ny, nx)."""
    nx, ny, nz = (int(v) for v in shape_xyz)
    gz, gy, gx = gain.shape[:3]
    L = dens.shape[0]
    iz, wz = axis_weights(nz, gz, z0, L)
    iy, wy = axis_weights(ny, gy)
    ix, wx = axis_weights(nx, gx)
    _apply(np.ascontiguousarray(gain, np.float32), iz, wz, iy, wy, ix, wx, rgb, dens)
