"""Readers: instrument spectra (:mod:`.spectra`), volume sources (:mod:`.volumes`), recipe and
measurement tables (:mod:`.recipes`, :mod:`.measurements_csv`). Imports only
:mod:`dreamprint_gui.core`; never Qt."""
