"""Looking a colour up once per run of voxels of that colour gives the per-voxel lookup's bits.

The reference is the per-voxel path (``finish_staging`` then ``interpolate_block``), run on a
copy of the same staged block; lanes and concentrations are compared as raw bits.
"""

import numpy as np
import pytest

from dreamprint_gui.gamut.alignment import (
    K_RHOK,
    K_TARGET,
    ROW_BLOCK,
    ROW_STRIDE,
    RUN_MIN,
    align_rows,
    block_buffers,
    count_runs,
    finish_staging,
    interpolate_block,
    kernel_table,
    lookup_align_block,
    lookup_runs,
)

RS = ROW_STRIDE


def _runs_block(rng, m, mean_run):
    """(3, m) colours in runs of random length (mean ``mean_run``), damaged values included."""
    k = max(m, 8)
    lengths = np.minimum(rng.geometric(1.0 / mean_run, k), m)
    colours = rng.random((k, 3)).astype(np.float32)
    colours[::5] = np.float32(0.5)                    # equal neighbouring runs' colours too
    colours[3] = [np.nan, 0.2, 0.3]                    # cleaned to 0
    colours[4] = [0.0, 0.2, 0.3]                       # equal to the cleaned NaN run
    colours[6] = [1.7, -0.0, np.inf]                   # cleaned to (1, -0, 1)
    colours[7] = [1.0, 0.0, 1.0]                       # +0, a different bit pattern from -0
    rgb = np.repeat(colours, lengths, axis=0)[:m]
    return rgb.T.copy()


def _stage(raw, dens):
    col, W, off, A, G, C = block_buffers()
    m = raw.shape[1]
    for c in range(3):
        col[c * RS:c * RS + m] = raw[c]
        col[c * RS + m:(c + 1) * RS] = np.nan  # stale lanes past the block
    G[:] = np.nan
    G[K_TARGET * RS:K_TARGET * RS + m] = dens
    return col, W, off, A, G, C


def _bits(a):
    return a.view(np.int32)


@pytest.mark.parametrize("m,mean_run", [(1, 1), (17, 3), (333, 6), (ROW_BLOCK, 40),
                                        (ROW_BLOCK, 1.5)])
def test_lookup_runs_writes_the_per_voxel_lanes(small_tables, m, mean_run):
    rng = np.random.default_rng(m)
    flat = kernel_table(small_tables)
    n = small_tables.packed.shape[0]
    raw = _runs_block(rng, m, mean_run)
    dens = rng.uniform(0, 40, m).astype(np.float32)
    col, W, off, A, G, _ = _stage(raw, dens)
    ref = [a.copy() for a in (col, W, off, A, G)]
    finish_staging(ref[0], m)
    interpolate_block(flat, n, ref[0], m, ref[1], ref[2], ref[3], ref[4])
    finish_staging(col, m)
    lookup_runs(flat, n, col, m, W, off, A, G)
    for q in list(range(K_RHOK + 1)) + [K_TARGET]:
        np.testing.assert_array_equal(_bits(G[q * RS:q * RS + m]),
                                      _bits(ref[4][q * RS:q * RS + m]), err_msg=f"lane {q}")
    clean = ref[0].reshape(3, RS)[:, :m]
    changes = np.any(_bits(clean[:, 1:]) != _bits(clean[:, :-1]), axis=0)
    assert count_runs(ref[0], m) == 1 + int(changes.sum())


@pytest.mark.parametrize("mean_run", [1.2, 8, 1e9])
def test_lookup_align_block_gives_the_per_voxel_concentrations(small_tables, mean_run):
    """Whichever path a block takes (runs of one colour or not), the concentrations and the
    clamp report are those of the per-voxel lookup and alignment, bit for bit."""
    rng = np.random.default_rng(int(mean_run * 10) % 97)
    flat = kernel_table(small_tables)
    n = small_tables.packed.shape[0]
    sc = np.float32(small_tables.sigma_clear)
    m = ROW_BLOCK - 5
    raw = _runs_block(rng, m, mean_run)
    dens = rng.uniform(0, 60, m).astype(np.float32)
    dens[::11] = np.float32(1e30)   # solid
    dens[::13] = np.nan
    dens[::17] = np.float32(0.1 * sc)  # below pure Clear: clamped low
    col, W, off, A, G, C = _stage(raw, dens)
    ref = [a.copy() for a in (col, W, off, A, G, C)]
    runs = count_runs(np.where(np.isnan(col), 0, np.clip(col, 0, 1)).astype(np.float32), m)
    assert (runs * RUN_MIN <= m) == (mean_run >= 8)  # both paths are exercised
    stats = np.zeros(4)
    lookup_align_block(flat, n, sc, col, m, W, off, A, G, C, stats)
    finish_staging(ref[0], m)
    interpolate_block(flat, n, ref[0], m, ref[1], ref[2], ref[3], ref[4])
    lo, hi = align_rows(ref[4], m, sc, ref[5])
    for q in range(8):
        np.testing.assert_array_equal(_bits(C[q * RS:q * RS + m]),
                                      _bits(ref[5][q * RS:q * RS + m]), err_msg=f"row {q}")
    assert (stats[0], stats[1]) == (lo, hi) and lo > 0
    assert stats[2] == max(0.0, float(ref[5][6 * RS:6 * RS + m].max()))
    assert stats[3] == max(0.0, float(ref[5][7 * RS:7 * RS + m].max()))


