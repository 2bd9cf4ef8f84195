"""The source's renders kept on disk: a proof of the same source on the same cameras renders it
once (the operator's look-compare-fix loop, ``evaluate methods``' rows, compensation's
held-out proofs).

Defines :func:`cached_render_source`: :func:`.source_render.render_source` of a view, read from
the cache when an identical render was made before, else rendered and kept.

The key is the content, not the settings that led to it: a BLAKE2b digest of the sampled field
(each cell's density and linear colour, the cells' origin and size, nearest or trilinear
lookup: :class:`.source_render.SourceField`), the view (azimuth, elevation, half-width,
distance), the resolution, the sub-pixel count, the floor's reflectance and the code of
:mod:`.source_render` and :mod:`.cameras` (a changed renderer misses). Two proofs whose fields
differ in one cell's value miss; nothing the key does not hold can change the image. The image
is stored as computed (float64), so a hit is bit-identical to a render. Entries live in
``cache_folder("proof_source")`` (:func:`...core.files.cache_folder`), written atomically;
beyond :data:`MAX_ENTRIES` the least recently used are removed. A cache that cannot be read
or written is skipped: the source is rendered as without it.
"""

from __future__ import annotations

import functools
import hashlib
import io
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from dreamprint_gui import __version__
from dreamprint_gui.core.errors import DreamPrintError
from dreamprint_gui.core.files import cache_folder, write_atomically
from dreamprint_gui.proof import cameras, source_render
from dreamprint_gui.proof.cameras import View
from dreamprint_gui.proof.source_render import SourceField, render_source

__all__ = ["cached_render_source", "render_key", "MAX_ENTRIES", "CACHE_NAME"]

CACHE_NAME = "proof_source"
MAX_ENTRIES = 256      # 2 MB each at 256 px (RGB + alpha, float64): 0.5 GB at most


@functools.cache  # the code does not change while the process runs: read it once
def _code_digest() -> bytes:
    h = hashlib.blake2b(digest_size=16)
    for mod in (source_render, cameras):
        try:
            h.update(Path(mod.__file__).read_bytes())
        except (OSError, TypeError):       # a frozen bundle: its version stands for the code
            h.update(__version__.encode())
    return h.digest()


def render_key(field: SourceField, view: View, resolution: int, sub: int = 2,
               floor_rho: float | None = None) -> str:
    """The cache key (hex) of a source render: the digest of everything it depends on."""
    h = hashlib.blake2b(digest_size=20)
    h.update(_code_digest())
    for a in (field.sigma, field.colour):
        arr = np.ascontiguousarray(a)
        h.update(repr((arr.dtype.str, arr.shape)).encode())
        h.update(arr.data)
    h.update(np.asarray(field.lo_mm, np.float64).tobytes())
    h.update(np.asarray(field.cell_mm, np.float64).tobytes())
    h.update(repr((bool(field.nearest), float(view.azimuth_deg), float(view.elevation_deg),
                   float(view.half_mm), float(view.distance_mm), int(resolution), int(sub),
                   None if floor_rho is None else float(floor_rho))).encode())
    return h.hexdigest()


def _read(path: Path, resolution: int) -> tuple[NDArray, NDArray] | None:
    try:
        with np.load(path) as z:
            rgb, alpha = z["rgb"], z["alpha"]
    except (OSError, ValueError, KeyError, EOFError):
        return None
    if rgb.shape != (resolution, resolution, 3) or alpha.shape != (resolution, resolution):
        return None
    try:
        path.touch()                       # least recently used goes first
    except OSError:
        pass
    return rgb, alpha


def _prune(folder: Path, keep: int) -> None:
    try:
        files = sorted(folder.glob("*.npz"), key=lambda p: p.stat().st_mtime)
        for p in files[:max(0, len(files) - keep)]:
            p.unlink(missing_ok=True)
    except OSError:
        pass


def cached_render_source(field: SourceField, view: View, resolution: int, sub: int = 2,
                         floor_rho: float | None = None) -> tuple[NDArray, NDArray, bool]:
    """:func:`.source_render.render_source` through the disk cache: ``(rgb, alpha, hit)``,
    ``hit`` True when the images were read from the cache."""
    folder = cache_folder(CACHE_NAME)
    path = folder / f"{render_key(field, view, resolution, sub, floor_rho)}.npz"
    got = _read(path, int(resolution))
    if got is not None:
        return got[0], got[1], True
    rgb, alpha = render_source(field, view, resolution, sub=sub, floor_rho=floor_rho)
    buf = io.BytesIO()
    np.savez(buf, rgb=rgb, alpha=alpha)
    try:
        folder.mkdir(parents=True, exist_ok=True)
        write_atomically(path, buf.getvalue(), "render.npz")
        _prune(folder, MAX_ENTRIES)
    except (OSError, DreamPrintError):
        pass                               # no cache: the render stands
    return rgb, alpha, False
