"""InstantNGP NeRF snapshots (``.ingp``, ``.msgpack``) sampled directly on the printer grid.

Defines :func:`read_snapshot` (the file's msgpack tree), :func:`parse_snapshot` (an
:class:`IngpModel`: configuration, weights, occupancy grid, placement), :class:`IngpSource`
(the :class:`~.base.VolumeSource`), :func:`open_path` and :func:`inspect_path`.

Layout, as instant-ngp writes it (``Testbed::save_snapshot`` in ``src/testbed.cu``): a
msgpack map holding the network configuration (``encoding``, ``network``, ``dir_encoding``,
``rgb_network``) and ``snapshot``: ``params_binary`` (``params_type`` ``"__half"`` or
``"float"``, ``n_params`` values), ``density_grid_binary`` (float16, 128^3 per cascade, Morton
order), ``density_grid_size`` (128), ``aabb``, ``render_aabb``, ``render_aabb_to_local``,
``nerf.aabb_scale`` and ``nerf.dataset`` (``scale``, ``offset``, ``from_mitsuba``, ``is_hdr``,
...).  ``.ingp`` files are the same bytes through zlib's gzip stream (``zstr``); a ``.msgpack``
may be either: both are detected from the first bytes.

Parameters are stored density MLP, colour MLP, position encoding, direction encoding
(``NerfNetwork::set_params_impl``); each MLP is its weight matrices, first to last, each
(out, in) row-major, no biases, widths padded to multiples of 16 (tiny-cuda-nn
``FullyFusedMLP``/``CutlassMLP``); the grid is one table per level, ``F`` features per entry.
Where the configuration leaves them out, values are derived as instant-ngp does
(``Testbed::reset_network``): ``per_level_scale = exp(ln(2048 aabb_scale / N_min) / (L - 1))``,
``N_min = 2^floor(log2_hashmap_size / 3)`` (with instant-ngp's default 15 for that
derivation, tiny-cuda-nn's 19 for the table), 16 levels of 2 features.  The evaluation itself is
:mod:`.kernels` (its docstring has the equations).

Placement.  Source units are the dataset's own (``transforms.json``) coordinates: instant-ngp's
position is ``q = C (p * scale + offset)`` with ``C`` its axis cycle (x, y, z) <- (y, z, x)
(none for Mitsuba scenes); the bounds are the render box (``render_aabb`` turned by
``render_aabb_to_local``, intersected with ``aabb``) mapped back.  Density: instant-ngp's
``sigma`` is per unit of its own space, so per source unit it is ``sigma * |scale|``; then the
product's rule (:mod:`.base`).  Only cells the snapshot's occupancy grid marks occupied are
evaluated (what instant-ngp's renderer does); elsewhere density is 0.

Colour is view-dependent in a NeRF; a print has one colour per voxel.  The colour used is the
network's colour for one stated view direction, by default looking straight down the source's
z axis (``view="down"``, a camera above the print: one colour-network pass per voxel), or the
mean over the six axis directions +-x, +-y, +-z (``view="mean"``, six passes), or a direction
``view="x,y,z"`` in source coordinates.  LDR snapshots learn sRGB-encoded colour (instant-ngp
trains on the images' sRGB values unless told to train in linear colours); HDR ones
(``is_hdr``) linear, with instant-ngp's exponential colour activation.
"""

from __future__ import annotations

import gzip
import math
import os
import threading
import zlib
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from dreamprint_gui.core.errors import DreamPrintError
from dreamprint_gui.io.volumes.base import (
    PrintGrid,
    SlabBuffers,
    check_slab,
    linear_to_srgb,
    voxel_centres,
)
from dreamprint_gui.io.volumes.dense import MAX_EXPANSION, bounds_list
from dreamprint_gui.io.volumes.ingp.kernels import ACT, sample_rows

__all__ = ["read_snapshot", "parse_snapshot", "IngpModel", "IngpSource", "open_path",
           "sh_encode", "snapshot_info", "VIEW_DIRECTIONS"]

GRID_SIZE = 128                     # NERF_GRIDSIZE()
MIN_OPTICAL_THICKNESS = 0.01        # NERF_MIN_OPTICAL_THICKNESS()
MLP_TYPES = ("fullyfusedmlp", "megakernelmlp", "cutlassmlp", "mlp")
GRID_TYPES = {"hashgrid": "hash", "grid": "hash", "densegrid": "dense", "tiledgrid": "tiled"}
VIEW_DIRECTIONS = {"down": ((0.0, 0.0, -1.0),),
                   "mean": ((1.0, 0, 0), (-1.0, 0, 0), (0, 1.0, 0), (0, -1.0, 0), (0, 0, 1.0),
                            (0, 0, -1.0))}


