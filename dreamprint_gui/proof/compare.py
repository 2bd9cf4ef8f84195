"""Source vs print: dE2000 map, mean / 95th-percentile dE2000 and S-CIELAB dE2000, PSNR, SSIM,
coverage error; the noise floor between two renders of the same print.

Defines :func:`compare_view`, :func:`noise_floor`, :func:`noise_corrected_de2000`,
:func:`noise_corrected_figures`, :func:`summarise`, :func:`de_heatmap`,
:func:`empty_source_note`, :func:`inside_source` and :data:`COVERAGE_THRESHOLD`.

- Colour: both images are XYZ relative to the white environment (D65 white = the observer's
  white), converted to CIELAB with that white; dE2000 by colour-science (CIE 2000).
- S-CIELAB dE2000 (:mod:`.scielab`): the same two images filtered as the eye sees them at the
  proof's viewing distance (the print at its real size), then dE2000 per pixel; mean and 95th
  percentile over the same object pixels.
- Noise floor (:func:`noise_floor_from_halves`): the proof's print is the mean of two
  independent halves of its samples (seeds s and s + 1, :func:`.print_render.render_print_halves`),
  ``x = (x_a + x_b) / 2``. Two independent proofs at the same settings differ by a noise of
  variance ``2 Var x = Var x_a``, while the halves differ by ``2 Var x_a``: so the floor is
  :func:`noise_floor` (both figures over the print's object pixels) between the pair
  ``x +- (x_a - x_b) / (2 sqrt 2)``, centred on the proof, whose difference
  ``(x_a - x_b) / sqrt 2`` has the variance of the difference between two proofs. It estimates
  what the floor was until 2026-12 (the print rendered again in full at seed + 1, both figures
  between the two renders) without the second render (``bench_proof.py --floor-check``). A
  difference between two proofs smaller than a few times the floor is render noise.
- The dE2000 mean less the render's noise (:func:`noise_corrected_de2000`,
  ``nc_mean_de2000`` and ``inside_source_nc_mean_de2000``): the noise adds to every pixel's
  dE2000, so the raw mean reads high at any spp. dE2000 squared is locally a quadratic form
  ``q`` of the Lab difference; with the print's noise covariance ``C`` (each half's ``2 C``),
  ``E dE(s, x)^2 = dE(s, E x)^2 + q(C)`` and ``E dE(x_a, x_b)^2 = 4 q(C)``, so per pixel
  ``sqrt(max(dE(s, x)^2 - dE(x_a, x_b)^2 / 4, 0))`` estimates the noiseless error. First order
  only (dE2000's weights depend on where the pair lies), and a root of a noisy square: per pixel
  it reads high where the true error is below about the noise's standard deviation per Lab axis
  and a little low above it (docs/physics.md). The raw figures keep their keys.
- Object pixels: where either image's coverage exceeds :data:`COVERAGE_THRESHOLD`; mean and
  95th percentile of dE2000 are over those pixels.
- Coverage: 1 - the direct (unscattered) transmittance of the pixel's rays through the volume:
  the emission-absorption alpha for the source, ``exp(-integral sigma_t)`` of the print's medium
  (luminance-weighted over bands) for the print. Coverage error: mean over object pixels of
  print minus source (positive: the print looks more opaque), and its mean absolute value.
- Where the source is empty (:func:`compare_view`'s ``empty_source_*``): the object pixels
  where only the print has coverage (source coverage at most the threshold), e.g. a Clear
  block's body around the object: their fraction of the object pixels, and their shares of
  the mean dE2000, of the mean S-CIELAB dE2000 and of the coverage error (sums over those
  pixels / all object pixels, so that a figure is its share inside the source plus this one).
  What lies there is not the object's reproduction: no ink placed inside the source's
  silhouette changes it.
- Inside the source (``inside_source_*``, the headline figures since issue 44:
  :func:`headline`): the same figures (dE2000 and S-CIELAB mean and p95, coverage error and
  its mean absolute value) over the other object pixels, where the source has coverage and ink
  placed in the object acts; ``inside_source_pixels`` counts them. The figures over all object
  pixels keep their keys.
- PSNR and SSIM (scikit-image, ``data_range = 1``, SSIM per channel with its default 7 x 7
  window) on the display images (sRGB-encoded, clipped to [0, 1]) over the whole frame.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from dreamprint_gui.physics.colorimetry import Observer, clip_unit, delta_E2000
from dreamprint_gui.proof.scielab import scielab_de2000

__all__ = ["compare_view", "noise_floor", "noise_floor_from_halves", "noise_corrected_de2000",
           "noise_corrected_figures", "noise_corrected_text", "NC_KEYS", "object_pixels",
           "headline_figures_text",
           "summarise",
           "summarise_floor", "FLOOR_KEYS",
           "mark_significance", "SIGNIFICANCE_FACTOR", "SIGNIFICANCE_KEYS", "de_heatmap",
           "to_display",
           "empty_source_note", "EMPTY_SOURCE_KEYS", "EMPTY_NOTE_MIN", "inside_source",
           "COVERAGE_THRESHOLD", "DE_MAP_MAX", "INSIDE_KEYS", "headline", "headline_text"]

COVERAGE_THRESHOLD = 0.05
# the headline figures (compare_view's inside_source_*: where the source has coverage)
INSIDE_KEYS = ("mean_de2000", "p95_de2000", "mean_scielab_de2000", "p95_scielab_de2000",
               "coverage_error", "coverage_abs_error")
# compare_view's figures of the object pixels where the source is empty (module docstring)
EMPTY_SOURCE_KEYS = ("empty_source_fraction", "empty_source_de2000",
                     "empty_source_scielab_de2000", "empty_source_coverage_error")
# each figure's share where the source is empty
_EMPTY_SHARE = {"mean_de2000": "empty_source_de2000",
                "mean_scielab_de2000": "empty_source_scielab_de2000",
                "coverage_error": "empty_source_coverage_error"}
# below this fraction of the object pixels, the figures where the source is empty go unsaid
EMPTY_NOTE_MIN = 0.005
DE_MAP_MAX = 20.0


def to_display(linear_rgb: NDArray) -> NDArray[np.uint8]:
    """8-bit sRGB of linear sRGB values (clipped)."""
    import colour

    enc = colour.models.eotf_inverse_sRGB(clip_unit(linear_rgb))
    return np.round(clip_unit(enc) * 255).astype(np.uint8)


def _stats(de: NDArray, mask: NDArray, prefix: str) -> dict:
    n = int(mask.sum())
    return {f"mean_{prefix}": float(de[mask].mean()) if n else 0.0,
            f"p95_{prefix}": float(np.percentile(de[mask], 95)) if n else 0.0}


def object_pixels(src_alpha: NDArray, prn_alpha: NDArray,
                  threshold: float = COVERAGE_THRESHOLD) -> NDArray[np.bool_]:
    """The object pixels of a view: where either image's coverage exceeds ``threshold``."""
    return (src_alpha > threshold) | (prn_alpha > threshold)


