"""Orientation and fitted bounds of a source: which source axis becomes the print's up, a turn
about the print's z, and the object's occupied bounds.

Defines
-------
- :data:`UP_AXES` (``x``, ``-x``, ``y``, ``-y``, ``z``, ``-z``) and :data:`ROTATIONS` (0, 90,
  180, 270 degrees).
- :func:`orientation_matrix`: the signed permutation ``M`` with ``p = M s`` (print coordinates
  ``p`` of a source point ``s``): first the rotation that takes the source axis ``up`` to +z,
  then a turn of ``rotate`` degrees counter-clockwise about +z (seen from above).
- :class:`Orientation` and :func:`choose_orientation`: the orientation of a job, picked
  automatically (``up=None``) where the source's convention is known (:func:`auto_up`).
- :func:`orient_source`: the source as seen in print coordinates. Gaussian splats are turned
  themselves (means, inverse covariances and extents permuted: the splat rasteriser's speed is
  unchanged); any other source is wrapped in :class:`OrientedSource`, which samples the inner
  source on the matching box of its own axes and transposes the arrays.
- :func:`occupied_bounds`: the object's non-empty bounds (``--fit occupied``).

Why only quarter turns. A signed permutation maps the printer's voxel grid onto an axis-aligned
grid of the source, so every reader samples as it does unturned (a voxel model stays crisp, a
splat keeps its closed-form kernel) and nothing is resampled twice; any other angle would
resample the source on a turned grid. The matrices are proper rotations (determinant +1): an
object is never mirrored.

What the file says comes first (:func:`auto_up`): an OpenVDB file's metadata (an ``up_axis``
entry, or the ``creator`` its writer states: Houdini and Maya scenes are y-up, Blender's
z-up), the ``cameras.json`` 3D Gaussian Splatting writes beside a splat PLY (the cameras' mean
up), the writer's convention (a MagicaVoxel model is z-up, as the built-in demo is). Otherwise
a guess, said to be one: the object stood as it would rest, on its largest flat side, else on
its longest axis (:mod:`.stand`, the resting-side rule), and where neither applies a convention
of the kind: the INRIA 3D Gaussian Splatting
PLY and the formats made from it (SuperSplat compressed PLY, antimatter15 ``.splat``,
``.ksplat``, PlayCanvas SOG) keep COLMAP's camera-derived world frame, y down (RDF: right,
down, front): up = -y. Niantic SPZ stores RUB
(right, up, back; the ``spz`` library converts PLY's RDF on writing): up = +y. An InstantNGP
snapshot's source units are its ``transforms.json`` coordinates, z up (the NeRF synthetic scenes,
and ``colmap2nerf.py`` turns the scene's up to +z): up = z. Every other kind: the file's z.
A COLMAP frame is "y down" only as far as its first camera was level; ``--up`` overrides.
"""

from __future__ import annotations

import copy
import math
import threading
from dataclasses import dataclass
from typing import Any

import numpy as np
from numba import njit

from dreamprint_gui.core.errors import DreamPrintError
from dreamprint_gui.io.volumes.base import PrintGrid, SlabBuffers, occupied_ranges
from dreamprint_gui.io.volumes.stand import resting_up

__all__ = ["UP_AXES", "ROTATIONS", "FIT_MODES", "orientation_matrix", "Orientation",
           "auto_up", "choose_orientation", "orient_source", "OrientedSource",
           "occupied_bounds", "parse_rotate"]

UP_AXES = ("x", "-x", "y", "-y", "z", "-z")
ROTATIONS = (0, 90, 180, 270)
FIT_MODES = ("occupied", "box")

# The rotation taking source axis ``up`` to +z (rows: print x, y, z in source coordinates).
_UP = {
    "z": ((1, 0, 0), (0, 1, 0), (0, 0, 1)),
    "-z": ((1, 0, 0), (0, -1, 0), (0, 0, -1)),    # half a turn about x
    "y": ((1, 0, 0), (0, 0, -1), (0, 1, 0)),      # a quarter turn about x
    "-y": ((1, 0, 0), (0, 0, 1), (0, -1, 0)),
    "x": ((0, 0, -1), (0, 1, 0), (1, 0, 0)),      # a quarter turn about y
    "-x": ((0, 0, 1), (0, 1, 0), (-1, 0, 0)),
}


