"""Engine speed: colorimetry of 1e5 spectra, KM forward model, density fits, full predict.

Run: .venv/bin/python benchmarks/bench_engine.py
"""

from __future__ import annotations

import time

import numpy as np

from dreamprint_gui.core.profile import default_profile
from dreamprint_gui.physics.colorimetry import observer_for
from dreamprint_gui.physics.density import fit_sigma_per_wavelength
from dreamprint_gui.physics.kubelka_munk import mix, reflectance_transmittance
from dreamprint_gui.physics.mixture import predict


def timed(label: str, fn, n: int, unit: str) -> None:
    fn()  # warm up (numba compile, caches)
    best = min(_once(fn) for _ in range(3))
    print(f"{label:<48} {best * 1e3:9.1f} ms   {n / best:10.3g} {unit}/s")


def _once(fn) -> float:
    t = time.perf_counter()
    fn()
    return time.perf_counter() - t


def main() -> None:
    p = default_profile()
    rng = np.random.default_rng(0)
    n = 100_000
    conc = rng.dirichlet(np.ones(6), n)
    K, S = mix(conc, p.K, p.S)
    spectra = rng.uniform(0, 1, (n, p.wavelengths_nm.size))
    obs = observer_for(p.wavelengths_nm)
    print(f"profile {p.name}: {p.wavelengths_nm.size} wavelengths, {n:,} mixtures")
    timed("spectra -> XYZ -> sRGB and CIELAB (1e5)", lambda: (obs.spectra_to_sRGB(spectra),
                                                          obs.spectra_to_Lab(spectra)), n,
          "spectra")
    timed("KM R, T at 0.5 mm (1e5 x 36)", lambda: reflectance_transmittance(K, S, 0.5),
          n * 36, "values")
    timed("density fit, tabulated (1e5 x 36)", lambda: fit_sigma_per_wavelength(K, S),
          n * 36, "fits")
    k, s = K[:2000], S[:2000]
    timed("density fit, exact solver (2e3 x 36)",
          lambda: fit_sigma_per_wavelength(k, s, exact=True), 2000 * 36, "fits")
    timed("predict: spectra, colour, density (1e5)", lambda: predict(p, conc), n, "mixtures")


if __name__ == "__main__":
    main()
