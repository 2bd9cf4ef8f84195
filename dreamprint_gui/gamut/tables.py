"""The RGB -> concentration table (section 4.2), its per-node density data, and its disk cache.

Defines
-------
- :class:`ColourTables`: the n^3 table over the encoded sRGB cube. Per node (``packed``, float32,
  fields in :data:`FIELDS`): the C, M, Y, K, W concentrations minimising the objective (eq. 10),
  the scalar density sigma (eq. 9, 1/mm) of that mixture, sigma of the mixture diluted with Clear
  to rho = 1/2 ... 1/32 (for density alignment without KM at run time), and sigma with 10 % of
  the node's K/W grey X (eqs. 11-13). Plus the 100-entry brightness table ``rho_K`` (eq. 11),
  dE2000 of every node's reproduction to its target (the out-of-gamut report), and metadata.
- :func:`build_tables`, :func:`get_tables` (cached in the platformdirs user cache, keyed by the
  profile's fingerprint, objective, rendering intent, size and :data:`TABLE_VERSION`),
  :func:`lookup` (tetrahedral, :func:`tetrahedral_nodes`).
- :func:`printed_xyz`: the colour a job prints for RGB colours (lookup, then eq. 7).
- :func:`mixture_sigma`: the exact scalar sigma of six-ink mixtures, as ``predict`` computes it.
- :func:`resolve_choice`: the objective and intent to use (explicit choice, else the profile's
  ``table`` settings, else the defaults).

Objectives (:mod:`.optimise`): ``srgb`` (paper eq. 10), ``cielab``, ``de2000``. Default:
:data:`DEFAULT_OBJECTIVE`, the one with the smallest lookup-minus-lattice-best dE2000 (see
docs/physics.md and ``dreamprint gamut --json``). Rendering intents (:mod:`.mapping`):
``colorimetric`` (the printable colour of minimum objective), ``relative`` (ICC media-relative:
the source white mapped onto the printable white first) and ``perceptual`` (SGCK compression
into the gamut first). Each node's dE2000 to its *source* colour is kept in ``dE2000`` (the
pre-flight measures against the intent's target itself).
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import time
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from contextlib import AbstractContextManager, nullcontext
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike, NDArray

from dreamprint_gui.core.durations import seconds_text
from dreamprint_gui.core.kernel_cache import compile_notice, uncached, while_compiling
from dreamprint_gui.core.profile import INKS, InkProfile
from dreamprint_gui.gamut import optimise
from dreamprint_gui.gamut.forward import (
    N_COLOUR_INKS,
    ForwardModel,
    forward_model,
    mixtures_lab,
    mixtures_xyz,
)
from dreamprint_gui.gamut.grey import brightness_table, grey_concentrations, rho_k_for
from dreamprint_gui.gamut.mapping import DEFAULT_INTENT, canonical_intent, intent_map
from dreamprint_gui.gamut.optimise import (
    canonical_objective,
    resample,
    solve_grid,
    srgb_to_xyz,
    targets_for,
)
from dreamprint_gui.physics.colorimetry import delta_E2000
from dreamprint_gui.physics.density import scalar_sigma
from dreamprint_gui.physics.kubelka_munk import mix

__all__ = ["ColourTables", "build_tables", "get_tables", "lookup", "printed_xyz",
           "interpolate_fields", "tetrahedral_nodes", "mixture_sigma",
           "DEFAULT_OBJECTIVE", "DEFAULT_INTENT", "DEFAULT_SIZE", "GREY_MAX", "CLEAR_KNOTS",
           "FIELDS", "TABLE_VERSION", "cache_dir", "resolve_choice", "kernels_estimate",
           "COMPILE_SECONDS"]

TABLE_VERSION = 3
DEFAULT_OBJECTIVE = "de2000"
DEFAULT_SIZE = 100
# Eq. 13 with the paper's "upper limit of rho+ 0.1" read as a bound on the grey: 1 - rho+ <= 0.1.
GREY_MAX = 0.1
# Clear dilutions rho (eq. 12) at which each node's sigma is tabulated; rho = 1 is the node itself.
CLEAR_KNOTS = tuple(2.0 ** -k for k in range(6))
F_CONC = slice(0, N_COLOUR_INKS)
F_SIGMA = N_COLOUR_INKS  # rho = 1
F_KNOTS = slice(N_COLOUR_INKS, N_COLOUR_INKS + len(CLEAR_KNOTS))  # rho = 1, 1/2, ..., 1/32
F_GREY = N_COLOUR_INKS + len(CLEAR_KNOTS)  # 10 % grey
N_FIELDS = F_GREY + 1
FIELDS = ("C", "M", "Y", "K", "W") + tuple(f"sigma_rho_{r:g}" for r in CLEAR_KNOTS) + (
    "sigma_grey_10pc",)
_CHUNK_NODES = 8192


@dataclass
class ColourTables:
    """Everything lookup and density alignment need, per node of the n^3 sRGB grid."""

    size: int
    objective: str
    packed: NDArray[np.float32]  # (n, n, n, N_FIELDS), see FIELDS
    dE2000: NDArray[np.float32]  # (n, n, n) reproduction vs target
    brightness_rho_k: NDArray[np.float64]  # (100,) eq. 11
    sigma_clear: float  # scalar sigma of pure Clear, the floor of alignment
    profile_fingerprint: str
    colour_thickness_mm: float
    layer_thickness_mm: float
    build_seconds: float  # the build's time (of an earlier run when ``cached``)
    cached: bool = False  # loaded from the disk cache
    load_seconds: float = 0.0  # the time to load it from the cache (0 when built)
    meta: dict = field(default_factory=dict)
    intent: str = DEFAULT_INTENT

    @property
    def conc(self) -> NDArray[np.float32]:
        """(n, n, n, 5) C, M, Y, K, W on the simplex."""
        return self.packed[..., F_CONC]

    @property
    def sigma(self) -> NDArray[np.float32]:
        """(n, n, n) scalar density (1/mm) of each node's mixture."""
        return self.packed[..., F_SIGMA]

    @property
    def clear_sigma_knots(self) -> NDArray[np.float32]:
        return self.packed[..., F_KNOTS]

    @property
    def grey_sigma(self) -> NDArray[np.float32]:
        return self.packed[..., F_GREY]


