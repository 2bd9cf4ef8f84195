"""Cache-line aligned zeros: the start on a 64-byte boundary, the shape, dtype and values."""

import numpy as np
import pytest

from dreamprint_gui.core.kernels.aligned import zeros_line_aligned


@pytest.mark.parametrize("shape, dtype", [(1, np.float64), (100_000, np.float64),
                                          ((7, 5, 3, 16), np.float32), (300_000, np.float32)])
def test_zeros_start_on_a_cache_line(shape, dtype):
    for _ in range(5):
        a = zeros_line_aligned(shape, dtype)
        assert a.ctypes.data % 64 == 0
        assert a.shape == np.empty(shape).shape and a.dtype == dtype
        assert a.flags.c_contiguous and not a.any()