def parse_rotate(value: Any) -> int:
    """``--rotate`` as 0, 90, 180 or 270 (any multiple of 90, negative too); else an error."""
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise DreamPrintError(f"--rotate must be a number of degrees (0, 90, 180, 270), "
                              f"got {value!r}") from None
    if not math.isfinite(v) or v % 90 != 0:
        raise DreamPrintError(f"--rotate must be a multiple of 90 degrees, got {value}: "
                              "quarter turns keep the source's own sampling (docs/print-jobs.md,"
                              " \"Orientation\")")
    return int(v) % 360


def orientation_matrix(up: str, rotate: int = 0) -> np.ndarray:
    """(3, 3) int ``M`` with ``p = M s``: source axis ``up`` -> +z, then ``rotate`` degrees
    counter-clockwise about +z."""
    if up not in _UP:
        raise DreamPrintError(f"--up must be one of {', '.join(UP_AXES)}, got {up!r}")
    k = parse_rotate(rotate) // 90
    turn = np.array(((0, -1, 0), (1, 0, 0), (0, 0, 1)), np.int64)   # 90 degrees about z
    m = np.array(_UP[up], np.int64)
    for _ in range(k):
        m = turn @ m
    return m


# OpenVDB writers that state themselves (file metadata ``creator``) and their scenes' up axis
_VDB_WRITERS = (("houdini", "y", "Houdini"), ("maya", "y", "Maya"),
                ("blender", "z", "Blender"), ("kamikaze", "z", "Blender (Kamikaze)"))
_UP_WORDS = {"x": "x", "+x": "x", "-x": "-x", "y": "y", "+y": "y", "-y": "-y", "z": "z",
             "+z": "z", "-z": "-z"}


def _stated_up(meta: dict) -> tuple[str, str] | None:
    """(up, reason) from a volume file's metadata: an explicit up axis (``up_axis``,
    ``upAxis``, ``up``: x, y or z, signed or not), else the writer (``creator``) of a known
    convention."""
    for key, value in meta.items():
        if str(key).replace("_", "").lower() in ("upaxis", "up") and \
                str(value).strip().lower() in _UP_WORDS:
            return _UP_WORDS[str(value).strip().lower()], f"the file's {key} says {value}"
    creator = str(meta.get("creator", ""))
    for word, up, name in _VDB_WRITERS:
        if word in creator.lower():
            return up, f"written by {name}, whose scenes are {up.lstrip('-')}-up"
    return None


def _cameras_up(path: str) -> tuple[str, str] | None:
    """(up, reason) from the ``cameras.json`` 3D Gaussian Splatting writes beside its output
    (``<model>/cameras.json`` for ``<model>/point_cloud/iteration_N/point_cloud.ply``): each
    entry's ``rotation`` is the camera-to-world rotation of an OpenCV/COLMAP camera (x right,
    y down), so its up in the world is ``-rotation[:, 1]``; the signed axis nearest their mean
    is up, when the cameras agree (mean length >= 0.5)."""
    import json
    from pathlib import Path

    p = Path(path)
    for folder in (p.parent, p.parent.parent, p.parent.parent.parent):
        f = folder / "cameras.json"
        if not f.is_file():
            continue
        try:
            cams = json.loads(f.read_text(encoding="utf-8"))
            rots = np.array([c["rotation"] for c in cams], dtype=np.float64)
        except (OSError, ValueError, KeyError, TypeError):
            return None
        if rots.ndim != 3 or rots.shape[1:] != (3, 3) or not len(rots):
            return None
        up = -rots[:, :, 1].mean(axis=0)
        if not np.all(np.isfinite(up)) or np.linalg.norm(up) < 0.5:
            return None
        a = int(np.argmax(np.abs(up)))
        axis = ("-" if up[a] < 0 else "") + "xyz"[a]
        return axis, f"the {len(rots)} cameras of {f.name} beside it look {axis}-up"
    return None


