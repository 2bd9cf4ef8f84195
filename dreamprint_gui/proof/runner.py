"""``dreamprint proof``: source and print rendered on the same cameras, compared, written out.

Defines :class:`ProofSettings`, :class:`ProofProgress`, :func:`run_proof` (a generator, driven
by the CLI and the GUI alike, returning the report) and :func:`validate`.

Steps: labels of the job (the engine's, for a source and a ``--method``; or a job folder's
slices) -> block fractions (:mod:`.medium`) -> per-band sigma_t, albedo -> Mitsuba renders
(:mod:`.print_render`) -> XYZ; the source sampled on the same cells and rendered by
emission-absorption (:mod:`.source_render`) -> comparison (:mod:`.compare`). Output
``DIR/view_NN_source.png``, ``view_NN_print.png``, ``view_NN_de2000.png``,
``contact_sheet.png``, ``proof.json``, written in a temporary sibling folder renamed to DIR
when complete; a cancel or an error removes it, so DIR is complete or absent.
"""

from __future__ import annotations

import json
import math
import threading
import time
from collections.abc import Generator
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np

from dreamprint_gui.core import progress as core_progress
from dreamprint_gui.core.errors import DreamPrintError
from dreamprint_gui.gamut.alignment import predicted_appearance
from dreamprint_gui.job.halftone import HALFTONE_METHODS
from dreamprint_gui.job.plan import JobCancelled
from dreamprint_gui.job.spec import HasSpec
from dreamprint_gui.physics.clear_bounds import clear_is_modelled, clear_low_bound
from dreamprint_gui.proof.cameras import orbit_views
from dreamprint_gui.proof.clear_report import clear_report
from dreamprint_gui.proof.compare import (
    COVERAGE_THRESHOLD,
    compare_view,
    de_heatmap,
    noise_corrected_figures,
    noise_floor_from_halves,
    summarise,
    summarise_floor,
    to_display,
)
from dreamprint_gui.proof.contact_sheet import contact_sheet
from dreamprint_gui.proof.km_to_rte import describe_conversion
from dreamprint_gui.proof.labels import JobFolderLabels, is_job_folder
from dreamprint_gui.proof.medium import block_for_cell, block_fractions, medium_coefficients
from dreamprint_gui.proof.methods import METHODS, method_labels
from dreamprint_gui.proof.optics import resolve_optics
from dreamprint_gui.proof.print_render import (
    SAMPLERS,
    hides_direct,
    pass_spp,
    render_print_halves,
    render_print_seeds,
    thick_tiles,
)
from dreamprint_gui.proof.reference import intent_reference, job_intent
from dreamprint_gui.proof.scielab import samples_per_degree
from dreamprint_gui.proof.source_cache import cached_render_source
from dreamprint_gui.proof.source_render import (
    SourceField,
    edge_refine,
    optical_depth,
    sample_source,
)
from dreamprint_gui.proof.spectral import spectral_bands
from dreamprint_gui.proof.staging import staged_folder

__all__ = ["ProofSettings", "ProofProgress", "run_proof", "validate", "render_proof",
           "write_proof", "print_xyz", "MAX_RESOLUTION", "MAX_SPP", "DEFAULT_SPP",
           "DEFAULT_RESOLUTION", "DEFAULT_MAX_CELLS", "DEFAULT_THICK_SPP", "THICK_T",
           "in_thread"]

MAX_RESOLUTION = 4096
MAX_SPP = 65536
MAX_VIEWS = 64
# 64 (in two halves of 32, render_print_halves): the demo's noise floor 0.48 S-CIELAB at 47 s
# per view (bench_proof.py, quiet 2-core host, adaptive bricks); 16 gave 0.98 (docs/physics.md
# "Noise floor")
DEFAULT_SPP = 64
DEFAULT_RESOLUTION = 256
DEFAULT_MAX_CELLS = 128
DEFAULT_THICK_SPP = 0
THICK_T = 0.1     # direct transmittance (luminance) below which a pixel gets thick_spp more


