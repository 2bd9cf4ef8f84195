"""OpenVDB ``.vdb`` fog volumes (and level sets on request), sampled sparsely.

Defines :class:`VdbSource`, :func:`open_path`, :func:`inspect_path` and :func:`check_header`.

The file is read in process by :mod:`.vdb_file` (a reader written to OpenVDB's published file
format: Python + numpy, blosc through imagecodecs, zip through zlib; no system package). The
grids we need become 8^3 blocks (:meth:`.vdb_file.VdbGrid.blocks`: leaves and tiles of every
level, over the 128^3 chunks of the grid's active box, blocks equal to the background left
out), sampled by the compiled sparse trilinear sampler (:mod:`.sampling`); a print job
densifies a fog volume over its blocks when that fits (:mod:`.leaf_grid`, bit-identical and
~10-100x faster), else samples the blocks.

Semantics follow OpenVDB: voxel (i, j, k) holds its value at world ``M (i, j, k)`` (the grid's
linear transform), interpolation is trilinear in index space (``BoxSampler``), voxels outside
every leaf read as the background.  Density: the fog volume's value per source unit (the rule
of :mod:`.base`).  Colour: a vec3 grid (``Cd``, ``color``, ``colour``, ``rgb``) or three
scalar grids ``color_r/g/b`` (``Cd_r``...), scene-linear as Houdini and Blender write them
(``colour_encoding="srgb"`` to override), else one uniform colour.  A level set (signed
distance) is refused, or read as a solid or a hollow shell (``level_set="solid"`` /
``"shell"``, :mod:`.level_set`).

Reference: OpenVDB file format and grid classes (openvdb.org/documentation/doxygen, "OpenVDB
Overview", "Grid classes"); Museth, "VDB", ACM TOG 32(3), 2013.
"""

from __future__ import annotations

import threading
from pathlib import Path

import numpy as np

from dreamprint_gui.core.errors import DreamPrintError
from dreamprint_gui.io.volumes.base import (
    PrintGrid,
    SlabBuffers,
    check_slab,
    linear_to_srgb_inplace,
    uniform_rgb,
    voxel_centres,
)
from dreamprint_gui.io.volumes.sampling import SparseBlocks, sample_sparse
from dreamprint_gui.io.volumes.vdb.leaf_grid import (
    LeafGridPlan,
    densify,
    index_axis,
    leaf_grid_values,
)
from dreamprint_gui.io.volumes.vdb.level_set import (
    GRID_ADVICE,
    LEVEL_SET_ADVICE,
    check_level_set_options,
    check_shell,
    level_set_density,
)
from dreamprint_gui.io.volumes.vdb.vdb_file import VdbError, VdbGrid, read_file, read_grid

__all__ = ["VdbSource", "open_path", "inspect_path", "check_header"]

# Values (all grids of a source together, 512 MB of float32) densified for sample_slab.
DENSE_BUDGET = 1 << 27
COLOUR_VEC = ("Cd", "color", "colour", "Color", "rgb", "albedo")
COLOUR_RGB = (("color_r", "color_g", "color_b"), ("Cd_r", "Cd_g", "Cd_b"),
              ("colour_r", "colour_g", "colour_b"), ("r", "g", "b"))


def _memory_limit() -> int:
    """Bytes the extracted blocks of one grid may take (80 % of the machine's memory)."""
    try:
        import psutil
        return int(psutil.virtual_memory().total * 0.8)
    except Exception:  # noqa: BLE001
        return 16 << 30


_MAGIC = 0x56444220
_MIN_VERSION = 222          # OPENVDB_FILE_VERSION_NODE_MASK_COMPRESSION: older files are refused
_MAX_VERSION = 225          # OPENVDB_FILE_VERSION_HALF_GRID: newer files are refused
_MAX_ENTRIES = 1_000_000