def auto_up(source) -> tuple[str, str, bool]:
    """(up, reason, guessed): what the file says (an OpenVDB file's metadata: its up axis or a
    writer of known convention; the cameras beside a 3DGS splat file; a MagicaVoxel model and
    the demo are z-up), else the resting-side rule (:func:`.stand.resting_up`: its largest
    flat side down, else its longest axis up), else the convention of its kind (module doc) or
    the file's z; ``guessed`` unless the file or its writer said."""
    fmt = str(getattr(source, "format", ""))
    low = fmt.lower()
    info = {}
    try:
        info = source.info() if hasattr(source, "info") else {}
    except Exception:  # noqa: BLE001 - a description is optional here
        info = {}
    stated = _stated_up(info.get("metadata") or {}) if isinstance(info, dict) else None
    if stated is not None:
        return stated[0], stated[1], False
    name = str(getattr(source, "name", ""))
    if low.startswith("demo"):
        return "z", "the built-in demo is made z-up", False
    if low == "magicavoxel":
        return "z", "MagicaVoxel models are z-up", False
    silent = "the file does not say"
    if "spz" in low:
        convention = "y", "SPZ's RUB frame, y up"
    elif low.startswith("splats") or hasattr(source, "n_total"):
        cams = _cameras_up(name) if name else None
        if cams is not None:
            return cams[0], cams[1], False
        silent = "no cameras.json beside it"
        convention = "-y", "COLMAP's frame, y down, as its first camera stood"
    elif "instantngp" in low:
        convention = "z", "transforms.json's frame, z up"
    else:
        convention = "z", "its z kept"
    rest = resting_up(source, convention[0])
    if rest is not None:
        return rest[0], f"{silent}; {rest[1]}", True
    return convention[0], f"{silent}; no flat side or long axis, so {convention[1]}", True


@dataclass(frozen=True)
class Orientation:
    """``up`` (source axis that becomes +z), ``rotate`` (degrees about +z), whether the up
    axis was picked automatically, and why."""

    up: str = "z"
    rotate: int = 0
    auto: bool = False
    reason: str = ""
    guessed: bool = False  # auto, and the file did not say (a convention or the file's z)

    @property
    def matrix(self) -> np.ndarray:
        return orientation_matrix(self.up, self.rotate)

    @property
    def is_identity(self) -> bool:
        return self.up == "z" and self.rotate == 0

    def describe(self) -> str:
        """One line: the up axis, where it came from (a guess says so) and the option that
        changes it."""
        if self.auto:
            how = f"{'a guess' if self.guessed else 'auto'}: {self.reason}; --up changes it"
        else:
            how = "as asked"
        turn = f", turned {self.rotate} degrees about z" if self.rotate else ""
        return f"up = source {self.up} ({how}){turn}"

    def to_json(self) -> dict[str, Any]:
        return {"up": self.up, "rotate_deg": self.rotate, "auto": self.auto,
                "guessed": self.guessed, "reason": self.reason,
                "matrix": self.matrix.tolist()}


def choose_orientation(source, up: str | None = None, rotate: Any = 0) -> Orientation:
    """The job's orientation: ``up`` as given (or None / "auto": :func:`auto_up`)."""
    rot = parse_rotate(rotate)
    if up is None or up == "auto":
        axis, reason, guessed = auto_up(source)
        return Orientation(axis, rot, True, reason, guessed)
    if up not in UP_AXES:
        raise DreamPrintError(f"--up must be auto or one of {', '.join(UP_AXES)}, got {up!r}")
    return Orientation(up, rot, False, "")


def _axes(m: np.ndarray) -> list[tuple[int, int]]:
    """Per print axis b: (source axis a, sign s) with p_b = s * s_a."""
    out = []
    for b in range(3):
        a = int(np.flatnonzero(m[b])[0])
        out.append((a, int(m[b, a])))
    return out


def _turned_bounds(bounds, m: np.ndarray):
    lo = np.asarray(bounds[0], float)
    hi = np.asarray(bounds[1], float)
    plo, phi = [], []
    for a, s in _axes(m):
        v0, v1 = s * lo[a], s * hi[a]
        plo.append(float(min(v0, v1)))
        phi.append(float(max(v0, v1)))
    return (tuple(plo), tuple(phi))


