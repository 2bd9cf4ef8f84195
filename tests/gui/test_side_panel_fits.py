"""At 1280 x 800 the preview's side panel cuts nothing off (issue 46): with every control a
file can show and several long warnings, the panel scrolls and each label keeps its height."""

from __future__ import annotations

from PySide6.QtWidgets import QApplication

from dreamprint_gui.gui.preview import PreviewPage


def test_long_warnings_and_all_rows_are_never_clipped(qtbot):
    p = PreviewPage()
    qtbot.addWidget(p)
    p.resize(1280, 740)                       # the page inside a 1280 x 800 window
    p.set_choices({"options": ["density_grid", "level_set"], "grids": ["a", "b"],
                   "level_set": True})
    p.level_set.setCurrentIndex(p.level_set.findData("shell"))
    long = ("44.0 % of the printed voxels' colours are outside the printable gamut (worst "
            "dE2000 12.2 from the source colour, the colorimetric target): they print as the "
            "nearest printable colour; Rendering intent relative maps the source white")
    p.warnings.setText("<ul>" + "".join(f"<li>{long}</li>" for _ in range(4)) + "</ul>")
    p.warnings_box.setVisible(True)
    p.content_note.setText("auto: solid, a level set")
    p.placement_note.setText("up = source y (auto: Houdini writes y-up); height of the object")
    p.show()
    qtbot.waitExposed(p)
    QApplication.processEvents()
    for label in (p.warnings, p.content_note, p.placement_note, p.status):
        if label.isVisible() and label.text():
            need = label.heightForWidth(label.width())
            assert label.height() >= need, (label.objectName(), label.height(), need)
    bar = p.side_scroll.verticalScrollBar()
    assert bar.maximum() > 0                  # taller than the window: it scrolls
    assert p.side_scroll.horizontalScrollBar().maximum() == 0