class _Header:
    """Bounds-checked little-endian reads of a .vdb's header, through a window of the file
    (grid descriptors lie after each grid's data: the reads jump over the grids)."""

    def __init__(self, path: Path, data: bytes, size: int) -> None:
        self.path, self.data, self.size, self.pos = path, data, size, 0
        self.base = 0  # file offset of data[0]

    def fail(self, what: str):
        raise DreamPrintError(what, self.path)

    def take(self, n: int, what: str) -> bytes:
        lo = self.pos - self.base
        if lo < 0 or lo + n > len(self.data):
            if self.pos + n <= self.size:  # not in the window: read the file from pos on
                with open(self.path, "rb") as f:
                    f.seek(self.pos)
                    self.data = f.read(max(n, 1 << 16))
                self.base = self.pos
                lo = 0
            if lo + n > len(self.data):
                self.fail(f"truncated: {what} needs bytes {self.pos:,}..{self.pos + n:,}, the "
                          f"file has {self.size:,}")
        out = self.data[lo:lo + n]
        self.pos += n
        return out

    def u32(self, what: str) -> int:
        return int.from_bytes(self.take(4, what), "little")

    def i32(self, what: str) -> int:
        return int.from_bytes(self.take(4, what), "little", signed=True)

    def i64(self, what: str) -> int:
        return int.from_bytes(self.take(8, what), "little", signed=True)

    def string(self, what: str) -> str:
        n = self.u32(what)
        if n > self.size:
            self.fail(f"damaged: {what} claims {n:,} bytes, the file has {self.size:,}")
        return self.take(n, what).decode("utf-8", "replace")


def check_header(path: Path) -> dict:
    """Check a .vdb's header and grid descriptors (OpenVDB file format, ``io/Archive.cc``
    ``readHeader`` and ``io/File.cc`` ``readGridDescriptors``) before its grids are read.

    Layout: int64 magic 0x56444220, uint32 file version, uint32 library major and minor, char
    "has grid offsets", (char "compressed" for file versions 220-221), a 36-character UUID; then
    (with grid offsets) the file metadata (int32 count; per entry name, type name, uint32
    size + value), int32 grid count and per grid a descriptor (unique name, type name, instance
    parent name from version 216, int64 grid, block and end positions; the next descriptor
    starts at the end position). Strings are uint32 length + bytes. Raises a
    :class:`DreamPrintError` for an empty file, a bad magic, an old version, or a file shorter
    than its header or its descriptors announce; returns the header's fields."""
    try:
        size = path.stat().st_size
        with open(path, "rb") as f:
            head = f.read(1 << 16)
    except OSError as exc:
        raise DreamPrintError(f"cannot read: {exc.strerror or exc}", path) from None
    if size == 0:
        raise DreamPrintError("empty file", path)
    h = _Header(path, head, size)
    magic = h.i64("the magic number")
    if magic != _MAGIC:
        h.fail(f"not an OpenVDB file (magic {magic & 0xFFFFFFFFFFFFFFFF:#x}, expected "
               f"{_MAGIC:#x})")
    version = h.u32("the file version")
    if version < _MIN_VERSION:
        h.fail(f"OpenVDB file format version {version} is older than {_MIN_VERSION} (OpenVDB "
               "before 2.0): re-save it with a current OpenVDB")
    if version > _MAX_VERSION:
        h.fail(f"OpenVDB file format version {version} is newer than {_MAX_VERSION}, the newest "
               "this reader knows (written by a newer OpenVDB)")
    lib = (h.u32("the library version"), h.u32("the library version"))
    offsets = h.take(1, "the grid-offsets flag") != b"\x00"
    h.take(36, "the file UUID")
    out = {"file_version": version, "library_version": list(lib), "grids": []}
    if not offsets:
        h.fail("written as a stream without grid offsets, which this reader does not read "
               "(save it as a file)")
    n_meta = h.i32("the file metadata count")
    if not 0 <= n_meta <= _MAX_ENTRIES:
        h.fail(f"damaged: the header claims {n_meta:,} metadata entries")
    for _ in range(n_meta):
        h.string("a metadata name")
        h.string("a metadata type")
        n = h.u32("a metadata value")
        if h.pos + n > size:
            h.fail(f"truncated: a metadata value needs bytes {h.pos:,}..{h.pos + n:,}, the file "
                   f"has {size:,}")
        h.take(n, "a metadata value")
    n_grids = h.i32("the grid count")
    if not 0 <= n_grids <= _MAX_ENTRIES:
        h.fail(f"damaged: the header claims {n_grids:,} grids")
    for k in range(n_grids):
        name = h.string(f"grid descriptor {k + 1} of {n_grids}").split("\x1e")[0]
        gtype = h.string(f"the type of grid {name!r}")
        parent = h.string(f"the instance parent of grid {name!r}")
        grid_pos = h.i64(f"the offsets of grid {name!r}")
        block_pos = h.i64(f"the offsets of grid {name!r}")
        end_pos = h.i64(f"the offsets of grid {name!r}")
        if parent:                        # an instance has no blocks (block offset 0)
            block_pos = grid_pos
        if not (0 < grid_pos <= block_pos <= end_pos):
            h.fail(f"damaged: grid {name!r} has inconsistent offsets {grid_pos}, {block_pos}, "
                   f"{end_pos}")
        if end_pos > size:
            h.fail(f"truncated: grid {name!r} ends at byte {end_pos:,}, the file has "
                   f"{size:,}")
        out["grids"].append({"name": name, "type": gtype, "end": end_pos})
        h.pos = end_pos
    return out


