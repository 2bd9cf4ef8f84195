"""Orientation (--up, --rotate) and --fit: a bright corner voxel lands where the closed form
puts it for every up axis; the knight at 20 mm (occupied) is 20 mm tall; splats stand up."""

import math

import numpy as np
import pytest

from dreamprint_gui.cli import main
from dreamprint_gui.core.errors import DreamPrintError
from dreamprint_gui.io.volumes.base import grid_for_source, voxel_centres
from dreamprint_gui.io.volumes.orient import (
    UP_AXES,
    choose_orientation,
    occupied_bounds,
    orient_source,
    orientation_matrix,
)


class Corner:
    """Box x 0..4, y 0..3, z 0..2 (source units) with density 1 only in the unit cell at its
    min corner: asymmetric along every axis."""

    name = "corner"
    format = "test"
    colour_encoding = "srgb"
    bounds = ((0.0, 0.0, 0.0), (4.0, 3.0, 2.0))

    def sample_slab(self, grid, z0, z1, *, density_scale=1.0, out=None):
        z, y, x = np.meshgrid(voxel_centres(grid, 2, z0, z1), voxel_centres(grid, 1),
                              voxel_centres(grid, 0), indexing="ij")
        sig = ((x > 0) & (x < 1) & (y > 0) & (y < 1) & (z > 0) & (z < 1)).astype(np.float32)
        rgb = np.stack([x, y, z], -1).astype(np.float32) / 4  # colour = source position
        return rgb, sig


# Print grid shape (x, y, z) and the bright voxel's (i, j, k), worked out by hand: up = -y puts
# the source's min-y cell at the top (k = 2 of 3), up = x its min-x cell at the bottom, ...
EXPECTED = {
    "z": ((4, 3, 2), (0, 0, 0)),
    "-z": ((4, 3, 2), (0, 2, 1)),
    "y": ((4, 2, 3), (0, 1, 0)),
    "-y": ((4, 2, 3), (0, 0, 2)),
    "x": ((2, 3, 4), (1, 0, 0)),
    "-x": ((2, 3, 4), (0, 0, 3)),
}


@pytest.mark.parametrize("up", UP_AXES)
def test_every_up_axis_maps_the_corner_voxel(up):
    o = choose_orientation(Corner(), up, 0)
    assert round(np.linalg.det(o.matrix)) == 1  # a rotation: never mirrored
    src = orient_source(Corner(), o)
    grid = grid_for_source(src, (1.0, 1.0, 1.0), height_mm=src.bounds[1][2] - src.bounds[0][2])
    shape, where = EXPECTED[up]
    assert tuple(grid.shape_xyz) == shape
    rgb, sig = src.sample_slab(grid, 0, shape[2])
    k, j, i = np.argwhere(sig > 0)[0]
    assert (i, j, k) == where and int(sig.sum()) == 1
    # colour travels with the voxel: the bright voxel's colour is its source position / 4
    assert np.allclose(rgb[k, j, i], 0.5 / 4)
    # a slab at a time gives the same arrays
    parts = [src.sample_slab(grid, z, z + 1)[1] for z in range(shape[2])]
    assert np.array_equal(np.concatenate(parts), sig)


def test_rotate_quarter_turn_and_refusals():
    src = orient_source(Corner(), choose_orientation(Corner(), "z", 90))
    grid = grid_for_source(src, (1.0, 1.0, 1.0), height_mm=2.0)
    assert tuple(grid.shape_xyz) == (3, 4, 2)  # x and y swap
    _, sig = src.sample_slab(grid, 0, 2)
    k, j, i = np.argwhere(sig > 0)[0]
    assert (i, j, k) == (2, 0, 0)  # (x, y) -> (-y, x): min-y goes to max x
    assert np.array_equal(orientation_matrix("z", 360), np.eye(3, dtype=int))
    with pytest.raises(DreamPrintError, match="multiple of 90"):
        choose_orientation(Corner(), "z", 45)
    with pytest.raises(DreamPrintError, match="--up"):
        choose_orientation(Corner(), "w", 0)


def test_knight_fit_occupied_is_the_height_asked(shared_data, capsys):
    """The knight fills x 0..18, y 7..15, z 0..15 of its 20 x 21 x 20 box (counted from
    the file's voxels below): at --height-mm 20 its occupied height is 20 mm."""
    from dreamprint_gui.io.volumes import open_source
    from dreamprint_gui.job.plan import ConvertSettings, prepare_job

    path = shared_data / "voxels" / "magicavoxel_chr_knight.vox"
    src = open_source(str(path))
    filled = np.argwhere(src.index > 0)  # (z, y, x)
    lo = filled.min(0)[::-1] + np.asarray(src.bounds[0])
    hi = filled.max(0)[::-1] + 1 + np.asarray(src.bounds[0])
    assert occupied_bounds(src) == (tuple(lo), tuple(hi))
    ctx = prepare_job(ConvertSettings(source=str(path), height_mm=20.0, table_size=17,
                                      printer="voxelprint-27um"))
    nz = ctx.grid.shape_xyz[2]
    assert nz == math.ceil(20.0 / 0.027 - 1e-9) and abs(nz * 0.027 - 20.0) < 0.027
    mpu = 20.0 / (hi[2] - lo[2])
    assert ctx.grid.mm_per_unit == pytest.approx(mpu)
    box = prepare_job(ConvertSettings(source=str(path), height_mm=20.0, table_size=17,
                                      printer="voxelprint-27um", fit="box"))
    assert box.grid.mm_per_unit == pytest.approx(20.0 / 20.0)  # the declared box: 20 tall
    assert main(["inspect", str(path), "--height-mm", "20"]) == 0
    out = capsys.readouterr().out
    assert "the print is" in out and "x 20.00 mm (x, y, z)" in out


def test_splats_stand_up_automatically_and_say_so(shared_data, capsys):
    """An INRIA 3DGS PLY is y-down (COLMAP): auto picks up = -y, its print height is the
    source's y extent, and inspect and the manifest say so."""
    from dreamprint_gui.io.volumes import open_source

    path = shared_data / "splats" / "inria3dgs_iter7000_sh3_9080.ply"
    src = open_source(str(path))
    o = choose_orientation(src, None, 0)
    assert (o.up, o.auto) == ("-y", True) and "y down" in o.reason
    turned = orient_source(src, o)
    (x0, y0, z0), (x1, y1, z1) = src.bounds
    assert turned.bounds[0][2] == pytest.approx(-y1) and turned.bounds[1][2] == pytest.approx(-y0)
    # the turned cloud samples like the generic wrapper of the same orientation
    from dreamprint_gui.io.volumes.orient import OrientedSource

    wrap = OrientedSource(src, o)
    grid = grid_for_source(turned, (0.5, 0.5, 0.5), height_mm=8.0)
    a = turned.sample_slab(grid, 5, 9)[1]
    b = wrap.sample_slab(grid, 5, 9)[1]
    assert a.max() > 0 and np.allclose(a, b, rtol=1e-4, atol=1e-6 * float(a.max()))
    assert main(["inspect", str(path), "--height-mm", "20"]) == 0
    out = capsys.readouterr().out
    assert "up = source -y (a guess: " in out and "--up changes it" in out
