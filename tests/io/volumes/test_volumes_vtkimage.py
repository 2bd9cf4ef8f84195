"""VTK image data, MetaImage and NRRD through pyvista: sample files, windows, closed forms."""

import json

import numpy as np
import pytest

from dreamprint_gui.cli import main
from dreamprint_gui.core.errors import DreamPrintError
from dreamprint_gui.io.volumes import grid_for_source, open_source


@pytest.mark.parametrize("name, shape, dtype, active, vmax, bounds_hi", [
    ("hydrogen.vti", [64, 64, 64], "float32", 249600, 1.0, [63, 63, 63]),
    ("ironProt.vtk", [68, 68, 68], "uint8", 106699, 255, [67, 67, 67]),
    ("HeadMRVolume.mhd", [48, 62, 42], "uint8", 123631, 255, [188, 244, 164]),
])
def test_sample_files(shared_data, name, shape, dtype, active, vmax, bounds_hi):
    s = open_source(shared_data / "volumes" / name)
    (g,) = s.info()["grids"]
    assert g["shape"] == shape and g["dtype"] == dtype and g["class"] == "scalar image"
    assert g["active_voxels"] == active and g["max"] == vmax
    assert g["bounds"] == [[0, 0, 0], bounds_hi]
    grid = grid_for_source(s, (0.5, 0.5, 0.25), height_mm=10)
    rgb, d = s.sample_slab(grid, 0, grid.shape_xyz[2])
    assert d.shape == grid.shape_xyz[::-1] and d.max() > 0


def _write_vti(tmp_path, values, spacing, origin, name="v.vti"):
    import pyvista as pv

    img = pv.ImageData(dimensions=values.shape[::-1], spacing=spacing, origin=origin)
    img.point_data["f"] = values.reshape(-1)          # x fastest: (z, y, x) C order
    p = tmp_path / name
    img.save(p)
    return p


def test_constant_box_on_anisotropic_grid(tmp_path, box_expectation):
    vals = np.full((5, 7, 9), 3.0, np.float32)       # z, y, x
    p = _write_vti(tmp_path, vals, (0.5, 0.25, 1.0), (1.0, -2.0, 0.0))
    s = open_source(p, window=(0.0, 3.0), density=2.0)
    lo, hi = (1.0, -2.0, 0.0), (1.0 + 8 * 0.5, -2.0 + 6 * 0.25, 4.0)
    assert s.bounds == (lo, hi)
    g = grid_for_source(s, (0.07, 0.03, 0.11), size_mm=(30, 30, 30))
    _, d = s.sample_slab(g, 0, g.shape_xyz[2], density_scale=1.5)
    want = box_expectation(g, lo, hi, 2.0 * 1.5 / g.mm_per_unit)
    np.testing.assert_allclose(d, want, rtol=1e-6)


def test_linear_ramp_is_interpolated_exactly(tmp_path, box_expectation):
    # trilinear interpolation reproduces a linear function exactly
    z, y, x = np.meshgrid(np.arange(4), np.arange(5), np.arange(6), indexing="ij")
    vals = (x * 1.0 + y * 2.0 + z * 3.0).astype(np.float32)
    p = _write_vti(tmp_path, vals, (1, 1, 1), (0, 0, 0))
    s = open_source(p, window=(0.0, 100.0), density=100.0)
    g = grid_for_source(s, (0.3, 0.7, 0.2), height_mm=3)
    _, d = s.sample_slab(g, 0, g.shape_xyz[2])
    from dreamprint_gui.io.volumes.base import voxel_centres
    cx, cy, cz = (voxel_centres(g, a) for a in range(3))
    want = cx[None, None, :] + 2 * cy[None, :, None] + 3 * cz[:, None, None]
    inside = box_expectation(g, (0, 0, 0), (5, 4, 3), 1.0) > 0
    np.testing.assert_allclose(d[inside] * g.mm_per_unit, want[inside], rtol=1e-5, atol=1e-4)
    assert not d[~inside].any()