# ---------------------------------------------------------------------------- reading
def _grid_info(g: VdbGrid) -> dict:
    """The description of one grid read by :mod:`.vdb_file` (the fields the former helper
    process gave: class, value type, active voxels, index bbox, range, transform...)."""
    st = g.stats()
    vals = st["active_values"]
    count = st["active_voxels"]
    lo = hi = None
    vec = None
    if g.channels == 1:
        v = vals[:, 0]
        lo, hi = (v.min().item(), v.max().item()) if len(v) else (0.0, 0.0)
    elif len(vals):
        x = vals.astype(np.float64)
        m = np.sqrt(np.sum(x * x, axis=1))
        vec = {"component_min": x.min(axis=0).tolist(), "component_max": x.max(axis=0).tolist(),
               "magnitude": [float(m.min()), float(m.max())]}
        lo, hi = vec["component_min"], vec["component_max"]
    bg = g.background.tolist()
    meta = {k: v for k, v in g.metadata.items() if isinstance(v, (int, float, str, bool))}
    return {"name": g.name, "class": g.grid_class, "type": g.value_type, "vector": vec,
            "active_voxels": count, "empty": count == 0, "bbox": st["bbox"], "min": lo,
            "max": hi, "background": bg[0] if len(bg) == 1 else bg, "half": g.half,
            "transform": g.transform, "metadata": meta}


def _read(path: Path, tree_for=None) -> tuple[dict, dict[str, VdbGrid]]:
    """({"grids": [per-grid description], "metadata": file metadata}, {name: VdbGrid}) of
    a .vdb, every grid read (a grid this reader cannot take, say of an unknown type, is
    described with ``unsupported`` and its reason); damaged data raises a DreamPrintError
    naming the file and the grid. Grids in the order of their unique names (OpenVDB's)."""
    check_header(path)
    try:
        vf = read_file(path)
        infos, grids = [], {}
        for gd in sorted(vf.grids, key=lambda d: d.unique_name):
            try:
                g = read_grid(vf, gd)
            except VdbError as exc:
                if not exc.unsupported:
                    raise
                infos.append({"name": gd.name, "class": "unsupported", "type": gd.tree_type,
                              "unsupported": exc.reason, "empty": True})
                continue
            infos.append(_grid_info(g))
            grids.setdefault(g.name, g)
    except VdbError as exc:
        raise DreamPrintError(str(exc), path) from None
    file_meta = {k: v for k, v in vf.metadata.items() if isinstance(v, (int, float, str, bool))}
    return {"grids": infos, "metadata": file_meta}, grids


