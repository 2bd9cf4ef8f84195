import sys

from dreamprint_gui.cli import main

sys.exit(main())
