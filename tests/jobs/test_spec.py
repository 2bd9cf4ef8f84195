"""The print spec (job/spec.py) and the one size rule (core/print_size.py)."""

from dataclasses import fields

import pytest

from dreamprint_gui.core.errors import DreamPrintError
from dreamprint_gui.core.print_size import check_print_size
from dreamprint_gui.core.printer import load_printer
from dreamprint_gui.job.plan import ConvertSettings
from dreamprint_gui.job.spec import PrintSpec
from dreamprint_gui.proof.compensate import CompensateSettings
from dreamprint_gui.proof.runner import ProofSettings

SETTINGS = (ConvertSettings, ProofSettings, CompensateSettings)

# a value other than the default for every field of the spec
CHOSEN = {"source": "x.vdb", "height_mm": None, "size_mm": (10.0, 20.0, 30.0), "up": "y",
          "rotate": 270, "fit": "box", "printer": "j850-paper", "profile": "p.json",
          "content": "solid", "sampling": "linear", "objective": "srgb", "intent": "perceptual",
          "table_size": 17, "density_scale": 0.5, "halftone": "random", "seed": 9,
          "background": "empty", "compensation": "c.npz",
          "source_options": (("grid", "density"), ("level_set", "solid"))}


def test_the_choices_cover_every_field():
    assert set(CHOSEN) == {f.name for f in fields(PrintSpec)}


@pytest.mark.parametrize("cls", SETTINGS)
def test_every_settings_class_holds_every_spec_field(cls):
    names = {f.name for f in fields(cls)}
    assert {f.name for f in fields(PrintSpec)} <= names


@pytest.mark.parametrize("cls", SETTINGS)
def test_settings_from_a_spec_give_the_spec_back(cls):
    spec = PrintSpec(**CHOSEN)
    s = cls.from_spec(spec)
    assert s.spec == spec
    for f in fields(PrintSpec):  # each field arrived, not only equal as a whole
        got = getattr(s, f.name)
        want = getattr(spec, f.name)
        assert (dict(got) == dict(want)) if f.name == "source_options" else got == want


def test_settings_carry_the_spec_from_one_class_to_another():
    spec = PrintSpec(**CHOSEN)
    cs = ConvertSettings.from_spec(spec, output="job", workers=2)
    assert cs.source_options == dict(CHOSEN["source_options"]) and cs.workers == 2
    ps = ProofSettings.from_spec(cs.spec, views=2)
    assert ps.spec == spec and ps.views == 2
    assert CompensateSettings.from_spec(ps.spec, iterations=1).spec == spec


def test_a_printer_is_stated_the_same_by_name_or_loaded():
    """A built-in loaded from its file (the GUI) and named (the CLI) are the same choice."""
    by_name = ConvertSettings(source="demo", height_mm=1.0, printer="voxelprint-14um")
    loaded = ConvertSettings(source="demo", height_mm=1.0,
                             printer=load_printer("voxelprint-14um"))
    assert loaded.spec.printer == by_name.spec.printer == "voxelprint-14um"


@pytest.mark.parametrize("height, size, required, words", [
    (None, None, True, "exactly one"), (2.0, (1, 2, 3), True, "exactly one"),
    (2.0, (1, 2, 3), False, "at most one"), (0.0, None, True, "--height-mm must be a positive"),
    (float("nan"), None, False, "--height-mm"), (None, (1, 0, 3), True, "three positive"),
    (None, (1, 2), True, "three positive"), (None, ("a", 1, 1), True, "three positive")])
def test_the_size_rule_refuses_in_one_line(height, size, required, words):
    with pytest.raises(DreamPrintError, match=words) as e:
        check_print_size(height, size, required)
    assert "\n" not in str(e.value)


@pytest.mark.parametrize("height, size, required", [
    (2.0, None, True), (None, (1.0, 2.0, 3.0), True), (None, None, False)])
def test_the_size_rule_takes_a_good_size(height, size, required):
    check_print_size(height, size, required)