def _affine(t: dict, name: str, path: Path) -> tuple[np.ndarray, np.ndarray]:
    cols = np.asarray(t["columns"], float)      # rows: world offset of one index step along i/j/k
    if not t.get("linear", True) or not np.allclose(cols - np.diag(np.diag(cols)), 0,
                                                     atol=1e-9 * np.abs(cols).max()):
        raise DreamPrintError(f"grid {name!r} has a rotated or frustum transform; DreamPrint "
                              "samples axis-aligned grids (resample it in Houdini/Blender)", path)
    scale = np.diag(cols).copy()
    if np.any(scale <= 0):
        raise DreamPrintError(f"grid {name!r} has a mirrored or degenerate voxel size", path)
    return np.asarray(t["origin"], float), scale


def _class_name(g: dict) -> str:
    c = g["class"].lower()
    if "level" in c:
        return "level set"
    if "fog" in c:
        return "fog volume"
    return c or "unknown"


def _info_entry(g: dict, path: Path) -> dict:
    if "unsupported" in g:
        return {"name": g["name"], "class": f"unsupported ({g['unsupported']})",
                "shape": [], "active_voxels": None, "dtype": g["type"], "bounds": None,
                "index_bounds": None}
    lo_i, hi_i = np.asarray(g["bbox"][0], float), np.asarray(g["bbox"][1], float)
    try:
        o, s = _affine(g["transform"], g["name"], path)
        bounds = [list(o + (lo_i - 0.5) * s), list(o + (hi_i + 0.5) * s)] \
            if not g["empty"] else None
    except DreamPrintError:
        bounds = None
    shape = [int(v) for v in (hi_i - lo_i + 1)] if not g["empty"] else [0, 0, 0]
    dtype = g["type"] + (" (half on disk)" if g.get("half") else "")
    lo, hi = g["min"], g["max"]
    out = {}
    if isinstance(lo, (list, tuple)):
        # OpenVDB's evalMinMax orders vectors lexicographically, which is no range at all: the
        # reader gives per-component and magnitude ranges of the active values instead.
        lo = hi = None
        vec = g.get("vector")
        if vec:
            lo, hi = vec["component_min"], vec["component_max"]
            out["magnitude"] = vec["magnitude"]
    index = None if g["empty"] else [[int(v) for v in lo_i], [int(v) for v in hi_i]]
    return {"name": g["name"], "class": _class_name(g), "shape": shape,
            "active_voxels": g["active_voxels"], "min": lo, "max": hi,
            "dtype": dtype, "bounds": bounds, "index_bounds": index, **out}


def inspect_path(path: Path) -> dict:
    """Per-grid description of a .vdb file (the ``inspect`` JSON)."""
    res, _ = _read(path)
    return {"format": "OpenVDB", "grids": [_info_entry(g, path) for g in res["grids"]]}


