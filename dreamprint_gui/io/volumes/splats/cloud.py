"""3D Gaussian splats as a density field: INRIA PLY (and nerfstudio's ``ns-export gaussian-splat``
PLY), SuperSplat compressed PLY, Niantic SPZ, antimatter15 ``.splat``, ``.ksplat``, PlayCanvas SOG
(the last four read in :mod:`.formats`).

Defines :class:`GaussianCloud` (the source), :func:`peak_density` and :func:`open_path`.

Readers: INRIA PLY through ``plyfile`` (any property order/precision; SH degree 0-3 from the
number of ``f_rest_*``); the chunked, quantised SuperSplat/PlayCanvas ``.compressed.ply`` and
SPZ through ``gsply`` (which returns pre-activation values like the INRIA file).  Activations
(Kerbl et al. 2023, sec. 4 and the reference code): colour ``0.5 + C0 * f_dc`` (C0 =
0.28209479, the degree-0 SH basis), opacity ``sigmoid(o)``, scales ``exp(s)``, rotation the
normalised quaternion (w, x, y, z).  Higher SH bands (view-dependent) are ignored: a print has
one colour per point.

Density derivation.  Gaussian i contributes ``rho_i(x) = s_i exp(-1/2 (x-mu)^T Sigma^-1 (x-mu))``
with ``Sigma = R diag(sigma^2) R^T``.  Along a unit direction d through the centre its optical
depth is ``tau(d) = s_i sqrt(2 pi / (d^T Sigma^-1 d))``; along principal axis k that is
``s_i sqrt(2 pi) sigma_k``.  The splat's alpha is opacity ``a`` at its centre from every view,
which no 3D density reproduces exactly for an anisotropic Gaussian; we match the geometric
mean over the principal axes, ``-ln(1 - a) = s_i sqrt(2 pi) (sigma_1 sigma_2 sigma_3)^(1/3)``,
so ``s_i = -ln(1 - a) / (sqrt(2 pi) (sigma_1 sigma_2 sigma_3)^(1/3))``: exact for isotropic
Gaussians, rotation invariant, and the transmittance through the centre along axis k is
``(1 - a)^(sigma_k / geomean)``.  The kernel is cut at Mahalanobis distance 3 (99.97 % of a
1D line integral).  Colour is density-weighted: ``c(x) = sum rho_i c_i / sum rho_i``;
density units are 1/source unit, then the rule of :mod:`.base` applies.
"""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
from numba import njit

from dreamprint_gui.core.errors import DreamPrintError
from dreamprint_gui.io.volumes.base import PrintGrid, SlabBuffers, check_slab, voxel_centres
from dreamprint_gui.io.volumes.dense import bounds_list
from dreamprint_gui.io.volumes.splats import formats as splat_formats
from dreamprint_gui.io.volumes.splats.raster import TILE_Z, pack_gaussians, rasterise_splats

__all__ = ["GaussianCloud", "peak_density", "open_path", "SH_C0"]

SH_C0 = 0.28209479177387814
MAX_OPACITY = 1.0 - 1e-6


def peak_density(opacity: np.ndarray, sigmas: np.ndarray) -> np.ndarray:
    """Centre density s (1/unit) of Gaussians with ``opacity`` (N,) and axis sigmas (N, 3)."""
    a = np.clip(np.asarray(opacity, float), 0.0, MAX_OPACITY)
    geo = np.cbrt(np.prod(np.asarray(sigmas, float), axis=1))
    return -np.log1p(-a) / (np.sqrt(2 * np.pi) * geo)


def _quat_to_rot(q: np.ndarray) -> np.ndarray:
    q = np.asarray(q, float)
    n = np.linalg.norm(q, axis=1, keepdims=True)
    q = np.where(n > 0, q / np.where(n > 0, n, 1), np.array([1.0, 0, 0, 0]))
    w, x, y, z = q.T
    return np.stack([
        np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)], -1),
        np.stack([2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)], -1),
        np.stack([2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], -1),
    ], axis=1)


