"""Helpers shared by the volume tests."""

import subprocess
import textwrap

import numpy as np
import pytest


@pytest.fixture(autouse=True)
def _idle(idle_machine):
    """What ``dreamprint inspect`` says on stderr about a file does not depend on the load."""


def _box_expectation(grid, lo, hi, value):
    """Closed form for a box of constant ``value`` over [lo, hi] (source units): value at the
    printer voxel centres inside the box, 0 outside, as a (z, y, x) array."""
    from dreamprint_gui.io.volumes.base import voxel_centres

    inside = [(voxel_centres(grid, a) >= lo[a]) & (voxel_centres(grid, a) <= hi[a])
              for a in range(3)]
    m = inside[2][:, None, None] & inside[1][None, :, None] & inside[0][None, None, :]
    return np.where(m, np.float32(value), np.float32(0))


@pytest.fixture
def box_expectation():
    return _box_expectation


WRITE = textwrap.dedent('''
    import sys
    import numpy as np
    import pyopenvdb as vdb
    out = sys.argv[1]

    def fog(name, value, lo, hi, half=False, voxel=0.25, offset=(1.0, -2.0, 0.5)):
        g = vdb.FloatGrid()
        g.fill(lo, hi, value)
        g.name = name
        g.gridClass = vdb.GridClass.FOG_VOLUME
        g.saveFloatAsHalf = half
        g.transform = vdb.createLinearTransform(voxelSize=voxel)
        g.transform.translate(offset)
        return g

    def vec(name, value, lo, hi, voxel=0.25, offset=(1.0, -2.0, 0.5)):
        g = vdb.Vec3SGrid()
        g.fill(lo, hi, value)
        g.name = name
        g.transform = vdb.createLinearTransform(voxelSize=voxel)
        g.transform.translate(offset)
        return g

    box = ((0, 0, 0), (15, 23, 9))
    vdb.write(out + '/box_half_cd.vdb', [fog('density', 0.5, *box, half=True),
                                          vec('Cd', (0.2, 0.5, 1.0), *box)])
    vdb.write(out + '/box_rgb3.vdb', [fog('density', 2.0, *box)] +
              [fog(n, v, *box) for n, v in (('color_r', 0.1), ('color_g', 0.4),
                                              ('color_b', 0.9))])
    # linear ramp in i: value = 0.01 * i
    ramp = fog('density', 0.0, (0, 0, 0), (1, 1, 1))
    a = np.zeros((64, 16, 16), np.float32) + (0.01 * np.arange(64, dtype=np.float32))[:, None, None]
    ramp.copyFromArray(a, (0, 0, 0))
    vdb.write(out + '/ramp.vdb', [ramp])
    ls = vdb.createLevelSetSphere(radius=2.0, center=(0, 0, 0), voxelSize=0.1, halfWidth=3.0)
    ls.name = 'ls_sphere'
    vdb.write(out + '/levelset.vdb', [ls])
    empty = vdb.FloatGrid()
    empty.name = 'density'
    empty.gridClass = vdb.GridClass.FOG_VOLUME
    vdb.write(out + '/empty.vdb', [empty, fog('heat', 1.0, *box)])
    vdb.write(out + '/multi.vdb', [fog('smoke', 1.0, *box), fog('heat', 1.0, *box)])
    far = fog('density', 1.0, (0, 0, 0), (7, 7, 7), voxel=1.0, offset=(0, 0, 0))
    far.fill((200000, 0, 0), (200007, 7, 7), 1.0)
    vdb.write(out + '/far.vdb', [far])
    big = fog('density', 0.75, (0, 0, 0), (255, 127, 135), voxel=0.01, offset=(0, 0, 0))
    vdb.write(out + '/bigtile.vdb', [big])
    rot = fog('density', 1.0, *box)
    rot.transform.rotate(0.3, vdb.Axis.Z)
    vdb.write(out + '/rotated.vdb', [rot])
''')


@pytest.fixture(scope="session")
def vdbs(tmp_path_factory, openvdb_python):
    out = tmp_path_factory.mktemp("vdb")
    script = out / "write.py"
    script.write_text(WRITE)
    subprocess.run([openvdb_python, "-I", str(script), str(out)], check=True)
    return out