def test_window_colormap_and_uniform_colour(tmp_path):
    vals = np.linspace(0, 10, 2 * 2 * 11, dtype=np.float32).reshape(2, 2, 11)
    p = _write_vti(tmp_path, vals, (1, 1, 1), (0, 0, 0))
    s = open_source(p, window=(2.0, 4.0), colour=(0.2, 0.4, 0.6))
    g = grid_for_source(s, (1, 1, 1), size_mm=(10, 1, 1))
    rgb, d = s.sample_slab(g, 0, 1)
    assert np.allclose(rgb, [0.2, 0.4, 0.6])
    s2 = open_source(p, colormap="viridis")
    rgb2, _ = s2.sample_slab(g, 0, 1)
    assert not np.allclose(rgb2[0, 0, 0], rgb2[0, 0, -1])
    with pytest.raises(DreamPrintError, match="window"):
        open_source(p, window=(4.0, 2.0))
    with pytest.raises(DreamPrintError, match="colormap"):
        open_source(p, colormap="no-such-map")


def test_rgba_array_gives_colour_and_density(tmp_path):
    import pyvista as pv

    img = pv.ImageData(dimensions=(3, 3, 3))
    rgba = np.zeros((27, 4), np.uint8)
    rgba[:] = (255, 0, 0, 255)
    img.point_data["rgba"] = rgba
    p = tmp_path / "c.vti"
    img.save(p)
    s = open_source(p, density=4.0)
    assert s.info()["grids"][0]["class"] == "rgba image"
    g = grid_for_source(s, (0.5, 0.5, 0.5), height_mm=2)
    rgb, d = s.sample_slab(g, 0, g.shape_xyz[2])
    np.testing.assert_allclose(d, 4.0 / g.mm_per_unit, rtol=1e-6)
    np.testing.assert_allclose(rgb[..., 0], 1.0, rtol=1e-6)
    assert not rgb[..., 1:].any()


def test_detached_nrrd_file_list(tmp_path):
    # NRRD format 5: "data file: <format> <min> <max> <step> [<subdim>]" one slice per file
    nx, ny, nz = 4, 3, 5
    vals = np.arange(nx * ny * nz, dtype=np.uint16).reshape(nz, ny, nx)
    for k in range(nz):
        (tmp_path / f"slice.{k:03d}.raw").write_bytes(vals[k].astype("<u2").tobytes())
    (tmp_path / "vol.nhdr").write_text(
        "NRRD0004\ntype: unsigned short\ndimension: 3\n"
        f"sizes: {nx} {ny} {nz}\nspacings: 0.5 0.5 2\nencoding: raw\nendian: little\n"
        f"data file: slice.%03d.raw 0 {nz - 1} 1 2\n")
    s = open_source(tmp_path / "vol.nhdr")
    (g,) = s.info()["grids"]
    assert g["shape"] == [nx, ny, nz] and g["max"] == nx * ny * nz - 1
    assert np.array_equal(s.volume.data[..., 0], vals.astype(np.float32))


def test_metaimage_and_legacy_vtk_written_by_vtk(tmp_path):
    import pyvista as pv
    from vtkmodules.vtkIOImage import vtkMetaImageWriter

    vals = np.random.default_rng(1).random((4, 5, 6)).astype(np.float32)
    img = pv.ImageData(dimensions=(6, 5, 4), spacing=(1, 2, 3))
    img.point_data["v"] = vals.reshape(-1)
    img.save(tmp_path / "x.vtk")
    w = vtkMetaImageWriter()
    w.SetInputData(img)
    w.SetFileName(str(tmp_path / "x.mhd"))
    w.SetCompression(True)
    w.Write()
    for ext in (".mhd", ".vtk"):
        s = open_source(tmp_path / f"x{ext}")
        np.testing.assert_allclose(s.volume.data[..., 0], vals, rtol=1e-6)
        assert s.bounds == ((0, 0, 0), (5, 8, 9))