class _Grid:
    """One grid's sparse blocks (:meth:`.vdb_file.VdbGrid.blocks` over its active box) + its
    index-to-world map."""

    def __init__(self, meta: dict, grid: VdbGrid, path: Path):
        self.name = meta["name"]
        self.origin, self.scale = _affine(meta["transform"], self.name, path)
        nc = grid.channels
        if meta["empty"]:
            origins = np.zeros((0, 3), np.int32)
            values = np.zeros((0, 8, 8, 8, nc), np.float32)
        else:
            try:
                origins, values = grid.blocks(*meta["bbox"], max_bytes=_memory_limit())
            except VdbError as exc:
                raise DreamPrintError(str(exc), path) from None
        bg = np.asarray(meta["background"], np.float32)
        self.blocks = SparseBlocks(origins, values, bg, self.name)

        self._dense = None

    def dense_values(self) -> int:
        """How many values a dense copy of the leaves' box would hold (0: no leaves)."""
        o = self.blocks.origins
        if len(o) == 0:
            return 0
        return int(np.prod(o.max(axis=0) - o.min(axis=0) + 10)) * self.blocks.nc

    def make_dense(self) -> None:
        b = self.blocks
        self._dense = densify(b.origins, b.values, b.background, channels=True,
                              limit=DENSE_BUDGET)

    def sample(self, grid: PrintGrid, z0: int, z1: int) -> np.ndarray:
        """Trilinear values (L, ny, nx, C): from a dense copy of the leaves when it fits
        (:func:`.leaf_grid.leaf_grid_values`, made on first use), else from the leaves; the
        same bits either way."""
        u = [(voxel_centres(grid, a, *((z0, z1) if a == 2 else (0, None))) - self.origin[a])
             / self.scale[a] for a in range(3)]
        if self._dense is None:
            return sample_sparse(self.blocks, u[2], u[1], u[0])
        dense, lo, rows = self._dense
        k0, wk = index_axis(u[2], lo[2])
        j0, wj = index_axis(u[1], lo[1])
        i0, wi = index_axis(u[0], lo[0])
        out = np.empty((len(k0), len(j0), len(i0), dense.shape[3]), np.float32)
        plane = np.empty((dense.shape[3], dense.shape[2]), np.float32)
        leaf_grid_values(dense, rows, k0, wk, j0, wj, i0, wi, plane, out)
        return out


