"""The reflectance factor of an optically thick patch in the proof's RTE, as a function of albedo.

Defines :class:`ThickCurve`, :func:`thick_curve`, :func:`chandrasekhar_h` and
:data:`CURVE_ALBEDOS`.

A semi-infinite homogeneous medium's reflectance factor at an instrument geometry depends only
on its single-scattering albedo ``omega = sigma_s / sigma_t`` (and the phase function and the
surface), not on ``sigma_t``: scaling ``sigma_t`` scales lengths. :mod:`.km_to_rte` inverts this
curve so that a thick patch renders Kubelka-Munk's ``R_inf`` of its K and S, the quantity the
inks were calibrated to.

- Isotropic scattering, no surface: the exact solution (Chandrasekhar 1960, ch. IV), with
  ``H(omega, mu)`` from its explicit integral form (no iteration)::

      ln H(mu) = -(mu / pi) int_0^{pi/2} ln(1 - omega theta cot theta)
                                         / (cos^2 theta + mu^2 sin^2 theta) dtheta
      d:8  (uniform diffuse light, read at mu = cos 8 deg):  R = 1 - sqrt(1 - omega) H(mu)
      45:0 (beam at mu0 = cos 45 deg, read on the normal):  R = (omega / 4) H(1) H(mu0) / (1 + mu0)

- Otherwise (Henyey-Greenstein phase, a glossy or matte surface): rendered once by the proof's
  own renderer (Mitsuba, the chart proof's integrator, lighting and surface BSDF) for
  :data:`CURVE_ALBEDOS`, and cached on disk (platformdirs user cache, ``rte_curves``, keyed by
  the optics, the geometry, the render settings and Mitsuba's version): a wide patch
  (``WIDTH_MM``) of ``sigma_t`` ``SIGMA_T`` per mm, ``THICK_MM`` deep, three albedos per render
  (one per RGB channel, the same ``sigma_t``), the camera seeing the central ``SPOT_MM``.
  ``tests/proof/test_thick_patch.py`` checks the rendered curve against the closed form where
  both exist.
"""

from __future__ import annotations

import hashlib
import json
import math
import os
from collections.abc import Callable
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike, NDArray

from dreamprint_gui.core.files import cache_folder
from dreamprint_gui.proof.mitsuba_setup import load_mitsuba
from dreamprint_gui.proof.optics import Optics
from dreamprint_gui.proof.print_render import BLOCK_PX, INTEGRATOR

__all__ = ["ThickCurve", "thick_curve", "chandrasekhar_h", "closed_form_curve",
           "render_curve", "CURVE_ALBEDOS", "GEOMETRY_MU"]

# albedos of the curve: dense where R changes fastest (omega -> 1), uniform in sqrt(1 - omega)


def _albedo_grid(n: int) -> NDArray[np.float64]:
    u = np.linspace(0.0, 1.0, n)
    return np.concatenate([1.0 - u[:0:-1] ** 2, [1.0 - 1e-5]])   # 0 ... 1 - 1e-5, ascending


CURVE_ALBEDOS = _albedo_grid(33)     # rendered curves: 33 albedos, 11 renders of three
CLOSED_FORM_ALBEDOS = _albedo_grid(257)
GEOMETRY_MU = {"d:8": math.cos(math.radians(8.0)), "45:0": 1.0}
SIGMA_T = 20.0
THICK_MM = 20.0
WIDTH_MM = 200.0
SPOT_MM = 6.0
CURVE_SPP = 256
CURVE_PIXELS = 16
CURVE_VERSION = 1


