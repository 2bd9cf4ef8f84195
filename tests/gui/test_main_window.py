"""The main window: starts on the default profile and the demo volume, previewed; the preview
renders pixels, follows its controls, scrubs halftoned layers; files open by drag and drop."""

from __future__ import annotations

import json
import re

import numpy as np
import pytest
from PySide6.QtCore import QMimeData, QPointF, Qt, QUrl
from PySide6.QtGui import QDropEvent

from dreamprint_gui.core.printer import EMPTY_LABEL
from dreamprint_gui.core.profile import default_profile
from dreamprint_gui.gui.main_window import MainWindow, classify_path
from dreamprint_gui.gui.materials import label_colours
from dreamprint_gui.gui.volume_view import frame_statistics


@pytest.fixture
def window(qtbot, gl_display, table_size):
    w = MainWindow(table_size=table_size)
    w.interactive = False
    qtbot.addWidget(w)
    w.preview.set_params(height_mm=6.0)  # a small print keeps the halftoned layers small
    w.show()
    with qtbot.waitSignal(w.ready, timeout=180000):
        w.use_default_profile()
        w.open_path("demo")
    yield w
    w.close()


def _volume_only_frame(plotter):
    """A frame with only the volumes drawn (box outlines and labels hidden)."""
    hidden = []
    for r in plotter.renderers:
        for name, actor in r.actors.items():
            if not name.startswith("volume"):
                actor.SetVisibility(False)
                hidden.append(actor)
    plotter.render()
    img = plotter.screenshot(return_img=True)
    for a in hidden:
        a.SetVisibility(True)
    plotter.render()
    return img


