"""Entry script of the PyInstaller bundle's desktop application (``dreamprint-gui``)."""

import multiprocessing
import sys

from dreamprint_gui.gui.app import main

if __name__ == "__main__":
    multiprocessing.freeze_support()  # worker processes of a frozen app start here
    sys.exit(main())