def _inside(mask: NDArray, src_alpha: NDArray, threshold: float) -> NDArray[np.bool_]:
    """The pixels of ``mask`` inside the source (its coverage above ``threshold``): the
    headline's pixels; the rest of ``mask`` is where the source is empty."""
    return mask & (src_alpha > threshold)


def _lab(observer: Observer, xyz: NDArray) -> NDArray:
    """CIELAB of an XYZ image relative to the white environment, negative values clipped."""
    return observer.XYZ_to_Lab(np.maximum(xyz, 0.0))


def compare_view(src_xyz: NDArray, prn_xyz: NDArray, src_alpha: NDArray, prn_alpha: NDArray,
                 observer: Observer, samples_per_degree: float,
                 threshold: float = COVERAGE_THRESHOLD, mask: NDArray | None = None
                 ) -> tuple[dict, NDArray[np.float64]]:
    """Figures of one view and its dE2000 map (res, res); NaN outside the object.

    ``samples_per_degree``: the pixels per degree of visual angle of the S-CIELAB figures.
    ``mask``: the object pixels (default: either coverage above ``threshold``); two prints
    compared with one source on the same pixels pass the union of theirs."""
    from skimage.metrics import peak_signal_noise_ratio, structural_similarity


    de = delta_E2000(_lab(observer, src_xyz), _lab(observer, prn_xyz))
    sde = scielab_de2000(src_xyz, prn_xyz, observer, samples_per_degree)
    if mask is None:
        mask = object_pixels(src_alpha, prn_alpha, threshold)
    a = to_display(observer.XYZ_to_linear_sRGB(src_xyz)).astype(np.float64) / 255
    b = to_display(observer.XYZ_to_linear_sRGB(prn_xyz)).astype(np.float64) / 255
    psnr = float(peak_signal_noise_ratio(a, b, data_range=1.0))
    ssim = float(structural_similarity(a, b, data_range=1.0, channel_axis=-1))
    n = int(mask.sum())
    d_alpha = prn_alpha - src_alpha
    cov = d_alpha[mask]
    inside = _inside(mask, src_alpha, threshold)
    empty = mask & ~inside
    share = 1.0 / n if n else 0.0
    figures = {
        "object_pixels": n,
        "mean_de2000": float(de[mask].mean()) if n else 0.0,
        "p95_de2000": float(np.percentile(de[mask], 95)) if n else 0.0,
        **_stats(sde, mask, "scielab_de2000"),
        "psnr_db": psnr if np.isfinite(psnr) else 99.0,
        "ssim": ssim,
        "coverage_error": float(cov.mean()) if n else 0.0,
        "coverage_abs_error": float(np.abs(cov).mean()) if n else 0.0,
        "source_coverage": float(src_alpha[mask].mean()) if n else 0.0,
        "print_coverage": float(prn_alpha[mask].mean()) if n else 0.0,
        "empty_source_fraction": float(empty.sum() * share),
        "empty_source_de2000": float(de[empty].sum() * share),
        "empty_source_scielab_de2000": float(sde[empty].sum() * share),
        "empty_source_coverage_error": float(d_alpha[empty].sum() * share),
        **_inside_figures(de, sde, d_alpha, inside),
    }
    return figures, np.where(mask, de, np.nan)


