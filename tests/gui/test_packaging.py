"""Packaging files: the desktop entry and AppStream metainfo validate; the PyInstaller recipe
carries resources/ and targets the console script's entry point."""

from __future__ import annotations

import ast
import subprocess
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
PKG = ROOT / "packaging"


def test_desktop_entry_validates():
    entry = PKG / "io.github.dreamprint.DreamPrint.desktop"
    r = subprocess.run(["desktop-file-validate", str(entry)], capture_output=True, text=True)
    assert r.returncode == 0 and not r.stdout.strip(), r.stdout + r.stderr
    text = entry.read_text()
    assert "Exec=dreamprint-gui %f" in text and "Icon=io.github.dreamprint.DreamPrint" in text


def test_metainfo_validates():
    meta = PKG / "io.github.dreamprint.DreamPrint.metainfo.xml"
    r = subprocess.run(["appstreamcli", "validate", "--no-net", str(meta)],
                       capture_output=True, text=True)
    assert r.returncode == 0, r.stdout + r.stderr


def test_icon_and_console_script():
    assert (ROOT / "resources" / "icons" / "dreamprint.svg").stat().st_size > 500
    assert (ROOT / "resources" / "icons" / "dreamprint.png").stat().st_size > 1000
    scripts = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["scripts"]
    assert scripts["dreamprint-gui"] == "dreamprint_gui.gui.app:main"


def test_pyinstaller_recipe():
    spec = (PKG / "dreamprint.spec").read_text()
    ast.parse(spec)  # valid Python
    assert '(str(ROOT / "resources"), "resources")' in spec  # where resources.py looks
    assert "COLLECT(" in spec  # one-folder
    entry = (PKG / "dreamprint_gui_entry.py").read_text()
    assert "from dreamprint_gui.gui.app import main" in entry
    cli = (PKG / "dreamprint_cli_entry.py").read_text()   # the bundle's `dreamprint`
    assert "from dreamprint_gui.cli import main" in cli
    scripts = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["scripts"]
    assert scripts["dreamprint"] == "dreamprint_gui.cli:main"
    for name in ("dreamprint_gui_entry.py", "dreamprint_cli_entry.py"):
        assert name in spec and "freeze_support()" in (PKG / name).read_text()
    # what the analysis cannot see: Mitsuba's variants, the libLLVM tree, the kernels' sources
    for needed in ('"mitsuba"', '"drjit"', "karellen-llvm-core", '"llvm/lib"',
                   '"dreamprint_gui": "pyz+py"', '"mitsuba": "pyz+py"', '"drjit": "pyz+py"',
                   '"vtkmodules"', '"imagecodecs"', '"gsply"', '"OpenEXR"'):
        assert needed in spec, needed


def test_metainfo_screenshots_are_real_files_at_the_declared_address():
    """No invented address: screenshot URLs only under the repository pyproject declares,
    each naming a screenshot that exists in docs/screenshots (none while there is no URL)."""
    import re
    import xml.etree.ElementTree as ET

    meta = ET.parse(PKG / "io.github.dreamprint.DreamPrint.metainfo.xml").getroot()
    images = [e.text.strip() for e in meta.iter("image")]
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    repo = (project.get("urls") or {}).get("Repository")
    if repo is None:
        assert images == [], "screenshot URLs without a public repository address"
    m = re.match(r"https://github\.com/([^/]+)/([^/]+?)(?:\.git)?/?$", repo or "")
    for url in images:
        assert url.startswith("https://"), url
        if m:
            assert url.startswith(f"https://raw.githubusercontent.com/{m[1]}/{m[2]}/"), url
        else:
            assert url.startswith(repo.rstrip("/") + "/"), url
        tail = url.split("/docs/screenshots/", 1)
        assert len(tail) == 2 and (ROOT / "docs" / "screenshots" / tail[1]).is_file(), url
    # the block the packaging README offers names files that exist
    readme = (PKG / "README.md").read_text()
    for name in re.findall(r"BASE/docs/screenshots/([\w.-]+)", readme):
        assert (ROOT / "docs" / "screenshots" / name).is_file(), name


def test_every_package_folder_is_installed():
    """A non-editable install (wheel, sdist) carries every folder of .py files: setuptools'
    discovery as pyproject.toml configures it (``packages.find``, regular packages only) finds
    each one, so a new sub-package (io/volumes/vdb/, gui/wizard/, ...) without an __init__.py
    would be left out of the wheel while the editable checkout still imports it."""
    from setuptools import find_packages

    find = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"][
        "packages"]["find"]
    found = set(find_packages(str(ROOT), include=find["include"]))
    folders = {".".join(p.parent.relative_to(ROOT).parts)
               for p in (ROOT / "dreamprint_gui").rglob("*.py") if "__pycache__" not in p.parts}
    assert folders - found == set()
    assert {"dreamprint_gui.io.volumes.vdb", "dreamprint_gui.io.volumes.splats",
            "dreamprint_gui.io.volumes.ingp", "dreamprint_gui.io.volumes.grids",
            "dreamprint_gui.gui.wizard"} <= found