class VdbSource:
    """A fog volume (or solidified level set) from a .vdb file, with optional colour grids."""

    def __init__(self, path: Path, density_grid: str, colour_grids: list[str], info: dict,
                 grids_meta: list[dict], grids: dict[str, VdbGrid], *,
                 colour=(1.0, 1.0, 1.0), level_set: str = "refuse",
                 solid_density: float = 1.0, colour_encoding: str = "linear",
                 shell_voxels: float = 1.0):
        self.name = str(path)
        self.format = "OpenVDB"
        self._info = info
        self.colour_encoding = colour_encoding
        self.uniform_colour = np.asarray(colour, np.float32)
        self.level_set = level_set
        self.solid_density = float(solid_density)
        self.shell_voxels = float(shell_voxels)
        names = [density_grid, *colour_grids]
        by_name = {}
        for m in grids_meta:
            by_name.setdefault(m["name"], m)
        metas = [by_name[n] for n in names]
        made = [_Grid(m, grids[m["name"]], path) for m in metas]
        self.density = made[0]
        self.colour_grids = made[1:]
        self.is_level_set = _class_name(metas[0]) == "level set"
        d = metas[0]
        lo_i, hi_i = np.asarray(d["bbox"][0], float), np.asarray(d["bbox"][1], float)
        o, s = self.density.origin, self.density.scale
        self.bounds = (tuple(float(v) for v in o + (lo_i - 0.5) * s),
                       tuple(float(v) for v in o + (hi_i + 0.5) * s))
        self.voxel_size = float(np.min(s))
        self._leaf_plan = LeafGridPlan(self.density.blocks, o, s)
        self._dense_tried = False
        self._dense_lock = threading.Lock()

    def _densify(self) -> None:
        """Dense copies of every grid's leaves for :meth:`sample_slab` when together they fit
        :data:`DENSE_BUDGET` values (made once; the same samples, ~10x faster)."""
        with self._dense_lock:            # worker threads share the source: one copy
            if self._dense_tried:
                return
            grids = [self.density, *self.colour_grids]
            if sum(g.dense_values() for g in grids) <= DENSE_BUDGET:
                for g in grids:
                    g.make_dense()
            self._dense_tried = True

    # A fog volume is sampled and labelled a layer at a time from a dense copy of its leaves
    # (job.sample_label.leaf_grid_job), bit-identical to sample_slab: with its one uniform
    # colour ("leaf_grid") or with a vec3 colour grid densified the same way
    # ("leaf_grid_colour").
    @property
    def layer_kind(self) -> str:
        return "leaf_grid_colour" if self.colour_grids else "leaf_grid"

    def _colour_dense(self):
        """The densified copy of the one vec3 colour grid (made once), or None if the source
        has another layout of colour grids or the copy would exceed :data:`DENSE_BUDGET`."""
        if len(self.colour_grids) != 1 or self.colour_grids[0].blocks.nc != 3:
            return None
        g = self.colour_grids[0]
        with self._dense_lock:
            if g._dense is None and 0 < g.dense_values() <= DENSE_BUDGET:
                g.make_dense()
        return g._dense

    def layer_plan(self, grid: PrintGrid, z0: int, z1: int, *, density_scale: float = 1.0
                   ) -> tuple | None:
        """The arguments of :func:`...job.sample_label.leaf_grid_job.leaf_grid_slab_labels`
        (uniform colour) or ``leaf_grid_colour_slab_labels`` (one vec3 colour grid) before
        their layer arrays (:class:`.leaf_grid.LeafGridPlan`), or None: a level set, three
        scalar colour grids or grids too large to densify take :meth:`sample_slab`."""
        check_slab(grid, z0, z1)
        if self.is_level_set:
            return None
        if not self.colour_grids:
            return self._leaf_plan.args(grid, z0, z1, density_scale, self.uniform_colour)
        colour = self._colour_dense()
        plan = None if colour is None else self._leaf_plan.args(grid, z0, z1, density_scale,
                                                                 self.uniform_colour)
        if plan is None:
            return None
        cdense, lo, rows = colour
        g = self.colour_grids[0]
        u = [(voxel_centres(grid, a, *((z0, z1) if a == 2 else (0, None))) - g.origin[a])
             / g.scale[a] for a in range(3)]
        k0, wk = index_axis(u[2], lo[2])
        j0, wj = index_axis(u[1], lo[1])
        i0, wi = index_axis(u[0], lo[0])
        return (*plan[:-1], cdense, rows, k0, wk, j0, wj, i0, wi,
                np.empty((3, cdense.shape[2]), np.float32), self.colour_encoding == "linear")

    def close(self) -> None:
        """Nothing to release: the blocks are in memory, freed with the source."""

    def sample_slab(self, grid: PrintGrid, z0: int, z1: int, *, density_scale: float = 1.0,
                    out: SlabBuffers | None = None):
        check_slab(grid, z0, z1)
        self._densify()
        d = self.density.sample(grid, z0, z1)[..., 0]
        if self.is_level_set:
            d = level_set_density(d, self.voxel_size, self.solid_density, self.level_set,
                                  self.shell_voxels)
        sigma = np.maximum(d, 0.0)
        sigma *= np.float32(density_scale / grid.mm_per_unit)
        if len(self.colour_grids) == 1:
            rgb = self.colour_grids[0].sample(grid, z0, z1)
        elif len(self.colour_grids) == 3:
            rgb = np.concatenate([g.sample(grid, z0, z1) for g in self.colour_grids], axis=-1)
        else:
            return uniform_rgb(d.shape, self.uniform_colour), sigma.astype(np.float32)
        if self.colour_encoding == "linear":
            rgb = linear_to_srgb_inplace(np.ascontiguousarray(rgb, np.float32))
        else:
            np.clip(rgb, 0.0, 1.0, out=rgb)
        return rgb, sigma.astype(np.float32)

    def info(self) -> dict:
        return self._info


