"""The gamut page renders and answers the colour picker; the export dialog runs the engine's
conversion with progress, can be cancelled, and leaves nothing behind."""

from __future__ import annotations

import numpy as np
import pytest

from dreamprint_gui.core.printer import PRINTER_NAMES, load_printer
from dreamprint_gui.core.profile import INKS, default_profile
from dreamprint_gui.gamut import get_tables
from dreamprint_gui.gui.export import ExportDialog
from dreamprint_gui.gui.gamut_view import GamutPage
from dreamprint_gui.gui.volume_view import frame_statistics
from dreamprint_gui.physics.mixture import predict


@pytest.fixture(scope="module")
def job_profile(table_size):
    p = default_profile().with_settings(
        layer_thickness_mm=load_printer("j850-paper").layer_thickness_mm)
    return p


def test_gamut_page(qtbot, gl_display, job_profile, table_size):
    page = GamutPage()
    qtbot.addWidget(page)
    page.resize(1200, 700)
    page.show()
    with qtbot.waitSignal(page.rendered, timeout=60000):
        page.set_profile(job_profile)
    img = page.plotter.screenshot(return_img=True)
    h, w = img.shape[:2]
    for half in (img[:, : w // 2], img[:, w // 2:]):
        assert frame_statistics(half)["non_background_fraction"] > 0.05
    # the printable gamut lies inside the lightness range of paper white and black ink
    lab_l = page.meshes[0].points_ab_l[:, 2]
    assert 0 <= lab_l.min() < 40 and 60 < lab_l.max() <= 100.5

    with qtbot.waitSignal(page.chartReady, timeout=120000):
        page.set_tables(get_tables(job_profile, size=table_size))
    assert page.chart_image is not None and not page.chart_image.isNull()
    # a printable grey on a table node (153/255 = 9/15 with 16 nodes per axis): the table's
    # own optimum, reproduced closely
    assert (table_size - 1) * 153 % 255 == 0
    page.set_colour((0.6, 0.6, 0.6))
    pick = page.last_pick
    assert abs(sum(pick["concentrations"].values()) - 1) < 1e-5
    assert pick["dE2000"] < 0.5
    ink_white = np.clip(predict(job_profile, np.eye(len(INKS))[INKS.index("W")]).sRGB, 0, 1)
    assert min(ink_white) > 0.6  # the grey is darker than white ink: inside the gamut
    assert f"{pick['dE2000']:.2f}" in page.de_label.text()
    # the 3D views name their axes as CIELAB does
    for i in (0, 1):
        actor = page.plotter.renderers[i].axes_actor
        assert (actor.GetXAxisLabelText(), actor.GetYAxisLabelText(),
                actor.GetZAxisLabelText()) == ("a*", "b*", "L*")
    _picker_matches_the_cli(qtbot, page, job_profile, table_size)

    # the page offers every intent the command line has (gamut.mapping.INTENTS)
    from dreamprint_gui.gamut.mapping import INTENTS

    assert [page.intent.itemData(i) for i in range(page.intent.count())] == list(INTENTS)
    # the perceptual intent: the chart and the picker show its mapping (source -> printed)
    page.set_colour((0.0, 0.0, 1.0))  # sRGB blue, far outside the printable gamut
    clipped = page.last_pick
    with qtbot.waitSignal(page.chartReady, timeout=180000):
        page.set_intent("perceptual")
    assert page.tables.intent == "perceptual" and "perceptual" in page.repro_title.text()
    page.set_colour((0.0, 0.0, 1.0))
    mapped = page.last_pick
    assert (mapped["intent"], clipped["intent"]) == ("perceptual", "colorimetric")
    assert mapped["sRGB"] != clipped["sRGB"]
    hue = [np.degrees(np.arctan2(p["Lab"][2], p["Lab"][1])) for p in (mapped, clipped)]
    src_hue = np.degrees(np.arctan2(mapped["target_Lab"][2], mapped["target_Lab"][1]))
    # perceptual keeps the (CAM16-UCS) hue of the source: closer to it in CIELAB than clipping
    assert abs(hue[0] - src_hue) < abs(hue[1] - src_hue) + 1.0


def _picker_matches_the_cli(qtbot, page, profile, table_size) -> None:
    """The picker takes sRGB on the CLI's 0-1 scale and shows the six inks `dreamprint lookup`
    reports for that colour and density, Clear included, each share beside its bar."""
    import json
    import tempfile
    from pathlib import Path

    from click.testing import CliRunner

    from dreamprint_gui.cli import cli
    from dreamprint_gui.core.profile import save_profile

    assert [s.maximum() for s in page.spins] == [1.0, 1.0, 1.0]
    assert "0 to 1" in page.rgb_scale.text() and "lookup --rgb" in page.rgb_scale.text()
    assert list(page.bars) == list(INKS)           # Clear has its bar
    page.spins[0].setValue(0.2)
    page.spins[1].setValue(0.45)
    page.spins[2].setValue(0.7)
    page.density.setText("2.5")
    page.density.editingFinished.emit()
    gui = page.last_pick["aligned"]
    with tempfile.TemporaryDirectory() as d:
        prof_path = Path(d) / "p.json"
        save_profile(profile, prof_path)
        res = CliRunner().invoke(cli, ["lookup", "--rgb", "0.2,0.45,0.7", "--density", "2.5",
                                       "--profile", str(prof_path), "--size", str(table_size),
                                       "--printer", "j850-paper", "--json"])
    assert res.exit_code == 0, res.output
    cli_rec = json.loads(res.output)[0]
    for ink in INKS:
        assert gui[ink] == pytest.approx(cli_rec["aligned"][ink], abs=1e-6), ink
        assert page.bar_values[ink].text() == f"{100 * cli_rec['aligned'][ink]:.1f} %"
        assert page.bars[ink].value() == round(1000 * cli_rec["aligned"][ink])
        assert not page.bars[ink].isTextVisible()   # nothing drawn over the bar's chunk
    assert gui["Cl"] > 0.05                        # a thin voxel: Clear fills the rest
    page.density.setText("")
    page.density.editingFinished.emit()
    assert page.last_pick["aligned"]["Cl"] == pytest.approx(0.0, abs=1e-9)


def _dialog(qtbot, tmp_path, table_size, height_mm):
    dlg = ExportDialog(None, source_path="demo", profile_path=None, table_size=table_size,
                       preview_params={"height_mm": height_mm})
    qtbot.addWidget(dlg)
    dlg.folder.setText(str(tmp_path))
    dlg.job_name.setText("job")
    dlg.show()
    return dlg


def test_export_dialog_passes_the_rendering_intent(qtbot, tmp_path, table_size):
    dlg = _dialog(qtbot, tmp_path, table_size, 2.0)
    assert dlg.settings_for_job().intent is None  # the profile's own choice by default
    dlg.intent.setCurrentIndex(dlg.intent.findData("colorimetric"))
    assert dlg.settings_for_job().intent == "colorimetric"
    dlg.intent.setCurrentIndex(dlg.intent.findData("perceptual"))
    assert dlg.settings_for_job().intent == "perceptual"
    dlg.intent.setCurrentIndex(dlg.intent.findData("relative"))
    assert dlg.settings_for_job().intent == "relative"
    from dreamprint_gui.gamut.mapping import INTENTS

    assert [dlg.intent.itemData(i) for i in range(1, dlg.intent.count())] == list(INTENTS)


def test_intent_advice_names_the_control_and_its_choice():
    from dreamprint_gui.gui.names import gui_wording

    # the pre-flight's out-of-gamut advice, as the export dialog shows it
    said = gui_wording("they print as the nearest printable colour; --intent relative maps the "
                       "source white to the printable white")
    assert "Rendering intent: Relative maps the source white" in said and "--" not in said


def test_export_runs_with_progress_and_summary(qtbot, tmp_path, table_size):
    import time

    from dreamprint_gui.gui.export_data import time_text
    from dreamprint_gui.gui.names import gui_wording

    dlg = _dialog(qtbot, tmp_path, table_size, 2.0)
    qtbot.waitUntil(lambda: dlg.preflight is not None, timeout=120000)
    seen = []
    t0 = time.monotonic()
    dlg.start()
    dlg.task.progress.connect(seen.append)
    with qtbot.waitSignal(dlg.task.done, timeout=180000):
        pass
    qtbot.waitUntil(lambda: dlg.manifest is not None or dlg.error.text(), timeout=5000)
    waited = time.monotonic() - t0
    assert dlg.task.outcome == "succeeded", dlg.error.text()
    manifest = dlg.manifest
    nx, ny, nz = manifest["grid_dimensions"]
    assert len(list((tmp_path / "job" / "slices").glob("*.png"))) == nz
    assert (tmp_path / "job" / "manifest.json").is_file()
    assert any(p.stage == "converting" for p in seen)
    assert dlg.progress.value() == 1000
    text = dlg.summary.toPlainText()
    assert dlg.summary.isVisible() and f"{nz} slices of {nx} x {ny}" in text
    # the whole summary shows without scrolling on this (1600 x 1000) screen, every material
    # of the manifest in it, with the printer's and the background's human names
    qtbot.wait(50)
    assert dlg.summary.verticalScrollBar().maximum() == 0, dlg.summary.height()
    assert dlg.summary.horizontalScrollBar().maximum() == 0
    for lab, info in manifest["labels"].items():
        assert info["material"] in text, lab
    assert PRINTER_NAMES["voxelprint-27um"] in text and "voxelprint-27um" not in text
    assert "Clear resin" in text
    assert manifest["printer"]["name"] == "voxelprint-27um"  # the default; the id stays in the file
    # the time is the job's as the operator waited for it: the dialog's clock from Export to
    # the finished job, which holds the manifest's own total (begun later, ended earlier)
    t = manifest["timings_s"]
    assert t["total"] <= dlg.elapsed_s <= waited
    assert time_text(t, dlg.elapsed_s) in text
    assert f"{dlg.elapsed_s:.1f} s from Export to the finished job" in text
    assert f"converting {t['convert']:.1f} s" in text
    # the pre-flight the dialog showed is the one the manifest records, warnings in the summary
    assert manifest["preflight"]["material_fractions"] == dlg.preflight.fractions
    for w in manifest["preflight"]["warnings"]:
        assert gui_wording(w["message"]) in text


def test_export_cancel_leaves_nothing(qtbot, tmp_path, table_size):
    dlg = _dialog(qtbot, tmp_path, table_size, 30.0)  # big enough to be cancelled mid-way
    cancelled = []

    def on_progress(p):
        if p.stage == "converting" and not cancelled:
            cancelled.append(True)
            dlg.cancel_button.click()

    dlg.start()
    dlg.task.progress.connect(on_progress)
    with qtbot.waitSignal(dlg.task.done, timeout=180000):
        pass
    assert cancelled and dlg.task.outcome == "cancelled", dlg.error.text()
    qtbot.waitUntil(lambda: "cancelled" in dlg.remaining.text(), timeout=5000)
    assert not (tmp_path / "job").exists()
    assert list(tmp_path.iterdir()) == []  # no temporary folder left beside the target
    assert dlg.start_button.isEnabled()  # the operator can try again


def test_export_workers_and_scheduler(qtbot, tmp_path, table_size):
    """Worker count and scheduler reach the engine's settings, persist, and a bad cluster
    address is reported inline."""
    from dreamprint_gui.gui.export_data import check_scheduler_address
    from dreamprint_gui.gui.settings import AppSettings

    settings = AppSettings()
    dlg = ExportDialog(None, source_path="demo", profile_path=None, table_size=table_size,
                       preview_params={"height_mm": 2.0}, settings=settings)
    qtbot.addWidget(dlg)
    dlg.folder.setText(str(tmp_path))
    dlg.job_name.setText("job")
    assert dlg.workers.value() == 0 and dlg.settings_for_job().workers is None  # all cores
    assert dlg.settings_for_job().scheduler is None  # the engine's default (threads)

    dlg.scheduler.setCurrentIndex(dlg.scheduler.findData("distributed"))
    assert not dlg.workers.isEnabled()
    dlg.scheduler_address.setText("")
    dlg.start()
    assert "address" in dlg.error.text() and dlg.task is None
    dlg.scheduler_address.setText("not an address")
    dlg.start()
    assert "not an address" in dlg.error.text() and dlg.task is None
    assert check_scheduler_address("cluster.lan:8786") == "tcp://cluster.lan:8786"
    dlg.scheduler_address.setText("tcp://10.0.0.5:8786")
    assert dlg.settings_for_job().scheduler == "tcp://10.0.0.5:8786"
    assert dlg.settings_for_job().workers is None

    dlg.scheduler.setCurrentIndex(dlg.scheduler.findData("threads"))
    dlg.workers.setValue(1)
    assert dlg.settings_for_job().workers == 1
    dlg.start()
    with qtbot.waitSignal(dlg.task.done, timeout=180000):
        pass
    assert dlg.task.outcome == "succeeded", dlg.error.text()
    assert dlg.manifest["execution"]["workers"] == 1
    assert "1 workers" in dlg.summary.toPlainText()

    again = ExportDialog(None, source_path="demo", profile_path=None, table_size=table_size,
                         settings=AppSettings())  # the choices came back from QSettings
    qtbot.addWidget(again)
    assert again.workers.value() == 1 and again.scheduler.currentData() == "threads"
    assert again.scheduler_address.text() == "tcp://10.0.0.5:8786"


def test_export_to_a_dask_cluster(qtbot, tmp_path, table_size):
    from distributed import LocalCluster

    with LocalCluster(n_workers=1, threads_per_worker=1, processes=False, protocol="tcp",
                      dashboard_address=None) as cluster:
        assert cluster.scheduler_address.startswith("tcp://")
        dlg = _dialog(qtbot, tmp_path, table_size, 2.0)
        dlg.scheduler.setCurrentIndex(dlg.scheduler.findData("distributed"))
        dlg.scheduler_address.setText(cluster.scheduler_address)
        dlg.start()
        with qtbot.waitSignal(dlg.task.done, timeout=180000):
            pass
        assert dlg.task.outcome == "succeeded", dlg.error.text()
    assert dlg.manifest["execution"]["scheduler"] == cluster.scheduler_address
    nz = dlg.manifest["grid_dimensions"][2]
    assert len(list((tmp_path / "job" / "slices").glob("*.png"))) == nz


def test_gamut_page_fits_1280x800(qtbot, gl_display, job_profile, table_size):
    """At 1280 x 800 the hexagon chart is drawn whole inside its panel, the picker says when a
    colour is out of gamut and shows what is printed instead, and the in-gamut share of sRGB
    is on screen."""
    from PySide6.QtCore import QPoint, QRect

    from dreamprint_gui.gamut.evaluation import IN_GAMUT_DE2000
    from dreamprint_gui.gui.main_window import MainWindow

    w = MainWindow(table_size=table_size)
    w.interactive = False
    qtbot.addWidget(w)
    w.resize(1280, 800)
    w.show()
    qtbot.waitExposed(w)
    page = w.gamut
    page.set_hold(False)
    w.tabs.setCurrentWidget(page)
    tables = get_tables(job_profile, size=table_size)
    with qtbot.waitSignal(page.chartReady, timeout=120000):
        page.set_profile(job_profile)
        page.set_tables(tables)
    page.pages.setCurrentIndex(1)
    qtbot.wait(50)
    chart = page.chart_view
    panel = page.pages.currentWidget()
    assert chart.isVisible() and panel is chart.parentWidget()
    drawn = chart.image_rect()
    top_left = chart.mapTo(panel, drawn.topLeft())
    box = QRect(top_left, drawn.size())
    assert not drawn.isEmpty()
    assert panel.rect().contains(box), (box, panel.rect())
    # and the panel itself is inside the window (not scrolled or clipped away)
    corner = panel.mapTo(w, QPoint(0, 0))
    assert w.rect().contains(QRect(corner, panel.size())), (corner, panel.size())
    # drawn large: the chart fills its panel along one axis
    assert drawn.width() >= 0.9 * chart.width() or drawn.height() >= 0.9 * chart.height()
    assert drawn.width() > 600  # readable at 1280 x 800 (the chart is 1320 x 924 pixels)

    # the in-gamut share, as `dreamprint gamut` computes it from the table's nodes
    expected = float(np.mean(np.asarray(tables.dE2000).ravel() <= IN_GAMUT_DE2000))
    assert 0 < expected < 1
    assert page.fraction_label.isVisible()
    assert f"{100 * expected:.0f} %" in page.fraction_label.text()

    # saturated sRGB red is outside the Vero gamut; a mid grey on a table node is inside
    page.set_colour((1.0, 0.0, 0.0))
    assert page.last_pick["dE2000"] > IN_GAMUT_DE2000
    assert "out of gamut" in page.de_label.text()
    assert f"{page.last_pick['dE2000']:.2f}" in page.de_label.text()
    printed = page.last_pick["sRGB"]
    r, g, b = (int(round(255 * max(0.0, min(1.0, c)))) for c in printed)
    assert f"rgb({r},{g},{b})" in page.repro_swatch.styleSheet()  # the mapped colour
    page.set_colour((0.6, 0.6, 0.6))
    assert "in gamut" in page.de_label.text() and "out of" not in page.de_label.text()
    w.close()


def test_export_shows_the_preflight_before_export(qtbot, tmp_path, table_size):
    """Before Export the dialog shows the engine's estimate of the job these settings make
    (grid, slices, disk, time, materials) and its warnings; it follows the settings."""
    from dreamprint_gui.gui.names import gui_wording
    from dreamprint_gui.job.preflight import preflight

    dlg = _dialog(qtbot, tmp_path, table_size, 2.0)
    qtbot.waitUntil(lambda: dlg.preflight is not None, timeout=120000)
    pf = dlg.preflight
    text = dlg.preflight_view.toPlainText()
    nx, ny, nz = pf.grid_shape
    assert f"{nx} x {ny} x {nz} voxels" in text and f"{nz:,} slices" in text
    assert "disk: about" in text and "materials (estimated" in text
    for w in pf.warnings:  # every warning of the estimate, once, options named as controls
        assert text.count(gui_wording(w.message)) == 1, w.message
        assert "--" not in gui_wording(w.message)
    assert ("No warnings" in text) == (not pf.warnings)
    assert "--" not in text  # the figures' lines too ("the Up control changes it")
    # the same figures as the engine gives for these settings (what `convert` prints)
    ref = preflight(dlg.settings_for_job())
    assert ref.grid_shape == pf.grid_shape and ref.fractions == pf.fractions
    dlg.density_scale.setValue(0.01)  # a nearly empty fog
    qtbot.waitUntil(lambda: dlg.preflight is not None and dlg.preflight.density_scale == 0.01,
                    timeout=120000)
    assert "mostly-clear" in [w.code for w in dlg.preflight.warnings]
    assert "Clear or empty" in dlg.preflight_view.toPlainText()
    assert not (tmp_path / "job").exists()  # nothing written by an estimate


def test_export_shows_the_preflight_step_under_way(qtbot, tmp_path, table_size, monkeypatch):
    """A pre-flight that takes a minute (a slow source, under load) says its step as it
    starts in the dialog, as `convert` does (issue 46)."""
    import threading

    from dreamprint_gui.job import preflight as pf_module

    release = threading.Event()
    real = pf_module.encode_slab

    def held(c, z0, z1):  # the slabs of a slow source
        release.wait(60)
        return real(c, z0, z1)

    monkeypatch.setattr(pf_module, "encode_slab", held)
    dlg = _dialog(qtbot, tmp_path, table_size, 2.0)
    qtbot.waitUntil(lambda: "pre-flight: timing the job's middle slab"
                    in dlg.preflight_view.toPlainText(), timeout=120000)
    assert dlg.preflight_view.toPlainText().startswith("estimating the job ... ")
    release.set()
    qtbot.waitUntil(lambda: dlg.preflight is not None, timeout=120000)


TINY_COMPENSATION = {"views": 1, "iterations": 1, "resolution": 24, "spp": 2, "max_cells": 12,
                     "field_cells": 6}


def test_export_compensates_appearance_first(qtbot, tmp_path, table_size):
    """"Compensate appearance": the correction is optimised, written beside the job and used
    by it; one progress bar with time left runs over both phases; the summary names it."""
    dlg = _dialog(qtbot, tmp_path, table_size, 2.0)
    dlg.compensation_options = TINY_COMPENSATION
    dlg.compensate.setChecked(True)
    seen = []
    dlg.start()
    dlg.task.progress.connect(seen.append)
    with qtbot.waitSignal(dlg.task.done, timeout=600000):
        pass
    qtbot.waitUntil(lambda: dlg.manifest is not None or dlg.error.text(), timeout=5000)
    assert dlg.task.outcome == "succeeded", dlg.error.text()
    corr = tmp_path / "job.correction.npz"
    assert corr.is_file() and (tmp_path / "job" / "manifest.json").is_file()
    comp = dlg.manifest["compensation"]
    assert comp["path"] == str(corr.absolute())
    stages = [p.stage for p in seen]
    assert "compensating" in stages and "converting" in stages
    assert stages.index("compensating") < stages.index("converting")
    fractions = [p.fraction for p in seen]
    assert fractions == sorted(fractions) and dlg.progress.value() == 1000
    assert any(p.eta_s is not None for p in seen)
    text = dlg.summary.toPlainText()
    before = comp["proof_figures"]["before"]["mean_de2000"]
    assert "Compensation" in text and "job.correction.npz" in text
    assert f"dE2000 mean {before:.2f}" in text and "optimised in" in text


def test_export_compensation_cancel_leaves_nothing(qtbot, tmp_path, table_size):
    """Cancelled once the correction is written (while converting): job and correction go."""
    dlg = _dialog(qtbot, tmp_path, table_size, 4.0)
    dlg.compensation_options = TINY_COMPENSATION
    dlg.compensate.setChecked(True)
    cancelled = []

    def on_progress(p):
        if p.stage == "converting" and not cancelled:
            # the correction is written; the placement, like every choice, is locked
            cancelled.append((tmp_path / "job.correction.npz").is_file()
                             and not dlg.up.isEnabled() and not dlg.compensate.isEnabled())
            dlg.cancel_button.click()

    dlg.start()
    dlg.task.progress.connect(on_progress)
    with qtbot.waitSignal(dlg.task.done, timeout=600000):
        pass
    assert cancelled == [True] and dlg.task.outcome == "cancelled", dlg.error.text()
    qtbot.waitUntil(lambda: "cancelled" in dlg.remaining.text(), timeout=5000)
    assert list(tmp_path.iterdir()) == []
    assert dlg.start_button.isEnabled() and dlg.compensate.isEnabled()


def _interrupted_export(settings, layers):
    """Leave the folder an export interrupted after ``layers`` layers leaves (its process gone:
    renamed to a pid above Linux's pid_max)."""
    from dataclasses import replace

    from dreamprint_gui.job.run import run_conversion

    gen = run_conversion(replace(settings, workers=1, slab_layers=2, scheduler="sync"),
                         preflight=False)
    with pytest.raises(KeyboardInterrupt):
        for p in gen:
            if p.stage == "converting" and p.layers_done >= layers:
                gen.throw(KeyboardInterrupt())
    out = settings.output
    [kept] = [p for p in out.parent.iterdir() if p.name.startswith(f".{out.name}.partial-")]
    kept.rename(kept.with_name(f".{out.name}.partial-4194400-0"))


def test_export_offers_to_resume_an_interrupted_export(qtbot, tmp_path, table_size):
    import hashlib
    from dataclasses import replace
    from pathlib import Path

    from dreamprint_gui.job.run import run_conversion

    dlg = _dialog(qtbot, tmp_path, table_size, 2.0)
    settings = replace(dlg.settings_for_job(), output=Path(dlg.target_path()))
    _interrupted_export(settings, 20)
    asked = []
    dlg.ask_resume = lambda name, done, total: asked.append((name, done, total)) or None
    dlg.start()  # the operator cancels the question: nothing starts, nothing is touched
    assert asked and asked[0][0] == "job" and 20 <= asked[0][1] < asked[0][2]
    assert dlg.task is None and dlg.start_button.isEnabled()
    dlg.ask_resume = lambda name, done, total: "resume"
    dlg.start()
    with qtbot.waitSignal(dlg.task.done, timeout=180000):
        pass
    assert dlg.task.outcome == "succeeded", dlg.error.text()
    assert dlg.manifest["execution"]["resumed_layers"] == asked[0][1]
    ref = tmp_path / "ref"
    for _ in run_conversion(replace(settings, output=ref), preflight=False):
        pass

    def digests(job):
        return [hashlib.sha256(p.read_bytes()).hexdigest()
                for p in sorted((job / "slices").iterdir())]

    assert digests(tmp_path / "job") == digests(ref)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["job", "ref"]


def test_export_can_start_an_interrupted_export_again(qtbot, tmp_path, table_size):
    from dataclasses import replace
    from pathlib import Path

    dlg = _dialog(qtbot, tmp_path, table_size, 2.0)
    settings = replace(dlg.settings_for_job(), output=Path(dlg.target_path()))
    _interrupted_export(settings, 10)
    dlg.ask_resume = lambda name, done, total: "restart"
    dlg.start()
    with qtbot.waitSignal(dlg.task.done, timeout=180000):
        pass
    assert dlg.task.outcome == "succeeded", dlg.error.text()
    assert dlg.manifest["execution"]["resumed_layers"] == 0
    assert [p.name for p in tmp_path.iterdir()] == ["job"]


def test_an_export_interrupted_in_this_session_is_offered_to_resume(qtbot, tmp_path,
                                                                     table_size, monkeypatch):
    """A lost cluster stops an export: the message says to Export again, and Export again
    (the application still running) offers to resume and finishes the missing layers."""
    import time
    from pathlib import Path

    import dreamprint_gui.job.run as run
    from dreamprint_gui.job.write import JobInterrupted

    real = run.run_slab

    def lost_at_the_last_slab(ctx, z0, z1, *args, **kw):
        nz = ctx.shape_xyz[2]
        if z1 == nz:  # once the other thread has recorded every other slab (any order)
            records = Path(args[0]).parent / "slabs"
            deadline = time.time() + 60
            while len(list(records.glob("*.json"))) < (nz - 1) // 2 and time.time() < deadline:
                time.sleep(0.02)
            raise JobInterrupted("lost the Dask scheduler at tcp://x:8786; the finished layers "
                                 "are kept: run the same command with --resume")
        return real(ctx, z0, z1, *args, **kw)

    dlg = _dialog(qtbot, tmp_path, table_size, 2.0)
    dlg.workers.setValue(2)
    with monkeypatch.context() as m:
        m.setattr(run, "run_slab", lost_at_the_last_slab)
        m.setattr(run, "slab_plan", lambda ctx, workers: [
            (z, min(z + 2, ctx.shape_xyz[2])) for z in range(0, ctx.shape_xyz[2], 2)])
        dlg.start()
        with qtbot.waitSignal(dlg.task.done, timeout=180000):
            pass
    assert dlg.task.outcome != "succeeded"
    assert "Export again to resume" in dlg.error.text(), dlg.error.text()
    asked = []
    dlg.ask_resume = lambda name, done, total: asked.append((done, total)) or "resume"
    dlg.start()
    with qtbot.waitSignal(dlg.task.done, timeout=180000):
        pass
    assert dlg.task.outcome == "succeeded", dlg.error.text()
    done, total = asked[0]
    assert dlg.manifest["execution"]["resumed_layers"] == done == 2 * ((total - 1) // 2)
    assert [p.name for p in tmp_path.iterdir()] == ["job"]
