"""NanoVDB ``.nvdb`` float grids (fog volumes; level sets on request), read to the layout of
NanoVDB 32.x (``nanovdb/NanoVDB.h`` and ``nanovdb/util/IO.h``, OpenVDB 10), sampled sparsely.

Defines :func:`read_nvdb`, :func:`inspect_path`, :func:`open_path` and :class:`NanoVdbSource`.

File: segments of ``Header`` (16 B: magic "NanoVDB0", version, grid count u16, codec u16),
one ``MetaData`` (176 B) + name per grid, then each grid's buffer (codec NONE: raw; ZIP: u64
size + zlib stream; BLOSC: chunks of u64 size + blosc frame, <= 1 GiB each).  Grid buffer:
``GridData`` (672 B; map at 296, class/type at 632/636), ``TreeData`` (64 B: byte offsets of
the first leaf/lower/upper/root node and node counts), nodes stored contiguously per level.
Float nodes: leaf 2144 B (origin = bbox min & ~7 at 0, 512 values at 96, x slowest),
lower 33856 B and upper 270400 B (bbox at 0, child mask at 544 / 4128, 8-byte tile table at
1088 / 8256), root 64 B (background at 28) + 32-B tiles.  Tile values that differ from the
background (constant 8^3 / 128^3 regions, e.g. a level set's interior) become leaf blocks.
Only uncompressed float values are read (not the quantised Fp4/8/16/N or half variants);
sampling follows OpenVDB (values at integer index coordinates, trilinear), density per source
unit as in :mod:`.base`.
"""

from __future__ import annotations

import struct
import zlib
from pathlib import Path

import numpy as np

from dreamprint_gui.core.errors import DreamPrintError
from dreamprint_gui.io.volumes.base import (
    PrintGrid,
    SlabBuffers,
    check_slab,
    uniform_rgb,
    voxel_centres,
)
from dreamprint_gui.io.volumes.dense import MAX_EXPANSION
from dreamprint_gui.io.volumes.sampling import SparseBlocks, sample_sparse
from dreamprint_gui.io.volumes.vdb.leaf_grid import LeafGridPlan
from dreamprint_gui.io.volumes.vdb.level_set import (
    GRID_ADVICE,
    LEVEL_SET_ADVICE,
    check_level_set_options,
    check_shell,
    level_set_density,
)

__all__ = ["read_nvdb", "inspect_path", "open_path", "NanoVdbSource"]

MAGIC = b"NanoVDB"
GRID_TYPES = ["unknown", "float", "double", "int16", "int32", "int64", "Vec3f", "Vec3d", "mask",
              "half", "uint32", "bool", "RGBA8", "Fp4", "Fp8", "Fp16", "FpN", "Vec4f", "Vec4d",
              "index"]
GRID_CLASSES = ["unknown", "level set", "fog volume", "staggered", "point index", "point data",
                "topology", "voxel volume", "index grid"]
LEAF, LOWER, UPPER = 2144, 33856, 270400
META = struct.Struct("<4Q2I6d6i3dI4I3IHHI")         # 176 bytes, util/IO.h MetaData


def _fail(msg: str, path: Path):
    raise DreamPrintError(f"damaged NanoVDB file: {msg}", path)


def _read_meta(path: Path) -> list[dict]:
    """Headers and per-grid metadata of every segment (no grid data read)."""
    size = path.stat().st_size
    grids = []
    with open(path, "rb") as f:
        pos = 0
        while pos < size:
            f.seek(pos)
            head = f.read(16)
            if len(head) < 16:
                _fail("truncated segment header", path)
            if head[:7] != MAGIC:
                if pos == 0:
                    raise DreamPrintError("not a NanoVDB file (no NanoVDB magic)", path)
                _fail("bad segment magic", path)
            major = struct.unpack_from("<I", head, 8)[0] >> 21
            count, codec = struct.unpack_from("<HH", head, 12)
            if major != 32:
                raise DreamPrintError(f"NanoVDB major version {major} is not supported (32)",
                                      path)
            if codec > 2:
                _fail(f"unknown codec {codec}", path)
            pos += 16
            metas = []
            for _ in range(count):
                f.seek(pos)
                raw = f.read(META.size)
                if len(raw) < META.size:
                    _fail("truncated grid metadata", path)
                v = META.unpack(raw)
                name_size = v[21]
                if name_size > 1 << 20:
                    _fail("absurd grid name size", path)
                name = f.read(name_size).split(b"\0")[0].decode("utf-8", "replace")
                pos += META.size + name_size
                metas.append({"grid_size": v[0], "file_size": v[1], "voxels": v[3],
                              "type": v[4], "class": v[5], "world_bbox": v[6:12],
                              "index_bbox": v[12:18], "voxel_size": v[18:21], "name": name,
                              "node_count": v[22:26], "codec": codec})
            for m in metas:
                m["offset"] = pos
                if m["file_size"] > size - pos:
                    _fail(f"grid {m['name']!r} runs past the end of the file", path)
                limit = m["file_size"] if codec == 0 else \
                    MAX_EXPANSION * m["file_size"] + (1 << 20)
                if m["grid_size"] > limit or m["grid_size"] < 672 + 64:
                    _fail(f"grid {m['name']!r} claims {m['grid_size']:,} bytes", path)
                pos += m["file_size"]
                grids.append(m)
    return grids