@pytest.mark.parametrize("colour", [(0.3, 0.8, 0.1), (np.nan, 1.7, -0.0), (1.0, 0.0, 1.0)])
def test_uniform_lanes_are_the_per_voxel_lanes(small_tables, colour):
    """A block of one colour: uniform_lanes (written once, every voxel of a block) then
    align_block give the per-voxel lookup's lanes and concentrations and its clamp report, bit
    for bit, damaged colours included."""
    from dreamprint_gui.gamut.alignment import align_block, uniform_lanes

    rng = np.random.default_rng(3)
    flat = kernel_table(small_tables)
    n = small_tables.packed.shape[0]
    sc = np.float32(small_tables.sigma_clear)
    m = ROW_BLOCK - 9
    raw = np.tile(np.asarray(colour, np.float32)[:, None], (1, m))
    dens = rng.uniform(0, 60, m).astype(np.float32)
    dens[::11] = np.float32(1e30)
    dens[::13] = np.nan
    dens[::17] = np.float32(0.1 * sc)
    col, W, off, A, G, C = _stage(raw, dens)
    ref = [a.copy() for a in (col, W, off, A, G, C)]
    finish_staging(ref[0], m)
    interpolate_block(flat, n, ref[0], m, ref[1], ref[2], ref[3], ref[4])
    lo, hi = align_rows(ref[4], m, sc, ref[5])
    G[:K_TARGET * RS] = np.nan                          # whatever the lanes held before
    uniform_lanes(flat, n, *np.asarray(colour, np.float32), col, W, off, A, G)
    stats = np.zeros(4)
    align_block(sc, m, G, C, stats)
    for q in range(K_RHOK + 1):
        np.testing.assert_array_equal(_bits(G[q * RS:q * RS + m]),
                                      _bits(ref[4][q * RS:q * RS + m]), err_msg=f"lane {q}")
    for q in range(8):
        np.testing.assert_array_equal(_bits(C[q * RS:q * RS + m]),
                                      _bits(ref[5][q * RS:q * RS + m]), err_msg=f"row {q}")
    assert (stats[0], stats[1]) == (lo, hi) and lo > 0


def test_align_rows_counts_the_clamped_voxels(small_tables):
    """align_rows' clamp counts (taken apart from its vectorised loop, from flags) are the
    voxels that meet the clamp conditions, written out here in float32: low where
    t <= s0 and t < sigma_clear, high where t > s0 and the grey is useless (sg <= s0) or
    needed beyond 10 % (gmax (t - s0) / (sg - s0) > gmax); targets on and next to the limits."""
    from dreamprint_gui.gamut.alignment import K_GREY, K_SIG
    from dreamprint_gui.gamut.tables import GREY_MAX

    rng = np.random.default_rng(9)
    flat = kernel_table(small_tables)
    n = small_tables.packed.shape[0]
    sc = np.float32(small_tables.sigma_clear)
    m = ROW_BLOCK
    raw = rng.random((3, m)).astype(np.float32)
    raw[:, ::7] = 1.0                                   # white: the grey is useless
    col, W, off, A, G, C = _stage(raw, np.zeros(m, np.float32))
    finish_staging(col, m)
    interpolate_block(flat, n, col, m, W, off, A, G)
    s0 = G[K_SIG * RS:K_SIG * RS + m].copy()
    sg = G[K_GREY * RS:K_GREY * RS + m].copy()
    pick = rng.integers(0, 6, m)
    t = np.choose(pick, [sg, np.nextafter(sg, np.float32(0)), np.nextafter(sg, np.float32(1e9)),
                         s0, np.full(m, sc), rng.uniform(0, 2, m).astype(np.float32) * sg])
    t = t.astype(np.float32)
    t[::13] = np.nextafter(sc, np.float32(0))
    G[K_TARGET * RS:K_TARGET * RS + m] = t
    lo, hi = align_rows(G, m, sc, C)
    clear = t <= s0
    useless = sg <= s0
    with np.errstate(divide="ignore", invalid="ignore"):
        graw = np.float32(GREY_MAX) * (t - s0) / (sg - s0)
    want_lo = clear & (t < sc)
    want_hi = ~clear & (useless | (graw > np.float32(GREY_MAX)))
    assert (lo, hi) == (int(want_lo.sum()), int(want_hi.sum()))
    assert 0 < lo < m and 0 < hi < m
    np.testing.assert_array_equal(C[6 * RS:6 * RS + m] > 0, want_lo)
    # clamped high with a shortfall of 0: the target equals sg and graw rounds above gmax
    assert (want_hi & (C[7 * RS:7 * RS + m] == 0)).any()
