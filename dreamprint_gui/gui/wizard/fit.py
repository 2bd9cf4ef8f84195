"""The calibration wizard's fit page: ``calibration.calibrate_profile`` (and
``chart_calibration.fit_chart``) on a worker thread.

:class:`FitPage` shows the stage and the elapsed time, with a Stop button that returns the
page at once (the fit has no cancel token: it is abandoned, ``workers.abandonable``, and its
result dropped); then a table of what can be checked per ink (with several thicknesses, the
held-out R/T error of ``calibration.leave_one_thickness_out``; with one R/T pair, that the
fit is exact by construction), and plots: measured vs fitted R and T, the fitted K and S, the
held-out and residual error per wavelength, the chart's cross-validated dE2000.
"""

from __future__ import annotations

import time

import numpy as np
from PySide6.QtCore import QTimer, Signal
from PySide6.QtWidgets import (
    QHBoxLayout,
    QLabel,
    QProgressBar,
    QPushButton,
    QTabWidget,
    QVBoxLayout,
    QWizard,
)

from dreamprint_gui.core.errors import DreamPrintError
from dreamprint_gui.core.profile import INKS
from dreamprint_gui.gui.wizard.common import ERROR_STYLE, INK_COLOURS, TaskPage, canvas
from dreamprint_gui.gui.wizard.slabs import slab_fit_table
from dreamprint_gui.gui.workers import Task, abandonable
from dreamprint_gui.physics.slab_fit import SlabFit

__all__ = ["FitPage", "FIT_TABLE_HEAD"]


def _held_out(measurements: list, base) -> dict[str, tuple[list, list[str]]]:
    """Leave-one-thickness-out of each ink with several thicknesses (worker thread)."""
    from dreamprint_gui.physics.calibration import leave_one_thickness_out

    out = {}
    for ink in INKS:
        layers = [m for m in measurements if m.ink == ink]
        if len({m.thickness_mm for m in layers}) > 1:
            out[ink] = leave_one_thickness_out(layers, base.wavelengths_nm.size)
    return out


def _fmt_err(x: float | None) -> str:
    if x is None:
        return "-"
    return "&lt; 0.0001" if x < 5e-5 else f"{x:.4f}"


FIT_TABLE_HEAD = ("<tr><th align='left'>ink</th><th align='left'>layers</th>"
                  "<th>held-out rms R</th><th>held-out rms T</th><th>worst held out</th>"
                  "<th>fit residual R / T<br>(worst wavelength)</th>"
                  "<th align='left'>what this says</th></tr>")


def _fit_row(fit, layers: list, held: list, notes: list[str]) -> str:
    """One ink's row of the fit table: what can be checked of its fit.

    Held-out error (leave-one-thickness-out) with several thicknesses; one layer with R and T
    is fitted exactly by construction, which the row says instead of a zero residual.
    """
    from dreamprint_gui.physics.calibration import exact_by_construction

    ts = sorted({m.thickness_mm for m in layers})
    layer_text = f"{len(layers)} at {', '.join(f'{t:g}' for t in ts)} mm"
    cells = [f"<b>{fit.ink}</b>", layer_text]
    s = fit.summary()
    residual = f"{_fmt_err(s['max_rms_R'])} / {_fmt_err(s['max_rms_T'])}"
    if exact_by_construction(layers):
        cells += ["-", "-", "-", "-",
                  "exact by construction (one R and T pair, two unknowns per wavelength): "
                  "nothing to check; measure a second thickness"]
    elif len(layers) == 1:
        q = "T" if layers[0].R is None else "R"
        cells += ["-", "-", "-", "-",
                  f"only {q}: matched exactly, K and S not separable; measure R and T"]
    elif held:
        worst = max(held, key=lambda h: max(h.overall_R or 0.0, h.overall_T or 0.0))
        rms = {q: [getattr(h, f"overall_{q}") for h in held] for q in "RT"}
        agg = {q: (None if all(v is None for v in vals) else
                   float(np.sqrt(np.mean([v * v for v in vals if v is not None]))))
               for q, vals in rms.items()}
        per = "; ".join(f"{h.thickness_mm:g} mm: R {_fmt_err(h.overall_R)}, "
                        f"T {_fmt_err(h.overall_T)}" for h in held)
        cells += [_fmt_err(agg["R"]), _fmt_err(agg["T"]), f"{worst.thickness_mm:g} mm",
                  residual, f"each thickness predicted from the others ({per})"]
    elif len(ts) == 1:
        cells += ["-", "-", "-", residual,
                  "one thickness: nothing to hold out; the residual is the repeats' spread"]
    else:
        cells += ["-", "-", "-", residual, ""]
    if notes:
        cells[-1] += ("; " if cells[-1] else "") + "; ".join(notes)
    aligns = ["left", "left", "center", "center", "center", "center", "left"]
    return "<tr>" + "".join(f"<td align='{a}'>{c}</td>" for a, c in
                            zip(aligns, cells, strict=True)) + "</tr>"