def _grid_buffer(path: Path, m: dict):
    """The grid's in-memory buffer: a read-only memory map (codec NONE) or inflated bytes."""
    if m["codec"] == 0:
        return np.memmap(path, np.uint8, "r", offset=m["offset"], shape=(m["grid_size"],))
    with open(path, "rb") as f:
        f.seek(m["offset"])
        raw = f.read(m["file_size"])
    out = bytearray()
    pos = 0
    try:
        if m["codec"] == 1:                  # ZIP: one size-prefixed zlib stream
            n = struct.unpack_from("<Q", raw, 0)[0]
            d = zlib.decompressobj()
            out += d.decompress(raw[8:8 + n], m["grid_size"] + 1)
            if not d.eof:                    # stream end and its checksum not reached
                _fail(f"grid {m['name']!r}: ZIP stream truncated or corrupt", path)
        else:                                # BLOSC: size-prefixed chunks
            import imagecodecs

            while len(out) < m["grid_size"] and pos + 8 <= len(raw):
                n = struct.unpack_from("<Q", raw, pos)[0]
                out += imagecodecs.blosc_decode(bytes(raw[pos + 8:pos + 8 + n]))
                pos += 8 + n
    except DreamPrintError:
        raise
    except Exception as exc:  # noqa: BLE001 - zlib/blosc errors on damaged data
        _fail(f"cannot decompress grid {m['name']!r} ({exc})", path)
    if len(out) != m["grid_size"]:
        _fail(f"grid {m['name']!r} decompresses to {len(out):,} bytes, not "
              f"{m['grid_size']:,}", path)
    return np.frombuffer(bytes(out), np.uint8)


def _u64(buf, off):
    return int(np.frombuffer(buf, np.uint64, 1, off)[0])


