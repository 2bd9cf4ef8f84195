"""Gaussian-splat exchange formats other than PLY: antimatter15 ``.splat``, GaussianSplats3D
``.ksplat``, Niantic SPZ (v1-v4) and PlayCanvas SOG.

Defines :func:`decode_splat`, :func:`decode_ksplat`, :func:`decode_spz` and
:func:`decode_sog`, each returning the activated Gaussians (:class:`Gaussians`: means, axis
sigmas, unit quaternions w-x-y-z, opacity, colour) that :class:`~.splats.GaussianCloud` samples
exactly as it samples an INRIA PLY: colour ``0.5 + C0 * f_dc`` (what 8-bit colour bytes store
directly), opacity after the sigmoid (what 8-bit alpha bytes store directly), covariance
``R diag(sigma^2) R^T``.

Layouts, from each format's published source:

- ``.splat`` (antimatter15/splat, ``convert.py``; PlayCanvas splat-transform
  ``read-splat.ts``): no header, 32-byte little-endian records: position float32 x3, linear
  scale float32 x3, colour+alpha uint8 x4 (``255 * (0.5 + C0 f_dc)`` and ``255 *
  sigmoid(opacity)``), rotation uint8 x4 (w, x, y, z) stored as ``q * 128 + 128`` of the unit
  quaternion, decoded ``(v - 128) / 128`` and renormalised.
- ``.ksplat`` (mkkellogg/GaussianSplats3D ``src/loaders/SplatBuffer.js``, format 0.1): a
  4096-byte header (uint8 major 0 / minor >= 1; uint32 [1] max section count, [2] section
  count, [3] max splat count, [4] splat count; uint16 [10] compression level 0/1/2; float32
  [9], [10] the 8-bit SH range), then one 1024-byte header per section (uint32 [0] splat count,
  [1] max splat count, [2] bucket size, [3] bucket count, float32 [4] bucket block size, uint16
  [10] bytes per bucket, uint32 [6] position quantisation range, [8] full buckets, [9] partial
  buckets, uint16 [20] SH degree), then per section the partial-bucket sizes (uint32 each),
  the bucket centres (float32 x3 each) and ``max splat count`` records: level 0 float32
  centre x3, scale x3, rotation x4 (w, x, y, z), RGBA uint8 x4, SH float32; levels 1 and 2
  uint16 centre x3 (``(v - range) * block / 2 / range + bucket centre``), float16 scale x3 and
  rotation x4, RGBA uint8 x4, SH float16 (level 1) or uint8 (level 2).
- SPZ (nianticlabs/spz ``src/cc/load-spz.cc``, ``splat-utils.h``): v1-v3 one gzip stream
  holding a 16-byte header (uint32 magic ``NGSP``, version, point count; uint8 SH degree,
  fractional bits, flags, reserved) and the sections positions (v1 float16 x3, else 24-bit
  signed fixed point x3 with ``fractional bits``), alphas (``255 sigmoid(o)``), colours
  (``f_dc * 0.15 * 255 + 127.5``), scales (``(ln s + 10) * 16``), rotations (v1-v2: x, y, z
  as ``q * 127.5 + 127.5`` with w >= 0 implied; v3+: "smallest three", 2 + 3 x 10 bits),
  SH; v4 a plain 32-byte header (..., uint8 stream count, uint32 table offset, 12 reserved),
  extensions, a table of (compressed, uncompressed) uint64 sizes and one zstd stream per
  non-empty section in the same order (``zstandard`` decodes them). Rotations are stored
  x, y, z, w. Coordinates are taken as stored (the library's default,
  ``CoordinateSystem::UNSPECIFIED``, as PlayCanvas's reader does); extensions are skipped.
  gsply is not used for SPZ: it reads v1's float16 positions as fixed point.
- SOG (PlayCanvas splat-transform ``read-sog.ts``): a ``.sog`` zip, a folder holding
  ``meta.json`` or that ``meta.json`` itself, read through ``gsply.sogread`` (v2 codebooks and
  the earlier min/max layout; WebP textures decoded with ``imagecodecs``).

Damaged files get one line naming the problem: a size that does not match what the header
announces is reported as ``truncated: the header announces N bytes ..., the file has M``.
"""

from __future__ import annotations

import struct
import zlib
from pathlib import Path
from typing import NamedTuple

import numpy as np

from dreamprint_gui.core.errors import DreamPrintError

__all__ = ["Gaussians", "decode_splat", "decode_ksplat", "decode_spz", "decode_sog",
           "is_sog"]