@dataclass(frozen=True)
class ProofSettings(HasSpec):
    """A proof: the print (the :class:`..job.spec.PrintSpec` fields, ``.spec``; or a job
    folder as the source) and the proof's own options (cameras, renderer, figures)."""

    source: str                      # a volume file, 'demo', or a job folder
    output: str | None = None
    height_mm: float | None = None
    size_mm: tuple[float, float, float] | None = None
    printer: str | None = None
    profile: str | None = None
    views: int = 4
    resolution: int = DEFAULT_RESOLUTION
    spp: int = DEFAULT_SPP
    method: str = "paper"
    halftone: str = "blue-noise"
    seed: int = 0
    density_scale: float = 1.0
    background: str = "clear"        # what voxels below the density threshold become
    max_cells: int = DEFAULT_MAX_CELLS
    layers_per_block: int = 2
    bands: int = 12
    max_depth: int = 512
    key_light: float = 0.0
    floor: bool = False
    viewing_distance_mm: float = 500.0   # S-CIELAB: the print seen at its size from here
    noise_floor: bool = True             # report the floor (from the print's two halves: free)
    sampler: str = "independent"         # Mitsuba's sampler of the print render
    thick_spp: int = DEFAULT_THICK_SPP   # extra spp on the tiles of the optically thick parts
    surface: str | None = None           # none | glossy | matte (None: the profile's, else none)
    phase: str | None = None             # isotropic | hg:G (None: the profile's, else isotropic)
    overwrite: bool = False
    table_size: int = 100
    source_options: tuple[tuple[str, Any], ...] = ()
    compensation: str | None = None  # a correction file (job.correction) the labels apply
    up: str | None = None            # source axis that becomes +z (None: auto)
    rotate: int = 0                  # degrees about the print's z
    fit: str = "occupied"            # "occupied" or "box"
    clear_low_bound: bool = False    # a modelled Clear: render again at its low bound
    content: str = "auto"            # fog | solid | auto (job.content)
    objective: str | None = None     # colour table objective (None: the profile's/default)
    intent: str | None = None        # rendering intent (None: the profile's/colorimetric)
    sampling: str | None = None      # None: the reader's default; "nearest" | "linear"


@dataclass(frozen=True)
class ProofProgress:
    stage: str          # "preparing", "labels", "source", "print", "compare", "gamut floor",
    #                     "writing", "done"
    done: int
    total: int
    elapsed_s: float
    message: str = ""


def validate(s: ProofSettings) -> None:
    """One-line errors for absurd settings, before any work."""

    if not 8 <= int(s.resolution) <= MAX_RESOLUTION:
        raise DreamPrintError(f"--resolution must be 8..{MAX_RESOLUTION} pixels, got "
                              f"{s.resolution}")
    if not 1 <= int(s.spp) <= MAX_SPP:
        raise DreamPrintError(f"--spp must be 1..{MAX_SPP}, got {s.spp}")
    if not 0 <= int(s.thick_spp) <= MAX_SPP:
        raise DreamPrintError(f"--thick-spp must be 0..{MAX_SPP}, got {s.thick_spp}")
    if not 1 <= int(s.views) <= MAX_VIEWS:
        raise DreamPrintError(f"--views must be 1..{MAX_VIEWS}, got {s.views}")
    if s.method not in METHODS:
        raise DreamPrintError(f"unknown method '{s.method}' (use {', '.join(METHODS)})")
    if s.halftone not in HALFTONE_METHODS:
        raise DreamPrintError(f"unknown halftoning '{s.halftone}' (use "
                              f"{' or '.join(HALFTONE_METHODS)})")
    if s.background not in ("clear", "empty"):
        raise DreamPrintError(f"--background must be clear or empty, not '{s.background}'")
    if s.compensation is not None and s.method != "paper":
        raise DreamPrintError("--compensation applies to the paper's method (the job's own)")
    if not 4 <= int(s.max_cells) <= 512:
        raise DreamPrintError(f"--cells must be 4..512, got {s.max_cells}")
    if not 1 <= int(s.bands) <= 36:
        raise DreamPrintError(f"--bands must be 1..36, got {s.bands}")
    if not 1 <= int(s.max_depth) <= 100000:
        raise DreamPrintError(f"--max-depth must be 1..100000, got {s.max_depth}")
    if not (math.isfinite(s.key_light) and s.key_light >= 0):
        raise DreamPrintError(f"--key-light must be >= 0, got {s.key_light}")
    if not (math.isfinite(s.viewing_distance_mm) and 10 <= s.viewing_distance_mm <= 1e5):
        raise DreamPrintError(f"--viewing-distance-mm must be 10..100000, got "
                              f"{s.viewing_distance_mm}")
    if s.sampler not in SAMPLERS:
        raise DreamPrintError(f"unknown sampler '{s.sampler}' (use {', '.join(SAMPLERS)})")
    optics = resolve_optics(s.surface, s.phase)     # the names, before any work
    if optics.surface != "none" and s.background == "empty":
        raise DreamPrintError("--surface needs --background clear: the surface is the print's "
                              "box of Clear resin, which an empty background does not print")


