"""Entry script of the PyInstaller bundle (the console script's target, as a file)."""

import sys

from dreamprint_gui.gui.app import main

if __name__ == "__main__":
    sys.exit(main())