def cache_dir() -> Path:
    from platformdirs import user_cache_path

    return user_cache_path("dreamprint") / "gamut"


def resolve_choice(profile: InkProfile, objective: str | None = None,
                   intent: str | None = None) -> tuple[str, str]:
    """(objective, intent): the explicit choice, else the profile's, else the default."""
    settings = getattr(profile, "table_settings", None) or {}
    obj = canonical_objective(objective if objective is not None else settings.get("objective"),
                              DEFAULT_OBJECTIVE)
    return obj, canonical_intent(intent if intent is not None else settings.get("intent"))


def _cache_key(profile: InkProfile, objective: str, size: int, intent: str) -> str:
    d = {"profile": profile.fingerprint(), "objective": objective, "size": size,
         "intent": intent, "version": TABLE_VERSION, "knots": CLEAR_KNOTS,
         "grey_max": GREY_MAX}
    return hashlib.sha256(json.dumps(d, sort_keys=True).encode()).hexdigest()[:20]


def mixture_sigma(profile: InkProfile, conc6: ArrayLike) -> NDArray[np.float64]:
    """Scalar sigma (eq. 9, 1/mm) of six-ink mixtures, exactly as ``mixture.predict``."""
    c = np.asarray(conc6, dtype=np.float64)
    # 2-D matrix product (a batched 3-D one is ~10 times slower in numpy)
    K, S = mix(c.reshape(-1, c.shape[-1]), profile.K, profile.S)
    sigma = scalar_sigma(K, S, profile.layer_thickness_mm, profile.density_t_max_mm,
                         profile.density_samples)
    return np.asarray(sigma).reshape(c.shape[:-1])