def _labels(s: ProofSettings):

    if is_job_folder(s.source):
        if s.method != "paper" or s.height_mm is not None or s.size_mm is not None:
            raise DreamPrintError("a job folder is judged as printed: --method, --height-mm "
                                  "and --size-mm do not apply to it", s.source)
        return JobFolderLabels(s.source, s.profile)
    return method_labels(s)


def render_proof(s: ProofSettings, cancel: threading.Event | None = None
                 ) -> Generator[ProofProgress, None, dict[str, Any]]:
    """Render and compare (no files); returns ``{"report": ..., "images": ...}``."""

    validate(s)
    t0 = time.perf_counter()
    timings: dict[str, float] = {}

    def el() -> float:
        return time.perf_counter() - t0

    def is_cancelled() -> bool:
        return cancel is not None and cancel.is_set()

    yield ProofProgress("preparing", 0, 1, el(), "opening the source, tables and renderer")
    # every stage's work runs in a thread (in_thread) so that the generator still says how it
    # goes every core.progress.HEARTBEAT_S seconds, and progress and cancel reach the caller
    box: dict[str, Any] = {}
    prog: dict[str, tuple[int, int]] = {"p": (0, 1)}

    def work_prepare() -> None:
        box["m"] = _labels(s)

    yield from in_thread(work_prepare, "preparing", prog, el, box, cancel)
    lab = box.pop("m")
    bands = spectral_bands(lab.profile, s.bands)
    size = tuple(n * v for n, v in zip(lab.shape_xyz, lab.voxel_mm, strict=True))
    block = block_for_cell(lab.voxel_mm, size, s.max_cells)
    timings["prepare"] = el()

    # labels -> block fractions
    prog["p"] = (0, 1)

    def work_fractions() -> None:
        box["m"] = block_fractions(lab.layer, lab.shape_xyz, lab.voxel_mm, block,
                                   s.layers_per_block,
                                   progress=lambda d, t: prog.__setitem__("p", (d, t)),
                                   cancelled=is_cancelled)

    yield from in_thread(work_fractions, "labels", prog, el, box, cancel)
    medium = box.pop("m")
    timings["labels"] = el() - sum(timings.values())
    lo, hi = medium.box_mm
    views = orbit_views(medium.print_size_mm, s.views)
    optics = resolve_optics(s.surface, s.phase, lab.profile.proof_optics)
    if optics.surface != "none" and s.background == "empty":
        raise DreamPrintError("--surface needs --background clear (the profile asks for a "
                              f"{optics.surface} surface; give --surface none)")

    yield ProofProgress("source", 0, len(views), el(), "rendering the source")
    t1 = time.perf_counter()
    # the reference: the source as the job's rendering intent maps it (.reference)
    intent = job_intent(lab)
    src_lin, src_alpha = [], []
    floor_rho = 0.5 if s.floor else None
    prog["p"] = (0, len(views))

    def work_source() -> None:
        # the print's coefficients too: with the source's sampling, the silent part
        # between the labels and the first view (measured 16.5 s on a cold cache)
        box["k"] = medium_coefficients(medium.fractions, bands.K, bands.S, optics)
        raw = sample_source(lab.source, lab.grid, medium.block_xyz, lab.density_scale,
                            medium.cells_xyz, lo)
        field = intent_reference(raw, intent, lab.profile)
        hits = 0
        for i, v in enumerate(views):
            if is_cancelled():
                raise JobCancelled("the proof was cancelled")
            # the same field on the same camera renders the same image: kept on disk
            rgb, a, hit = cached_render_source(field, v, s.resolution, floor_rho=floor_rho)
            hits += hit
            src_lin.append(rgb)
            src_alpha.append(a)
            prog["p"] = (i + 1, len(views))
        box["m"] = (raw, hits)

    yield from in_thread(work_source, "source", prog, el, box, cancel)
    sigma_t, albedo = box.pop("k")
    raw, hits = box.pop("m")
    timings["source_render"] = time.perf_counter() - t1

    t2 = time.perf_counter()
    y_w = bands.xyz_weights[:, 1] / bands.xyz_weights[:, 1].sum()
    direct_T: list[np.ndarray] = []
    box.clear()
    prog["p"] = (0, 1)

    def work_print() -> None:
        # the direct transmittance and its thick tiles (measured 7.6 s before the first
        # pass, silent when it ran in the generator)
        direct_T.extend(optical_depth(sigma_t, lo, medium.cell_mm, v, s.resolution, sub=3,
                                      refine=edge_refine(raw)) for v in views)
        extra = [(i, r) for i, T in enumerate(direct_T)
                 for r in thick_tiles(T @ y_w, THICK_T)]
        # two halves of the samples at seeds s, s + 1: their mean is the print, their
        # difference the noise floor (with or without reporting it: the same image)
        box["m"] = render_print_halves(
            sigma_t, albedo, lo, hi, views, s.resolution,
            pass_spp(bands.xyz_weights, s.spp), s.seed, s.max_depth,
            s.key_light, s.floor, progress=lambda d, t: prog.__setitem__("p", (d, t)),
            cancelled=is_cancelled, sampler=s.sampler, optics=optics, extra=extra,
            extra_spp=s.thick_spp)

    yield from in_thread(work_print, "print", prog, el, box, cancel)
    prn_bands, halves, info = box["m"]
    seeds = tuple(info["halves"]["seeds"])
    timings["print_render"] = time.perf_counter() - t2
    # one view's print (both halves, all bands)
    timings["print_render_per_view"] = timings["print_render"] / len(views)

    t3 = time.perf_counter()
    yield ProofProgress("compare", 0, len(views), el(), "comparing")
    obs = bands.observer
    to_xyz = np.linalg.inv(obs.xyz_to_linear_srgb)
    per_view, images, prints = [], [], []
    # the print at its real size on the frame (orthographic), seen from the viewing distance
    spd = samples_per_degree(2.0 * views[0].half_mm / s.resolution, s.viewing_distance_mm)
    for i, v in enumerate(views):
        T = direct_T[i]
        prn_alpha = 1.0 - T @ y_w
        src_xyz = src_lin[i] @ to_xyz.T
        prn_xyz = print_xyz(bands, prn_bands[i], T, s.floor, optics)
        prints.append((prn_xyz, prn_alpha))
        fig, de = compare_view(src_xyz, prn_xyz, src_alpha[i], prn_alpha, obs, spd)
        # the halves: the dE2000 mean less the render's noise, and the noise floor
        half_xyz = [print_xyz(bands, h[i], T, s.floor, optics) for h in halves]
        fig.update(noise_corrected_figures(src_xyz, *half_xyz, src_alpha[i], prn_alpha, obs,
                                           de=de))
        if s.noise_floor:
            fig["noise_floor"] = noise_floor_from_halves(*half_xyz, prn_alpha, obs, spd,
                                                         source_alpha=src_alpha[i])
        per_view.append({"view": i, **v.describe(), **fig})
        images.append({"source": src_lin[i], "print": obs.XYZ_to_linear_sRGB(prn_xyz),
                       "de2000": de})
        yield ProofProgress("compare", i + 1, len(views), el())
    timings["compare"] = time.perf_counter() - t3
    t5 = time.perf_counter()
    overall = summarise(per_view)
    bounds = None
    if s.clear_low_bound and clear_is_modelled(lab.profile):
        bounds = yield from _at_clear_low_bound(
            s, lab, medium, optics, views, src_lin, src_alpha, prints, spd, el, cancel,
            edge_refine(raw))
    clear = clear_report(lab.profile, bounds, s.clear_low_bound)
    timings["clear_low_bound"] = time.perf_counter() - t5
    t4 = time.perf_counter()
    box.clear()
    prog["p"] = (0, 1)

    def work_floor() -> None:
        box["m"] = gamut_floor(lab, raw, views, s.resolution, src_lin, src_alpha, obs, spd,
                               floor_rho)
        prog["p"] = (1, 1)

    # the tables' prediction rendered (measured 49.8 s silent on a cold cache, load 7)
    yield from in_thread(work_floor, "gamut floor", prog, el, box, cancel)
    floor_fig = box.pop("m")
    timings["gamut_floor"] = time.perf_counter() - t4
    timings["total"] = el()
    report = {
        "format": "dreamprint-proof", "format_version": 1,
        "source": s.source, "method": s.method,
        "halftoning": getattr(lab, "halftoning", {}),
        "settings": {k: (list(v) if isinstance(v, tuple) else v)
                     for k, v in asdict(s).items() if k not in ("output", "overwrite")},
        "print_size_mm": [round(x, 4) for x in medium.print_size_mm],
        "grid_dimensions": list(lab.shape_xyz),
        "medium": medium.describe(),
        "spectral": bands.describe(),
        "km_to_rte": describe_conversion(optics),
        "optics": {**optics.describe(),
                   "from": ("command line" if s.surface is not None or s.phase is not None
                            else "profile" if lab.profile.proof_optics else "defaults")},
        "renderer": info,
        "source_renderer": "emission-absorption ray march (dreamprint)",
        "reference": {"intent": intent,
                      "what": "the source as the job's rendering intent maps its colours "
                              "(proof/reference.py); colorimetric: the source's own"},
        # views whose source render was read from the disk cache (proof/source_cache.py)
        "source_renders_cached": hits,
        "lighting": {"environment": "uniform white (D65), radiance 1",
                     "key_light_irradiance": s.key_light, "floor": s.floor},
        "viewing": {"distance_mm": s.viewing_distance_mm,
                    "pixel_mm": round(2.0 * views[0].half_mm / s.resolution, 5),
                    "pixels_per_degree": round(spd, 3),
                    "metric": "S-CIELAB (Zhang & Wandell 1996) then CIEDE2000"},
        "views": per_view,
        "overall": overall,
        "headline": "overall.inside_source_*: inside the source (compare.headline)",
        "clear": clear,
        "compensation": _compensation(lab),
        "gamut_floor": floor_fig,
        "noise_floor": (
            {"method": f"the print is the mean of two independent halves of its samples "
                       f"(Mitsuba seeds {seeds[0]} and {seeds[1]}); figures over the print's "
                       "object pixels between the proof +- (half a - half b) / (2 sqrt 2), a "
                       "pair that differs as two independent proofs at these settings do "
                       "(proof/compare.py)",
             "seeds": list(seeds), **summarise_floor([v["noise_floor"] for v in per_view])}
            if s.noise_floor else None),
        "timings_s": timings,
    }
    return {"report": report, "images": images}


