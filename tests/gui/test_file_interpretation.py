"""The GUI offers what the CLI does for a file's interpretation (issue 46): a level set opens
(as a solid, or a hollow shell), a file of several grids asks which one, in the GUI's words."""

from __future__ import annotations

import subprocess
import textwrap

import pytest

from dreamprint_gui.gui.main_window import MainWindow
from dreamprint_gui.gui.names import gui_wording
from dreamprint_gui.io.volumes.vdb.level_set import LEVEL_SET_ADVICE

WRITE = textwrap.dedent('''
    import sys
    import pyopenvdb as vdb
    out = sys.argv[1]
    ls = vdb.createLevelSetSphere(radius=2.0, center=(0, 0, 0), voxelSize=0.1, halfWidth=3.0)
    ls.name = 'ls_sphere'
    vdb.write(out + '/levelset.vdb', [ls])
    grids = []
    for name, value in (('smoke', 1.0), ('heat', 2.0)):
        g = vdb.FloatGrid()
        g.fill((0, 0, 0), (15, 15, 15), value)
        g.name = name
        g.gridClass = vdb.GridClass.FOG_VOLUME
        g.transform = vdb.createLinearTransform(voxelSize=0.25)
        grids.append(g)
    vdb.write(out + '/multi.vdb', grids)
''')


@pytest.fixture(scope="module")
def vdb_files(tmp_path_factory, openvdb_python):
    out = tmp_path_factory.mktemp("vdb-gui")
    script = out / "write.py"
    script.write_text(WRITE)
    subprocess.run([openvdb_python, "-I", str(script), str(out)], check=True)
    return out


def test_the_cli_advice_reads_as_the_gui_controls():
    said = gui_wording("grid 'ls' is a level set, not a fog volume: " + LEVEL_SET_ADVICE)
    assert "(Level set: Solid)" in said and "(Level set: Shell)" in said
    assert "--option" not in said
    said = gui_wording("no grid named 'density'; choose one of: a, b (--option grid=NAME)")
    assert said.endswith("(the Grid control)")
    assert gui_wording("unknown reader option --option foo=1") \
        == "unknown reader option Reader options foo=1"


@pytest.fixture
def window(qtbot, gl_display, table_size):
    w = MainWindow(table_size=table_size, with_gamut=False)
    w.interactive = False
    qtbot.addWidget(w)
    w.preview.set_params(height_mm=5.0)
    w.show()
    w.use_default_profile()
    yield w
    w.close()


def test_a_level_set_opens_as_a_solid_and_as_a_shell(window, qtbot, vdb_files):
    p = window.preview
    with qtbot.waitSignal(p.rendered, timeout=180000):
        window.open_path(vdb_files / "levelset.vdb")
    assert window.source is not None and window.source.level_set == "solid"
    assert p.form.isRowVisible(p.level_set) and not p.form.isRowVisible(p.shell_voxels)
    assert not p.form.isRowVisible(p.grid)          # one grid: nothing to choose
    with qtbot.waitSignal(window.sourceChanged, timeout=60000):
        p.level_set.setCurrentIndex(p.level_set.findData("shell"))
    assert window.source.level_set == "shell" and window.source.shell_voxels == 1.0
    assert p.form.isRowVisible(p.shell_voxels)
    assert p.job_settings().source_options == {"level_set": "shell", "shell_voxels": 1.0}
    # a wall thicker than the file's narrow band: said in the window, the preview waits
    p.shell_voxels.setValue(5.0)
    qtbot.waitUntil(lambda: p.waiting_for_choice is not None, timeout=60000)
    assert "shell_voxels at most 2" in window.last_error


def test_several_grids_ask_which_one_with_the_gui_words(window, qtbot, vdb_files):
    p = window.preview
    window.open_path(vdb_files / "multi.vdb")
    qtbot.waitUntil(lambda: p.waiting_for_choice is not None, timeout=60000)
    assert "(the Grid control)" in window.last_error and "--option" not in window.last_error
    assert window.source is None
    assert p.form.isRowVisible(p.grid)
    assert sorted(map(str, (p.grid.itemData(i) for i in range(p.grid.count())))) \
        == ["None", "heat", "smoke"]
    with qtbot.waitSignal(p.rendered, timeout=180000):
        p.grid.setCurrentIndex(p.grid.findData("heat"))
    assert window.source is not None
    assert p.job_settings().source_options == {"density_grid": "heat"}
