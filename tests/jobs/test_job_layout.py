"""The print-job path lives in ``dreamprint_gui.job``: it imports no Qt, and the public names keep
working from the paths the CLI, GUI, proof engine and older scripts used (thin re-exports)."""

import importlib
import subprocess
import sys

import pytest

# old module -> names it must still offer, and the module that now defines them
MOVED = [
    ("dreamprint_gui.engine.pipeline", "dreamprint_gui.job.plan",
     ["ConvertSettings", "ConvertProgress", "JobContext", "JobCancelled", "prepare_job",
      "DEFAULT_SLAB_VOXELS", "source_options_for", "replace_settings"]),
    ("dreamprint_gui.engine.pipeline", "dreamprint_gui.job.run", ["run_conversion"]),
    ("dreamprint_gui.engine.pipeline", "dreamprint_gui.job.slab", ["halftone_layer", "run_slab"]),
    ("dreamprint_gui.engine.halftone", "dreamprint_gui.job.halftone",
     ["Halftoner", "HALFTONE_METHODS", "MASK_VERSION", "blue_noise_mask", "pick_label",
      "label_rows", "fraction_variance_ratio", "box_for_voxel", "uniform_hash"]),
    ("dreamprint_gui.io.job_export", "dreamprint_gui.job.write",
     ["JobWriter", "check_target", "slice_name", "disk_error", "MANIFEST", "SLICES",
      "CANCEL_MARKER"]),
    ("dreamprint_gui.io.volumes.base", "dreamprint_gui.io.volumes.registry",
     ["FORMATS", "sniff_format", "open_source", "inspect_file", "inspect_source",
      "reader_options"]),
    ("dreamprint_gui.io.volumes", "dreamprint_gui.io.volumes.registry", ["open_source"]),
]


@pytest.mark.parametrize(("old", "new", "names"), MOVED)
def test_old_import_paths_give_the_same_objects(old, new, names):
    old_mod, new_mod = importlib.import_module(old), importlib.import_module(new)
    for name in names:
        assert getattr(old_mod, name) is getattr(new_mod, name), (old, name)


def test_shims_list_only_names_they_offer():
    for old in ("dreamprint_gui.engine.pipeline", "dreamprint_gui.engine.halftone",
                "dreamprint_gui.io.job_export"):
        mod = importlib.import_module(old)
        missing = [n for n in mod.__all__ if not hasattr(mod, n)]
        assert not missing, (old, missing)


def test_job_package_imports_no_qt():
    code = (
        "import sys, pkgutil, importlib\n"
        "import dreamprint_gui.job as j\n"
        "for m in pkgutil.walk_packages(j.__path__, j.__name__ + '.'):\n"
        "    importlib.import_module(m.name)\n"
        "assert 'dreamprint_gui.job.run' in sys.modules\n"
        "bad = [m for m in sys.modules if m.startswith(('PySide6', 'PyQt', 'pyvistaqt'))"
        " or m.startswith('dreamprint_gui.gui')]\n"
        "assert not bad, bad\n"
    )
    subprocess.run([sys.executable, "-c", code], check=True)


def test_volume_base_imports_no_reader():
    """No import circle in io/volumes: the base protocol, which every reader imports, imports
    no reader (at module level or in a function), only the registry for its moved names and
    the sRGB encoding kernel (which imports no reader)."""
    import ast

    import dreamprint_gui.io.volumes.base as base

    tree = ast.parse(open(base.__file__, encoding="utf-8").read())
    siblings = {node.module or "" for node in ast.walk(tree)
                if isinstance(node, ast.ImportFrom) and node.level == 1}
    siblings |= {alias.name for node in ast.walk(tree)
                 if isinstance(node, ast.ImportFrom) and node.level == 1 and node.module is None
                 for alias in node.names}
    assert siblings <= {"", "registry", "srgb_encode"}, siblings
    code = (
        "import sys\n"
        "import dreamprint_gui.io.volumes.base as b\n"
        "readers = [m for m in sys.modules if m.startswith('dreamprint_gui.io.volumes.')\n"
        "           and m.rsplit('.', 1)[1] not in ('base', 'registry', 'srgb_encode')]\n"
        "assert not readers, readers\n"
        "assert b.open_source('demo').bounds\n"
    )
    subprocess.run([sys.executable, "-c", code], check=True)