class OrientedSource:
    """``inner`` seen in print coordinates ``p = M s``. A slab of print layers is sampled as
    the matching axis-aligned box of the inner source (one ``sample_slab`` call over its full
    z range), whose arrays are transposed and flipped into print order. Offers no
    ``layer_plan`` (the job takes the general path)."""

    layer_plan = None

    def __init__(self, inner, orientation: Orientation) -> None:
        self.inner = inner
        self.orientation = orientation
        self.m = orientation.matrix
        self.name = inner.name
        self.format = inner.format
        self.colour_encoding = inner.colour_encoding
        self.bounds = _turned_bounds(inner.bounds, self.m)
        # each thread's buffers for the inner source's box (reused slab after slab: a fresh
        # array's page faults cost as much as the transposing copy)
        self._local = threading.local()

    def __getattr__(self, name: str):  # reader attributes (solid_density, volume, ...)
        if name == "inner":
            raise AttributeError(name)
        return getattr(self.inner, name)

    def sample_slab(self, grid: PrintGrid, z0: int, z1: int, *, density_scale: float = 1.0,
                    out: SlabBuffers | None = None):
        if not (0 <= z0 < z1 <= grid.shape_xyz[2]):
            raise ValueError(f"slab {z0}:{z1} outside the grid's {grid.shape_xyz[2]} layers")
        axes = _axes(self.m)
        shape_p = [grid.shape_xyz[0], grid.shape_xyz[1], z1 - z0]
        start = [0, 0, z0]
        n_s = [0, 0, 0]
        vox_s = [0.0, 0.0, 0.0]
        org_s = [0.0, 0.0, 0.0]
        for b, (a, s) in enumerate(axes):
            step = grid.voxel_mm[b] / grid.mm_per_unit
            o = grid.origin[b] + start[b] * step
            n_s[a] = shape_p[b]
            vox_s[a] = grid.voxel_mm[b]
            org_s[a] = o if s > 0 else -(o + shape_p[b] * step)
        inner_grid = PrintGrid(tuple(n_s), tuple(vox_s), tuple(org_s), grid.mm_per_unit)
        buf = getattr(self._local, "buffers", None)
        if buf is None:
            buf = self._local.buffers = SlabBuffers()
        rgb, sigma = self.inner.sample_slab(inner_grid, 0, n_s[2], density_scale=density_scale,
                                            out=buf)
        # array axis of print axis b is 2 - b; it comes from the inner array's axis 2 - a
        perm = [2 - axes[2 - k][0] for k in range(3)]
        sig = np.transpose(sigma, perm)
        col = np.transpose(rgb, perm + [3])
        flip = tuple(slice(None, None, -1) if axes[2 - k][1] < 0 else slice(None)
                     for k in range(3))
        sig = sig[flip]
        col = col[flip]
        if out is not None:
            r_out, s_out = out.take((shape_p[2], shape_p[1], shape_p[0]))
        else:
            r_out = np.empty((shape_p[2], shape_p[1], shape_p[0], 3), np.float32)
            s_out = np.empty((shape_p[2], shape_p[1], shape_p[0]), np.float32)
        if perm == [2, 1, 0]:  # x <-> z: a tiled copy (numpy's gathers along the slow axis)
            _swap_xz_copy(sig, s_out)
            _swap_xz_copy_rgb(col, r_out)
        else:
            np.copyto(s_out, sig)
            np.copyto(r_out, col)
        return r_out, s_out

    def occupied_bounds(self):
        """The inner source's occupied bounds, turned into print coordinates."""
        b = occupied_bounds(self.inner)
        return None if b is None else _turned_bounds(b, self.m)

    def info(self) -> dict:
        return self.inner.info()


@njit(cache=True, nogil=True)
def _swap_xz_copy(view, out):
    """``out[a, b, c] = view[a, b, c]`` where ``view`` is an x <-> z transposed (and possibly
    flipped) view: copied in 16 x 16 tiles of (a, c) so reads and writes both stay in cache."""
    na, nb, nc = out.shape
    for b in range(nb):
        for a0 in range(0, na, 16):
            for c0 in range(0, nc, 16):
                for a in range(a0, min(na, a0 + 16)):
                    for c in range(c0, min(nc, c0 + 16)):
                        out[a, b, c] = view[a, b, c]


