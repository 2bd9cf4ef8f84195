"""The entries every job's manifest has are written once (job/manifest.py) for a conversion and
a translucency wedge alike, and agree with the slices on disk."""

import json

import numpy as np
from PIL import Image

from dreamprint_gui.cli import main
from dreamprint_gui.core.printer import load_printer
from dreamprint_gui.job.manifest import LABELS

SHARED = {"format", "format_version", "software", "created", "printer", "physical_size_mm",
          "voxel_mm", "grid_dimensions", "seed", "halftoning", "slices", "labels",
          "voxel_counts", "mean_concentration", "total_voxels", "timings_s"}


def _job(tmp_path, capsys, *args):
    out = tmp_path / args[0].replace(" ", "_")
    code = main([*args[0].split(), "-o", str(out), *args[1:]])
    assert code == 0, capsys.readouterr().err
    return out, json.loads((out / "manifest.json").read_text())


def test_a_conversion_and_a_wedge_write_the_same_entries(tmp_path, capsys):
    conv, mc = _job(tmp_path, capsys, "convert demo", "--height-mm", "0.4", "--table-size", "9",
                    "--quiet", "--printer", "voxelprint-14um")
    wedge, mw = _job(tmp_path, capsys, "target wedge", "--inks", "W", "--thickness-mm", "0.1",
                     "--slab-mm", "5")
    for folder, m in ((conv, mc), (wedge, mw)):
        assert SHARED <= set(m), SHARED - set(m)
        assert m["format"] == "dreamprint-job" and m["software"]["name"] == "dreamprint"
        nx, ny, nz = m["grid_dimensions"]
        printer = load_printer(m["printer"]["name"])
        np.testing.assert_allclose(m["physical_size_mm"],
                                   np.multiply([nx, ny, nz], printer.voxel_mm))
        files = sorted((folder / "slices").glob("*.png"))
        assert len(files) == m["slices"]["count"] == nz
        assert m["slices"]["first"] == "slices/" + files[0].name
        assert m["slices"]["last"] == "slices/" + files[-1].name
        with Image.open(files[0]) as im:
            assert im.size == (m["slices"]["width"], m["slices"]["height"])
        assert list(m["labels"]) == list(LABELS) == list(m["voxel_counts"])
        assert m["total_voxels"] == nx * ny * nz == sum(m["voxel_counts"].values())
        assert abs(sum(m["mean_concentration"].values()) - 1.0) < 1e-6  # float32 concentrations
