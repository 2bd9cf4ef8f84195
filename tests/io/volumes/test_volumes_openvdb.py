"""OpenVDB through the in-process reader: sample file, generated variants, closed forms, errors."""

import json

import numpy as np
import pytest

from dreamprint_gui.cli import main
from dreamprint_gui.core.errors import DreamPrintError
from dreamprint_gui.io.volumes import grid_for_source, open_source
from dreamprint_gui.io.volumes.base import linear_to_srgb, voxel_centres


def test_sample_file_grids_and_counts(shared_data):
    f = shared_data / "volumes" / "blender_mantaflow_fluid_data_0190.vdb"
    info = open_source(f).info()
    grids = {g["name"]: g for g in info["grids"]}
    assert set(grids) == {"density", "flame", "shadow", "temperature", "velocity"}
    d = grids["density"]
    assert d["class"] == "fog volume" and d["active_voxels"] == 14112
    assert d["shape"] == [21, 21, 32] and d["dtype"].startswith("float")
    assert d["max"] == pytest.approx(0.97021484375)
    assert grids["velocity"]["dtype"].startswith("vec3s")


def _box_world(lo_i, hi_i, voxel=0.25, offset=(1.0, -2.0, 0.5)):
    o = np.asarray(offset)
    return tuple(o + (np.asarray(lo_i) - 0.5) * voxel), tuple(o + (np.asarray(hi_i) + 0.5) * voxel)


def test_half_box_with_vec3_colour_closed_form(vdbs):
    s = open_source(vdbs / "box_half_cd.vdb")
    lo, hi = _box_world((0, 0, 0), (15, 23, 9))
    np.testing.assert_allclose(s.bounds, (lo, hi))
    g = grid_for_source(s, (0.07, 0.03, 0.11), size_mm=(20, 20, 20))
    rgb, d = s.sample_slab(g, 0, g.shape_xyz[2], density_scale=3.0)
    # trilinear interpolation of a box: full value between the outer voxel centres
    vs = 0.25
    inner_lo = tuple(np.asarray(lo) + vs)
    inner_hi = tuple(np.asarray(hi) - vs)
    cz, cy, cx = (voxel_centres(g, a) for a in (2, 1, 0))
    inside = ((cz >= inner_lo[2]) & (cz <= inner_hi[2]))[:, None, None] \
        & ((cy >= inner_lo[1]) & (cy <= inner_hi[1]))[None, :, None] \
        & ((cx >= inner_lo[0]) & (cx <= inner_hi[0]))[None, None, :]
    np.testing.assert_allclose(d[inside], 0.5 * 3.0 / g.mm_per_unit, rtol=1e-6)
    outside = ((cz < lo[2]) | (cz > hi[2]))[:, None, None] | ((cy < lo[1]) | (cy > hi[1]))[
        None, :, None] | ((cx < lo[0]) | (cx > hi[0]))[None, None, :]
    assert not d[outside].any()
    want = linear_to_srgb(np.array([0.2, 0.5, 1.0], np.float32))
    np.testing.assert_allclose(rgb[inside], np.broadcast_to(want, rgb[inside].shape), atol=1e-6)
    assert s.colour_encoding == "linear"


