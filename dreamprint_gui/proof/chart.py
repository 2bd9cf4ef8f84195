"""Chart proof: each recipe of a printed chart as a flat patch, seen as an instrument sees it.

Defines :class:`ChartSettings`, :class:`Chart`, :func:`load_chart` (files),
:func:`chart_from_arrays` (the calibration wizard's arrays), :func:`render_chart`,
:func:`proof_chart` (render + report, nothing written), :func:`chart_picture`,
:func:`run_chart_proof` (the command), :data:`GEOMETRIES` and :data:`DEFAULT_GEOMETRY`.

The same model as the object proof (:mod:`.runner`): a patch is a uniform mixture whose K and S
mix linearly in the recipe's fractions (paper eq. 5), converted to sigma_a, sigma_s and phase
function by :mod:`.km_to_rte` with the proof's optics (:mod:`.optics`: surface, phase) so that
each thick patch reads KM's R_inf at the chart's geometry (the calibration's model), rendered
by Mitsuba's ``volpath`` in the proof's spectral bands (:mod:`.spectral`) and integrated to XYZ
and CIELAB with the CIE 1931 observer under D65, as the measured spectra are.

Scene: the patches side by side (``PATCH_MM`` square boxes each, ``THICK_MM`` deep unless a
thickness is given: "optically thick", the inks' diffusion lengths are below 1 mm), a black
backing behind them, the surface (if any) on each patch's faces. One orthographic camera sees the
whole chart; each patch's reflectance factor is the mean of the pixels within ``SPOT_MM`` of
its centre (its edges, within 3 mm, where light crosses from the neighbours, are not read).

Instrument geometries (reflectance factor against a perfect white diffuser under the same
light):

- ``d:8`` (the default; sphere instruments, specular component included, SCI): a uniform
  environment of radiance 1 lights the patch from every direction; the camera looks 8 degrees
  off the normal. A perfect white diffuser would return radiance 1, so the factor is the
  radiance.
- ``45:0`` (most hand-held spectrophotometers; the specular reflection is not seen): a
  directional light 45 degrees off the normal giving irradiance 1 on the patch, no
  environment, the camera on the normal. A perfect white diffuser would return 1 / pi, so the
  factor is pi times the radiance.

Output folder (written complete or not at all): ``chart_proof.json`` (settings, per patch the
recipe, proof Lab and, with measurements, measured Lab and dE2000; mean, p95, worst patches),
``patches.csv`` (the same per patch) and ``chart.png`` (each patch as a square: measured left,
proofed right; the proof alone without measurements).
"""

from __future__ import annotations

import csv
import json
import math
import time
from collections.abc import Callable
from contextlib import AbstractContextManager, nullcontext
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from dreamprint_gui.core.errors import DreamPrintError
from dreamprint_gui.core.profile import INKS, InkProfile, load_profile
from dreamprint_gui.core.progress import eta_text, heartbeat
from dreamprint_gui.io.chart_files import read_chart
from dreamprint_gui.job.plan import JobCancelled
from dreamprint_gui.physics.colorimetry import delta_E2000, observer_for
from dreamprint_gui.proof.cameras import View
from dreamprint_gui.proof.compare import to_display
from dreamprint_gui.proof.km_to_rte import describe_conversion
from dreamprint_gui.proof.medium import medium_coefficients
from dreamprint_gui.proof.mitsuba_setup import load_mitsuba
from dreamprint_gui.proof.optics import Optics, resolve_optics
from dreamprint_gui.proof.print_render import BLOCK_PX, INTEGRATOR
from dreamprint_gui.proof.spectral import SpectralBands, spectral_bands
from dreamprint_gui.proof.staging import staged_folder

__all__ = ["ChartSettings", "Chart", "load_chart", "render_chart", "run_chart_proof",
           "chart_from_arrays", "proof_chart", "chart_picture", "chart_report", "GEOMETRIES",
           "DEFAULT_GEOMETRY", "DEFAULT_CHART_SPP", "PATCH_MM", "THICK_MM", "SPOT_MM"]

