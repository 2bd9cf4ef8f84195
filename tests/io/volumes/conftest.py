"""Helpers shared by the volume tests."""

import numpy as np
import pytest


def _box_expectation(grid, lo, hi, value):
    """Closed form for a box of constant ``value`` over [lo, hi] (source units): value at the
    printer voxel centres inside the box, 0 outside, as a (z, y, x) array."""
    from dreamprint_gui.io.volumes.base import voxel_centres

    inside = [(voxel_centres(grid, a) >= lo[a]) & (voxel_centres(grid, a) <= hi[a])
              for a in range(3)]
    m = inside[2][:, None, None] & inside[1][None, :, None] & inside[0][None, None, :]
    return np.where(m, np.float32(value), np.float32(0))


@pytest.fixture
def box_expectation():
    return _box_expectation
