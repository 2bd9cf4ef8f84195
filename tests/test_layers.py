"""The engine and io layers never import Qt (they run headless, in workers and on clusters)."""

import subprocess
import sys


def test_engine_and_io_import_without_qt():
    code = (
        "import sys, pkgutil, importlib\n"
        "import dreamprint_gui.engine as e, dreamprint_gui.io as i, dreamprint_gui.cli\n"
        "for pkg in (e, i):\n"
        "    for m in pkgutil.walk_packages(pkg.__path__, pkg.__name__ + '.'):\n"
        "        importlib.import_module(m.name)\n"
        "bad = [m for m in sys.modules if m.startswith(('PySide6', 'PyQt', 'pyvistaqt'))]\n"
        "assert not bad, bad\n"
    )
    subprocess.run([sys.executable, "-c", code], check=True)
