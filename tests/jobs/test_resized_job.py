"""A prepared job resized (``job.plan.resized_job``: the Preview's shortcut while a size,
density or background control is dragged) is the job ``prepare_job`` makes for the new
settings; any other change is prepared again (the Preview used to keep its tables when the
intent changed)."""

from dataclasses import fields, replace

import pytest

from dreamprint_gui.core.errors import DreamPrintError
from dreamprint_gui.job.plan import RESIZABLE, ConvertSettings, prepare_job, resized_job

BASE = ConvertSettings(source="demo", height_mm=3.0, table_size=17)


@pytest.fixture(scope="module")
def prepared():
    return prepare_job(BASE)


@pytest.mark.parametrize("change", [
    {"height_mm": 5.0}, {"height_mm": None, "size_mm": (4.0, 4.0, 2.0)},
    {"background": "empty"}, {"density_scale": 2.0},
])
def test_a_resized_job_is_the_prepared_one(prepared, change):
    s = replace(BASE, **change)
    got, want = resized_job(prepared, s), prepare_job(s)
    assert got is not None and got.settings == s
    assert got.source is prepared.source and got.tables is prepared.tables  # nothing reopened
    assert got.grid == want.grid
    for k in ("method", "seed", "voxel_mm", "threshold", "bg_label"):
        assert getattr(got.halftoner, k) == getattr(want.halftoner, k), k


@pytest.mark.parametrize("change", [
    {"intent": "relative"}, {"objective": "srgb"}, {"seed": 1}, {"up": "x"}, {"fit": "box"},
    {"content": "solid"}, {"halftone": "random"}, {"printer": "j850-paper"},
    {"density_threshold": 0.5}, {"compensation": "c.npz"},
])
def test_any_other_change_prepares_again(prepared, change):
    assert resized_job(prepared, replace(BASE, **change)) is None


def test_a_setting_added_later_is_compared(prepared):
    """Every setting but the resizable ones decides, without a list to keep up to date."""
    others = [f.name for f in fields(ConvertSettings) if f.name not in RESIZABLE]
    assert {"intent", "objective", "source_options", "sampling"} <= set(others)
    assert resized_job(prepared, replace(BASE, source_options={"grid": "density"})) is None


def test_a_resized_job_larger_than_the_tray_is_refused(prepared):
    with pytest.raises(DreamPrintError, match="larger than the printer's tray"):
        resized_job(prepared, replace(BASE, height_mm=5000.0))


@pytest.mark.parametrize("change", [
    {"density_scale": -1.0}, {"density_scale": float("nan")}, {"background": "grey"},
    {"height_mm": None}, {"height_mm": -2.0}, {"size_mm": (4.0, 4.0, 2.0)},
])
def test_a_resize_the_job_refuses_is_refused_alike(prepared, change):
    """The Preview shows no job the export would refuse: the same one-line error."""
    s = replace(BASE, **change)
    with pytest.raises(DreamPrintError) as want:
        prepare_job(s)
    with pytest.raises(DreamPrintError) as got:
        resized_job(prepared, s)
    assert str(got.value) == str(want.value)
