"""The up axis from what the file says (issue 46): an OpenVDB writer's convention (Houdini and
Maya y-up, Blender z-up) or an explicit up axis in its metadata, the cameras a 3DGS splat was
trained from; otherwise a guess, said to be one, with the option that changes it."""

from __future__ import annotations

import json
import shutil
import subprocess
import textwrap

import numpy as np
import pytest

from dreamprint_gui.cli import main
from dreamprint_gui.io.volumes import open_source
from dreamprint_gui.io.volumes.orient import choose_orientation

WRITE = textwrap.dedent('''
    import sys
    import pyopenvdb as vdb
    out = sys.argv[1]

    def plume():
        # a smoke plume as Houdini writes it: its long axis (height) along y
        g = vdb.FloatGrid()
        g.fill((0, 0, 0), (7, 39, 7), 1.0)
        g.name = 'density'
        g.gridClass = vdb.GridClass.FOG_VOLUME
        g.transform = vdb.createLinearTransform(voxelSize=0.1)
        return g

    vdb.write(out + '/houdini.vdb', [plume()],
              metadata={'creator': 'Houdini 19.5.303/GEO_VDBTranslator'})
    vdb.write(out + '/blender.vdb', [plume()], metadata={'creator': 'Blender/Smoke'})
    vdb.write(out + '/stated.vdb', [plume()], metadata={'up_axis': '-x'})
    vdb.write(out + '/silent.vdb', [plume()])
''')


@pytest.fixture(scope="module")
def vdbs(tmp_path_factory, openvdb_python):
    out = tmp_path_factory.mktemp("up-vdb")
    (out / "write.py").write_text(WRITE)
    subprocess.run([openvdb_python, "-I", str(out / "write.py"), str(out)], check=True)
    return out


@pytest.mark.parametrize("name, up, guessed, words", [
    ("houdini.vdb", "y", False, "written by Houdini"),
    ("blender.vdb", "z", False, "written by Blender"),
    ("stated.vdb", "-x", False, "the file's up_axis says -x"),
    ("silent.vdb", "z", True, "the file does not say"),
])
def test_an_openvdb_file_stands_as_its_writer_meant(vdbs, name, up, guessed, words):
    o = choose_orientation(open_source(vdbs / name), None, 0)
    assert (o.up, o.auto, o.guessed) == (up, True, guessed)
    text = o.describe()
    assert words in text and text.endswith("--up changes it)")
    assert ("a guess:" in text) == guessed


def test_the_houdini_plume_prints_standing(vdbs, capsys):
    """Its long y axis (4 units) becomes the print's height (was: lying on its side)."""
    assert main(["inspect", str(vdbs / "houdini.vdb"), "--json"]) == 0
    place = json.loads(capsys.readouterr().out)["placement"]
    lo, hi = np.asarray(place["fit_bounds"])
    assert np.allclose(hi - lo, (0.8, 0.8, 4.0))
    assert place["orientation"]["up"] == "y" and "written by Houdini" in place["orientation_text"]


def _cameras(n, up_world, rng, upside_down=0):
    """cameras.json entries (3DGS camera_to_JSON): camera-to-world rotations of level OpenCV
    cameras (y down) around an object whose up is ``up_world``; ``upside_down`` of them flipped."""
    up = np.asarray(up_world, float)
    out = []
    for k in range(n):
        fwd = np.cross(up, [0.3, 0.5, 0.8])
        fwd /= np.linalg.norm(fwd)
        a = 2 * np.pi * k / n                      # cameras all around the up axis
        fwd = fwd * np.cos(a) + np.cross(up, fwd) * np.sin(a)
        down = -up + 0.05 * rng.standard_normal(3)
        down -= fwd * (down @ fwd)
        down /= np.linalg.norm(down)
        if k < upside_down:
            down = -down
        right = np.cross(down, fwd)
        R = np.stack([right, down, fwd], axis=1)   # columns: camera x, y, z in the world
        out.append({"id": k, "img_name": f"{k:05d}", "width": 8, "height": 8,
                    "position": (-3 * fwd).tolist(), "rotation": R.tolist(), "fx": 8, "fy": 8})
    return out


def test_a_splat_stands_as_its_cameras_stood(shared_data, tmp_path):
    model = tmp_path / "model"
    ply = model / "point_cloud" / "iteration_7000" / "point_cloud.ply"
    ply.parent.mkdir(parents=True)
    shutil.copy(shared_data / "splats" / "inria3dgs_iter7000_sh3_9080.ply", ply)
    rng = np.random.default_rng(0)
    (model / "cameras.json").write_text(json.dumps(_cameras(24, (0, 0, 1), rng)))
    o = choose_orientation(open_source(ply), None, 0)
    assert (o.up, o.guessed) == ("z", False) and "24 cameras of cameras.json" in o.reason
    (model / "cameras.json").write_text(json.dumps(_cameras(24, (0, 0, 1), rng, 12)))
    o = choose_orientation(open_source(ply), None, 0)   # cameras disagree: the convention
    assert (o.up, o.guessed) == ("-y", True) and "a guess" in o.describe()


def test_inspect_says_how_a_level_set_stands(tmp_path, openvdb_python, capsys):
    """A level set is placed as a job opens it (content auto: a solid), so inspect says its
    orientation too (it said nothing: the file was opened as a fog and refused)."""
    script = tmp_path / "w.py"
    script.write_text(textwrap.dedent('''
        import sys
        import pyopenvdb as vdb
        ls = vdb.createLevelSetSphere(radius=1.0, center=(0, 0, 0), voxelSize=0.1)
        vdb.write(sys.argv[1], [ls], metadata={'creator': 'Houdini 20.0/GEO_VDBTranslator'})
    '''))
    subprocess.run([openvdb_python, "-I", str(script), str(tmp_path / "ls.vdb")], check=True)
    assert main(["inspect", str(tmp_path / "ls.vdb")]) == 0
    out = capsys.readouterr().out
    assert "print orientation: up = source y (auto: written by Houdini" in out