def _inside_figures(de: NDArray, sde: NDArray, d_alpha: NDArray, inside: NDArray) -> dict:
    """The headline figures (:data:`INSIDE_KEYS`) over the object pixels where the source
    has coverage."""
    n = int(inside.sum())
    cov = d_alpha[inside]
    return {"inside_source_pixels": n,
            **{f"inside_source_{k}": v for k, v in _stats(de, inside, "de2000").items()},
            **{f"inside_source_{k}": v for k, v in
               _stats(sde, inside, "scielab_de2000").items()},
            "inside_source_coverage_error": float(cov.mean()) if n else 0.0,
            "inside_source_coverage_abs_error": float(np.abs(cov).mean()) if n else 0.0}


def noise_floor(prn_xyz: NDArray, prn_xyz2: NDArray, prn_alpha: NDArray, observer: Observer,
                samples_per_degree: float, threshold: float = COVERAGE_THRESHOLD,
                source_alpha: NDArray | None = None) -> dict:
    """Per-pixel and S-CIELAB dE2000 (mean, p95) between two renders of the same print, over
    the print's object pixels (coverage > ``threshold``); with ``source_alpha``, also over
    those where the source has coverage (``inside_source_*``, the headline's pixels)."""
    de = delta_E2000(_lab(observer, prn_xyz), _lab(observer, prn_xyz2))
    sde = scielab_de2000(prn_xyz, prn_xyz2, observer, samples_per_degree)
    mask = prn_alpha > threshold
    out = {"object_pixels": int(mask.sum()), **_stats(de, mask, "de2000"),
           **_stats(sde, mask, "scielab_de2000")}
    if source_alpha is not None:
        inside = _inside(mask, source_alpha, threshold)
        out["inside_source_pixels"] = int(inside.sum())
        for k, v in {**_stats(de, inside, "de2000"),
                     **_stats(sde, inside, "scielab_de2000")}.items():
            out[f"inside_source_{k}"] = v
    return out


