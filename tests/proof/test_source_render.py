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


def _edge_field(nearest, cells=43):
    # a solid slab whose edge crosses pixel column 5 at 3/8 of its width (cells of 1/80 mm,
    # the frame 1 mm wide at 10 px: 8 cells a pixel; 43 occupied cells in y)
    sigma = np.zeros((20, 80, 10), np.float32)
    sigma[:, :cells, :] = SOLID_SIGMA
    return SourceField(sigma, np.full((20, 80, 10, 3), 0.5, np.float32),
                       np.array([-0.0625, -0.5, -0.125]), np.full(3, 0.0125), nearest)


def test_a_solid_edge_inside_a_pixel_is_covered_by_its_area():
    """Looking along -x, image columns run along +y: the edge at y = 0.0375 mm covers 3/8 of
    column 5. 2 x 2 fixed sub-pixels read 1/2; the refined pixel reads 3/8 (the area Mitsuba's
    box filter integrates), in the source's coverage and in the print's direct transmittance
    alike."""
    from dreamprint_gui.proof.source_render import REFINE_SUB, edge_refine, optical_depth

    view = View(0.0, 0.0, 0.5, 5.0)
    field = _edge_field(True)
    _, alpha = render_source(field, view, 10)
    np.testing.assert_allclose(alpha[4:6, 5], 3 / 8, atol=1e-6)
    np.testing.assert_allclose(alpha[4:6, 4], 1.0, atol=1e-6)
    np.testing.assert_allclose(alpha[4:6, 6], 0.0, atol=1e-6)
    assert edge_refine(field) == REFINE_SUB and edge_refine(_edge_field(False)) == 0
    coef = np.repeat(field.sigma[..., None], 2, axis=-1)
    T = optical_depth(coef, field.lo_mm, field.cell_mm, view, 10, sub=2,
                      refine=edge_refine(field))
    np.testing.assert_allclose(T[4:6, 5], 5 / 8, atol=1e-6)
    T2 = optical_depth(coef, field.lo_mm, field.cell_mm, view, 10, sub=2)
    np.testing.assert_allclose(T2[4:6, 5], 1 / 2, atol=1e-6)   # unrefined: the 2 x 2 reading


def test_an_edge_the_coarse_sub_pixels_miss_is_refined_from_its_neighbour():
    """An edge at 7/8 of column 5 lies beyond both 2 x 2 sub-pixels (at 1/4 and 3/4), which read
    it fully covered; its neighbour column 6 sees the edge, so column 5 is refined too: 7/8."""
    view = View(0.0, 0.0, 0.5, 5.0)
    _, alpha = render_source(_edge_field(True, 47), view, 10)
    np.testing.assert_allclose(alpha[4:6, 5], 7 / 8, atol=1e-6)


def test_pixel_rays_are_the_rays_of_those_pixels():
    """A pixel's refined sub-pixels are placed as View.rays places the whole film's."""
    view = View(37.0, 21.0, 3.0, 30.0)
    full, _ = view.rays(6, 4)
    some = view.pixel_rays(6, np.array([0, 2, 5]), np.array([5, 1, 3]), 4)
    for n, (r, c) in enumerate(((0, 5), (2, 1), (5, 3))):
        block = full[4 * r:4 * r + 4, 4 * c:4 * c + 4].reshape(16, 3)
        np.testing.assert_allclose(some[n], block, atol=1e-12)
