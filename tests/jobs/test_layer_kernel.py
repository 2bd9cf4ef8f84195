"""The print job's fused per-layer kernel equals its parts: ``lookup_and_align_into`` followed
by ``Halftoner.layer_into`` (labels, counts, intended concentrations and clamp report)."""

import numpy as np
import pytest

from dreamprint_gui.gamut import lookup_and_align_into
from dreamprint_gui.job.plan import ConvertSettings, prepare_job
from dreamprint_gui.job.slab import _labels_of_slab


@pytest.mark.parametrize("halftone", ["blue-noise", "random"])
def test_fused_layer_equals_lookup_then_halftone(tmp_path, halftone):
    ctx = prepare_job(ConvertSettings(source="demo", output=tmp_path / "J", height_mm=0.6,
                                      table_size=17, seed=11, halftone=halftone))
    _, tables = ctx.resources()
    ny, nx = 37, 53
    rng = np.random.default_rng(4)
    rgb = rng.random((2, ny * nx, 3), dtype=np.float32)
    rgb[:, 100:140] = rgb[:, 99:100]                # runs of identical voxels
    dens = rng.uniform(0.0, 40.0, (2, ny * nx)).astype(np.float32)
    dens[:, 100:140] = dens[:, 99:100]
    dens[:, ::7] = 0.5 * ctx.halftoner.threshold    # background voxels
    dens[0, 5] = np.nan
    rgb[1, 6] = np.nan
    dens[0, 4 * nx:6 * nx] = 0.0                    # rows without foreground (skipped whole)
    dens[1, 7 * nx:8 * nx] = np.nan
    dens[1, 9 * nx:10 * nx - 1] = 0.0               # one foreground voxel, at the row's end
    z0 = 9
    labels = np.empty((2, ny, nx), np.uint8)
    counts = np.zeros(7, np.int64)
    sums = np.zeros((2, 7))
    stats = np.zeros(4)
    _labels_of_slab(ctx, rgb.reshape(2, ny, nx, 3), dens.reshape(2, ny, nx), z0, labels, counts,
                    sums, stats)

    rc = np.zeros(7, np.int64)
    rs = np.zeros(7)
    low = high = 0
    short_low = short_high = 0.0
    for k in range(2):  # each layer of the slab, through the library's two steps
        fg = dens[k] >= ctx.halftoner.threshold
        conc = np.zeros((ny * nx, 6), np.float32)
        sub = np.empty((int(fg.sum()), 6), np.float32)
        ref_counts = lookup_and_align_into(tables, rgb[k][fg], dens[k][fg], sub)
        conc[fg] = sub
        d = np.where(fg, dens[k], 0.0).astype(np.float32)  # NaN density is background in both
        ref = np.empty((ny, nx), np.uint8)
        ctx.halftoner.layer_into(conc, d, z0 + k, ref, rc, rs)
        np.testing.assert_array_equal(labels[k], ref)
        low += ref_counts.n_clamped_low
        high += ref_counts.n_clamped_high
        short_low = max(short_low, ref_counts.max_shortfall_low)
        short_high = max(short_high, ref_counts.max_shortfall_high)
    np.testing.assert_array_equal(counts, rc)
    np.testing.assert_allclose(sums.sum(axis=0), rs, rtol=1e-12)
    assert (stats[0], stats[1]) == (low, high)
    assert stats[2] == pytest.approx(short_low)
    assert stats[3] == pytest.approx(short_high)
    assert stats[0] + stats[1] > 0  # the test exercises the clamp report