def noise_floor_from_halves(half_a_xyz: NDArray, half_b_xyz: NDArray, prn_alpha: NDArray,
                            observer: Observer, samples_per_degree: float,
                            threshold: float = COVERAGE_THRESHOLD,
                            source_alpha: NDArray | None = None) -> dict:
    """The noise floor of a proof whose print is the mean of two independent halves of its
    samples (XYZ ``half_a_xyz``, ``half_b_xyz``): :func:`noise_floor` between
    ``x +- (x_a - x_b) / (2 sqrt 2)``, ``x = (x_a + x_b) / 2``, a pair centred on the proof that
    differs as two independent proofs at its settings do (module docstring)."""
    a = np.asarray(half_a_xyz, np.float64)
    b = np.asarray(half_b_xyz, np.float64)
    mean = (a + b) / 2.0
    d = (a - b) / (2.0 * np.sqrt(2.0))
    return noise_floor(mean + d, mean - d, prn_alpha, observer, samples_per_degree, threshold,
                       source_alpha)


def noise_corrected_de2000(src_xyz: NDArray, half_a_xyz: NDArray, half_b_xyz: NDArray,
                           observer: Observer, de: NDArray | None = None
                           ) -> NDArray[np.float64]:
    """Per-pixel dE2000 of the print ``(half_a + half_b) / 2`` against the source with the
    render noise's share taken out (module docstring)::

        sqrt(max(dE(s, x)^2 - dE(x_a, x_b)^2 / 4, 0))       x = (x_a + x_b) / 2

    ``de``: ``dE(s, x)`` when the caller has it (:func:`compare_view`'s map). Equal halves (no
    noise) give the plain dE2000."""
    a = np.asarray(half_a_xyz, np.float64)
    b = np.asarray(half_b_xyz, np.float64)
    if de is None:
        de = delta_E2000(_lab(observer, np.asarray(src_xyz, np.float64)),
                         _lab(observer, (a + b) / 2.0))
    n = delta_E2000(_lab(observer, a), _lab(observer, b))
    return np.sqrt(np.maximum(de * de - 0.25 * n * n, 0.0))


# the noise-corrected figures a view carries (:func:`noise_corrected_figures`)
NC_KEYS = ("nc_mean_de2000", "inside_source_nc_mean_de2000")


def noise_corrected_figures(src_xyz: NDArray, half_a_xyz: NDArray, half_b_xyz: NDArray,
                            src_alpha: NDArray, prn_alpha: NDArray, observer: Observer,
                            threshold: float = COVERAGE_THRESHOLD, de: NDArray | None = None
                            ) -> dict:
    """The mean of :func:`noise_corrected_de2000` over the object pixels and inside the source
    (the pixels of :func:`compare_view`'s ``mean_de2000`` and ``inside_source_mean_de2000``);
    ``de`` as there."""
    dc = noise_corrected_de2000(src_xyz, half_a_xyz, half_b_xyz, observer, de)
    mask = object_pixels(src_alpha, prn_alpha, threshold)
    inside = _inside(mask, src_alpha, threshold)
    return {"nc_mean_de2000": float(dc[mask].mean()) if mask.any() else 0.0,
            "inside_source_nc_mean_de2000": float(dc[inside].mean()) if inside.any() else 0.0}


FLOOR_KEYS = ("mean_de2000", "p95_de2000", "mean_scielab_de2000", "p95_scielab_de2000")