def test_preview_renders_source_and_print(window):
    img = _volume_only_frame(window.preview.plotter)
    h, w = img.shape[:2]
    left, right = frame_statistics(img[:, : w // 2]), frame_statistics(img[:, w // 2:])
    assert left["non_background_fraction"] > 0.02, left
    assert right["non_background_fraction"] > 0.02, right
    assert "downsampled" in window.preview.note.text()
    assert window.preview.data.print_shape_xyz == tuple(window.preview.ctx.grid.shape_xyz)


def test_slice_scrubber_shows_halftoned_labels(window, qtbot):
    p = window.preview
    nx, ny, nz = p.data.print_shape_xyz
    labels = p.slice_labels
    assert labels.shape == (ny, nx) and labels.max() <= EMPTY_LABEL
    assert p.slice_image is not None and p.legend.rows
    assert abs(sum(share for _, share in p.legend.rows) - 100) < 0.5
    # full resolution: one image pixel per printer voxel, in the printer file's display
    # colours: the slice codes, except Clear (the legend's 227, 233, 253 in the files) shown
    # light steel blue 150, 190, 225
    img = p.slice_image
    assert (img.width(), img.height()) == (nx, ny)
    rows = np.frombuffer(img.constBits(), np.uint8).reshape(ny, img.bytesPerLine())
    shown = rows[:, : 3 * nx].reshape(ny, nx, 3)
    np.testing.assert_array_equal(shown, window.printer.display_palette()[labels])
    colours, names = label_colours(window.printer)
    codes = window.printer.palette()
    assert tuple(codes[5]) == (227, 233, 253) and tuple(colours[5]) == (150, 190, 225)
    np.testing.assert_array_equal(np.delete(colours, 5, 0), np.delete(codes, 5, 0))
    assert [n for n, _ in p.legend.rows] == [names[i] for i in np.unique(labels)]
    # zoom and pan: the wheel zooms in, Fit shows the whole layer again
    view = p.slice_view
    p.pages.setCurrentIndex(1)  # the layers tab
    qtbot.waitUntil(lambda: view.canvas.isVisible(), timeout=5000)
    assert view.canvas.viewport().width() > 300  # a full-size view, not a thumbnail
    whole = view.visible_voxels()
    assert whole.width() >= nx - 1 and whole.height() >= ny - 1
    view.canvas.zoom_by(8.0)
    part = view.visible_voxels()
    assert part.width() < whole.width() / 2 or part.height() < whole.height() / 2
    view.fit_button.click()
    assert view.visible_voxels().width() >= nx - 1
    p.slice_slider.setValue(0)  # the bottom layer of a cloud is mostly background
    qtbot.waitUntil(lambda: p.shown_layer == 0, timeout=30000)
    # the layer's height above the build plate, in mm: layer k spans k t .. (k + 1) t
    t = window.printer.layer_thickness_mm
    assert f"layer 0 of {nz}, z 0.000-{t:.3f} mm" in p.slice_label.text()
    p.slice_slider.setValue(nz - 1)
    qtbot.waitUntil(lambda: p.shown_layer == nz - 1, timeout=30000)
    assert f"z {(nz - 1) * t:.3f}-{nz * t:.3f} mm" in p.slice_label.text()
    assert nz * t == pytest.approx(p.ctx.grid.size_mm[2])  # the top layer ends the grid


def test_density_scale_and_background_follow_the_engine(window, qtbot):
    p = window.preview
    base = p.data
    with qtbot.waitSignal(p.rendered, timeout=60000):
        p.set_params(density_scale=3.0)
    # the source's density rule: sigma = density * scale / mm per unit
    np.testing.assert_allclose(p.data.source_sigma, 3.0 * base.source_sigma, rtol=1e-5)
    with qtbot.waitSignal(p.rendered, timeout=60000):
        p.set_params(background="empty")
    below = p.data.source_sigma < p.ctx.halftoner.threshold
    assert below.any() and np.all(p.data.print_sigma[below] == 0)
    assert np.all(p.data.print_sigma[~below] > 0)


def test_drop_a_profile_and_a_bad_file(window, qtbot, tmp_path):
    prof = default_profile().to_json_dict()
    prof["name"] = "dropped-profile"
    path = tmp_path / "dropped.json"
    path.write_text(json.dumps(prof))
    bad = tmp_path / "broken.json"
    bad.write_text("{ not json")

    def drop(p):
        mime = QMimeData()
        mime.setUrls([QUrl.fromLocalFile(str(p))])
        ev = QDropEvent(QPointF(10, 10), Qt.DropAction.CopyAction, mime,
                        Qt.MouseButton.NoButton, Qt.KeyboardModifier.NoModifier)
        window.dropEvent(ev)

    drop(path)
    assert window.profile.name == "dropped-profile"
    assert window.settings.recent_files()[0] == str(path.resolve())
    drop(bad)  # the problem is reported, the active profile stays
    assert window.profile.name == "dropped-profile"
    assert "broken.json" in window.statusBar().currentMessage()
    qtbot.waitUntil(lambda: window.tables is not None, timeout=120000)


def test_classify_path():
    assert classify_path("a/b.json") == "profile"
    assert classify_path("set.TOML") == "calibration-set"
    assert classify_path("cloud.vdb") == "volume" and classify_path("demo") == "volume"


def _texts_showing(fragment: str) -> list[str]:
    """Every place on screen that shows ``fragment``: visible labels (message boxes included),
    status bars, and window titles."""
    from PySide6.QtWidgets import QApplication, QLabel, QMainWindow, QWidget

    found = []
    for w in QApplication.allWidgets():
        # PySide can hand back a wrapper of another type for a widget being deleted (seen once:
        # a QOffscreenSurface, with no isVisible): not on screen
        if not isinstance(w, QWidget) or not w.isVisible():
            continue
        if isinstance(w, QLabel) and fragment in w.text():
            found.append(f"label in {type(w.window()).__name__}")
        if isinstance(w, QMainWindow) and fragment in w.statusBar().currentMessage():
            found.append("status bar")
        if w.isWindow() and fragment in w.windowTitle():
            found.append("window title")
    return found


@pytest.mark.parametrize("kind", ["cut .vox", "empty .vdb"])
def test_a_damaged_file_is_reported_once(qtbot, tmp_path, shared_data, kind):
    """Opening a damaged file: one dialog says it; nothing else repeats it."""
    from PySide6.QtWidgets import QMessageBox

    if kind == "cut .vox":
        knight = shared_data / "voxels" / "magicavoxel_chr_knight.vox"
        bad = tmp_path / "knight-cut.vox"
        bad.write_bytes(knight.read_bytes()[:100])  # cut inside a chunk
        problem = "runs past the end"
    else:
        bad = tmp_path / "cloud.vdb"
        bad.write_bytes(b"")
        problem = "empty file"
    w = MainWindow(with_gamut=False)
    qtbot.addWidget(w)
    w.show()
    qtbot.waitExposed(w)
    with qtbot.waitSignal(w.openFailed, timeout=30000) as blocker:
        w.open_path(bad)
    message = blocker.args[1]
    assert bad.name in message and problem in message
    qtbot.waitUntil(lambda: w.problem_box is not None and w.problem_box.isVisible(),
                    timeout=5000)
    where = _texts_showing(problem)
    assert where == ["label in QMessageBox"], where
    assert not w.statusBar().currentMessage().startswith("Opening")  # no stale promise
    boxes = [b for b in w.findChildren(QMessageBox) if b.isVisible()]
    assert len(boxes) == 1
    # a second problem replaces the first dialog instead of stacking another
    with qtbot.waitSignal(w.openFailed, timeout=30000):
        w.open_path(bad)
    # the first dialog closes and the second opens: wait for the second's text (between the
    # two, once in a fresh-clone CI run, the old box was still the one visible box and the new
    # one's text not yet showing)
    qtbot.waitUntil(lambda: len([b for b in w.findChildren(QMessageBox)
                                 if b.isVisible()]) == 1
                    and len(_texts_showing(problem)) == 1, timeout=5000)
    w.problem_box.close()


def test_opening_a_file_shows_the_preview(qtbot, shared_data):
    """The window starts on the preview whatever page the last session ended on, and opening
    a volume from another page brings the preview to the front."""
    from dreamprint_gui.gui.settings import AppSettings

    settings = AppSettings()
    settings.set("window/tab", 1)  # what older versions restored
    settings.sync()
    w = MainWindow(settings=settings)
    w.interactive = False
    qtbot.addWidget(w)
    assert w.tabs.currentWidget() is w.preview
    w.tabs.setCurrentWidget(w.gamut)
    assert w.tabs.currentWidget() is w.gamut
    with qtbot.waitSignal(w.sourceChanged, timeout=30000):
        w.open_path(shared_data / "voxels" / "magicavoxel_chr_knight.vox")
    assert w.tabs.currentWidget() is w.preview
    w.tabs.setCurrentWidget(w.gamut)
    with qtbot.waitSignal(w.sourceChanged, timeout=30000):
        w.open_path("demo")
    assert w.tabs.currentWidget() is w.preview


def test_voxel_model_previews_solid_with_its_intent(qtbot, gl_display, table_size, shared_data):
    """A .vox opens on auto content: the engine picks solid, the preview says so, the source
    is sampled nearest (sharp) and its occupied voxels are opaque; fog is one choice away."""
    from dreamprint_gui.job.content import SOLID_SIGMA

    w = MainWindow(table_size=table_size)
    w.interactive = False
    qtbot.addWidget(w)
    p = w.preview
    p.set_params(height_mm=4.0)
    w.show()
    knight = shared_data / "voxels" / "magicavoxel_chr_knight.vox"
    with qtbot.waitSignal(p.preflightReady, timeout=180000):
        w.use_default_profile()
        w.open_path(knight)
    assert p.ctx.content.mode == "solid" and p.ctx.content.picked
    assert "auto: solid" in p.content_note.text() and "voxel model" in p.content_note.text()
    assert p.sampling.isEnabled() and p.params()["sampling"] is None  # the reader's: nearest
    assert getattr(p.ctx.source, "sampling", None) == "nearest"
    # the size the preview states has the digits `dreamprint inspect` gives for the same height
    from click.testing import CliRunner

    from dreamprint_gui.cli import cli

    res = CliRunner().invoke(cli, ["inspect", str(knight), "--height-mm", "4"])
    assert res.exit_code == 0, res.output
    span = res.output.split("the print is ")[1].split(" mm")[0]
    # the status line says the size once the preview has rendered (before: what it prepares)
    qtbot.waitUntil(lambda: f"print {span} mm on " in p.status.text(), timeout=120000)
    occupied = p.data.source_sigma > 0
    assert 0.01 < occupied.mean() < 0.5
    assert np.all(p.data.source_sigma[occupied] == SOLID_SIGMA)  # opaque, not a haze
    # the printed solid is far denser than the fog the same file gives
    solid_print = float(np.median(p.data.print_sigma[occupied]))
    # a render of the solid may still be on its way: wait for the fog's own data
    p.set_params(content="fog")
    qtbot.waitUntil(lambda: p.ctx.content.mode == "fog"
                    and float(p.data.source_sigma.max()) < 0.1 * SOLID_SIGMA, timeout=120000)
    assert p.ctx.content.mode == "fog" and not p.ctx.content.picked
    fog = p.data.source_sigma[p.data.source_sigma > 0]
    assert fog.max() < 0.1 * SOLID_SIGMA
    assert float(np.median(p.data.print_sigma[occupied])) < solid_print
    # the demo cloud offers no voxel-edge choice and goes back to auto
    w.open_path("demo")
    qtbot.waitUntil(lambda: not p.sampling.isEnabled() and p.ctx.source is not None
                    and "demo" in str(getattr(p.ctx.settings, "source", "")), timeout=120000)
    assert p.params()["content"] == "auto"
    assert p.ctx.content.mode == "fog"
    w.close()


def test_preflight_warning_shown_once(window, qtbot):
    """A nearly empty fog (density scale 0.01): the pre-flight's mostly-clear warning shows in
    the preview's Warnings box and nowhere else."""
    p = window.preview
    # the pre-flight of these settings, not one of the start's still on its way
    with qtbot.waitSignal(p.preflightReady, timeout=120000,
                          check_params_cb=lambda pf: pf.density_scale == 0.01):
        p.set_params(density_scale=0.01)
    codes = [wn.code for wn in p.preflight.warnings]
    assert "mostly-clear" in codes, codes
    assert p.warnings_box.isVisible()
    where = _texts_showing("Clear or empty")
    assert where == ["label in MainWindow"], where
    assert "--density-scale" not in p.warnings.text()  # named as the control is
    with qtbot.waitSignal(p.preflightReady, timeout=120000,
                          check_params_cb=lambda pf: pf.density_scale == 1.0):
        p.set_params(density_scale=1.0)
    assert "mostly-clear" not in [wn.code for wn in p.preflight.warnings]


def test_the_first_preview_shows_progress(qtbot, gl_display, table_size, monkeypatch):
    """Preparing the job (opening the source, the colour tables, the halftone mask, the
    kernels: minutes on a first start) is said with its estimate made before it starts
    (job.prepare_time), its seconds counting and a busy bar; then the prediction's
    percentage; the bar goes once the preview is shown."""
    import time

    from dreamprint_gui.job import plan

    real = plan.prepare_job

    def slow_prepare(settings, notify=None):  # stands in for a first start's builds
        time.sleep(2.5)
        return real(settings, notify)

    monkeypatch.setattr(plan, "prepare_job", slow_prepare)
    w = MainWindow(table_size=table_size)
    w.interactive = False
    qtbot.addWidget(w)
    p = w.preview
    p.set_params(height_mm=4.0)
    w.show()
    from PySide6.QtCore import QTimer

    seen: list[str] = []
    watch = QTimer(interval=100)
    watch.timeout.connect(lambda: seen.append(p.view.message.text()))
    watch.start()
    w.use_default_profile()
    w.open_path("demo")
    # the estimate in core.durations' words: "about 3 s", or "under 1 s" on a quick machine
    estimated = re.compile(r"preparing demo: (about [\d.]+ (s|min)|under 1 s) \(the source"
                           r"[^;]* (about [\d.]+ s|under 1 s)")
    qtbot.waitUntil(lambda: "preparing demo: " in p.view.message.text()
                    and "opening it" not in p.view.message.text(), timeout=120000)
    assert p.busy.isVisible() and p.busy.maximum() == 0   # busy: no fraction to tell yet
    qtbot.waitUntil(lambda: " 2 s" in p.view.message.text(), timeout=10000)  # seconds count
    with qtbot.waitSignal(w.ready, timeout=180000):
        pass
    watch.stop()
    assert not p.busy.isVisible()
    assert any("preparing demo" in m and " 1 s" in m for m in seen)
    # the estimate made before it started, and its parts
    assert any(estimated.search(m) for m in seen), seen[:3]
    assert any("predicting the print" in m and "%" in m for m in seen), seen[-5:]
    w.close()


def test_the_tables_compile_is_said_while_the_window_waits(qtbot, gl_display, table_size,
                                                          monkeypatch):
    """A first build's kernel compile (gamut.get_tables' notify: 'compiling the colour kernels
    ...', issue 46) reaches the window's waiting line, as the build's percentage does."""
    import dreamprint_gui.gamut as gamut

    real = gamut.get_tables

    def first_use(*a, notify=None, **k):          # stands in for a cold kernel cache
        assert notify is not None                  # the window passes it
        notify("compiling the colour kernels: first run after an install or upgrade, about "
               "16 s; cached after")
        return real(*a, notify=notify, **k)

    monkeypatch.setattr(gamut, "get_tables", first_use)
    w = MainWindow(table_size=table_size)
    w.interactive = False
    qtbot.addWidget(w)
    said: list[str] = []
    monkeypatch.setattr(w, "_say_waiting", said.append)
    w.use_default_profile()
    qtbot.waitUntil(lambda: w.tables is not None, timeout=120000)
    assert any(m.startswith("compiling the colour kernels: first run") for m in said), said
    w.close()
