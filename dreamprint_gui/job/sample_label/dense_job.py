"""The print job's fused path for dense grids: sample a strip of a layer, label it, next strip.

Defines :func:`dense_slab_labels` (density and colour grids) and :func:`window_slab_labels`
(scalar images through a window and a colour table: VTK, MetaImage, NRRD). For each layer of
a slab, the dense grid's trilinear samples
(:func:`..io.volumes.dense_sampler.dense_layer`) go into colour and density arrays, which
:func:`.layer_kernel.strip_labels` turns into labels straight away, in one compiled call
(nogil). The general path samples the whole slab first (16 bytes per voxel written to memory,
then read back); here the arrays are reused (a 1e7-voxel job's sampling and labelling: 12.0 ->
9.6 ns per voxel on one core, 1e8: 7.8 -> 5.9). A layer goes a strip of rows at a
time (:data:`STRIP_VOXELS`, :func:`.layer_kernel.strip_labels`), so that its arrays stay in
the L2 cache however wide the layer: a 1e10-voxel job's layer of colour and density is 32 MB,
and sampling it whole cost the demo 5.7 ns per voxel on one core against 4.3 in strips (two
workers: 242 -> 315 Mvox/s; 1e9 jobs, 7 MB layers, unchanged). The labels, counts,
sums and clamp report are those of sampling the slab and calling
:func:`.layer_kernel.slab_labels`: the same samples, the same kernel, layer by layer.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from dreamprint_gui.io.volumes.dense import window_kernel
from dreamprint_gui.io.volumes.dense_sampler import (
    COLOUR,
    COLOUR_WHERE_DENSE,
    DENSITY,
    RAW,
    dense_layer,
    dense_window_layer,
)
from dreamprint_gui.io.volumes.srgb_encode import AS_IS, ENCODE
from dreamprint_gui.job.sample_label.layer_kernel import (
    STRIP_VOXELS,
    UNIFORM,
    layer_state,
    strip_labels,
    strip_rows,
)

__all__ = ["dense_slab_labels", "window_slab_labels"]


@njit(cache=True, nogil=True, error_model="numpy")
def dense_slab_labels(vol, rows_nz, iz0, iz1, wz, vz, iy0, iy1, wy, vy, ix0, ix1, wx, vx, rslot,
                      srows, planes, planes_nz, plane_layer, row, cpl, scale, uniform, linear,
                      rgb, dens, z0, threshold, bg_label, flat, n, sigma_clear, method,
                      mask, ox, oy, oz, seed, order, labels, counts, sums, stats,
                      strip_voxels=STRIP_VOXELS):
    """Labels (L, ny, nx) of layers ``z0 .. z0 + L - 1`` of a dense grid ``vol`` (channel 0
    density, 1-3 premultiplied colour if it has 4 channels, else ``uniform`` sRGB colour (3,)):
    the slab's plan (:class:`..io.volumes.dense_sampler.DenseLayers` ``.args()``), density
    ``scale`` (1/mm per source unit), ``linear`` (the colour channels hold linear values: each
    voxel the labelling reads is sRGB-encoded in its staged block,
    :func:`..io.volumes.srgb_encode.prepare_staged`, the values
    :meth:`..io.volumes.dense.DenseSource.sample_slab` gives), working arrays ``rgb``
    (ny * nx, 3) and ``dens`` (ny * nx,) (a strip's rows used), then the arguments of
    :func:`.layer_kernel.slab_labels` after ``z0``, and the strip size ``strip_voxels``. A grid
    without colour channels is looked up once per layer (:data:`.layer_kernel.UNIFORM`)."""
    colour = vol.shape[3] == 4
    if colour:
        # The kernel reads colour only where the density reaches a positive threshold: rows
        # without density may keep the previous layer's colour (base.SlabBuffers).
        mode = COLOUR_WHERE_DENSE if threshold > 0 else COLOUR
    else:
        mode = DENSITY
        for c in range(3):
            rgb[0, c] = uniform[c]
    rgb_flat = rgb.reshape(-1)
    op = (ENCODE if linear else AS_IS) if colour else UNIFORM
    ny, nx = labels.shape[1:]
    strip = strip_rows(ny, nx, strip_voxels)
    state = layer_state(nx)
    for k in range(labels.shape[0]):
        for s0 in range(0, ny, strip):
            nr = min(strip, ny - s0)
            dense_layer(vol, rows_nz, k, iz0, iz1, wz, vz, iy0, iy1, wy, vy, ix0, ix1, wx, vx,
                        rslot, srows, planes, planes_nz, plane_layer, row, cpl, rgb_flat,
                        rgb_flat, dens, mode, scale, s0, nr)
            strip_labels(rgb, dens, z0 + k, s0, nr, threshold, bg_label, flat, n, sigma_clear,
                         method, mask, ox, oy, oz, seed, order, labels[k], counts, sums[k],
                         stats, op, state)


@njit(cache=True, nogil=True, error_model="numpy")
def window_slab_labels(vol, rows_nz, iz0, iz1, wz, vz, iy0, iy1, wy, vy, ix0, ix1, wx, vx, rslot,
                       srows, planes, planes_nz, plane_layer, row, cpl, low, inv_width, lut,
                       density, use_outside, outside_z, outside_y, outside_x, values, rgb, dens,
                       z0, threshold, bg_label, flat, n, sigma_clear, method, mask, ox,
                       oy, oz, seed, order, labels, counts, sums, stats,
                       strip_voxels=STRIP_VOXELS):
    """Labels (L, ny, nx) of layers ``z0 .. z0 + L - 1`` of a scalar image (``vol`` one
    channel): per layer, the trilinear samples (:func:`..io.volumes.dense_sampler.dense_layer`)
    into ``values`` (ny * nx), the window ``t = clip((v - low) * inv_width, 0, 1)`` -> density
    ``t * density`` and colour ``lut[t]`` (:func:`..io.volumes.dense.window_kernel`; the
    paper's sec. 4.1 maps a scalar field to extinction and albedo), density 0 at voxels outside
    the image (``outside_z[k] | outside_y[j] | outside_x[i]``, if ``use_outside``: a window
    below 0, where the sampler's 0 would be lifted), then :func:`.layer_kernel.strip_labels`.
    The plan is :meth:`..io.volumes.grids.vtkimage.ImageSource.layer_plan`'s. A table of one colour
    (every entry the same bits: no colour map) gives only the density, windowed in the
    sampler's row pass (:func:`..io.volumes.dense_sampler.dense_window_layer`), and is looked
    up once per layer (:data:`.layer_kernel.UNIFORM`). A strip of rows at a time, as
    :func:`dense_slab_labels` (``values``, ``rgb`` and ``dens``: the strip's rows used)."""
    ny, nx = labels.shape[1:]
    li = lut.view(np.int32)
    one_colour = True
    for i in range(1, lut.shape[0]):
        for c in range(3):
            one_colour &= li[i, c] == li[0, c]
    if one_colour:
        for c in range(3):
            rgb[0, c] = lut[0, c]
    op = UNIFORM if one_colour else AS_IS
    strip = strip_rows(ny, nx, strip_voxels)
    state = layer_state(nx)
    for k in range(labels.shape[0]):
        for s0 in range(0, ny, strip):
            nr = min(strip, ny - s0)
            nv = nr * nx
            if one_colour:
                dense_window_layer(vol, rows_nz, k, iz0, iz1, wz, vz, iy0, iy1, wy, vy, ix0,
                                   ix1, wx, vx, rslot, srows, planes, planes_nz, plane_layer,
                                   row, low, inv_width, density, dens, s0, nr)
            else:
                dense_layer(vol, rows_nz, k, iz0, iz1, wz, vz, iy0, iy1, wy, vy, ix0, ix1, wx,
                            vx, rslot, srows, planes, planes_nz, plane_layer, row, cpl, values,
                            values, dens, RAW, np.float32(1.0), s0, nr)
                window_kernel(values[:nv], low, inv_width, lut, density, rgb[:nv], dens[:nv])
            if use_outside:
                for jl in range(nr):
                    for i in range(nx):
                        if outside_z[k] or outside_y[s0 + jl] or outside_x[i]:
                            dens[jl * nx + i] = 0.0
            strip_labels(rgb, dens, z0 + k, s0, nr, threshold, bg_label, flat, n, sigma_clear,
                         method, mask, ox, oy, oz, seed, order, labels[k], counts, sums[k],
                         stats, op, state)
