"""The explicit-vector kernel steps against numpy written from their definitions."""

import math

import numpy as np
import pytest
from numba import njit
from numba.core.errors import TypingError

from dreamprint_gui.core.kernels.vec16 import (
    accumulate8,
    prefetch,
    transpose16x13,
    weighted_sum16,
)
from dreamprint_gui.gamut.alignment import (
    K_RHOK,
    LANES,
    PREFETCH_AHEAD,
    ROW_BLOCK,
    ROW_STRIDE,
    block_buffers,
    finish_staging,
    interpolate_block,
)


@njit
def _transpose(src, s0, dst, d0, stride):
    transpose16x13(src, s0, dst, d0, stride)


@njit
def _wsum(src, o, w, out, d):
    weighted_sum16(src, (o[0], o[1], o[2], o[3], o[4], o[5], o[6], o[7]),
                   (w[0], w[1], w[2], w[3], w[4], w[5], w[6], w[7]), out, d)


def test_transpose_writes_the_first_thirteen_columns_as_rows_and_nothing_else():
    rng = np.random.default_rng(1)
    src = rng.standard_normal(16 * 16 + 37).astype(np.float32)
    s0, d0, stride = 5, 3, 21
    dst = np.full(3 + 12 * 21 + 16 + 8, -7.0, np.float32)
    _transpose(src, np.int64(s0), dst, np.int64(d0), np.int64(stride))
    block = src[s0:s0 + 256].reshape(16, 16)  # row r = voxel, column q = lane
    expect = np.full_like(dst, -7.0)
    for q in range(13):
        expect[d0 + q * stride:d0 + q * stride + 16] = block[:, q]
    np.testing.assert_array_equal(dst, expect)


@njit
def _wsum4(src, o, w, out, d):
    weighted_sum16(src, (o[0], o[1], o[2], o[3]), (w[0], w[1], w[2], w[3]), out, d)


@pytest.mark.parametrize("nodes", [8, 4])
def test_weighted_sum_is_the_float32_expression_in_order(nodes):
    rng = np.random.default_rng(2)
    src = (rng.standard_normal(4096) * 10.0 ** rng.integers(-6, 6, 4096)).astype(np.float32)
    for _ in range(50):
        o = rng.integers(0, 4096 - 16, nodes).astype(np.uint64)
        w = rng.random(nodes).astype(np.float32)
        d = int(rng.integers(0, 48))
        out = np.full(64, np.float32(3.5))
        (_wsum if nodes == 8 else _wsum4)(src, o, w, out, np.uint64(d))
        acc = w[0] * src[int(o[0]):int(o[0]) + 16]
        for n in range(1, nodes):
            acc = acc + w[n] * src[int(o[n]):int(o[n]) + 16]  # float32 rounding per operation
        assert acc.dtype == np.float32
        np.testing.assert_array_equal(out[d:d + 16], acc)
        assert np.all(np.delete(out, np.arange(d, d + 16)) == np.float32(3.5))


def test_intrinsics_refuse_other_types():
    with pytest.raises(TypingError):
        _transpose(np.zeros(300), np.int64(0), np.zeros(300), np.int64(0), np.int64(16))
    with pytest.raises(TypingError):
        _wsum(np.zeros(64, np.float32), np.zeros(8, np.int32), np.zeros(8, np.float32),
              np.zeros(16, np.float32), np.uint64(0))


# The six tetrahedra of a cell as colour management modules list them: the condition on the
# fractions (x, y, z), and the two inner vertices (unit steps in x, y, z).
_TETRAHEDRA = (
    (lambda x, y, z: (x >= y) & (y >= z), (1, 0, 0), (1, 1, 0)),
    (lambda x, y, z: (x >= z) & (z >= y), (1, 0, 0), (1, 0, 1)),
    (lambda x, y, z: (z >= x) & (x >= y), (0, 0, 1), (1, 0, 1)),
    (lambda x, y, z: (y >= x) & (x >= z), (0, 1, 0), (1, 1, 0)),
    (lambda x, y, z: (y >= z) & (z >= x), (0, 1, 0), (0, 1, 1)),
    (lambda x, y, z: (z >= y) & (y >= x), (0, 0, 1), (0, 1, 1)),
)


