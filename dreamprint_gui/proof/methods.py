"""The paper's ablations as label-producing methods (its Fig. "ablation study" as numbers).

Defines :data:`METHODS`, :func:`method_labels`, :class:`BruteForceLabels`,
:class:`JointLabels`.

- ``paper``: the product's pipeline (table lookup + density alignment + halftoning), i.e.
  exactly ``dreamprint convert`` (:class:`.labels.EngineLabels`).
- ``brute-force`` (paper section 3.1, "a brute-force approach"): 3 x 3 x 3 hyper-voxels; the
  hyper-voxel's density-weighted mean colour, approximated by discrete labels without pigment
  modelling: the colour (linear sRGB) as a convex combination of the inks' own colours (each
  ink's optically thick KM colour), solved by non-negative least squares on the simplex; the
  hyper-voxel's opacity over its own size, ``alpha = 1 - exp(-mean sigma * 3 voxels)``, is the
  fraction of coloured voxels, the rest Clear.
- ``no-alignment`` (the paper's "w/o density alignment"): RGB and density solved jointly for all
  six inks, no Clear/grey alignment: minimise ``dE76(c)^2 / 100 + (ln sigma(c) - ln sigma*)^2``
  over the simplex (KM colour of the mixture, eq. 7; its sigma, eq. 9), tabulated on an RGB x
  log-sigma grid (9^3 x 12 nodes, softmax-parametrised gradient descent) and interpolated
  (quadrilinear) per voxel. The weight 1 between the terms is the paper's "difficult to adjust"
  choice made once: a factor e in density costs as much as dE76 10.

Every method's concentrations go through the job's own halftoner (``Halftoner.layer_into``, the
same seed, mask, background threshold and ink order as ``paper``), so only the way
concentrations are chosen differs.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from dreamprint_gui.core.profile import INKS
from dreamprint_gui.gamut.tables import mixture_sigma
from dreamprint_gui.job.plan import ConvertSettings
from dreamprint_gui.physics.colorimetry import observer_for
from dreamprint_gui.physics.kubelka_munk import reflectance_infinite
from dreamprint_gui.physics.mixture import mixture_colour
from dreamprint_gui.proof.labels import EngineLabels

__all__ = ["METHODS", "method_labels", "BruteForceLabels", "JointLabels"]

METHODS = ("paper", "no-alignment", "brute-force")
_CL = INKS.index("Cl")


def method_labels(s: Any):
    """The label source of ``s.method`` for proof settings ``s``."""

    cs = ConvertSettings.from_spec(s.spec)
    if s.method == "paper":
        return EngineLabels(cs)
    if s.method == "brute-force":
        return BruteForceLabels(cs)
    if s.method == "no-alignment":
        return JointLabels(cs)
    raise ValueError(f"unknown method {s.method!r}")


def _linear(srgb: NDArray) -> NDArray:
    c = np.clip(np.asarray(srgb, np.float64), 0.0, 1.0)
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)


class _SampledLabels:
    """Shared: the job's context (grid, source, halftoner) and its halftoning of concentrations."""

    def __init__(self, settings: Any) -> None:

        base = EngineLabels(settings)
        self.settings = settings
        self.ctx = base.ctx
        self.shape_xyz = base.shape_xyz
        self.voxel_mm = base.voxel_mm
        self.grid = base.grid
        self.source = base.source
        self.density_scale = base.density_scale
        self.profile = base.profile
        self.halftoning = base.halftoning

    def _sample(self, z0: int, z1: int) -> tuple[NDArray, NDArray]:
        rgb, dens = self.source.sample_slab(self.grid, z0, z1, density_scale=self.density_scale)
        return np.array(rgb, np.float32), np.array(dens, np.float32)

    def _halftone(self, conc: NDArray, dens: NDArray, z: int) -> NDArray[np.uint8]:
        nx, ny, _ = self.shape_xyz
        out = np.empty((ny, nx), np.uint8)
        self.ctx.halftoner.layer_into(np.ascontiguousarray(conc.reshape(-1, 6), np.float32),
                                      np.ascontiguousarray(dens.reshape(-1), np.float32), z, out,
                                      np.zeros(7, np.int64), np.zeros(7))
        return out


