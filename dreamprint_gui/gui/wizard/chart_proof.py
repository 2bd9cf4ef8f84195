"""The calibration wizard's chart proof page (after a chart calibration only): "how well
does the proof predict your chart".

:class:`ChartProofPage` runs the chart proof (``proof.chart``) of the fitted profile on a
worker thread (progress per render pass, Stop) and shows dE2000 mean, p95, max and worst
patches, and the measured-vs-proofed picture.
"""

from __future__ import annotations

import time

import numpy as np
from PySide6.QtCore import Qt, QTimer
from PySide6.QtWidgets import (
    QComboBox,
    QHBoxLayout,
    QLabel,
    QProgressBar,
    QPushButton,
    QSpinBox,
    QVBoxLayout,
    QWizard,
)

from dreamprint_gui.core.errors import DreamPrintError
from dreamprint_gui.gui.wizard.common import ERROR_STYLE, TaskPage
from dreamprint_gui.gui.workers import Task

__all__ = ["ChartProofPage"]


class ChartProofPage(TaskPage):
    """After a chart calibration: how well does the print proof predict your chart? Renders
    each patch with the fitted profile as ``dreamprint proof --chart`` does, on a worker
    thread (progress per render pass, Stop), and shows dE2000 against the measurements, the
    worst patches and the measured-vs-proofed picture."""

    def __init__(self, wizard: QWizard) -> None:
        super().__init__()
        self.wiz = wizard
        self.report: dict | None = None
        self.picture: np.ndarray | None = None
        self.error_text = ""
        self._task: Task | None = None
        self.setTitle("Chart proof (optional)")
        self.setSubTitle("How well does the print proof predict your chart? Each patch is "
                         "rendered with the fitted profile as the proof renders a print, and "
                         "compared with your measurement. Skip with Next.")
        from dreamprint_gui.proof.chart import GEOMETRIES

        self.geometry = QComboBox()
        self.geometry.addItems(list(GEOMETRIES))
        self.geometry.setToolTip("The instrument's geometry: d:8 (sphere, specular included) or "
                                 "45:0 (most hand-held spectrophotometers)")
        self.spp = QSpinBox(minimum=16, maximum=4096, value=256, singleStep=64)
        self.spp.setToolTip("Samples per pixel: more is less noise and longer")
        self.run_button = QPushButton("Proof the chart")
        self.run_button.clicked.connect(self.start)
        self.stop_button = QPushButton("Stop")
        self.stop_button.clicked.connect(self.stop)
        self.bar = QProgressBar(minimum=0, maximum=1)
        self.bar.setMaximumWidth(200)
        self.elapsed = QLabel("")
        row = QHBoxLayout()
        row.addWidget(QLabel("Geometry"))
        row.addWidget(self.geometry)
        row.addWidget(QLabel("Samples per pixel"))
        row.addWidget(self.spp)
        row.addWidget(self.run_button)
        row.addWidget(self.stop_button)
        row.addWidget(self.bar)
        row.addWidget(self.elapsed, 1)
        self.status = QLabel("")
        self.status.setWordWrap(True)
        self.image = QLabel("")
        self.image.setObjectName("chartProofPicture")
        self.image.setAlignment(Qt.AlignmentFlag.AlignLeft | Qt.AlignmentFlag.AlignTop)
        self.legend = QLabel("")
        lay = QVBoxLayout(self)
        lay.addLayout(row)
        lay.addWidget(self.status)
        lay.addWidget(self.legend)
        lay.addWidget(self.image, 1)
        self._t0 = 0.0
        self._detail = ""          # the pass under way, as the render's heartbeat says it
        self._clock = QTimer(self, interval=500)
        self._clock.timeout.connect(self._tick)
        self._set_running(False)

    def _set_running(self, running: bool) -> None:
        self.run_button.setEnabled(not running)
        self.stop_button.setVisible(running)
        self.bar.setVisible(running)
        self._run_clock(running)

    def _tick(self) -> None:
        self.elapsed.setText(f"rendering {time.monotonic() - self._t0:.0f} s"
                             + (f" ({self._detail})" if self._detail else ""))

    def _inputs(self):
        fit = self.wiz.fit_page.result
        chart = self.wiz.chart_page
        if fit is None or chart.recipes is None or chart.reflectance is None:
            raise DreamPrintError("no chart calibration to proof: give a mixture chart (second "
                                  "page) and fit")
        return fit[0], chart.recipes, chart.reflectance

    def start(self) -> None:
        """Render the chart with the fitted profile on a worker thread."""
        self.stop()
        self.report = self.picture = None
        self.error_text = ""
        self.image.clear()
        self.legend.setText("")
        try:
            profile, recipes, refl = self._inputs()
        except DreamPrintError as exc:
            self._failed(str(exc), "")
            return
        geometry, spp = self.geometry.currentText(), int(self.spp.value())

        def job(report, cancel):
            from dreamprint_gui.proof.chart import (
                ChartSettings,
                chart_from_arrays,
                chart_picture,
                proof_chart,
            )

            chart = chart_from_arrays(recipes, refl, profile, geometry=geometry)
            s = ChartSettings(recipes="(calibration wizard)", geometry=geometry, spp=spp)
            rep, band_R, bands = proof_chart(
                chart, s, progress=lambda d, t, detail=None: report((d, t, detail)),
                cancelled=cancel.is_set)
            return rep, chart_picture(chart, band_R, bands)

        self.status.setText("")
        self.status.setStyleSheet("")
        self.bar.setMaximum(1)
        self.bar.setValue(0)
        self._detail = ""
        self._start_task(job, "chart-proof")

    def _progress(self, item) -> None:
        """A pass done (``(done, total, None)``) or how the pass under way goes (``detail``:
        'pass 2 of 4: 12 s, about 8 s left', every ``core.progress.HEARTBEAT_S`` s)."""
        done, total, detail = item
        self.bar.setMaximum(int(total))
        self.bar.setValue(int(done))
        self._detail = detail or ""
        self._tick()

    def stop(self) -> None:
        """Stop the running proof: the page is ready at once; the render ends after its
        current pass and its result is dropped."""
        self._stop_task("The chart proof was stopped.")

    def _finished(self) -> None:
        if self._task.outcome != "cancelled":
            self._set_running(False)
            self.elapsed.setText(f"rendered in {time.monotonic() - self._t0:.0f} s"
                                 if self._task.outcome == "succeeded" else "")

    def _failed(self, message: str, _tb: str) -> None:
        self.error_text = message
        self.status.setText(f"The chart proof failed: {message}")
        self.status.setStyleSheet(ERROR_STYLE)

    def _done(self, result) -> None:
        from PySide6.QtGui import QImage, QPixmap

        rep, picture = result
        self.report, self.picture = rep, picture
        de = rep["de2000"]
        worst = ", ".join(f"#{w['patch']} ({w['de2000']:.1f})" for w in de["worst_patches"])
        self.status.setText(
            f"<b>{rep['patches_count']} patches</b>, {rep['geometry']}, surface "
            f"{rep['optics']['surface']}, phase {rep['optics']['phase']}: dE2000 mean "
            f"<b>{de['mean']:.2f}</b>, p95 {de['p95']:.2f}, max {de['max']:.2f}; worst patches "
            f"{worst}.<br>The profile was fitted to these patches: this checks that the proof "
            "renders what the calibration predicts; the Fit page's cross-validated figure says "
            "how well new mixtures are predicted.")
        self.legend.setText("Each square: measured (left half), proofed (right half).")
        h, w = picture.shape[:2]
        img = QImage(np.ascontiguousarray(picture).data, w, h, 3 * w,
                     QImage.Format.Format_RGB888).copy()
        self.image.setPixmap(QPixmap.fromImage(img))

    def cleanupPage(self) -> None:  # noqa: N802 - Qt override
        self.stop()