class FitPage(TaskPage):
    """Fits on a worker thread; plots measured vs fitted R and T, residuals, chart dE2000."""

    fitted = Signal(object)

    def __init__(self, wizard: QWizard) -> None:
        super().__init__()
        self.wiz = wizard
        self.result = None  # (profile, fits, chart_fit)
        self.held_out: dict[str, tuple[list, list[str]]] = {}
        self.error_text = ""
        self._task: Task | None = None
        self.setTitle("Fit")
        self.setSubTitle("Kubelka-Munk K and S per wavelength, fitted to your measurements.")
        self.status = QLabel("")
        self.status.setWordWrap(True)
        self.busy = QProgressBar(minimum=0, maximum=0)  # no fraction to show: a busy bar
        self.busy.setTextVisible(False)
        self.busy.setMaximumWidth(160)
        self.elapsed = QLabel("")
        self.elapsed.setObjectName("fitElapsed")
        self.stop_button = QPushButton("Stop")
        self.stop_button.setToolTip("Stop fitting: the page returns at once and the running "
                                    "fit's result is discarded")
        self.stop_button.clicked.connect(self.stop)
        self.again_button = QPushButton("Fit again")
        self.again_button.clicked.connect(self.start)
        run_row = QHBoxLayout()
        run_row.addWidget(self.busy)
        run_row.addWidget(self.elapsed, 1)
        run_row.addWidget(self.stop_button)
        run_row.addWidget(self.again_button)
        self._stage = ""
        self._t0 = 0.0
        self._clock = QTimer(self, interval=500)
        self._clock.timeout.connect(self._tick)
        self.tabs = QTabWidget()
        self.fit_fig, self.fit_canvas = canvas((8, 4.5))
        self.ks_fig, self.ks_canvas = canvas((8, 4.5))
        self.res_fig, self.res_canvas = canvas((8, 3))
        self.chart_fig, self.chart_canvas = canvas((8, 3))
        self.tabs.addTab(self.fit_canvas, "Measured vs fitted")
        self.tabs.addTab(self.ks_canvas, "Fitted K and S")
        self.tabs.addTab(self.res_canvas, "Held-out and residual error")
        self.tabs.addTab(self.chart_canvas, "Chart dE2000")
        lay = QVBoxLayout(self)
        lay.addLayout(run_row)
        lay.addWidget(self.status)
        lay.addWidget(self.tabs, 1)
        self._set_running(False)

    def initializePage(self) -> None:  # noqa: N802 - Qt override
        self.start()

    def _set_running(self, running: bool) -> None:
        self.busy.setVisible(running)
        self.stop_button.setVisible(running)
        self.again_button.setVisible(not running)
        self._run_clock(running)

    def _tick(self) -> None:
        self.elapsed.setText(f"{self._stage} {time.monotonic() - self._t0:.0f} s")

    def _progress(self, stage: str) -> None:
        self._stage = stage
        self._tick()

    def stop(self) -> None:
        """Abandon the running fit: the page is ready again at once, its result is dropped."""
        if self._stop_task("The fit was stopped. Change the inputs (Back) or fit again."):
            self.completeChanged.emit()

    def start(self) -> None:
        """Fit the current inputs on a worker thread (a running fit is abandoned first)."""
        self.stop()
        self.result = None
        self.error_text = ""
        self.completeChanged.emit()
        measurements = self.wiz.measurements_page.measurements()
        chart = self.wiz.chart_page
        recipes, refl, folds = chart.recipes, chart.reflectance, int(chart.folds.value())
        base = self.wiz.base_profile
        name = self.wiz.default_name
        slabs = self.wiz.slab_options()

        def job(report, cancel):
            from dreamprint_gui.physics.calibration import calibrate_profile

            if not measurements and recipes is None:
                raise DreamPrintError("nothing to fit: choose ink measurements (first page) or "
                                      "a mixture chart (second page)")
            held: dict[str, tuple[list, list[str]]] = {}
            if measurements:
                report("fitting K and S of each ink" + (" inside the slabs' faces:" if slabs
                                                        else ":"))
                profile, fits = abandonable(
                    lambda: calibrate_profile(measurements, base, name=name, slabs=slabs),
                    cancel, name="calibrate-profile")
                if not slabs and any(len({m.thickness_mm for m in measurements
                                          if m.ink == f.ink}) > 1 for f in fits):
                    report("holding out each thickness in turn:")
                    held = abandonable(lambda: _held_out(measurements, base), cancel,
                                       name="leave-one-thickness-out")
            else:
                profile, fits = base.with_settings(name=name), []
            chart_fit = None
            if recipes is not None:
                from dreamprint_gui.physics.chart_calibration import fit_chart

                n = len(recipes)
                report(f"refitting the inks to the chart's {n} patches with "
                       f"{folds}-fold cross-validation (this can take a minute):")
                start = profile

                def step(done: int, total: int, detail: str | None = None) -> None:
                    report(f"refitting the inks to the chart's {n} patches: fit {done + 1} "
                           f"of {total} (all patches, then each of the {total - 1} folds)"
                           + (f", {detail.split(': ', 1)[-1]}:" if detail else ":")
                           if done < total else
                           f"refitted to the chart's {n} patches ({total} fits):")

                chart_fit = abandonable(
                    lambda: fit_chart(start, recipes, refl, name=name, folds=folds,
                                      progress=step), cancel, name="fit-chart")
                profile = chart_fit.profile
            return profile, fits, chart_fit, measurements, held

        self.status.setText("")
        self.status.setStyleSheet("")
        self._stage = "fitting:"
        self._start_task(job, "calibration")

    def _finished(self) -> None:
        if self._task.outcome != "cancelled":  # a stop has already reset the page
            self._set_running(False)
            self.elapsed.setText(f"fitted in {time.monotonic() - self._t0:.0f} s"
                                 if self._task.outcome == "succeeded" else "")
        self.completeChanged.emit()

    def cleanupPage(self) -> None:  # noqa: N802 - Qt override
        self.stop()

    def isComplete(self) -> bool:  # noqa: N802 - Qt override
        return self.result is not None

    def nextId(self) -> int:  # noqa: N802 - Qt override
        """The chart proof page only after a chart calibration."""
        ids = self.wiz.page_ids
        with_chart = self.result is not None and self.result[2] is not None
        return ids[self.wiz.chart_proof_page if with_chart else self.wiz.save_page]

    def _failed(self, message: str, _tb: str) -> None:
        self.error_text = message
        self.status.setText(f"The fit failed: {message}")
        self.status.setStyleSheet(ERROR_STYLE)

    def _done(self, result) -> None:
        profile, fits, chart_fit, measurements, held = result
        self.result = (profile, fits, chart_fit)
        self.held_out = held
        text = ""
        if fits and isinstance(fits[0], SlabFit):
            text = slab_fit_table(fits)
        elif fits:
            rows = [_fit_row(f, [m for m in measurements if m.ink == f.ink],
                             *held.get(f.ink, ([], []))) for f in fits]
            text = ("<table cellspacing='0' cellpadding='3'>" + FIT_TABLE_HEAD + "".join(rows)
                    + "</table>")
        if chart_fit is not None:
            cv = chart_fit.report()["cross_validated_dE2000"]
            text += (f"<b>chart</b>: cross-validated dE2000 mean {cv['mean']:.2f}, "
                     f"p95 {cv['p95']:.2f}, max {cv['max']:.2f}")
        self.status.setText(text)
        self._plot_fit(profile, measurements, fits)
        self._plot_ks(profile, [f.ink for f in fits])
        self._plot_residuals(fits, held)
        self._plot_chart(chart_fit)
        self.tabs.setTabEnabled(3, chart_fit is not None)
        self.fitted.emit(self.result)

    def _plot_fit(self, profile, measurements, fits=()) -> None:
        from dreamprint_gui.physics.kubelka_munk import reflectance_transmittance

        slab_fits = {f.ink: f for f in fits if isinstance(f, SlabFit)}

        fig = self.fit_fig
        fig.clear()
        inks = [ink for ink in INKS if any(m.ink == ink for m in measurements)]
        axes = np.atleast_1d(fig.subplots(2, max(1, len(inks)), sharex=True, sharey="row",
                                          squeeze=False))
        wl = profile.wavelengths_nm
        for j, ink in enumerate(inks):
            i = INKS.index(ink)
            for m in (m for m in measurements if m.ink == ink):
                R, T = (slab_fits[ink].predict(m.thickness_mm) if ink in slab_fits else
                        reflectance_transmittance(profile.K[i], profile.S[i], m.thickness_mm))
                for row, meas, fit in ((0, m.R, R), (1, m.T, T)):
                    ax = axes[row, j]
                    if meas is not None:
                        ax.plot(wl, meas, "o", ms=2.5, color=INK_COLOURS[ink], alpha=0.7)
                        ax.plot(wl, fit, "-", lw=1.2, color="#333")
            axes[0, j].set_title(ink, fontsize=9)
        for row, q in enumerate(("R", "T")):
            axes[row, 0].set_ylabel(f"{q} (dots measured, line fitted)", fontsize=7)
            for ax in axes[row]:
                ax.tick_params(labelsize=6)
        for ax in axes[1]:
            ax.set_xlabel("nm", fontsize=7)
        self.fit_canvas.draw_idle()

    def _plot_ks(self, profile, inks: list[str]) -> None:
        """The fitted K and S (1/mm) of each fitted ink, on a log scale."""
        fig = self.ks_fig
        fig.clear()
        inks = [ink for ink in INKS if ink in inks]
        if not inks:
            self.ks_canvas.draw_idle()
            return
        axes = fig.subplots(1, len(inks), sharey=True, squeeze=False)[0]
        wl = profile.wavelengths_nm
        for ax, ink in zip(axes, inks, strict=True):
            i = INKS.index(ink)
            ax.plot(wl, profile.K[i], "-", color=INK_COLOURS[ink], lw=1.5, label="K")
            ax.plot(wl, profile.S[i], "--", color="#555", lw=1.2, label="S")
            ax.set_yscale("log")
            ax.set_title(ink, fontsize=9)
            ax.set_xlabel("wavelength (nm)", fontsize=7)
            ax.tick_params(labelsize=6)
            ax.legend(fontsize=7)
        axes[0].set_ylabel("K (absorption), S (scattering): 1/mm", fontsize=7)
        self.ks_canvas.draw_idle()

    def _plot_residuals(self, fits, held) -> None:
        """Held-out error per wavelength (solid) where there is one, else the fit residual
        (dotted; exactly zero for one layer, which is said in the title)."""
        fig = self.res_fig
        fig.clear()
        ax_r, ax_t = fig.subplots(1, 2, sharey=True)
        wl = self.wiz.base_profile.wavelengths_nm
        for f in fits:
            colour = INK_COLOURS[f.ink]
            outs = held.get(f.ink, ([], []))[0]
            for ax, q in ((ax_r, "R"), (ax_t, "T")):
                curves = [getattr(h, f"rms_{q}") for h in outs
                          if np.isfinite(getattr(h, f"rms_{q}")).any()]
                if curves:
                    with np.errstate(invalid="ignore"):
                        ho = np.sqrt(np.nanmean(np.square(curves), axis=0))
                    ax.plot(wl, ho, "-", color=colour, label=f"{f.ink} held out")
                res = getattr(f, f"rms_{q}")
                if np.isfinite(res).any():
                    ax.plot(wl, res, ":", color=colour, label=f"{f.ink} fit residual")
        for ax, q in ((ax_r, "R"), (ax_t, "T")):
            ax.set_title(f"rms error of {q} per wavelength", fontsize=9)
            ax.set_xlabel("wavelength (nm)", fontsize=8)
            ax.tick_params(labelsize=7)
            if ax.lines:
                ax.legend(fontsize=6)
        self.res_canvas.draw_idle()

    def _plot_chart(self, chart_fit) -> None:
        fig = self.chart_fig
        fig.clear()
        if chart_fit is None:
            self.chart_canvas.draw_idle()
            return
        ax = fig.subplots()
        x = np.arange(chart_fit.cv_dE2000.size)
        ax.bar(x - 0.2, chart_fit.fit_dE2000, 0.4, label="fit (own patches)")
        ax.bar(x + 0.2, chart_fit.cv_dE2000, 0.4, label=f"cross-validated ({chart_fit.folds} "
               "folds)")
        ax.set_xlabel("patch", fontsize=8)
        ax.set_ylabel("dE2000", fontsize=8)
        ax.legend(fontsize=7)
        self.chart_canvas.draw_idle()
