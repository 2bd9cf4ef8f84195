"""Stage 4 of a print job: labels -> PNG slices (``png_slices``; the zlib stream written from
the label runs: ``label_deflate``)."""