def chandrasekhar_h(omega: ArrayLike, mu: ArrayLike, n: int = 200) -> NDArray[np.float64]:
    """Chandrasekhar's H-function of isotropic scattering, ``(len(omega), len(mu))``, by its
    explicit integral (above), Gauss-Legendre in ``theta = (pi/2) u^2`` (the substitution tames
    the logarithm's singularity at theta = 0 when omega = 1)."""
    om = np.atleast_1d(np.asarray(omega, np.float64))[:, None, None]
    m = np.atleast_1d(np.asarray(mu, np.float64))[None, :, None]
    x, w = np.polynomial.legendre.leggauss(n)
    u = (x + 1.0) / 2.0
    th = np.pi / 2.0 * u ** 2
    dth = np.pi * u * (w / 2.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        one_minus = np.where(th < 1e-2, th ** 2 / 3 + th ** 4 / 45 + 2 * th ** 6 / 945,
                             1.0 - th / np.tan(th))
    f = np.log((1.0 - om) + om * one_minus) / (np.cos(th) ** 2 + m ** 2 * np.sin(th) ** 2)
    return np.exp(-(m[..., 0] / np.pi) * np.sum(f * dth, axis=-1))


def closed_form_curve(geometry: str, albedos: ArrayLike = CURVE_ALBEDOS) -> NDArray[np.float64]:
    """Reflectance factor of a semi-infinite isotropic medium, no surface, at ``geometry``."""
    om = np.asarray(albedos, np.float64)
    if geometry == "d:8":
        return 1.0 - np.sqrt(1.0 - om) * chandrasekhar_h(om, GEOMETRY_MU["d:8"])[:, 0]
    if geometry == "45:0":
        mu0 = math.cos(math.radians(45.0))
        h = chandrasekhar_h(om, [1.0, mu0])
        return om / 4.0 * h[:, 0] * h[:, 1] / (1.0 + mu0)
    raise ValueError(f"unknown geometry '{geometry}'")


@dataclass(frozen=True)
class ThickCurve:
    """Monotone reflectance-vs-albedo curve of a thick patch and its inverse."""

    albedos: NDArray[np.float64]      # ascending, from 0 to just below 1
    reflectance: NDArray[np.float64]  # non-decreasing
    source: str                       # "closed form" or "rendered ..."

    def __call__(self, albedo: ArrayLike) -> NDArray[np.float64]:
        """R of ``albedo``, interpolated linearly in ``sqrt(1 - omega)`` (in which the curve
        is nearly straight near omega = 1, ``R ~ 1 - H sqrt(1 - omega)``)."""
        u = np.sqrt(np.clip(1.0 - np.asarray(albedo, np.float64), 0.0, 1.0))
        return np.interp(u, self._u[::-1], self.reflectance[::-1])

    @property
    def _u(self) -> NDArray[np.float64]:
        return np.sqrt(1.0 - self.albedos)

    def albedo_for(self, R: ArrayLike) -> NDArray[np.float64]:
        """The albedo whose thick patch reads ``R`` (clamped to the curve's range: a reading
        below the albedo-0 patch's, e.g. a surface's own reflection, gives 0)."""
        r = self.reflectance
        keep = np.concatenate([[True], np.diff(r) > 0])   # strictly increasing for the inverse
        u = np.interp(np.asarray(R, np.float64), r[keep], self._u[keep])
        return 1.0 - u * u


def _isotropic_none(g: float, surface: str) -> bool:
    return g == 0.0 and surface == "none"


def _key(optics: Optics, geometry: str) -> dict:
    mi, _, _ = load_mitsuba()
    return {"version": CURVE_VERSION, "geometry": geometry, **optics.describe(),
            "spp": CURVE_SPP, "pixels": CURVE_PIXELS, "sigma_t": SIGMA_T, "thick_mm": THICK_MM,
            "max_depth": 512, "mitsuba": mi.__version__,
            "albedos": [round(float(a), 8) for a in CURVE_ALBEDOS]}


def _cache_dir() -> Path:
    return cache_folder("rte_curves")


def render_curve(optics: Optics, geometry: str, albedos: ArrayLike = CURVE_ALBEDOS,
                 spp: int = CURVE_SPP, pixels: int = CURVE_PIXELS, max_depth: int = 512,
                 seed: int = 0, progress: Callable[[int, int], None] | None = None
                 ) -> NDArray[np.float64]:
    """Reflectance factors of thick patches of ``albedos`` rendered with the chart proof's
    renderer, lighting and surface (one wide patch per three albedos)."""
    mi, _, _ = load_mitsuba()
    T = mi.ScalarTransform4f
    om = np.asarray(albedos, np.float64)
    n = len(om)
    padded = np.concatenate([om, np.full((-n) % 3, om[-1])])
    out = np.empty(len(padded))
    phase = ({"type": "isotropic"} if optics.g == 0 else {"type": "hg", "g": float(optics.g)})
    passes = len(padded) // 3
    for p in range(passes):
        a3 = padded[3 * p:3 * p + 3]
        d: dict = {"type": "scene",
                   "integrator": {"type": INTEGRATOR, "max_depth": int(max_depth),
                                  "rr_depth": int(max_depth), "hide_emitters": False,
                                  "block_size": BLOCK_PX},
                   "patch": {"type": "cube",
                             "to_world": T().translate([-THICK_MM / 2, 0.0, 0.0])
                             @ T().scale([THICK_MM / 2, WIDTH_MM / 2, WIDTH_MM / 2]),
                             "bsdf": optics.bsdf() or {"type": "null"},
                             "interior": {"type": "homogeneous", "scale": SIGMA_T,
                                          "sigma_t": {"type": "rgb", "value": [1.0] * 3},
                                          "albedo": {"type": "rgb",
                                                     "value": [float(v) for v in a3]},
                                          "phase": dict(phase)}}}
        if geometry == "d:8":
            d["environment"] = {"type": "constant",
                                "radiance": {"type": "rgb", "value": [1.0] * 3}}
            el, factor = math.radians(8.0), 1.0
        elif geometry == "45:0":
            a = math.radians(45.0)
            d["light"] = {"type": "directional",
                          "direction": [-math.cos(a), 0.0, -math.sin(a)],
                          "irradiance": {"type": "rgb", "value": [1.0 / math.cos(a)] * 3}}
            el, factor = 0.0, math.pi
        else:
            raise ValueError(f"unknown geometry '{geometry}'")
        eye = [100.0 * math.cos(el), 0.0, 100.0 * math.sin(el)]
        half = SPOT_MM / 2
        d["camera"] = {"type": "orthographic",
                       "to_world": T().look_at(origin=eye, target=[0.0, 0.0, 0.0],
                                               up=[0.0, 0.0, 1.0]) @ T().scale([half, half, 1.0]),
                       "near_clip": 1e-3, "far_clip": 1e4,
                       "film": {"type": "hdrfilm", "width": int(pixels), "height": int(pixels),
                                "rfilter": {"type": "box"}, "pixel_format": "rgb"},
                       "sampler": {"type": "independent", "sample_count": int(spp)}}
        img = np.asarray(mi.render(mi.load_dict(d), spp=int(spp), seed=int(seed) * 7919 + p),
                         np.float64)[..., :3]
        out[3 * p:3 * p + 3] = factor * img.reshape(-1, 3).mean(axis=0)
        if progress is not None:
            progress(p + 1, passes)
    return out[:n]


@lru_cache(maxsize=32)
def _curve(surface: str, ior: float, roughness: float, g: float, geometry: str) -> ThickCurve:
    if _isotropic_none(g, surface):
        return ThickCurve(CLOSED_FORM_ALBEDOS, closed_form_curve(geometry, CLOSED_FORM_ALBEDOS),
                          "closed form (Chandrasekhar H-function)")
    optics = Optics(surface, ior, roughness, g)
    key = _key(optics, geometry)
    digest = hashlib.sha256(json.dumps(key, sort_keys=True).encode()).hexdigest()[:16]
    path = _cache_dir() / f"curve-{digest}.json"
    R = None
    if path.is_file():
        try:
            data = json.loads(path.read_text(encoding="utf-8"))
            if data.get("key") == key:
                R = np.asarray(data["reflectance"], np.float64)
        except (OSError, ValueError, KeyError):
            R = None
    if R is None or R.shape != CURVE_ALBEDOS.shape:
        R = render_curve(optics, geometry, spp=CURVE_SPP, pixels=CURVE_PIXELS)
        try:
            path.parent.mkdir(parents=True, exist_ok=True)
            tmp = path.with_suffix(f".{os.getpid()}.tmp")
            tmp.write_text(json.dumps({"key": key, "reflectance": R.tolist()}), encoding="utf-8")
            os.replace(tmp, path)
        except OSError:
            pass   # an unwritable cache only costs the render next time
    R = np.maximum.accumulate(R)   # the rendered curve's noise must not make it decrease
    return ThickCurve(CURVE_ALBEDOS, R, f"rendered (Mitsuba, {key['spp']} spp), cached")


def thick_curve(optics: Optics, geometry: str) -> ThickCurve:
    """The curve of the proof's ``optics`` (surface, phase) at the instrument ``geometry``."""
    return _curve(optics.surface, float(optics.ior), float(optics.roughness), float(optics.g),
                  geometry)
