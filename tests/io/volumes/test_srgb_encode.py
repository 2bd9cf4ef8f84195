"""Linear -> sRGB encoding (io/volumes/srgb_encode.py): against a correctly rounded reference,
in place and masked variants, the edge values."""

import numpy as np
import pytest

from dreamprint_gui.io.volumes.base import linear_to_srgb, linear_to_srgb_inplace
from dreamprint_gui.io.volumes.srgb_encode import (
    AS_IS,
    CLIP,
    ENCODE,
    clip_where,
    encode_where,
    prepare_staged,
)


def _reference(x: np.ndarray) -> np.ndarray:
    """IEC 61966-2-1 in float32 steps, the power correctly rounded (float64 ** -> float32)."""
    x = np.clip(x.astype(np.float32), 0, 1)
    p = (x.astype(np.float64) ** np.float64(np.float32(1 / 2.4))).astype(np.float32)
    enc = p * np.float32(1.055) - np.float32(0.055)
    return np.where(x <= np.float32(0.0031308), x * np.float32(12.92), enc).astype(np.float32)


# The segment lines' largest error (module docstring; 2.98e-7 measured): a thirty-thousandth of
# a table node's 1/99, and on average a tenth of that.
MAX_ERROR = 3.5e-7
MEAN_ERROR = 4e-8
# sha256 (first 16 hex) of the segment lines, float32 a then b (the table of every machine)
TABLE_SHA256 = "cddeb3914aa481f8"


def test_every_float_of_the_power_range_against_a_correctly_rounded_power():
    """All 70,439,396 float32 values of (0.0031308, 1]: within MAX_ERROR of the correctly
    rounded encoding, MEAN_ERROR on average, and a brighter linear value never encoded darker
    by more than twice that (where the lines of neighbouring segments meet). In runs of 2**22
    consecutive floats (the step between runs checked too): the whole range at once took
    2.7 GB and 7x the CPU time."""
    lo, hi = np.float32(0.0031308).view(np.uint32), np.float32(1.0).view(np.uint32)
    err_max, err_sum, n, step_min, last = 0.0, 0.0, 0, np.inf, None
    for start in range(int(lo) + 1, int(hi) + 1, 1 << 22):
        x = np.arange(start, min(start + (1 << 22), int(hi) + 1), dtype=np.uint32)
        x = x.view(np.float32)
        got = linear_to_srgb(x).astype(np.float64)
        err = np.abs(got - _reference(x))
        err_max, err_sum, n = max(err_max, err.max()), err_sum + err.sum(), n + x.size
        steps = np.diff(got if last is None else np.concatenate(([last], got)))
        step_min, last = min(step_min, steps.min()), got[-1]
    assert n == hi - lo == 70_439_396
    assert err_max <= MAX_ERROR
    assert err_sum / n <= MEAN_ERROR
    assert step_min >= -2 * MAX_ERROR


def test_random_floats_of_the_whole_range_against_a_correctly_rounded_power():
    rng = np.random.default_rng(5)
    lo, hi = np.float32(0.0031308).view(np.uint32), np.float32(1.0).view(np.uint32)
    x = rng.integers(lo, hi, 1_000_000, endpoint=True, dtype=np.uint32).view(np.float32)
    got, want = linear_to_srgb(x), _reference(x)
    assert np.abs(got.astype(np.float64) - want).max() <= MAX_ERROR


def test_segment_table_is_computed_without_the_cpu_dispatched_power():
    """The lines come from plain IEEE float64 steps (vector_math's array log2 / exp2), not
    numpy's CPU-dispatched ``**`` (with which 3 of the 2151 lines differ): the table's bits are
    pinned, the same on every machine, and each line agrees with math.pow's curve to float64
    rounding."""
    import hashlib
    import math

    from dreamprint_gui.io.volumes import srgb_encode as se

    digest = hashlib.sha256(se._SEG_A.tobytes() + se._SEG_B.tobytes()).hexdigest()[:16]
    assert digest == TABLE_SHA256
    for s in (0, 700, len(se._SEG_A) - 1):
        a, b = se._segment_lines(se._SEG_FIRST + s, 1)
        x0 = float(se._from_segment(se._SEG_FIRST + s))
        x1 = float(se._from_segment(se._SEG_FIRST + s + 1))
        curve = lambda v: 1.055 * math.pow(v, se._E) - 0.055  # noqa: E731
        assert b[0] == pytest.approx((curve(x1) - curve(x0)) / (x1 - x0), rel=1e-7)


