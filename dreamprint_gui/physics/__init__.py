"""The method's physics: Kubelka-Munk two-flux slabs (:mod:`.kubelka_munk`), mixtures
(:mod:`.mixture`), Saunderson's surface correction (:mod:`.saunderson`), colour under D65 /
CIE 1931 (:mod:`.colorimetry`), the scalar density fit (:mod:`.density`) and calibration from
measured R, T (:mod:`.calibration`) or a mixture chart (:mod:`.chart_calibration`).
Imports only :mod:`dreamprint_gui.core`."""
