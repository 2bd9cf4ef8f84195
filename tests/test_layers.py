"""The package's layers (issue 26): the contract in ``pyproject.toml`` holds, nothing below
``gui/`` imports Qt, the moved modules' old paths are gone, and an import written inside a
function is never one of the package's own modules below cli/ and gui/ (such an import only
ever dodged a circle; heavy or optional third-party dependencies are the one reason left)."""

import ast
import importlib
import pkgutil
import subprocess
import sys
from pathlib import Path

import pytest

import dreamprint_gui

PACKAGE = Path(dreamprint_gui.__file__).resolve().parent
BELOW_GUI = ("core", "physics", "io", "gamut", "job", "proof", "cli")


def test_layers_contract_holds():
    """``lint-imports`` (import-linter) checks the layers, the Qt ban and the absence of import
    circles between sibling modules; it fails on any import that runs up a layer."""
    exe = Path(sys.executable).with_name("lint-imports")
    out = subprocess.run([str(exe)], cwd=PACKAGE.parent, capture_output=True, text=True)
    assert out.returncode == 0, out.stdout[-3000:] + out.stderr[-2000:]
    assert "4 kept, 0 broken" in out.stdout


def test_nothing_below_gui_imports_qt():
    code = (
        "import sys, pkgutil, importlib\n"
        f"for name in {BELOW_GUI!r}:\n"
        "    pkg = importlib.import_module('dreamprint_gui.' + name)\n"
        "    for m in pkgutil.walk_packages(pkg.__path__, pkg.__name__ + '.'):\n"
        "        if not m.name.endswith('.__main__'):  # runs the command line\n"
        "            importlib.import_module(m.name)\n"
        "bad = [m for m in sys.modules if m.startswith(('PySide6', 'PyQt', 'pyvistaqt'))\n"
        "       or m.startswith('dreamprint_gui.gui')]\n"
        "assert not bad, bad\n"
    )
    subprocess.run([sys.executable, "-c", code], check=True)


def test_view_data_modules_import_no_qt():
    """A view's non-Qt half beside it (``gui/*_data.py``: the preview's, the gamut views', the
    export dialog's) loads without Qt, so that it is tested and reused headless."""
    names = sorted(m.name for m in pkgutil.iter_modules([str(PACKAGE / "gui")])
                   if m.name.endswith("_data"))
    assert {"preview_data", "gamut_data", "export_data"} <= set(names)
    code = ("import sys, importlib\n"
            f"for n in {names!r}:\n"
            "    importlib.import_module('dreamprint_gui.gui.' + n)\n"
            "bad = [m for m in sys.modules if m.startswith(('PySide6', 'shiboken6', 'PyQt',"
            " 'pyvistaqt'))]\n"
            "assert not bad, bad\n")
    subprocess.run([sys.executable, "-c", code], check=True)


@pytest.mark.parametrize("old", ["dreamprint_gui.engine", "dreamprint_gui.errors",
                                 "dreamprint_gui.resources", "dreamprint_gui.io.job_export",
                                 "dreamprint_gui.job.sample_label.vec16",
                                 "dreamprint_gui.gui.wizard_common", "dreamprint_gui.gui.slab_page",
                                 "dreamprint_gui.io.volumes.openvdb",
                                 "dreamprint_gui.io.volumes.splat_raster",
                                 "dreamprint_gui.io.volumes.ingp_kernels",
                                 "dreamprint_gui.io.volumes.vtkimage"])
def test_old_paths_are_gone(old):
    with pytest.raises(ModuleNotFoundError):
        importlib.import_module(old)


def test_every_layer_folder_is_a_layer():
    """A new top-level folder must be placed in the contract (``exhaustive = true`` says so to
    lint-imports too); this names the folders the README's Layout section describes."""
    folders = {m.name for m in pkgutil.iter_modules([str(PACKAGE)]) if m.ispkg}
    assert folders == {"core", "physics", "io", "gamut", "job", "proof", "cli", "gui"}


def _function_local_own_imports(path: Path) -> list[str]:
    tree = ast.parse(path.read_text(encoding="utf-8"))
    found = []
    for fn in ast.walk(tree):
        if not isinstance(fn, ast.FunctionDef | ast.AsyncFunctionDef):
            continue
        for node in ast.walk(fn):
            if isinstance(node, ast.ImportFrom) and (
                    node.level or (node.module or "").startswith("dreamprint_gui")):
                found.append(f"{path.relative_to(PACKAGE)}:{node.lineno} {node.module}")
            elif isinstance(node, ast.Import) and any(
                    a.name.startswith("dreamprint_gui") for a in node.names):
                found.append(f"{path.relative_to(PACKAGE)}:{node.lineno}")
    return found


@pytest.mark.parametrize("layer", ["core", "physics", "io", "gamut", "job", "proof"])
def test_no_own_module_imported_inside_a_function(layer):
    found = [f for p in sorted((PACKAGE / layer).rglob("*.py"))
             for f in _function_local_own_imports(p)]
    assert not found, found


def _private_imports(path: Path, modules: set[str]) -> list[str]:
    """Another module's private (underscore) names that ``path`` imports or reads: ``from
    M import _x``, and ``M._x`` on a module bound by an import."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    found, bound = [], {}
    for n in ast.walk(tree):
        if isinstance(n, ast.Import):
            for a in n.names:
                if a.name.startswith("dreamprint_gui"):
                    bound[a.asname or a.name.split(".")[0]] = a.name
        elif isinstance(n, ast.ImportFrom) and (n.module or "").startswith("dreamprint_gui"):
            for a in n.names:
                if a.name.startswith("_") and not a.name.startswith("__"):
                    found.append(f"{path.name}:{n.lineno} from {n.module} import {a.name}")
                elif f"{n.module}.{a.name}" in modules:
                    bound[a.asname or a.name] = f"{n.module}.{a.name}"
    for n in ast.walk(tree):
        if (isinstance(n, ast.Attribute) and isinstance(n.value, ast.Name)
                and n.value.id in bound and n.attr.startswith("_")
                and not n.attr.startswith("__")):
            found.append(f"{path.name}:{n.lineno} {bound[n.value.id]}.{n.attr}")
    return found


def test_no_module_uses_another_modules_private_name(tmp_path):
    """A name with a leading underscore is its module's own: a module that needs another's
    imports a public name (issue 45)."""
    files = sorted(PACKAGE.rglob("*.py"))
    modules = {".".join(f.relative_to(PACKAGE.parent).with_suffix("").parts) for f in files}
    modules = {m.removesuffix(".__init__") for m in modules}
    bad = [hit for f in files for hit in _private_imports(f, modules)]
    assert not bad, bad
    # the check sees both forms
    probe = tmp_path / "probe.py"
    probe.write_text("from dreamprint_gui.job.plan import _open_source\n"
                     "from dreamprint_gui.job import plan\nplan._stamp('x')\n")
    assert len(_private_imports(probe, modules | {"dreamprint_gui.job.plan"})) == 2