def summarise_floor(views: list[dict]) -> dict:
    """Object-pixel-weighted means of the views' noise floors."""
    w = np.array([max(v["object_pixels"], 0) for v in views], float)
    if w.sum() == 0:
        w = np.ones(len(views))
    out = {k: float(np.average([v[k] for v in views], weights=w)) for k in FLOOR_KEYS}
    out["object_pixels"] = int(sum(v["object_pixels"] for v in views))
    if all("inside_source_pixels" in v for v in views):
        wi = np.array([v["inside_source_pixels"] for v in views], float)
        wi = wi if wi.sum() > 0 else np.ones(len(views))
        out.update({f"inside_source_{k}": float(np.average(
            [v[f"inside_source_{k}"] for v in views], weights=wi)) for k in FLOOR_KEYS})
        out["inside_source_pixels"] = int(sum(v["inside_source_pixels"] for v in views))
    return out


def summarise(views: list[dict]) -> dict:
    """Overall figures: object-pixel-weighted means of the per-view figures (p95 as the
    pixel-weighted mean of the views' p95)."""
    w = np.array([max(v["object_pixels"], 0) for v in views], float)
    if w.sum() == 0:
        w = np.ones(len(views))
    keys = ("mean_de2000", "p95_de2000", "mean_scielab_de2000", "p95_scielab_de2000",
            "psnr_db", "ssim", "coverage_error", "coverage_abs_error", "source_coverage",
            "print_coverage", *EMPTY_SOURCE_KEYS)
    out = {k: float(np.average([v[k] for v in views], weights=w)) for k in keys}
    out["object_pixels"] = int(sum(v["object_pixels"] for v in views))
    if all("inside_source_pixels" in v for v in views):
        wi = np.array([v["inside_source_pixels"] for v in views], float)
        wi = wi if wi.sum() > 0 else np.ones(len(views))
        out.update({f"inside_source_{k}": float(np.average(
            [v[f"inside_source_{k}"] for v in views], weights=wi)) for k in INSIDE_KEYS})
        out["inside_source_pixels"] = int(sum(v["inside_source_pixels"] for v in views))
    if views and all(k in v for v in views for k in NC_KEYS):
        out["nc_mean_de2000"] = float(np.average([v["nc_mean_de2000"] for v in views],
                                                 weights=w))
        if "inside_source_pixels" in out:
            out["inside_source_nc_mean_de2000"] = float(np.average(
                [v["inside_source_nc_mean_de2000"] for v in views], weights=wi))
    return out


def headline(figures: dict) -> dict:
    """The headline figures of a proof (``evaluate methods``, the proof's text, the proof
    tab): inside the source, i.e. over the object pixels where the source has coverage, where
    ink placed in the object acts; ``where`` says so. A figures dict without those pixels
    (a source empty on every camera, or one from before they were recorded) gives its figures
    over all object pixels, ``where`` "all object pixels" (NaN for a figure it lacks).
    ``nc_mean_de2000``: the dE2000 mean less the render's noise, where the figures have it
    (:func:`noise_corrected_figures`)."""
    if figures.get("inside_source_pixels", 0) > 0:
        out = {"where": "inside the source", **{k: figures[f"inside_source_{k}"]
                                                 for k in INSIDE_KEYS}}
        if "inside_source_nc_mean_de2000" in figures:
            out["nc_mean_de2000"] = figures["inside_source_nc_mean_de2000"]
        return out
    out = {"where": "all object pixels",
           **{k: figures.get(k, float("nan")) for k in INSIDE_KEYS}}
    if "nc_mean_de2000" in figures:
        out["nc_mean_de2000"] = figures["nc_mean_de2000"]
    return out


def noise_corrected_text(h: dict) -> str:
    """" (D less the render's noise)" after a headline's dE2000 mean (:func:`headline`), or ""
    when it has no noise-corrected figure."""
    if "nc_mean_de2000" not in h:
        return ""
    return f" ({h['nc_mean_de2000']:.2f} less the render's noise)"


def headline_figures_text(h: dict) -> str:
    """A headline's (:func:`headline`) figures: where, the dE2000 mean (and less the render's
    noise), p95, S-CIELAB and the coverage error."""
    return (f"{h['where']}: dE2000 mean {h['mean_de2000']:.2f}{noise_corrected_text(h)}, "
            f"p95 {h['p95_de2000']:.2f}; S-CIELAB {h['mean_scielab_de2000']:.2f}; coverage "
            f"error {h['coverage_error']:+.3f}")


