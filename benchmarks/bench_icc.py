"""The ICC profile's figures (issue 48): build time, size, and its accuracy read back by Little CMS.

For each ICC version and DreamPrint intent asked for, builds the product's profile (the 100^3
table, 33^3 profile grids, as ``dreamprint icc``), reads it back with Little CMS (double
precision) and prints, over the 9^3 RGB cube + the demo's colours + the knight voxel model's
palette + the INRIA splat's colours (from ../shared/data when present) and over 5000 random RGB:

- A2B (ICC-absolute) vs DreamPrint's prediction of the print: dE2000 mean / p95 / max;
- B2A1 then A2B1 on the prints of those colours: dE2000 mean / p95 / max;

and, when ArgyllCMS is installed, ``profcheck -k -i D65`` of the profile against the .ti3 of a
9^3 patch set (Argyll computing the colours itself from the spectra).

    PYTHONPATH=. python benchmarks/bench_icc.py [--versions 2,4] [--intents colorimetric]
        [--grid 33]
"""

from __future__ import annotations

import argparse
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))


def source_colours():
    import numpy as np

    from dreamprint_gui.gamut.icc_export import check_colours

    parts = [check_colours()]
    data = ROOT.parent / "shared" / "data"
    if data.is_dir():
        from dreamprint_gui.io.volumes.grids.magicavoxel import read_vox
        from dreamprint_gui.io.volumes.splats.cloud import open_path

        models, palette = read_vox(data / "voxels" / "magicavoxel_chr_knight.vox")
        used = np.unique(np.concatenate([m[1][:, 3] for m in models]))
        parts.append(palette[used, :3] / 255.0)
        parts.append(np.clip(open_path(data / "splats" / "inria3dgs_iter7000_sh3_9080.ply")
                             .rgb, 0, 1))
    return np.concatenate(parts)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--versions", default="2,4")
    ap.add_argument("--intents", default="colorimetric,relative,perceptual")
    ap.add_argument("--grid", type=int, default=33)
    args = ap.parse_args()
    import numpy as np

    from dreamprint_gui.core.profile import default_profile
    from dreamprint_gui.gamut import get_tables, lcms
    from dreamprint_gui.gamut.characterisation import characterisation_text
    from dreamprint_gui.gamut.icc import build_icc, check_profile
    from dreamprint_gui.gamut.print_pcs import PrintPCS

    profile = default_profile()
    colours = source_colours()
    rnd = np.random.default_rng(48).random((5000, 3))
    print(f"Little CMS {lcms.library().cmsGetEncodedCMMversion()}; {len(colours)} source "
          f"colours (9^3 cube, demo, voxel palette, splat), 5000 random RGB")
    for intent in args.intents.split(","):
        tables = get_tables(profile, intent=intent)
        pcs = PrintPCS.for_tables(profile, tables)
        for version in (int(v) for v in args.versions.split(",")):
            t0 = time.perf_counter()
            data = build_icc(profile, tables, printer="Stratasys J850", version=version,
                             a2b_grid=args.grid, b2a_grid=args.grid)
            secs = time.perf_counter() - t0
            line = f"{intent:12s} v{version} {args.grid}^3: built {secs:5.1f} s, "
            line += f"{len(data) / 1e6:.2f} MB"
            for name, rgb in (("sources", colours), ("random", rnd)):
                f = check_profile(data, pcs, rgb)
                a, r = f["a2b_dE2000"], f["round_trip_dE2000"]
                line += (f" | {name}: A2B {a['mean']:.3f}/{a['p95']:.3f}/{a['max']:.2f}, "
                         f"B2A>A2B {r['mean']:.3f}/{r['p95']:.3f}/{r['max']:.2f}")
            print(line, flush=True)
            if version == 2 and shutil.which("profcheck"):
                with tempfile.TemporaryDirectory() as d:
                    icc, ti3 = Path(d) / "p.icc", Path(d) / "p.ti3"
                    icc.write_bytes(data)
                    ti3.write_text(characterisation_text(pcs, profile, 9, "argyll"))
                    out = subprocess.run(["profcheck", "-k", "-i", "D65", str(ti3), str(icc)],
                                         capture_output=True, text=True, check=True)
                    print(f"{'':12s}    ArgyllCMS profcheck (729 patches): "
                          f"{out.stdout.strip().splitlines()[-1]}", flush=True)


if __name__ == "__main__":
    main()
