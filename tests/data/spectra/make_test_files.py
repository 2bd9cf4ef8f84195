"""Generate the spectral test files in this folder and the example calibration set.

Run from the repository root: ``python tests/data/spectra/make_test_files.py``. Deterministic;
the outputs are committed so tests need not regenerate them. Every file is built from closed
forms (a logistic reflectance edge, Beer-Lambert absorbance bands, and the Kubelka-Munk layer of
the built-in default profile), so a test can compare what is read with what was meant.

The instrument layouts are those the readers' docstrings describe (Cary WinUV CSV, i1Profiler
and ArgyllCMS CGATS.17, JCAMP-DX 4.24 DIFDUP); each writer here is written out by hand, not
through DreamPrint's own writers, so reading them back is not a round trip of one code path.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
SET = HERE.parent / "calibration_set"


def edge(wl: np.ndarray, centre: float = 550.0, low: float = 0.05, high: float = 0.85,
         width: float = 25.0) -> np.ndarray:
    """A smooth reflectance edge (yellow-like for centre ~500, red-like for ~600)."""
    return low + (high - low) / (1.0 + np.exp(-(wl - centre) / width))


def band(wl: np.ndarray, centre: float, peak: float, width: float) -> np.ndarray:
    """A Gaussian absorbance band."""
    return peak * np.exp(-0.5 * ((wl - centre) / width) ** 2)


PATCHES = {  # name -> (centre, low, high)
    "Patch 1 yellow": (500.0, 0.06, 0.88),
    "Patch 2 red": (600.0, 0.04, 0.80),
    "Patch 3 grey": (550.0, 0.30, 0.31),
}


def cary(path: Path, names: list[str], x_lists: list[np.ndarray], y_lists: list[np.ndarray],
         mode: str) -> None:
    """Cary WinUV "Save as CSV": name row, heading row, columns side by side, method blocks."""
    n = max(len(x) for x in x_lists)
    rows = ["".join(f"{nm},," for nm in names)[:-1],
            "".join(f"Wavelength (nm),{mode}," for _ in names)]
    for i in range(n):
        cells = []
        for x, y in zip(x_lists, y_lists, strict=True):
            cells.append(f"{x[i]:.7g},{y[i]:.10g}," if i < len(x) else ",,")
        rows.append("".join(cells).rstrip(",") + ",")
    rows.append("")
    for nm, x in zip(names, x_lists, strict=True):
        rows += [f"{nm},", nm, "Collection Time: 3/14/2025 10:21:07 AM", "Operator Name  :",
                 "Scan Software Version: 5.1.0.1016", "Parameter List :",
                 "Instrument                        Cary 60", f"Start (nm)          "
                 f"              {x[0]:.1f}", f"Stop (nm)                         {x[-1]:.1f}",
                 "X Mode                            Nanometers",
                 f"Y Mode                            {mode}",
                 "UV-Vis Data Interval (nm)         5.00", "Beam Mode                   "
                 "      Dual Beam", "Comments", "Method Log     :", "Method Name    : T-scan",
                 "End Method Modifications", ""]
    path.write_text("\r\n".join(rows) + "\r\n", encoding="utf-8", newline="")


def cgats_i1profiler(path: Path, names: list[str], wl: np.ndarray, values: np.ndarray,
                     percent: bool) -> None:
    """i1Profiler-like CGATS.17: tabs, CRLF, quoted names with blanks, SPECTRAL_NM fields."""
    scale = 100.0 if percent else 1.0
    fields = ["SAMPLE_ID", "SAMPLE_NAME", "LAB_L", "LAB_A", "LAB_B"] + [
        f"SPECTRAL_NM{w:.0f}" for w in wl]
    lines = ["CGATS.17", 'ORIGINATOR\t"i1Profiler"', 'CREATED\t"March 14, 2025"',
             'INSTRUMENTATION\t"i1Pro 3"', 'MEASUREMENT_CONDITION\t"M0"',
             "KEYWORD\t\"DEVCALSTD\"", 'DEVCALSTD\t"XRGA"', "",
             f"NUMBER_OF_FIELDS\t{len(fields)}", "BEGIN_DATA_FORMAT", "\t".join(fields),
             "END_DATA_FORMAT", f"NUMBER_OF_SETS\t{len(names)}", "BEGIN_DATA"]
    for i, (nm, v) in enumerate(zip(names, values, strict=True), 1):
        lines.append(f'{i}\t"{nm}"\t50.00\t0.00\t0.00\t'
                     + "\t".join(f"{x * scale:.6g}" for x in v))
    lines.append("END_DATA")
    path.write_text("\r\n".join(lines) + "\r\n", encoding="utf-8", newline="")


def main() -> None:
    SET.mkdir(parents=True, exist_ok=True)
    wl10 = np.arange(380.0, 731.0, 10.0)
    names = list(PATCHES)
    R = np.array([edge(wl10, c, lo, hi) for c, lo, hi in PATCHES.values()])

    # i1Profiler, percent without saying so (the 0-100 ambiguity).
    cgats_i1profiler(HERE / "cgats_i1profiler_percent.txt", names, wl10, R, percent=True)

    # ArgyllCMS .ti3: SPEC_ fields, SPECTRAL_NORM 100, blanks, a second table after.
    wl_a = np.arange(380.0, 731.0, 10.0)
    fields = ["SAMPLE_ID", "CMYK_C", "CMYK_M", "CMYK_Y", "CMYK_K"] + [
        f"SPEC_{w:.0f}" for w in wl_a]
    lines = ["CTI3   ", "", 'DESCRIPTOR "Argyll Calibration Target chart information 3"',
             'ORIGINATOR "Argyll chartread"', 'DEVICE_CLASS "OUTPUT"',
             'COLOR_REP "CMYK_XYZ"', 'KEYWORD "SPECTRAL_BANDS"', f'SPECTRAL_BANDS "{wl_a.size}"',
             'KEYWORD "SPECTRAL_START_NM"', 'SPECTRAL_START_NM "380.000000"',
             'KEYWORD "SPECTRAL_END_NM"', 'SPECTRAL_END_NM "730.000000"',
             'KEYWORD "SPECTRAL_NORM"', 'SPECTRAL_NORM "100.000000"', "",
             f"NUMBER_OF_FIELDS {len(fields)}", "BEGIN_DATA_FORMAT", " ".join(fields) + " ",
             "END_DATA_FORMAT", "", f"NUMBER_OF_SETS {len(names)}", "BEGIN_DATA"]
    for i, v in enumerate(R, 1):
        lines.append(f"{i} 0.0 0.0 0.0 0.0 " + " ".join(f"{x * 100:.6f}" for x in v))
    lines += ["END_DATA", "", "CAL", "", 'DESCRIPTOR "Argyll Device Calibration State"',
              "NUMBER_OF_FIELDS 2", "BEGIN_DATA_FORMAT", "RGB_I RGB_R", "END_DATA_FORMAT",
              "NUMBER_OF_SETS 2", "BEGIN_DATA", "0.0 0.0", "1.0 1.0", "END_DATA"]
    (HERE / "cgats_argyll.ti3").write_text("\n".join(lines) + "\n", encoding="utf-8")

    # CGATS long layout: one row per (sample, wavelength), SPECTRAL_PCT in 0-100.
    lines = ["CGATS.17", 'ORIGINATOR "spectro lab"', "NUMBER_OF_FIELDS 3",
             "BEGIN_DATA_FORMAT", "SAMPLE_NAME SPECTRAL_NM SPECTRAL_PCT", "END_DATA_FORMAT",
             f"NUMBER_OF_SETS {len(names) * wl10.size}", "BEGIN_DATA"]
    for nm, v in zip(names, R, strict=True):
        lines += [f'"{nm}" {w:.0f} {x * 100:.6f}' for w, x in zip(wl10, v, strict=True)]
    lines.append("END_DATA")
    (HERE / "cgats_spectral_pct_long.txt").write_text("\n".join(lines) + "\n", encoding="utf-8")

    # Cary, three %T samples side by side, descending, the third shorter.
    wl5 = np.arange(800.0, 349.0, -5.0)
    xs = [wl5, wl5, wl5[10:]]
    A = [band(x, c, p, w) + 0.02 for x, (c, p, w) in
         zip(xs, [(620, 1.2, 40), (530, 0.9, 35), (430, 1.5, 30)], strict=True)]
    cary(HERE / "cary_multi_percentT.csv", ["cyan 0.5mm", "magenta 0.5mm", "yellow 0.5mm"],
         xs, [100 * 10.0 ** -a for a in A], "%T")

    # Plain CSV, a sample per row, semicolons, decimal commas, percent reflectance.
    head = "Sample;" + ";".join(f"{w:.0f} nm" for w in wl10)
    rows = ["# exported from a lab sheet: Reflectance in %", head]
    for nm, v in zip(names, R, strict=True):
        rows.append(nm + ";" + ";".join(f"{x * 100:.4f}".replace(".", ",") for x in v))
    (HERE / "csv_rows_semicolon_percent.csv").write_text("\n".join(rows) + "\n",
                                                         encoding="utf-8")

    # Plain CSV, a wavelength per row, micrometres, transmittance fractions, uneven steps.
    wl_um = np.array([0.36, 0.38, 0.39, 0.41, 0.45, 0.5, 0.55, 0.6, 0.65, 0.7, 0.75, 0.8])
    T = 10.0 ** -(band(wl_um * 1000, 600, 0.8, 50) + 0.01)
    rows = ["# clear resin 2 mm, transmittance", "Wavelength (µm),resin 2mm"]
    rows += [f"{w:.2f},{t:.8f}" for w, t in zip(wl_um, T, strict=True)]
    (HERE / "csv_columns_micrometres_T.csv").write_text("\n".join(rows) + "\n",
                                                        encoding="utf-8")

    # JCAMP-DX 4.24 absorbance, DIFDUP compressed by hand-written rules (see jcamp_encode).
    wl2 = np.arange(360.0, 781.0, 2.0)
    a = band(wl2, 620, 1.2, 40) + 0.02
    a[wl2 > 740] = a[wl2 > 740][0]  # a flat tail so DUP counts occur
    ints = np.rint(a / 1e-5).astype(int)
    (HERE / "jcamp_difdup_absorbance.jdx").write_text(
        jcamp_text("cyan ink 0.5 mm", "ABSORBANCE", wl2, ints, 1e-5), encoding="utf-8")

    # IES TM-27-14: a relative SPD (refused as R/T) and a reflectance.
    import colour

    for fname, quantity, values in (
            ("spdx_led_relative.spdx", "relative", band(wl10, 450, 1.0, 12)
             + band(wl10, 580, 0.6, 60)),
            ("spdx_reflectance.spdx", "reflectance", R[0])):
        sd = colour.SpectralDistribution_IESTM2714(
            str(HERE / fname), header=colour.io.Header_IESTM2714(
                manufacturer="DreamPrint tests", catalog_number="0",
                description=fname, document_creator="make_test_files.py",
                unique_identifier=fname, measurement_equipment="none",
                laboratory="none", report_number="0", report_date="2025-03-14",
                document_creation_date="2025-03-14", comments="generated"),
            spectral_quantity=quantity, reflection_geometry="di:8" if quantity ==
            "reflectance" else None)
        sd.wavelengths = wl10
        sd.values = values
        sd.write()

    make_calibration_set()


def jcamp_text(title: str, yunits: str, wl: np.ndarray, ints: np.ndarray, yfactor: float,
               per_line: int = 12) -> str:
    """JCAMP-DX 4.24 with (X++(Y..Y)) in DIFDUP form, following McDonald & Wilks 1988."""
    lines = [f"##TITLE={title}", "##JCAMP-DX=4.24", "##DATA TYPE=UV/VIS SPECTRUM",
             "##ORIGIN=DreamPrint test data", "##OWNER=public domain",
             "##XUNITS=NANOMETERS", f"##YUNITS={yunits}", "##XFACTOR=1.0",
             f"##YFACTOR={yfactor}", f"##FIRSTX={wl[0]:g}", f"##LASTX={wl[-1]:g}",
             f"##NPOINTS={wl.size}", f"##FIRSTY={ints[0] * yfactor:.6g}",
             "##XYDATA=(X++(Y..Y))"]
    lines += jcamp_encode(ints, wl, per_line)
    lines.append("##END=")
    return "\n".join(lines) + "\n"


def jcamp_encode(ints: np.ndarray, wl: np.ndarray, per_line: int) -> list[str]:
    sqz_pos, sqz_neg = "@ABCDEFGHI", "@abcdefghi"
    dif_pos, dif_neg = "%JKLMNOPQR", "%jklmnopqr"
    dup = "STUVWXYZs"

    def code(v: int, pos: str, neg: str) -> str:
        s = str(abs(v))
        return (pos if v >= 0 else neg)[int(s[0])] + s[1:]

    out = []
    i = 0
    while i < ints.size:
        start = max(i - 1, 0)  # each later line repeats the previous last ordinate (Y check)
        chunk = [int(v) for v in ints[start:i + per_line]]
        text = code(chunk[0], sqz_pos, sqz_neg)
        j = 1
        while j < len(chunk):
            d = chunk[j] - chunk[j - 1]
            k = j
            while k + 1 < len(chunk) and chunk[k + 1] - chunk[k] == d:
                k += 1
            text += code(d, dif_pos, dif_neg)
            if k > j:
                n = str(k - j + 1)
                text += dup[int(n[0]) - 1] + n[1:]
            j = k + 1
        out.append(f"{wl[start]:g} {text}")
        i += per_line
    return out


def make_calibration_set() -> None:
    """Six inks at two thicknesses, R in CGATS (fractions), T in Cary %T and one JCAMP file."""
    from dreamprint_gui.core.profile import INKS, default_profile
    from dreamprint_gui.physics.kubelka_munk import reflectance_transmittance

    prof = default_profile()
    grid = prof.wavelengths_nm
    thick = (0.1, 0.3)
    names, Rs, Ts = [], [], []
    for i, ink in enumerate(INKS):
        for t in thick:
            R, T = reflectance_transmittance(prof.K[i], prof.S[i], t)
            names.append(f"{ink} {t} mm")
            Rs.append(R)
            Ts.append(T)
    cgats_i1profiler(SET / "reflectance_i1profiler.txt", names, grid, np.array(Rs),
                     percent=False)
    # T of all but cyan from a Cary export on a 5 nm grid reaching beyond the profile grid.
    wl5 = np.arange(750.0, 369.0, -5.0)
    cary_names, cary_y = [], []
    for name, T in zip(names, Ts, strict=True):
        if name.startswith("C "):
            continue
        cary_names.append(name)
        cary_y.append(100 * np.interp(wl5, grid, T))
    cary(SET / "transmittance_cary.csv", cary_names, [wl5] * len(cary_names), cary_y, "%T")
    # Cyan's T as absorbance JCAMP-DX on the profile grid itself (converted on import).
    for t, T in zip(thick, Ts[0:2], strict=True):
        ints = np.rint(-np.log10(T) / 1e-6).astype(int)
        (SET / f"cyan_{t}mm_absorbance.jdx").write_text(
            jcamp_text(f"C {t} mm", "ABSORBANCE", grid, ints, 1e-6), encoding="utf-8")
    toml = ['# DreamPrint calibration set (see docs/calibration-set.md).',
            '# Generated by tests/data/spectra/make_test_files.py from the built-in profile,',
            '# so a calibration from it should give back that profile\'s K and S.',
            'format = "dreamprint-calibration-set"', "version = 1",
            'name = "example: default profile, synthetic measurements"', "",
            "[defaults]", "extrapolate_nm = 0", ""]
    for ink in INKS:
        for t in thick:
            name = f"{ink} {t} mm"
            toml += ["[[layer]]", f'ink = "{ink}"', f"thickness_mm = {t}",
                     f'R = {{ file = "reflectance_i1profiler.txt", sample = "{name}" }}']
            if ink == "C":
                toml.append(f'T = {{ file = "cyan_{t}mm_absorbance.jdx" }}')
            else:
                toml.append(f'T = {{ file = "transmittance_cary.csv", sample = "{name}" }}')
            toml.append("")
    (SET / "set.toml").write_text("\n".join(toml), encoding="utf-8")
    assert math.isfinite(float(np.sum(Rs)))


if __name__ == "__main__":
    main()
