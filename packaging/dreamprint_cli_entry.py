"""Entry script of the PyInstaller bundle's command line (``dreamprint``)."""

import multiprocessing
import sys

from dreamprint_gui.cli import main

if __name__ == "__main__":
    multiprocessing.freeze_support()  # worker processes of a frozen app start here
    sys.exit(main())
