"""Halftoning: unbiased fractions, blue noise beats i.i.d., position-keyed determinism.

Statistical tolerances: for ``random`` each voxel is an independent draw, so a fraction over n
voxels has standard error sqrt(c(1-c)/n); we allow 5 standard errors (false alarm ~6e-7). The
blue-noise mask is deterministic and exact over whole tiles (|bias| <= 1/N per tile); we allow
the same 5-sigma i.i.d. bound, which it must beat by far.
"""

import numpy as np
import pytest

from dreamprint_gui.job.halftone import (
    Halftoner,
    blue_noise_mask,
    box_for_voxel,
    fraction_variance_ratio,
    uniform_hash,
)

VOX = (0.084, 0.028, 0.014)
CONC = np.array([0.12, 0.2, 0.05, 0.03, 0.1, 0.5], np.float32)


@pytest.fixture(scope="module")
def blocks():
    block = np.broadcast_to(CONC, (72, 72, 24, 6))
    return {m: Halftoner.create(m, 11, VOX).block(block) for m in ("random", "blue-noise")}


def test_mask_is_a_permutation_of_rank_thresholds():
    m = blue_noise_mask(VOX)
    n = m.size
    np.testing.assert_allclose(np.sort(m.ravel()), (np.arange(n) + 0.5) / n, rtol=1e-6)


@pytest.mark.parametrize("method", ["random", "blue-noise"])
def test_fractions_converge_to_concentrations(blocks, method):
    lab = blocks[method]
    n = lab.size
    frac = np.bincount(lab.ravel(), minlength=7)[:6] / n
    se = np.sqrt(CONC * (1 - CONC) / n)
    assert np.all(np.abs(frac - CONC) < 5 * se), (frac, CONC)


def test_varying_concentrations_are_unbiased():
    # A smooth random field of concentrations: the expected count of ink m is sum(c_m).
    rng = np.random.default_rng(5)
    c = rng.dirichlet(np.ones(6), size=(40, 60, 30)).astype(np.float32)
    for method in ("random", "blue-noise"):
        lab = Halftoner.create(method, 3, VOX).block(c)
        for m in range(6):
            expect = float(c[..., m].sum())
            var = float((c[..., m] * (1 - c[..., m])).sum())
            assert abs((lab == m).sum() - expect) < 5 * np.sqrt(var) + 1


def test_blue_noise_beats_iid(blocks):
    box = box_for_voxel(VOX)  # ~0.25 mm
    r_iid, _ = fraction_variance_ratio(blocks["random"], CONC, box)
    r_bn, b_bn = fraction_variance_ratio(blocks["blue-noise"], CONC, box)
    assert np.all(np.abs(r_iid - 1) < 0.25)   # i.i.d. is binomial by construction
    assert np.all(r_bn < 0.6), r_bn
    assert np.nanmean(r_bn) < 0.3


@pytest.mark.parametrize("method", ["random", "blue-noise"])
def test_labels_depend_only_on_position(method):
    h = Halftoner.create(method, 99, VOX)
    rng = np.random.default_rng(0)
    c = rng.dirichlet(np.ones(6), size=(20, 30, 40)).astype(np.float32)
    whole = h.block(c)
    # The same voxels converted as two sub-blocks with their absolute origin.
    a = h.block(c[:7, :, 10:], origin_xyz=(10, 0, 0))
    b = h.block(c[7:, 5:, :], origin_xyz=(0, 5, 7))
    np.testing.assert_array_equal(a, whole[:7, :, 10:])
    np.testing.assert_array_equal(b, whole[7:, 5:, :])
    other = Halftoner.create(method, 100, VOX).block(c)
    assert (other != whole).mean() > 0.1  # the seed matters


def test_uniform_hash_is_uniform_and_independent():
    u = uniform_hash(1, (32, 64, 64)).ravel()
    assert abs(u.mean() - 0.5) < 5 * np.sqrt(1 / 12 / u.size)
    hist = np.bincount((u * 16).astype(int), minlength=16)
    expected = u.size / 16
    chi2 = ((hist - expected) ** 2 / expected).sum()
    assert chi2 < 50  # 15 dof: p ~ 1e-5
    assert abs(np.corrcoef(u[:-1], u[1:])[0, 1]) < 5 / np.sqrt(u.size)