GEOMETRIES = ("d:8", "45:0")
DEFAULT_GEOMETRY = "d:8"
DEFAULT_CHART_SPP = 512
PATCH_MM = 12.0
THICK_MM = 10.0
SPOT_MM = 6.0
GAP_MM = 0.05
PIXELS_PER_PATCH = 8
MAX_PATCHES = 5000


@dataclass(frozen=True)
class ChartSettings:
    recipes: str
    reflectance: str | None = None
    output: str | None = None
    profile: str | None = None
    surface: str | None = None
    phase: str | None = None
    geometry: str = DEFAULT_GEOMETRY
    thickness_mm: float | None = None
    spp: int = DEFAULT_CHART_SPP
    bands: int = 12
    seed: int = 0
    max_depth: int = 512
    overwrite: bool = False


@dataclass(frozen=True)
class Chart:
    recipes: NDArray[np.float64]                 # (n, 6) INKS order
    measured_lab: NDArray[np.float64] | None     # (n, 3)
    profile: InkProfile
    optics: Optics


def _checked_optics(surface: str | None, phase: str | None, profile: InkProfile,
                    geometry: str) -> Optics:
    optics = resolve_optics(surface, phase, profile.proof_optics)
    if optics.surface == "glossy" and geometry == "45:0":
        raise DreamPrintError("a glossy surface cannot be proofed at 45:0 (the renderer cannot "
                              "connect a directional light through a smooth surface); use "
                              "geometry d:8 or a matte surface")
    return optics


def load_chart(s: ChartSettings) -> Chart:
    """Read and check everything before any rendering: one-line errors, nothing written."""
    if s.geometry not in GEOMETRIES:
        raise DreamPrintError(f"unknown geometry '{s.geometry}' (use {', '.join(GEOMETRIES)})")
    if s.thickness_mm is not None and not (math.isfinite(s.thickness_mm)
                                           and 0.01 <= s.thickness_mm <= 100):
        raise DreamPrintError(f"--thickness-mm must be 0.01..100, got {s.thickness_mm}")
    if not 1 <= int(s.spp) <= 65536:
        raise DreamPrintError(f"--spp must be 1..65536, got {s.spp}")
    if not 1 <= int(s.bands) <= 36:
        raise DreamPrintError(f"--bands must be 1..36, got {s.bands}")
    profile = load_profile(s.profile)
    optics = _checked_optics(s.surface, s.phase, profile, s.geometry)
    files = read_chart(s.recipes, s.reflectance, profile.wavelengths_nm,
                       max_patches=MAX_PATCHES)
    lab = None
    if files.reflectance is not None:
        lab = observer_for(profile.wavelengths_nm).spectra_to_Lab(files.reflectance)
    recipes = files.recipes
    return Chart(recipes, lab, profile, optics)


def _layout(n: int) -> tuple[int, int]:
    cols = int(math.ceil(math.sqrt(n)))
    return int(math.ceil(n / cols)), cols


