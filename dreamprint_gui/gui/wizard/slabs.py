"""The calibration wizard's slab page: a thickness series of slabs measured in air.

Shown after the measurements page when the operator ticks "slabs measured in air" (the
translucency wedge, ``dreamprint target wedge``). It sets what ``calibrate --slabs`` takes (the
faces' refractive index, which gives k1 and k2 by Fresnel's equations, and whether k2 is fitted
per ink: :class:`~dreamprint_gui.physics.slab_fit.SlabOptions`), lists each ink's series and what
it cannot separate (:func:`~dreamprint_gui.physics.slab_fit.series_warnings`), and plots the
measured T and R against thickness at 450, 550 and 650 nm on a log scale: straight lines of T
are Beer-Lambert bulk absorption, their intercept at 0 mm the two faces.

:func:`slab_fit_table` is the fit page's table after a slab fit: per ink the faces and the
worst 1-sigma of K and S over 450-700 nm, per slab its dE2000 in R and T, the slabs that do
not fit and the fit's warnings.
"""

from __future__ import annotations

import html

import numpy as np
from PySide6.QtWidgets import (
    QCheckBox,
    QDoubleSpinBox,
    QFormLayout,
    QLabel,
    QVBoxLayout,
    QWizardPage,
)

from dreamprint_gui.core.profile import INKS
from dreamprint_gui.gui.wizard.common import ERROR_STYLE, INK_COLOURS, canvas
from dreamprint_gui.physics import saunderson
from dreamprint_gui.physics.slab_fit import REFRACTIVE_INDEX, SlabOptions, series_warnings

__all__ = ["SlabPage", "slab_fit_table", "PLOT_NM"]

PLOT_NM = (450.0, 550.0, 650.0)


class SlabPage(QWizardPage):
    """Faces, k2 and each ink's thickness series; plotted against thickness."""

    def __init__(self, wizard) -> None:
        super().__init__()
        self.wiz = wizard
        self.setTitle("Slabs measured in air")
        self.setSubTitle("Each slab reflects at both faces. The fit finds, per wavelength, the "
                         "bulk K and S that reproduce every slab's R and T inside those faces; "
                         "two or more thicknesses separate the faces from the bulk.")
        self.index = QDoubleSpinBox(decimals=3, minimum=1.3, maximum=1.8, singleStep=0.01,
                                    value=REFRACTIVE_INDEX)
        self.index.setToolTip("the cured resin's refractive index (PolyJet: about 1.49-1.53)")
        self.faces = QLabel("")
        self.fit_k2 = QCheckBox("fit k2 per ink (two or more thicknesses; recommended for the "
                                "Clear, whose light stays collimated inside a thin slab)")
        self.index.valueChanged.connect(self._faces)
        form = QFormLayout()
        form.addRow("refractive index", self.index)
        form.addRow("faces", self.faces)
        form.addRow("", self.fit_k2)
        self.series = QLabel("")
        self.series.setObjectName("slabSeries")
        self.series.setWordWrap(True)
        self.problem = QLabel("")
        self.problem.setStyleSheet(ERROR_STYLE)
        self.problem.setWordWrap(True)
        self.figure, self.canvas = canvas((8, 3))
        self.canvas.setMinimumHeight(220)
        lay = QVBoxLayout(self)
        lay.addLayout(form)
        lay.addWidget(self.series)
        lay.addWidget(self.problem)
        lay.addWidget(self.canvas, 1)
        self._faces()

    def options(self) -> SlabOptions:
        return SlabOptions(float(self.index.value()), self.fit_k2.isChecked())

    def _k2(self) -> float:
        return saunderson.diffuse_internal_k2(float(self.index.value()))

    def _faces(self) -> None:
        n = float(self.index.value())
        self.faces.setText(f"k1 {saunderson.fresnel_k1(n):.3f} (Fresnel, normal incidence), "
                           f"k2 {self._k2():.3f} (diffuse light inside)")
        if self.isVisible():
            self._show_series()

    def initializePage(self) -> None:  # noqa: N802 - Qt override
        self._show_series()

    def _by_ink(self) -> dict[str, list]:
        out: dict[str, list] = {}
        for m in self.wiz.measurements_page.measurements():
            out.setdefault(m.ink, []).append(m)
        return {ink: out[ink] for ink in INKS if ink in out}

    def _show_series(self) -> None:
        by_ink = self._by_ink()
        rows = []
        for ink, layers in by_ink.items():
            ts = sorted({m.thickness_mm for m in layers})
            notes = series_warnings(layers, self._k2(), float(self.index.value()))
            what = ("; ".join(html.escape(w.split(": ", 1)[1]) for w in notes) if notes else
                    "bulk and faces separable")
            nR = sum(m.R is not None for m in layers)
            nT = sum(m.T is not None for m in layers)
            style = " style='color:#d33'" if notes else ""
            rows.append(f"<tr><td><b>{ink}</b></td><td>{', '.join(f'{t:g}' for t in ts)} mm"
                        f"</td><td align='center'>{nR} / {nT}</td><td{style}>{what}</td></tr>")
        self.series.setText("<table cellspacing='0' cellpadding='3'><tr><th align='left'>ink"
                            "</th><th align='left'>thicknesses</th><th>R / T</th>"
                            "<th align='left'>what the series separates</th></tr>"
                            + "".join(rows) + "</table>" if rows else "")
        self.problem.setText("" if by_ink else "No measurements: go back and choose each "
                             "slab's R and T files and its thickness, or a calibration set.")
        self._plot(by_ink)
        self.completeChanged.emit()

    def isComplete(self) -> bool:  # noqa: N802 - Qt override
        by_ink = self._by_ink()
        return bool(by_ink) and all(any(m.T is not None for m in v) for v in by_ink.values())

    def _plot(self, by_ink: dict[str, list]) -> None:
        fig = self.figure
        fig.clear()
        ax_t, ax_r = fig.subplots(1, 2)
        wl = self.wiz.base_profile.wavelengths_nm
        styles = ("o-", "s--", "^:")
        for ink, layers in by_ink.items():
            layers = sorted(layers, key=lambda m: m.thickness_mm)
            for nm, style in zip(PLOT_NM, styles, strict=True):
                j = int(np.argmin(np.abs(wl - nm)))
                for ax, q in ((ax_t, "T"), (ax_r, "R")):
                    pts = [(m.thickness_mm, getattr(m, q)[j]) for m in layers
                           if getattr(m, q) is not None and np.isfinite(m.thickness_mm)]
                    if pts:
                        x, y = zip(*pts, strict=True)
                        ax.plot(x, np.maximum(y, 1e-4), style, ms=3, lw=1,
                                color=INK_COLOURS[ink], label=f"{ink} {wl[j]:g} nm")
        for ax, title in ((ax_t, "transmittance T against thickness (log)"),
                          (ax_r, "reflectance R against thickness (log)")):
            ax.set_title(title, fontsize=9)
            ax.set_xlabel("slab thickness (mm)", fontsize=8)
            ax.set_yscale("log")
            ax.tick_params(labelsize=7)
            if ax.lines:
                ax.legend(fontsize=6, ncol=2)
        self.canvas.draw_idle()