def _with_clear(conc5: NDArray) -> NDArray[np.float64]:
    return np.concatenate([conc5, np.zeros(conc5.shape[:-1] + (1,))], axis=-1)


def _clear() -> NDArray[np.float64]:
    c = np.zeros(len(INKS))
    c[INKS.index("Cl")] = 1.0
    return c


def _node_sigmas(profile: InkProfile, conc5: NDArray, rgb: NDArray,
                 rho_k_table: NDArray) -> NDArray[np.float64]:
    """(N, 2) sigmas of the nodes' mixtures and of them with 10 % grey X (eqs. 11, 13)."""
    c6 = _with_clear(conc5)
    grey = grey_concentrations(rho_k_for(rho_k_table, rgb.mean(axis=-1)))
    greyed = (1.0 - GREY_MAX) * c6 + GREY_MAX * grey
    return mixture_sigma(profile, np.stack([c6, greyed], axis=1))


def _clear_ratios(profile: InkProfile, conc5: NDArray) -> NDArray[np.float64]:
    """(N, len(CLEAR_KNOTS) - 1): sigma(rho C* + (1 - rho) Cl) / sigma(C*) (eq. 12), rho < 1."""
    c6 = _with_clear(conc5)
    rho = np.asarray(CLEAR_KNOTS)[None, :, None]
    s = mixture_sigma(profile, rho * c6[:, None, :] + (1.0 - rho) * _clear())
    return s[:, 1:] / s[:, :1]


def build_tables(profile: InkProfile, objective: str | None = None, size: int = DEFAULT_SIZE,
                 progress: Callable[[float], None] | None = None,
                 intent: str | None = None) -> ColourTables:
    """Solve the n^3 table (not cached; see :func:`get_tables`)."""
    objective, intent = resolve_choice(profile, objective, intent)
    if size < 2:
        raise ValueError("the table needs at least 2 nodes per axis")
    t0 = time.perf_counter()
    model = forward_model(profile)
    target_xyz = None
    imap = intent_map(model, intent)
    if imap is not None:
        def target_xyz(rgb):
            return imap.map_xyz(srgb_to_xyz(model, rgb))

    conc, _ = solve_grid(model, objective, size, progress, target_xyz)
    a = np.linspace(0.0, 1.0, size)
    rgb = np.stack(np.meshgrid(a, a, a, indexing="ij"), axis=-1).reshape(-1, 3)
    flat = conc.reshape(-1, N_COLOUR_INKS)
    dE = delta_E2000(mixtures_lab(model, flat), targets_for(model, "lab", rgb))
    rho_k_table = brightness_table(profile)
    packed = np.empty((flat.shape[0], N_FIELDS), dtype=np.float32)
    packed[:, F_CONC] = flat
    # The Clear-dilution curves are smooth in the colour: tabulated on a half-resolution grid
    # as ratios to the node's own sigma and resampled (a 7x saving of KM density fits).
    n_half = max(2, (size + 1) // 2)
    half = resample(conc, n_half).reshape(-1, N_COLOUR_INKS)
    ratios = np.empty((half.shape[0], len(CLEAR_KNOTS) - 1))

    def chunk(start: int) -> None:
        stop = min(start + _CHUNK_NODES, flat.shape[0])
        two = _node_sigmas(profile, flat[start:stop], rgb[start:stop], rho_k_table)
        packed[start:stop, F_SIGMA] = two[:, 0]
        packed[start:stop, F_GREY] = two[:, 1]

    def chunk_half(start: int) -> None:
        stop = min(start + _CHUNK_NODES, half.shape[0])
        ratios[start:stop] = _clear_ratios(profile, half[start:stop])

    jobs = [(chunk, s) for s in range(0, flat.shape[0], _CHUNK_NODES)]
    jobs += [(chunk_half, s) for s in range(0, half.shape[0], _CHUNK_NODES)]
    # The density kernels release the GIL: threads use all cores.
    with ThreadPoolExecutor(max_workers=max(1, min(4, os.cpu_count() or 1))) as pool:
        for i, _ in enumerate(pool.map(lambda job: job[0](job[1]), jobs)):
            if progress is not None:
                progress(0.8 + 0.2 * (i + 1) / len(jobs))
    ratios = resample(ratios.reshape(n_half, n_half, n_half, -1), size).reshape(-1, ratios.shape[1])
    packed[:, F_SIGMA + 1:F_GREY] = packed[:, F_SIGMA:F_SIGMA + 1] * ratios
    clear6 = _clear()
    return ColourTables(
        size=size, objective=objective, intent=intent,
        packed=packed.reshape(size, size, size, N_FIELDS),
        dE2000=dE.reshape(size, size, size).astype(np.float32), brightness_rho_k=rho_k_table,
        sigma_clear=float(mixture_sigma(profile, clear6)),
        profile_fingerprint=profile.fingerprint(),
        colour_thickness_mm=float(profile.colour_thickness_mm),
        layer_thickness_mm=float(profile.layer_thickness_mm),
        build_seconds=time.perf_counter() - t0)


def _save(tables: ColourTables, path: Path) -> None:
    meta = {"size": tables.size, "objective": tables.objective, "intent": tables.intent,
            "sigma_clear": tables.sigma_clear, "profile_fingerprint": tables.profile_fingerprint,
            "colour_thickness_mm": None if math.isinf(tables.colour_thickness_mm)
            else tables.colour_thickness_mm,
            "layer_thickness_mm": tables.layer_thickness_mm,
            "build_seconds": tables.build_seconds, "version": TABLE_VERSION,
            "fields": list(FIELDS)}
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.stem}.{os.getpid()}.tmp.npz")
    try:
        np.savez(tmp, packed=tables.packed, dE2000=tables.dE2000,
                 brightness_rho_k=tables.brightness_rho_k, meta=json.dumps(meta))
        tmp.replace(path)
    finally:
        tmp.unlink(missing_ok=True)