def chart_scene(mi, sigma_t3: NDArray, albedo3: NDArray, optics: Optics, geometry: str,
                thickness_mm: float, spp: int, max_depth: int) -> tuple[dict, View, float]:
    """Mitsuba scene of a chart (rows, cols, 3 bands) with its camera; returns the scene, the
    view and the factor turning radiance into reflectance factor. The patches' faces are the
    plane x = 0 (normal +x), columns along +y, rows down along -z. Each patch is its own box
    with a homogeneous medium (its own majorant: one grid over the chart made delta tracking
    step at the darkest ink's rate in every patch) and the surface on its faces; the patches
    are ``GAP_MM`` apart (their sides are far from the spot read)."""
    T = mi.ScalarTransform4f
    rows, cols = sigma_t3.shape[:2]
    w, h, t = cols * PATCH_MM, rows * PATCH_MM, float(thickness_mm)
    phase = ({"type": "isotropic"} if optics.g == 0 else {"type": "hg", "g": float(optics.g)})
    d: dict = {"type": "scene",
               "integrator": {"type": INTEGRATOR, "max_depth": int(max_depth),
                              "rr_depth": int(max_depth), "hide_emitters": False,
                              "block_size": BLOCK_PX},
               "backing": {"type": "rectangle",
                           "to_world": T().translate([-t - 1e-3, 0.0, 0.0])
                           @ T().rotate([0, 1, 0], 90) @ T().scale([2 * w, 2 * h, 1.0]),
                           "bsdf": {"type": "diffuse", "reflectance": {"type": "rgb",
                                                                       "value": [0.0] * 3}}}}
    for r in range(rows):
        for c in range(cols):
            st = np.asarray(sigma_t3[r, c], np.float64)
            scale = float(max(st.max(), 1e-6))
            medium = {"type": "homogeneous", "scale": scale,
                      "sigma_t": {"type": "rgb", "value": (st / scale).tolist()},
                      "albedo": {"type": "rgb",
                                 "value": np.clip(albedo3[r, c], 0, 1).astype(float).tolist()},
                      "phase": dict(phase)}
            centre = [-t / 2, -w / 2 + (c + 0.5) * PATCH_MM, h / 2 - (r + 0.5) * PATCH_MM]
            half = [t / 2, PATCH_MM / 2 - GAP_MM, PATCH_MM / 2 - GAP_MM]
            d[f"patch_{r:03d}_{c:03d}"] = {
                "type": "cube", "to_world": T().translate(centre) @ T().scale(half),
                "bsdf": optics.bsdf() or {"type": "null"}, "interior": medium}
    if geometry == "d:8":
        d["environment"] = {"type": "constant", "radiance": {"type": "rgb", "value": [1.0] * 3}}
        view_el, factor = 8.0, 1.0
    else:  # 45:0: irradiance 1 on the patch
        a = math.radians(45.0)
        d["light"] = {"type": "directional", "direction": [-math.cos(a), 0.0, -math.sin(a)],
                      "irradiance": {"type": "rgb", "value": [1.0 / math.cos(a)] * 3}}
        view_el, factor = 0.0, math.pi
    half = max(w, h / math.cos(math.radians(view_el))) / 2
    view = View(0.0, view_el, half, 4.0 * max(w, h) + 10.0 * t)
    res = int(PIXELS_PER_PATCH * max(rows, cols) * 2 * half / max(w, h))
    d["camera"] = {"type": "orthographic",
                   "to_world": T().look_at(origin=[float(v) for v in view.eye],
                                           target=[0.0, 0.0, 0.0], up=[0.0, 0.0, 1.0])
                   @ T().scale([half, half, 1.0]),
                   "near_clip": 1e-3, "far_clip": 1e7,
                   "film": {"type": "hdrfilm", "width": res, "height": res,
                            "rfilter": {"type": "box"}, "pixel_format": "rgb"},
                   "sampler": {"type": "independent", "sample_count": int(spp)}}
    return d, view, factor


def _spots(view: View, res: int, rows: int, cols: int, n: int) -> list[NDArray]:
    """Per patch, the flat pixel indices whose ray meets the slab's face within the spot."""
    right, up, fwd = view.basis()
    u = (np.arange(res) + 0.5) / res * 2.0 - 1.0
    yy = u * view.half_mm                       # image x -> world y (right = +y)
    zz = -u * view.half_mm                      # image rows from the top -> +z
    # orthographic rays meet the plane x = 0 at z = z_image / cos(elevation) (right is +y)
    zc = zz / math.cos(math.radians(view.elevation_deg))
    w, h = cols * PATCH_MM, rows * PATCH_MM
    out = []
    for k in range(n):
        r, c = divmod(k, cols)
        cy = -w / 2 + (c + 0.5) * PATCH_MM
        cz = h / 2 - (r + 0.5) * PATCH_MM
        iy = np.flatnonzero(np.abs(yy - cy) < SPOT_MM / 2)
        iz = np.flatnonzero(np.abs(zc - cz) < SPOT_MM / 2)
        out.append((iz[:, None] * res + iy[None, :]).ravel())
    return out