# ----------------------------------------------------------------------------------- reading

def read_snapshot(path: Path) -> dict:
    """The msgpack tree of a snapshot (gzip, zlib or plain msgpack, told by the first bytes)."""
    import msgpack

    try:
        raw = path.read_bytes()
    except OSError as exc:
        raise DreamPrintError(f"cannot read: {exc.strerror or exc}", path) from None
    if not raw:
        raise DreamPrintError("empty file", path)
    limit = MAX_EXPANSION * len(raw) + (1 << 20)
    try:
        if raw[:2] == b"\x1f\x8b":
            raw = gzip.decompress(raw)
        elif raw[0] == 0x78 and (raw[0] * 256 + raw[1]) % 31 == 0:
            raw = zlib.decompress(raw)
    except (OSError, EOFError, zlib.error) as exc:
        raise DreamPrintError(f"damaged compressed snapshot: {exc}", path) from None
    if len(raw) > limit:
        raise DreamPrintError("the snapshot expands beyond any plausible size", path)
    try:
        tree = msgpack.unpackb(raw, raw=False, strict_map_key=False)
    except Exception as exc:  # noqa: BLE001 - msgpack raises assorted types on bad input
        raise DreamPrintError(f"not an InstantNGP snapshot (msgpack: {exc})", path) from None
    if not isinstance(tree, dict) or not isinstance(tree.get("snapshot"), dict):
        raise DreamPrintError("not an InstantNGP snapshot (no 'snapshot' map)", path)
    return tree


def _next_multiple(v: int, m: int) -> int:
    return (v + m - 1) // m * m


def _lower(v) -> str:
    return str(v).lower()


def _vec3(v, what, path) -> np.ndarray:
    a = np.asarray(v, float).reshape(-1)
    if a.shape != (3,) or not np.all(np.isfinite(a)):
        raise DreamPrintError(f"snapshot field {what} must be three numbers, got {v!r}", path)
    return a


def _box(v, what, path) -> tuple[np.ndarray, np.ndarray]:
    if not isinstance(v, dict) or "min" not in v or "max" not in v:
        raise DreamPrintError(f"snapshot field {what} must be a {{min, max}} box", path)
    return _vec3(v["min"], what + ".min", path), _vec3(v["max"], what + ".max", path)


@dataclass
class Mlp:
    """A bias-free tiny-cuda-nn MLP: ``mats`` flat float32, ``shapes`` (n_layers, 2) out, in."""

    otype: str
    width: int
    n_hidden_layers: int
    activation: str
    output_activation: str
    mats: np.ndarray
    shapes: np.ndarray

    @property
    def n_params(self) -> int:
        return int(np.prod(self.shapes, axis=1).sum())

    def matrices(self) -> list[np.ndarray]:
        out, off = [], 0
        for o, i in self.shapes:
            out.append(self.mats[off:off + o * i].reshape(o, i))
            off += o * i
        return out


def _mlp_layout(cfg, n_in: int, n_out: int, what: str, path) -> Mlp:
    if not isinstance(cfg, dict):
        raise DreamPrintError(f"snapshot has no '{what}' configuration", path)
    otype = str(cfg.get("otype", "MLP"))
    if _lower(otype) not in MLP_TYPES:
        raise DreamPrintError(f"{what} type '{otype}' is not supported (FullyFusedMLP, "
                              "CutlassMLP, MegakernelMLP are)", path)
    width = int(cfg.get("n_neurons", 128))
    n_hidden = int(cfg.get("n_hidden_layers", 5))
    act = str(cfg.get("activation", "ReLU"))
    out_act = str(cfg.get("output_activation", "None"))
    for a in (act, out_act):
        if _lower(a) not in ACT:
            raise DreamPrintError(f"{what} activation '{a}' is not supported (None, ReLU, "
                                  "LeakyReLU, Exponential, Sigmoid, Tanh are)", path)
    if width < 1 or n_hidden < 0 or (n_hidden == 0 and _lower(otype) != "cutlassmlp" and
                                     _lower(otype) != "mlp"):
        raise DreamPrintError(f"{what}: {n_hidden} hidden layers of {width} neurons is not a "
                              "network tiny-cuda-nn builds", path)
    out_pad = _next_multiple(n_out, 16)
    if n_hidden == 0:
        shapes = [(out_pad, n_in)]
    else:
        shapes = [(width, n_in)] + [(width, width)] * (n_hidden - 1) + [(out_pad, width)]
    return Mlp(otype, width, n_hidden, act, out_act, np.empty(0, np.float32),
               np.asarray(shapes, np.int64))


