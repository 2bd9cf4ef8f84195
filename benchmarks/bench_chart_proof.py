"""Chart proof against a real printed chart: the built-in profile, the optics variants, and the
operator's 2-fold workflow (calibrate from half the patches, chart-proof the other half).

Needs a chart's recipes (``calibrate --chart`` format) and its measured reflectance (one
spectrum per recipe). The data used for the figures in docs/physics.md (70 printed PolyJet
mixtures of K, C, M, Y, W, measured 380-730 nm) is public but under a non-commercial licence, so
it is not shipped: its `ratios.csv` and `color_measurements.csv` are read as distributed.

    python benchmarks/bench_chart_proof.py RECIPES.csv REFLECTANCE.csv [--spp 512]
        [--variants none,glossy,matte,none+hg:0.4 | --variants ""] [--no-folds] [--geometry d:8]
        [--fold-variants default,matte,...]

Prints, per variant with the built-in profile, the chart proof's dE2000 (mean, p95, max) and
Kubelka-Munk R_inf's on the same patches; then per fold the calibration's own cross-validated
figure, KM R_inf of the held-out half (at the profile's wavelengths and in the proof's bands:
the floor the band integration sets) and the chart proof of the held-out half with the
calibrated profile, for each of ``--fold-variants`` (``default``: the proof's default optics).
A variant is SURFACE[+PHASE], e.g. ``matte+hg:0.4``.

The target figure (issue 28): the last line, ``2-fold chart proof ... default``.
"""

from __future__ import annotations

import argparse
import os
import time

import numpy as np


def main() -> None:
    from dreamprint_gui.core.profile import default_profile
    from dreamprint_gui.io.chart_files import read_chart
    from dreamprint_gui.physics.chart_calibration import fit_chart
    from dreamprint_gui.physics.colorimetry import delta_E2000, observer_for
    from dreamprint_gui.physics.kubelka_munk import mix, reflectance_infinite
    from dreamprint_gui.proof.chart import render_chart
    from dreamprint_gui.proof.optics import resolve_optics
    from dreamprint_gui.proof.spectral import spectral_bands

    ap = argparse.ArgumentParser()
    ap.add_argument("recipes")
    ap.add_argument("reflectance")
    ap.add_argument("--spp", type=int, default=512)
    ap.add_argument("--bands", type=int, default=12)
    ap.add_argument("--geometry", default="d:8")
    ap.add_argument("--variants", default="none,glossy,matte,none+hg:0.4")
    ap.add_argument("--no-folds", action="store_true")
    ap.add_argument("--fold-variants", default="default")
    args = ap.parse_args()

    base = default_profile()
    files = read_chart(args.recipes, args.reflectance, base.wavelengths_nm)
    c, R = files.recipes, files.reflectance
    obs = observer_for(base.wavelengths_nm)
    lab = obs.spectra_to_Lab(R)
    print(f"{len(c)} patches, {args.geometry}, {args.spp} spp, {args.bands} bands; "
          f"{os.cpu_count()} cores, load average {os.getloadavg()[0]:.1f}")

    def fmt(de):
        return f"mean {de.mean():5.2f}  p95 {np.percentile(de, 95):5.2f}  max {de.max():5.2f}"

    def proof(profile, idx, variant):
        surface, _, phase = variant.partition("+")
        optics = resolve_optics(None if surface == "default" else surface, phase or None,
                                profile.proof_optics)
        b = spectral_bands(profile, args.bands)
        t0 = time.perf_counter()
        Rb, _ = render_chart(c[idx], profile, optics, b, args.geometry, spp=args.spp)
        de = delta_E2000(lab[idx], b.observer.XYZ_to_Lab(np.maximum(b.to_XYZ(Rb), 0)))
        return de, time.perf_counter() - t0

    allidx = np.arange(len(c))
    km = delta_E2000(lab, obs.spectra_to_Lab(reflectance_infinite(*mix(c, base.K, base.S))))
    print(f"built-in profile, KM R_inf (36 wavelengths)   {fmt(km)}")
    for v in [v for v in args.variants.split(",") if v]:
        de, t = proof(base, allidx, v)
        print(f"built-in profile, chart proof {v:16s} {fmt(de)}   ({t:.0f} s)", flush=True)
    if args.no_folds:
        return
    perm = np.random.default_rng(0).permutation(len(c))
    halves = (np.sort(perm[: len(c) // 2]), np.sort(perm[len(c) // 2:]))
    fvars = [v for v in args.fold_variants.split(",") if v]
    res: dict[str, list] = {v: [] for v in fvars}
    for k, (train, test) in enumerate((halves, halves[::-1])):
        fit = fit_chart(base, c[train], R[train], name=f"fold{k}")
        p = fit.profile
        km = delta_E2000(lab[test], obs.spectra_to_Lab(reflectance_infinite(*mix(c[test], p.K,
                                                                                 p.S))))
        b = spectral_bands(p, args.bands)
        kmb = delta_E2000(lab[test], b.observer.XYZ_to_Lab(
            b.to_XYZ(reflectance_infinite(*mix(c[test], b.K, b.S)))))
        print(f"fold {k + 1}: calibrated on {len(train)} patches (its own 5-fold CV "
              f"{fit.cv_dE2000.mean():.2f}); held-out {len(test)}: KM R_inf {fmt(km)}; "
              f"in {args.bands} bands {fmt(kmb)}", flush=True)
        for v in fvars:
            de, t = proof(p, test, v)
            res[v].append(de)
            print(f"fold {k + 1}: chart proof {v:16s} {fmt(de)} ({t:.0f} s)", flush=True)
    for v in fvars:
        both = np.concatenate(res[v])
        print(f"2-fold chart proof, both halves, {v}: {fmt(both)}; load average "
              f"{os.getloadavg()[0]:.1f}")
    print(f"CPU time of this process {time.process_time():.0f} s")


if __name__ == "__main__":
    main()