def open_path(path: Path, fmt: str = "openvdb", *, density_grid: str | None = None,
              colour_grid: str | None = None, colour=(1.0, 1.0, 1.0), level_set: str = "refuse",
              solid_density: float = 1.0, colour_encoding: str = "linear",
              shell_voxels: float = 1.0) -> VdbSource:
    """Open a .vdb: ``density_grid`` (default ``density``, else the only float fog volume),
    ``colour_grid`` (a vec3 grid name; default: found by name), ``level_set`` "refuse",
    "solid" or "shell" (with ``solid_density`` per source unit; a shell ``shell_voxels`` of
    the file's voxels thick)."""
    check_level_set_options(level_set, shell_voxels, path)
    res, read = _read(path)
    grids = {}
    for g in res["grids"]:
        grids.setdefault(g["name"], g)
    info = {"format": "OpenVDB", "grids": [_info_entry(g, path) for g in res["grids"]]}
    if res["metadata"]:
        info["metadata"] = dict(res["metadata"])  # the writer (creator), an up axis: orient.py
    if not grids:
        raise DreamPrintError("the file holds no grids", path)
    scalar = [g for g in res["grids"] if g["type"] in ("float", "double", "half")]
    if density_grid is None:
        if "density" in grids:
            density_grid = "density"
        else:
            fog = [g for g in scalar if _class_name(g) == "fog volume"]
            pool = fog or ([g for g in scalar if _class_name(g) == "level set"]
                           if level_set != "refuse" else [])
            if not pool and any(_class_name(g) == "level set" for g in scalar):
                raise DreamPrintError("the file holds a level set, not a fog volume: "
                                      + LEVEL_SET_ADVICE, path)
            if len(pool) != 1:
                raise DreamPrintError("no grid named 'density'; choose one of: "
                                      f"{', '.join(grids)} ({GRID_ADVICE})", path)
            density_grid = pool[0]["name"]
    if density_grid not in grids:
        raise DreamPrintError(f"no grid named {density_grid!r} (has: {', '.join(grids)})", path)
    g = grids[density_grid]
    if "unsupported" in g:
        raise DreamPrintError(f"grid {density_grid!r}: {g['unsupported']}", path)
    if g["type"] not in ("float", "double", "half"):
        raise DreamPrintError(f"grid {density_grid!r} holds {g['type']} values, not a scalar "
                              "density", path)
    if _class_name(g) == "level set" or (density_grid.startswith("ls_")
                                         and level_set == "refuse"
                                         and _class_name(g) != "fog volume"):
        if level_set == "refuse":
            raise DreamPrintError(f"grid {density_grid!r} is a level set, not a fog volume: "
                                  + LEVEL_SET_ADVICE, path)
        check_shell(level_set, shell_voxels, abs(float(np.ravel(g["background"])[0])),
                    float(np.min(_affine(g["transform"], density_grid, path)[1])),
                    density_grid, path)
    if g["empty"]:
        raise DreamPrintError(f"grid {density_grid!r} is empty (no active voxels)", path)
    colour_grids: list[str] = []
    if colour_grid is not None:
        if colour_grid not in grids:
            raise DreamPrintError(f"no colour grid named {colour_grid!r}", path)
        if "unsupported" in grids[colour_grid]:
            raise DreamPrintError(f"grid {colour_grid!r}: {grids[colour_grid]['unsupported']}",
                                  path)
        if not grids[colour_grid]["type"].startswith("vec3"):
            raise DreamPrintError(f"grid {colour_grid!r} is not a vec3 colour grid", path)
        colour_grids = [colour_grid]
    else:
        vec = [n for n in COLOUR_VEC if n in grids and grids[n]["type"].startswith("vec3")
               and not grids[n]["empty"]]
        trip = [t for t in COLOUR_RGB if all(n in grids and not grids[n]["empty"] for n in t)]
        if vec:
            colour_grids = [vec[0]]
        elif trip:
            colour_grids = list(trip[0])
    return VdbSource(path, density_grid, colour_grids, info, res["grids"], read, colour=colour,
                     level_set=level_set, solid_density=solid_density,
                     colour_encoding=colour_encoding, shell_voxels=shell_voxels)