@njit(cache=True, nogil=True)
def _frames(q, s2, inv_s2, inv_cov, half):
    """Per Gaussian, from its quaternion ``q`` (w, x, y, z; normalised here, identity if 0) and
    squared axis sigmas ``s2`` (and their inverses): the inverse covariance ``R diag(1/s2) R^T``
    as (xx, yy, zz, xy, xz, yz) into ``inv_cov`` and the 3-sigma half-extents
    ``3 sqrt(diag(R diag(s2) R^T))`` into ``half`` (the density model's kernel and its support,
    module docstring). The arithmetic of :func:`_quat_to_rot` and ``np.einsum("nij,nj,nkj->nik",
    ...)``, bit for bit (a test holds it to them), ~20x faster for a million Gaussians."""
    rot = np.empty((3, 3))
    for g in range(q.shape[0]):
        w0, x0, y0, z0 = q[g, 0], q[g, 1], q[g, 2], q[g, 3]
        nrm = math.sqrt(((w0 * w0 + x0 * x0) + y0 * y0) + z0 * z0)
        if nrm > 0:
            w, x, y, z = w0 / nrm, x0 / nrm, y0 / nrm, z0 / nrm
        else:
            w, x, y, z = 1.0, 0.0, 0.0, 0.0
        rot[0, 0] = 1 - 2 * (y * y + z * z)
        rot[0, 1] = 2 * (x * y - w * z)
        rot[0, 2] = 2 * (x * z + w * y)
        rot[1, 0] = 2 * (x * y + w * z)
        rot[1, 1] = 1 - 2 * (x * x + z * z)
        rot[1, 2] = 2 * (y * z - w * x)
        rot[2, 0] = 2 * (x * z - w * y)
        rot[2, 1] = 2 * (y * z + w * x)
        rot[2, 2] = 1 - 2 * (x * x + y * y)
        for t in range(6):
            i = (0, 1, 2, 0, 0, 1)[t]
            k = (0, 1, 2, 1, 2, 2)[t]
            inv_cov[g, t] = ((rot[i, 0] * inv_s2[g, 0] * rot[k, 0]
                              + rot[i, 1] * inv_s2[g, 1] * rot[k, 1])
                             + rot[i, 2] * inv_s2[g, 2] * rot[k, 2])
        for i in range(3):
            c = ((rot[i, 0] * s2[g, 0] * rot[i, 0] + rot[i, 1] * s2[g, 1] * rot[i, 1])
                 + rot[i, 2] * s2[g, 2] * rot[i, 2])
            half[g, i] = 3.0 * math.sqrt(c)


class GaussianCloud:
    """Activated Gaussians (means, axis sigmas, unit quaternions wxyz, opacity, sRGB colour)."""

    def __init__(self, name: str, fmt: str, means, sigmas, quats, opacity, rgb,
                 sh_degree: int = 0, bounds=None):
        self.name = name
        self.format = fmt
        self.colour_encoding = "srgb"
        # a slab's Gaussians are set up once and walked TILE_Z layers together: at 1e10 voxels
        # (1-layer slabs by size) 7-layer slabs converted a 1e6-Gaussian job 1.3x faster
        # (dreamprint convert 99.3 -> 75.2 s, CPU 176.8 -> 136.0 s; docs/print-jobs.md)
        self.slab_layers = TILE_Z
        self.sh_degree = int(sh_degree)
        means = np.asarray(means, float).reshape(-1, 3)
        sigmas = np.asarray(sigmas, float).reshape(-1, 3)
        opacity = np.asarray(opacity, float).reshape(-1)
        rgb = np.clip(np.asarray(rgb, float).reshape(-1, 3), 0.0, 1.0)
        ok = (np.all(np.isfinite(means), 1) & np.all(np.isfinite(sigmas), 1)
              & np.all(sigmas > 0, 1) & np.isfinite(opacity) & (opacity > 0)
              & np.all(np.isfinite(rgb), 1))
        quats = np.asarray(quats, float).reshape(-1, 4)
        inv_cov = np.empty((len(means), 6))
        half = np.empty((len(means), 3))
        with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
            _frames(np.ascontiguousarray(quats), np.ascontiguousarray(sigmas ** 2),
                    np.ascontiguousarray(sigmas ** -2.0), inv_cov, half)
        # a scale so small (or large) that the inverse covariance or the extent overflows, or a
        # non-finite rotation, has no printable kernel: skipped like a zero opacity (its NaN
        # would otherwise blank the voxels of every Gaussian it overlaps)
        ok &= (np.all(np.isfinite(inv_cov), 1) & np.all(np.isfinite(half), 1)
               & np.all(np.isfinite(quats), 1))
        self.n_total = len(means)
        self.n_skipped = int(self.n_total - np.count_nonzero(ok))
        if bounds is None and self.n_skipped == self.n_total:
            raise DreamPrintError(
                "no Gaussians in the file" if not self.n_total else
                f"none of the {self.n_total:,} Gaussians can be printed: each has zero opacity, "
                "a zero or extreme scale or a non-finite value", name)
        means, sigmas, opacity, rgb = means[ok], sigmas[ok], opacity[ok], rgb[ok]
        self.mean = np.ascontiguousarray(means)
        self.inv_cov = np.ascontiguousarray(inv_cov[ok])
        self.half = np.ascontiguousarray(half[ok])
        self.peak = np.ascontiguousarray(peak_density(opacity, sigmas))
        self.rgb = np.ascontiguousarray(rgb)
        self.index_by_height()
        if bounds is None:
            if len(self.mean):
                lo = (self.mean - self.half).min(0)
                hi = (self.mean + self.half).max(0)
            else:
                lo = hi = np.zeros(3)
            bounds = (tuple(float(v) for v in lo), tuple(float(v) for v in hi))
        self.bounds = bounds

    def index_by_height(self) -> None:
        """The rasteriser's copy of the Gaussians (:func:`.raster.pack_gaussians`) in
        order of their lowest z, with their lowest and highest z and the running maximum of the
        highest: a slab's Gaussians are then one stretch of rows, found by two binary
        searches, read one after another (in file order they were gathered from all over the
        arrays: ~2 ns per voxel to select them, and a cache miss per array and Gaussian)."""
        zmin = self.mean[:, 2] - self.half[:, 2]
        order = np.argsort(zmin, kind="stable")
        self._packed = pack_gaussians(self.mean, self.inv_cov, self.half, self.peak, self.rgb,
                                      order)
        self._zmin_sorted = zmin[order]
        self._zmax_sorted = (self.mean[:, 2] + self.half[:, 2])[order]
        self._zmax_reach = np.maximum.accumulate(self._zmax_sorted) if len(order) else zmin

    def sample_slab(self, grid: PrintGrid, z0: int, z1: int, *, density_scale: float = 1.0,
                    out: SlabBuffers | None = None):
        check_slab(grid, z0, z1)
        zs = voxel_centres(grid, 2, z0, z1)
        n = np.searchsorted(self._zmin_sorted, zs[-1], side="right")
        lo = np.searchsorted(self._zmax_reach[:n], zs[0], side="left")
        # ascending rows of the height order: a fixed order, deterministic sums
        cand = lo + np.flatnonzero(self._zmax_sorted[lo:n] >= zs[0])
        pitch = tuple(float(v) / grid.mm_per_unit for v in grid.voxel_mm)
        return rasterise_splats(cand, self._packed, grid.origin, pitch, grid.shape_xyz, z0, z1,
                                density_scale / grid.mm_per_unit, out)

    def info(self) -> dict:
        return {"format": self.format, "gaussians": int(self.n_total),
                "skipped": self.n_skipped,  # zero opacity or scale, or non-finite: not printed
                "sh_degree": self.sh_degree, "bounds": bounds_list(self.bounds)}