def test_three_scalar_colour_grids(vdbs):
    s = open_source(vdbs / "box_rgb3.vdb", colour_encoding="srgb")
    g = grid_for_source(s, (0.5, 0.5, 0.5), height_mm=10)
    rgb, d = s.sample_slab(g, g.shape_xyz[2] // 2, g.shape_xyz[2] // 2 + 1)
    c = rgb[0, g.shape_xyz[1] // 2, g.shape_xyz[0] // 2]
    np.testing.assert_allclose(c, [0.1, 0.4, 0.9], atol=1e-6)


def test_linear_ramp_reproduced(vdbs):
    s = open_source(vdbs / "ramp.vdb")
    g = grid_for_source(s, (0.013, 0.05, 0.05), height_mm=4)
    _, d = s.sample_slab(g, 0, g.shape_xyz[2])
    cx = voxel_centres(g, 0)
    i = (cx - 1.0) / 0.25                         # index coordinate along i
    inside_x = (i >= 0) & (i <= 63)
    mid = d[d.shape[0] // 2, d.shape[1] // 2] * g.mm_per_unit
    np.testing.assert_allclose(mid[inside_x], 0.01 * i[inside_x], atol=2e-6)


def test_level_set_refused_or_solid(vdbs):
    with pytest.raises(DreamPrintError, match="a level set, not a fog volume"):
        open_source(vdbs / "levelset.vdb", density_grid="ls_sphere")
    s = open_source(vdbs / "levelset.vdb", level_set="solid", solid_density=5.0)
    assert s.info()["grids"][0]["class"] == "level set"
    g = grid_for_source(s, (0.25, 0.25, 0.25), height_mm=5.0)
    _, d = s.sample_slab(g, 0, g.shape_xyz[2])
    cz, cy, cx = np.meshgrid(*(voxel_centres(g, a) for a in (2, 1, 0)), indexing="ij")
    r = np.sqrt(cx ** 2 + cy ** 2 + cz ** 2)
    full = 5.0 / g.mm_per_unit
    np.testing.assert_allclose(d[r < 1.8], full, rtol=1e-6)      # deep inside (interior tiles)
    assert not d[r > 2.2].any()


def test_empty_grid_multi_grid_and_rotated(vdbs):
    with pytest.raises(DreamPrintError, match="'density' is empty"):
        open_source(vdbs / "empty.vdb")
    with pytest.raises(DreamPrintError, match="choose one of: ") as e:
        open_source(vdbs / "multi.vdb")
    assert "smoke" in str(e.value) and "heat" in str(e.value)
    s = open_source(vdbs / "multi.vdb", density_grid="heat")
    assert sorted(g["name"] for g in s.info()["grids"]) == ["heat", "smoke"]
    with pytest.raises(DreamPrintError, match="rotated"):
        open_source(vdbs / "rotated.vdb")


def test_far_apart_blocks_stay_sparse(vdbs):
    s = open_source(vdbs / "far.vdb")
    assert s.density.blocks.n_leaves == 2
    assert s.density.blocks.top.size < 2000            # 128^3-voxel nodes along one axis only
    g = grid_for_source(s, (1.0, 0.005, 0.005), height_mm=1.0)   # 1e9 voxels in the print
    assert g.n_voxels > 1e9
    _, d = s.sample_slab(g, 5, 6)                     # one layer: bounded by the slab
    assert d.shape == (1, g.shape_xyz[1], g.shape_xyz[0]) and d.max() > 0


def test_bad_vdb_files(vdbs, tmp_path):
    good = (vdbs / "box_rgb3.vdb").read_bytes()
    t = tmp_path / "trunc.vdb"
    t.write_bytes(good[: len(good) // 2])
    with pytest.raises(DreamPrintError):
        open_source(t)
    g = tmp_path / "garbage.vdb"
    g.write_bytes(b"\x20\x42\x44\x56" + bytes(range(256)) * 4)
    with pytest.raises(DreamPrintError):
        open_source(g)


def test_inspect_vdb_json(vdbs, capsys):
    assert main(["inspect", "--json", str(vdbs / "levelset.vdb")]) == 0
    (g,) = json.loads(capsys.readouterr().out)["grids"]
    assert g["name"] == "ls_sphere" and g["class"] == "level set" and g["active_voxels"] > 0


def test_level_set_shell_is_the_wall_of_the_solid(vdbs):
    """``level_set=shell``: the sphere's wall (r 2, 2 voxels of 0.1 thick): its volume is the
    closed form 4/3 pi (2^3 - 1.8^3); thicker than the narrow band (3 voxels) is refused."""
    with pytest.raises(DreamPrintError, match=r"level_set=solid\) or as a hollow shell"):
        open_source(vdbs / "levelset.vdb")
    s = open_source(vdbs / "levelset.vdb", level_set="shell", shell_voxels=2.0)
    g = grid_for_source(s, (0.05, 0.05, 0.05), height_mm=4.6)
    _, d = s.sample_slab(g, 0, g.shape_xyz[2])
    cell = g.mm_per_unit ** -3 * np.prod(g.voxel_mm)          # source units^3 per voxel
    volume = float(d.sum() * g.mm_per_unit) * cell              # solid_density 1
    want = 4.0 / 3.0 * np.pi * (2.0 ** 3 - 1.8 ** 3)
    assert abs(volume - want) / want < 0.02, (volume, want)
    cz, cy, cx = np.meshgrid(*(voxel_centres(g, a) for a in (2, 1, 0)), indexing="ij")
    r = np.sqrt(cx ** 2 + cy ** 2 + cz ** 2)
    assert not d[r < 1.7].any() and not d[r > 2.1].any()     # hollow inside, nothing outside
    with pytest.raises(DreamPrintError, match="shell_voxels at most 2"):
        open_source(vdbs / "levelset.vdb", level_set="shell", shell_voxels=2.5)
    with pytest.raises(DreamPrintError, match="level_set must be one of refuse, solid, shell"):
        open_source(vdbs / "levelset.vdb", level_set="hollow")
