"""The Print proof page renders in the background, shows three images and the figures."""

import numpy as np

from dreamprint_gui.gui.proof_view import COMPENSATION_TITLES, ProofPage, compensation_text
from dreamprint_gui.job.plan import ConvertSettings
from dreamprint_gui.proof.compare import headline, inside_source, to_display


def _page(qtbot, table_size):
    js = ConvertSettings(source="demo", height_mm=3.0, table_size=table_size)
    page = ProofPage(job_settings=lambda: js)
    qtbot.addWidget(page)
    page.views.setValue(1)
    page.resolution.setValue(32)
    page.spp.setValue(4)
    page.cells.setValue(16)
    return page


def test_proof_page_proofs_the_previews_placement_and_rendering(qtbot):
    """The tab proofs the job the Preview shows and the export prints: its placement (up,
    rotate, fit) and rendering (content, objective, intent, sampling) come with the settings."""
    js = ConvertSettings(source="demo", height_mm=3.0, table_size=17, up="x", rotate=90,
                         fit="box", content="solid", objective="srgb", intent="relative",
                         sampling="linear")
    page = ProofPage(job_settings=lambda: js)
    qtbot.addWidget(page)
    ps = page.proof_settings()
    for name in ("up", "rotate", "fit", "content", "objective", "intent", "sampling"):
        assert getattr(ps, name) == getattr(js, name), name


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


def _widget_pixels(widget) -> np.ndarray:
    """The widget's rendering as an (h, w, 3) uint8 RGB array."""
    img = widget.grab().toImage().convertToFormat(widget.grab().toImage().Format.Format_RGB888)
    h, w = img.height(), img.width()
    buf = np.frombuffer(img.constBits(), np.uint8, img.bytesPerLine() * h)
    return buf.reshape(h, img.bytesPerLine())[:, :3 * w].reshape(h, w, 3)


