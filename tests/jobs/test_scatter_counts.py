"""Labels scattered into a layer row and counted per label, against numpy."""

import numpy as np
import pytest

from dreamprint_gui.job.halftone import scatter_counts


@pytest.mark.parametrize("m,spread", [(0, 7), (1, 7), (1023, 7), (1024, 7), (70_000, 7),
                                      (131_071, 1)])
def test_scatter_counts_puts_and_counts_every_label(m, spread):
    """Every label 0-6, and one label 2 x 65535 + 1 times (a 16-bit tally would overflow)."""
    rng = np.random.default_rng(m)
    lab = rng.integers(0, spread, m).astype(np.uint8)
    lab[rng.random(m) < 0.5] = 6 if spread > 1 else 0
    n = m + 50
    idx = np.sort(rng.choice(n, m, replace=False)).astype(np.int64)
    k0 = 3
    idx_full = np.concatenate([np.full(k0, -1, np.int64), idx])
    row = np.full(n, 9, np.uint8)
    counts = np.arange(7, dtype=np.int64)  # added to, not overwritten
    scatter_counts(row, idx_full, k0, lab, m, counts)
    want = np.full(n, 9, np.uint8)
    want[idx] = lab
    np.testing.assert_array_equal(row, want)
    np.testing.assert_array_equal(counts, np.arange(7) + np.bincount(lab, minlength=7))
