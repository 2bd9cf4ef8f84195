"""Rebuild resources/profiles/polyjet_default.json from resources/inks/polyjet_ks/.

Run: .venv/bin/python scripts/build_default_profile.py
The assumptions (absolute scale, Clear ink) are documented in resources/profiles/SOURCES.md.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from dreamprint_gui.core.profile import INKS, InkProfile, now_iso, save_profile

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT / "resources" / "inks" / "polyjet_ks"
# The source tabulates K/S of opaque patches with no unit. Read as "per 10 um", i.e. x100 per mm:
# then every ink is opaque (T < 0.3 %) within the paper's t_max = 5 mm at every wavelength, as its
# Table 1 requires, and a 1 mm VeroWhite-like layer lets through about a tenth of the light.
SCALE_PER_MM = 100.0
SOURCE_ROWS = ("K", "C", "M", "Y", "W")


def clear_ink(wl: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """VeroClear-like resin: internal transmittance ~97 %/mm at 550 nm, lower in the violet
    (the slight yellow of acrylate photopolymers), scattering 0.002/mm (near-transparent)."""
    K = 0.03 + 0.25 * np.exp(-(wl - 380.0) / 25.0)
    S = np.full_like(wl, 0.002)
    return K, S


def main() -> None:
    wl = np.loadtxt(DATA / "spectral_samples.csv", delimiter=",", dtype=np.float64)
    Ks = np.loadtxt(DATA / "absorbtion_K.csv", delimiter=",") * SCALE_PER_MM
    Ss = np.loadtxt(DATA / "scattering_S.csv", delimiter=",") * SCALE_PER_MM
    K = np.zeros((len(INKS), wl.size))
    S = np.zeros_like(K)
    for row, ink in enumerate(SOURCE_ROWS):
        K[INKS.index(ink)], S[INKS.index(ink)] = Ks[row], Ss[row]
    K[INKS.index("Cl")], S[INKS.index("Cl")] = clear_ink(wl)
    profile = InkProfile(
        name="polyjet-default", wavelengths_nm=wl, K=K, S=S,
        provenance={
            "created": now_iso(),
            "model": "Kubelka-Munk two-flux, colour at R_inf, density eqs. 8-9",
            "measurements": "resources/inks/polyjet_ks (YanniZhangYZ/gaussian-fabrication "
                            "ink_meta, Inria non-commercial licence)",
            "scale": f"source K and S x {SCALE_PER_MM:g} = 1/mm (assumed, see SOURCES.md)",
            "clear_ink": "modelled: K = 0.03 + 0.25 exp(-(lambda-380)/25) 1/mm, S = 0.002/mm",
            # the colour inks' K/S are measured (the source), their absolute scale assumed
            "ink_origin": {ink: "modelled" for ink in INKS},
        },
    )
    out = ROOT / "resources" / "profiles" / "polyjet_default.json"
    save_profile(profile, out)
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
