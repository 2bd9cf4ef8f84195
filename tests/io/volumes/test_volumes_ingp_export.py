"""InstantNGP's volume exports (RGBA PNG slices, raw RGBA volumes), written here as
instant-ngp's ``save_rgba_grid_to_png_sequence`` / ``save_rgba_grid_to_raw_file`` lay them out."""

import json
import math

import numpy as np
import pytest
from PIL import Image

from dreamprint_gui.cli import main
from dreamprint_gui.core.errors import DreamPrintError
from dreamprint_gui.io.volumes import grid_for_source, open_source


def write_png_sequence(folder, sigma, rgb, depth=0.01):
    """sigma (nz, ny, nx) per instant-ngp unit, rgb (nz, ny, nx, 3): alpha 1 - exp(-sigma
    depth), RGB premultiplied, row 0 = largest y, files {z:04d}_{w}x{h}.png."""
    folder.mkdir()
    nz, ny, nx = sigma.shape
    alpha = 1 - np.exp(-sigma * depth)
    for z in range(nz):
        px = np.empty((ny, nx, 4), np.uint8)
        for y in range(ny):
            src_y = ny - 1 - y
            px[y, :, :3] = np.clip(rgb[z, src_y] * alpha[z, src_y, :, None] * 255, 0, 255)
            px[y, :, 3] = np.clip(alpha[z, src_y] * 255, 0, 255)
        Image.fromarray(px, "RGBA").save(folder / f"{z:04d}_{nx}x{ny}.png")
    return folder


def test_png_sequence_density_from_alpha(tmp_path):
    nz, ny, nx = 4, 3, 5
    sigma = np.zeros((nz, ny, nx))
    sigma[1:3, 1, 1:4] = 60.0                     # alpha = 1 - exp(-0.6) = 0.451
    rgb = np.zeros((nz, ny, nx, 3))
    rgb[..., 0] = 0.8
    rgb[..., 2] = 0.2
    folder = write_png_sequence(tmp_path / "rgba_slices", sigma, rgb)
    for target in (folder, folder / f"0002_{nx}x{ny}.png"):
        s = open_source(target)
        assert s.format == "InstantNGP RGBA PNG slices"
        vs = 1 / 5
        np.testing.assert_allclose(s.bounds[1], [nx * vs, ny * vs, nz * vs])
        g = grid_for_source(s, (1, 1, 1), size_mm=(nx, ny, nz))   # one print voxel per voxel
        assert g.shape_xyz == (nx, ny, nz)
        rgbo, d = s.sample_slab(g, 0, nz)
        # closed form from the 8-bit alpha: sigma = -ln(1 - A/255) / 0.01 per unit
        a8 = round((1 - math.exp(-0.6)) * 255) / 255
        want = np.where(sigma > 0, -math.log(1 - a8) / 0.01 / g.mm_per_unit, 0.0)
        np.testing.assert_allclose(d, want, rtol=1e-5)
        np.testing.assert_allclose(rgbo[sigma > 0], np.broadcast_to([0.8, 0, 0.2], (6, 3)),
                                   atol=1 / 255 / a8)


def test_png_sequence_errors(tmp_path, capsys):
    f = tmp_path / "s"
    write_png_sequence(f, np.ones((3, 2, 2)), np.ones((3, 2, 2, 3)))
    (f / "0001_2x2.png").unlink()
    with pytest.raises(DreamPrintError, match="gaps"):
        open_source(f)
    (f / "0001_2x2.png").write_bytes(b"not a png")
    assert main(["inspect", str(f)]) == 2
    err = capsys.readouterr().err.strip()
    assert "cannot read PNG slice" in err and "\n" not in err


def write_raw(folder, sigma, rgb, cascade=0):
    """Raw RGBA float32 as save_rgba_grid_to_raw_file: x fastest, y from the top, then z."""
    folder.mkdir(exist_ok=True)
    nz, ny, nx = sigma.shape
    out = np.empty((nz, ny, nx, 4), np.float32)
    out[..., :3] = rgb[:, ::-1]
    out[..., 3] = sigma[:, ::-1]
    p = folder / f"{nx}x{ny}x{nz}_{cascade}.bin"
    out.tofile(p)
    return p


def test_raw_volume_placed_in_its_cascade(tmp_path):
    nz, ny, nx = 4, 8, 2
    rng = np.random.default_rng(0)
    sigma = rng.uniform(0, 5, (nz, ny, nx))
    rgb = rng.uniform(0, 1, (nz, ny, nx, 3))
    folder = tmp_path / "volume_raw"
    write_raw(folder, sigma, rgb, 0)
    p1 = write_raw(folder, sigma, rgb, 1)
    s0 = open_source(folder)                       # a folder opens cascade 0
    assert s0.bounds == ((0.0, 0.0, 0.0), (1.0, 1.0, 1.0))
    assert s0.info()["grids"][0]["other_cascades"] == [p1.name]
    s1 = open_source(p1)
    assert s1.bounds == ((-0.5, -0.5, -0.5), (1.5, 1.5, 1.5))
    # sample exactly at voxel centres of cascade 0: values come back as written
    g = grid_for_source(s0, (1 / nx, 1 / ny, 1 / nz), size_mm=(1, 1, 1))
    assert g.shape_xyz == (nx, ny, nz)
    rgbo, d = s0.sample_slab(g, 0, nz, density_scale=3.0)
    np.testing.assert_allclose(d, sigma * 3.0 / g.mm_per_unit, rtol=1e-5)
    np.testing.assert_allclose(rgbo, rgb, atol=1e-5)


def test_raw_volume_size_mismatch(tmp_path, capsys):
    p = tmp_path / "4x4x4_0.bin"
    np.zeros(10, np.float32).tofile(p)
    assert main(["inspect", str(p)]) == 2
    err = capsys.readouterr().err.strip()
    assert "needs 1,024 bytes, the file has 40" in err and "\n" not in err
    q = tmp_path / "density.bin"                   # any other .bin is not claimed
    np.zeros(10, np.float32).tofile(q)
    with pytest.raises(DreamPrintError, match="not a volume format"):
        open_source(q)


def test_inspect_json_png(tmp_path, capsys):
    f = write_png_sequence(tmp_path / "x_rgba_slices", np.ones((2, 3, 4)), np.ones((2, 3, 4, 3)))
    assert main(["inspect", "--json", str(f)]) == 0
    info = json.loads(capsys.readouterr().out)
    assert info["format"] == "InstantNGP RGBA PNG slices"
    assert info["grids"][0]["shape"] == [4, 3, 2]
