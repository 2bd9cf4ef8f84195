"""Radiance grids (.npz, EXR stacks) and MagicaVoxel models."""

import struct

import numpy as np
import pytest

from dreamprint_gui.cli import main
from dreamprint_gui.core.errors import DreamPrintError
from dreamprint_gui.io.volumes import grid_for_source, open_source
from dreamprint_gui.io.volumes.base import linear_to_srgb, voxel_centres
from dreamprint_gui.io.volumes.grids.magicavoxel import DEFAULT_PALETTE


def test_npz_constant_box_anisotropic(tmp_path, box_expectation):
    sigma = np.full((3, 4, 5), 7.0, np.float32)
    rgb = np.zeros((3, 4, 5, 3), np.float32)
    rgb[..., 1] = 0.25
    bounds = np.array([[-1.0, 0.0, 2.0], [1.5, 2.0, 3.5]])
    p = tmp_path / "f.npz"
    np.savez_compressed(p, sigma=sigma, rgb=rgb, bounds=bounds)
    s = open_source(p)
    assert s.bounds == (tuple(bounds[0]), tuple(bounds[1]))
    g = grid_for_source(s, (0.09, 0.05, 0.13), size_mm=(10, 10, 10))
    rgb_o, d = s.sample_slab(g, 0, g.shape_xyz[2], density_scale=0.5)
    want = box_expectation(g, bounds[0], bounds[1], 7.0 * 0.5 / g.mm_per_unit)
    np.testing.assert_allclose(d, want, rtol=1e-6)
    inside = want > 0
    np.testing.assert_allclose(rgb_o[inside], np.broadcast_to([0, 0.25, 0], rgb_o[inside].shape),
                               atol=1e-6)
    (info,) = s.info()["grids"]
    assert info["shape"] == [5, 4, 3] and info["active_voxels"] == 60


def test_npz_colour_is_density_weighted(tmp_path):
    # two cells: dense red beside empty blue: halfway between, colour stays red
    sigma = np.array([[[4.0, 0.0]]], np.float32)
    rgb = np.array([[[[1, 0, 0], [0, 0, 1]]]], np.float32)
    p = tmp_path / "w.npz"
    np.savez(p, sigma=sigma, rgb=rgb, bounds=np.array([[0, 0, 0], [2, 1, 1.0]]))
    s = open_source(p)
    g = grid_for_source(s, (0.25, 1, 1), size_mm=(2, 1, 1))
    rgb_o, d = s.sample_slab(g, 0, 1)
    x = voxel_centres(g, 0)
    mid = (x > 0.5) & (x < 1.5)
    np.testing.assert_allclose(rgb_o[0, 0, mid], np.broadcast_to([1, 0, 0], (mid.sum(), 3)),
                               atol=1e-6)
    np.testing.assert_allclose(d[0, 0, mid] * g.mm_per_unit, 4 * (1.5 - x[mid]), rtol=1e-5)


