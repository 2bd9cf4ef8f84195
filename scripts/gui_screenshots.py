"""Screenshots of the real application for the README (docs/screenshots/).

Run under a virtual screen:  xvfb-run -a -s "-screen 0 1280x800x24" \
    .venv/bin/python scripts/gui_screenshots.py [--table-size 100]

Drives the application as an operator would: the main window on the default profile and the demo
volume (preview), the gamut page with a picked colour, the hexagon chart and an ICC export, the
print proof
tab (one small view of the demo) and its appearance compensation, a voxel model (the
sample .vox: preview, export dialog with its pre-flight, the finished job's summary), and the
calibration wizard's measurements page and its fit of a two-thickness calibration set (ink
measurements generated from the default profile with the forward model, 1 % noise, written as
instrument files, so the wizard has something real to read; the clear resin's real absorbance
file stated as absorbance).
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
DATA = Path(os.environ.get("DREAMPRINT_SAMPLE_DATA") or ROOT.parent / "shared" / "data")
sys.path.insert(0, str(ROOT))


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--out", default=str(ROOT / "docs" / "screenshots"))
    ap.add_argument("--table-size", type=int, default=None)
    ap.add_argument("--voxel-model", default=str(DATA / "voxels" / "magicavoxel_chr_knight.vox"),
                    help="a .vox for the voxel-model preview and the export dialog")
    ap.add_argument("--size", default="1280x800", help="window size WxH (default 1280x800, a "
                    "laptop screen)")
    args = ap.parse_args()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)

    # the screenshots start from default settings, and leave the operator's own untouched
    os.environ["DREAMPRINT_SETTINGS"] = str(Path(tempfile.mkdtemp()) / "settings.ini")
    from PySide6.QtCore import QEventLoop, QTimer
    from PySide6.QtWidgets import QApplication

    app = QApplication([sys.argv[0]])
    app.setApplicationName("DreamPrint")
    from dreamprint_gui.gui.app import grab_window
    from dreamprint_gui.gui.crash import install_exception_hook
    from dreamprint_gui.gui.main_window import MainWindow

    install_exception_hook(interactive=False)

    def wait(signal, timeout_s=900) -> None:
        loop = QEventLoop()
        signal.connect(loop.quit)
        QTimer.singleShot(int(timeout_s * 1000), loop.quit)
        loop.exec()

    def settle(ms=1200) -> None:
        loop = QEventLoop()
        QTimer.singleShot(ms, loop.quit)
        loop.exec()

    def wait_until(condition, timeout_s=900) -> None:
        for _ in range(int(timeout_s * 5)):
            if condition():
                return
            settle(200)

    w = MainWindow(table_size=args.table_size)
    w.interactive = False
    w.resize(*(int(v) for v in args.size.split("x")))
    w.move(0, 0)
    w.show()
    w.preview.set_params(height_mm=40.0, density_scale=1.0, background="clear")
    w.use_default_profile()
    w.open_path("demo")
    wait(w.ready)
    if w.preview.preflight is None:  # its warnings show in the side panel
        wait(w.preview.preflightReady)
    settle()
    grab_window(w, str(out / "preview.png"))

    w.tabs.setCurrentWidget(w.gamut)
    if w.gamut.chart_image is None:
        wait(w.gamut.chartReady)
    if not w.gamut.drawn:  # the page draws its 3D view once it is shown
        wait(w.gamut.rendered)
    w.gamut.set_colour((0.85, 0.35, 0.2))
    w.gamut.pages.setCurrentIndex(0)
    settle()
    grab_window(w, str(out / "gamut.png"))
    w.gamut.pages.setCurrentIndex(1)
    settle(600)
    grab_window(w, str(out / "gamut-chart.png"))
    # "Export ICC profile" (issue 48): the status line after the export, with its figures
    w.gamut.pages.setCurrentIndex(0)
    w.gamut.icc.export_to(str(Path(tempfile.mkdtemp()) / "dreamprint-j850.icc"))
    wait(w.gamut.icc.exported)
    settle()
    grab_window(w, str(out / "gamut-icc.png"))

    # the print proof tab: one small view of the demo (Mitsuba; about a minute)
    w.tabs.setCurrentWidget(w.proof)
    pp = w.proof
    pp.views.setValue(1)
    pp.resolution.setValue(96)
    pp.spp.setValue(8)
    pp.cells.setValue(48)
    pp.render()
    wait(pp.finished)
    settle()
    grab_window(w, str(out / "proof-tab.png"))
    # its Compensate appearance: 2 iterations on 3 training cameras, then both proofs
    pp.comp_iterations.setValue(2)
    pp.compensate()
    wait(pp.finished)
    settle()
    grab_window(w, str(out / "proof-compensation.png"))

    voxel = Path(args.voxel_model)
    if voxel.is_file():
        # a voxel model: solid on auto, sharp voxels; then its export, before and after
        w.tabs.setCurrentWidget(w.preview)
        w.preview.set_params(height_mm=20.0)
        w.open_path(str(voxel))
        wait(w.preview.preflightReady)
        settle(1500)
        grab_window(w, str(out / "preview-voxel.png"))
        w.preview.pages.setCurrentIndex(1)  # the printer's layers, through the knight's body
        w.preview.slice_slider.setValue(w.preview.slice_slider.maximum() * 11 // 20)
        wait_until(lambda: w.preview.shown_layer == w.preview.slice_slider.value())
        settle(600)
        w.preview.slice_view.canvas.fit()
        settle(600)
        grab_window(w, str(out / "preview-layer.png"))
        w.preview.pages.setCurrentIndex(0)

        w.preview.set_params(height_mm=8.0)  # a job that exports in seconds
        wait(w.preview.preflightReady)
        w.export_dialog()
        dlg = w._export
        dlg.folder.setText(tempfile.mkdtemp())
        dlg.move(60, 40)
        wait_until(lambda: dlg.preflight is not None)
        settle()
        grab_window(dlg, str(out / "export.png"))
        dlg.start()
        wait_until(lambda: dlg.task.outcome is not None)
        settle()
        grab_window(dlg, str(out / "export-summary.png"))
        dlg.close()
    else:
        print(f"no voxel model at {voxel}: preview-voxel.png and export*.png not taken")

    import numpy as np

    from dreamprint_gui.core.profile import INKS, default_profile
    from dreamprint_gui.gui.wizard.calibration import CalibrationWizard
    from dreamprint_gui.io.spectra import Sample, write_spectra
    from dreamprint_gui.physics.kubelka_munk import reflectance_transmittance

    prof = default_profile()
    wl = prof.wavelengths_nm
    rng = np.random.default_rng(1)
    tmp = Path(tempfile.mkdtemp())

    def noisy(x):  # a spectrophotometer's 1 % noise
        return np.clip(x * (1 + 0.01 * rng.standard_normal(wl.size)), 0, 1)

    # the measurements page: one swatch of 0.4 mm per ink in two instrument files, and the
    # clear resin's absorbance (a file that does not say what it holds) stated as absorbance
    R, T = reflectance_transmittance(prof.K, prof.S, 0.4)
    write_spectra(tmp / "inks_R.csv", [Sample(ink, wl, noisy(R[i])) for i, ink in
                                       enumerate(INKS)], quantity="reflectance", format="csv-rows")
    write_spectra(tmp / "inks_T.csv", [Sample(ink, wl, noisy(T[i])) for i, ink in
                                       enumerate(INKS)], quantity="transmittance",
                  format="csv-columns")
    wiz = CalibrationWizard(w, settings=w.settings, base_profile=prof)
    wiz.move(0, 0)
    wiz.resize(*(int(v) for v in args.size.split("x")))
    wiz.show()
    for ink in INKS[:5]:
        row = wiz.measurements_page.rows[ink]
        row.thickness.setValue(0.4)
        row.load("R", str(tmp / "inks_R.csv"))
        row.load("T", str(tmp / "inks_T.csv"))
    resin = DATA / "spectra" / "formats" / "resin_PR48_absorbance_2015-07-27.csv"
    if resin.is_file():
        row = wiz.measurements_page.rows["Cl"]
        row.set_file_quantity("T", "absorbance")
        row.load("T", str(resin))
    settle()
    grab_window(wiz, str(out / "wizard-measurements.png"))
    wiz.close()

    # the fit page: a calibration set of two thicknesses per ink, so each is held out in turn
    layers = []
    r_samples, t_samples = [], []
    for t in (0.2, 0.6):
        R, T = reflectance_transmittance(prof.K, prof.S, t)
        for i, ink in enumerate(INKS[:5]):
            name = f"{ink} {t:g} mm"
            r_samples.append(Sample(name, wl, noisy(R[i])))
            t_samples.append(Sample(name, wl, noisy(T[i])))
            layers.append(f'[[layer]]\nink = "{ink}"\nthickness_mm = {t}\n'
                          f'R = {{ file = "R.csv", sample = "{name}" }}\n'
                          f'T = {{ file = "T.csv", sample = "{name}" }}\n')
    write_spectra(tmp / "R.csv", r_samples, quantity="reflectance", format="csv-rows")
    write_spectra(tmp / "T.csv", t_samples, quantity="transmittance", format="csv-rows")
    (tmp / "set.toml").write_text('format = "dreamprint-calibration-set"\nversion = 1\n\n'
                                  + "\n".join(layers))
    wiz = CalibrationWizard(w, settings=w.settings, base_profile=prof,
                            calibration_set=str(tmp / "set.toml"))
    wiz.move(0, 0)
    wiz.resize(*(int(v) for v in args.size.split("x")))
    wiz.show()
    wiz.next()
    wiz.next()
    wait(wiz.fit_page.fitted)
    settle()
    grab_window(wiz, str(out / "wizard.png"))
    wiz.close()
    w.close()
    print("screenshots in", out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