def test_proof_images_scale_with_the_page_and_the_de_map_has_a_colour_bar(qtbot):
    """A 32 px result fills the enlarged page (each rendered pixel a block, no smoothing);
    the colour bar runs from the heat map's colour of 0 to that of 20 dE2000."""
    from dreamprint_gui.proof.compare import DE_MAP_MAX, de_heatmap

    page = ProofPage(job_settings=lambda: None)
    qtbot.addWidget(page)
    page.resize(1280, 760)
    page.show()
    qtbot.waitExposed(page)
    src = np.zeros((32, 32, 3))
    src[:, 16:] = 1.0               # left half black, right half white
    de = np.full((32, 32), np.nan)
    de[8:24, 8:24] = 10.0
    report = {"overall": {"mean_de2000": 10.0, "p95_de2000": 10.0, "psnr_db": 20.0,
                          "mean_scielab_de2000": 4.0, "ssim": 0.5, "source_coverage": 0.25,
                          "print_coverage": 0.25},
              "viewing": {"distance_mm": 500.0}, "noise_floor": None,
              "renderer": {"variant": "scalar_rgb"}, "timings_s": {"total": 1.0}}
    page._on_result({"report": report, "images": [{"source": src, "print": src, "de2000": de}]})
    qtbot.wait(50)
    lab = page.image_labels[0]
    r = lab.image_rect()
    assert r.width() == r.height() and r.width() >= 4 * 32      # scaled up, square kept
    px = _widget_pixels(lab)
    y = r.center().y()
    # the boundary between the halves stays sharp: one rendered pixel is a block
    left, right = px[y, r.left() + 2], px[y, r.right() - 2]
    assert left.max() < 10 and right.min() > 245
    col = r.left() + r.width() // 2
    edge = px[y, col - r.width() // 32: col + r.width() // 32]
    assert ((edge.mean(axis=1) > 10) & (edge.mean(axis=1) < 245)).sum() <= 2
    # the dE map: its middle is the heat map's colour of 10
    dmap = page.image_labels[2]
    dpx = _widget_pixels(dmap)
    c = dmap.image_rect().center()
    np.testing.assert_allclose(dpx[c.y(), c.x()], de_heatmap(np.array([10.0]))[0], atol=3)
    # the colour bar: magma from 0 to DE_MAP_MAX, ticks labelled
    bar = page.colour_bar
    assert bar.isVisible() and bar.ticks[-1] == DE_MAP_MAX
    bpx = _widget_pixels(bar)
    br = bar.bar_rect()
    ends = de_heatmap(np.array([0.0, DE_MAP_MAX]))
    np.testing.assert_allclose(bpx[br.center().y(), br.left() + 2], ends[0], atol=12)
    np.testing.assert_allclose(bpx[br.center().y(), br.right() - 3], ends[1], atol=12)
    # a smaller page, smaller images
    page.resize(900, 500)
    qtbot.wait(50)
    assert page.image_labels[0].image_rect().width() < r.width()


TINY_TRAINING = {"training_views": 1, "train_resolution": 24, "train_spp": 4, "field_cells": 6}


def test_proof_page_compensates_and_shows_both_prints(qtbot, table_size):
    """Compensate appearance: source | open-loop print | compensated print of the chosen view,
    the figures of both on the page's cameras; Render proof goes back to the dE map."""
    page = _page(qtbot, table_size)
    page.compensation_options = TINY_TRAINING
    page.comp_iterations.setValue(1)
    seen = []
    with qtbot.waitSignal(page.finished, timeout=600_000) as sig:
        page.compensate_button.click()
        page.task.progress.connect(seen.append)
    assert sig.args == ["succeeded"], page.status.text()
    assert [t.text() for t in page.titles] == list(COMPENSATION_TITLES)
    src, open_loop, comp = page.view_rgb
    assert src.shape == open_loop.shape == comp.shape == (32, 32, 3)
    assert src[0, 0].min() >= 250 and open_loop[0, 0].min() >= 240 and comp[0, 0].min() >= 240
    mid = slice(12, 20)
    for im in (src, open_loop, comp):
        assert im[mid, mid].mean() < 245
    assert np.abs(open_loop.astype(int) - comp.astype(int)).max() > 0  # the field acted
    # the images shown are those of the two proofs, the figures theirs
    res = page.comparison
    for key, shown in (("open_loop", open_loop), ("compensated", comp)):
        np.testing.assert_array_equal(shown, to_display(res[key]["images"][0]["print"]))
    text = page.figures.text()
    for key, name in (("open_loop", "open loop"), ("compensated", "compensated")):
        o = headline(res[key]["report"]["overall"])    # inside the source
        assert o["where"] == "inside the source"
        assert f"{name}, inside the source: dE2000 mean {o['mean_de2000']:.2f}" in text
        assert f"S-CIELAB {o['mean_scielab_de2000']:.2f}" in text
        assert f"coverage error {o['coverage_error']:+.3f}" in text
    assert not page.colour_bar.isVisibleTo(page)
    assert res["optimiser"]["settings"]["seed"] == 1  # trained on another seed than shown
    stages = [p.stage for p in seen]
    assert stages[0] == "compensating" and stages[-1] == "proof (compensated)"
    assert any(p.eta_s is not None for p in seen)
    assert page.progress.value() == page.progress.maximum() > 0
    assert page.render_button.isEnabled() and page.compensate_button.isEnabled()


def test_proof_page_compensation_cancel_leaves_nothing(qtbot, table_size, tmp_path,
                                                       monkeypatch):
    """Cancelled while the compensated proof renders (its correction in a temporary file):
    no result, no file left."""
    import tempfile

    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))
    page = _page(qtbot, table_size)
    page.compensation_options = TINY_TRAINING
    page.comp_iterations.setValue(1)
    held = []

    def on_progress(p):
        if p.stage == "proof (compensated)" and not held:
            held.append([f.name for f in tmp_path.iterdir()])
            page.cancel_button.click()

    with qtbot.waitSignal(page.finished, timeout=600_000) as sig:
        page.compensate_button.click()
        page.task.progress.connect(on_progress)
    assert sig.args == ["cancelled"]
    assert held and any(n.startswith("dreamprint-correction-") for n in held[0])
    assert list(tmp_path.iterdir()) == []
    assert page.comparison is None and page.render_button.isEnabled()
    assert page.status.text() == "cancelled"


def test_proof_page_reports_a_failed_compensation_in_one_line(qtbot, table_size):
    """A source that cannot be read: one line in the status, no traceback."""
    js = ConvertSettings(source="/nonexistent/cloud.vdb", height_mm=3.0, table_size=table_size)
    page = ProofPage(job_settings=lambda: js)
    qtbot.addWidget(page)
    with qtbot.waitSignal(page.finished, timeout=120_000) as sig:
        page.compensate_button.click()
    assert sig.args == ["failed"]
    msg = page.status.text()
    assert "cloud.vdb" in msg and "Traceback" not in msg and "\n" not in msg
    assert page.compensate_button.isEnabled()