def read_nvdb(path: Path, m: dict):
    """Leaf blocks of float grid ``m``: (origins (L, 3), values (L, 8, 8, 8, 1), background,
    index-to-world (origin xyz, scale xyz), (min, max))."""
    buf = _grid_buffer(path, m)
    n = len(buf)
    if bytes(buf[:7]) != MAGIC:
        _fail(f"grid {m['name']!r} has no grid magic", path)
    _gclass, gtype = struct.unpack_from("<II", bytes(buf[632:640]))
    if gtype != 1:
        kind = GRID_TYPES[gtype] if gtype < len(GRID_TYPES) else gtype
        raise DreamPrintError(f"grid {m['name']!r} holds {kind} values: only uncompressed "
                              "float grids are read", path)
    mat = np.frombuffer(buf, np.float64, 9, 296 + 88).reshape(3, 3)
    vec = np.frombuffer(buf, np.float64, 3, 296 + 232)
    if not np.allclose(mat - np.diag(np.diag(mat)), 0, atol=1e-9 * np.abs(mat).max()) \
            or np.any(np.diag(mat) <= 0):
        raise DreamPrintError(f"grid {m['name']!r} has a rotated or mirrored transform", path)
    tree = 672
    offs = [_u64(buf, tree + 8 * k) for k in range(4)]
    counts = struct.unpack_from("<3I", bytes(buf[tree + 32:tree + 44]))
    for lvl, (size, cnt) in enumerate(zip((LEAF, LOWER, UPPER), counts, strict=True)):
        if cnt and tree + offs[lvl] + size * cnt > n:
            _fail(f"grid {m['name']!r}: level-{lvl} nodes run past the buffer", path)
    if tree + offs[3] + 64 > n:
        _fail(f"grid {m['name']!r}: root node outside the buffer", path)
    root = tree + offs[3]
    bg = np.float32(np.frombuffer(buf, np.float32, 1, root + 28)[0])
    vmin, vmax = (float(v) for v in np.frombuffer(buf, np.float32, 2, root + 32))

    origins = []
    values = []
    if counts[0]:
        leaf_dt = np.dtype({"names": ["origin", "values"], "formats": [("<i4", 3), ("<f4", 512)],
                            "offsets": [0, 96], "itemsize": LEAF})
        leaves = np.frombuffer(buf, leaf_dt, counts[0], tree + offs[0])
        origins.append(leaves["origin"] & ~7)
        values.append(leaves["values"].reshape(-1, 8, 8, 8, 1))
    # constant tiles in the internal nodes that differ from the background
    for lvl, size, dim, table, mask_off, child in ((1, LOWER, 16, 1088, 544, 8),
                                                    (2, UPPER, 32, 8256, 4128, 128)):
        if not counts[lvl]:
            continue
        dt = np.dtype({"names": ["bbox", "child", "table"],
                       "formats": [("<i4", 3), ("<u8", dim ** 3 // 64), ("<f4", (dim ** 3, 2))],
                       "offsets": [0, mask_off, table], "itemsize": size})
        nodes = np.frombuffer(buf, dt, counts[lvl], tree + offs[lvl])
        span = dim * child
        for node in nodes:
            bits = np.unpackbits(node["child"].view(np.uint8), bitorder="little").astype(bool)
            tv = node["table"][:, 0]
            idx = np.nonzero(~bits & (tv != bg))[0]
            if not len(idx):
                continue
            org = node["bbox"] & ~(span - 1)
            loc = np.stack([(idx >> (2 * int(np.log2(dim)))) & (dim - 1),
                            (idx >> int(np.log2(dim))) & (dim - 1), idx & (dim - 1)], 1) * child
            for c, v in zip(loc, tv[idx], strict=True):
                sub = np.stack(np.meshgrid(*(np.arange(child // 8) * 8,) * 3, indexing="ij"),
                               -1).reshape(-1, 3)
                origins.append(org + c + sub)
                values.append(np.full((len(sub), 8, 8, 8, 1), v, np.float32))
    if origins:
        o = np.concatenate(origins)
        vals = values[0] if len(values) == 1 else np.concatenate(values)
    else:
        o = np.zeros((0, 3), np.int64)
        vals = np.zeros((0, 8, 8, 8, 1), np.float32)
    return o, vals, bg, (vec.copy(), np.diag(mat).copy()), (vmin, vmax)


def _info_entry(m: dict) -> dict:
    lo, hi = np.asarray(m["index_bbox"][:3], float), np.asarray(m["index_bbox"][3:], float)
    vs = np.asarray(m["voxel_size"], float)
    wlo = np.asarray(m["world_bbox"][:3], float)
    empty = m["voxels"] == 0 or np.any(hi < lo)
    # world bbox of voxel centres -> cell bounds (half a voxel out), as for OpenVDB
    bounds = None if empty else [list(wlo - 0.5 * vs),
                                 list(wlo + (hi - lo + 0.5) * vs)]
    t = m["type"]
    return {"name": m["name"], "class": GRID_CLASSES[m["class"]] if m["class"] < 9 else "unknown",
            "shape": [0, 0, 0] if empty else [int(v) for v in hi - lo + 1],
            "active_voxels": int(m["voxels"]), "min": None, "max": None,
            "dtype": GRID_TYPES[t] if t < len(GRID_TYPES) else str(t), "bounds": bounds}


def inspect_path(path: Path) -> dict:
    """Per-grid description (min/max read from each float grid's root node)."""
    grids = []
    for m in _read_meta(path):
        e = _info_entry(m)
        if m["type"] == 1 and m["voxels"]:
            *_, (e["min"], e["max"]) = read_nvdb(path, m)
        grids.append(e)
    return {"format": "NanoVDB", "grids": grids}


class NanoVdbSource:
    """A float NanoVDB grid as density (fog volume, or a level set made solid)."""

    def __init__(self, path: Path, m: dict, info: dict, *, colour=(1.0, 1.0, 1.0),
                 level_set: str = "refuse", solid_density: float = 1.0,
                 shell_voxels: float = 1.0):
        self.name = str(path)
        self.level_set = level_set
        self.shell_voxels = float(shell_voxels)
        self.format = "NanoVDB"
        self.colour_encoding = "srgb"
        self.uniform_colour = np.asarray(colour, np.float32)
        self._info = info
        o, vals, bg, (self.origin, self.scale), _ = read_nvdb(path, m)
        self.blocks = SparseBlocks(o, vals, bg, m["name"])
        self.is_level_set = m["class"] == 1
        if self.is_level_set:
            check_shell(level_set, shell_voxels, abs(float(np.ravel(bg)[0])),
                        float(self.scale.min()), m["name"], path)
        self.solid_density = float(solid_density)
        lo = np.asarray(m["index_bbox"][:3], float)
        hi = np.asarray(m["index_bbox"][3:], float)
        self.bounds = (tuple(float(v) for v in self.origin + (lo - 0.5) * self.scale),
                       tuple(float(v) for v in self.origin + (hi + 0.5) * self.scale))
        self._leaf_plan = LeafGridPlan(self.blocks, self.origin, self.scale)

    layer_kind = "leaf_grid"  # as openvdb.VdbSource

    def layer_plan(self, grid: PrintGrid, z0: int, z1: int, *, density_scale: float = 1.0
                   ) -> tuple | None:
        """As :meth:`.openvdb.VdbSource.layer_plan` (None for a level set)."""
        check_slab(grid, z0, z1)
        if self.is_level_set:
            return None
        return self._leaf_plan.args(grid, z0, z1, density_scale, self.uniform_colour)

    def sample_slab(self, grid: PrintGrid, z0: int, z1: int, *, density_scale: float = 1.0,
                    out: SlabBuffers | None = None):
        check_slab(grid, z0, z1)
        u = [(voxel_centres(grid, a, *((z0, z1) if a == 2 else (0, None))) - self.origin[a])
             / self.scale[a] for a in range(3)]
        d = sample_sparse(self.blocks, u[2], u[1], u[0])[..., 0]
        if self.is_level_set:
            d = level_set_density(d, float(self.scale.min()), self.solid_density,
                                  self.level_set, self.shell_voxels)
        sigma = np.maximum(d, 0.0).astype(np.float32)
        sigma *= np.float32(density_scale / grid.mm_per_unit)
        return uniform_rgb(d.shape, self.uniform_colour,
                           None if out is None else out.take(d.shape)[0]), sigma

    def info(self) -> dict:
        return self._info


def open_path(path: Path, fmt: str = "nanovdb", *, density_grid: str | None = None,
              colour=(1.0, 1.0, 1.0), level_set: str = "refuse",
              solid_density: float = 1.0, shell_voxels: float = 1.0) -> NanoVdbSource:
    """Open a .nvdb: ``density_grid`` (default ``density``, else the only float grid); a level
    set as ``level_set`` solid or shell (:mod:`.level_set`)."""
    check_level_set_options(level_set, shell_voxels, path)
    metas = _read_meta(path)
    info = {"format": "NanoVDB", "grids": [_info_entry(m) for m in metas]}
    if not metas:
        raise DreamPrintError("the file holds no grids", path)
    names = [m["name"] for m in metas]
    if density_grid is None:
        floats = [m for m in metas if m["type"] == 1]
        chosen = next((m for m in metas if m["name"] == "density"), None)
        if chosen is None:
            if len(floats) != 1:
                raise DreamPrintError("no grid named 'density'; choose one of: "
                                      f"{', '.join(names)} ({GRID_ADVICE})", path)
            chosen = floats[0]
    else:
        chosen = next((m for m in metas if m["name"] == density_grid), None)
        if chosen is None:
            raise DreamPrintError(f"no grid named {density_grid!r} (has: {', '.join(names)})",
                                  path)
    if chosen["class"] == 1 and level_set == "refuse":
        raise DreamPrintError(f"grid {chosen['name']!r} is a level set, not a fog volume: "
                              + LEVEL_SET_ADVICE, path)
    if chosen["voxels"] == 0:
        raise DreamPrintError(f"grid {chosen['name']!r} is empty (no active voxels)", path)
    return NanoVdbSource(path, chosen, info, colour=colour, level_set=level_set,
                         solid_density=solid_density, shell_voxels=shell_voxels)