SH_C0 = 0.28209479177387814
_SPLAT_RECORD = np.dtype([("pos", "<f4", 3), ("scale", "<f4", 3), ("rgba", "u1", 4),
                          ("rot", "u1", 4)])


class Gaussians(NamedTuple):
    """Decoded, activated Gaussians: (N, 3) means, (N, 3) axis sigmas, (N, 4) quaternions
    (w, x, y, z; not necessarily normalised), (N,) opacity in [0, 1], (N, 3) colour
    ``0.5 + C0 * f_dc`` (may leave [0, 1]), the SH degree and the format's name."""

    means: np.ndarray
    sigmas: np.ndarray
    quats: np.ndarray
    opacity: np.ndarray
    rgb: np.ndarray
    sh_degree: int
    format: str


def _from_gsply(data, fmt: str) -> Gaussians:
    shn = getattr(data, "shN", None)
    n = len(data.means)
    k = 0 if shn is None else int(np.asarray(shn).reshape(n, -1).shape[1] // 3)
    degree = {0: 0, 3: 1, 8: 2, 15: 3, 24: 4}.get(k, 0)
    return Gaussians(np.asarray(data.means, float), np.exp(np.asarray(data.scales, float)),
                     np.asarray(data.quats, float), _sigmoid(data.opacities).reshape(-1),
                     0.5 + SH_C0 * np.asarray(data.sh0, float).reshape(n, 3), degree, fmt)


def _sigmoid(x):
    return 1.0 / (1.0 + np.exp(-np.asarray(x, float)))


# ------------------------------------------------------------------------------ antimatter15

def decode_splat(path: Path) -> Gaussians:
    """An antimatter15 ``.splat`` file (32-byte records, no header)."""
    size = path.stat().st_size
    if size == 0:
        raise DreamPrintError("empty .splat file (no 32-byte records)", path)
    if size % _SPLAT_RECORD.itemsize:
        n, extra = divmod(size, _SPLAT_RECORD.itemsize)
        raise DreamPrintError(f"truncated or not a .splat file: {size:,} bytes is {n:,} whole "
                              f"32-byte records and {extra} byte(s) more", path)
    rec = np.fromfile(path, dtype=_SPLAT_RECORD)
    rgba = rec["rgba"].astype(float) / 255.0
    quats = (rec["rot"].astype(float) - 128.0) / 128.0
    return Gaussians(rec["pos"].astype(float), rec["scale"].astype(float), quats, rgba[:, 3],
                     rgba[:, :3], 0, "splats (antimatter15 .splat)")


# ------------------------------------------------------------------------------------ ksplat

_KSPLAT_HEADER = 4096
_KSPLAT_SECTION_HEADER = 1024
# (bytes per centre, scale, rotation, colour, SH component, default quantisation range)
_KSPLAT_LEVELS = {0: (12, 12, 16, 4, 4, 1), 1: (6, 6, 8, 4, 2, 32767),
                  2: (6, 6, 8, 4, 1, 32767)}
_SH_COMPONENTS = {0: 0, 1: 9, 2: 24, 3: 45}


def decode_ksplat(path: Path) -> Gaussians:
    """A GaussianSplats3D ``.ksplat`` file, compression level 0, 1 or 2 (see module doc)."""
    data = path.read_bytes()
    size = len(data)
    if size < _KSPLAT_HEADER:
        raise DreamPrintError(f"truncated: a .ksplat file starts with a {_KSPLAT_HEADER}-byte "
                              f"header, the file has {size:,} bytes", path)
    major, minor = data[0], data[1]
    if major != 0 or minor < 1:
        raise DreamPrintError(f"not a .ksplat file this reader knows (version {major}.{minor};"
                              " 0.1 or later 0.x is)", path)
    max_sections, _sections, _max_splats, n_splats = struct.unpack_from("<4I", data, 4)
    level = struct.unpack_from("<H", data, 20)[0]
    if level not in _KSPLAT_LEVELS:
        raise DreamPrintError(f"unknown compression level {level} (0, 1 or 2)", path)
    sh_min, sh_max = struct.unpack_from("<2f", data, 36)
    del sh_min, sh_max                       # SH bands beyond DC are not sampled
    c_b, s_b, r_b, col_b, sh_b, default_range = _KSPLAT_LEVELS[level]
    if max_sections > (size - _KSPLAT_HEADER) // _KSPLAT_SECTION_HEADER:
        raise DreamPrintError(f"truncated: the header announces {max_sections:,} sections "
                              f"({max_sections * _KSPLAT_SECTION_HEADER:,} bytes of section "
                              f"headers), the file has {size - _KSPLAT_HEADER:,} bytes after "
                              "the main header", path)
    sections = []
    base = _KSPLAT_HEADER + max_sections * _KSPLAT_SECTION_HEADER
    for i in range(max_sections):
        h = _KSPLAT_HEADER + i * _KSPLAT_SECTION_HEADER
        count, max_count, bucket_size, bucket_count = struct.unpack_from("<4I", data, h)
        block = struct.unpack_from("<f", data, h + 16)[0]
        bucket_bytes = struct.unpack_from("<H", data, h + 20)[0]
        q_range = struct.unpack_from("<I", data, h + 24)[0] or default_range
        full, partial = struct.unpack_from("<2I", data, h + 32)
        degree = struct.unpack_from("<H", data, h + 40)[0]
        if degree not in _SH_COMPONENTS:
            raise DreamPrintError(f"section {i}: SH degree {degree} (0-3 expected)", path)
        if count > max_count:
            raise DreamPrintError(f"section {i}: {count:,} splats but room for {max_count:,}",
                                  path)
        per = c_b + s_b + r_b + col_b + _SH_COMPONENTS[degree] * sh_b
        buckets_storage = bucket_bytes * bucket_count + partial * 4
        sections.append((base, count, bucket_size, bucket_count, block, q_range, full,
                         partial, per, degree, buckets_storage))
        base += buckets_storage + per * max_count
    if base > size:
        raise DreamPrintError(f"truncated: the header announces {base:,} bytes ({n_splats:,} "
                              f"splats in {max_sections} section(s)), the file has {size:,}",
                              path)
    if sum(s[1] for s in sections) != n_splats:
        raise DreamPrintError(f"the header announces {n_splats:,} splats but its sections hold "
                              f"{sum(s[1] for s in sections):,}", path)

    buf = np.frombuffer(data, dtype=np.uint8)
    parts = []
    max_degree = 0
    for i, (base, count, bsize, bcount, block, q_range, full, partial, per, degree,
            buckets_storage) in enumerate(sections):
        if count == 0:
            continue
        max_degree = max(max_degree, degree)
        meta = base
        centres_at = meta + partial * 4
        data_at = base + buckets_storage
        rec = buf[data_at:data_at + per * count].reshape(count, per)
        if level == 0:
            means = rec[:, 0:12].copy().view("<f4").astype(float)
            scales = rec[:, 12:24].copy().view("<f4").astype(float)
            quats = rec[:, 24:40].copy().view("<f4").astype(float)
            rgba = rec[:, 40:44].astype(float) / 255.0
        else:
            q = rec[:, 0:6].copy().view("<u2").astype(float)
            sizes = np.frombuffer(data, "<u4", partial, meta) if partial else np.zeros(0, int)
            bucket = np.concatenate([np.repeat(np.arange(full), bsize),
                                     np.repeat(full + np.arange(partial), sizes)])
            if bucket.size < count or (bcount and bucket.max(initial=0) >= bcount):
                raise DreamPrintError(f"section {i}: its buckets hold {bucket.size:,} splats, "
                                      f"the section announces {count:,}", path)
            centres = np.frombuffer(data, "<f4", bcount * 3, centres_at).reshape(-1, 3)
            means = (q - q_range) * (block / 2.0 / q_range) + centres[bucket[:count]]
            scales = rec[:, 6:12].copy().view("<f2").astype(float)
            quats = rec[:, 12:20].copy().view("<f2").astype(float)
            rgba = rec[:, 20:24].astype(float) / 255.0
        parts.append((means, scales, quats, rgba))
    if not parts:
        raise DreamPrintError("the .ksplat file holds no splats", path)
    means, scales, quats, rgba = (np.concatenate(p) for p in zip(*parts, strict=True))
    return Gaussians(means, scales, quats, rgba[:, 3], rgba[:, :3], max_degree,
                     f"splats (.ksplat, compression level {level})")


# --------------------------------------------------------------------------------------- SPZ

_NGSP = 0x5053474E
_SPZ_COLOUR_SCALE = 0.15
_SH_DIM = {0: 0, 1: 3, 2: 8, 3: 15, 4: 24}


def _spz_sizes(version: int, n: int, degree: int) -> list[int]:
    """Bytes of the positions, alphas, colours, scales, rotations and SH sections."""
    return [n * (6 if version == 1 else 9), n, 3 * n, 3 * n, n * (3 if version < 3 else 4),
            n * _SH_DIM[degree] * 3]


def _spz_header_checks(version: int, n: int, degree: int, fb: int, path: Path) -> None:
    if degree not in _SH_DIM:
        raise DreamPrintError(f"SH degree {degree} (0-4 expected)", path)
    if n == 0:
        raise DreamPrintError("the SPZ header announces no Gaussians", path)
    if version > 1 and not 0 <= fb <= 23:
        raise DreamPrintError(f"{fb} fractional bits for 24-bit positions", path)


def _spz_sections(path: Path) -> tuple[int, int, int, int, list[bytes]]:
    """(version, points, SH degree, fractional bits, the six attribute sections)."""
    raw = path.read_bytes()
    if raw[:2] == b"\x1f\x8b":
        d = zlib.decompressobj(16 + zlib.MAX_WBITS)
        try:
            payload = d.decompress(raw)
        except zlib.error as exc:
            raise DreamPrintError(f"damaged gzip stream in an SPZ file ({exc})", path) from None
        complete = d.eof
        if len(payload) < 16:
            raise DreamPrintError(f"truncated: the gzip stream holds {len(payload)} bytes, less "
                                  "than the 16-byte SPZ header", path)
        magic, version, n, degree, fb, _flags = struct.unpack_from("<IIIBBB", payload)
        if magic != _NGSP:
            raise DreamPrintError("not an SPZ file (no NGSP magic inside the gzip stream)", path)
        if not 1 <= version <= 3:
            raise DreamPrintError(f"SPZ version {version} in a gzip stream (1-3 expected)", path)
        _spz_header_checks(version, n, degree, fb, path)
        sizes = _spz_sizes(version, n, degree)
        need = 16 + sum(sizes)
        if need > len(payload):
            cut = "" if complete else " (the gzip stream itself is cut short)"
            raise DreamPrintError(f"truncated: the header announces {n:,} Gaussians ({need:,} "
                                  f"bytes unpacked), the file has {len(payload):,}{cut}", path)
        offsets = np.cumsum([16] + sizes)
        return version, n, degree, fb, [payload[a:b] for a, b in
                                        zip(offsets[:-1], offsets[1:], strict=True)]
    if len(raw) >= 4 and struct.unpack_from("<I", raw)[0] == _NGSP:
        if len(raw) < 32:
            raise DreamPrintError(f"truncated: an SPZ v4 header is 32 bytes, the file has "
                                  f"{len(raw)}", path)
        _m, version, n, degree, fb, _fl, streams, toc = struct.unpack_from("<IIIBBBBI", raw)
        if version < 4:
            raise DreamPrintError(f"an uncompressed SPZ file of version {version} (versions 1-3"
                                  " are gzip streams)", path)
        _spz_header_checks(version, n, degree, fb, path)
        sizes = _spz_sizes(version, n, degree)
        wanted = [k for k, size in enumerate(sizes) if size]
        if streams != len(wanted):
            raise DreamPrintError(f"the header lists {streams} streams; {n:,} Gaussians of SH "
                                  f"degree {degree} need {len(wanted)}", path)
        end = toc + 16 * streams
        if toc < 32 or end > len(raw):
            raise DreamPrintError(f"truncated: the header puts its table of {streams} streams "
                                  f"at bytes {toc:,}-{end:,}, the file has {len(raw):,}", path)
        table = struct.unpack_from(f"<{2 * streams}Q", raw, toc)
        need = end + sum(table[0::2])
        if need > len(raw):
            raise DreamPrintError(f"truncated: the header announces {n:,} Gaussians in "
                                  f"{need:,} bytes, the file has {len(raw):,}", path)
        import zstandard

        out = [b""] * 6
        at = end
        names = ("positions", "alphas", "colours", "scales", "rotations", "SH")
        for k, (csize, usize) in zip(wanted, zip(table[0::2], table[1::2], strict=True),
                                      strict=True):
            if usize != sizes[k]:
                raise DreamPrintError(f"the {names[k]} stream unpacks to {usize:,} bytes; "
                                      f"{n:,} Gaussians need {sizes[k]:,}", path)
            try:
                out[k] = zstandard.ZstdDecompressor().decompress(raw[at:at + csize],
                                                                 max_output_size=usize)
            except zstandard.ZstdError as exc:
                raise DreamPrintError(f"damaged zstd stream ({names[k]}): {exc}", path) from None
            if len(out[k]) != usize:
                raise DreamPrintError(f"the {names[k]} stream unpacks to {len(out[k]):,} bytes, "
                                      f"not {usize:,}", path)
            at += csize
        return version, n, degree, fb, out
    raise DreamPrintError("not an SPZ file (neither a gzip stream nor an NGSP header)", path)


def _smallest_three(r: np.ndarray) -> np.ndarray:
    """SPZ v3+ rotations: 2 bits naming the largest component, three 10-bit signed magnitudes
    scaled by 1/sqrt(2), x-y-z-w order (load-spz / splat-utils unpackQuaternionSmallestThree)."""
    comp = r.astype(np.uint32) @ np.array([1, 1 << 8, 1 << 16, 1 << 24], dtype=np.uint32)
    largest = (comp >> 30).astype(int)
    q = np.zeros((len(comp), 4))
    for i in (3, 2, 1, 0):
        take = largest != i
        c = comp[take]
        v = np.sqrt(0.5) * (c & 511).astype(float) / 511.0
        q[take, i] = np.where((c >> 9) & 1, -v, v)
        comp[take] = c >> 10
    rows = np.arange(len(comp))
    q[rows, largest] = np.sqrt(np.maximum(0.0, 1.0 - np.sum(q * q, axis=1)))
    return q


def decode_spz(path: Path) -> Gaussians:
    """A Niantic SPZ file, any version (1-3 gzip, 4 zstd); coordinates as stored."""
    version, n, degree, fb, (pos, alpha, colour, scale, rot, _sh) = _spz_sections(path)
    if version == 1:
        means = np.frombuffer(pos, "<f2").reshape(n, 3).astype(float)
    else:
        b = np.frombuffer(pos, np.uint8).reshape(n * 3, 3).astype(np.int32)
        fixed = b[:, 0] | (b[:, 1] << 8) | (b[:, 2] << 16)
        fixed = np.where(fixed & 0x800000, fixed - (1 << 24), fixed)
        means = (fixed.astype(float) / (1 << fb)).reshape(n, 3)
    r = np.frombuffer(rot, np.uint8)
    if version < 3:
        xyz = r.reshape(n, 3).astype(float) / 127.5 - 1.0
        w = np.sqrt(np.maximum(0.0, 1.0 - np.sum(xyz * xyz, axis=1)))
        xyzw = np.column_stack([xyz, w])
    else:
        xyzw = _smallest_three(r.reshape(n, 4))
    quats = xyzw[:, [3, 0, 1, 2]]
    f_dc = (np.frombuffer(colour, np.uint8).reshape(n, 3) / 255.0 - 0.5) / _SPZ_COLOUR_SCALE
    sigmas = np.exp(np.frombuffer(scale, np.uint8).reshape(n, 3) / 16.0 - 10.0)
    opacity = np.frombuffer(alpha, np.uint8) / 255.0
    return Gaussians(means, sigmas, quats, opacity, 0.5 + SH_C0 * f_dc, degree,
                     f"splats (SPZ v{version})")


# --------------------------------------------------------------------------------------- SOG

def is_sog(path: Path) -> bool:
    """A ``.sog`` bundle, a ``meta.json`` of a SOG folder, or a folder holding one."""
    if path.is_dir():
        path = path / "meta.json"
    if path.name == "meta.json" and path.is_file():
        try:
            head = path.read_bytes()[:65536]
        except OSError:
            return False
        return b'"means"' in head and b'"quats"' in head
    return path.suffix.lower() == ".sog"


def decode_sog(path: Path) -> Gaussians:
    """A PlayCanvas SOG scene (``.sog`` zip, folder or ``meta.json``), through ``gsply``."""
    import zipfile

    import gsply

    target = path / "meta.json" if path.is_dir() else path
    if not target.exists():
        raise DreamPrintError("a SOG folder needs its meta.json", path)
    if target.suffix.lower() == ".sog" and not zipfile.is_zipfile(target):
        raise DreamPrintError("not a SOG bundle (not a zip archive; truncated?)", path)
    try:
        data = gsply.sogread(target)
    except zipfile.BadZipFile as exc:
        raise DreamPrintError(f"damaged SOG bundle: {exc}", path) from None
    except (KeyError, ValueError) as exc:
        raise DreamPrintError(f"cannot read SOG: {exc}", path) from None
    except Exception as exc:  # noqa: BLE001 - image decoders raise assorted types
        raise DreamPrintError(f"cannot read SOG: {type(exc).__name__}: {exc}", path) from None
    return _from_gsply(data, "splats (PlayCanvas SOG)")
