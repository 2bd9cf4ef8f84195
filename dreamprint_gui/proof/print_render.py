"""The print rendered by Mitsuba 3: a heterogeneous scattering medium under a white environment.

Defines :func:`render_print`, :func:`render_print_halves` (the proof's: two independent halves
of the samples, their mean the image, their difference the noise floor) and
:data:`DEFAULT_MAX_DEPTH`.

Scene (units mm, the print centred on the origin, z up):

- the print: boxes ("bricks" of cells, :mod:`.bricks`, see :func:`scene_dict`) with index-matched
  (``null``) boundaries, each holding a ``heterogeneous`` medium: ``sigma_t`` and ``albedo``
  grid volumes on the proof's cells (:mod:`.medium`, :mod:`.km_to_rte`), nearest-cell lookup
  (a cell is a uniform mixture), the phase function of :mod:`.optics` (isotropic by default).
  By default no surface reflection: the KM coefficients of the product's profile describe the
  inks without one (Saunderson is off by default), so the render judges exactly the model the
  tables were built with. ``--surface glossy|matte`` (:mod:`.optics`) puts a dielectric
  (smooth, or rough GGX) box on the print's bounds, around the bricks;
- light: a uniform ``constant`` environment of radiance 1 in every band (white, D65 once the
  bands are weighted, :mod:`.spectral`); optionally a ``directional`` key light from the upper
  front-left, and a neutral diffuse floor under the print;
- integrator: ``volpathmis`` (unidirectional volumetric path tracing with multiple scattering,
  delta tracking with spectral MIS, next-event estimation; :data:`INTEGRATOR` says why not
  ``volpath``), ``max_depth`` bounces. Without a floor the
  environment seen straight through the print (camera rays that leave without a real
  collision) is hidden (``hide_emitters``) and added back exactly by the caller as the
  medium's direct transmittance per band (:func:`.source_render.optical_depth`): delta
  tracking estimates it with 0/1 samples, the largest noise of the image (a pixel of
  transmittance 0.5 had a standard deviation of 0.5 / sqrt(spp)); the expectation is the same.
  With a surface the straight-through light is refracted (no longer the straight rays' exact
  transmittance), so Mitsuba samples it and nothing is added (:func:`hides_direct`);
- sensors: one ``orthographic`` camera per view, the same rays as the source render
  (:mod:`.cameras`), box pixel filter.

Mitsuba's RGB variant transports three channels independently (spectral MIS for distance
sampling); the channels carry three spectral bands at a time, so 12 bands take 4 renders
(:func:`pass_bands`; its ``"mono"`` layout, one band in all three channels, takes spectral MIS
out of the path and lowers the noise at a given spp by a third, but costs as much per pass:
the same noise per CPU second, ``docs/proof-measurements.md``).
A pass whose bands weigh little in colour (650-730 nm: its noise hardly reaches XYZ) is
rendered at a quarter of the samples (:func:`pass_spp`).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np
from numpy.typing import NDArray

from dreamprint_gui.job.plan import JobCancelled
from dreamprint_gui.proof.bricks import optically_deep, partition, uniform
from dreamprint_gui.proof.cameras import View
from dreamprint_gui.proof.mitsuba_setup import fell_back, load_mitsuba
from dreamprint_gui.proof.optics import Optics

__all__ = ["render_print", "render_print_seeds", "render_print_halves", "half_spp", "BLOCK_PX",
           "hides_direct", "thick_tiles", "pass_spp", "pass_bands", "LAYOUTS",
           "DEFAULT_MAX_DEPTH", "DEFAULT_SAMPLER", "SAMPLERS"]

DEFAULT_MAX_DEPTH = 512
# volpathmis, not volpath: the three channels of a pass are three bands whose sigma_t differ
# (Cyan: 3.7, 12.4, 42.3 /mm); Mitsuba 3.9's volpath renders such a chromatic medium biased
# (a thick Cyan patch's first band 0.075 against the exact 0.103 of Chandrasekhar's solution,
# 0.102 when the channels are equal), volpathmis (spectral MIS, Miller et al. 2019) 0.098.
INTEGRATOR = "volpathmis"
DEFAULT_SAMPLER = "independent"
DEFAULT_RR_DEPTH = 5          # Mitsuba's: Russian roulette from the 5th bounce on
SAMPLERS = ("independent", "stratified", "multijitter", "orthogonal", "ldsampler")
LAYOUTS = ("rgb", "mono")
FAINT_PASS = 0.25     # a pass weighing less than this x the largest in colour gets spp / 4
TILE_PX = 32
# the scalar variant's image blocks (pixels a side), one thread each: fixed, so that a render
# does not depend on the number of threads (Mitsuba's automatic size halves the blocks until
# every thread has one, and each pixel's random stream is seeded from its block's index)
BLOCK_PX = 16
BRICK_GAP = 1.5e-4
FLOOR_REFLECTANCE = 0.5


def _sensor(mi, view: View, resolution: int, spp: int, sampler: str = "independent",
            crop: tuple[int, int, int, int] | None = None) -> dict:
    T = mi.ScalarTransform4f
    eye = [float(v) for v in view.eye]
    to_world = (T().look_at(origin=eye, target=[0.0, 0.0, 0.0], up=[0.0, 0.0, 1.0])
                @ T().scale([view.half_mm, view.half_mm, 1.0]))
    width = height = int(resolution)
    if crop is not None:
        # a part of the frame as a camera of its own: a film of the part's size placed by its
        # transform, not a crop of the frame's film: Dr.Jit compiles a crop's offset into the
        # kernel (one kernel per crop), the transform not (one kernel for parts of one size).
        # Mitsuba's camera x and y run against the film's columns and rows.
        x0, y0, width, height = (int(c) for c in crop)
        cx = 1.0 - (2.0 * x0 + width) / resolution
        cy = 1.0 - (2.0 * y0 + height) / resolution
        to_world = to_world @ T().translate([cx, cy, 0.0]) @ T().scale(
            [width / resolution, height / resolution, 1.0])
    film = {"type": "hdrfilm", "width": width, "height": height,
            "rfilter": {"type": "box"}, "pixel_format": "rgb"}
    return {"type": "orthographic",
            "to_world": to_world,
            "near_clip": 1e-3, "far_clip": 1e7,
            "film": film,
            "sampler": {"type": sampler, "sample_count": int(spp)}}


def hides_direct(floor: bool, optics: Optics | None) -> bool:
    """Whether the render hides the environment seen straight through the print (and the
    caller adds it back exactly): without a floor and without a surface."""
    return not floor and (optics is None or optics.surface == "none")


def scene_dict(mi, sigma_t3: NDArray, albedo3: NDArray, lo: NDArray, hi: NDArray,
               views: list[View], resolution: int, spp: int, max_depth: int,
               key_light: float = 0.0, floor: bool = False, brick: int | None = None,
               sampler: str = "independent", optics: Optics | None = None,
               rr_depth: int | None = None,
               crops: list[tuple[int, tuple[int, int, int, int]]] = ()) -> dict:
    """The Mitsuba scene description of one pass (three bands). ``crops``: extra sensors
    ``view_NN_crop_MMM``, (view index, (x0, y0, width, height) in pixels) each, rendering part
    of a view's frame."""
    T = mi.ScalarTransform4f
    optics = optics or Optics()
    phase = ({"type": "isotropic"} if optics.g == 0
             else {"type": "hg", "g": float(optics.g)})
    lo = np.asarray(lo, np.float64)
    hi = np.asarray(hi, np.float64)
    ncz, ncy, ncx = sigma_t3.shape[:3]
    cell = (hi - lo) / np.array([ncx, ncy, ncz])
    d: dict = {"type": "scene",
               "integrator": {"type": INTEGRATOR, "max_depth": int(max_depth),
                              "rr_depth": int(DEFAULT_RR_DEPTH if rr_depth is None else rr_depth),
                              "hide_emitters": hides_direct(floor, optics),
                              "block_size": BLOCK_PX},
               "environment": {"type": "constant", "radiance": {"type": "rgb",
                                                                "value": [1.0, 1.0, 1.0]}}}
    # Bricks, each its own box and medium: delta tracking then steps by the brick's own
    # majorant (Mitsuba's heterogeneous medium has one majorant per medium), so the thin Clear
    # around an object is not crossed in the steps of its densest ink; bricks holding no ink are
    # left out. By default the boxes of proof.bricks.partition (a cost model of crossings
    # against collision steps: 25.0 -> 12.8 s per demo render against cubes of 16 cells),
    # ``brick`` N: cubes of N cells. Boundaries are index-matched; between bricks a gap of
    # vacuum wider than Mitsuba's ray epsilon (~1e-4 relative to the coordinates) is needed:
    # with shared faces (or gaps of 2e-5 relative) rays leaving a brick skipped the next one
    # and renders came out too bright against the closed-form transmittance of an absorber;
    # with BRICK_GAP (1.5e-4 relative per side: 3 um in a 40 mm print, 0.1 % of a 16-cell
    # brick) they agree (tests/proof/test_print_render.py).
    gap = BRICK_GAP * (1.0 + float(np.abs(np.concatenate([lo, hi])).max()))
    boxes = (partition(sigma_t3, tuple(cell)) if brick is None
             else uniform(sigma_t3, int(brick)))
    for n_bricks, box in enumerate(boxes):
        z0, z1, y0, y1, x0, x1 = box
        st = sigma_t3[z0:z1, y0:y1, x0:x1]
        al = albedo3[z0:z1, y0:y1, x0:x1]
        blo = lo + cell * np.array([x0, y0, z0])
        ext = cell * np.array([x1 - x0, y1 - y0, z1 - z0])
        grid_tf = T().translate(blo.tolist()) @ T().scale(ext.tolist())
        medium = {"type": "heterogeneous", "scale": 1.0,
                  "sigma_t": {"type": "gridvolume", "filter_type": "nearest",
                              "grid": mi.VolumeGrid(np.ascontiguousarray(st)),
                              "to_world": grid_tf, "raw": True},
                  "albedo": {"type": "gridvolume", "filter_type": "nearest",
                             "grid": mi.VolumeGrid(np.ascontiguousarray(al)),
                             "to_world": grid_tf, "raw": True},
                  "phase": dict(phase)}
        if key_light <= 0 and optically_deep(sigma_t3, box, tuple(cell)):
            # no shadow rays from deep inside the ink (bricks.optically_deep); a directional
            # key light can only be reached by them, so it keeps them everywhere
            medium["sample_emitters"] = False
        d[f"brick_{n_bricks:05d}"] = {
            "type": "cube", "to_world": T().translate((blo + ext / 2).tolist())
            @ T().scale((ext / 2 - gap).tolist()), "bsdf": {"type": "null"},
            "interior": medium}
    ext = hi - lo
    mid = (hi + lo) / 2
    bsdf = optics.bsdf()
    if bsdf is not None:
        # the print's outer boundary; the bricks sit inside it, inset by their gap
        d["print_surface"] = {"type": "cube", "to_world": T().translate(mid.tolist())
                              @ T().scale((ext / 2).tolist()), "bsdf": bsdf}
    if key_light > 0:
        d["key"] = {"type": "directional", "direction": [0.5, 0.6, -0.62],
                    "irradiance": {"type": "rgb", "value": [key_light] * 3}}
    if floor:
        size = 20.0 * float(max(ext))
        d["floor"] = {"type": "rectangle",
                      "to_world": T().translate([float(mid[0]), float(mid[1]),
                                                 float(lo[2]) - 1e-3])
                      @ T().scale([size, size, 1.0]),
                      "bsdf": {"type": "diffuse", "reflectance": {"type": "rgb", "value": [
                          FLOOR_REFLECTANCE] * 3}}}
    for i, v in enumerate(views):
        d[f"view_{i:02d}"] = _sensor(mi, v, resolution, spp, sampler)
    for j, (i, rect) in enumerate(crops):
        d[f"view_{i:02d}_crop_{j:03d}"] = _sensor(mi, views[i], resolution, spp, sampler, rect)
    return d