def test_background_threshold_and_label():
    h = Halftoner.create("random", 1, VOX, threshold=0.5, bg_label=6)
    conc = np.tile(np.array([1, 0, 0, 0, 0, 0], np.float32), (4, 1))
    dens = np.array([0.1, 0.6, 0.49, 0.5], np.float32)
    out = np.empty((2, 2), np.uint8)
    counts = np.zeros(7, np.int64)
    sums = np.zeros(7)
    h.layer_into(conc, dens, 0, out, counts, sums)
    assert out.ravel().tolist() == [6, 0, 6, 0]
    assert counts.tolist() == [2, 0, 0, 0, 0, 0, 2]


def _first_crossing(c, t, order):
    """The label rule written out: the first ink (in ``order``) whose cumulative concentration
    exceeds t times the total; on a rounding miss the last ink with a positive share."""
    c = [float(v) for v in c]
    tt = t * sum(c)
    acc = 0.0
    for m in order:
        acc += c[m]
        if tt < acc:
            return m
    for m in reversed(order):
        if c[m] > 0.0:
            return m
    return 6


def test_pick_label_is_the_first_crossing():
    from numba import njit

    from dreamprint_gui.job.halftone import INK_ORDER, pick_label

    @njit
    def labels(conc, t, order):
        out = np.empty(conc.shape[0], np.int64)
        for i in range(conc.shape[0]):
            out[i] = pick_label(conc[i], t[i], order, 6)
        return out

    rng = np.random.default_rng(5)
    n = 4000
    conc = (rng.random((n, 6)) * (rng.random((n, 6)) < 0.6)).astype(np.float32)
    conc[:400] -= np.float32(0.3) * (rng.random((400, 6)) < 0.2)  # a negative share
    conc[400:450] = 0.0                                          # nothing to draw
    conc[450:500, 2] = np.nan                                    # a damaged voxel
    t = rng.random(n)
    t[500:550] = 0.0
    t[550:600] = 1.0                                             # t * s rounds onto s
    t[600:650] = np.nan
    order = np.asarray(INK_ORDER, np.int64)
    got = labels(conc, t, order)
    want = [_first_crossing(conc[i], t[i], INK_ORDER) for i in range(n)]
    assert got.tolist() == want
    assert len(set(want)) == 7  # every ink and the fallback label are exercised


def test_label_rows_gives_pick_labels_answers():
    """The branch-free, vectorised form used by the print job equals the written-out rule on
    the same awkward inputs (negative and NaN shares, all-zero voxels, t = 0, 1 and NaN)."""
    from dreamprint_gui.job.halftone import INK_ORDER, label_rows

    rng = np.random.default_rng(9)
    n = 3000
    conc = (rng.random((n, 6)) * (rng.random((n, 6)) < 0.6)).astype(np.float32)
    conc[:300] -= np.float32(0.3) * (rng.random((300, 6)) < 0.2)
    conc[300:350] = 0.0
    conc[350:400, 4] = np.nan
    t = rng.random(n)
    t[400:450] = 0.0
    t[450:500] = 1.0
    t[500:550] = np.nan
    order = np.asarray(INK_ORDER, np.int64)
    lab = np.empty(n, np.uint8)
    label_rows(np.ascontiguousarray(conc.T), t, n, order, 6, lab)
    want = [_first_crossing(conc[i], t[i], INK_ORDER) for i in range(n)]
    assert lab.tolist() == want
    assert len(set(want)) == 7


