"""OpenVDB header checks before any grid is read, and the tidy ``inspect`` output."""

import json
import math
import struct

import pytest

from dreamprint_gui.cli import main
from dreamprint_gui.core.errors import DreamPrintError
from dreamprint_gui.io.volumes import open_source
from dreamprint_gui.io.volumes.vdb.openvdb import check_header


def _header(version=224, grids=(("density", "Tree_float_5_4_3", 100, 200, 300),), meta=0):
    """A .vdb header written to the OpenVDB layout (io/Archive.cc, io/GridDescriptor.cc)."""
    out = struct.pack("<qIIIb", 0x56444220, version, 10, 0, 1) + b"0" * 36
    out += struct.pack("<i", meta)
    for k in range(meta):
        for s in (f"key{k}".encode(), b"string", b"value"):
            out += struct.pack("<I", len(s)) + s
    out += struct.pack("<i", len(grids))
    for name, gtype, g, b, e in grids:
        for s in (name.encode(), gtype.encode(), b""):
            out += struct.pack("<I", len(s)) + s
        out += struct.pack("<qqq", g, b, e)
    return out


def test_header_of_a_real_file(vdbs):
    h = check_header(vdbs / "box_rgb3.vdb")
    assert h["file_version"] >= 221 and [g["name"] for g in h["grids"]][0] == "density"
    assert h["grids"][-1]["end"] == (vdbs / "box_rgb3.vdb").stat().st_size