def headline_text(figures: dict) -> str:
    """One line: the headline figures (:func:`headline_figures_text`), then the same over all
    object pixels and the share of the pixels where the source is empty (the Clear block's
    body)."""
    h = headline(figures)
    line = headline_figures_text(h)
    if h["where"] == "all object pixels":
        return line
    return (line + f" (all object pixels: dE2000 mean {figures['mean_de2000']:.2f}, S-CIELAB "
            f"{figures['mean_scielab_de2000']:.2f}, coverage error "
            f"{figures['coverage_error']:+.3f}; where the source is empty "
            f"{100 * figures['empty_source_fraction']:.0f} % of them)")


def inside_source(figures: dict, key: str) -> float | None:
    """The mean of ``key`` (``mean_de2000``, ``mean_scielab_de2000`` or ``coverage_error``)
    over the object pixels where the source is not empty: the figure less its share where the
    source is empty (:func:`compare_view`), over the rest's fraction; None when there is no
    such pixel."""
    rest = 1.0 - figures["empty_source_fraction"]
    if rest <= 0.0:
        return None
    return (figures[key] - figures[_EMPTY_SHARE[key]]) / rest


def empty_source_note(figures: dict, min_fraction: float = EMPTY_NOTE_MIN) -> str:
    """One line on the share of the figures from the object pixels where the source is empty
    (:func:`compare_view`), or "" when those pixels are under ``min_fraction`` of the object
    pixels. The figures inside the source are the headline (:func:`headline_text`), which
    every surface shows first, so they are not repeated here."""
    if figures.get("empty_source_fraction", 0.0) < min_fraction:
        return ""
    note = (f"where the source is empty ({100 * figures['empty_source_fraction']:.0f} % of the "
            f"object pixels, e.g. a Clear block's body; no ink in the object changes it): "
            f"{figures['empty_source_de2000']:.2f} of the dE2000 mean, "
            f"{figures['empty_source_scielab_de2000']:.2f} of the S-CIELAB mean, "
            f"{figures['empty_source_coverage_error']:+.3f} of the coverage error")
    return note


SIGNIFICANCE_FACTOR = 3.0
# the headline figures a methods table ranks (inside the source, :func:`headline`)
SIGNIFICANCE_KEYS = ("inside_source_mean_de2000", "inside_source_mean_scielab_de2000")


def mark_significance(rows: list[dict], factor: float = SIGNIFICANCE_FACTOR,
                      keys: tuple[str, ...] = ("mean_de2000", "mean_scielab_de2000")) -> None:
    """Add ``row["vs_best"][key] = {"difference", "threshold", "significant"}`` to each row of a
    methods table: the row's figure minus the best (lowest) row's, against ``factor`` times the
    larger of the two rows' noise floors (``row["noise_floor"][key]``). A difference at or
    below the threshold is render noise, not a ranking; without floors ``significant`` is None.
    """
    for key in keys:
        best = min(rows, key=lambda r: r[key])
        for r in rows:
            d = r[key] - best[key]
            floors = [x["noise_floor"][key] for x in (r, best)
                      if key in (x.get("noise_floor") or {})]
            thr = factor * max(floors) if len(floors) == 2 else None
            r.setdefault("vs_best", {})[key] = {
                "difference": d, "threshold": thr,
                "significant": None if thr is None else bool(d > thr)}


def de_heatmap(de: NDArray, vmax: float = DE_MAP_MAX) -> NDArray[np.uint8]:
    """RGB uint8 heat map of a dE2000 map (matplotlib 'magma', 0..vmax; NaN -> white)."""
    from matplotlib import colormaps

    cm = colormaps["magma"]
    v = np.clip(np.nan_to_num(de, nan=0.0) / vmax, 0.0, 1.0)
    img = (cm(v)[..., :3] * 255).round().astype(np.uint8)
    img[np.isnan(de)] = 255
    return img