def _at_clear_low_bound(s: ProofSettings, lab, medium, optics, views, src_lin: list,
                        src_alpha: list, prints: list, spd: float, el, cancel,
                        refine: int = 0):
    """The same labels rendered (one seed) with the Clear at its low bound
    (:func:`~dreamprint_gui.physics.clear_bounds.clear_low_bound`); both prints compared with
    the same source renders on the same pixels (the union of the two comparisons' object
    pixels): ``(modelled, low bound)`` overall figures (:func:`.compare.summarise`)."""
    low = clear_low_bound(lab.profile)
    bands = spectral_bands(low, s.bands)
    sigma_t, albedo = medium_coefficients(medium.fractions, bands.K, bands.S, optics)
    lo, hi = medium.box_mm
    y_w = bands.xyz_weights[:, 1] / bands.xyz_weights[:, 1].sum()
    direct_T = [optical_depth(sigma_t, lo, medium.cell_mm, v, s.resolution, sub=3,
                              refine=refine) for v in views]
    extra = [(i, r) for i, T in enumerate(direct_T) for r in thick_tiles(T @ y_w, THICK_T)]
    box: dict[str, Any] = {}
    prog: dict[str, tuple[int, int]] = {"p": (0, 1)}

    def work() -> None:
        box["m"] = render_print_seeds(
            sigma_t, albedo, lo, hi, views, s.resolution,
            pass_spp(bands.xyz_weights, s.spp), (s.seed,), s.max_depth, s.key_light,
            s.floor, progress=lambda d, t: prog.__setitem__("p", (d, t)),
            cancelled=lambda: cancel is not None and cancel.is_set(), sampler=s.sampler,
            optics=optics, extra=extra, extra_spp=s.thick_spp)

    yield ProofProgress("print", 0, 1, el(), "rendering the print with the Clear at its low "
                        "bound")
    yield from in_thread(work, "print", prog, el, box, cancel)
    rendered = box["m"][0][0]
    to_xyz = np.linalg.inv(bands.observer.xyz_to_linear_srgb)
    both: tuple[list, list] = ([], [])
    for i, v in enumerate(views):
        T = direct_T[i]
        low_alpha = 1.0 - T @ y_w
        src_xyz = src_lin[i] @ to_xyz.T
        mask = ((src_alpha[i] > COVERAGE_THRESHOLD) | (prints[i][1] > COVERAGE_THRESHOLD)
                | (low_alpha > COVERAGE_THRESHOLD))
        for out, (xyz, alpha) in zip(both, (prints[i], (print_xyz(
                bands, rendered[i], T, s.floor, optics), low_alpha)), strict=True):
            fig, _ = compare_view(src_xyz, xyz, src_alpha[i], alpha, bands.observer, spd,
                                  mask=mask)
            out.append({"view": i, **v.describe(), **fig})
    return summarise(both[0]), summarise(both[1])