# ------------------------------------------------------------------------------------ readers

_PLY_SIZES = {"char": 1, "uchar": 1, "int8": 1, "uint8": 1, "short": 2, "ushort": 2, "int16": 2,
              "uint16": 2, "int": 4, "uint": 4, "int32": 4, "uint32": 4, "float": 4,
              "float32": 4, "double": 8, "float64": 8}


def _ply_header(path: Path) -> tuple[str, list[tuple[str, int, list[str]]]]:
    """(format, [(element, count, [property names])]) after checking sizes against the file."""
    with open(path, "rb") as f:
        raw = f.read(1 << 16)
    end = raw.find(b"end_header")
    if not raw.startswith(b"ply") or end < 0:
        raise DreamPrintError("not a PLY file (no 'ply' ... 'end_header' header)", path)
    nl = raw.find(b"\n", end)
    header_len = nl + 1 if nl >= 0 else len(raw)
    fmt = ""
    elements: list[tuple[str, int, list[str]]] = []
    rows: list[int] = []
    for line in raw[:end].decode("ascii", "replace").splitlines():
        w = line.split()
        if not w:
            continue
        if w[0] == "format" and len(w) >= 2:
            fmt = w[1]
        elif w[0] == "element" and len(w) == 3:
            if not re.fullmatch(r"\d+", w[2]):
                raise DreamPrintError(f"bad element count in header: {line.strip()}", path)
            elements.append((w[1], int(w[2]), []))
            rows.append(0)
        elif w[0] == "property" and elements:
            if w[1] == "list":
                rows[-1] = -1           # variable-size rows: cannot pre-size
            else:
                rows[-1] += _PLY_SIZES.get(w[1], 0) if rows[-1] >= 0 else 0
            elements[-1][2].append(w[-1])
    if fmt.startswith("binary"):
        need = sum(c * r for (_, c, _), r in zip(elements, rows, strict=True) if r > 0)
        have = path.stat().st_size - header_len
        if need > have:
            raise DreamPrintError(f"truncated: the header announces {need:,} bytes of data, the "
                                  f"file has {have:,}", path)
    else:
        n = sum(c for _, c, _ in elements)
        if n > path.stat().st_size:
            raise DreamPrintError(f"the header claims {n:,} rows, more than the file's bytes",
                                  path)
    return fmt, elements


