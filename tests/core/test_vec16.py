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


def test_weighted_sum_is_the_float32_expression_in_order():
    rng = np.random.default_rng(2)
    src = (rng.standard_normal(4096) * 10.0 ** rng.integers(-6, 6, 4096)).astype(np.float32)
    for _ in range(50):
        o = rng.integers(0, 4096 - 16, 8).astype(np.uint64)
        w = rng.random(8).astype(np.float32)
        d = int(rng.integers(0, 48))
        out = np.full(64, np.float32(3.5))
        _wsum(src, o, w, out, np.uint64(d))
        acc = w[0] * src[int(o[0]):int(o[0]) + 16]
        for n in range(1, 8):
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


@pytest.mark.parametrize("m", [1, 15, 16, 17, PREFETCH_AHEAD, PREFETCH_AHEAD + 1, 333,
                               ROW_BLOCK])
def test_interpolate_block_is_trilinear_interpolation_of_the_node_lanes(m):
    n = 9
    rng = np.random.default_rng(m)
    table = rng.random((n, n, n, LANES)).astype(np.float32)
    rgb = rng.random((m, 3)).astype(np.float32)
    rgb[:4] = [[0, 0, 0], [1, 1, 1], [1, 0, 0.5], [0.125, 1, 0]][:m]
    col, W, off, A, G, _ = block_buffers()
    for c in range(3):
        col[c * ROW_STRIDE:c * ROW_STRIDE + m] = rgb[:, c]
    G[:] = np.nan
    interpolate_block(table.reshape(-1), n, col, m, W, off, A, G)
    top = np.float32(n - 1)
    c = rgb * top
    i = np.minimum(c.astype(np.int64), n - 2)
    f = c - i.astype(np.float32)
    g = np.float32(1.0) - f
    acc = None
    for a in (0, 1):  # node order x, then y, then z; weights (wx * wy) * wz as the kernel forms
        for b in (0, 1):
            for e in (0, 1):
                w = ((f[:, 0] if a else g[:, 0]) * (f[:, 1] if b else g[:, 1])) * \
                    (f[:, 2] if e else g[:, 2])
                term = w[:, None] * table[i[:, 0] + a, i[:, 1] + b, i[:, 2] + e]
                acc = term if acc is None else acc + term
    for q in range(K_RHOK + 1):
        np.testing.assert_array_equal(G[q * ROW_STRIDE:q * ROW_STRIDE + m], acc[:, q])
    # at the nodes themselves the interpolation returns the node (round trip of the table)
    if m > 1:
        np.testing.assert_array_equal(G[np.arange(K_RHOK + 1) * ROW_STRIDE + 1],
                                      table[-1, -1, -1, :K_RHOK + 1])
    assert np.all(np.isnan(G[(K_RHOK + 1) * ROW_STRIDE:]))  # the target's lane untouched


@njit
def _prefetch_all(src, step):
    for i in range(0, src.shape[0], step):
        prefetch(src, np.uint64(i))
    return src[src.shape[0] - 1]


def test_prefetch_is_only_a_hint():
    src = np.random.default_rng(4).random(4096).astype(np.float32)
    before = src.copy()
    assert _prefetch_all(src, 7) == before[-1]
    np.testing.assert_array_equal(src, before)
    with pytest.raises(TypingError):
        _prefetch_all(np.zeros(64), 1)


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
