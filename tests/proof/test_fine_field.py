"""The two-scale correction (proof/fine_field.py): the coarse field at the fine cells is the
job's own interpolation, the fine detail is what the coarse field cannot hold, shrunk where
few pixels see a cell, and bounded."""

import math

import numpy as np
import pytest

from dreamprint_gui.job.correction import apply_correction
from dreamprint_gui.proof.fine_field import FINE_RANGE, compose, fine_update, upsample


def test_upsampled_coarse_field_is_what_the_job_applies_at_those_points():
    """A voxel grid with one voxel per fine cell: the job's density factor at each voxel
    (job/correction.apply_correction, the numba kernel) equals up(g) there."""
    rng = np.random.default_rng(0)
    coarse = np.exp(rng.normal(0.0, 0.3, (3, 4, 5, 4)))
    fshape = (7, 9, 11)
    up = upsample(coarse, fshape)
    assert up.shape == fshape + (4,)
    dens = np.full(fshape, 1.0, np.float32)
    rgb = np.full(fshape + (3,), 0.5, np.float32)
    apply_correction(coarse.astype(np.float32), fshape[::-1], 0, rgb, dens)
    np.testing.assert_allclose(dens, up[..., 3], rtol=1e-5)


def test_a_linear_coarse_field_is_reproduced_inside():
    """Trilinear interpolation is exact for a field linear in the cell-centre coordinates
    (away from the clamped outer half cells)."""
    g, n = 4, 16
    x = (np.arange(g) + 0.5) / g
    coarse = np.broadcast_to((2.0 * x)[None, None, :, None], (g, g, g, 1))
    up = upsample(coarse, (n, n, n))
    xf = (np.arange(n) + 0.5) / n
    inner = (xf >= x[0]) & (xf <= x[-1])
    np.testing.assert_allclose(up[0, 0, inner, 0], 2.0 * xf[inner], atol=1e-12)


def test_fine_detail_is_the_residual_of_the_coarse_update_shrunk_by_its_weight():
    shape = (6, 6, 6)
    coarse_upd = np.full((3, 3, 3, 1), 0.2)
    # data agreeing with the coarse mean everywhere: no detail
    den = np.full(shape, 4.0)
    num = 0.2 * den[..., None]
    np.testing.assert_allclose(fine_update(num, den, coarse_upd), 0.0, atol=1e-12)
    # one well-seen fine region that asks for more: detail there, of the right sign, below
    # the residual (shrinkage), and less where the same residual is seen by fewer pixels
    num2 = num.copy()
    num2[2:4, 2:4, 2:4, 0] = 0.6 * den[2:4, 2:4, 2:4]
    d_many = fine_update(num2, den, coarse_upd)
    d_few = fine_update(num2 / 20, den / 20, coarse_upd)
    assert 0.0 < d_many[2, 2, 2, 0] < 0.4
    assert 0.0 < d_few[2, 2, 2, 0] < d_many[2, 2, 2, 0]
    # no weight at all: no detail (the coarse field alone)
    np.testing.assert_array_equal(fine_update(num * 0, den * 0, coarse_upd), 0.0)


def test_compose_bounds_the_total_and_without_fine_is_the_coarse_field():
    coarse = np.full((2, 2, 2, 4), math.log(6.0))
    np.testing.assert_allclose(compose(coarse, None), 6.0)
    fine = np.full((4, 4, 4, 4), math.log(FINE_RANGE))
    g = compose(coarse, fine)
    assert g.shape == (4, 4, 4, 4)
    np.testing.assert_allclose(g, 8.0)        # 6 x 2 clipped to the coarse field's 8
    np.testing.assert_allclose(compose(coarse * 0, fine * 0), 1.0)


def test_the_optimiser_writes_a_fine_field_or_the_coarse_one(tmp_path):
    """fine_cells above field_cells: the correction is the composed fine field (no finer than
    the proof's cells); 0: the coarse field as before."""
    from dreamprint_gui.proof.compensate import CompensateSettings, optimise

    def run(**kw):
        kw = {"iterations": 1, **kw}
        gen = optimise(CompensateSettings(source="demo", height_mm=3.0, views=1,
                                          resolution=16, spp=2, max_cells=12, field_cells=4,
                                          table_size=17, **kw))
        try:
            while True:
                next(gen)
        except StopIteration as stop:
            return stop.value

    fine = run(fine_cells=64)
    assert max(fine["correction"].gain.shape[:3]) == 12
    assert fine["report"]["fine_cells_xyz"] is not None
    coarse = run(fine_cells=0, iterations=0)
    assert max(coarse["correction"].gain.shape[:3]) == 4
    assert coarse["report"]["fine_cells_xyz"] is None
    with pytest.raises(Exception, match="--fine-cells"):
        run(fine_cells=2)


def test_the_command_line_default_is_the_optimisers():
    from dataclasses import fields

    from dreamprint_gui.cli.proof import compensate
    from dreamprint_gui.proof.compensate import FINE_CELLS, CompensateSettings

    opts = {p.name: p for p in compensate.params}
    assert opts["fine_cells"].default == FINE_CELLS
    defaults = {f.name: f.default for f in fields(CompensateSettings)}
    for name in ("views", "iterations", "resolution", "spp", "max_cells", "field_cells",
                 "fine_cells", "occlusion"):
        assert opts[name].default == defaults[name], name


def test_occlusion_prior_against_the_open_share_of_flat_faces_edges_and_steps():
    """The object's share of the neighbourhood at the surface: 1/2 on a flat face (no
    factor), 1/4 on a convex edge (the print is lighter there: factor 1 / 1.5), 3/4 in a
    concave step (darker: factor 2); read half a cell under the surface (relative to a flat
    face read there), so within a few %. Every other cell takes its nearest surface cell's
    factor."""
    from dreamprint_gui.proof.fine_field import occlusion_prior

    n = 60
    cell = np.array([0.05, 0.05, 0.05])
    box = cell * n

    def factor(occupied, at):
        sigma = np.where(occupied, 100.0, 0.0)
        g = np.exp(occlusion_prior(sigma, cell, box, (n, n, n), 1.0, 0.5))
        assert np.all(g[..., 3] == 1.0)
        return g[at][0]

    z, y, x = np.meshgrid(*(np.arange(n),) * 3, indexing="ij")
    flat = z < 30
    assert factor(flat, (29, 30, 30)) == pytest.approx(1.0, abs=0.01)
    # empty cells carry their nearest surface cell's factor (no dilution at the surface)
    assert factor(flat, (40, 30, 30)) == pytest.approx(factor(flat, (29, 30, 30)), abs=1e-9)
    edge = (z < 30) & (x < 30)
    # closed forms at the cells' centres, half a cell (0.025 mm: 0.05 of the 0.5 mm radius)
    # from each face: a half-space reaching past the centre by that holds P = Phi(0.05) of it
    p = 0.5 * (1 + math.erf(0.05 / math.sqrt(2)))
    assert factor(edge, (29, 30, 29)) == pytest.approx((1 - p * p) ** -1 * (1 - p), rel=0.03)
    step = (z < 30) | (x < 30)
    assert factor(step, (29, 30, 30)) == pytest.approx((1 - p) / (p * (1 - p)), rel=0.03)
    # inside: the nearest surface cell's (the flat top, 5 cells above)
    assert factor(step, (24, 30, 45)) == pytest.approx(factor(step, (29, 30, 45)), abs=1e-9)
    assert factor(step, (24, 30, 45)) == pytest.approx(1.0, abs=0.06)