def test_edges_and_out_of_range():
    x = np.array([np.nan, -1.0, -0.0, 0.0, 0.0031308, np.nextafter(np.float32(0.0031308),
                                                                    np.float32(1)),
                  1.0, 7.0, np.inf, -np.inf], np.float32)
    got = linear_to_srgb(x)
    assert np.isnan(got[0])
    np.testing.assert_array_equal(got[1:4], 0.0)
    assert got[4] == np.float32(0.0031308) * np.float32(12.92)
    assert abs(float(got[5]) - float(_reference(x[5:6])[0])) <= MAX_ERROR
    np.testing.assert_array_equal(got[6:9], np.float32(1.055) - np.float32(0.055))  # f32 steps
    assert got[9] == 0.0


@pytest.mark.parametrize("rows, nx", [(1, 1), (1, 7), (40, 25), (3, 4097)])
def test_in_place_and_row_variants_agree(rows, nx):
    """encode_where / clip_where convert exactly the rows holding a voxel at or above the
    threshold, with linear_to_srgb's bits / np.clip's; other rows are left as they were."""
    n = rows * nx
    rng = np.random.default_rng(n)
    x = rng.uniform(-0.2, 1.3, (n, 3)).astype(np.float32)
    x[0, 0] = np.nan
    want = linear_to_srgb(x)
    np.testing.assert_array_equal(linear_to_srgb_inplace(x.copy()).view(np.uint32),
                                  want.view(np.uint32))
    dens = rng.uniform(0, 0.49, n).astype(np.float32)
    dens[rng.integers(0, n, max(1, rows // 3))] = 0.5             # some rows reach it
    hit = np.repeat((dens >= 0.5).reshape(rows, nx).any(axis=1), nx)
    for fn, ref in ((encode_where, want), (clip_where, np.clip(x, 0, 1))):
        y = x.copy()
        fn(y, dens, np.float32(0.5), nx)
        np.testing.assert_array_equal(y[hit].view(np.uint32), ref[hit].view(np.uint32))
        np.testing.assert_array_equal(y[~hit].view(np.uint32), x[~hit].view(np.uint32))
    with pytest.raises(ValueError):
        linear_to_srgb_inplace(np.zeros((4, 4), np.float32)[:, ::2])


@pytest.mark.parametrize("m", [0, 1, 5, 16, 1000])
def test_staged_block_variant_agrees(m):
    """prepare_staged converts the first ``m`` values of each channel row of a staged block
    (stride ``m + 13``) with linear_to_srgb's bits (ENCODE) or clip_where's (CLIP: np.clip's,
    NaN kept, but -0.0 -> +0.0), and nothing else; AS_IS leaves the block."""
    stride = m + 13
    rng = np.random.default_rng(m)
    col = rng.uniform(-0.2, 1.3, 3 * stride).astype(np.float32)
    col[rng.integers(0, col.size, 3)] = np.nan
    col[rng.integers(0, col.size, 3)] = -0.0
    staged = np.zeros(3 * stride, bool)
    for c in range(3):
        staged[c * stride:c * stride + m] = True
    clipped = np.clip(col, 0, 1) + np.float32(0.0)              # -0.0 + 0.0 = +0.0
    for op, ref in ((ENCODE, linear_to_srgb(col)), (CLIP, clipped), (AS_IS, col)):
        y = col.copy()
        prepare_staged(y, m, stride, op)
        np.testing.assert_array_equal(y[staged].view(np.uint32), ref[staged].view(np.uint32))
        np.testing.assert_array_equal(y[~staged].view(np.uint32), col[~staged].view(np.uint32))