def _load(path: Path, key_profile: str, objective: str, size: int,
          intent: str) -> ColourTables | None:
    try:
        with np.load(path, allow_pickle=False) as z:
            meta = json.loads(str(z["meta"]))
            packed = z["packed"]
            dE = z["dE2000"]
            bt = z["brightness_rho_k"]
    except (OSError, ValueError, KeyError, json.JSONDecodeError):
        return None  # missing or damaged: rebuild
    if (meta.get("version") != TABLE_VERSION or meta.get("profile_fingerprint") != key_profile
            or meta.get("objective") != objective or meta.get("size") != size
            or meta.get("intent") != intent
            or packed.shape != (size, size, size, N_FIELDS) or not np.all(np.isfinite(packed))):
        return None
    ct = meta["colour_thickness_mm"]
    return ColourTables(size=size, objective=objective, intent=intent, packed=packed, dE2000=dE,
                        brightness_rho_k=bt, sigma_clear=float(meta["sigma_clear"]),
                        profile_fingerprint=key_profile,
                        colour_thickness_mm=math.inf if ct is None else float(ct),
                        layer_thickness_mm=float(meta["layer_thickness_mm"]),
                        build_seconds=float(meta["build_seconds"]), cached=True)


# Wall seconds of a 100^3 build on the idle 2-core development machine, both cores busy (its
# solve is a prange kernel; the job's estimate scales it by prepare_time.parallel_slowdown),
# for the announcement of a first-use build; scaled by the node count. de2000:
# bench_preflight.py --samples --modes cold on a quiet machine (2026-12-02, load 1) 17.6, 21.1
# and 22.0 s for 40-43 CPU s; srgb 19 CPU s (benchmarks/bench_gamut.py), cielab solves like it.
# Until then 36 s, an idle machine's seconds measured under load: a two-thread kernel there
# shares what one core gets
BUILD_SECONDS_100 = {"de2000": 20.0, "cielab": 10.0, "srgb": 10.0}
# Seconds numba takes to compile the table solve's kernel (.optimise) before a first build
# after an install or upgrade (its cache is keyed on the sources): 15.9 CPU s of one thread
# (53 s wall at load 7.9; `dreamprint gamut` with empty caches, numba's compile events,
# 2026-12-02), an idle machine's wall seconds
COMPILE_SECONDS = 16.0
COMPILE_WHAT = "compiling the colour kernels"


