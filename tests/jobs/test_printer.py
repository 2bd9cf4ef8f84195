"""Printer profiles: built-ins, user TOML files, validation and the tray check."""

import pytest

from dreamprint_gui.core.errors import DreamPrintError
from dreamprint_gui.core.printer import (
    EMPTY_LABEL,
    builtin_printers,
    check_tray,
    load_printer,
)


def test_builtins_have_the_documented_grids():
    names = builtin_printers()
    assert {"j850-paper", "voxelprint-14um", "voxelprint-27um"} <= set(names)
    p = load_printer("j850-paper")
    assert p.voxel_mm == (0.084, 0.028, 0.014)
    v = load_printer("voxelprint-27um")
    assert v.voxel_mm[0] == pytest.approx(25.4 / 600)
    assert v.voxel_mm[1] == pytest.approx(25.4 / 300)
    assert v.voxel_mm[2] == pytest.approx(0.027)
    assert load_printer("voxelprint-14um").layer_thickness_mm == pytest.approx(0.014)
    assert v.tray_mm == (490.0, 390.0, 200.0)
    pal = p.palette()
    assert pal.shape == (EMPTY_LABEL + 1, 3)
    assert len({tuple(c) for c in pal}) == 7


def _write(tmp_path, text):
    f = tmp_path / "my.toml"
    f.write_text(text)
    return f


def test_user_file_round_trip_and_edit(tmp_path):
    from dreamprint_gui.core.resources import resource_path

    text = resource_path("printers", "j850-paper.toml").read_text()
    text = text.replace('name = "j850-paper"', 'name = "mine"').replace(
        "rgb = [0, 90, 158]", "rgb = [1, 2, 3]")
    p = load_printer(_write(tmp_path, text))
    assert p.name == "mine" and p.material_rgb[0] == (1, 2, 3)


@pytest.mark.parametrize("change, fragment", [
    (("rgb = [0, 90, 158]", "rgb = [0, 90, 300]"), "0..255"),
    (("rgb = [0, 90, 158]", "rgb = [166, 33, 98]"), "distinct"),
    (("voxel_mm = [0.084, 0.028, 0.014]", "voxel_mm = [0.084, -1, 0.014]"), "positive"),
    (("[materials.Cl]", "[materials.Xx]"), "lacks Cl"),
    (('format = "dreamprint-printer"', 'format = "x"'), "not a printer profile"),
    (("tray_mm = [490.0", "tray_mm = [490.0,,"), "invalid TOML"),
])
def test_bad_files_name_the_problem(tmp_path, change, fragment):
    from dreamprint_gui.core.resources import resource_path

    text = resource_path("printers", "j850-paper.toml").read_text().replace(*change)
    f = _write(tmp_path, text)
    with pytest.raises(DreamPrintError) as e:
        load_printer(f)
    assert fragment in str(e.value) and str(f) in str(e.value)


def test_unknown_printer_lists_builtins():
    with pytest.raises(DreamPrintError, match="j850-paper"):
        load_printer("nope")


def test_tray_refusal_names_both_sizes():
    p = load_printer("j850-paper")
    check_tray((5000, 10000, 10000), p)  # 420 x 280 x 140 mm fits
    with pytest.raises(DreamPrintError) as e:
        check_tray((6000, 10000, 10000), p)  # 504 mm > 490 mm
    msg = str(e.value)
    assert "504.0 x 280.0 x 140.0" in msg and "490.0 x 390.0 x 200.0" in msg