def _num(x: float | None, fmt: str = ".2f") -> str:
    return "-" if x is None else format(x, fmt)


def _rel(x: float | None) -> str:
    """A relative 1-sigma: '-' where the coefficient is 0, 'unresolved' beyond 100 %."""
    if x is None:
        return "- (0)"
    return "unresolved" if x > 1.0 else f"{x:.1%}"


def slab_fit_table(fits: list) -> str:
    """HTML of the fit page after a slab fit (see the module docstring)."""
    rows = []
    for f in fits:
        s = f.summary()
        k2 = "fitted" if s["k2_fitted"] else "from n"
        slabs = []
        for r in s["slabs"]:
            t = "inf" if r["thickness_mm"] is None else f"{r['thickness_mm']:g}"
            cell = f"{t} mm: {_num(r['dE2000_R'])} / {_num(r['dE2000_T'])}"
            slabs.append(cell if r["fits"] else
                         f"<span style='color:#d33'><b>{cell} does not fit</b></span>")
        warn = "<br>".join(f"<span style='color:#d33'>{html.escape(w)}</span>"
                           for w in s["warnings"] if "does not fit" not in w)
        rows.append(f"<tr><td><b>{f.ink}</b></td><td>k1 {s['k1']:.3f}, k2 {s['k2']:.3f} "
                    f"({k2})</td><td align='center'>"
                    f"{_rel(s['max_rel_sigma_K_450_700'])} / "
                    f"{_rel(s['max_rel_sigma_S_450_700'])}</td><td>"
                    f"{'; '.join(slabs)}{'<br>' + warn if warn else ''}</td></tr>")
    return ("<table cellspacing='0' cellpadding='3'><tr><th align='left'>ink</th>"
            "<th align='left'>faces</th><th>1-sigma K / S<br>(worst, 450-700 nm)</th>"
            "<th align='left'>per slab: dE2000 R / T of the fit</th></tr>" + "".join(rows)
            + "</table>")
