"""Screenshots of the calibration wizard's slab page and its fit (issue 43), at 1280 x 800.

    xvfb-run -a -s "-screen 0 1280x800x24" .venv/bin/python scripts/wizard_slab_screenshots.py

A Clear thickness series of real instrument files, one row (file and sample) per slab: the
reflectance of each slab from the X-Rite Spectrolino export (its samples X1, X2, X3 at 1, 2 and
4 mm) and the transmittance from the clear photopolymer resin's absorbance file (stated as
absorbance), from ../shared/data/spectra/formats. Writes docs/screenshots/wizard-slabs.png
(the slab page) and wizard-slabs-fit.png (the fit, k2 fitted).
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

SERIES = ((1.0, "X1"), (2.0, "X2"), (4.0, "X3"))


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("--out", default=str(ROOT / "docs" / "screenshots"))
    ap.add_argument("--size", default="1280x800")
    args = ap.parse_args()
    out = Path(args.out)
    os.environ["DREAMPRINT_SETTINGS"] = str(Path(tempfile.mkdtemp()) / "settings.ini")
    from PySide6.QtCore import QEventLoop, QTimer
    from PySide6.QtWidgets import QApplication

    app = QApplication([sys.argv[0]])
    app.setApplicationName("DreamPrint")
    from dreamprint_gui.core.profile import default_profile
    from dreamprint_gui.gui.app import grab_window
    from dreamprint_gui.gui.wizard.calibration import CalibrationWizard

    def settle(ms=1200) -> None:
        loop = QEventLoop()
        QTimer.singleShot(ms, loop.quit)
        loop.exec()

    formats = DATA / "spectra" / "formats"
    wiz = CalibrationWizard(None, base_profile=default_profile())
    wiz.move(0, 0)
    wiz.resize(*(int(v) for v in args.size.split("x")))
    wiz.show()
    page = wiz.measurements_page
    rows = [page.rows["Cl"]] + [page.add_row("Cl") for _ in SERIES[1:]]
    for row, (t, sample) in zip(rows, SERIES, strict=True):
        row.thickness.setValue(t)
        row.load("R", str(formats / "X-Rite_Digital_Colour_Checker.txt"), sample=sample)
        row.set_file_quantity("T", "absorbance")
        row.load("T", str(formats / "resin_PR48_absorbance_2015-07-27.csv"))
    page.slabs_box.setChecked(True)
    wiz.next()
    wiz.slab_page.fit_k2.setChecked(True)
    settle()
    grab_window(wiz, str(out / "wizard-slabs.png"))
    wiz.next()
    wiz.next()
    loop = QEventLoop()
    wiz.fit_page.fitted.connect(loop.quit)
    QTimer.singleShot(300_000, loop.quit)
    loop.exec()
    settle()
    grab_window(wiz, str(out / "wizard-slabs-fit.png"))
    print(wiz.fit_page.status.text())
    wiz.close()
    app.processEvents()
    print("screenshots in", out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