@dataclass
class GridLayout:
    grid_type: str
    n_levels: int
    n_features: int
    log2_hashmap_size: int
    base_resolution: int
    per_level_scale: float
    interpolation: str
    scales: np.ndarray          # float32 per level
    resolutions: np.ndarray     # int64 per level
    offsets: np.ndarray         # int64 (levels + 1), in entries
    hashed: np.ndarray          # uint8 per level
    table: np.ndarray           # float32 (entries, F)

    @property
    def n_params(self) -> int:
        return int(self.offsets[-1]) * self.n_features


def _grid_layout(enc, aabb_scale: int, path) -> GridLayout:
    if not isinstance(enc, dict):
        raise DreamPrintError("snapshot has no 'encoding' configuration", path)
    otype = str(enc.get("otype", "OneBlob"))
    if _lower(otype) not in GRID_TYPES:
        raise DreamPrintError(f"position encoding '{otype}' is not supported (HashGrid, "
                              "DenseGrid, TiledGrid are)", path)
    n_feat = int(enc.get("n_features_per_level", 2))
    if n_feat not in (1, 2, 4, 8):
        raise DreamPrintError(f"n_features_per_level {n_feat} is not one tiny-cuda-nn builds "
                              "(1, 2, 4, 8)", path)
    if "n_features" in enc or "n_grid_features" in enc:
        n_levels = int(enc.get("n_features", enc.get("n_grid_features"))) // n_feat
    else:
        n_levels = int(enc.get("n_levels", 16))
    if not 1 <= n_levels <= 128:
        raise DreamPrintError(f"{n_levels} encoding levels is out of range", path)
    log2_t = int(enc.get("log2_hashmap_size", 19))
    base = int(enc.get("base_resolution", 0)) or (1 << (int(enc.get("log2_hashmap_size", 15))
                                                        // 3))
    pls = float(enc.get("per_level_scale", 0.0))
    if pls <= 0.0:
        pls = float(np.exp(np.float32(np.log(np.float32(2048.0 * aabb_scale) / np.float32(base)))
                           / np.float32(n_levels - 1))) if n_levels > 1 else 2.0
    gtype = _lower(enc.get("type", {"hash": "Hash", "dense": "Dense", "tiled": "Tiled"}[
        GRID_TYPES[_lower(otype)]]))
    if gtype not in ("hash", "dense", "tiled"):
        raise DreamPrintError(f"grid type '{gtype}' is not supported (Hash, Dense, Tiled)", path)
    interp = _lower(enc.get("interpolation", "Linear"))
    if interp not in ("linear", "smoothstep", "nearest"):
        raise DreamPrintError(f"grid interpolation '{interp}' is not supported", path)
    hash_type = _lower(enc.get("hash", "CoherentPrime"))
    if hash_type != "coherentprime":
        raise DreamPrintError(f"hash '{hash_type}' is not supported (CoherentPrime is)", path)
    if enc.get("fixed_point_pos", False):
        raise DreamPrintError("fixed-point grid positions are not supported", path)
    if not 1 <= log2_t <= 30 or base < 1:
        raise DreamPrintError("hash table size or base resolution out of range", path)
    log2_pls = np.float32(np.log2(np.float32(pls)))
    scales = np.empty(n_levels, np.float32)
    res = np.empty(n_levels, np.int64)
    offsets = np.zeros(n_levels + 1, np.int64)
    hashed = np.zeros(n_levels, np.uint8)
    max_params = np.iinfo(np.uint32).max // 2
    for lvl in range(n_levels):
        s = np.float32(np.exp2(np.float32(lvl) * log2_pls) * np.float32(base) - np.float32(1.0))
        r = int(math.ceil(float(s))) + 1
        scales[lvl], res[lvl] = s, r
        n = max_params if float(r) ** 3 > max_params else r ** 3
        n = _next_multiple(n, 8)
        if gtype == "tiled":
            n = min(n, base ** 3)
        elif gtype == "hash":
            n = min(n, 1 << log2_t)
        offsets[lvl + 1] = offsets[lvl] + n
        # grid_index: dense index while it fits (res <= 1625 and the table holds res^3)
        stride = r ** 3 if r <= 0x659 else 0xFFFFFFFF
        hashed[lvl] = 1 if (gtype == "hash" and n < stride) else 0
    return GridLayout(gtype, n_levels, n_feat, log2_t, base, pls, interp, scales, res, offsets,
                      hashed, np.empty((0, n_feat), np.float32))


def _dir_encoding(cfg, path) -> int:
    """SH degree of the direction encoding (SphericalHarmonics, alone or as the only nested
    encoding of a Composite with no extra dimensions)."""
    if not isinstance(cfg, dict):
        raise DreamPrintError("snapshot has no 'dir_encoding' configuration", path)
    otype = _lower(cfg.get("otype", ""))
    if otype == "sphericalharmonics":
        sh = cfg
    elif otype == "composite":
        nested = [n for n in cfg.get("nested", []) if isinstance(n, dict)]
        sh_list = [n for n in nested if _lower(n.get("otype")) == "sphericalharmonics"]
        if len(sh_list) != 1 or int(sh_list[0].get("n_dims_to_encode", 3)) != 3:
            raise DreamPrintError("direction encoding: only a Composite holding one "
                                  "SphericalHarmonics of the 3 direction dims is supported", path)
        sh = sh_list[0]
    else:
        raise DreamPrintError(f"direction encoding '{cfg.get('otype')}' is not supported "
                              "(SphericalHarmonics is)", path)
    degree = int(sh.get("degree", 4))
    if not 1 <= degree <= 8:
        raise DreamPrintError(f"spherical-harmonics degree {degree} is out of range", path)
    if otype == "composite" and (degree * degree) % 16:
        raise DreamPrintError(f"a Composite direction encoding of SH degree {degree} (padded) "
                              "is not supported; degree 4 is", path)
    return degree


def sh_encode(d: np.ndarray, degree: int) -> np.ndarray:
    """Real spherical harmonics of unit direction ``d`` (3,) up to ``degree`` (degree^2 values),
    tiny-cuda-nn's ``sh_enc`` for degrees 1-4 (its constants; instant-ngp uses degree 4)."""
    x, y, z = (float(v) for v in d)
    xy, xz, yz, x2, y2, z2 = x * y, x * z, y * z, x * x, y * y, z * z
    v = [0.28209479177387814,
         -0.48860251190291987 * y, 0.48860251190291987 * z, -0.48860251190291987 * x,
         1.0925484305920792 * xy, -1.0925484305920792 * yz,
         0.94617469575755997 * z2 - 0.31539156525251999, -1.0925484305920792 * xz,
         0.54627421529603959 * x2 - 0.54627421529603959 * y2,
         0.59004358992664352 * y * (-3.0 * x2 + y2), 2.8906114426405538 * xy * z,
         0.45704579946446572 * y * (1.0 - 5.0 * z2), 0.3731763325901154 * z * (5.0 * z2 - 3.0),
         0.45704579946446572 * x * (1.0 - 5.0 * z2), 1.4453057213202769 * z * (x2 - y2),
         0.59004358992664352 * x * (-x2 + 3.0 * y2)]
    if degree > 4:
        raise ValueError("SH degree above 4 is not implemented")
    return np.asarray(v[:degree * degree], np.float64)


@dataclass
class IngpModel:
    """Everything :func:`.kernels.sample_rows` needs, plus what ``inspect`` reports."""

    grid: GridLayout
    density: Mlp
    colour: Mlp
    sh_degree: int
    dir_width: int                  # padded direction-encoding width
    dens_out_width: int             # padded density-MLP output width
    aabb: tuple[np.ndarray, np.ndarray]
    render_box: tuple[np.ndarray, np.ndarray]
    render_R: np.ndarray
    scale: float
    offset: np.ndarray
    cycle: np.ndarray               # 3x3: q = cycle @ (p * scale + offset)
    is_hdr: bool
    aabb_scale: int
    max_cascade: int
    occupancy: np.ndarray | None    # uint8 (mips, 128, 128, 128) [mip, z, y, x] or None
    occupied_fraction: list[float]
    n_params: int
    params_type: str
    training_step: int | None

    def to_ngp(self) -> tuple[np.ndarray, np.ndarray]:
        """(A, t) with ``q = A p + t`` (p source, q instant-ngp)."""
        return self.cycle * self.scale, self.cycle @ self.offset

    def source_bounds(self) -> tuple[tuple[float, ...], tuple[float, ...]]:
        """Source-space box holding the render box (turned) intersected with the aabb."""
        lo, hi = self.render_box
        corners = np.array([[(hi if (c >> a) & 1 else lo)[a] for a in range(3)]
                            for c in range(8)])
        world = corners @ np.linalg.inv(self.render_R).T    # R^-1 c: in instant-ngp space
        wlo = np.maximum(world.min(0), self.aabb[0])
        whi = np.minimum(world.max(0), self.aabb[1])
        if np.any(whi <= wlo):
            raise DreamPrintError("the render box and the aabb do not overlap")
        cs = np.array([[(whi if (c >> a) & 1 else wlo)[a] for a in range(3)] for c in range(8)])
        A, t = self.to_ngp()
        src = np.linalg.solve(A, (cs - t).T).T
        return tuple(float(v) for v in src.min(0)), tuple(float(v) for v in src.max(0))


def _morton_order() -> np.ndarray:
    """Index into a Morton-ordered 128^3 grid of cell [z, y, x] (tiny-cuda-nn ``morton3D``)."""
    def expand(v):
        v = v.astype(np.uint32)
        v = (v * np.uint32(0x00010001)) & np.uint32(0xFF0000FF)
        v = (v * np.uint32(0x00000101)) & np.uint32(0x0F00F00F)
        v = (v * np.uint32(0x00000011)) & np.uint32(0xC30C30C3)
        v = (v * np.uint32(0x00000005)) & np.uint32(0x49249249)
        return v
    i = np.arange(GRID_SIZE, dtype=np.uint32)
    ex = expand(i)
    return (ex[None, None, :] | (ex[None, :, None] << 1) | (ex[:, None, None] << 2)).astype(
        np.int64)


def _binary(v, what, path) -> bytes:
    if isinstance(v, (bytes, bytearray, memoryview)):
        return bytes(v)
    if isinstance(v, dict) and isinstance(v.get("bytes"), list):  # nlohmann's JSON form
        return bytes(bytearray(int(b) & 0xFF for b in v["bytes"]))
    raise DreamPrintError(f"snapshot field {what} is not binary data", path)


def parse_snapshot(tree: dict, path) -> IngpModel:
    """Check a snapshot's configuration and cut its parameters into the model's pieces."""
    snap = tree["snapshot"]
    mode = _lower(snap.get("mode", "nerf" if "nerf" in snap else "none"))
    if mode != "nerf":
        raise DreamPrintError(f"an InstantNGP '{mode}' snapshot is not a radiance field "
                              "(DreamPrint reads NeRF snapshots)", path)
    if int(snap.get("version", 0)) < 1:
        raise DreamPrintError("snapshot format older than instant-ngp's version 1", path)
    nerf = snap.get("nerf") if isinstance(snap.get("nerf"), dict) else {}
    ds = nerf.get("dataset") if isinstance(nerf.get("dataset"), dict) else {}
    aabb_scale = int(nerf.get("aabb_scale", ds.get("aabb_scale", 1)))
    if not 1 <= aabb_scale <= 128:
        raise DreamPrintError(f"aabb_scale {aabb_scale} is out of range (1-128)", path)
    if int(ds.get("n_extra_learnable_dims", 0)):
        raise DreamPrintError("snapshots with per-image latent codes (n_extra_learnable_dims) "
                              "are not supported", path)
    net = tree.get("network")
    grid = _grid_layout(tree.get("encoding"), aabb_scale, path)
    align = 16 if _lower((net or {}).get("otype", "")) in ("fullyfusedmlp", "megakernelmlp") \
        else 8
    enc_width = _next_multiple(grid.n_levels * grid.n_features, align)
    dens_out = int((net or {}).get("n_output_dims", 16)) if isinstance(net, dict) else 16
    density = _mlp_layout(net, enc_width, dens_out, "density network", path)
    sh_degree = _dir_encoding(tree.get("dir_encoding"), path)
    dir_width = _next_multiple(sh_degree * sh_degree, 16)
    dens_w = _next_multiple(dens_out, 16)
    colour = _mlp_layout(tree.get("rgb_network"), _next_multiple(dens_w + dir_width, 16), 3,
                         "colour network", path)
    # parameters: density MLP, colour MLP, position encoding, direction encoding (none)
    ptype = str(snap.get("params_type", "__half"))
    dtype = {"__half": "<f2", "float": "<f4"}.get(ptype)
    if dtype is None:
        raise DreamPrintError(f"params_type '{ptype}' is not supported (__half, float)", path)
    blob = _binary(snap.get("params_binary"), "params_binary", path)
    params = np.frombuffer(blob, dtype, len(blob) // np.dtype(dtype).itemsize)
    need = density.n_params + colour.n_params + grid.n_params
    n_params = int(snap.get("n_params", params.size))
    if params.size != need or n_params != need:
        raise DreamPrintError(f"the snapshot holds {params.size:,} parameters (n_params "
                              f"{n_params:,}) but its configuration needs {need:,}: damaged, or "
                              "a layout DreamPrint does not know", path)
    p32 = params.astype(np.float32)
    if not np.all(np.isfinite(p32)):
        raise DreamPrintError("the snapshot's parameters hold NaN or infinite values", path)
    o = 0
    density.mats = np.ascontiguousarray(p32[o:o + density.n_params])
    o += density.n_params
    colour.mats = np.ascontiguousarray(p32[o:o + colour.n_params])
    o += colour.n_params
    grid.table = np.ascontiguousarray(p32[o:o + grid.n_params].reshape(-1, grid.n_features))
    # placement
    default = (np.full(3, 0.5 - 0.5 * min(128, aabb_scale)), np.full(3, 0.5 + 0.5 *
                                                                     min(128, aabb_scale)))
    aabb = _box(snap["aabb"], "aabb", path) if "aabb" in snap else default
    render = _box(snap["render_aabb"], "render_aabb", path) if "render_aabb" in snap else aabb
    R = np.asarray(snap.get("render_aabb_to_local", np.eye(3)), float)
    if R.shape != (3, 3) or not np.all(np.isfinite(R)):
        raise DreamPrintError("render_aabb_to_local must be a 3x3 matrix", path)
    if np.any(aabb[1] <= aabb[0]):
        raise DreamPrintError("the snapshot's aabb is empty", path)
    scale = float(ds.get("scale", 1.0))
    offset = _vec3(ds.get("offset", [0.0, 0.0, 0.0]), "dataset.offset", path)
    if not (math.isfinite(scale) and scale != 0):
        raise DreamPrintError(f"dataset scale must be a non-zero number, got {scale}", path)
    cycle = np.eye(3) if ds.get("from_mitsuba", False) else np.array(
        [[0.0, 1, 0], [0, 0, 1], [1, 0, 0]])
    # occupancy grid (density_grid_binary, Morton order per cascade)
    max_cascade = 0
    while (1 << max_cascade) < aabb_scale:
        max_cascade += 1
    occ = None
    frac: list[float] = []
    if "density_grid_binary" in snap:
        dg = np.frombuffer(_binary(snap["density_grid_binary"], "density_grid_binary", path),
                           "<f2").astype(np.float32)
        n_cells = GRID_SIZE ** 3
        if dg.size:
            if int(snap.get("density_grid_size", GRID_SIZE)) != GRID_SIZE or \
                    dg.size != n_cells * (max_cascade + 1):
                raise DreamPrintError(f"density grid of {dg.size:,} values does not fit "
                                      f"{max_cascade + 1} cascades of 128^3", path)
            dg = np.nan_to_num(dg, nan=0.0, posinf=np.inf, neginf=0.0)
            thresh = min(MIN_OPTICAL_THICKNESS, float(np.maximum(dg[:n_cells], 0).mean()))
            order = _morton_order()
            occ = np.empty((max_cascade + 1, GRID_SIZE, GRID_SIZE, GRID_SIZE), np.uint8)
            for m in range(max_cascade + 1):
                occ[m] = dg[m * n_cells:(m + 1) * n_cells][order] > thresh
                frac.append(float(occ[m].mean()))
    step = snap.get("training_step")
    return IngpModel(grid, density, colour, sh_degree, dir_width, dens_w, aabb, render, R, scale,
                     offset, cycle, bool(ds.get("is_hdr", False)), aabb_scale, max_cascade, occ,
                     frac, need, ptype, None if step is None else int(step))


# ------------------------------------------------------------------------------------ source

def _parse_view(view) -> tuple[str, np.ndarray]:
    if isinstance(view, str) and view.strip().lower() in VIEW_DIRECTIONS:
        key = view.strip().lower()
        return key, np.asarray(VIEW_DIRECTIONS[key], float)
    try:
        parts = view.split(",") if isinstance(view, str) else list(view)
        d = np.asarray([float(v) for v in parts], float)
    except (TypeError, ValueError):
        d = np.zeros(0)
    if d.shape != (3,) or not np.all(np.isfinite(d)) or np.linalg.norm(d) == 0:
        raise DreamPrintError(f"view must be 'down', 'mean' or a direction 'x,y,z', got {view!r}")
    return "direction", (d / np.linalg.norm(d))[None, :]


class IngpSource:
    """An InstantNGP NeRF snapshot as a :class:`~.base.VolumeSource` (see the module docstring).

    ``view``: ``"down"`` (default), ``"mean"`` or ``"x,y,z"``; ``occupancy``: skip cells the
    snapshot's occupancy grid marks empty (default, as instant-ngp renders); ``threads``: row
    groups sampled at once by one call (default: every core when called from the main thread
    of the main process, else 1: a print job's workers already run one slab per core).
    """

    def __init__(self, name: str, model: IngpModel, *, view="down", occupancy: bool = True,
                 threads: int | None = None, colour_encoding: str | None = None):
        self.name = name
        self.model = model
        self.format = "InstantNGP snapshot"
        self.view_kind, dirs_src = _parse_view(view)
        self.view_dirs = dirs_src
        self.occupancy = bool(occupancy) and model.occupancy is not None
        self.threads = threads
        enc = colour_encoding or ("linear" if model.is_hdr else "srgb")
        if enc not in ("srgb", "linear"):
            raise DreamPrintError(f"colour_encoding must be 'srgb' or 'linear', got {enc!r}")
        self.colour_encoding = enc
        self.bounds = model.source_bounds()
        A, t = model.to_ngp()
        self._A = np.ascontiguousarray(A, np.float64)
        self._t = np.ascontiguousarray(t, np.float64)
        # direction constants of the colour MLP's first layer (module docstring, step 4)
        lin = A / np.linalg.norm(A[:, 0])          # direction map: the rotation part of A
        first = model.colour.matrices()[0]
        dw = model.dens_out_width
        consts = []
        for d in dirs_src:
            dq = lin @ d
            dq /= np.linalg.norm(dq)
            sh = sh_encode(dq, model.sh_degree)
            enc_dir = np.concatenate([np.ones(model.dir_width - sh.size), sh])
            consts.append(first[:, dw:dw + model.dir_width].astype(np.float64) @ enc_dir)
        self._dir_consts = np.ascontiguousarray(np.asarray(consts), np.float32)
        self._first_a = np.ascontiguousarray(first[:, :dw], np.float32)
        self._occ = model.occupancy if self.occupancy else np.zeros((1, 1, 1, 1), np.uint8)

    def _kernel_args(self, sigma_factor: float, colour_cut: float = 0.0):
        m = self.model
        g = m.grid
        return (self._A, self._t, np.asarray(m.aabb[0], float), np.asarray(m.aabb[1], float),
                np.ascontiguousarray(m.render_R, float), np.asarray(m.render_box[0], float),
                np.asarray(m.render_box[1], float), self._occ, self.occupancy, m.max_cascade,
                g.table, g.n_features, g.offsets, g.scales, g.resolutions, g.hashed,
                {"linear": 0, "smoothstep": 1, "nearest": 2}[g.interpolation],
                int(m.density.shapes[0, 1]),
                m.density.mats, m.density.shapes, ACT[_lower(m.density.activation)],
                ACT[_lower(m.density.output_activation)],
                m.colour.mats, m.colour.shapes, ACT[_lower(m.colour.activation)],
                ACT[_lower(m.colour.output_activation)], self._first_a, self._dir_consts,
                1 if m.is_hdr else 0, float(sigma_factor), np.float32(colour_cut))

    def evaluate(self, xs, ys, zs, sigma_factor: float = 1.0, threads: int = 1):
        """(rgb (nz, ny, nx, 3) as the network gives it, density (nz, ny, nx) in instant-ngp's
        units times ``sigma_factor``) at the source points ``xs`` x ``ys`` x ``zs``."""
        xs, ys, zs = (np.ascontiguousarray(v, np.float64) for v in (xs, ys, zs))
        sigma = np.empty((zs.size, ys.size, xs.size), np.float32)
        rgb = np.empty(sigma.shape + (3,), np.float32)
        self._run(xs, ys, zs, sigma_factor, sigma, rgb, threads)
        return rgb, sigma

    def _line_axis(self, xs, ys) -> int:
        """The source axis (0 x, 1 y) the kernel runs its lines along: of those along which
        one instant-ngp coordinate varies over increasing voxel centres, the one with the
        finer step in the encoding's coordinate (more coarse levels a line at a time, longer
        lines); x on a tie.  Depends on the grid alone: every thread makes the same choice."""
        ext = np.asarray(self.model.aabb[1], float) - np.asarray(self.model.aabb[0], float)
        best, best_du = 0, math.inf
        for la, c in ((0, xs), (1, ys)):
            col = self._A[:, la]
            nz = np.flatnonzero(col)
            if nz.size != 1 or c.size < 2 or not np.all(np.diff(c) > 0):
                continue
            du = abs(col[nz[0]]) * float(np.max(np.diff(c))) / ext[nz[0]]
            if du < best_du:
                best, best_du = la, du
        return best

    def _run(self, xs, ys, zs, sigma_factor, sigma, rgb, threads, colour_cut=0.0):
        args = self._kernel_args(sigma_factor, colour_cut)
        la = self._line_axis(xs, ys)
        rows = zs.size * (ys.size if la == 0 else xs.size)
        if la == 1:             # one contiguous pass, not a column's voxels a row apart
            sigma.fill(0.0)
            rgb.fill(0.0)
        n = max(1, min(int(threads), rows))
        if n == 1:
            sample_rows(0, rows, la, xs, ys, zs, *args, sigma, rgb)
            return
        # interleaved chunks of rows: occupied regions spread over the threads
        chunk = max(1, min(64, rows // (8 * n)))
        starts = list(range(0, rows, chunk))
        with ThreadPoolExecutor(n) as ex:
            futs = [ex.submit(sample_rows, s, min(rows, s + chunk), la, xs, ys, zs, *args, sigma,
                              rgb) for s in starts]
            for f in futs:
                f.result()

    def _threads(self) -> int:
        if self.threads is not None:
            return max(1, int(self.threads))
        import multiprocessing

        if threading.current_thread() is threading.main_thread() and \
                multiprocessing.parent_process() is None:
            return os.cpu_count() or 1
        return 1                # a job's worker thread or process: the job uses the cores

    def sample_slab(self, grid: PrintGrid, z0: int, z1: int, *, density_scale: float = 1.0,
                    out: SlabBuffers | None = None):
        check_slab(grid, z0, z1)
        xs = voxel_centres(grid, 0)
        ys = voxel_centres(grid, 1)
        zs = voxel_centres(grid, 2, z0, z1)
        shape = (zs.size, ys.size, xs.size)
        if out is not None:
            rgb, sigma = out.take(shape)
        else:
            sigma = np.empty(shape, np.float32)
            rgb = np.empty(shape + (3,), np.float32)
        factor = abs(self.model.scale) * density_scale / grid.mm_per_unit
        # a consumer that reads colour only where the density reaches its threshold: the
        # colour network runs only there (SlabBuffers.colour_threshold)
        cut = out.colour_threshold if out is not None and out.colour_where_dense else 0.0
        self._run(xs, ys, zs, factor, sigma, rgb, self._threads(), cut)
        if self.colour_encoding == "linear":
            rgb = linear_to_srgb(rgb)
        else:
            np.clip(rgb, 0.0, 1.0, out=rgb)
        return rgb, sigma

    def info(self) -> dict:
        return snapshot_info(self.model, self.bounds, self.view_kind, self.view_dirs,
                             self.occupancy, self.colour_encoding)


def snapshot_info(m: IngpModel, bounds, view_kind: str, view_dirs, occupancy: bool,
                  colour_encoding: str) -> dict:
    g = m.grid
    finest = int(g.resolutions[-1])
    hashed = int(g.hashed.sum())

    def mlp(n: Mlp) -> dict:
        return {"type": n.otype, "neurons": n.width, "hidden_layers": n.n_hidden_layers,
                "activation": n.activation, "output_activation": n.output_activation}

    if view_kind == "down":
        view = "one view: looking down the source z axis (direction 0,0,-1)"
    elif view_kind == "mean":
        view = "mean over the 6 view directions +-x, +-y, +-z"
    else:
        view = "one view: direction " + ",".join(f"{v:.4g}" for v in view_dirs[0])
    return {
        "format": "InstantNGP snapshot",
        "kind": "NeRF (instant-ngp): density and colour networks evaluated per voxel",
        "encoding": {"type": g.grid_type, "levels": g.n_levels,
                     "features_per_level": g.n_features,
                     "log2_hashmap_size": g.log2_hashmap_size,
                     "base_resolution": g.base_resolution,
                     "per_level_scale": round(g.per_level_scale, 6),
                     "finest_resolution": finest, "hashed_levels": hashed,
                     "interpolation": g.interpolation},
        "density_network": mlp(m.density),
        "colour_network": mlp(m.colour),
        "direction_encoding": f"spherical harmonics, degree {m.sh_degree}",
        "parameters": m.n_params, "params_type": m.params_type,
        "training_step": m.training_step,
        "aabb": bounds_list(m.aabb), "render_aabb": bounds_list(m.render_box),
        "aabb_scale": m.aabb_scale,
        "dataset_scale": m.scale, "dataset_offset": [float(v) for v in m.offset],
        "occupancy_grid": ({"cascades": m.max_cascade + 1,
                            "occupied_fraction": [round(f, 6) for f in m.occupied_fraction],
                            "used": bool(occupancy)} if m.occupancy is not None else None),
        "colour": (f"{'HDR, linear' if m.is_hdr else 'LDR, sRGB-encoded'} "
                   f"({colour_encoding} used), {view}"),
        "density_units": "instant-ngp sigma x |dataset scale| per source unit",
        "bounds": bounds_list(bounds),
    }


def open_path(path: Path, fmt: str = "instant-ngp", *, view="down", occupancy: bool = True,
              threads: int | None = None, colour_encoding: str | None = None) -> IngpSource:
    """Open an InstantNGP snapshot (see the module docstring for the options)."""
    model = parse_snapshot(read_snapshot(path), path)
    try:
        return IngpSource(str(path), model, view=view, occupancy=occupancy, threads=threads,
                          colour_encoding=colour_encoding)
    except DreamPrintError as exc:
        if exc.path is None:
            raise DreamPrintError(exc.problem, path) from None
        raise
