"""The source's emission-absorption render (proof/source_render.py): a solid's silhouette."""

import numpy as np

from dreamprint_gui.io.volumes.base import PrintGrid
from dreamprint_gui.job.content import SOLID_SIGMA, SolidSource
from dreamprint_gui.proof.cameras import View
from dreamprint_gui.proof.source_render import SourceField, render_source, sample_source


def _block(nearest):
    # 2 x 2 x 2 solid cells of 1 mm at the centre of an 8 mm cube of cells
    sigma = np.zeros((8, 8, 8), np.float32)
    sigma[3:5, 3:5, 3:5] = SOLID_SIGMA
    return SourceField(sigma, np.full((8, 8, 8, 3), 0.5, np.float32),
                       np.array([-4.0, -4.0, -4.0]), np.ones(3), nearest)


def test_a_solid_covers_exactly_its_cells():
    # seen face-on, the 2 x 2 mm block covers 4 of the frame's 64 mm^2, nothing more
    view = View(0.0, 0.0, 4.0, 20.0)
    _, alpha = render_source(_block(True), view, 64)
    assert abs(alpha.mean() - 4 / 64) < 1e-3
    assert alpha.max() > 0.999
    # trilinear, the solid density stays opaque down to a small weight: the silhouette grows
    # by up to half a cell on each side (what nearest-cell lookup removes)
    _, alpha_tri = render_source(_block(False), view, 64)
    assert alpha_tri.mean() > 1.5 * 4 / 64


class _Ball:
    name = "ball"
    format = "test"
    bounds = ((-4.0, -4.0, -4.0), (4.0, 4.0, 4.0))
    colour_encoding = "srgb"

    def sample_slab(self, grid, z0, z1, *, density_scale=1.0, out=None):
        nx, ny, _ = grid.shape_xyz
        c = [grid.origin[a] + (np.arange(n) + 0.5) * grid.voxel_mm[a] / grid.mm_per_unit
             for a, n in enumerate((nx, ny, z1))]
        z, y, x = np.meshgrid(c[2][z0:z1], c[1], c[0], indexing="ij")
        dens = np.where(x * x + y * y + z * z < 9.0, 1.0, 0.0).astype(np.float32)
        return np.full(dens.shape + (3,), 0.5, np.float32), dens


def test_a_solid_source_is_sampled_for_nearest_cell_lookup():
    grid = PrintGrid((8, 8, 8), (1.0, 1.0, 1.0), (-4.0, -4.0, -4.0), 1.0)
    lo = np.array([-4.0, -4.0, -4.0])
    fog = sample_source(_Ball(), grid, (1, 1, 1), 1.0, (8, 8, 8), lo)
    solid = sample_source(SolidSource(_Ball(), None, 0.5), grid, (1, 1, 1), 1.0, (8, 8, 8), lo)
    assert not fog.nearest and solid.nearest
    assert set(np.unique(solid.sigma)) == {0.0, SOLID_SIGMA}
