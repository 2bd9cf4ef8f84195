"""A reader of OpenVDB ``.vdb`` files written to the published file format, in Python + numpy.

Defines :func:`read_file` (header, file metadata and grid descriptors), :func:`read_grid` (one
grid's metadata, transform and tree) and :class:`VdbGrid` with :meth:`VdbGrid.stats` (active
voxel count, index bounding box, range of the active values) and :meth:`VdbGrid.blocks` (the
8^3 blocks a sampler needs).

The specification is OpenVDB's own source (MPL-2.0 / Apache-2.0, read as the format's
definition; no code copied): ``io/Archive.cc`` (``readHeader``, ``readGridCompression``,
``doReadGrid``), ``io/File.cc`` (``readGridDescriptors``), ``io/GridDescriptor.cc``,
``MetaMap.cc`` (``readMeta``), ``math/Transform.cc`` and ``math/Maps.h`` (the maps' ``read``
and ``applyMap``), ``tree/Tree.h``, ``tree/RootNode.h``, ``tree/InternalNode.h`` and
``tree/LeafNode.h`` (``readTopology`` / ``readBuffers``) and ``io/Compression.h/.cc``
(``readCompressedValues``, ``bloscFromStream``, ``unzipFromStream``). All little-endian:

* File: int64 magic ``0x56444220``, uint32 file version (222..225 read here), uint32 library
  major and minor, char "has grid offsets", 36-byte UUID, the file metadata, int32 grid count,
  then per grid a descriptor (unique name ``name\\x1eN``, tree type name, with suffix
  ``_HalfFloat`` when saved as half, instance parent name, int64 grid / block / end offsets)
  followed by the grid: uint32 compression flags (1 zip, 2 active mask, 4 blosc), metadata
  (uint32 count; name, type name, uint32 size, bytes), transform (map type name and its
  doubles), topology, buffers. Strings are uint32 length + bytes.
* Topology (tree ``Tree_<type>_5_4_3``): int32 buffer count (1); root: background value,
  uint32 tile and child counts, tiles (int32 x3 origin, value, bool active), children (int32
  x3 origin + an upper internal node); internal node (32^3 slots of 128^3 voxels, then 16^3
  slots of 8^3 voxels): child mask, value mask (bit n of uint64 word n/64), the node's slot
  values through ``readCompressedValues`` (tile values, half floats when the grid is saved
  as half), then its children in slot order; leaf: its value mask.
* Buffers: per leaf, in the order root children (sorted by origin) -> slots: the value mask
  again, then ``readCompressedValues`` of its 512 voxels.
* ``readCompressedValues``: one byte of per-node metadata (0 no mask / inactive values are
  +background, 1 all inactive -background, 2 one other inactive value, 3 a mask selecting
  -background / +background, 4 a mask selecting background / one value, 5 a mask selecting
  two values, 6 all values stored), then the inactive value(s) at full precision, then the
  selection mask, then the stored values: only the active ones when the grid's flags have
  the active-mask bit and the metadata is not 6, else all; each chunk zip (int64 size + zlib
  stream, or -size + raw bytes), blosc (the same with a blosc frame) or raw; half floats
  when the grid is saved as half (no chunk at all for zero half values).

Slot index n of a node of side 2^d: ``n = (x << 2d) + (y << d) + z`` (x, y, z local).
Refused with a reason (:class:`VdbError`): damaged or truncated data, versions outside
222..225, streams without grid offsets, tree configurations other than 5-4-3, value types
other than float / double / half / int32 / int64 / vec3s / vec3d / vec3i, instanced grids,
non-linear (frustum) transforms.
"""

from __future__ import annotations

import mmap
import struct
import zlib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

__all__ = ["VdbError", "VdbGrid", "GridDescriptor", "VdbFile", "read_file", "read_grid",
           "MIN_VERSION", "MAX_VERSION"]

MAGIC = 0x56444220
MIN_VERSION = 222           # OPENVDB_FILE_VERSION_NODE_MASK_COMPRESSION
MAX_VERSION = 225           # OPENVDB_FILE_VERSION_HALF_GRID (OpenVDB 11-12)
COMPRESS_ZIP, COMPRESS_ACTIVE_MASK, COMPRESS_BLOSC = 1, 2, 4
HALF_SUFFIX = "_HalfFloat"
# value type -> (numpy dtype on disk, components, stored as half when saved as half)
VALUE_TYPES = {
    "float": ("<f4", 1, True), "double": ("<f8", 1, True), "half": ("<f2", 1, False),
    "int32": ("<i4", 1, False), "int64": ("<i8", 1, False),
    "vec3s": ("<f4", 3, True), "vec3d": ("<f8", 3, True), "vec3i": ("<i4", 3, False),
}
_STRUCT = {"<f4": "f", "<f8": "d", "<f2": "e", "<i4": "i", "<i8": "q"}
LEAF, LOWER, UPPER = 8, 128, 4096          # side of a leaf, lower and upper internal node
_MAX_ENTRIES = 1_000_000