def tables_path(profile: InkProfile, objective: str | None = None, size: int = DEFAULT_SIZE,
                intent: str | None = None, cache: str | os.PathLike | None = None) -> Path:
    """Where :func:`get_tables` keeps (or would keep) these tables."""
    objective, intent = resolve_choice(profile, objective, intent)
    folder = Path(cache) if cache is not None else cache_dir()
    return folder / f"tables_{_cache_key(profile, objective, size, intent)}.npz"


def build_estimate(profile: InkProfile, objective: str | None = None,
                   size: int = DEFAULT_SIZE, intent: str | None = None,
                   cache: str | os.PathLike | None = None) -> float | None:
    """Estimated seconds :func:`get_tables` will spend building, or None when the cache holds
    the tables (checked by the file's presence: a stale file is rebuilt, rarely)."""
    objective, intent = resolve_choice(profile, objective, intent)
    if tables_path(profile, objective, size, intent, cache).is_file():
        return None
    extra = 1.15 if intent != "colorimetric" else 1.0  # the intent's mapping of every target
    return BUILD_SECONDS_100.get(objective, 30.0) * extra * (size / 100) ** 3


def kernels_estimate() -> float | None:
    """Seconds numba will spend compiling the table solve's kernels (:mod:`.optimise`) before
    a build, :data:`COMPILE_SECONDS`, or None when they are cached
    (:func:`..core.kernel_cache.uncached`, the rule the job's first-use compiles follow)."""
    return COMPILE_SECONDS if uncached(optimise) else None


def get_tables(profile: InkProfile, objective: str | None = None, size: int = DEFAULT_SIZE,
               progress: Callable[[float], None] | None = None,
               cache: str | os.PathLike | None = None,
               intent: str | None = None,
               notify: Callable[[str], None] | None = None) -> ColourTables:
    """The tables for ``profile``: from the disk cache when present, else built and cached.

    ``objective``/``intent`` default to the profile's ``table`` settings, else to
    :data:`DEFAULT_OBJECTIVE` / ``colorimetric``. ``cache`` overrides the folder (default:
    :func:`cache_dir`). ``progress(fraction)`` is called during a build only (a table loaded
    from the cache reports nothing: the caller would otherwise say "building").
    ``notify(message)``: before a build whose kernels numba has not cached
    (:func:`kernels_estimate`), "compiling the colour kernels: first run after an install or
    upgrade, about 16 s; cached after", then "compiling the colour kernels: 12 s" every
    ``core.progress.HEARTBEAT_S`` seconds while numba compiles
    (:func:`..core.kernel_cache.while_compiling`); nothing when they are cached.
    """
    objective, intent = resolve_choice(profile, objective, intent)
    path = tables_path(profile, objective, size, intent, cache)
    fp = profile.fingerprint()
    t0 = time.perf_counter()
    found = _load(path, fp, objective, size, intent)
    if found is not None:
        found.load_seconds = time.perf_counter() - t0
        return found
    compiling: AbstractContextManager = nullcontext()
    est = kernels_estimate() if notify is not None else None
    if est is not None:
        notify(compile_notice(COMPILE_WHAT, "first run after an install or upgrade", est))
        compiling = while_compiling(lambda el: notify(f"{COMPILE_WHAT}: {seconds_text(el)}"))
    with compiling:
        tables = build_tables(profile, objective, size, progress, intent)
    try:
        _save(tables, path)
    except OSError:
        pass  # a read-only cache only costs a rebuild next time
    return tables


