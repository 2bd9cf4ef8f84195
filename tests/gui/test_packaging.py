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
