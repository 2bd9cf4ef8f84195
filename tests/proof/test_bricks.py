"""The print's medium cut into bricks (proof.bricks): every inked cell in exactly one box, and
boxes where the cost model says they pay."""

import numpy as np
import pytest

from dreamprint_gui.proof.bricks import COLLISION_WEIGHT, _box_cost, partition, uniform


def _cover(boxes, shape):
    cov = np.zeros(shape, np.int32)
    for z0, z1, y0, y1, x0, x1 in boxes:
        cov[z0:z1, y0:y1, x0:x1] += 1
    return cov


def _cost(boxes, m, cell):
    return sum(_box_cost((z1 - z0, y1 - y0, x1 - x0), float(m[z0:z1, y0:y1, x0:x1].max()),
                         np.asarray(cell)) for z0, z1, y0, y1, x0, x1 in boxes)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_partition_covers_every_inked_cell_once(seed):
    rng = np.random.default_rng(seed)
    m = np.zeros((30, 20, 25, 3), np.float32)
    m[2:28, 1:19, 3:22] = 0.01                                      # Clear
    m[10:20, 5:12, 8:15] = rng.uniform(1, 5, (10, 7, 7, 3))         # an ink blob
    m[rng.random(m.shape[:3]) < 0.01] = 0                           # holes
    boxes = partition(m, (0.3, 0.3, 0.32))
    cov = _cover(boxes, m.shape[:3])
    assert cov.max() == 1
    assert (cov[m.max(-1) > 0] == 1).all()
    assert boxes == partition(m, (0.3, 0.3, 0.32))                  # deterministic


def test_partition_of_a_uniform_medium_is_its_occupied_box():
    m = np.zeros((20, 20, 20), np.float32)
    m[3:17, 2:18, 5:9] = 2.0
    assert partition(m, (0.5, 0.5, 0.5)) == [(3, 17, 2, 18, 5, 9)]
    assert partition(np.zeros((4, 4, 4)), (1, 1, 1)) == []


def test_partition_separates_dense_ink_from_thin_clear_and_lowers_the_cost():
    """A dense blob in a large thin block: the blob gets boxes of its own (one majorant for the
    whole block would step through the Clear at the ink's rate), and the model's cost is below
    one box and below uniform cubes of 8 and 16 cells."""
    cell = (0.3, 0.3, 0.3)
    m = np.full((64, 64, 64), 0.01, np.float32)
    m[20:30, 30:40, 25:35] = 20.0
    boxes = partition(m, cell)
    assert 1 < len(boxes) < 64
    dense = [b for b in boxes if m[b[0]:b[1], b[2]:b[3], b[4]:b[5]].max() == 20.0]
    vol = sum((b[1] - b[0]) * (b[3] - b[2]) * (b[5] - b[4]) for b in dense)
    assert vol < 4 * 1000                     # the blob's boxes are not much more than the blob
    one = _cost([(0, 64, 0, 64, 0, 64)], m, cell)
    c = _cost(boxes, m, cell)
    assert c < 0.5 * one
    assert c < _cost(uniform(m, 8), m, cell)
    assert c < _cost(uniform(m, 16), m, cell)
    # the cost: crossings (surface) plus collision steps (majorant x volume)
    assert _box_cost((1, 1, 1), 2.0, np.ones(3)) == pytest.approx(6.0 + COLLISION_WEIGHT * 2.0)


def test_optically_deep_counts_mean_free_paths_across_the_smallest_extent():
    from dreamprint_gui.proof.bricks import optically_deep

    m = np.zeros((10, 20, 40, 3), np.float32)
    m[...] = (2.0, 1.0, 8.0)
    box = (0, 10, 0, 20, 0, 40)
    # least extinct channel 1.0 /mm x smallest extent (z: 10 cells of 0.5 mm) = 5 mfp
    assert optically_deep(m, box, (0.5, 0.5, 0.5), tau=4.9)
    assert not optically_deep(m, box, (0.5, 0.5, 0.5), tau=5.1)
    assert not optically_deep(m, (0, 2, 0, 20, 0, 40), (0.5, 0.5, 0.5))     # a thin sheet
    assert not optically_deep(np.full((8, 8, 8, 3), 0.01, np.float32), (0, 8, 0, 8, 0, 8),
                              (1.0, 1.0, 1.0))                               # Clear