class VdbError(Exception):
    """A problem with a .vdb's content: ``grid`` (or None) and the reason; ``unsupported``:
    valid content this reader does not take (a value type, instancing, a frustum), as opposed
    to damaged data."""

    def __init__(self, reason: str, grid: str | None = None, *, unsupported: bool = False
                 ) -> None:
        self.reason, self.grid, self.unsupported = reason, grid, unsupported
        super().__init__(reason if grid is None else f"grid {grid!r}: {reason}")


class _Cursor:
    """Bounds-checked little-endian reads from a buffer (an mmap of the file)."""

    __slots__ = ("buf", "pos", "size", "grid")

    def __init__(self, buf, pos: int, grid: str | None = None) -> None:
        self.buf, self.pos, self.size, self.grid = buf, pos, len(buf), grid

    def need(self, n: int, what: str) -> int:
        p = self.pos
        if n < 0 or p + n > self.size:
            raise VdbError(f"truncated or damaged: {what} needs bytes {p:,}..{p + n:,}, the "
                           f"file has {self.size:,}", self.grid)
        self.pos = p + n
        return p

    def take(self, n: int, what: str) -> bytes:
        p = self.need(n, what)
        return self.buf[p:p + n]

    def unpack(self, fmt: str, what: str):
        s = struct.calcsize(fmt)
        return struct.unpack_from(fmt, self.buf, self.need(s, what))

    def u32(self, what: str) -> int:
        return self.unpack("<I", what)[0]

    def string(self, what: str) -> str:
        n = self.u32(what)
        return self.take(n, what).decode("utf-8", "replace")

    def array(self, dtype, count: int, what: str) -> np.ndarray:
        dt = np.dtype(dtype)
        p = self.need(dt.itemsize * count, what)
        return np.frombuffer(self.buf, dt, count, p)


@dataclass
class GridDescriptor:
    name: str
    unique_name: str
    tree_type: str
    half_suffix: bool
    instance_parent: str
    grid_pos: int
    block_pos: int
    end_pos: int


@dataclass
class VdbFile:
    path: Path
    version: int
    library: tuple[int, int]
    metadata: dict
    grids: list[GridDescriptor]
    buf: object = field(repr=False)


def _open_buffer(path: Path):
    with open(path, "rb") as f:
        size = f.seek(0, 2)
        if size == 0:
            return b""
        return mmap.mmap(f.fileno(), 0, access=mmap.ACCESS_READ)


def _read_meta(c: _Cursor, what: str) -> dict:
    """MetaMap::readMeta: the values of known scalar types, the others skipped by size."""
    n = c.u32(f"the {what} metadata count")
    if n > _MAX_ENTRIES:
        raise VdbError(f"damaged: {n:,} {what} metadata entries", c.grid)
    out = {}
    for _ in range(n):
        name = c.string(f"a {what} metadata name")
        typ = c.string(f"the type of {what} metadata {name!r}")
        size = c.u32(f"the size of {what} metadata {name!r}")
        raw = c.take(size, f"{what} metadata {name!r}")
        fmt = {"bool": "<?", "int32": "<i", "int64": "<q", "float": "<f", "double": "<d",
               "vec3i": "<3i", "vec3s": "<3f", "vec3d": "<3d"}.get(typ)
        if typ == "string":
            out[name] = raw.decode("utf-8", "replace")
        elif fmt is not None and struct.calcsize(fmt) == size:
            v = struct.unpack(fmt, raw)
            out[name] = v[0] if len(v) == 1 else list(v)
    return out


