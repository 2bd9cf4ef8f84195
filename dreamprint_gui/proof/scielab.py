"""S-CIELAB (Zhang & Wandell 1996): a colour difference of images as seen at a viewing distance.

Defines :func:`samples_per_degree`, :func:`channel_kernel`, :func:`scielab_filter`,
:func:`scielab_de2000` and the published constants :data:`XYZ_TO_OPPONENT` and
:data:`FILTERS`.

Which step: the proof's comparison (:mod:`.compare`) and its noise floor (:mod:`.runner`)
report it beside the per-pixel CIEDE2000. Per-pixel dE2000 counts detail the eye does not
resolve (a 0.2 mm pixel's Monte Carlo noise, a halftone's dots) as fully visible colour error;
S-CIELAB first blurs each image as the eye's contrast sensitivity does at the stated viewing
distance, then takes the per-pixel difference.

Method (Zhang & Wandell 1996; the parameters of the authors' released code, which normalises
the weights of the paper's table to sum to 1):

1. XYZ -> opponent channels ``O = M XYZ`` (Poirson & Wandell 1993),
   ``M = XYZ_TO_OPPONENT`` (luminance, red-green, blue-yellow).
2. Each channel is convolved with a sum of Gaussians ``k_c = sum_i w_ci G(h_ci)``,
   ``sum_i w_ci = 1``, where ``G(h)`` is a unit-sum isotropic Gaussian whose full width at
   half maximum is ``h`` degrees of visual angle (:data:`FILTERS`), truncated, like the released
   code, to a support of one degree. Each Gaussian is separable, so the channel's filter is the
   weighted sum of row-then-column convolutions. A pixel is an area, so the kernel's taps are the
   Gaussian integrated over each pixel (differences of the normal CDF), which stays exact when a
   pixel is wider than a Gaussian (the released code instead up-samples to 224 samples/degree).
3. Back to XYZ (``M^-1``), CIELAB relative to the white, per-pixel CIEDE2000 (the released
   code's ``deltaEversion = '2000'``; the paper used CIELAB 1976).

Viewing: a pixel of ``p`` mm seen from ``D`` mm subtends ``2 atan(p / 2D)``; samples per degree
is its inverse (:func:`samples_per_degree`). The proof's pixel is the print's real size on the
frame (orthographic cameras), so the figure is the print seen at its real size from ``D``.

Checked in ``tests/proof/test_scielab.py``: kernels sum to 1; a uniform image gives
exactly the per-pixel dE2000; black/white noise finer than the eye resolves (single pixels at
224 samples/degree) against its uniform mean gives a small S-CIELAB dE while its per-pixel dE
is large; a coarse pattern (pixels of 1/5 degree) keeps most of its per-pixel dE.

References
----------
- Zhang, X., Wandell, B. A. (1996). A spatial extension of CIELAB for digital color image
  reproduction. SID Symposium Digest 27, 731-734.
- Poirson, A. B., Wandell, B. A. (1993). Appearance of colored patterns: pattern-color
  separability. JOSA A 10(12), 2458-2470.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.ndimage import convolve1d
from scipy.special import ndtr

from dreamprint_gui.physics.colorimetry import delta_E2000

__all__ = ["XYZ_TO_OPPONENT", "FILTERS", "DEFAULT_VIEWING_DISTANCE_MM", "samples_per_degree",
           "channel_kernel", "scielab_filter", "scielab_de2000"]

# Poirson & Wandell (1993) opponent space of XYZ (rows: luminance, red-green, blue-yellow).
XYZ_TO_OPPONENT = np.array([[0.2787, 0.7218, -0.1066],
                            [-0.4488, 0.2898, 0.0772],
                            [0.0860, -0.5900, 0.5011]])

# Per channel: (full width at half maximum in degrees, weight) of each Gaussian; weights sum to 1.
FILTERS: tuple[tuple[tuple[float, float], ...], ...] = (
    ((0.05, 1.00327), (0.225, 0.114416), (7.0, -0.117686)),
    ((0.0685, 0.616725), (0.826, 0.383275)),
    ((0.0920, 0.567885), (0.6451, 0.432115)),
)
SUPPORT_DEG = 1.0
DEFAULT_VIEWING_DISTANCE_MM = 500.0   # arm's length


def samples_per_degree(pixel_mm: float, distance_mm: float) -> float:
    """Pixels per degree of visual angle for pixels of ``pixel_mm`` seen from ``distance_mm``."""
    if not (pixel_mm > 0 and distance_mm > 0):
        raise ValueError("pixel size and viewing distance must be > 0")
    return 1.0 / math.degrees(2.0 * math.atan(pixel_mm / (2.0 * distance_mm)))


def _gaussian_taps(fwhm_px: float, half: int) -> NDArray[np.float64]:
    """Unit-sum taps ``-half..half`` of a Gaussian of ``fwhm_px``, integrated over each pixel."""
    sigma = fwhm_px / (2.0 * math.sqrt(2.0 * math.log(2.0)))
    edges = (np.arange(-half, half + 2) - 0.5) / sigma
    taps = np.diff(ndtr(edges))
    return taps / taps.sum()


def _half_width(spd: float) -> int:
    return max(0, int(math.ceil(SUPPORT_DEG * spd / 2.0)) - 1) if spd >= 2 else 0


def channel_kernel(channel: int, spd: float) -> NDArray[np.float64]:
    """The 2-D filter of opponent ``channel`` (0, 1, 2) at ``spd`` samples per degree."""
    half = _half_width(spd)
    k = np.zeros((2 * half + 1, 2 * half + 1))
    for fwhm, w in FILTERS[channel]:
        g = _gaussian_taps(fwhm * spd, half)
        k += w * np.outer(g, g)
    return k


def scielab_filter(xyz: ArrayLike, spd: float) -> NDArray[np.float64]:
    """XYZ image ``(h, w, 3)`` filtered as the eye sees it at ``spd`` samples per degree."""
    xyz = np.asarray(xyz, np.float64)
    opp = xyz @ XYZ_TO_OPPONENT.T
    half = _half_width(spd)
    out = np.empty_like(opp)
    for c in range(3):
        acc = np.zeros(opp.shape[:2])
        for fwhm, w in FILTERS[c]:
            g = _gaussian_taps(fwhm * spd, half)
            acc += w * convolve1d(convolve1d(opp[..., c], g, axis=0, mode="nearest"), g,
                                  axis=1, mode="nearest")
        out[..., c] = acc
    return out @ np.linalg.inv(XYZ_TO_OPPONENT).T


def scielab_de2000(xyz_a: ArrayLike, xyz_b: ArrayLike, observer, spd: float
                   ) -> NDArray[np.float64]:
    """Per-pixel S-CIELAB dE2000 map ``(h, w)`` of two XYZ images relative to ``observer``'s
    white (:class:`..colorimetry.Observer`), at ``spd`` samples per degree."""
    fa = np.maximum(scielab_filter(xyz_a, spd), 0.0)
    fb = np.maximum(scielab_filter(xyz_b, spd), 0.0)
    return delta_E2000(observer.XYZ_to_Lab(fa), observer.XYZ_to_Lab(fb))