def gamut_floor(lab, field, views, resolution: int, src_lin: list, src_alpha: list, obs,
                samples_per_deg: float, floor_rho: float | None = None) -> dict | None:
    """The gamut floor: the source ``field`` (its own colours: the tables map them) rendered
    (emission-absorption, the same cameras) with each cell's colour and density replaced by
    what the job's tables deposit for them
    (:func:`dreamprint_gui.gamut.alignment.predicted_appearance`: lookup, density alignment,
    the mixture's KM colour at the reference thickness and its sigma; cells below the
    background threshold empty), compared with the source render. No light transport between
    voxels and no background block: what any method with these inks could at best show,
    compared with the proof's reference ``src_lin`` (the source as the intent maps it). None
    for a job folder (no tables)."""
    ctx = getattr(lab, "ctx", None)
    if ctx is None or ctx.tables is None:
        return None
    # cells below the background threshold print nothing here: only the others are predicted
    kept = field.sigma >= ctx.halftoner.threshold
    rgb = np.clip(field.colour[kept], 0, 1)
    srgb = np.where(rgb <= 0.0031308, 12.92 * rgb, 1.055 * rgb ** (1 / 2.4) - 0.055)
    pred, sig_kept = predicted_appearance(ctx.tables, lab.profile, srgb, field.sigma[kept])
    pred = np.clip(pred, 0, 1)
    lin = np.zeros(field.colour.shape, np.float64)
    lin[kept] = np.where(pred <= 0.04045, pred / 12.92, ((pred + 0.055) / 1.055) ** 2.4)
    sig = np.zeros(field.sigma.shape, np.float64)
    sig[kept] = sig_kept
    floor_field = SourceField(np.ascontiguousarray(sig, np.float32),
                              np.ascontiguousarray(lin, np.float32), field.lo_mm,
                              field.cell_mm, field.nearest)
    to_xyz = np.linalg.inv(obs.xyz_to_linear_srgb)
    per_view = []
    for i, v in enumerate(views):
        rgb_f, a_f, _ = cached_render_source(floor_field, v, resolution, floor_rho=floor_rho)
        fig, _ = compare_view(src_lin[i] @ to_xyz.T, rgb_f @ to_xyz.T, src_alpha[i], a_f, obs,
                              samples_per_deg)
        per_view.append(fig)
    return summarise(per_view)