class BruteForceLabels(_SampledLabels):
    """The paper's brute-force hyper-voxel method (see the module docstring)."""

    HYPER = 3

    def __init__(self, settings: Any) -> None:
        super().__init__(settings)

        p = self.profile
        obs = observer_for(p.wavelengths_nm)
        R = reflectance_infinite(p.K[:5], p.S[:5])          # C, M, Y, K, W thick colours
        self.ink_rgb = np.clip(obs.XYZ_to_linear_sRGB(obs.spectra_to_XYZ(R)), 0, None)
        self._lut_n = 17
        self._lut = self._colour_lut()

    def _colour_lut(self) -> NDArray:
        """Simplex NNLS weights of the 5 inks for a 17^3 grid of linear RGB."""
        from scipy.optimize import nnls

        n = self._lut_n
        g = np.linspace(0, 1, n)
        A = np.vstack([self.ink_rgb.T, 10.0 * np.ones((1, 5))])   # sum-to-one row, weighted
        out = np.empty((n, n, n, 5))
        for i, r in enumerate(g):
            for j, gg in enumerate(g):
                for k, b in enumerate(g):
                    w, _ = nnls(A, np.array([r, gg, b, 10.0]))
                    out[i, j, k] = w / max(w.sum(), 1e-12)
        return out

    def layer(self, z: int) -> NDArray[np.uint8]:
        h = self.HYPER
        nx, ny, nz = self.shape_xyz
        z0 = (z // h) * h
        z1 = min(nz, z0 + h)
        rgb, dens = self._sample(z0, z1)
        L = z1 - z0
        pyy, pxx = -(-ny // h) * h, -(-nx // h) * h
        d = np.zeros((L, pyy, pxx))
        c = np.zeros((L, pyy, pxx, 3))
        d[:, :ny, :nx] = dens
        c[:, :ny, :nx] = _linear(rgb) * dens[..., None]
        bd = d.reshape(L, pyy // h, h, pxx // h, h).sum(axis=(0, 2, 4))
        bc = c.reshape(L, pyy // h, h, pxx // h, h, 3).sum(axis=(0, 2, 4))
        colour = bc / np.maximum(bd, 1e-12)[..., None]
        mean_sigma = bd / (L * h * h)
        size = h * float(np.mean(self.voxel_mm))
        alpha = 1.0 - np.exp(-mean_sigma * size)
        idx = np.clip(np.rint(colour * (self._lut_n - 1)).astype(int), 0, self._lut_n - 1)
        w = self._lut[idx[..., 0], idx[..., 1], idx[..., 2]]       # (by, bx, 5)
        conc = np.zeros(w.shape[:2] + (6,))
        conc[..., :5] = alpha[..., None] * w
        conc[..., _CL] = 1.0 - alpha
        conc = np.repeat(np.repeat(conc, h, axis=0), h, axis=1)[:ny, :nx]
        # the hyper-voxel's mean density decides background vs print, like the voxel's does
        dvox = np.repeat(np.repeat(mean_sigma, h, axis=0), h, axis=1)[:ny, :nx]
        return self._halftone(conc, dvox, z)


class JointLabels(_SampledLabels):
    """The paper's "w/o density alignment": colour and density solved jointly (module doc)."""

    N_RGB = 9
    N_SIGMA = 12

    def __init__(self, settings: Any) -> None:
        super().__init__(settings)
        self._build()

    def _objective(self, c: NDArray, lab_t: NDArray, ls_t: NDArray) -> NDArray:

        obs = self._obs
        lab = obs.XYZ_to_Lab(mixture_colour(self.profile, c, observer=obs))
        ls = np.log(np.maximum(mixture_sigma(self.profile, c), 1e-9))
        return ((lab - lab_t) ** 2).sum(-1) / 100.0 + (ls - ls_t) ** 2

    def _build(self) -> None:

        p = self.profile
        self._obs = obs = observer_for(p.wavelengths_nm)
        s_lo = float(mixture_sigma(p, np.eye(6)[_CL]))
        s_hi = float(mixture_sigma(p, np.eye(6)).max())
        self._g_rgb = np.linspace(0, 1, self.N_RGB)
        self._g_ls = np.linspace(np.log(s_lo), np.log(s_hi), self.N_SIGMA)
        R, G, B, LS = np.meshgrid(self._g_rgb, self._g_rgb, self._g_rgb, self._g_ls,
                                  indexing="ij")
        rgb = np.stack([R, G, B], -1).reshape(-1, 3)
        ls_t = LS.reshape(-1)
        lab_t = obs.XYZ_to_Lab(obs.sRGB_to_XYZ(rgb))
        z = np.zeros((rgb.shape[0], 6))
        m = np.zeros_like(z)
        v = np.zeros_like(z)
        eps = 1e-3
        lr = 0.1
        for it in range(1, 121):  # Adam on softmax logits, forward-difference gradients
            c = _softmax(z)
            f0 = self._objective(c, lab_t, ls_t)
            grad = np.empty_like(z)
            for k in range(6):
                dz = z.copy()
                dz[:, k] += eps
                grad[:, k] = (self._objective(_softmax(dz), lab_t, ls_t) - f0) / eps
            m = 0.9 * m + 0.1 * grad
            v = 0.999 * v + 0.001 * grad ** 2
            z -= lr * (m / (1 - 0.9 ** it)) / (np.sqrt(v / (1 - 0.999 ** it)) + 1e-8)
        self._table = _softmax(z).reshape(self.N_RGB, self.N_RGB, self.N_RGB, self.N_SIGMA, 6)
        self.fit_objective_mean = float(self._objective(_softmax(z), lab_t, ls_t).mean())

    def layer(self, z: int) -> NDArray[np.uint8]:
        from scipy.interpolate import RegularGridInterpolator

        rgb, dens = self._sample(z, z + 1)
        rgb, dens = rgb[0], dens[0]
        nx, ny, _ = self.shape_xyz
        conc = np.zeros((ny, nx, 6))
        conc[..., _CL] = 1.0
        fg = dens > self.ctx.halftoner.threshold
        if fg.any():
            ls = np.clip(np.log(np.maximum(dens[fg], 1e-12)), self._g_ls[0], self._g_ls[-1])
            pts = np.column_stack([np.clip(rgb[fg], 0, 1), ls])
            interp = RegularGridInterpolator((self._g_rgb, self._g_rgb, self._g_rgb,
                                              self._g_ls), self._table)
            c = np.clip(interp(pts), 0, None)
            conc[fg] = c / c.sum(-1, keepdims=True)
        return self._halftone(conc, dens, z)


def _softmax(z: NDArray) -> NDArray:
    e = np.exp(z - z.max(-1, keepdims=True))
    return e / e.sum(-1, keepdims=True)
