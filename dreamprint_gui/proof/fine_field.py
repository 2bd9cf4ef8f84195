"""A correction at two scales: coarse everywhere, fine where light leaves the object.

Defines :func:`upsample` (a coarse field at a fine field's cell centres, the job's own
trilinear interpolation; the optimiser interpolates log factors with it), :func:`fine_update`
(the fine detail of one back-projected update) and :func:`compose` (the one field a job
applies).

The compensation's update (:mod:`.compensate`) is a weighted mean of per-pixel log ratios
back-projected onto a field with each sample's weight in the source's emission-absorption
render, ``w = T_i (1 - exp(-sigma_i h))``: the weight is where the camera sees the object, a
shell a few of the source's mean free paths deep under its surface (one cell of a solid, the
visible depth of a fog). A coarse field (0.6 mm cells at 20 mm) averages that shell over its
edges: a voxel model's one-voxel edges, where light leaves translucent ink through the faces
beside the edge, are out of its reach. So the correction carries a second, fine field (the
proof's own cells or half of them) of log factors ``f`` on top of the coarse ``c``::

    log g = up(c) + f                     g applied per voxel by the job (job/correction.py)

    c += step * u_c                       u_c = S(sum w r) / S(sum w)  on coarse cells
    f += step * W / (W + lambda) * (u_f - up(u_c))    on fine cells, W = S(sum w) there

with ``r`` the pixel log ratios, ``S`` a Gaussian of 0.7 cells, ``up`` the job's trilinear
interpolation of a coarse field at the fine cell centres. ``u_f - up(u_c)`` is the detail the
coarse field cannot hold (a Laplacian-pyramid split: where the fine data agrees with the coarse
mean, ``f`` does not move). Regularisers that keep the halftone printable and the detail real:

- *shrinkage* ``W / (W + lambda)``: where few training pixels see a fine cell (``W`` small:
  inside the object, behind it, at grazing angles) its detail shrinks towards the coarse field,
  so render noise seen by one pixel does not become ink;
- *a bounded detail* ``|f| <= ln FINE_RANGE``: the fine field moves ink concentrations at most by
  that factor around the coarse field's, so no voxel's mixture jumps to an extreme that the
  halftone would print as isolated dots; the total stays within the coarse field's [1/8, 8];
- the factors act as the coarse ones do: colours scaled as a whole below the top of the gamut,
  density scaled except a solid's (``job/correction.py``), so every concentration the halftoning
  follows is a mixture the tables made.

Hand-written: the split is a few lines of NumPy and SciPy's Gaussian filter.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from dreamprint_gui.job.correction import axis_weights

__all__ = ["upsample", "fine_update", "compose", "FINE_RANGE", "SHRINK_WEIGHT"]

# the fine detail's largest factor around the coarse field
FINE_RANGE = 2.0
# lambda: the back-projected weight (in units of one pixel that sees a cell fully) at which a
# fine cell's detail counts half
SHRINK_WEIGHT = 0.5


def upsample(coarse: NDArray, fshape: tuple[int, int, int]) -> NDArray[np.float64]:
    """A field ``coarse`` (gz, gy, gx, C; factors or their logs) at the centres of a
    ``fshape`` (fz, fy, fx) field's cells:
    trilinear between coarse cell centres, clamped at the outer half cells, as the job
    interpolates a field (:func:`..job.correction.axis_weights`)."""
    c = np.asarray(coarse, np.float64)
    out = c
    for axis, n in enumerate(fshape):
        g = c.shape[axis]
        i0, w = axis_weights(n, g)
        i1 = np.minimum(i0 + 1, g - 1)
        shape = [1] * out.ndim
        shape[axis] = n
        w = w.astype(np.float64).reshape(shape)
        out = np.take(out, i0, axis=axis) * (1.0 - w) + np.take(out, i1, axis=axis) * w
    return out


def fine_update(num: NDArray, den: NDArray, coarse_update: NDArray, smooth: float = 0.7,
                shrink: float = SHRINK_WEIGHT) -> NDArray[np.float64]:
    """The fine field's update (module docstring): ``num`` (fz, fy, fx, C) and ``den`` (fz, fy,
    fx) the back-projected sums on the fine cells, ``coarse_update`` the coarse field's update
    (gz, gy, gx, C) of the same iteration."""
    from scipy.ndimage import gaussian_filter

    W = gaussian_filter(den, smooth, mode="nearest")
    up = upsample(coarse_update, den.shape)
    out = np.zeros(num.shape)
    ok = W > 1e-9
    conf = np.where(ok, W / (W + shrink), 0.0)
    for c in range(num.shape[-1]):
        sm = gaussian_filter(num[..., c], smooth, mode="nearest")
        mean = np.divide(sm, W, out=np.zeros_like(sm), where=ok)
        out[..., c] = conf * (mean - up[..., c])
    return out


def compose(log_coarse: NDArray, log_fine: NDArray | None) -> NDArray[np.float64]:
    """The one field the job applies: ``exp(up(c) + f)`` on the fine cells (the total clipped
    to [1/8, 8]), or ``exp(c)`` without a fine field."""
    if log_fine is None:
        return np.exp(np.asarray(log_coarse, np.float64))
    total = upsample(log_coarse, log_fine.shape[:3]) + log_fine
    return np.exp(np.clip(total, -math.log(8.0), math.log(8.0)))
