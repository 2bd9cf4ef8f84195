"""The print job's fused path for sparse VDB grids: sample a strip of a layer, label it, next.

Defines :func:`leaf_grid_slab_labels`: for each layer of a slab, the densities of an OpenVDB or
NanoVDB fog volume densified over its leaves (:func:`..io.volumes.vdb.leaf_grid.leaf_grid_layer`,
the reconstruction step of the paper's sec. 4.1, bit-identical to the sparse sampler) go into
a density array a strip of rows at a time (:data:`.layer_kernel.STRIP_VOXELS`), which
:func:`.layer_kernel.strip_labels` turns into labels straight away (background test -> lookup
-> alignment -> halftone, paper Fig. 2), in one compiled call (nogil), as :mod:`.dense_job`
does for dense grids (the whole layer's results, whatever the strips; with a ``Cd`` grid, a
1e10-voxel job's layer 10.2 -> 9.6 ns per voxel on one core, density alone unchanged). Colour
is the source's one uniform colour (:func:`leaf_grid_slab_labels`) or a densified vec3 colour
grid sampled the same way (:func:`leaf_grid_colour_slab_labels`, e.g. Houdini's ``Cd``).
"""

from __future__ import annotations

from numba import njit

from dreamprint_gui.io.volumes.srgb_encode import CLIP, ENCODE
from dreamprint_gui.io.volumes.vdb.leaf_grid import leaf_grid_layer, leaf_grid_values_where
from dreamprint_gui.job.sample_label.layer_kernel import (
    STRIP_VOXELS,
    UNIFORM,
    layer_state,
    strip_labels,
    strip_rows,
)

__all__ = ["leaf_grid_slab_labels", "leaf_grid_colour_slab_labels"]


@njit(cache=True, nogil=True, error_model="numpy")
def leaf_grid_slab_labels(dense, rows_nz, k0, wk, j0, wj, i0, wi, plane, scale, uniform, rgb,
                          dens, z0, threshold, bg_label, flat, n, sigma_clear, method,
                          mask, ox, oy, oz, seed, order, labels, counts, sums, stats,
                          strip_voxels=STRIP_VOXELS):
    """Labels (L, ny, nx) of layers ``z0 .. z0 + L - 1`` of a densified leaf grid: the slab's
    plan (``dense, rows_nz, k0, wk`` per layer, ``j0, wj, i0, wi``, ``plane`` scratch, density
    ``scale`` (1/mm per source unit), ``uniform`` colour (3,)), one layer's working arrays
    ``rgb`` (ny * nx, 3) and ``dens`` (ny * nx,), then the arguments of
    :func:`.layer_kernel.slab_labels` after ``z0``. The one colour is looked up once per
    layer (:data:`.layer_kernel.UNIFORM`: only ``rgb[0]`` is read)."""
    for c in range(3):
        rgb[0, c] = uniform[c]
    ny, nx = labels.shape[1:]
    strip = strip_rows(ny, nx, strip_voxels)
    state = layer_state(nx)
    for k in range(labels.shape[0]):
        for s0 in range(0, ny, strip):
            nr = min(strip, ny - s0)
            leaf_grid_layer(dense, rows_nz, k0[k], wk[k], j0, wj, i0, wi, plane, scale, dens,
                            s0, nr)
            strip_labels(rgb, dens, z0 + k, s0, nr, threshold, bg_label, flat, n, sigma_clear,
                         method, mask, ox, oy, oz, seed, order, labels[k], counts, sums[k],
                         stats, UNIFORM, state)


@njit(cache=True, nogil=True, error_model="numpy")
def leaf_grid_colour_slab_labels(dense, rows_nz, k0, wk, j0, wj, i0, wi, plane, scale, cdense,
                                 crows_nz, ck0, cwk, cj0, cwj, ci0, cwi, cplane, linear, rgb,
                                 dens, z0, threshold, bg_label, flat, n, sigma_clear,
                                 method, mask, ox, oy, oz, seed, order, labels, counts, sums,
                                 stats, strip_voxels=STRIP_VOXELS):
    """As :func:`leaf_grid_slab_labels`, the colour sampled per layer from a densified vec3
    grid ``cdense`` (nk, nj, ni, 3) with its own corners and weights (``ck0``, ``cwk`` per
    layer, ``cj0``/``cwj``, ``ci0``/``cwi``; ``cplane`` (3, ni) scratch), at the voxels the
    labelling reads only (:func:`..io.volumes.vdb.leaf_grid.leaf_grid_values_where`), then
    sRGB-encoded if ``linear`` (else clipped to [0, 1]) in the labelling's staged blocks
    (``colour_op``): the values of :meth:`..io.volumes.vdb.openvdb.VdbSource.sample_slab` where
    the labels read them, a layer at a time."""
    rgb_flat = rgb.reshape(-1)
    cplane_flat = cplane.reshape(-1)
    op = ENCODE if linear else CLIP
    ny, nx = labels.shape[1:]
    strip = strip_rows(ny, nx, strip_voxels)
    state = layer_state(nx)
    for k in range(labels.shape[0]):
        for s0 in range(0, ny, strip):
            nr = min(strip, ny - s0)
            leaf_grid_layer(dense, rows_nz, k0[k], wk[k], j0, wj, i0, wi, plane, scale, dens,
                            s0, nr)
            leaf_grid_values_where(cdense, crows_nz, ck0[k], cwk[k], cj0, cwj, ci0, cwi,
                                   cplane_flat, rgb_flat, dens, threshold, s0, nr)
            strip_labels(rgb, dens, z0 + k, s0, nr, threshold, bg_label, flat, n, sigma_clear,
                         method, mask, ox, oy, oz, seed, order, labels[k], counts, sums[k],
                         stats, op, state)
