"""The "Print proof" page: the print rendered physically (Mitsuba) beside the source.

Defines :class:`ProofPage`. It takes the job settings the preview would export (source, profile,
printer, height, density scale, background) from a callable, so the proof judges exactly what
the operator is about to print; Render runs :func:`dreamprint_gui.proof.runner.render_proof` on the
background worker (:mod:`.workers`) with progress and Cancel; the result shows source | print |
dE2000 map of the chosen view and the figures. Change the size, density or profile on the
preview page and press Render again. "Compensate appearance" optimises a correction through the
proof (:func:`dreamprint_gui.proof.compensated.compare_compensation`: training cameras and seed
apart from the proof's) and shows source | open-loop print | compensated print with the figures
of both, on the proof's cameras. The images scale with the page (:class:`ScaledImage`:
the aspect kept, pixels shown as blocks when enlarged) and the dE2000 map has its colour bar
(:class:`ColourBar`).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace
from typing import Any

import numpy as np
from PySide6.QtCore import QRect, QSize, Qt, Signal
from PySide6.QtGui import QImage, QPainter, QPixmap
from PySide6.QtWidgets import (
    QCheckBox,
    QComboBox,
    QFormLayout,
    QHBoxLayout,
    QLabel,
    QProgressBar,
    QPushButton,
    QSizePolicy,
    QSpinBox,
    QVBoxLayout,
    QWidget,
)

from dreamprint_gui.core.durations import clock_words
from dreamprint_gui.gui.workers import Task, generator_job, run_task

__all__ = ["ProofPage", "to_pixmap", "ScaledImage", "ColourBar", "compensation_text"]

PROOF_TITLES = ("source (emission-absorption)", "print (Mitsuba volpath)",
                "dE2000, source vs print")
COMPENSATION_TITLES = ("source (emission-absorption)", "open-loop print (paper's method)",
                       "compensated print")


def compensation_text(result: dict) -> str:
    """The figures of a compensation (:func:`..proof.compensated.compare_compensation`):
    open loop and compensated on the proof's cameras, the gamut floor, the optimiser's own."""
    from dreamprint_gui.proof.compare import EMPTY_NOTE_MIN, headline, headline_figures_text
    rows = []
    for key, name in (("open_loop", "open loop"), ("compensated", "compensated")):
        rows.append(f"{name}, {headline_figures_text(headline(result[key]['report']['overall']))}")
    a = result["open_loop"]["report"]["overall"]
    b = result["compensated"]["report"]["overall"]
    ha, hb = headline(a), headline(b)

    def change(k: str) -> str:
        return f"{100 * (hb[k] / ha[k] - 1):+.0f} %" if ha[k] > 0 else "n/a"

    # the render's noise raises both raw means alike and so shrinks their change
    nc = f" ({change('nc_mean_de2000')} less the render's noise)" \
        if "nc_mean_de2000" in ha and "nc_mean_de2000" in hb else ""
    rows.append(f"change: dE2000 {change('mean_de2000')}{nc}, "
                f"S-CIELAB {change('mean_scielab_de2000')}")
    if a.get("empty_source_fraction", 0.0) >= EMPTY_NOTE_MIN:
        rows.append(f"all object pixels: dE2000 mean {a['mean_de2000']:.2f} -> "
                    f"{b['mean_de2000']:.2f}, S-CIELAB {a['mean_scielab_de2000']:.2f} -> "
                    f"{b['mean_scielab_de2000']:.2f}; of which where the source is empty "
                    f"({100 * a['empty_source_fraction']:.0f} % of them, e.g. the Clear block; "
                    f"no correction changes it): dE2000 {a['empty_source_de2000']:.2f} -> "
                    f"{b['empty_source_de2000']:.2f}, coverage error "
                    f"{a['empty_source_coverage_error']:+.3f} -> "
                    f"{b['empty_source_coverage_error']:+.3f}")
    floor = result["open_loop"]["report"].get("gamut_floor")
    opt = result["optimiser"]
    f = opt["figures"]
    rows.append((f"gamut floor (the inks' best, no light transport): dE2000 "
                 f"{headline(floor)['mean_de2000']:.2f}; " if floor else "")
                + f"optimised on {len(opt['training_views'])} other cameras, seed "
                f"{opt['settings']['seed']}: dE2000 {headline(f['before'])['mean_de2000']:.2f} "
                f"-> {headline(f['after'])['mean_de2000']:.2f} in {opt['seconds']:.0f} s")
    return "\n".join(rows)


def to_pixmap(rgb: np.ndarray) -> QPixmap:
    """QPixmap of an (h, w, 3) uint8 image."""
    a = np.ascontiguousarray(rgb, np.uint8)
    h, w, _ = a.shape
    img = QImage(a.data, w, h, 3 * w, QImage.Format.Format_RGB888)
    return QPixmap.fromImage(img.copy())


class ScaledImage(QWidget):
    """A rendered image as large as its widget allows, aspect kept, centred.

    Enlarged, each rendered pixel is a block (no smoothing: a 192 px render is not made to look
    sharper than it is); reduced, it is filtered.
    """

    def __init__(self, parent: QWidget | None = None) -> None:
        super().__init__(parent)
        self._pixmap: QPixmap | None = None
        policy = QSizePolicy(QSizePolicy.Policy.Expanding, QSizePolicy.Policy.Preferred)
        policy.setHeightForWidth(True)  # as tall as its width makes the image: the title
        self.setSizePolicy(policy)      # above and the colour bar below stay beside it
        self.setMinimumSize(64, 64)

    def sizeHint(self) -> QSize:  # noqa: N802 - Qt override
        return QSize(320, 320)

    def hasHeightForWidth(self) -> bool:  # noqa: N802 - Qt override
        return True

    def heightForWidth(self, width: int) -> int:  # noqa: N802 - Qt override
        if self._pixmap is None or self._pixmap.isNull() or self._pixmap.width() == 0:
            return width
        return max(64, round(width * self._pixmap.height() / self._pixmap.width()))

    def setPixmap(self, pixmap: QPixmap) -> None:  # noqa: N802 - QLabel's name
        self._pixmap = pixmap
        self.updateGeometry()
        self.update()

    def pixmap(self) -> QPixmap:
        return self._pixmap if self._pixmap is not None else QPixmap()

    def image_rect(self) -> QRect:
        """Where the image is drawn, in widget coordinates (empty without an image)."""
        if self._pixmap is None or self._pixmap.isNull():
            return QRect()
        box = self.contentsRect()
        size = self._pixmap.size().scaled(box.size(), Qt.AspectRatioMode.KeepAspectRatio)
        return QRect(box.x() + (box.width() - size.width()) // 2, box.y(),
                     size.width(), size.height())

    def paintEvent(self, event) -> None:  # noqa: N802 - Qt override
        r = self.image_rect()
        if r.isEmpty():
            return
        p = QPainter(self)
        p.setRenderHint(QPainter.RenderHint.SmoothPixmapTransform,
                        r.width() < self._pixmap.width())
        p.drawPixmap(r, self._pixmap)
        p.end()


class ColourBar(QWidget):
    """The dE2000 map's scale: the heat map's colours from 0 to ``vmax``, with ticks."""

    def __init__(self, vmax: float, parent: QWidget | None = None) -> None:
        super().__init__(parent)
        from dreamprint_gui.proof.compare import de_heatmap

        self.vmax = vmax
        ramp = de_heatmap(np.linspace(0.0, vmax, 256)[None, :].repeat(2, axis=0), vmax=vmax)
        self.ramp = to_pixmap(ramp)
        self.ticks = [v for v in np.linspace(0.0, vmax, 5)]
        self.setSizePolicy(QSizePolicy.Policy.Expanding, QSizePolicy.Policy.Fixed)
        self.setFixedHeight(self.fontMetrics().height() * 2 + 16)
        self.setToolTip("dE2000 between the source and the print per pixel (CIEDE2000; about "
                        "1 is a just noticeable difference); white: no object in either image")

    def bar_rect(self) -> QRect:
        fm = self.fontMetrics()
        pad = fm.horizontalAdvance(f"{self.vmax:g}+") // 2 + 2
        return QRect(pad, 2, max(1, self.width() - 2 * pad), fm.height())

    def paintEvent(self, event) -> None:  # noqa: N802 - Qt override
        p = QPainter(self)
        r = self.bar_rect()
        p.drawPixmap(r, self.ramp)
        p.setPen(self.palette().windowText().color())
        p.drawRect(r.adjusted(0, 0, -1, -1))
        fm = self.fontMetrics()
        y = r.bottom() + 4
        for i, v in enumerate(self.ticks):
            x = r.left() + round(i / (len(self.ticks) - 1) * (r.width() - 1))
            p.drawLine(x, r.bottom() + 1, x, y)
            label = f"{v:g}" + ("+" if i == len(self.ticks) - 1 else "")
            w = fm.horizontalAdvance(label)
            p.drawText(x - w // 2, y + fm.ascent(), label)
        p.end()


class ProofPage(QWidget):
    """Render controls, progress, three images and the figures."""

    finished = Signal(str)  # "succeeded" | "failed" | "cancelled"

    def __init__(self, parent: QWidget | None = None,
                 job_settings: Callable[[], Any] | None = None) -> None:
        super().__init__(parent)
        self._job_settings = job_settings
        self.task: Task | None = None
        self.result: dict | None = None
        self.images: list[dict[str, np.ndarray]] = []

        self.views = QSpinBox(minimum=1, maximum=16, value=2)
        self.resolution = QSpinBox(minimum=16, maximum=1024, value=192, singleStep=32,
                                   suffix=" px")
        self.spp = QSpinBox(minimum=1, maximum=4096, value=64)   # runner.DEFAULT_SPP
        self.spp.setToolTip("Samples per pixel of the print render. 64 (the default) keeps the "
                            "proof's own noise floor near 0.5 S-CIELAB dE2000, so differences "
                            "above 1.5 are the print's, not the renderer's; fewer is quicker "
                            "and noisier (16: about 1.0).")
        self.method = QComboBox()
        for m in ("paper", "no-alignment", "brute-force"):
            self.method.addItem(m, m)
        self.halftone = QComboBox()
        for h in ("blue-noise", "random"):
            self.halftone.addItem(h, h)
        self.cells = QSpinBox(minimum=8, maximum=256, value=96)
        self.cells.setToolTip("Medium cells along the print's longest axis")
        self.clear_low_bound = QCheckBox("Clear at its low bound too")
        self.clear_low_bound.setToolTip(
            "When the profile's Clear is modelled (not measured): render the print once more "
            "with the Clear at its plausible low bound (K 0.002 /mm, MEASURED.md) and show the "
            "figures at both, so the share of the error that rests on the guess shows (one "
            "more print render)")
        self.comp_iterations = QSpinBox(minimum=1, maximum=20, value=4)
        self.comp_iterations.setToolTip("Render-compare-update iterations of the compensation "
                                        "(each renders the print on the training cameras)")
        self.render_button = QPushButton("Render proof")
        self.compensate_button = QPushButton("Compensate appearance")
        self.compensate_button.setToolTip(
            "Optimise a correction of the job's colours and densities through the proof "
            "(on training cameras of its own and another seed), then render the open-loop and the "
            "compensated print on this page's cameras (the paper's method; several minutes)")
        self.cancel_button = QPushButton("Cancel", enabled=False)
        self.progress = QProgressBar()
        self.status = QLabel("Render the print as a scattering medium (Mitsuba 3) beside the "
                             "source, on the preview's source, size and profile.")
        self.status.setWordWrap(True)
        self.view_pick = QSpinBox(minimum=0, maximum=0)
        self.view_pick.setPrefix("view ")
        self.view_pick.valueChanged.connect(self._show_view)
        self.image_labels = [ScaledImage() for _ in range(3)]
        self.figures = QLabel()
        self.figures.setWordWrap(True)
        self.figures.setTextInteractionFlags(Qt.TextInteractionFlag.TextSelectableByMouse)

        form = QFormLayout()
        form.addRow("Views", self.views)
        form.addRow("Resolution", self.resolution)
        form.addRow("Samples per pixel", self.spp)
        form.addRow("Method", self.method)
        form.addRow("Halftoning", self.halftone)
        form.addRow("Medium cells", self.cells)
        form.addRow("", self.clear_low_bound)
        form.addRow("Compensation iterations", self.comp_iterations)
        side = QVBoxLayout()
        side.addLayout(form)
        side.addWidget(self.render_button)
        side.addWidget(self.compensate_button)
        side.addWidget(self.cancel_button)
        side.addWidget(self.progress)
        side.addWidget(self.status)
        side.addStretch(1)
        from dreamprint_gui.proof.compare import DE_MAP_MAX

        pics = QHBoxLayout()
        self.colour_bar = ColourBar(DE_MAP_MAX)
        self.titles = [QLabel(t, alignment=Qt.AlignmentFlag.AlignCenter) for t in PROOF_TITLES]
        for k, (title, lab) in enumerate(zip(self.titles, self.image_labels, strict=True)):
            col = QVBoxLayout()
            col.addWidget(title)
            col.addWidget(lab)
            if k == 2:
                col.addWidget(self.colour_bar)
            else:  # the images stay level with the dE map above its bar
                col.addSpacing(self.colour_bar.height())
            col.addStretch(1)
            pics.addLayout(col)
        right = QVBoxLayout()
        right.addWidget(self.view_pick)
        right.addLayout(pics, 1)
        right.addWidget(self.figures)
        top = QHBoxLayout(self)
        top.addLayout(side)
        top.addLayout(right, 1)
        self.render_button.clicked.connect(lambda: self.render())
        self.compensate_button.clicked.connect(lambda: self.compensate())
        self.cancel_button.clicked.connect(self.cancel)
        self.comparison: dict | None = None  # the last compensation's result
        self.compensation_options: dict = {}  # compare_compensation's training settings

    def proof_settings(self):
        """The proof settings from the job settings and this page's controls (or None)."""
        from dreamprint_gui.proof.runner import ProofSettings

        js = self._job_settings() if self._job_settings is not None else None
        if js is None or not getattr(js, "source", None):
            return None
        spec = replace(js.spec, halftone=str(self.halftone.currentData()))
        return ProofSettings.from_spec(
            spec, views=self.views.value(), resolution=self.resolution.value(),
            spp=self.spp.value(), method=str(self.method.currentData()),
            max_cells=self.cells.value(),
            clear_low_bound=self.clear_low_bound.isChecked())

    def render(self, settings=None) -> None:
        """Start a render (of ``settings``, default :meth:`proof_settings`)."""
        from dreamprint_gui.proof.runner import render_proof

        s = settings if settings is not None else self.proof_settings()
        if s is None:
            self.status.setText("Open a source first (File > Open).")
            return
        self._start(Task(generator_job(lambda cancel: render_proof(s, cancel)), "proof"),
                    self._on_result)

    def compensate(self, settings=None) -> None:
        """Compensate the job of ``settings`` (default :meth:`proof_settings`) and show the
        open-loop and the compensated print on this page's cameras (no noise floor reported:
        two proofs already)."""
        from dataclasses import replace

        from dreamprint_gui.proof.compensated import compare_compensation

        s = settings if settings is not None else self.proof_settings()
        if s is None:
            self.status.setText("Open a source first (File > Open).")
            return
        s = replace(s, method="paper", noise_floor=False)
        n = self.comp_iterations.value()
        opts = dict(self.compensation_options)
        self._start(Task(generator_job(lambda cancel: compare_compensation(
            s, cancel, iterations=n, **opts)), "compensate"), self._on_comparison)

    def _start(self, task: Task, on_result) -> None:
        if self.task is not None:
            return
        self.render_button.setEnabled(False)
        self.compensate_button.setEnabled(False)
        self.cancel_button.setEnabled(True)
        self.progress.setRange(0, 0)
        self.status.setText("preparing ...")
        self.task = task
        self.task.progress.connect(self._on_progress)
        self.task.succeeded.connect(on_result)
        self.task.failed.connect(lambda msg, tb: self._end("failed", msg))
        self.task.cancelled.connect(lambda: self._end("cancelled", "cancelled"))
        run_task(self.task)

    def cancel(self) -> None:
        if self.task is not None:
            self.task.cancel()

    def _on_progress(self, p) -> None:
        if hasattr(p, "fraction"):  # a compensation: one bar over all its phases
            self.progress.setRange(0, 1000)
            self.progress.setValue(round(1000 * p.fraction))
            self.status.setText(f"{p.stage}: {p.message}\nelapsed "
                                f"{clock_words(p.elapsed_s)}; time left {clock_words(p.eta_s)}")
            return
        if p.total:
            self.progress.setRange(0, p.total)
            self.progress.setValue(p.done)
        self.status.setText(f"{p.stage} {p.done}/{p.total}  {p.elapsed_s:.0f} s")

    def _set_mode(self, titles: tuple[str, ...]) -> None:
        for lab, t in zip(self.titles, titles, strict=True):
            lab.setText(t)
        self.colour_bar.setVisible(titles is PROOF_TITLES)

    def _on_comparison(self, result: dict) -> None:
        self.comparison = result
        self.result = None
        self._set_mode(COMPENSATION_TITLES)
        ol, co = result["open_loop"]["images"], result["compensated"]["images"]
        self.images = [{"source": a["source"], "open_loop": a["print"], "compensated": b["print"]}
                       for a, b in zip(ol, co, strict=True)]
        self.view_pick.setMaximum(len(self.images) - 1)
        self._show_view(self.view_pick.value())
        self.figures.setText(compensation_text(result))
        self._end("succeeded", "done: open loop and compensated on this page's cameras")

    def _on_result(self, result: dict) -> None:
        from dreamprint_gui.proof.clear_report import clear_lines
        from dreamprint_gui.proof.compare import empty_source_note, headline, noise_corrected_text

        self.comparison = None
        self._set_mode(PROOF_TITLES)
        self.result = result["report"]
        self.images = result["images"]
        self.view_pick.setMaximum(len(self.images) - 1)
        self._show_view(self.view_pick.value())
        o = self.result["overall"]
        f = self.result.get("noise_floor")
        floor = (f"; noise floor (halves at seeds {f['seeds'][0]}, {f['seeds'][1]}): dE2000 "
                 f"{f['mean_de2000']:.2f}, S-CIELAB {f['mean_scielab_de2000']:.2f}" if f else "")
        h = headline(o)
        self.figures.setText(
            f"{h['where']}: dE2000 mean {h['mean_de2000']:.2f}{noise_corrected_text(h)}, "
            f"p95 {h['p95_de2000']:.2f}; "
            f"S-CIELAB dE2000 mean {h['mean_scielab_de2000']:.2f} at "
            f"{self.result['viewing']['distance_mm']:g} mm; coverage error "
            f"{h['coverage_error']:+.3f}\n"
            f"all object pixels: dE2000 mean {o['mean_de2000']:.2f}, p95 {o['p95_de2000']:.2f}; "
            f"S-CIELAB dE2000 mean {o['mean_scielab_de2000']:.2f}{floor}; PSNR "
            f"{o['psnr_db']:.1f} dB; "
            f"SSIM {o['ssim']:.3f}; coverage "
            f"{o['source_coverage']:.3f} (source) -> {o['print_coverage']:.3f} (print); "
            f"{self.result['renderer']['variant']}, {self.result['timings_s']['total']:.0f} s"
            + (f"; {note}" if (note := empty_source_note(o)) else "")
            + "".join(f"\n{line.strip()}" for line in clear_lines(self.result.get("clear"))))
        self._end("succeeded", "done")

    def _show_view(self, i: int) -> None:
        from dreamprint_gui.proof.compare import de_heatmap, to_display

        if not self.images or not 0 <= i < len(self.images):
            return
        im = self.images[i]
        if "compensated" in im:
            self.view_rgb = [to_display(im[k]) for k in ("source", "open_loop", "compensated")]
        else:
            self.view_rgb = [to_display(im["source"]), to_display(im["print"]),
                             de_heatmap(im["de2000"])]
        for lab, rgb in zip(self.image_labels, self.view_rgb, strict=True):
            lab.setPixmap(to_pixmap(rgb))

    def _end(self, outcome: str, message: str) -> None:
        self.task = None
        self.render_button.setEnabled(True)
        self.compensate_button.setEnabled(True)
        self.cancel_button.setEnabled(False)
        self.progress.setRange(0, 1)
        self.progress.setValue(1 if outcome == "succeeded" else 0)
        self.status.setText(message)
        self.finished.emit(outcome)