def render_print(sigma_t: NDArray, albedo: NDArray, lo: NDArray, hi: NDArray,
                 views: list[View], resolution: int, spp: int, seed: int,
                 max_depth: int = DEFAULT_MAX_DEPTH, key_light: float = 0.0,
                 floor: bool = False,
                 progress: Callable[[int, int], None] | None = None,
                 cancelled: Callable[[], bool] | None = None,
                 sampler: str = DEFAULT_SAMPLER, optics: Optics | None = None,
                 rr_depth: int | None = None) -> tuple[NDArray, dict]:
    """Band radiance images (views, res, res, n_bands) of the medium (ncz, ncy, ncx, n_bands).

    Deterministic for a given ``seed`` (Mitsuba's sampler seed per view and pass). Returns the
    images and ``{"renderer": ..., "variant": ..., "note": ...}``.
    """
    imgs, info = render_print_seeds(sigma_t, albedo, lo, hi, views, resolution, spp, (seed,),
                                    max_depth, key_light, floor, progress, cancelled, sampler,
                                    optics, rr_depth)
    return imgs[0], info


def render_print_seeds(sigma_t: NDArray, albedo: NDArray, lo: NDArray, hi: NDArray,
                       views: list[View], resolution: int, spp: int | Sequence[int],
                       seeds: tuple[int, ...],
                       max_depth: int = DEFAULT_MAX_DEPTH, key_light: float = 0.0,
                       floor: bool = False,
                       progress: Callable[[int, int], None] | None = None,
                       cancelled: Callable[[], bool] | None = None,
                       sampler: str = DEFAULT_SAMPLER, optics: Optics | None = None,
                       rr_depth: int | None = None,
                       extra: list[tuple[int, tuple[int, int, int, int]]] = (),
                       extra_spp: int = 0,
                       brick: int | None = None,
                       layout: str = "rgb") -> tuple[list[NDArray], dict]:
    """:func:`render_print` at each of ``seeds`` (one scene per pass serves them all): the
    proof and its noise floor's second render. Returns the images per seed and the info.
    ``spp``: samples per pixel of every pass, or one count per pass (:func:`pass_spp`).

    ``extra``: rectangles (view index, (x0, y0, width, height)) rendered again at
    ``extra_spp`` (:func:`thick_tiles`); their pixels are the mean of all their samples,
    ``(spp * base + extra_spp * crop) / (spp + extra_spp)``, each sample independent (own
    seed), so every pixel stays an unbiased estimate, with less variance where it was added."""

    mi, variant, note = load_mitsuba()
    nb_ = sigma_t.shape[-1]
    groups = pass_bands(nb_, layout)
    passes = len(groups)
    pass_spp_ = [int(spp)] * passes if np.ndim(spp) == 0 else [int(n) for n in spp]
    if len(pass_spp_) != passes or min(pass_spp_) < 1:
        raise ValueError(f"spp: one count >= 1 per pass ({passes}), got {spp}")
    outs = [np.empty((len(views), resolution, resolution, nb_), np.float32) for _ in seeds]
    extra = list(extra) if extra_spp > 0 else []
    total = passes * (len(views) + len(extra)) * len(seeds)
    done = 0
    for p, group in enumerate(groups):
        # the pass's channels (three bands, or one band thrice) and where each band lands:
        # its first channel
        ch = list(group)
        bands_ = sorted(set(ch))
        first = [ch.index(b) for b in bands_]
        st_p = np.ascontiguousarray(sigma_t[..., ch], np.float32)
        al_p = np.ascontiguousarray(albedo[..., ch], np.float32)
        scene = mi.load_dict(scene_dict(
            mi, st_p, al_p, lo, hi, views, resolution,
            pass_spp_[p],
            max_depth, key_light, floor, brick=brick, sampler=sampler, optics=optics,
            rr_depth=rr_depth, crops=extra))
        sensors = {sn.id(): sn for sn in scene.sensors()}
        for out, seed in zip(outs, seeds, strict=True):
            for i in range(len(views)):
                if cancelled is not None and cancelled():

                    raise JobCancelled("the proof was cancelled")
                img = mi.render(scene, sensor=sensors[f"view_{i:02d}"], spp=pass_spp_[p],
                                seed=int(seed) * 7919 + 101 * i + p)
                out[i][:, :, bands_] = np.asarray(img, np.float32)[..., first]
                done += 1
                if progress is not None:
                    progress(done, total)
            for j, (i, (x0, y0, w, h)) in enumerate(extra):
                if cancelled is not None and cancelled():

                    raise JobCancelled("the proof was cancelled")
                img = mi.render(scene, sensor=sensors[f"view_{i:02d}_crop_{j:03d}"],
                                spp=int(extra_spp),
                                seed=int(seed) * 7919 + 101 * i + p + 1000003 * (j + 1))
                part = out[i][y0:y0 + h, x0:x0 + w, bands_]
                out[i][y0:y0 + h, x0:x0 + w, bands_] = (
                    pass_spp_[p] * part + extra_spp * np.asarray(img, np.float32)[..., first]
                ) / (pass_spp_[p] + extra_spp)
                done += 1
                if progress is not None:
                    progress(done, total)
    info = {"renderer": "mitsuba", "version": mi.__version__, "variant": variant, "note": note,
            "fallback": fell_back(), "integrator": INTEGRATOR, "max_depth": int(max_depth),
            "spp": max(pass_spp_), "pass_spp": pass_spp_,
            "sampler": sampler, "passes": passes,
            "extra_spp": int(extra_spp) if extra else 0,
            "extra_pixels": int(sum(r[2] * r[3] for _, r in extra)),
            "rr_depth": int(DEFAULT_RR_DEPTH if rr_depth is None else rr_depth),
            "bricks": "adaptive" if brick is None else int(brick),
            **(optics or Optics()).describe()}
    info["layout"] = layout
    return outs, info