@pytest.mark.parametrize("encoding", ["raw", "gzip", "bzip2", "ascii"])
def test_attached_nrrd_encodings(tmp_path, encoding):
    import bz2
    import gzip

    vals = np.random.default_rng(2).random((3, 4, 5)).astype(">f4")      # big-endian
    body = vals.tobytes()
    if encoding == "gzip":
        body = gzip.compress(body)
    elif encoding == "bzip2":
        body = bz2.compress(body)
    elif encoding == "ascii":
        body = " ".join(repr(float(v)) for v in vals.reshape(-1)).encode()
    head = ("NRRD0005\n# a comment\ntype: float\ndimension: 3\nsizes: 5 4 3\n"
            "space dimension: 3\nspace directions: (0.5,0,0) (0,0.25,0) (0,0,2)\n"
            "space origin: (10,20,30)\nkinds: domain domain domain\n"
            f"endian: big\nencoding: {encoding}\nunits:=mm\n\n")
    p = tmp_path / "a.nrrd"
    p.write_bytes(head.encode() + body)
    s = open_source(p)
    np.testing.assert_allclose(s.volume.data[..., 0], vals.astype(np.float32), rtol=1e-6)
    assert s.bounds == ((10, 20, 30), (12, 20.75, 34))
    p.write_bytes(head.encode() + body[: len(body) // 2])
    with pytest.raises(DreamPrintError):
        open_source(p)


def test_bad_files(tmp_path):
    trunc = tmp_path / "t.mhd"
    (tmp_path / "t.raw").write_bytes(b"\0" * 100)
    trunc.write_text("NDims = 3\nDimSize = 100000 100000 100000\nElementType = MET_UCHAR\n"
                     "ElementDataFile = t.raw\n")
    with pytest.raises(DreamPrintError, match="claims"):
        open_source(trunc)
    g = tmp_path / "g.vti"
    g.write_bytes(b"<?xml version='1.0'?><VTKFile type='ImageData'>garbage")
    with pytest.raises(DreamPrintError):
        open_source(g)
    huge = tmp_path / "h.nrrd"
    huge.write_bytes(b"NRRD0004\ntype: float\ndimension: 3\nsizes: 99999 99999 99999\n"
                     b"encoding: gzip\n\n" + b"\x1f\x8b" + b"\0" * 100)
    with pytest.raises(DreamPrintError, match="claims"):
        open_source(huge)
    poly = tmp_path / "p.vtk"
    import pyvista as pv
    pv.Sphere().save(poly)
    with pytest.raises(DreamPrintError, match="not image data"):
        open_source(poly)


def test_inspect_cli(shared_data, capsys):
    f = str(shared_data / "volumes" / "ironProt.vtk")
    assert main(["inspect", "--json", f]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["grids"][0]["shape"] == [68, 68, 68]
    assert main(["inspect", f]) == 0
    assert "68 x 68 x 68" in capsys.readouterr().out


def test_inspect_cli_error_is_one_line(tmp_path, capsys):
    p = tmp_path / "bad.vti"
    p.write_bytes(b"\x00\x01garbage")
    assert main(["inspect", str(p)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("dreamprint: error: ") and str(p) in err and err.count("\n") == 1


@pytest.mark.parametrize("name", ["ironProt.vtk", "HeadMRVolume.mhd"])
def test_truncated_data_is_refused_not_zero_padded(shared_data, tmp_path, name):
    src = shared_data / "volumes" / name
    if name.endswith(".mhd"):
        (tmp_path / name).write_text(src.read_text().replace("HeadMRVolume.raw", "short.raw"))
        (tmp_path / "short.raw").write_bytes((src.parent / "HeadMRVolume.raw").read_bytes()[:50000])
    else:
        (tmp_path / name).write_bytes(src.read_bytes()[:30000])
    with pytest.raises(DreamPrintError, match="damaged or truncated") as e:
        open_source(tmp_path / name)
    # the reader's own words, as one clean line (MetaIO's came tab-indented and quoted)
    reason = str(e.value).split("damaged or truncated file: ", 1)[1]
    assert reason and reason == reason.strip().strip('"') and "\t" not in reason


def test_garbled_metaimage_header_is_called_damaged(tmp_path):
    f = tmp_path / "rand.mhd"
    f.write_bytes(np.random.default_rng(0).integers(0, 256, 3000, dtype=np.uint8).tobytes())
    with pytest.raises(DreamPrintError, match="rand.mhd: damaged"):
        open_source(f)


def test_reader_complaint_made_one_line():
    """A reader's complaint reaches the operator as its last line, without indentation or the
    quotes VTK wraps MetaIO's message in; a quoted name inside the message keeps its quotes."""
    from dreamprint_gui.io.volumes.grids.vtkimage import _one_line

    assert _one_line('ERROR: In vtkMetaImageReader\n\t"MetaImage cannot read data from file."'
                     ) == "MetaImage cannot read data from file."
    assert _one_line('cannot open "a b.raw"\n') == 'cannot open "a b.raw"'
    assert _one_line('  "a"b"  ') == 'a"b'