def _tetrahedral_reference(table, rgb):
    """Tetrahedral interpolation written case by case (float32 as the kernel rounds: weights
    1 - a, a - b, b - c, c of the sorted fractions; sum in node order)."""
    n = table.shape[0]
    c = rgb * np.float32(n - 1)
    i = np.minimum(c.astype(np.int64), n - 2)
    f = c - i.astype(np.float32)
    out = np.full((len(rgb), table.shape[-1]), np.nan, np.float32)
    done = np.zeros(len(rgb), bool)
    for cond, e1, e2 in _TETRAHEDRA:
        sel = cond(f[:, 0], f[:, 1], f[:, 2]) & ~done
        done |= sel
        fs = -np.sort(-f[sel], axis=1)
        w = (np.float32(1) - fs[:, 0], fs[:, 0] - fs[:, 1], fs[:, 1] - fs[:, 2], fs[:, 2])
        ii = i[sel]
        nodes = [ii, ii + e1, ii + e2, ii + 1]
        acc = None
        for wk, nk in zip(w, nodes, strict=True):
            term = wk[:, None] * table[nk[:, 0], nk[:, 1], nk[:, 2]]
            acc = term if acc is None else acc + term
        out[sel] = acc
    assert done.all()
    return out


@pytest.mark.parametrize("m", [1, 15, 16, 17, PREFETCH_AHEAD, PREFETCH_AHEAD + 1, 333,
                               ROW_BLOCK])
def test_interpolate_block_is_tetrahedral_interpolation_of_the_node_lanes(m):
    n = 9
    rng = np.random.default_rng(m)
    table = rng.random((n, n, n, LANES)).astype(np.float32)
    rgb = rng.random((m, 3)).astype(np.float32)
    rgb[:6] = [[0, 0, 0], [1, 1, 1], [1, 0, 0.5], [0.125, 1, 0], [0.3, 0.3, 0.7],
               [0.55, 0.2, 0.55]][:m]  # nodes, a cell face, ties between fractions
    col, W, off, A, G, _ = block_buffers()
    for c in range(3):
        col[c * ROW_STRIDE:c * ROW_STRIDE + m] = rgb[:, c]
    G[:] = np.nan
    interpolate_block(table.reshape(-1), n, col, m, W, off, A, G)
    expect = _tetrahedral_reference(table, rgb)
    for q in range(K_RHOK + 1):
        np.testing.assert_array_equal(G[q * ROW_STRIDE:q * ROW_STRIDE + m], expect[:, q])
    # at the nodes themselves the interpolation returns the node (round trip of the table)
    if m > 1:
        np.testing.assert_array_equal(G[np.arange(K_RHOK + 1) * ROW_STRIDE + 1],
                                      table[-1, -1, -1, :K_RHOK + 1])
    assert np.all(np.isnan(G[(K_RHOK + 1) * ROW_STRIDE:]))  # the target's lane untouched


def test_interpolate_block_reproduces_a_linear_table():
    """Closed form: tetrahedral interpolation is exact for a table linear in the colour."""
    n = 11
    rng = np.random.default_rng(5)
    a = rng.standard_normal((3, LANES))
    grid = np.stack(np.meshgrid(*[np.arange(n) / (n - 1)] * 3, indexing="ij"), -1)
    table = (grid @ a + 0.5).astype(np.float32)
    m = 500
    rgb = rng.random((m, 3)).astype(np.float32)
    col, W, off, A, G, _ = block_buffers()
    for c in range(3):
        col[c * ROW_STRIDE:c * ROW_STRIDE + m] = rgb[:, c]
    interpolate_block(table.reshape(-1), n, col, m, W, off, A, G)
    expect = rgb.astype(np.float64) @ a + 0.5
    for q in range(K_RHOK + 1):
        np.testing.assert_allclose(G[q * ROW_STRIDE:q * ROW_STRIDE + m], expect[:, q],
                                   atol=2e-5)


