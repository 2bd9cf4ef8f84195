"""The Print proof page renders in the background, shows three images and the figures."""

import numpy as np

from dreamprint_gui.gui.proof_view import ProofPage
from dreamprint_gui.job.plan import ConvertSettings


def _page(qtbot, table_size):
    js = ConvertSettings(source="demo", height_mm=3.0, table_size=table_size)
    page = ProofPage(job_settings=lambda: js)
    qtbot.addWidget(page)
    page.views.setValue(1)
    page.resolution.setValue(32)
    page.spp.setValue(4)
    page.cells.setValue(16)
    return page


def test_proof_page_renders_and_shows_pixels(qtbot, table_size):
    page = _page(qtbot, table_size)
    with qtbot.waitSignal(page.finished, timeout=600_000) as sig:
        page.render_button.click()
    assert sig.args == ["succeeded"], page.status.text()
    src, prn, de = page.view_rgb
    assert src.shape == prn.shape == (32, 32, 3)
    # corners show the white environment; the object darkens the middle of both images
    assert src[0, 0].min() >= 250 and prn[0, 0].min() >= 240
    mid = slice(12, 20)
    assert src[mid, mid].mean() < 245 and prn[mid, mid].mean() < 245
    assert not page.image_labels[1].pixmap().isNull()
    assert "dE2000" in page.figures.text()
    assert "S-CIELAB" in page.figures.text() and "noise floor" in page.figures.text()
    assert page.render_button.isEnabled() and not page.cancel_button.isEnabled()


def test_proof_page_cancel(qtbot, table_size):
    page = _page(qtbot, table_size)
    page.task_progress = []
    with qtbot.waitSignal(page.finished, timeout=600_000) as sig:
        page.render_button.click()
        page.cancel_button.click()
    assert sig.args == ["cancelled"]
    assert page.result is None and page.render_button.isEnabled()


def test_proof_page_without_source(qtbot):
    page = ProofPage(job_settings=lambda: None)
    qtbot.addWidget(page)
    page.render_button.click()
    assert "Open a source" in page.status.text() and page.task is None
    assert np is not None