def _compensation(lab) -> dict | None:
    """What proof.json says of a correction the labels applied: the file, its field and the
    optimiser's before/after figures on its training cameras."""
    corr = getattr(getattr(lab, "ctx", None), "correction", None)
    if corr is None:
        return None
    return {"path": str(lab.settings.compensation), **corr.describe(),
            "optimiser_figures": corr.report.get("figures")}


def print_xyz(bands, rendered: np.ndarray, direct_T: np.ndarray, floor: bool,
              optics=None) -> np.ndarray:
    """XYZ (res, res, 3) of a print view: Mitsuba's band images plus, without a floor or a
    surface, the environment seen straight through (the renderer hides it; ``direct_T`` per
    band is its exact expectation, :mod:`.print_render`)."""
    return bands.to_XYZ(rendered + (direct_T if hides_direct(floor, optics) else 0.0))


def in_thread(fn, stage, prog, el, box, cancel):
    """Run ``fn`` in a thread and yield :class:`ProofProgress` of ``stage`` whenever
    ``prog["p"]`` (done, total) changes, and again (same counts, the elapsed time) once
    ``core.progress.HEARTBEAT_S`` seconds passed without a change: one Mitsuba render of the
    print, about 20 s, leaves the GIL to this generator while it runs. An error ``fn`` raises
    is kept in ``box["e"]`` and raised here, and a consumer that stops (cancel, close) sets
    ``cancel`` and waits for the thread."""

    def run() -> None:
        try:
            fn()
        except BaseException as exc:  # noqa: BLE001 - re-raised below, in the generator
            box["e"] = exc

    th = threading.Thread(target=run, name=f"dreamprint-proof-{stage}", daemon=True)
    th.start()
    last = None
    said = time.monotonic()
    try:
        while th.is_alive():
            th.join(0.2)
            p = prog["p"]
            now = time.monotonic()
            if p != last or now - said >= core_progress.HEARTBEAT_S:
                last, said = p, now
                yield ProofProgress(stage, p[0], p[1], el())
    except BaseException:
        if cancel is not None:
            cancel.set()
        th.join()
        raise
    if "e" in box:
        raise box["e"]