def render_chart(recipes: NDArray, profile: InkProfile, optics: Optics, bands: SpectralBands,
                 geometry: str = DEFAULT_GEOMETRY, thickness_mm: float | None = None,
                 spp: int = DEFAULT_CHART_SPP, seed: int = 0, max_depth: int = 512,
                 progress: Callable[..., None] | None = None,
                 cancelled: Callable[[], bool] | None = None
                 ) -> tuple[NDArray[np.float64], dict[str, Any]]:
    """Band reflectance factors (n, n_bands) of the recipes (n, 6) as flat patches.

    ``progress(done, total)`` after each render pass (three bands) and, while a pass renders
    (one Mitsuba call, tens of seconds), ``progress(done, total, "pass k of n: 12 s, about 8 s
    left")`` every ``core.progress.HEARTBEAT_S`` seconds (:func:`_pass_heartbeat`; the render
    and its numbers are untouched); ``cancelled()`` is polled between passes (raises
    JobCancelled)."""
    nb = bands.n
    passes = -(-nb // 3)
    if progress is not None:       # before loading the renderer (seconds on a cold start)
        progress(0, passes)
    mi, variant, note = load_mitsuba()
    n = len(recipes)
    rows, cols = _layout(n)
    frac = np.zeros((rows * cols, 7))
    frac[:n, :6] = recipes
    frac[n:, INKS.index("K")] = 1.0          # unused cells: black ink
    st, al = medium_coefficients(frac.reshape(rows, cols, 7), bands.K, bands.S, optics,
                                 geometry)
    out = np.zeros((n, passes * 3))
    t = THICK_MM if thickness_mm is None else float(thickness_mm)
    took: list[float] = []          # seconds of each pass so far (the next pass's ETA)
    t_pass = time.monotonic()
    for p in range(passes):
        if cancelled is not None and cancelled():
            raise JobCancelled("the chart proof was cancelled")
        ch = slice(3 * p, min(3 * p + 3, nb))
        st3 = np.zeros((rows, cols, 3), np.float32)
        al3 = np.zeros((rows, cols, 3), np.float32)
        st3[..., :ch.stop - ch.start] = st[..., ch]
        al3[..., :ch.stop - ch.start] = al[..., ch]
        d, view, factor = chart_scene(mi, st3, al3, optics, geometry, t, spp, max_depth)
        with _pass_heartbeat(progress, p, passes, took):
            # the scene held while the image is evaluated: with only a temporary's reference
            # Dr.Jit kept the GIL for the whole render (measured: the heartbeat thread ran 7
            # times in 10 s against 105 with the scene held; same image)
            scene = mi.load_dict(d)
            img = np.asarray(mi.render(scene, spp=int(spp), seed=int(seed) * 7919 + p),
                             np.float64)[..., :3]
            del scene
        took.append(time.monotonic() - t_pass)
        t_pass = time.monotonic()
        res = img.shape[0]
        flat = img.reshape(-1, 3)
        for k, idx in enumerate(_spots(view, res, rows, cols, n)):
            out[k, 3 * p:3 * p + 3] = factor * flat[idx].mean(axis=0)
        if progress is not None:
            progress(p + 1, passes)
    info = {"renderer": "mitsuba", "version": mi.__version__, "variant": variant, "note": note,
            "integrator": f"{INTEGRATOR} (no Russian roulette)", "spp": int(spp),
            "max_depth": int(max_depth), "passes": passes}
    return out[:, :nb], info


def _pass_heartbeat(progress: Callable[..., None] | None, p: int, passes: int,
                    took: list[float]) -> AbstractContextManager:
    """While pass ``p`` renders, ``progress(p, passes, "pass p+1 of n: elapsed, about T
    left")`` every ``HEARTBEAT_S`` seconds (:func:`..core.progress.heartbeat`); the time left
    is from the pass before it (every pass renders the same patches at the same samples; the
    first may also compile the renderer's kernel), none for the first. Nothing without
    ``progress``."""
    if progress is None:
        return nullcontext()
    expected = took[-1] if took else None
    return heartbeat(lambda el: progress(p, passes, f"pass {p + 1} of {passes}: "
                                                   f"{eta_text(el, expected)}"))


def _stats(x: NDArray) -> dict[str, float]:
    return {"mean": float(np.mean(x)), "p95": float(np.percentile(x, 95)),
            "max": float(np.max(x))}


def chart_report(s: ChartSettings, chart: Chart, band_R: NDArray, bands: SpectralBands,
                 info: dict) -> dict[str, Any]:
    obs = bands.observer
    lab = obs.XYZ_to_Lab(np.maximum(bands.to_XYZ(band_R), 0.0))
    patches = []
    for k, c in enumerate(chart.recipes):
        row: dict[str, Any] = {"patch": k + 1,
                               "recipe": {ink: round(float(v), 6) for ink, v in zip(INKS, c,
                                                                                   strict=True)
                                          if v > 0},
                               "proof_lab": [round(float(v), 3) for v in lab[k]]}
        patches.append(row)
    rep: dict[str, Any] = {
        "format": "dreamprint-chart-proof", "format_version": 1,
        "recipes": s.recipes, "reflectance": s.reflectance, "patches_count": len(patches),
        "profile": chart.profile.name, "geometry": s.geometry,
        "geometry_note": ("diffuse illumination, viewed 8 degrees off the normal, specular "
                          "included" if s.geometry == "d:8" else
                          "light 45 degrees off the normal, viewed on the normal"),
        "thickness_mm": s.thickness_mm, "optically_thick": s.thickness_mm is None,
        "optics": chart.optics.describe(),
        "km_to_rte": describe_conversion(chart.optics, s.geometry),
        "spectral": bands.describe(), "renderer": info,
        "patches": patches}
    if chart.measured_lab is not None:
        de = delta_E2000(chart.measured_lab, lab)
        for k, row in enumerate(patches):
            row["measured_lab"] = [round(float(v), 3) for v in chart.measured_lab[k]]
            row["de2000"] = round(float(de[k]), 4)
        worst = np.argsort(-de)[:5]
        rep["de2000"] = {**_stats(de), "worst_patches": [
            {"patch": int(k) + 1, "de2000": round(float(de[k]), 3)} for k in worst]}
    return rep


def chart_picture(chart: Chart, band_R: NDArray, bands: SpectralBands,
                  px: int = 48) -> NDArray[np.uint8]:
    """sRGB picture (rows * px, cols * px, 3): one square per patch, measured left half,
    proofed right half (the proof alone without measurements), numbered in its top-left corner
    as the report and ``patches.csv`` number the patches (1, 2, ...; row by row), in black or
    white, whichever stands out from the patch."""
    obs = bands.observer
    rows, cols = _layout(len(chart.recipes))
    img = np.full((rows * px, cols * px, 3), 255, np.uint8)
    proof_rgb = to_display(obs.XYZ_to_linear_sRGB(np.maximum(bands.to_XYZ(band_R), 0)))
    meas_rgb = None
    if chart.measured_lab is not None:
        import colour

        xyz = colour.Lab_to_XYZ(chart.measured_lab,
                                illuminant=colour.XYZ_to_xy(obs.white_XYZ))
        meas_rgb = to_display(obs.XYZ_to_linear_sRGB(xyz))
    for k in range(len(chart.recipes)):
        r, c = divmod(k, cols)
        y0, x0 = r * px + 2, c * px + 2
        img[y0:y0 + px - 4, x0:x0 + px - 4] = proof_rgb[k]
        if meas_rgb is not None:
            img[y0:y0 + px - 4, x0:x0 + (px - 4) // 2] = meas_rgb[k]
    return _numbered(img, len(chart.recipes), cols, px)


def _numbered(img: NDArray[np.uint8], n: int, cols: int, px: int) -> NDArray[np.uint8]:
    """The patch numbers written on a chart picture (Pillow's built-in font)."""
    from PIL import Image, ImageDraw, ImageFont

    pic = Image.fromarray(img)
    draw = ImageDraw.Draw(pic)
    font = ImageFont.load_default(size=max(8, px // 4))
    for k in range(n):
        r, c = divmod(k, cols)
        x, y = c * px + 4, r * px + 3
        corner = img[y:y + px // 4, x:x + px // 3].reshape(-1, 3).mean(axis=0)
        light = float(corner @ np.array([0.2126, 0.7152, 0.0722])) > 140
        draw.text((x, y), str(k + 1), fill=(0, 0, 0) if light else (255, 255, 255), font=font)
    return np.asarray(pic)


def _write(rep: dict, chart: Chart, band_R: NDArray, bands: SpectralBands,
           folder: Path) -> None:
    from PIL import Image

    with open(folder / "patches.csv", "w", newline="", encoding="utf-8") as f:
        wr = csv.writer(f)
        meas = chart.measured_lab is not None
        wr.writerow(["patch", *INKS, "proof_L", "proof_a", "proof_b"]
                    + (["measured_L", "measured_a", "measured_b", "de2000"] if meas else []))
        for k, row in enumerate(rep["patches"]):
            wr.writerow([k + 1, *[f"{v:.6g}" for v in chart.recipes[k]], *row["proof_lab"]]
                        + ([*row["measured_lab"], row["de2000"]] if meas else []))
    img = chart_picture(chart, band_R, bands)
    Image.fromarray(img).save(folder / "chart.png")
    (folder / "chart_proof.json").write_text(json.dumps(rep, indent=2) + "\n", encoding="utf-8")


def chart_from_arrays(recipes: NDArray, reflectance: NDArray | None, profile: InkProfile,
                      surface: str | None = None, phase: str | None = None,
                      geometry: str = DEFAULT_GEOMETRY) -> Chart:
    """A chart from recipes (n, 6) and measured reflectance (n, n_wl on the profile's grid),
    checked as :func:`load_chart` checks files (the calibration wizard's chart)."""
    if geometry not in GEOMETRIES:
        raise DreamPrintError(f"unknown geometry '{geometry}' (use {', '.join(GEOMETRIES)})")
    optics = _checked_optics(surface, phase, profile, geometry)
    c = np.asarray(recipes, np.float64)
    lab = None
    if reflectance is not None:
        R = np.asarray(reflectance, np.float64)
        if R.shape != (len(c), profile.wavelengths_nm.size):
            raise DreamPrintError(f"{len(R)} measured spectra for {len(c)} recipes")
        lab = observer_for(profile.wavelengths_nm).spectra_to_Lab(R)
    return Chart(c, lab, profile, optics)


def proof_chart(chart: Chart, s: ChartSettings,
                progress: Callable[..., None] | None = None,
                cancelled: Callable[[], bool] | None = None
                ) -> tuple[dict[str, Any], NDArray[np.float64], SpectralBands]:
    """Render ``chart`` with ``s``'s geometry, thickness and sampling; the report (as
    ``chart_proof.json``), the band reflectances and the bands. Writes nothing."""
    bands = spectral_bands(chart.profile, s.bands)
    band_R, info = render_chart(chart.recipes, chart.profile, chart.optics, bands, s.geometry,
                                s.thickness_mm, s.spp, s.seed, s.max_depth, progress,
                                cancelled)
    return chart_report(s, chart, band_R, bands, info), band_R, bands


def run_chart_proof(s: ChartSettings,
                    progress: Callable[..., None] | None = None) -> dict[str, Any]:
    """Check the inputs, render, write ``s.output`` atomically; returns the report.
    ``progress(done, total)`` after each render pass (three bands each), ``progress(done,
    total, detail)`` while one renders (:func:`render_chart`)."""
    if s.output is None:
        raise DreamPrintError("no output folder given (-o DIR)")
    out = Path(s.output)
    if out.exists() and not s.overwrite:
        raise DreamPrintError("already exists (use --overwrite to replace it)", out)
    if out.exists() and not out.is_dir():
        raise DreamPrintError("exists and is not a folder", out)
    if not out.absolute().parent.is_dir():
        raise DreamPrintError("the folder to write into does not exist", out.absolute().parent)
    chart = load_chart(s)
    rep, band_R, bands = proof_chart(chart, s, progress)
    with staged_folder(out, "chart") as tmp:
        _write(rep, chart, band_R, bands, tmp)
    return rep
