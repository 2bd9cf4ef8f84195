"""DreamPrint's desktop application (PySide6 + pyvistaqt).

Everything Qt lives in this package; it computes nothing itself: it calls the layers below
(``proof``, ``job``, ``gamut``, ``physics``, ``io``, ``core``: the README's Layout) and shows
their results, as the command line (:mod:`dreamprint_gui.cli`) prints them. Widgets import
those layers inside the functions that use them, so that the window appears before numba,
colour-science and the tables load.
Entry point: :func:`dreamprint_gui.gui.app.main` (console script ``dreamprint-gui``).
"""
