"""The calibration wizard: ink measurements (or a chart) -> a fitted, saved, active profile.

One module per page: :class:`CalibrationWizard` (a QWizard, :mod:`.calibration`) and its pages:

1. :class:`MeasurementsPage` (:mod:`.measurements`): per ink, the files holding its reflectance
   and transmittance (any format ``io.spectra.read_spectra`` reads), the sample in each (the
   picked one is the one used: only its own impossible values refuse it, naming it;
   ``calibration_set.measured_values``), what each file holds when it does not say (the CLI's
   ``--file-quantity``: an absorbance file is read as T = 10^-A), and the swatch thickness,
   required (no default: the page names the inks lacking it); or a calibration set (TOML,
   ``io.spectra.calibration_set``; several thicknesses per ink). Every parsed spectrum is
   plotted at once, resampled onto the profile's grid; each file's problem shows on its own
   row. A tick, "slabs measured in air", leads to the slab page (:class:`SlabPage`,
   :mod:`.slabs`, the translucency wedge): the faces' refractive index, k2 fitted or not, each
   ink's thickness series and what it can separate.
2. :class:`ChartPage` (:mod:`.chart`) (optional): a mixture chart, recipes (``--mix-file`` CSV)
   and the measured reflectance of each patch.
3. :class:`FitPage` (:mod:`.fit`): runs ``calibration.calibrate_profile`` (and
   ``chart_calibration.fit_chart``) on a worker thread, showing the stage and the elapsed time,
   with a Stop button that returns the page at once (the fit has no cancel token: it is
   abandoned, ``workers.abandonable``, and its result dropped); then a table of what can be
   checked per ink (with several thicknesses, the held-out R/T error of
   ``calibration.leave_one_thickness_out``; with one R/T pair, that the fit is exact by
   construction), and plots: measured vs fitted R and T, the fitted K and S, the held-out and
   residual error per wavelength, the chart's cross-validated dE2000.
4. :class:`ChartProofPage` (:mod:`.chart_proof`) (after a chart calibration only): "how well
   does the proof predict your chart": the chart proof (``proof.chart``) of the fitted profile
   on a worker thread (progress per render pass, Stop), dE2000 mean, p95, max and worst
   patches, and the measured-vs-proofed picture.
5. :class:`SavePage` (:mod:`.save`): name and file; saving makes the profile active
   (``profileSaved``).

What the pages share (ink colours, the error style, a plot canvas, a page that runs a task)
is in :mod:`.common`.
"""
