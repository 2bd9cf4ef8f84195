"""DreamPrint's desktop application (PySide6 + pyvistaqt).

Everything Qt lives in this package; it computes nothing the engine owns, it calls the engine
(``dreamprint_gui.engine``) and the readers (``dreamprint_gui.io``) and shows their results.
Entry point: :func:`dreamprint_gui.gui.app.main` (console script ``dreamprint-gui``).
"""