@pytest.mark.parametrize("make, message", [
    (lambda good: b"", r"t\.vdb: empty file"),
    (lambda good: good[:5], r"truncated: the magic number needs bytes 0\.\.8, the file has 5"),
    (lambda good: b"\x00" * 64, r"not an OpenVDB file \(magic 0x0"),
    (lambda good: good[:40], r"truncated: the file UUID needs bytes 21\.\.57, the file has 40"),
    (lambda good: good[: len(good) // 2], r"truncated: grid '.*' ends at byte [\d,]+, the"),
    (lambda good: good[:-1], r"truncated: grid 'color_b' ends at byte [\d,]+, the file has"),
])
def test_damaged_files_named_before_any_grid_is_read(vdbs, tmp_path, make, message):
    good = (vdbs / "box_rgb3.vdb").read_bytes()
    t = tmp_path / "t.vdb"
    t.write_bytes(make(good))
    with pytest.raises(DreamPrintError, match=message):
        open_source(t)


def test_descriptors_written_to_the_spec(tmp_path, capsys):
    f = tmp_path / "h.vdb"
    f.write_bytes(_header(meta=2) + b"\x00" * 240)     # 300 bytes in all: as announced
    assert check_header(f)["grids"] == [{"name": "density", "type": "Tree_float_5_4_3",
                                         "end": 300}]
    f.write_bytes(_header(meta=2) + b"\x00" * 100)
    with pytest.raises(DreamPrintError, match="grid 'density' ends at byte 300, the file has"):
        check_header(f)
    f.write_bytes(_header(version=221))
    with pytest.raises(DreamPrintError, match="version 221 is older than 222"):
        check_header(f)
    f.write_bytes(_header(version=226))
    with pytest.raises(DreamPrintError, match="version 226 is newer than 225"):
        check_header(f)
    f.write_bytes(_header(grids=(("density", "Tree_float_5_4_3", 200, 100, 300),)) + bytes(300))
    with pytest.raises(DreamPrintError, match="inconsistent offsets"):
        check_header(f)
    # the command line: one line, exit 2, no traceback
    f.write_bytes(b"")
    assert main(["inspect", str(f)]) == 2
    assert capsys.readouterr().err.strip() == f"dreamprint: error: {f}: empty file"


def _descriptor(name, gtype, g, b, e):
    out = b""
    for s in (name.encode(), gtype.encode(), b""):
        out += struct.pack("<I", len(s)) + s
    return out + struct.pack("<qqq", g, b, e)


def test_second_descriptor_after_megabytes_of_grid_data(tmp_path):
    """Each descriptor follows its grid's data (io/File.cc): a reader must jump over a large
    first grid (a real density + colour export) to the second descriptor."""
    head = _header(grids=())[:-4] + struct.pack("<i", 2)
    d1 = _descriptor("density", "Tree_float_5_4_3", 0, 0, 0)
    first_end = len(head) + len(d1) + 5_000_000            # 5 MB of grid data
    d1 = _descriptor("density", "Tree_float_5_4_3", len(head) + len(d1),
                     len(head) + len(d1) + 100, first_end)
    d2 = _descriptor("color", "Tree_vec3s_5_4_3", first_end + 60, first_end + 160,
                     first_end + 2_000_000)
    f = tmp_path / "two.vdb"
    f.write_bytes(head + d1 + bytes(5_000_000) + d2 + bytes(2_000_000 - len(d2)))
    grids = check_header(f)["grids"]
    assert [(g["name"], g["type"], g["end"]) for g in grids] == [
        ("density", "Tree_float_5_4_3", first_end),
        ("color", "Tree_vec3s_5_4_3", first_end + 2_000_000)]
    f.write_bytes(head + d1 + bytes(5_000_000) + d2[:7])   # cut inside the second descriptor
    with pytest.raises(DreamPrintError, match="truncated: grid descriptor 2 of 2 needs bytes"):
        check_header(f)


def test_inspect_vector_grid_ranges_and_units(vdbs, capsys):
    assert main(["inspect", "--json", str(vdbs / "box_half_cd.vdb")]) == 0
    info = json.loads(capsys.readouterr().out)
    cd = next(g for g in info["grids"] if g["name"] == "Cd")
    assert cd["min"] == pytest.approx([0.2, 0.5, 1.0]) and cd["max"] == pytest.approx(
        [0.2, 0.5, 1.0])
    assert cd["magnitude"] == pytest.approx([math.sqrt(0.04 + 0.25 + 1.0)] * 2, rel=1e-6)
    assert cd["index_bounds"] == [[0, 0, 0], [15, 23, 9]]
    assert info["content"] == {"mode": "fog", "reason": "a fog volume"}
    assert main(["inspect", str(vdbs / "box_half_cd.vdb"), "--height-mm", "20"]) == 0
    text = capsys.readouterr().out
    assert "- .. -" not in text and "range" not in text
    assert "values per component x 0.2 .. 0.2, y 0.5 .. 0.5, z 1 .. 1" in text
    assert "source units" in text and "index i 0 .. 15, j 0 .. 23, k 0 .. 9" in text
    # box of 16 x 24 x 10 voxels of 0.25 units: z extent 2.5 units -> 20 mm, 8 mm per unit
    assert "1 source unit = 8 mm; the print is 32.00 x 48.00 x 20.00 mm (x, y, z)" in text


def test_inspect_level_set_content(vdbs, capsys):
    assert main(["inspect", str(vdbs / "levelset.vdb")]) == 0
    assert "content: solid (--content auto: a level set (grid 'ls_sphere'))" in \
        capsys.readouterr().out


def test_inspect_vtk_vector_array_per_component(tmp_path, capsys):
    import numpy as np
    import pyvista as pv

    g = pv.ImageData(dimensions=(4, 5, 6))
    v = np.random.default_rng(0).normal(size=(g.n_points, 3)).astype(np.float32)
    g.point_data["vel"] = v
    g.save(tmp_path / "vec.vti")
    assert main(["inspect", "--json", str(tmp_path / "vec.vti")]) == 0
    info = json.loads(capsys.readouterr().out)
    (vel,) = info["grids"]
    assert vel["class"] == "vector image"
    np.testing.assert_allclose(vel["min"], v.min(axis=0), rtol=1e-6)
    np.testing.assert_allclose(vel["max"], v.max(axis=0), rtol=1e-6)
    mag = np.linalg.norm(v.astype(np.float64), axis=1)
    np.testing.assert_allclose(vel["magnitude"], [mag.min(), mag.max()], rtol=1e-5)
    # the job still refuses to map three components, with its message
    assert main(["convert", str(tmp_path / "vec.vti"), "-o", str(tmp_path / "J"),
                 "--height-mm", "1"]) == 2
    assert "3 components" in capsys.readouterr().err