def read_file(path: Path) -> VdbFile:
    """Header, file metadata and grid descriptors of a .vdb (raises :class:`VdbError`)."""
    buf = _open_buffer(path)
    c = _Cursor(buf, 0)
    magic = c.unpack("<q", "the magic number")[0]
    if magic != MAGIC:
        raise VdbError(f"not an OpenVDB file (magic {magic & 0xFFFFFFFFFFFFFFFF:#x})")
    version, major, minor = c.unpack("<III", "the version numbers")
    if version > MAX_VERSION:
        raise VdbError(f"OpenVDB file format version {version} is newer than {MAX_VERSION}, "
                       "the newest this reader knows (written by a newer OpenVDB)")
    if version < MIN_VERSION:
        raise VdbError(f"OpenVDB file format version {version} is older than {MIN_VERSION} "
                       "(OpenVDB before 2.0): re-save it with a current OpenVDB")
    offsets = c.take(1, "the grid-offsets flag") != b"\x00"
    c.take(36, "the file UUID")
    if not offsets:
        raise VdbError("written as a stream without grid offsets, which this reader does not "
                       "read (save it as a file)")
    meta = _read_meta(c, "file")
    n = c.unpack("<i", "the grid count")[0]
    if not 0 <= n <= _MAX_ENTRIES:
        raise VdbError(f"damaged: the header claims {n:,} grids")
    grids = []
    for k in range(n):
        unique = c.string(f"grid descriptor {k + 1} of {n}")
        name = unique.split("\x1e")[0]
        c.grid = name
        ttype = c.string("its type")
        half = ttype.endswith(HALF_SUFFIX)
        if half:
            ttype = ttype[:-len(HALF_SUFFIX)]
        parent = c.string("its instance parent")
        g, b, e = c.unpack("<qqq", "its offsets")
        if parent:                        # an instance has no blocks (block offset 0)
            b = g
        if not (c.pos == g <= b <= e <= c.size):
            raise VdbError(f"damaged or truncated: offsets {g:,}, {b:,}, {e:,} in a file of "
                           f"{c.size:,} bytes", name)
        grids.append(GridDescriptor(name, unique, ttype, half, parent, g, b, e))
        c.pos, c.grid = e, None
    return VdbFile(path, version, (major, minor), meta, grids, buf)


def _transform(c: _Cursor) -> dict:
    """Transform::read: the map, as origin = map(0, 0, 0) and columns[e] = map(e) - origin
    for the index unit vectors e, computed as each map's ``applyMap`` does (math/Maps.h)."""
    kind = c.string("the transform's map type")
    vec = {"ScaleMap": 5, "UniformScaleMap": 5, "TranslationMap": 1,
           "ScaleTranslateMap": 6, "UniformScaleTranslateMap": 6}
    if kind in ("AffineMap", "UnitaryMap"):
        m = c.unpack("<16d", "the transform's matrix")

        def apply(x, y, z):
            return [x * m[r] + y * m[4 + r] + z * m[8 + r] + m[12 + r] for r in range(3)]
    elif kind in vec:
        v = c.unpack(f"<{3 * vec[kind]}d", "the transform's values")
        if kind == "TranslationMap":
            t = v[0:3]

            def apply(x, y, z):
                return [a + b for a, b in zip((x, y, z), t, strict=True)]
        elif vec[kind] == 5:
            s = v[0:3]

            def apply(x, y, z):
                return [a * b for a, b in zip((x, y, z), s, strict=True)]
        else:
            t, s = v[0:3], v[3:6]

            def apply(x, y, z):
                return [a * b + d for a, b, d in zip((x, y, z), s, t, strict=True)]
    elif kind == "NonlinearFrustumMap":
        raise VdbError("a frustum transform (NonlinearFrustumMap): DreamPrint samples "
                       "grids with a linear transform (resample it in Houdini/Blender)", c.grid,
                       unsupported=True)
    else:
        raise VdbError(f"an unknown transform map type {kind!r}", c.grid, unsupported=True)
    o = apply(0.0, 0.0, 0.0)
    cols = [[a - b for a, b in zip(apply(*e), o, strict=True)]
            for e in ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0))]
    return {"map": kind, "origin": o, "columns": cols, "linear": True}


def _mask_bits(raw, count: int) -> np.ndarray:
    """A node mask's bits (bit n of little-endian uint64 word n // 64) as bool (count,)."""
    return np.unpackbits(np.frombuffer(raw, np.uint8), bitorder="little")[:count].view(bool)


def _blosc(raw: bytes, nbytes: int) -> bytes:
    """A blosc frame (bloscFromStream), after checking that its header announces ``nbytes``
    (bytes 4..7: the uncompressed size) so that damaged data cannot ask for any size."""
    import imagecodecs

    if len(raw) < 16 or int.from_bytes(raw[4:8], "little") != nbytes:
        raise ValueError("its blosc header does not announce the expected size")
    return imagecodecs.blosc_decode(raw)