@njit
def _prefetch_all(src, step):
    for i in range(0, src.shape[0], step):
        prefetch(src, np.uint64(i))
    return src[src.shape[0] - 1]


@pytest.mark.parametrize("dtype", [np.float32, np.float64, np.int64])
def test_prefetch_is_only_a_hint(dtype):
    src = (np.random.default_rng(4).random(4096) * 1000).astype(dtype)
    before = src.copy()
    assert _prefetch_all(src, 7) == before[-1]
    np.testing.assert_array_equal(src, before)


@pytest.mark.parametrize("bad", [np.zeros(64, np.int8), np.zeros((8, 8), np.float32)])
def test_prefetch_takes_only_1d_arrays_of_its_types(bad):
    with pytest.raises(TypingError):
        _prefetch_all(bad, 1)


def test_finish_staging_cleans_colours():
    rng = np.random.default_rng(5)
    col = block_buffers()[0]
    m = 21
    raw = rng.normal(0.5, 0.8, (3, m)).astype(np.float32)
    raw[0, 0] = np.nan
    raw[1, 3] = np.inf
    raw[2, 4] = -np.inf
    for c in range(3):
        col[c * ROW_STRIDE:c * ROW_STRIDE + m] = raw[c]
        col[c * ROW_STRIDE + m:c * ROW_STRIDE + 32] = np.nan  # stale lanes of the last group
    assert finish_staging(col, m) == 32
    clean = np.where(np.isnan(raw), 0.0, np.clip(raw, 0.0, 1.0)).astype(np.float32)
    for c in range(3):
        np.testing.assert_array_equal(col[c * ROW_STRIDE:c * ROW_STRIDE + m], clean[c])
        assert np.all(col[c * ROW_STRIDE + m:c * ROW_STRIDE + 32] == 0.0)


@njit
def _acc8(src, o, acc, j):
    accumulate8(src, o, acc, j)


def test_accumulate8_adds_eight_floats_in_double():
    rng = np.random.default_rng(9)
    src = rng.standard_normal(40).astype(np.float32)
    acc = rng.standard_normal(24)
    ref = acc.copy()
    _acc8(src, np.int64(5), acc, np.int64(1))
    ref[8:16] += src[5:13].astype(np.float64)
    np.testing.assert_array_equal(acc, ref)


@pytest.mark.parametrize("m", [0, 1, 7, 8, 9, 1023, ROW_BLOCK])
def test_block_conc_sums_is_the_fixed_order_sum(m):
    from dreamprint_gui.job.sample_label.layer_kernel import block_conc_sums

    rng = np.random.default_rng(m)
    C = rng.random(8 * ROW_STRIDE).astype(np.float32)
    sums = np.full(7, 0.25)
    block_conc_sums_py = njit(lambda C, m, acc, sums: block_conc_sums(C, m, acc, sums))
    block_conc_sums_py(C, m, np.empty(48), sums)
    m8 = m - m % 8
    for q in range(6):
        row = C[q * ROW_STRIDE:q * ROW_STRIDE + m].astype(np.float64)
        part = np.zeros(8)
        for k0 in range(0, m8, 8):  # lane j adds its voxels in order
            part += row[k0:k0 + 8]
        s = 0.0
        for j in range(8):
            s += part[j]
        for k in range(m8, m):
            s += row[k]
        assert sums[q] == 0.25 + s
        assert sums[q] == pytest.approx(0.25 + math.fsum(row), rel=1e-12)
    assert sums[6] == 0.25