def _rare_ink_layer_residues(lab, ink, mask_shape):
    """Largest number of ``ink`` voxels of one layer on one residue (x mod mx, y mod my)."""
    _, my, mx = mask_shape
    layer = lab[lab.shape[0] // 2] == ink
    return max(int(layer[j::my, i::mx].sum()) for j in range(my) for i in range(mx)), \
        int(layer.sum())


def test_rare_ink_forms_no_lattice():
    # Smoke-like colour, magenta (index 1) rare. One mask offset for the whole job put every
    # magenta voxel of a layer on one residue of the tile period (a 1 mm lattice); with a hashed
    # shift per tile the residues are as spread as i.i.d. placement's, and the power spectrum of
    # the placement at the tile's fundamental frequencies is at the i.i.d. level (periodogram 1;
    # a lattice gives tens).
    conc = np.array([0.05, 0.007, 0.03, 0.01, 0.10, 0.803], np.float32)
    h = Halftoner.create("blue-noise", 7, VOX)
    mz, my, mx = h.mask.shape
    shape = (mz, 4 * my, 8 * mx)
    lab = h.block(np.broadcast_to(conc, (*shape, 6)))
    most, total = _rare_ink_layer_residues(lab, 1, h.mask.shape)
    assert total > 40 and most <= 4, (most, total)
    ind = (lab == 1).astype(np.float64)
    c = float(conc[1])
    p = np.abs(np.fft.rfftn(ind - ind.mean())) ** 2 / (ind.size * c * (1 - c))
    fz, fy, fx = shape[0] // mz, shape[1] // my, shape[2] // mx
    low = p[np.ix_([0, fz, -fz], [0, fy, -fy], [0, fx])].ravel()[1:]
    assert low.max() < 5, low.max()
    harm = p[::fz, ::fy, ::fx].ravel()[1:]
    assert 0.7 < harm.mean() / p.ravel()[1:].mean() < 1.3


def test_every_tile_reads_the_whole_mask_once():
    # Unbiasedness over a tile: whatever its shift, each tile reads every threshold once.
    from dreamprint_gui.job.halftone import tile_layout

    h = Halftoner.create("blue-noise", 3, VOX)
    mz, my, mx = h.mask.shape
    ox, oy, oz = h.offset_xyz
    x0, y0, z0 = mx - ox, my - oy, mz - oz  # the first whole tile
    seed = np.uint64(3)
    thr = np.empty((mz, 2 * my, 2 * mx), np.float32)
    for k in range(mz):
        cols, rows, tiles = tile_layout(x0, 2 * mx, y0, 2 * my, z0 + k, ox, oy, oz, mz, my, mx,
                                        seed)
        for j in range(2 * my):
            for i in range(2 * mx):
                t = tiles[rows[1, j], cols[1, i]]
                thr[k, j, i] = h.mask[t[0], (rows[0, j] + t[1]) % my, (cols[0, i] + t[2]) % mx]
    ref = np.sort(h.mask.ravel())
    shifts = set()
    for b in range(2):
        for a in range(2):
            tile = thr[:, b * my:(b + 1) * my, a * mx:(a + 1) * mx]
            np.testing.assert_array_equal(np.sort(tile.ravel()), ref)
            shifts.add(tile.tobytes())
    assert len(shifts) == 4  # the tiles differ


@pytest.mark.parametrize("method", ["blue-noise", "random"])
def test_threshold_row_equals_the_voxels_thresholds(method):
    from numba import njit

    from dreamprint_gui.job.halftone import fg_threshold, threshold_row, tile_layout

    @njit
    def both(method, mask, ox, oy, oz, seed, x0, nx, y0, ny, z, row, one):
        mz, my, mx = mask.shape
        cols, rows, tiles = tile_layout(x0, nx, y0, ny, z, ox, oy, oz, mz, my, mx, seed)
        for j in range(ny):
            threshold_row(method, mask, tiles, cols, rows, seed, j, x0, y0 + j, z, 0, nx,
                          row[j])
            lo = j % 7
            hi = max(lo, nx - j % 5)
            part = np.full(nx, -2.0)
            threshold_row(method, mask, tiles, cols, rows, seed, j, x0, y0 + j, z, lo, hi, part)
            for i in range(nx):
                if (lo <= i < hi) != (part[i] == row[j, i]):
                    row[j, i] = -3.0  # a span's thresholds are the row's, and only the span
            for i in range(nx):
                one[j, i] = fg_threshold(method, mask, tiles, cols, rows, seed, i, j, x0 + i,
                                         y0 + j, z)

    h = Halftoner.create(method, 17, VOX)
    code, mask, ox, oy, oz, seed, _ = h.kernel_args()
    for x0, nx, y0, ny, z in [(0, 101, 0, 90, 3), (5, 37, 11, 40, 200), (0, 1, 0, 2, 0),
                              (23, 12, 2, 3, 77)]:
        row = np.full((ny, nx + 3), -1.0)
        one = np.empty((ny, nx))
        both(code, mask, ox, oy, oz, seed, x0, nx, y0, ny, z, row, one)
        np.testing.assert_array_equal(row[:, :nx], one)
        assert np.all(row[:, nx:] == -1.0)  # nothing past the row