@njit(cache=True, nogil=True)
def _swap_xz_copy_rgb(view, out):
    """:func:`_swap_xz_copy` of (a, b, c, 3) colour arrays."""
    na, nb, nc, _ = out.shape
    for b in range(nb):
        for a0 in range(0, na, 16):
            for c0 in range(0, nc, 16):
                for a in range(a0, min(na, a0 + 16)):
                    for c in range(c0, min(nc, c0 + 16)):
                        for k in range(3):
                            out[a, b, c, k] = view[a, b, c, k]


def _turned_gaussians(cloud, m: np.ndarray):
    """A copy of a :class:`.splats.cloud.GaussianCloud` in print coordinates: means ``M mu``,
    inverse covariances ``M Sigma^-1 M^T``, 3-sigma extents permuted."""
    c = copy.copy(cloud)
    axes = _axes(m)
    src = [a for a, _ in axes]
    sgn = np.array([s for _, s in axes], float)
    c.mean = np.ascontiguousarray(cloud.mean[:, src] * sgn)
    c.half = np.ascontiguousarray(cloud.half[:, src])
    # (xx, yy, zz, xy, xz, yz) -> full, permute with signs, back
    ic = cloud.inv_cov
    full = np.empty((len(ic), 3, 3))
    for t, (i, k) in enumerate(((0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2))):
        full[:, i, k] = ic[:, t]
        full[:, k, i] = ic[:, t]
    turned = full[:, src][:, :, src] * (sgn[:, None] * sgn[None, :])
    c.inv_cov = np.ascontiguousarray(np.stack(
        [turned[:, i, k] for i, k in ((0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2))], 1))
    c.index_by_height()
    c.bounds = _turned_bounds(cloud.bounds, m)
    c.orientation = None
    return c


def orient_source(source, orientation: Orientation):
    """``source`` in print coordinates (itself when the orientation is the identity)."""
    if orientation.is_identity:
        return source
    m = orientation.matrix
    if hasattr(source, "inv_cov") and hasattr(source, "_zmin_sorted"):
        turned = _turned_gaussians(source, m)
        turned.orientation = orientation
        return turned
    return OrientedSource(source, orientation)


def occupied_bounds(source, cells: int = 96):
    """The bounds (source units, the source's own frame) of what ``source`` holds: where its
    density is positive. A source may know them exactly (``occupied_bounds()``: a voxel
    model's filled voxels); otherwise the source is sampled on a grid of about ``cells``
    cells along its longest axis over its declared bounds, and the occupied cells' box,
    widened by one cell on each side (a feature between two cell centres is kept), clipped to
    the declared bounds. None if nothing is occupied."""
    exact = getattr(source, "occupied_bounds", None)
    if callable(exact):
        return exact()
    lo = np.asarray(source.bounds[0], float)
    hi = np.asarray(source.bounds[1], float)
    ext = hi - lo
    if not (np.all(np.isfinite(ext)) and ext.max() > 0):
        return source.bounds
    step = float(ext.max()) / cells
    n = [max(1, math.ceil(e / step)) for e in ext]
    cell = [e / k if e > 0 else step for e, k in zip(ext, n, strict=True)]
    grid = PrintGrid(tuple(n), tuple(cell), tuple(lo), 1.0)   # 1 mm per unit: cells in units
    occ = np.zeros((n[2], n[1], n[0]), bool)
    step_z = max(1, 2_000_000 // max(1, n[0] * n[1]))
    for z in range(0, n[2], step_z):
        _, sigma = source.sample_slab(grid, z, min(n[2], z + step_z), density_scale=1.0)
        occ[z:z + step_z] = np.asarray(sigma) > 0
    ranges = occupied_ranges(occ)
    if ranges is None:
        return None
    out_lo, out_hi = [], []
    for a in range(3):
        i0, i1 = max(0, ranges[a][0] - 1), min(n[a], ranges[a][1] + 1)
        out_lo.append(float(lo[a] + i0 * cell[a]) if ext[a] > 0 else float(lo[a]))
        out_hi.append(float(min(hi[a], lo[a] + i1 * cell[a])) if ext[a] > 0 else float(hi[a]))
    return (tuple(out_lo), tuple(out_hi))