def _sigmoid(x):
    return 1.0 / (1.0 + np.exp(-np.asarray(x, float)))


def _from_gsply(path: Path, fmt: str, data) -> GaussianCloud:
    shn = getattr(data, "shN", None)
    k = 0 if shn is None else int(np.asarray(shn).reshape(len(data.means), -1).shape[1] // 3)
    degree = {0: 0, 3: 1, 8: 2, 15: 3}.get(k, 0)
    return GaussianCloud(str(path), fmt, data.means, np.exp(np.asarray(data.scales, float)),
                         data.quats, _sigmoid(data.opacities),
                         0.5 + SH_C0 * np.asarray(data.sh0, float), degree)


def _read_inria(path: Path) -> GaussianCloud:
    from plyfile import PlyData

    try:
        ply = PlyData.read(str(path))
        v = ply["vertex"].data
    except Exception as exc:  # noqa: BLE001 - plyfile raises assorted types on bad input
        raise DreamPrintError(f"cannot read PLY: {exc}", path) from None
    names = set(v.dtype.names or ())
    # nerfstudio's splatfacto export at SH degree 0 (through open3d) writes the activated
    # colour as uchar red/green/blue instead of f_dc_*.
    rgb_bytes = not {"f_dc_0", "f_dc_1", "f_dc_2"} <= names and {"red", "green", "blue"} <= names
    need = ["x", "y", "z", "opacity", "scale_0", "scale_1", "scale_2", "rot_0", "rot_1",
            "rot_2", "rot_3"] + ([] if rgb_bytes else ["f_dc_0", "f_dc_1", "f_dc_2"])
    missing = [n for n in need if n not in names]
    if missing:
        raise DreamPrintError("not a Gaussian-splat PLY (missing vertex properties "
                              f"{', '.join(missing)})", path)

    def col(*ks):
        return np.stack([np.asarray(v[k], float) for k in ks], axis=1)

    if rgb_bytes:
        rgb = col("red", "green", "blue")
        if v["red"].dtype.kind in "ui" or rgb.max(initial=0.0) > 1.0:
            rgb = rgb / 255.0
    else:
        rgb = 0.5 + SH_C0 * col("f_dc_0", "f_dc_1", "f_dc_2")
    n_rest = sum(1 for n in names if n.startswith("f_rest_"))
    degree = {0: 0, 9: 1, 24: 2, 45: 3}.get(n_rest, 0)
    return GaussianCloud(str(path), "splats (INRIA PLY)", col("x", "y", "z"),
                         np.exp(col("scale_0", "scale_1", "scale_2")),
                         col("rot_0", "rot_1", "rot_2", "rot_3"),
                         _sigmoid(np.asarray(v["opacity"], float)), rgb, degree)


def _cloud(path: Path, g: splat_formats.Gaussians) -> GaussianCloud:
    """The source of Gaussians decoded by :mod:`.formats`."""
    return GaussianCloud(str(path), g.format, g.means, g.sigmas, g.quats, g.opacity, g.rgb,
                         g.sh_degree)


def open_path(path: Path, fmt: str = "splats") -> GaussianCloud:
    """Open a splat file: PLY (INRIA, nerfstudio's export, SuperSplat compressed), SPZ,
    antimatter15 ``.splat``, ``.ksplat`` or PlayCanvas SOG (see :mod:`.formats`)."""
    import gsply

    if splat_formats.is_sog(path):
        return _cloud(path, splat_formats.decode_sog(path))
    suffix = path.suffix.lower()
    if suffix == ".splat":
        return _cloud(path, splat_formats.decode_splat(path))
    if suffix == ".ksplat":
        return _cloud(path, splat_formats.decode_ksplat(path))
    with open(path, "rb") as f:
        head = f.read(4)
    spz_like = head[:2] == b"\x1f\x8b" or head == b"NGSP"
    if suffix == ".spz" or (head[:3] != b"ply" and spz_like):
        return _cloud(path, splat_formats.decode_spz(path))  # also an SPZ named .ply
    if head[:3] != b"ply":
        what = "is empty" if not head else "does not start with the line 'ply'"
        raise DreamPrintError(f"not a PLY file: it {what} (a splat PLY starts with 'ply', "
                              "then its header)", path)
    _fmt, elements = _ply_header(path)
    if any(name == "chunk" for name, _, _ in elements):
        try:
            data = gsply.plyread(path)
        except Exception as exc:  # noqa: BLE001
            raise DreamPrintError(f"cannot read compressed splat PLY: {exc}", path) from None
        return _from_gsply(path, "splats (SuperSplat compressed PLY)", data)
    return _read_inria(path)
