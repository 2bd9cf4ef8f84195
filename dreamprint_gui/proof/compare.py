"""Source vs print: dE2000 map, mean / 95th-percentile dE2000, PSNR, SSIM, coverage error.

Defines :func:`compare_view`, :func:`summarise`, :func:`de_heatmap` and
:data:`COVERAGE_THRESHOLD`.

- Colour: both images are XYZ relative to the white environment (D65 white = the observer's
  white), converted to CIELAB with that white; dE2000 by colour-science (CIE 2000).
- Object pixels: where either image's coverage exceeds :data:`COVERAGE_THRESHOLD`; mean and
  95th percentile of dE2000 are over those pixels.
- Coverage: 1 - the direct (unscattered) transmittance of the pixel's rays through the volume:
  the emission-absorption alpha for the source, ``exp(-integral sigma_t)`` of the print's medium
  (luminance-weighted over bands) for the print. Coverage error: mean over object pixels of
  print minus source (positive: the print looks more opaque), and its mean absolute value.
- PSNR and SSIM (scikit-image, ``data_range = 1``, SSIM per channel with its default 7 x 7
  window) on the display images (sRGB-encoded, clipped to [0, 1]) over the whole frame.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from dreamprint_gui.physics.colorimetry import Observer, clip_unit, delta_E2000

__all__ = ["compare_view", "summarise", "de_heatmap", "to_display", "COVERAGE_THRESHOLD",
           "DE_MAP_MAX"]

COVERAGE_THRESHOLD = 0.05
DE_MAP_MAX = 20.0


def to_display(linear_rgb: NDArray) -> NDArray[np.uint8]:
    """8-bit sRGB of linear sRGB values (clipped)."""
    import colour

    enc = colour.models.eotf_inverse_sRGB(clip_unit(linear_rgb))
    return np.round(clip_unit(enc) * 255).astype(np.uint8)


def compare_view(src_xyz: NDArray, prn_xyz: NDArray, src_alpha: NDArray, prn_alpha: NDArray,
                 observer: Observer, threshold: float = COVERAGE_THRESHOLD
                 ) -> tuple[dict, NDArray[np.float64]]:
    """Figures of one view and its dE2000 map (res, res); NaN outside the object."""
    from skimage.metrics import peak_signal_noise_ratio, structural_similarity


    lab_s = observer.XYZ_to_Lab(np.maximum(src_xyz, 0.0))
    lab_p = observer.XYZ_to_Lab(np.maximum(prn_xyz, 0.0))
    de = delta_E2000(lab_s, lab_p)
    mask = (src_alpha > threshold) | (prn_alpha > threshold)
    a = to_display(observer.XYZ_to_linear_sRGB(src_xyz)).astype(np.float64) / 255
    b = to_display(observer.XYZ_to_linear_sRGB(prn_xyz)).astype(np.float64) / 255
    psnr = float(peak_signal_noise_ratio(a, b, data_range=1.0))
    ssim = float(structural_similarity(a, b, data_range=1.0, channel_axis=-1))
    n = int(mask.sum())
    cov = (prn_alpha - src_alpha)[mask]
    figures = {
        "object_pixels": n,
        "mean_de2000": float(de[mask].mean()) if n else 0.0,
        "p95_de2000": float(np.percentile(de[mask], 95)) if n else 0.0,
        "psnr_db": psnr if np.isfinite(psnr) else 99.0,
        "ssim": ssim,
        "coverage_error": float(cov.mean()) if n else 0.0,
        "coverage_abs_error": float(np.abs(cov).mean()) if n else 0.0,
        "source_coverage": float(src_alpha[mask].mean()) if n else 0.0,
        "print_coverage": float(prn_alpha[mask].mean()) if n else 0.0,
    }
    return figures, np.where(mask, de, np.nan)


def summarise(views: list[dict]) -> dict:
    """Overall figures: object-pixel-weighted means of the per-view figures (p95 as the
    pixel-weighted mean of the views' p95)."""
    w = np.array([max(v["object_pixels"], 0) for v in views], float)
    if w.sum() == 0:
        w = np.ones(len(views))
    keys = ("mean_de2000", "p95_de2000", "psnr_db", "ssim", "coverage_error",
            "coverage_abs_error", "source_coverage", "print_coverage")
    out = {k: float(np.average([v[k] for v in views], weights=w)) for k in keys}
    out["object_pixels"] = int(sum(v["object_pixels"] for v in views))
    return out


def de_heatmap(de: NDArray, vmax: float = DE_MAP_MAX) -> NDArray[np.uint8]:
    """RGB uint8 heat map of a dE2000 map (matplotlib 'magma', 0..vmax; NaN -> white)."""
    from matplotlib import colormaps

    cm = colormaps["magma"]
    v = np.clip(np.nan_to_num(de, nan=0.0) / vmax, 0.0, 1.0)
    img = (cm(v)[..., :3] * 255).round().astype(np.uint8)
    img[np.isnan(de)] = 255
    return img
