"""Start-up stays responsive: the window is built without the 3D stack (imported later on a
worker), volumes open on a worker and report problems by signal, the gamut page waits while
held, and the preview's prediction runs in chunks that report progress and stop on cancel."""

from __future__ import annotations

import os
import subprocess
import sys
import threading

import numpy as np
import pytest

from dreamprint_gui.core.printer import DEFAULT_PRINTER, load_printer
from dreamprint_gui.core.profile import default_profile
from dreamprint_gui.gamut import get_tables, predicted_appearance
from dreamprint_gui.gui import preview_data
from dreamprint_gui.gui.export_data import convert_settings
from dreamprint_gui.gui.preview_data import PreviewCancelled, compute_preview, job_context


def test_window_is_built_without_the_3d_stack(tmp_path):
    code = (
        "import sys\n"
        "from PySide6.QtWidgets import QApplication\n"
        "app = QApplication([])\n"
        "from dreamprint_gui.gui.main_window import MainWindow\n"
        "w = MainWindow()\n"
        "w.show(); app.processEvents()\n"
        "heavy = sorted(m for m in ('vtk', 'pyvista', 'pyvistaqt', 'colour', 'numba')\n"
        "               if m in sys.modules)\n"
        "print('HEAVY', heavy, w.preview.view.has_plotter, w.gamut.view.has_plotter)\n"
    )
    env = dict(os.environ, QT_QPA_PLATFORM="offscreen",
               DREAMPRINT_SETTINGS=str(tmp_path / "s.ini"),
               DREAMPRINT_LOG_DIR=str(tmp_path / "log"))
    r = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True,
                       timeout=120)
    assert r.returncode == 0, r.stderr[-2000:]
    assert "HEAVY [] False False" in r.stdout, r.stdout


@pytest.fixture(scope="module")
def preview_inputs(table_size):
    printer = load_printer(DEFAULT_PRINTER)
    settings = convert_settings("demo", None, printer, height_mm=10.0, density_scale=1.0,
                                background="clear", output=None, table_size=table_size)
    ctx = job_context(settings)
    profile = default_profile().with_settings(layer_thickness_mm=printer.layer_thickness_mm)
    return ctx, profile


def test_chunked_prediction_reports_progress_and_matches_one_call(preview_inputs, monkeypatch):
    ctx, profile = preview_inputs
    monkeypatch.setattr(preview_data, "PREDICT_CHUNK", 1000)  # many chunks on a small grid
    seen: list[float] = []
    data = compute_preview(ctx, profile, n=32, progress=seen.append)
    assert len(seen) > 3 and seen == sorted(seen) and seen[-1] == pytest.approx(1.0)
    inside = data.source_sigma >= ctx.halftoner.threshold
    assert inside.sum() > 1000
    # every voxel is a pure function of its inputs: chunks change nothing
    rgb, sigma = predicted_appearance(ctx.tables, profile, data.source_rgb[inside],
                                      data.source_sigma[inside])
    np.testing.assert_allclose(data.print_rgb[inside], np.clip(rgb, 0, 1), atol=1e-6)
    np.testing.assert_allclose(data.print_sigma[inside], sigma, rtol=1e-6)


def test_cancelled_prediction_stops(preview_inputs, monkeypatch):
    ctx, profile = preview_inputs
    monkeypatch.setattr(preview_data, "PREDICT_CHUNK", 500)
    cancel = threading.Event()
    seen: list[float] = []

    def progress(f: float) -> None:
        seen.append(f)
        if len(seen) == 2:  # after the sampling and the first chunks
            cancel.set()

    with pytest.raises(PreviewCancelled):
        compute_preview(ctx, profile, n=32, progress=progress, cancel=cancel)
    assert seen[-1] < 1.0


def test_volume_opens_on_a_worker_and_reports_problems(qtbot, tmp_path, table_size):
    from dreamprint_gui.gui.main_window import MainWindow

    w = MainWindow(table_size=table_size)
    w.interactive = False
    qtbot.addWidget(w)
    with qtbot.waitSignal(w.sourceChanged, timeout=60000):
        assert w.open_path("demo") is True
    assert w.source_path == "demo"
    bad = tmp_path / "broken.vti"
    bad.write_text("not a vti file")
    with qtbot.waitSignal(w.openFailed, timeout=60000) as blocker:
        assert w.open_path(str(bad)) is True  # started; the problem comes by signal
    path, message = blocker.args
    assert path == str(bad) and "broken.vti" in message
    assert w.source_path == "demo"  # the open source stays
    assert str(bad) not in w.settings.recent_files()
    assert "broken.vti" in w.statusBar().currentMessage()


def test_held_gamut_page_waits(qtbot, table_size):
    from dreamprint_gui.gui.gamut_view import GamutPage

    page = GamutPage()
    qtbot.addWidget(page)
    page.set_hold(True)
    profile = default_profile().with_settings(
        layer_thickness_mm=load_printer(DEFAULT_PRINTER).layer_thickness_mm)
    page.set_profile(profile)
    page.set_tables(get_tables(profile, size=table_size))
    assert page._task is None and page._chart_task is None  # nothing started while held
    assert "once the preview is ready" in page.view.message.text()
    with qtbot.waitSignal(page.chartReady, timeout=120000):
        page.set_hold(False)  # hidden: meshes are computed, not drawn
    qtbot.waitUntil(lambda: page.meshes is not None, timeout=60000)
    assert not page.view.has_plotter and page.last_pick is not None