def test_npz_bad_files(tmp_path):
    p = tmp_path / "a.npz"
    np.savez(p, sigma=np.zeros((2, 2, 2)))
    with pytest.raises(DreamPrintError, match="bounds"):
        open_source(p)
    np.savez(p, sigma=np.zeros((2, 2, 2)), bounds=np.array([[0, 0, 0], [1, 1, 1.0]]),
             rgb=np.zeros((2, 2, 3)))
    with pytest.raises(DreamPrintError, match="'rgb' must be"):
        open_source(p)
    np.savez(p, sigma=np.zeros((20, 20, 20)), bounds=np.array([[0, 0, 0], [1, 1, 1.0]]))
    data = p.read_bytes()
    p.write_bytes(data[: len(data) // 2])
    with pytest.raises(DreamPrintError, match="damaged"):
        open_source(p)
    # a .npy header claiming an absurd shape is refused before allocating
    import io
    import zipfile

    buf = io.BytesIO()
    np.lib.format.write_array_header_1_0(buf, {"descr": "<f4", "fortran_order": False,
                                               "shape": (100000, 100000, 100000)})
    with zipfile.ZipFile(p, "w") as z:
        z.writestr("sigma.npy", buf.getvalue() + b"\0" * 64)
        z.writestr("bounds.npy", b"")
    with pytest.raises(DreamPrintError, match="claims"):
        open_source(p)


def _write_exr(path, density, rgb, channel="density"):
    import OpenEXR

    chans = {channel: density.astype(np.float32)}
    for c, n in enumerate("RGB"):
        chans[n] = rgb[..., c].astype(np.float32)
    OpenEXR.File({"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage},
                 chans).write(str(path))


def test_exr_stack(tmp_path):
    nz, ny, nx = 3, 4, 5
    dens = np.random.default_rng(3).random((nz, ny, nx)).astype(np.float32)
    rgb = np.zeros((ny, nx, 3), np.float32)
    rgb[..., 0] = 0.18
    for k in range(nz):      # names sort numerically: 2 < 10
        _write_exr(tmp_path / f"slice_{[2, 10, 11][k]}.exr", dens[k][::-1], rgb)
    s = open_source(tmp_path, voxel_size=0.5)
    assert s.bounds == ((0, 0, 0), (2.5, 2.0, 1.5))
    np.testing.assert_allclose(s.volume.data[..., 0], dens, rtol=1e-6)
    g = grid_for_source(s, (0.5, 0.5, 0.5), size_mm=(2.5, 2.0, 1.5))   # one printer voxel each
    rgb_o, d = s.sample_slab(g, 0, nz)
    np.testing.assert_allclose(d, dens, rtol=1e-5)
    np.testing.assert_allclose(rgb_o[..., 0], linear_to_srgb(np.float32(0.18)), atol=1e-5)
    # a single slice file opens its folder
    assert open_source(tmp_path / "slice_2.exr").bounds == ((0, 0, 0), (5, 4, 3))
    # a slice of another size is refused
    _write_exr(tmp_path / "slice_99.exr", np.zeros((2, 2)), np.zeros((2, 2, 3)))
    with pytest.raises(DreamPrintError, match="the first was"):
        open_source(tmp_path)


def test_exr_damaged(tmp_path):
    _write_exr(tmp_path / "a.exr", np.ones((8, 8)), np.ones((8, 8, 3)))
    data = (tmp_path / "a.exr").read_bytes()
    (tmp_path / "a.exr").write_bytes(data[: len(data) // 2])
    with pytest.raises(DreamPrintError):
        open_source(tmp_path / "a.exr")


def test_vox_sample_file(shared_data, capsys):
    f = shared_data / "voxels" / "magicavoxel_chr_knight.vox"
    s = open_source(f, solid_density=2.0)
    (g,) = s.info()["grids"]
    assert g["shape"] == [20, 21, 20] and g["class"] == "palette voxels"
    assert g["active_voxels"] == 398
    assert s.bounds == ((0, 0, 0), (20, 21, 20))
    assert main(["inspect", str(f)]) == 0
    assert "20 x 21 x 20" in capsys.readouterr().out


def _chunk(cid, content, children=b""):
    return cid + struct.pack("<ii", len(content), len(children)) + content + children


def _vox(size, voxels, palette=None, extra=b""):
    body = _chunk(b"SIZE", struct.pack("<iii", *size))
    body += _chunk(b"XYZI", struct.pack("<i", len(voxels)) + bytes(
        b for v in voxels for b in v))
    if palette is not None:
        body += _chunk(b"RGBA", palette.tobytes())
    return b"VOX " + struct.pack("<i", 150) + _chunk(b"MAIN", b"", body + extra)


def test_vox_nearest_voxels_exact_and_default_palette(tmp_path):
    p = tmp_path / "m.vox"
    p.write_bytes(_vox((3, 2, 4), [(0, 0, 0, 1), (2, 1, 3, 215), (1, 0, 2, 216)]))
    s = open_source(p, solid_density=3.0)
    g = grid_for_source(s, (0.25, 0.5, 0.125), size_mm=(3, 2, 4))    # 1 mm per voxel
    rgb, d = s.sample_slab(g, 0, g.shape_xyz[2])
    cz, cy, cx = (np.floor(voxel_centres(g, a)).astype(int) for a in (2, 1, 0))
    filled = {(0, 0, 0): 1, (2, 1, 3): 215, (1, 0, 2): 216}
    for (x, y, z), idx in filled.items():
        sel = (cz == z)[:, None, None] & (cy == y)[None, :, None] & (cx == x)[None, None, :]
        np.testing.assert_allclose(d[sel], 3.0 / g.mm_per_unit, rtol=1e-6)
        np.testing.assert_allclose(rgb[sel][0], DEFAULT_PALETTE[idx, :3] / 255, atol=1e-6)
    assert np.count_nonzero(d) == 3 * (4 * 2 * 8)
    # spec's default palette: 1 = white, 2 = (ff, ff, cc), 215 = (00, 00, 33), 216 = (ee, 0, 0)
    assert DEFAULT_PALETTE[1].tolist() == [255, 255, 255, 255]
    assert DEFAULT_PALETTE[2].tolist() == [255, 255, 204, 255]
    assert DEFAULT_PALETTE[215].tolist() == [0, 0, 0x33, 255]
    assert DEFAULT_PALETTE[216].tolist() == [0xEE, 0, 0, 255]
    assert DEFAULT_PALETTE[255].tolist() == [0x11, 0x11, 0x11, 255]


def test_vox_palette_chunk_maps_index_minus_one(tmp_path):
    pal = np.zeros((256, 4), np.uint8)
    pal[4] = (10, 20, 30, 255)                 # colour index 5
    p = tmp_path / "p.vox"
    p.write_bytes(_vox((1, 1, 1), [(0, 0, 0, 5)], pal))
    s = open_source(p)
    g = grid_for_source(s, (1, 1, 1), height_mm=1)
    rgb, d = s.sample_slab(g, 0, 1)
    np.testing.assert_allclose(rgb[0, 0, 0], np.array([10, 20, 30]) / 255, atol=1e-6)


def test_vox_bad_files(tmp_path):
    p = tmp_path / "b.vox"
    good = _vox((3, 3, 3), [(0, 0, 0, 1)])
    p.write_bytes(good[:-3])
    with pytest.raises(DreamPrintError, match="damaged"):
        open_source(p)
    p.write_bytes(_vox((100000, 3, 3), []))
    with pytest.raises(DreamPrintError, match="out of range"):
        open_source(p)
    bad = bytearray(_vox((3, 3, 3), [(0, 0, 0, 1)]))
    i = bad.find(b"XYZI") + 12
    bad[i:i + 4] = struct.pack("<i", 2_000_000_000)
    p.write_bytes(bytes(bad))
    with pytest.raises(DreamPrintError, match="claims"):
        open_source(p)
    p.write_bytes(_vox((2, 2, 2), [(5, 0, 0, 1)]))
    with pytest.raises(DreamPrintError, match="outside"):
        open_source(p)