LOOKUP_CHUNK = 1 << 17  # colours per step of :func:`interpolate_fields` (bounds its memory)


def tetrahedral_nodes(rgb: NDArray, n: int) -> tuple[NDArray[np.int64], NDArray[np.float64]]:
    """The four nodes (flat indices into an ``(n, n, n)`` grid, (N, 4)) and weights (N, 4) of
    the tetrahedral interpolation of encoded sRGB ``rgb`` (N, 3) in an n^3 table, the rule of
    ICC colour management modules for 3D tables and of the print job's kernel
    (:func:`.alignment.interpolate_nodes`): with the fractions in the cell sorted
    ``a >= b >= c``, ``v = (1 - a) v_000 + (a - b) v_(e_a) + (b - c) v_(e_a + e_b) + c v_111``.
    Colours are clamped to the cube; NaN counts as 0 (a damaged voxel never indexes outside)."""
    c = np.clip(np.nan_to_num(np.asarray(rgb, np.float64), nan=0.0), 0.0, 1.0) * (n - 1)
    i0 = np.minimum(c.astype(np.int64), n - 2)
    f = c - i0
    order = np.argsort(-f, axis=1, kind="stable")  # largest fraction first
    fs = np.take_along_axis(f, order, axis=1)
    stride = np.array([n * n, n, 1], np.int64)[order]
    base = i0 @ np.array([n * n, n, 1], np.int64)
    nodes = np.stack([base, base + stride[:, 0], base + stride[:, 0] + stride[:, 1],
                      base + n * n + n + 1], axis=1)
    weights = np.stack([1.0 - fs[:, 0], fs[:, 0] - fs[:, 1], fs[:, 1] - fs[:, 2], fs[:, 2]],
                       axis=1)
    return nodes, weights


def interpolate_fields(packed: NDArray, rgb: ArrayLike,
                       fields: slice | int | list[int]) -> NDArray:
    """Fields ``fields`` of the table ``packed`` (n, n, n, F) at encoded sRGB ``rgb`` (N, 3),
    tetrahedral (:func:`tetrahedral_nodes`), float64 (N, ...)."""
    rgb = np.asarray(rgb).reshape(-1, 3)
    n = packed.shape[0]
    flat = packed.reshape(n ** 3, -1)[:, fields]
    out = np.empty((len(rgb),) + flat.shape[1:])
    for s in range(0, len(rgb), LOOKUP_CHUNK):
        nodes, w = tetrahedral_nodes(rgb[s:s + LOOKUP_CHUNK], n)
        v = flat[nodes].astype(np.float64)
        out[s:s + LOOKUP_CHUNK] = np.einsum("nk,nk...->n...", w, v)
    return out


def lookup(tables: ColourTables, rgb: ArrayLike) -> NDArray[np.float64]:
    """C, M, Y, K, W (..., 5) for encoded sRGB in [0, 1] (..., 3), tetrahedral in the table
    (:func:`tetrahedral_nodes`, as the print job's kernel).

    Colours outside [0, 1] are clamped to the cube. Interpolation of simplex points stays on the
    simplex (renormalised: the table is float32).
    """
    rgb = np.asarray(rgb, dtype=np.float64)
    out = interpolate_fields(tables.packed, rgb.reshape(-1, 3), F_CONC)
    out /= out.sum(-1, keepdims=True)
    return out.reshape(rgb.shape[:-1] + (N_COLOUR_INKS,))


def printed_xyz(tables: ColourTables, model: ForwardModel, rgb: ArrayLike) -> NDArray[np.float64]:
    """XYZ (D65, white Y = 1) of what a job prints for encoded sRGB ``rgb`` (..., 3): the
    table's mixture (:func:`lookup`, the table's intent) and its colour at the profile's
    reference thickness (eq. 7 on R + T, :func:`.forward.mixtures_xyz`), as ``dreamprint
    lookup`` reports it."""
    return mixtures_xyz(model, lookup(tables, rgb))