def test_compensation_text_names_the_share_where_the_source_is_empty():
    """With a Clear block the comparison says how much of each figure lies where the source is
    empty (what no correction changes); without one it says nothing of it."""
    def overall(de, share, frac):
        o = {"mean_de2000": de, "p95_de2000": 2 * de, "mean_scielab_de2000": de / 2,
             "coverage_error": 0.1, "empty_source_fraction": frac,
             "empty_source_de2000": share, "empty_source_scielab_de2000": 2.0,
             "empty_source_coverage_error": 0.08, "inside_source_pixels": 10}
        for k in ("mean_de2000", "mean_scielab_de2000", "coverage_error"):  # as compare_view
            o[f"inside_source_{k}"] = inside_source(o, k) if frac < 1 else 0.0
        o["inside_source_p95_de2000"] = 3 * de
        o["inside_source_p95_scielab_de2000"] = de
        o["inside_source_coverage_abs_error"] = 0.1
        return o

    def result(frac):
        return {"open_loop": {"report": {"overall": overall(8.0, 5.5, frac),
                                         "gamut_floor": None}},
                "compensated": {"report": {"overall": overall(7.0, 5.4, frac)}},
                "optimiser": {"training_views": [0, 1, 2], "settings": {"seed": 1},
                              "seconds": 3.0, "figures": {"before": {"mean_de2000": 9.0},
                                                          "after": {"mean_de2000": 8.0}}}}

    text = compensation_text(result(0.8))
    assert "where the source is empty (80 % of them" in text
    assert "dE2000 5.50 -> 5.40, coverage error +0.080 -> +0.080" in text
    # the headline, inside the source: (8.0 - 5.5) / 0.2 -> (7.0 - 5.4) / 0.2; S-CIELAB
    # (4 - 2) / 0.2 -> (3.5 - 2) / 0.2; the change is the headline's
    assert "open loop, inside the source: dE2000 mean 12.50" in text
    assert "compensated, inside the source: dE2000 mean 8.00" in text
    assert "S-CIELAB 10.00" in text and "S-CIELAB 7.50" in text
    assert "change: dE2000 -36 %, S-CIELAB -25 %" in text
    assert "all object pixels: dE2000 mean 8.00 -> 7.00" in text
    assert "source is empty" not in compensation_text(result(0.0))
    assert "less the render's noise" not in text   # figures without the two halves


def test_compensation_text_gives_the_change_less_the_render_noise():
    """With the proofs' noise-corrected means the comparison gives them and their change."""
    def overall(de, nc, scielab):
        return {"inside_source_pixels": 10, "inside_source_mean_de2000": de,
                "inside_source_nc_mean_de2000": nc, "inside_source_p95_de2000": 2 * de,
                "inside_source_mean_scielab_de2000": scielab,
                "inside_source_p95_scielab_de2000": de, "inside_source_coverage_error": 0.0,
                "inside_source_coverage_abs_error": 0.0, "empty_source_fraction": 0.0}

    result = {"open_loop": {"report": {"overall": overall(8.0, 6.0, 5.0),
                                       "gamut_floor": None}},
              "compensated": {"report": {"overall": overall(7.2, 4.5, 3.0)}},
              "optimiser": {"training_views": [0], "settings": {"seed": 1}, "seconds": 3.0,
                            "figures": {"before": {"mean_de2000": 9.0},
                                        "after": {"mean_de2000": 8.0}}}}
    text = compensation_text(result)
    assert "open loop, inside the source: dE2000 mean 8.00 (6.00 less the render's noise)" \
        in text
    assert "compensated, inside the source: dE2000 mean 7.20 (4.50 less the render's noise)" \
        in text
    assert "change: dE2000 -10 % (-25 % less the render's noise), S-CIELAB -40 %" in text
    # one side without the two halves (an older report): no change less the noise
    del result["compensated"]["report"]["overall"]["inside_source_nc_mean_de2000"]
    text = compensation_text(result)
    assert "change: dE2000 -10 %, S-CIELAB -40 %" in text
    assert "open loop, inside the source: dE2000 mean 8.00 (6.00 less the render's noise)" \
        in text


def test_proof_page_shows_the_clear_at_both_bounds(qtbot, table_size):
    """A modelled Clear (the built-in profile), the box ticked: the figures name both bounds."""
    page = _page(qtbot, table_size)
    page.clear_low_bound.setChecked(True)
    assert page.proof_settings().clear_low_bound
    with qtbot.waitSignal(page.finished, timeout=600_000) as sig:
        page.render_button.click()
    assert sig.args == ["succeeded"], page.status.text()
    text = page.figures.text()
    assert "Clear modelled, not measured; at its low bound" in text
    assert "at the modelled Clear" in text and "at the low bound" in text
