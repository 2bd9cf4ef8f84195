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

__all__ = ["upsample", "fine_update", "compose", "occlusion_prior", "FINE_RANGE",
           "SHRINK_WEIGHT"]

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


def occlusion_prior(sigma: NDArray, cell_mm: NDArray, box_mm: NDArray,
                    fshape: tuple[int, int, int], strength: float, radius_mm: float
                    ) -> NDArray[np.float64]:
    """Log factors (fz, fy, fx, 4) on the fine field's cells against a solid print's shading by
    its own shape under the uniform environment: a print receives light only through its
    surface, so in a concave step (more of the object around it) it is darker than the same ink
    on a flat face, and on a convex edge lighter (light entering the side face leaves through
    the front), while the source's emission-absorption render has no shading at all. With ``n``
    the object's share of a Gaussian neighbourhood of ``radius_mm`` at a surface cell (1/2 on a
    flat face, more in a concave step, less on an edge), the open share ``2 (1 - n)`` scales the
    light it receives (an ambient-occlusion estimate), and the colour factors undo it::

        log g = -strength ln(2 (1 - n))     clipped to +-ln FINE_RANGE, colour channels only

    ``n`` is read at a surface cell's centre, half a cell under the surface, so it is taken
    relative to a flat face's share there (``2 (1 - n)`` becomes ``(1 - n) / (1 - n_flat)``).
    Every other cell takes the factor of the surface cell nearest to it (the light it sends
    out leaves there; empty cells too, so the fine cells straddling the surface and the job's
    interpolation keep it: the job reads no colour where the source is empty). The object:
    cells more than half opaque across (a solid's voxels);
    ``sigma`` (nz, ny, nx) 1/mm: the source sampled on cells of ``cell_mm`` (x, y, z) from the
    corner of the print's box (``box_mm``, its size x, y, z); the factors are read at the
    centres of the ``fshape`` cells of that box (trilinear)."""
    from scipy.ndimage import binary_erosion, distance_transform_edt, gaussian_filter

    solid = _opacity(sigma, cell_mm) > 0.5
    out = np.zeros(solid.shape + (4,))
    if not solid.any():
        return _at_fine_centres(out, cell_mm, box_mm, fshape)
    rad = _radius_cells(radius_mm, cell_mm)
    n = gaussian_filter(solid.astype(np.float64), rad, mode="constant")
    # a flat face read at a surface cell's centre, half a cell under it: its share there
    n_flat = 0.5 * (1.0 + math.erf(0.5 / (min(rad) * math.sqrt(2.0))))
    surface = solid & ~binary_erosion(solid, border_value=0)
    lim = math.log(FINE_RANGE)
    log_s = np.clip(-float(strength) * np.log(np.clip((1.0 - n) / (1.0 - n_flat), 5e-4, None)),
                    -lim, lim)
    # every cell, inside or out, reads its nearest surface cell (in mm): the fine cells
    # straddling the surface and the job's interpolation keep the surface's factor
    _, idx = distance_transform_edt(~surface, sampling=[float(cell_mm[a]) for a in (2, 1, 0)],
                                    return_indices=True)
    out[..., :3] = log_s[idx[0], idx[1], idx[2]][..., None]
    return _at_fine_centres(out, cell_mm, box_mm, fshape)


def _opacity(sigma: NDArray, cell_mm: NDArray) -> NDArray[np.float64]:
    """A cell's opacity across its smallest side, ``1 - exp(-sigma h)``."""
    return 1.0 - np.exp(-np.asarray(sigma, np.float64) * float(np.min(cell_mm)))


def _radius_cells(radius_mm: float, cell_mm: NDArray) -> list[float]:
    """A radius in mm in cells along (z, y, x)."""
    return [float(radius_mm) / float(cell_mm[a]) for a in (2, 1, 0)]


def _at_fine_centres(values: NDArray, cell_mm: NDArray, box_mm: NDArray,
                     fshape: tuple[int, int, int]) -> NDArray[np.float64]:
    """``values`` (nz, ny, nx, C) on cells of ``cell_mm`` from the corner of the print's box
    read at the centres of the ``fshape`` cells of the box (size ``box_mm`` x, y, z;
    trilinear, the edge cells held beyond the last centre)."""
    from scipy.ndimage import map_coordinates

    axes = [(np.arange(n) + 0.5) * (float(box_mm[a]) / n) / float(cell_mm[a]) - 0.5
            for n, a in zip(fshape, (2, 1, 0), strict=True)]
    zz, yy, xx = np.meshgrid(*axes, indexing="ij")
    res = np.zeros(tuple(fshape) + (values.shape[-1],))
    for ch in range(values.shape[-1]):
        res[..., ch] = map_coordinates(values[..., ch], [zz, yy, xx], order=1, mode="nearest")
    return res
