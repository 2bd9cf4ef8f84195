"""One print, stated the same way by every surface: the spec the CLI (convert, proof,
compensate) and the GUI (Preview, Print proof tab, export) build for the same choices is equal,
field by field, for every field :class:`PrintSpec` has (a field added later is covered)."""

from dataclasses import fields

import pytest

from dreamprint_gui.cli import main
from dreamprint_gui.core.printer import load_printer
from dreamprint_gui.job.spec import PrintSpec

# the choices every surface offers: size, placement, printer, content, density, background
CHOICES = {"height_mm": 3.0, "up": "x", "rotate": 90, "fit": "box", "content": "solid",
           "density_scale": 1.5, "background": "empty", "printer": "voxelprint-14um"}
CLI = ["--height-mm", "3", "--up", "x", "--rotate", "90", "--fit", "box", "--content",
       "solid", "--density-scale", "1.5", "--background", "empty", "--printer",
       "voxelprint-14um", "--table-size", "17"]


class _Stop(Exception):
    pass


def _cli_spec(monkeypatch, module, name, argv):
    """The spec of the settings a command hands to its runner (stopped there)."""
    seen = []

    def capture(settings, *a, **k):
        seen.append(settings)
        raise _Stop

    monkeypatch.setattr(module, name, capture)
    assert main(argv) == 2
    return seen[0].spec


def _export_dialog(qtbot, monkeypatch, tmp_path, preview_params: dict):
    """The export dialog for the demo with the Preview's ``preview_params`` and CHOICES'
    printer, writing ``tmp_path/job``."""
    from dreamprint_gui.gui.export import ExportDialog

    # the dialog's pre-flight estimate (seconds on a worker) is not what these tests read
    monkeypatch.setattr(ExportDialog, "update_preflight", lambda self: None)
    export = ExportDialog(None, source_path="demo", profile_path=None, table_size=17,
                          preview_params=preview_params)
    qtbot.addWidget(export)
    export.printer.setCurrentIndex(export.printer.findData(CHOICES["printer"]))
    export.folder.setText(str(tmp_path))
    export.job_name.setText("job")
    return export


def _equal_field_by_field(specs: dict[str, PrintSpec]) -> None:
    ref_name, ref = next(iter(specs.items()))
    for name, spec in specs.items():
        for f in fields(PrintSpec):
            assert getattr(spec, f.name) == getattr(ref, f.name), (
                f"{f.name}: {name} {getattr(spec, f.name)!r}, {ref_name} "
                f"{getattr(ref, f.name)!r}")


def test_every_surface_builds_the_same_spec(qtbot, monkeypatch, tmp_path):
    import dreamprint_gui.job.run as job_run
    import dreamprint_gui.proof.compensate as compensate
    import dreamprint_gui.proof.runner as runner
    from dreamprint_gui.gui.preview import PreviewPage
    from dreamprint_gui.gui.proof_view import ProofPage

    specs = {
        "convert": _cli_spec(monkeypatch, job_run, "run_conversion",
                             ["convert", "demo", "-o", str(tmp_path / "job"), *CLI]),
        "proof": _cli_spec(monkeypatch, runner, "run_proof",
                           ["proof", "demo", "-o", str(tmp_path / "proof"), *CLI]),
        "compensate": _cli_spec(monkeypatch, compensate, "run_compensate",
                                ["compensate", "demo", "-o", str(tmp_path / "c.npz"), *CLI]),
    }

    preview = PreviewPage(table_size=17)
    qtbot.addWidget(preview)
    preview.set_inputs(source_path="demo", printer=load_printer(CHOICES["printer"]))
    preview.set_params(**{k: CHOICES[k] for k in ("height_mm", "density_scale", "background",
                                                  "content", "up", "rotate", "fit")})
    specs["preview"] = preview.job_settings().spec

    tab = ProofPage(job_settings=preview.job_settings)
    qtbot.addWidget(tab)
    specs["proof tab"] = tab.proof_settings().spec

    export = _export_dialog(qtbot, monkeypatch, tmp_path, preview.params())
    specs["export"] = export.settings_for_job().spec

    for name, spec in specs.items():  # the choices arrived, not only the defaults
        for k, v in CHOICES.items():
            assert getattr(spec, k) == v, (name, k)
    _equal_field_by_field(specs)


def test_cli_and_export_compensate_by_one_route(qtbot, monkeypatch, tmp_path):
    """``convert --compensate`` and the export's "Compensate appearance" call the same
    function (``proof.compensated.run_compensated_conversion``) with the same spec; nothing
    else optimises a correction on the way (the stand-in stops both before any work)."""
    import dreamprint_gui.proof.compensate as compensate
    import dreamprint_gui.proof.compensated as compensated
    from dreamprint_gui.gui.preview import PreviewPage

    reached = []

    def route(settings, *a, **k):
        reached.append(settings)
        raise _Stop

    monkeypatch.setattr(compensated, "run_compensated_conversion", route)
    monkeypatch.setattr(compensate, "run_compensate", route)   # the old CLI route: not taken
    assert main(["convert", "demo", "-o", str(tmp_path / "job"), *CLI, "--compensate"]) == 2
    assert len(reached) == 1 and reached[0].compensation is None

    preview = PreviewPage(table_size=17)
    qtbot.addWidget(preview)
    preview.set_params(**{k: CHOICES[k] for k in ("height_mm", "density_scale", "background",
                                                  "content", "up", "rotate", "fit")})
    export = _export_dialog(qtbot, monkeypatch, tmp_path, preview.params())
    export.compensate.setChecked(True)
    export.start()
    qtbot.waitUntil(lambda: export.task.outcome is not None, timeout=60000)
    assert export.task.outcome == "failed" and len(reached) == 2
    cli_settings, gui_settings = reached
    assert type(cli_settings) is type(gui_settings)
    _equal_field_by_field({"convert --compensate": cli_settings.spec,
                           "export, Compensate appearance": gui_settings.spec})
    assert gui_settings.output == cli_settings.output


def test_a_difference_in_any_field_is_found():
    """The comparison is not blind: each field changed alone is reported by name."""
    base = PrintSpec(source="demo", height_mm=3.0)
    other = {"source": "x.vdb", "height_mm": 4.0, "size_mm": (1.0, 2.0, 3.0), "up": "y",
             "rotate": 180, "fit": "box", "printer": "j850-paper", "profile": "p.json",
             "content": "fog", "sampling": "linear", "objective": "srgb",
             "intent": "relative", "table_size": 17, "density_scale": 2.0,
             "halftone": "random", "seed": 1, "background": "empty",
             "compensation": "c.npz", "source_options": (("grid", "density"),)}
    assert set(other) == {f.name for f in fields(PrintSpec)}
    for k, v in other.items():
        with pytest.raises(AssertionError, match=k):
            _equal_field_by_field({"a": base, "b": PrintSpec(**{**base.__dict__, k: v})})