def half_spp(spp: int | Sequence[int]) -> int | list[int]:
    """Samples per pixel of each half (:func:`render_print_halves`): ``ceil(n / 2)`` of each
    count ``n`` (an odd count renders one sample more in all; a count of 1, 1 per half)."""
    if np.ndim(spp) == 0:
        return -(-int(spp) // 2)
    return [-(-int(n) // 2) for n in spp]


def render_print_halves(sigma_t: NDArray, albedo: NDArray, lo: NDArray, hi: NDArray,
                        views: list[View], resolution: int, spp: int | Sequence[int],
                        seed: int, max_depth: int = DEFAULT_MAX_DEPTH,
                        key_light: float = 0.0, floor: bool = False,
                        progress: Callable[[int, int], None] | None = None,
                        cancelled: Callable[[], bool] | None = None,
                        sampler: str = DEFAULT_SAMPLER, optics: Optics | None = None,
                        extra: list[tuple[int, tuple[int, int, int, int]]] = (),
                        extra_spp: int = 0, brick: int | None = None,
                        rr_depth: int | None = None, layout: str = "rgb"
                        ) -> tuple[NDArray, tuple[NDArray, NDArray], dict]:
    """The proof's print render: two independent halves of the samples, Mitsuba seeds ``seed``
    and ``seed + 1`` at :func:`half_spp` of ``spp`` (per pass) and of ``extra_spp`` each, and
    their mean::

        L = (L_a + L_b) / 2

    an unbiased estimate with the variance of one render at ``spp`` (each half carries half the
    samples; Var L = Var L_a / 2). The two halves also give the noise floor
    (:func:`.compare.noise_floor_from_halves`) at no further render. Returns ``(mean, (a, b),
    info)``, images ``(views, res, res, n_bands)``; ``info`` as :func:`render_print_seeds`' with
    ``spp``, ``pass_spp`` and ``extra_spp`` the totals of both halves and ``halves`` the seeds
    and counts of each."""
    half = half_spp(spp)
    half_extra = -(-int(extra_spp) // 2)
    (a, b), info = render_print_seeds(sigma_t, albedo, lo, hi, views, resolution, half,
                                      (int(seed), int(seed) + 1), max_depth, key_light, floor,
                                      progress, cancelled, sampler, optics, rr_depth,
                                      extra=extra,
                                      extra_spp=half_extra, brick=brick, layout=layout)
    info["halves"] = {"seeds": [int(seed), int(seed) + 1], "pass_spp": info["pass_spp"],
                      "extra_spp": info["extra_spp"]}
    info["pass_spp"] = [2 * n for n in info["pass_spp"]]
    info["spp"] = max(info["pass_spp"])
    info["extra_spp"] = 2 * info["extra_spp"]
    return (a.astype(np.float64) + b) / 2.0, (a, b), info


def pass_bands(n_bands: int, layout: str = "rgb") -> list[tuple[int, int, int]]:
    """The bands each Mitsuba pass carries in its three channels: ``"rgb"``, three
    consecutive bands a pass (the last pass repeats its last band when ``n_bands`` is not a
    multiple of 3); ``"mono"``, one band a pass in all three channels (``n_bands`` passes)."""
    n = int(n_bands)
    if layout == "mono":
        return [(b, b, b) for b in range(n)]
    if layout != "rgb":
        raise ValueError(f"layout must be one of {LAYOUTS}, not {layout!r}")
    out = []
    for b0 in range(0, n, 3):
        g = list(range(b0, min(b0 + 3, n)))
        out.append(tuple(g + [g[-1]] * (3 - len(g))))
    return out


def pass_spp(xyz_weights: NDArray, spp: int, faint: float = FAINT_PASS,
             layout: str = "rgb") -> list[int]:
    """Samples per pixel of each pass (three bands each, ``xyz_weights`` (n_bands, 3) the
    bands' CIE XYZ weights, :mod:`.spectral`): ``spp``, but a quarter of it (at least 1) in a
    pass whose colour weight (the norm of its bands' XYZ weights) is below ``faint`` times the
    largest pass's. Its noise reaches the colour through that weight: with the default 12
    bands the 650-730 nm pass weighs 0.044 against 0.44-0.60 and carried 0.05 of the 0.99
    S-CIELAB noise floor at 16 spp (docs/physics.md), while its samples cost as much as the
    others'."""
    w = np.asarray(xyz_weights, np.float64)
    norm = np.array([np.linalg.norm(w[sorted(set(g))])
                     for g in pass_bands(w.shape[0], layout)])
    return [int(spp) if n >= faint * norm.max() else max(1, int(spp) // 4) for n in norm]


def thick_tiles(direct_T: NDArray, threshold: float, tile: int = TILE_PX
                ) -> list[tuple[int, int, int, int]]:
    """Squares (x0, y0, tile, tile) of one size covering the pixels of one view whose direct
    transmittance ``direct_T`` (res, res) is below ``threshold``: the optically thick parts of
    the print, where the scattered light (and its noise) is. The tiles of a ``tile``-pixel grid
    holding such pixels (those at the frame's right or bottom edge moved inwards, overlapping
    their neighbour, so all have one size: one Mitsuba kernel serves them). The choice depends
    on the medium only (the exact transmittance), never on the render's samples."""
    thick = np.asarray(direct_T) < threshold
    res_y, res_x = thick.shape
    tile = min(int(tile), res_x, res_y)
    out = []
    for y0 in range(0, res_y, tile):
        for x0 in range(0, res_x, tile):
            if thick[y0:y0 + tile, x0:x0 + tile].any():
                out.append((min(x0, res_x - tile), min(y0, res_y - tile), tile, tile))
    return out