def _unzip(raw: bytes, nbytes: int) -> bytes:
    """A zlib stream (unzipFromStream), inflated to at most ``nbytes + 1`` bytes."""
    d = zlib.decompressobj()
    return d.decompress(raw, nbytes + 1)


class _Values:
    """Reads ``readCompressedValues`` chunks of one grid (its flags, types and background)."""

    def __init__(self, flags: int, dtype: str, nc: int, half: bool, background: np.ndarray,
                 grid: str) -> None:
        self.flags, self.nc, self.grid = flags, nc, grid
        self.dtype = np.dtype(dtype)
        self.disk = np.dtype("<f2") if half else self.dtype
        self.half = half
        self.full_size = self.dtype.itemsize * nc          # one value at full precision
        self.size = self.disk.itemsize * nc                # one stored value
        self.mask_c = bool(flags & COMPRESS_ACTIVE_MASK)
        self.bg = background
        self.log: list | None = None        # (start, end, decoded bytes) of every chunk
        if flags & COMPRESS_BLOSC:
            self.decode = _blosc
        elif flags & COMPRESS_ZIP:
            self.decode = _unzip
        else:
            self.decode = None

    def chunk(self, c: _Cursor, count: int, what: str) -> bytes:
        """``count`` stored values' bytes (readData / HalfReader), logged when asked."""
        start = c.pos
        out = self._chunk(c, count, what)
        if self.log is not None:
            self.log.append((start, c.pos, out))
        return out

    def _chunk(self, c: _Cursor, count: int, what: str) -> bytes:
        nbytes = count * self.size
        if self.half and count < 1:
            return b""
        if self.decode is None:
            return c.take(nbytes, what)
        n = c.unpack("<q", what)[0]
        if n <= 0:
            if -n != nbytes:
                raise VdbError(f"damaged: {what} holds {-n:,} bytes, expected {nbytes:,}",
                               self.grid)
            return c.take(nbytes, what)
        raw = c.take(n, what)
        try:
            out = self.decode(raw, nbytes)
        except Exception as exc:  # noqa: BLE001 - any codec failure is damaged data
            raise VdbError(f"damaged: {what} does not decompress ({exc})", self.grid) from None
        if len(out) != nbytes:
            raise VdbError(f"damaged: {what} decompresses to {len(out):,} bytes, expected "
                           f"{nbytes:,}", self.grid)
        return out

    def header(self, c: _Cursor, what: str):
        """(metadata code, inactive value 0, inactive value 1): the values an unsaved inactive
        voxel takes where the selection mask (read next, codes 3-5) is off / on."""
        meta = c.buf[c.need(1, what)]
        if meta > 6:
            raise VdbError(f"damaged: {what} has compression metadata {meta} (0..6 known)",
                           self.grid)
        iv1 = self.bg
        iv0 = self.bg if meta == 0 else -self.bg
        if meta in (2, 4, 5):
            iv0 = c.array(self.dtype, self.nc, what)
            if meta == 5:
                iv1 = c.array(self.dtype, self.nc, what)
        return meta, iv0, iv1

    def node(self, c: _Cursor, value_mask: np.ndarray, what: str) -> np.ndarray:
        """All values (n, nc) of one node (an internal node's slots)."""
        n = len(value_mask)
        meta, iv0, iv1 = self.header(c, what)
        sel = None
        if meta in (3, 4, 5):
            sel = _mask_bits(c.take(n // 8, what), n)
        count = n
        if self.mask_c and meta != 6:
            count = int(np.count_nonzero(value_mask))
        data = np.frombuffer(self.chunk(c, count, what), self.disk).reshape(count, self.nc)
        if count == n:
            return data.astype(self.dtype)
        out = np.empty((n, self.nc), self.dtype)
        out[:] = iv0
        if sel is not None:
            out[sel] = iv1
        out[value_mask] = data
        return out


@dataclass
class _Node:
    origin: tuple[int, int, int]
    child: np.ndarray         # (slots,) bool
    active: np.ndarray        # (slots,) bool
    values: np.ndarray        # (slots, nc)


@dataclass
class VdbGrid:
    """One grid as read: its tree (root tiles, internal nodes, leaves) and its description."""

    name: str
    value_type: str
    grid_class: str
    half: bool
    metadata: dict
    transform: dict
    background: np.ndarray                    # (nc,)
    root_tiles: list                          # [(origin (3,), value (nc,), active)]
    upper: list                               # [_Node] (32^3 slots of 128^3 voxels)
    lower: list                               # [_Node] (16^3 slots of 8^3 voxels)
    leaf_origins: np.ndarray                  # (L, 3) int64
    leaf_active: np.ndarray                   # (L, 512) bool
    leaf_values: np.ndarray                   # (L, 512, nc)

    @property
    def channels(self) -> int:
        return int(self.background.shape[0])

    def _active_tiles(self):
        """(origins (T, 3), sides (T,), values (T, nc)) of every active tile."""
        o, s, v = [], [], []
        for org, val, act in self.root_tiles:
            if act:
                o.append(np.asarray(org))
                s.append(UPPER)
                v.append(val)
        for nodes, side, dim in ((self.upper, LOWER, 32), (self.lower, LEAF, 16)):
            for nd in nodes:
                idx = np.nonzero(nd.active & ~nd.child)[0]
                if len(idx):
                    loc = np.stack([idx // (dim * dim), (idx // dim) % dim, idx % dim], -1)
                    o.extend(np.asarray(nd.origin) + loc * side)
                    s.extend([side] * len(idx))
                    v.extend(nd.values[idx])
        if not o:
            return np.zeros((0, 3), np.int64), np.zeros(0, np.int64), \
                np.zeros((0, self.channels), self.leaf_values.dtype)
        return np.asarray(o, np.int64).reshape(-1, 3), np.asarray(s, np.int64), \
            np.asarray(v).reshape(-1, self.channels)

    def stats(self) -> dict:
        """Active voxel count, active index bbox (inclusive; OpenVDB's empty box when none),
        and the active values (tiles counted once, as their value) for ranges."""
        to, ts, tv = self._active_tiles()
        act = self.leaf_active
        count = int(np.count_nonzero(act)) + int(np.sum(ts.astype(object) ** 3))
        lo = np.full(3, np.iinfo(np.int32).max, np.int64)
        hi = np.full(3, np.iinfo(np.int32).min, np.int64)
        any_leaf = act.any(axis=1)
        if any_leaf.any():
            a = act[any_leaf].reshape(-1, 8, 8, 8)
            org = self.leaf_origins[any_leaf]
            for ax, others in ((0, (2, 3)), (1, (1, 3)), (2, (1, 2))):
                # only the leaves at the least / greatest origin can hold the extreme voxel
                for_lo = org[:, ax] == org[:, ax].min()
                for_hi = org[:, ax] == org[:, ax].max()
                first = np.argmax(a[for_lo].any(axis=others), axis=1)
                last = 7 - np.argmax(a[for_hi].any(axis=others)[:, ::-1], axis=1)
                lo[ax] = min(lo[ax], int(org[for_lo, ax][0] + first.min()))
                hi[ax] = max(hi[ax], int(org[for_hi, ax][0] + last.max()))
        if len(to):
            lo = np.minimum(lo, to.min(axis=0))
            hi = np.maximum(hi, (to + ts[:, None] - 1).max(axis=0))
        values = np.concatenate([self.leaf_values[act], tv]) if len(tv) else \
            self.leaf_values[act]
        return {"active_voxels": count, "bbox": [lo.tolist(), hi.tolist()],
                "active_values": values}

    def blocks(self, lo: list[int], hi: list[int], max_bytes: int
               ) -> tuple[np.ndarray, np.ndarray]:
        """(origins (B, 3) int32, values (B, 8, 8, 8, nc) float32 [block, i, j, k, c]) of every
        8^3 block, active or not, whose values differ from the background, in the 128^3
        lower-node chunks that meet the index box [lo, hi]: leaves as stored, tiles of every
        level filled at their own size. Chunk by chunk in (i, j, k) order, blocks in (i, j, k)
        order inside a chunk. Raises VdbError when they would take more than ``max_bytes``."""
        nc = self.channels
        bg = self.background.astype(np.float32)
        clo = np.floor_divide(np.asarray(lo, np.int64), LOWER) * LOWER
        chi = np.floor_divide(np.asarray(hi, np.int64), LOWER) * LOWER

        def in_range(o):                     # chunk origins (n, 3) within [clo, chi]
            o = np.asarray(o, np.int64).reshape(-1, 3)
            return np.all((o >= clo) & (o <= chi), axis=1)

        origins, values, consts, const_org = [], [], [], []
        # leaves
        if len(self.leaf_origins):
            lv = self.leaf_values.astype(np.float32, copy=False)
            keep = np.any((lv != bg).reshape(len(lv), -1), axis=1)
            keep &= in_range(np.floor_divide(self.leaf_origins, LOWER) * LOWER)
            origins.append(self.leaf_origins[keep])
            values.append(lv[keep])
        # tiles of lower nodes (8^3 each)
        for nd in self.lower:
            if not in_range(nd.origin)[0]:
                continue
            idx = np.nonzero(~nd.child)[0]
            tv = nd.values[idx].astype(np.float32)
            k = np.any(tv != bg, axis=1)
            if k.any():
                idx, tv = idx[k], tv[k]
                loc = np.stack([idx // 256, (idx // 16) % 16, idx % 16], -1) * LEAF
                const_org.append(np.asarray(nd.origin) + loc)
                consts.append(tv)
        # 128^3 chunks covered by an upper node's tile or a root tile: 4096 blocks each
        chunk_tiles = []
        for nd in self.upper:
            idx = np.nonzero(~nd.child)[0]
            if len(idx) == 0:
                continue
            loc = np.stack([idx // 1024, (idx // 32) % 32, idx % 32], -1) * LOWER
            org = np.asarray(nd.origin) + loc
            k = in_range(org)
            if k.any():
                chunk_tiles.append((org[k], nd.values[idx[k]]))
        for org, val, _ in self.root_tiles:
            a = [np.arange(max(o, c0), min(o + UPPER - 1, c1) + 1, LOWER)
                 for o, c0, c1 in zip(org, clo, chi, strict=True)]
            if all(len(x) for x in a):
                g = np.stack(np.meshgrid(*a, indexing="ij"), -1).reshape(-1, 3)
                chunk_tiles.append((g, np.broadcast_to(val, (len(g), nc))))
        sub = np.stack(np.meshgrid(*(np.arange(16) * LEAF,) * 3, indexing="ij"), -1)
        sub = sub.reshape(-1, 3)
        for org, val in chunk_tiles:
            v32 = np.asarray(val).astype(np.float32)
            k = np.any(v32 != bg, axis=1)
            for o, v in zip(org[k], v32[k], strict=True):
                const_org.append(o + sub)
                consts.append(np.broadcast_to(v, (len(sub), nc)))
        n_blocks = sum(len(o) for o in origins) + sum(len(o) for o in const_org)
        if n_blocks * 512 * nc * 4 > max_bytes:
            raise VdbError(f"its active region needs {n_blocks * 512 * nc * 4 / 1e9:.1f} GB "
                           f"of voxel values, more than the {max_bytes / 1e9:.1f} GB this "
                           "machine can give it", self.name)
        if const_org:
            co = np.concatenate(const_org)
            cv = np.concatenate(consts)
            origins.append(co)
            values.append(np.broadcast_to(cv[:, None, :], (len(cv), 512, nc)))
        if not origins:
            return np.zeros((0, 3), np.int32), np.zeros((0, 8, 8, 8, nc), np.float32)
        o = np.concatenate(origins).astype(np.int64)
        chunk = np.floor_divide(o, LOWER)
        order = np.lexsort((o[:, 2], o[:, 1], o[:, 0], chunk[:, 2], chunk[:, 1], chunk[:, 0]))
        out = np.empty((len(o), 512, nc), np.float32)
        start = 0
        for v in values:                     # concatenate into `out` without a second copy
            out[start:start + len(v)] = v
            start += len(v)
        out = out[order] if not np.array_equal(order, np.arange(len(o))) else out
        return o[order].astype(np.int32), out.reshape(len(o), 8, 8, 8, nc)


def _tree_type(ttype: str, name: str) -> tuple[str, str, int, bool]:
    parts = ttype.split("_")
    if len(parts) < 2 or parts[0] != "Tree":
        raise VdbError(f"an unknown grid type {ttype!r}", name, unsupported=True)
    vt, dims = parts[1], parts[2:]
    if vt not in VALUE_TYPES:
        raise VdbError(f"holds {vt} values ({ttype}), which DreamPrint does not read "
                       "(float, double, half, int32, int64, vec3s, vec3d, vec3i)", name,
                       unsupported=True)
    if dims != ["5", "4", "3"]:
        raise VdbError(f"a tree configuration {ttype!r} other than OpenVDB's standard 5-4-3",
                       name, unsupported=True)
    dt, nc, real = VALUE_TYPES[vt]
    return vt, dt, nc, real


def read_grid(vf: VdbFile, gd: GridDescriptor, *, tree: bool = True,
              chunk_log: list | None = None) -> VdbGrid:
    """Read one grid of ``vf`` (with its tree unless ``tree`` is False). Raises
    :class:`VdbError` naming the grid for anything it cannot read faithfully. ``chunk_log``
    (a list) receives (start, end, decoded bytes) of every compressed chunk (for tests that
    re-encode a file)."""
    name = gd.name
    vt, dt, nc, real = _tree_type(gd.tree_type, name)
    if gd.instance_parent:
        raise VdbError(f"an instance of grid {gd.instance_parent!r} (instanced grids are not "
                       "read: save the file without instancing)", name, unsupported=True)
    c = _Cursor(vf.buf, gd.grid_pos, name)
    flags = c.u32("the compression flags")
    if flags & ~(COMPRESS_ZIP | COMPRESS_ACTIVE_MASK | COMPRESS_BLOSC):
        raise VdbError(f"damaged: unknown compression flags {flags:#x}", name)
    meta = _read_meta(c, "grid")
    cls = str(meta.get("class", "unknown")).strip().lower()
    if cls not in ("level set", "fog volume", "staggered"):
        cls = "unknown"
    half = bool(meta.get("is_saved_as_half_float", False)) and real
    xf = _transform(c)
    if not tree:
        return VdbGrid(name, vt, cls, half, meta, xf, np.zeros(nc, dt), [], [], [],
                       np.zeros((0, 3), np.int64), np.zeros((0, 512), bool),
                       np.zeros((0, 512, nc), dt))
    buffers = c.unpack("<i", "the buffer count")[0]
    if buffers != 1:
        raise VdbError(f"damaged: {buffers} buffers per node (1 expected)", name)
    bg = np.array(c.array(dt, nc, "the background value"))
    vals = _Values(flags, dt, nc, half, bg, name)
    vals.log = chunk_log
    n_tiles, n_children = c.unpack("<II", "the root's tile and child counts")
    if n_tiles > (1 << 24) or n_children > (1 << 24):
        raise VdbError(f"damaged: the root claims {n_tiles:,} tiles and {n_children:,} "
                       "children", name)
    root_tiles = []
    tile_fmt = struct.Struct(f"<3i{nc}{_STRUCT[dt]}?")
    for _ in range(n_tiles):
        t = tile_fmt.unpack_from(c.buf, c.need(tile_fmt.size, "a root tile"))
        org = t[:3]
        if any(v % UPPER for v in org):
            raise VdbError(f"damaged: a root tile at {org} (not a multiple of 4096)", name)
        root_tiles.append((org, np.asarray(t[3:3 + nc], dt), bool(t[-1])))
    upper, lower, leaf_masks, leaf_org = [], [], [], []
    per_child = []                                   # (origin, leaf index range) per root child
    for _ in range(n_children):
        org = c.unpack("<3i", "a root child's origin")
        if any(v % UPPER for v in org):
            raise VdbError(f"damaged: an internal node at {org} (not a multiple of 4096)", name)
        first = len(leaf_org)
        _internal(c, org, 5, vals, upper, lower, leaf_masks, leaf_org)
        per_child.append((org, first, len(leaf_org)))
    if len({p[0] for p in per_child}) != len(per_child):
        raise VdbError("damaged: two root children at the same origin", name)
    if c.pos != gd.block_pos:
        raise VdbError(f"damaged: its topology ends at byte {c.pos:,}, its descriptor says "
                       f"{gd.block_pos:,}", name)
    # buffers are read in the root's (sorted) order of its children
    order = [i for p in sorted(per_child) for i in range(p[1], p[2])]
    masks = np.frombuffer(b"".join(leaf_masks[i] for i in order), np.uint8)
    origins = np.asarray([leaf_org[i] for i in order], np.int64).reshape(-1, 3)
    active = np.unpackbits(masks, bitorder="little").view(bool).reshape(-1, 512)
    values = _leaf_buffers(c, vals, active, name)
    if c.pos != gd.end_pos:
        raise VdbError(f"damaged: its data ends at byte {c.pos:,}, its descriptor says "
                       f"{gd.end_pos:,}", name)
    return VdbGrid(name, vt, cls, half, meta, xf, bg, root_tiles, upper, lower, origins,
                   active, values)


def _internal(c: _Cursor, org, log2: int, vals: _Values, upper, lower, leaf_masks, leaf_org):
    """InternalNode::readTopology of a node of 2^log2 slots per side (5: upper, 4: lower)."""
    n = 1 << (3 * log2)
    what = "an upper internal node" if log2 == 5 else "a lower internal node"
    child = _mask_bits(c.take(n // 8, what), n)
    active = _mask_bits(c.take(n // 8, what), n)
    values = vals.node(c, active, f"the tile values of {what} at {tuple(org)}")
    (upper if log2 == 5 else lower).append(_Node(tuple(org), child, active, values))
    side = LOWER if log2 == 5 else LEAF
    d2 = 2 * log2
    mask = (1 << log2) - 1
    for s in np.nonzero(child)[0].tolist():
        o = (org[0] + (s >> d2) * side, org[1] + ((s >> log2) & mask) * side,
             org[2] + (s & mask) * side)
        if log2 == 5:
            _internal(c, o, 4, vals, upper, lower, leaf_masks, leaf_org)
        else:
            leaf_masks.append(c.take(64, "a leaf's value mask"))
            leaf_org.append(o)


def _leaf_buffers(c: _Cursor, vals: _Values, active: np.ndarray, name: str) -> np.ndarray:
    """LeafNode::readBuffers of every leaf (in buffer order): their 512 values each. The loop
    over leaves only cuts the stream into chunks (the common case, code 0 and a blosc / zip /
    raw chunk, inline); values are placed for all leaves at once."""
    n_leaves = len(active)
    nc, dtype = vals.nc, vals.dtype
    counts = active.sum(axis=1).tolist()
    buf, size = c.buf, c.size
    chunks = []
    full = np.zeros(n_leaves, bool)
    fill0 = np.empty((n_leaves, nc), dtype)
    fill0[:] = vals.bg
    fill1 = fill0.copy()
    special = False                                  # any code other than 0 seen
    sel_rows, sel_masks = [], []
    mask_c, esize, half = vals.mask_c, vals.size, vals.half
    decode, log = vals.decode, vals.log
    size_at = struct.Struct("<q").unpack_from
    what = "a leaf's values"
    for n in range(n_leaves):
        p = c.pos + 64                               # the mask again: the topology's is used
        if p >= size:
            c.need(65, what)                         # raises: truncated
        meta = buf[p]
        c.pos = p + 1
        if meta:
            special = True
            hc = _Cursor(buf, p, name)
            meta, iv0, iv1 = vals.header(hc, what)
            c.pos = hc.pos
            fill0[n] = iv0
            fill1[n] = iv1
            if meta in (3, 4, 5):
                sel_rows.append(n)
                sel_masks.append(buf[c.need(64, "a leaf's selection mask"):c.pos])
        count = counts[n] if (mask_c and meta != 6) else 512
        if count == 512:
            full[n] = True
        nbytes = count * esize
        start = c.pos
        if decode is None or (half and count == 0):
            if not (half and count == 0):
                if start + nbytes > size:
                    c.need(nbytes, what)
                chunks.append(buf[start:start + nbytes])
                c.pos = start + nbytes
        else:
            if start + 8 > size:
                c.need(8, what)
            k = size_at(buf, start)[0]
            q = start + 8
            if k <= 0:
                if -k != nbytes:
                    raise VdbError(f"damaged: {what} holds {-k:,} bytes, expected {nbytes:,}",
                                   name)
                if q + nbytes > size:
                    c.pos = q
                    c.need(nbytes, what)
                chunks.append(buf[q:q + nbytes])
                c.pos = q + nbytes
            else:
                if q + k > size:
                    c.pos = q
                    c.need(k, what)
                try:
                    out = decode(buf[q:q + k], nbytes)
                except Exception as exc:  # noqa: BLE001 - any codec failure is damaged data
                    raise VdbError(f"damaged: {what} does not decompress ({exc})",
                                   name) from None
                if len(out) != nbytes:
                    raise VdbError(f"damaged: {what} decompresses to {len(out):,} bytes, "
                                   f"expected {nbytes:,}", name)
                chunks.append(out)
                c.pos = q + k
        if log is not None:
            log.append((start, c.pos, chunks[-1] if c.pos > start else b""))
    data = np.frombuffer(b"".join(chunks), vals.disk).reshape(-1, nc)
    out = np.empty((n_leaves, 512, nc), dtype)
    part = ~full
    if part.all() and not special:
        out[...] = vals.bg                           # every inactive voxel: the background
    elif part.any():
        out[part] = fill0[part][:, None, :]
        if sel_rows:
            sel = np.unpackbits(np.frombuffer(b"".join(sel_masks), np.uint8),
                                bitorder="little").view(bool).reshape(-1, 512)
            rows = np.asarray(sel_rows)
            sub = out[rows]
            np.copyto(sub, fill1[rows][:, None, :], where=sel[:, :, None])
            out[rows] = sub
    where = active.copy()
    where[full] = True
    if int(where.sum()) != len(data):
        raise VdbError("damaged: the leaves' value counts do not match their masks", name)
    out[where] = data
    return out