def write_proof(result: dict, folder: Path) -> None:
    """Write the images, contact sheet and proof.json of ``result`` into ``folder``."""
    from PIL import Image


    rows = []
    for i, im in enumerate(result["images"]):
        src = to_display(im["source"])
        prn = to_display(im["print"])
        de = de_heatmap(im["de2000"])
        Image.fromarray(src).save(folder / f"view_{i:02d}_source.png")
        Image.fromarray(prn).save(folder / f"view_{i:02d}_print.png")
        Image.fromarray(de).save(folder / f"view_{i:02d}_de2000.png")
        rows.append((src, prn, de))
    contact_sheet(rows, result["report"]).save(folder / "contact_sheet.png")
    (folder / "proof.json").write_text(json.dumps(result["report"], indent=2) + "\n",
                                       encoding="utf-8")


def _check_target(out: Path, overwrite: bool, source: str | None = None) -> None:
    if source is not None and source != "demo":
        src, dst = Path(source).resolve(), out.resolve()
        if src == dst or dst in src.parents:
            # --overwrite would replace the source (or the job folder judged) by the proof
            raise DreamPrintError(f"the output folder is, or contains, the source {source}; "
                                  "choose another -o", out)
    if out.exists() and not overwrite:
        raise DreamPrintError("already exists (use --overwrite to replace it)", out)
    if out.exists() and not out.is_dir():
        raise DreamPrintError("exists and is not a folder", out)
    parent = out.absolute().parent
    if not parent.is_dir():
        raise DreamPrintError("the folder to write into does not exist", parent)


def run_proof(s: ProofSettings, cancel: threading.Event | None = None
              ) -> Generator[ProofProgress, None, dict[str, Any]]:
    """Render, compare and write ``s.output`` atomically; returns the report."""
    if s.output is None:
        raise DreamPrintError("no output folder given (-o DIR)")
    out = Path(s.output)
    _check_target(out, s.overwrite, s.source)
    validate(s)
    result = yield from render_proof(s, cancel)
    if cancel is not None and cancel.is_set():
        raise JobCancelled("the proof was cancelled")
    total = result["report"]["timings_s"]["total"]
    yield ProofProgress("writing", 0, 1, total, "writing images")
    t_w = time.perf_counter()
    with staged_folder(out, "proof") as tmp:
        box: dict[str, Any] = {}
        prog = {"p": (0, 1)}

        def work_write() -> None:
            write_proof(result, tmp)
            prog["p"] = (1, 1)

        # the contact sheet and images (measured 14 s silent): a line every HEARTBEAT_S
        yield from in_thread(work_write, "writing", prog,
                             lambda: total + time.perf_counter() - t_w, box, cancel)
        if cancel is not None and cancel.is_set():
            raise JobCancelled("the proof was cancelled")
    yield ProofProgress("done", 1, 1, result["report"]["timings_s"]["total"], str(out))
    return result["report"]
