"""The fused path for dense grids (sample a strip of a layer, label it:
``job.sample_label.dense_job``) writes exactly what the general path does (sample the whole
slab, then ``slab_labels``): labels, counts,
per-layer concentration sums and the clamp report, bit for bit, for any slab partition and
any strip height."""

import numpy as np
import pytest

from dreamprint_gui.io.volumes.base import SlabBuffers
from dreamprint_gui.io.volumes.dense import DenseSource, DenseVolume
from dreamprint_gui.job.plan import ConvertSettings, prepare_job
from dreamprint_gui.job.sample_label.dense_job import dense_slab_labels
from dreamprint_gui.job.slab import _labels_of_slab


def _cloud(shape, channels, seed=5):
    """A random cloud on [0, 1]^3 (cell-centred): empty rows, empty layers, -0.0 and NaN."""
    rng = np.random.default_rng(seed)
    nz, ny, nx = shape
    data = np.zeros((nz, ny, nx, channels), np.float32)
    data[..., 0] = rng.uniform(-5.0, 60.0, shape)           # negative: clipped to 0 density
    data[..., 0] *= rng.random(shape) < 0.7
    if channels == 4:
        data[..., 1:] = rng.random(shape + (3,))
    data[:, ny // 3] = 0.0                                   # an empty source row per layer
    if nz > 2:
        data[nz // 2] = 0.0                                  # an empty source layer
    flat = data.reshape(-1)
    flat[rng.integers(0, flat.size, 5)] = -0.0
    flat[rng.integers(0, flat.size, 3)] = np.nan
    n = np.array([nx, ny, nz], float)
    return DenseVolume(data, 0.5 / n, 1.0 / n, cell_centred=True)


def _general(ctx, source, z0, z1, threshold):
    nx, ny, _ = ctx.shape_xyz
    buf = SlabBuffers(colour_where_dense=threshold > 0)
    rgb, dens = source.sample_slab(ctx.grid, z0, z1, density_scale=ctx.settings.density_scale,
                                   out=buf)
    out = (np.empty((z1 - z0, ny, nx), np.uint8), np.zeros(7, np.int64), np.zeros((z1 - z0, 7)),
           np.zeros(4))
    _labels_of_slab(ctx, rgb, dens, z0, *out)
    return out


def _fused(ctx, source, z0, z1, strip_voxels=None):
    nx, ny, _ = ctx.shape_xyz
    plan = source.layer_plan(ctx.grid, z0, z1, density_scale=ctx.settings.density_scale)
    assert plan is not None
    rgb = np.full((ny * nx, 3), np.nan, np.float32)         # stale garbage must never be read
    dens = np.full(ny * nx, 7.0, np.float32)
    out = (np.empty((z1 - z0, ny, nx), np.uint8), np.zeros(7, np.int64), np.zeros((z1 - z0, 7)),
           np.zeros(4))
    if strip_voxels is None:
        dense_slab_labels(*plan, rgb, dens, z0, *ctx.kernel_args(), *out)
    else:
        dense_slab_labels(*plan, rgb, dens, z0, *ctx.kernel_args(), *out, strip_voxels)
    return out


def _assert_same(a, b):
    for x, y in zip(a, b, strict=True):
        np.testing.assert_array_equal(np.asarray(x).view(np.uint8), np.asarray(y).view(np.uint8))


@pytest.mark.parametrize("shape, channels", [
    ((3, 5, 4), 4),        # much coarser than the print: planes shared by many layers
    ((90, 7, 300), 4),     # finer than the print in z and x: two new planes per layer
    ((1, 6, 6), 4),        # one source layer: both planes are the same layer
    ((9, 11, 8), 1),       # density only: uniform colour
])
@pytest.mark.parametrize("threshold, background, halftone", [
    (None, "clear", "blue-noise"), (0.0, "empty", "random")])
@pytest.mark.parametrize("encoding", ["srgb", "linear"])
def test_fused_path_equals_sample_then_label(tmp_path, shape, channels, threshold, background,
                                            halftone, encoding):
    """Linear colour (an EXR stack, a radiance grid marked linear) is sRGB-encoded by both
    paths with the same kernel (io/volumes/srgb_encode.py)."""
    ctx = prepare_job(ConvertSettings(source="demo", output=tmp_path / "J", height_mm=0.5,
                                      table_size=17, seed=2, halftone=halftone,
                                      background=background, density_threshold=threshold,
                                      density_scale=0.7))
    source = DenseSource("cloud", "test", _cloud(shape, channels), uniform_colour=(0.9, 0.2, 0.4),
                         colour_encoding=encoding)
    ctx.source = source
    nz = ctx.shape_xyz[2]
    thr = float(ctx.kernel_args()[0])
    whole = _general(ctx, source, 0, nz, thr)
    assert len(np.unique(whole[0])) > 2                      # the job is not trivially uniform
    _assert_same(_fused(ctx, source, 0, nz), whole)
    nx = ctx.shape_xyz[0]
    for strip_voxels in (1, 3 * nx + 2):  # strips of 1 and 3 rows
        _assert_same(_fused(ctx, source, 0, nz, strip_voxels), whole)
    assert nz > 13
    cuts = [0, 1, 4, 5, 13, nz]                               # any partition of the layers
    parts = [_fused(ctx, source, a, b) for a, b in zip(cuts[:-1], cuts[1:], strict=True)]
    np.testing.assert_array_equal(np.concatenate([p[0] for p in parts]), whole[0])
    np.testing.assert_array_equal(sum(p[1] for p in parts), whole[1])
    np.testing.assert_array_equal(np.concatenate([p[2] for p in parts]).view(np.uint8),
                                  whole[2].view(np.uint8))


@pytest.mark.parametrize("window, colormap", [((2.0, 40.0), None), ((-3.0, 25.0), "viridis")])
def test_scalar_image_fused_path_equals_sample_then_label(tmp_path, window, colormap):
    """A scalar image (VTK, MetaImage, NRRD) through its window and colour table: the fused path
    (``window_slab_labels``) writes what sample_slab + slab_labels write, for any partition,
    including the zeroed density outside the image when the window starts below 0."""
    from dreamprint_gui.io.volumes.dense import colormap_lut
    from dreamprint_gui.io.volumes.grids.vtkimage import ImageSource
    from dreamprint_gui.job.sample_label.dense_job import window_slab_labels

    ctx = prepare_job(ConvertSettings(source="demo", output=tmp_path / "J", height_mm=0.5,
                                      table_size=17, seed=2, density_threshold=0.0,
                                      density_scale=0.7))
    vol = _cloud((12, 9, 10), 1)
    vol.data[np.isnan(vol.data)] = 0.0                       # the reader's nan_to_num
    # the image covers only part of the job's grid, so some voxels lie outside it
    vol = DenseVolume(vol.data, (0.2, 0.1, 0.15), (0.05, 0.08, 0.06), cell_centred=False)
    source = ImageSource("img", "test", vol, window, 3.0, colormap_lut(colormap, None), [])
    ctx.source = source
    ctx.grid = _grid_over(ctx, source)
    nx, ny, nz = ctx.shape_xyz
    whole = _general(ctx, source, 0, nz, 0.0)
    assert len(np.unique(whole[0])) > 2

    def fused(z0, z1, strip_voxels=1 << 15):
        plan = source.layer_plan(ctx.grid, z0, z1, density_scale=ctx.settings.density_scale)
        out = (np.empty((z1 - z0, ny, nx), np.uint8), np.zeros(7, np.int64),
               np.zeros((z1 - z0, 7)), np.zeros(4))
        window_slab_labels(*plan, np.full((ny * nx, 3), np.nan, np.float32),
                           np.full(ny * nx, 7.0, np.float32), z0, *ctx.kernel_args(), *out,
                           strip_voxels)
        return out

    _assert_same(fused(0, nz), whole)
    for strip_voxels in (1, 2 * nx + 1):  # strips of 1 and 2 rows
        _assert_same(fused(0, nz, strip_voxels), whole)
    parts = [fused(a, b) for a, b in ((0, 3), (3, 4), (4, nz))]
    np.testing.assert_array_equal(np.concatenate([p[0] for p in parts]), whole[0])


def _grid_over(ctx, source):
    """A grid 1.3x the image's size, centred on it (voxels outside the image on every side)."""
    from dreamprint_gui.io.volumes.base import PrintGrid

    lo, hi = np.array(source.bounds[0]), np.array(source.bounds[1])
    c, ext = (lo + hi) / 2, (hi - lo) * 1.3
    vox = (0.02, 0.015, 0.025)
    shape = tuple(int(np.ceil(e / v)) for e, v in zip(ext, vox, strict=True))
    return PrintGrid(shape, vox, tuple(c - ext / 2), 1.0)
