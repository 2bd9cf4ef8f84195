"""Time read_spectra on large instrument exports (a big chart, a many-sample Cary export).

Run: ``python benchmarks/spectra_read.py``. Prints seconds per file and per sample.
"""

from __future__ import annotations

import tempfile
import time
from pathlib import Path

import numpy as np

from dreamprint_gui.io.spectra import Sample, read_spectra, write_spectra


def cary(path: Path, n_samples: int, n_points: int) -> None:
    wl = np.linspace(1100.0, 190.0, n_points)
    rows = ["".join(f"s{i},," for i in range(n_samples))[:-1],
            "".join("Wavelength (nm),%T," for _ in range(n_samples))]
    y = 50 + 40 * np.sin(wl / 50.0)
    rows += ["".join(f"{x:.4f},{v:.6f}," for _ in range(n_samples)) for x, v in zip(wl, y,
                                                                                    strict=True)]
    path.write_text("\r\n".join(rows + ["", "s0,", "Collection Time: now"]) + "\r\n")


def main() -> None:
    rng = np.random.default_rng(0)
    wl = np.arange(380.0, 731.0, 10.0)
    with tempfile.TemporaryDirectory() as d:
        d = Path(d)
        chart = [Sample(f"P{i}", wl, rng.uniform(0.01, 0.95, wl.size)) for i in range(5000)]
        cases = []
        for fmt in ("cgats", "csv-rows", "csv-columns", "jcamp-dx"):
            n = 5000 if fmt != "jcamp-dx" else 200
            p = d / f"chart.{fmt}"
            write_spectra(p, chart[:n], quantity="reflectance", format=fmt)
            cases.append((f"{fmt}, {n} samples x {wl.size} bands", p, n))
        cary(d / "cary.csv", 20, 911)
        cases.append(("Cary CSV, 20 samples x 911 points", d / "cary.csv", 20))
        for label, p, n in cases:
            t0 = time.perf_counter()
            sf = read_spectra(p)
            dt = time.perf_counter() - t0
            assert len(sf) == n
            print(f"{label:<38} {p.stat().st_size / 1e6:6.2f} MB  {dt:6.3f} s  "
                  f"{dt / n * 1e6:8.1f} us/sample")


if __name__ == "__main__":
    main()
