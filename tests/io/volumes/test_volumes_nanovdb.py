"""NanoVDB: files written by nanovdb_convert (Debian libnanovdb-tools, the reference writer)
from generated OpenVDB files must sample exactly like the OpenVDB originals."""

import shutil
import subprocess

import numpy as np
import pytest

from dreamprint_gui.cli import main
from dreamprint_gui.core.errors import DreamPrintError
from dreamprint_gui.io.volumes import grid_for_source, open_source

CONVERT = shutil.which("nanovdb_convert")


@pytest.fixture(scope="module")
def nvdbs(vdbs, tmp_path_factory):
    if CONVERT is None:
        pytest.fail("nanovdb_convert missing: apt-get install libnanovdb-tools (quickstart.sh)")
    out = tmp_path_factory.mktemp("nvdb")
    for name in ("box_half_cd", "ramp", "levelset", "bigtile"):
        for codec, flag in (("none", []), ("zip", ["-z"]), ("blosc", ["-b"])):
            subprocess.run([CONVERT, "-f", *flag, str(vdbs / f"{name}.vdb"),
                            str(out / f"{name}_{codec}.nvdb")], check=True,
                           capture_output=True)
    return out


@pytest.mark.parametrize("codec", ["none", "zip", "blosc"])
@pytest.mark.parametrize("name, opts", [("box_half_cd", {}), ("ramp", {}), ("bigtile", {}),
                                        ("levelset", {"level_set": "solid"})])
def test_nanovdb_samples_like_openvdb(vdbs, nvdbs, name, opts, codec):
    ref = open_source(vdbs / f"{name}.vdb", **opts)
    s = open_source(nvdbs / f"{name}_{codec}.nvdb", **opts)
    np.testing.assert_allclose(s.bounds, ref.bounds, rtol=1e-12)
    g = grid_for_source(ref, (0.13, 0.07, 0.11), size_mm=(12, 12, 12))
    _, d_ref = ref.sample_slab(g, 0, g.shape_xyz[2])
    _, d = s.sample_slab(g, 0, g.shape_xyz[2])
    assert d_ref.max() > 0
    np.testing.assert_array_equal(d, d_ref)


def test_manta_sample_file_converted(shared_data, tmp_path):
    f = tmp_path / "m.nvdb"
    subprocess.run([CONVERT, str(shared_data / "volumes" / "blender_mantaflow_fluid_data_0190.vdb"),
                    str(f)], check=True, capture_output=True)
    info = open_source(f).info()
    grids = {g["name"]: g for g in info["grids"]}
    assert grids["density"]["active_voxels"] == 14112
    assert grids["density"]["shape"] == [21, 21, 32]
    assert grids["velocity"]["dtype"] == "Vec3f"


def test_nanovdb_errors(nvdbs, tmp_path, capsys):
    with pytest.raises(DreamPrintError, match="level set, not a fog volume"):
        open_source(nvdbs / "levelset_none.nvdb")
    data = (nvdbs / "ramp_none.nvdb").read_bytes()
    for cut in (10, 100, len(data) // 2, len(data) - 8):
        p = tmp_path / f"t{cut}.nvdb"
        p.write_bytes(data[:cut])
        with pytest.raises(DreamPrintError):
            open_source(p)
    # an absurd grid size in the metadata is refused before anything is allocated
    bad = bytearray(data)
    bad[16:24] = (1 << 60).to_bytes(8, "little")
    p = tmp_path / "huge.nvdb"
    p.write_bytes(bytes(bad))
    with pytest.raises(DreamPrintError, match="claims"):
        open_source(p)
    zipped = bytearray((nvdbs / "ramp_zip.nvdb").read_bytes())
    zipped[-200:-100] = b"\x00" * 100
    p = tmp_path / "z.nvdb"
    p.write_bytes(bytes(zipped))
    with pytest.raises(DreamPrintError):
        open_source(p)
    assert main(["inspect", "--json", str(nvdbs / "levelset_blosc.nvdb")]) == 0
    assert '"level set"' in capsys.readouterr().out
