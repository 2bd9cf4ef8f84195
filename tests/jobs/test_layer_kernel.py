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


@pytest.mark.parametrize("colour_op", ["as-is", "encode", "uniform"])
@pytest.mark.parametrize("halftone, ny, nx, empty", [
    ("blue-noise", 61, 97, 0.3),   # ~4000 foreground voxels: blocks of 1024 end inside strips
    ("random", 61, 97, 0.3),
    ("blue-noise", 9, 2600, 0.2),  # rows wider than a block: several blocks a row, the first
    ("random", 12, 512, 0.0),      # with voxels staged at the strip before
])
def test_strips_give_the_layer_bit_for_bit(tmp_path, colour_op, halftone, ny, nx, empty):
    """A layer labelled in strips of rows (``strip_labels``, each strip's samples in arrays of
    their own, refilled between strips) gives the labels, counts, concentration sums and clamp
    report of the whole layer in one call, for strips of any height: the blocks, which reach
    over strips, are the same."""
    from dreamprint_gui.io.volumes.srgb_encode import AS_IS, ENCODE
    from dreamprint_gui.job.sample_label.layer_kernel import (
        UNIFORM,
        layer_labels,
        layer_state,
        strip_labels,
    )

    op = {"as-is": AS_IS, "encode": ENCODE, "uniform": UNIFORM}[colour_op]
    ctx = prepare_job(ConvertSettings(source="demo", output=tmp_path / "J", height_mm=0.6,
                                      table_size=17, seed=3, halftone=halftone))
    args = ctx.kernel_args()
    rng = np.random.default_rng(8)
    rgb = rng.random((ny * nx, 3), dtype=np.float32)
    if op == UNIFORM:
        rgb[:] = rgb[0]
    dens = rng.uniform(0.0, 40.0, ny * nx).astype(np.float32)
    dens[rng.random(ny * nx) < empty] = 0.0
    if ny > 33:
        dens[:4 * nx] = 0.0                      # empty rows, sparse rows
        dens[20 * nx:22 * nx:5] = 0.0
        dens[30 * nx:33 * nx] = np.where(np.arange(3 * nx) % 9 == 0, 30.0, 0.0)
    dens[7] = np.nan
    dens[ny * nx - 1] = 0.0
    z = 5

    def run(strip_rows):
        out = (np.empty((ny, nx), np.uint8), np.zeros(7, np.int64), np.zeros(7), np.zeros(4))
        if strip_rows is None:
            layer_labels(rgb, dens, z, *args, *out, op)
            return out
        state = layer_state(nx)
        for y0 in range(0, ny, strip_rows):
            nr = min(strip_rows, ny - y0)
            # the strip's own arrays, garbage beyond: only its rows may be read
            r = np.full(((strip_rows + 3) * nx, 3), np.nan, np.float32)
            d = np.full((strip_rows + 3) * nx, 99.0, np.float32)
            r[:nr * nx] = rgb[y0 * nx:(y0 + nr) * nx]
            d[:nr * nx] = dens[y0 * nx:(y0 + nr) * nx]
            if op == UNIFORM:
                r[0] = rgb[0]
            strip_labels(r, d, z, y0, nr, *args, *out, op, state)
        return out

    whole = run(None)
    assert len(np.unique(whole[0])) > 2
    assert whole[3][0] + whole[3][1] > 0  # the clamp report is exercised
    for strip_rows in sorted({1, 2, 5, 7, 13, ny - 1, ny}):
        for a, b in zip(run(strip_rows), whole, strict=True):
            np.testing.assert_array_equal(a.view(np.uint8), b.view(np.uint8))
