"""The README's compensation figure: source | open-loop print | compensated print per view.

Runs :func:`dreamprint_gui.proof.compensated.compare_compensation` (what the proof tab's
"Compensate appearance" runs: the correction optimised on the optimiser's training cameras
(elevations 35 and 5 degrees in turn) with seed + 1, then the proof of the paper's open-loop
job and of the compensated job on the proof's cameras at elevation 20 degrees with the seed),
on the default printer, and writes one PNG with the figures of both and a JSON of the reports
beside it.

    PYTHONPATH=. python scripts/compensation_figure.py SOURCE OUT.png [--height-mm 20]
        [--background empty] [--views 2] [--resolution 160] [--spp 64] [--cells 128]
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))


def sheet(result: dict, title: str):
    import numpy as np
    from PIL import Image, ImageDraw

    from dreamprint_gui.proof.compare import to_display

    ol, co = result["open_loop"], result["compensated"]
    # every image cropped to the box that holds the object in all of them (the figures are
    # those of the whole frames), then enlarged by whole pixels (no smoothing)
    shown = [[to_display(im) for im in (x["source"], x["print"], y["print"])]
             for x, y in zip(ol["images"], co["images"], strict=True)]
    ink = np.any([np.any(im < 245, axis=-1) for row in shown for im in row], axis=0)
    ys, xs = np.nonzero(ink)
    n = ink.shape[0]
    y0, y1 = max(0, ys.min() - 4), min(n, ys.max() + 5)
    x0, x1 = max(0, xs.min() - 4), min(n, xs.max() + 5)
    k = max(1, min(3, 240 // max(x1 - x0, y1 - y0)))
    shown = [[np.kron(im[y0:y1, x0:x1], np.ones((k, k, 1), np.uint8)) for im in row]
             for row in shown]
    rh, rw = shown[0][0].shape[:2]
    pad, head, cap = 6, 58, 16
    w = 3 * rw + 4 * pad
    h = head + len(ol["images"]) * (rh + cap + pad) + pad
    img = Image.new("RGB", (max(w, 560), h), (255, 255, 255))
    d = ImageDraw.Draw(img)
    a, b = ol["report"]["overall"], co["report"]["overall"]
    floor = ol["report"].get("gamut_floor") or {}

    def figs(o):
        return (f"dE2000 {o['mean_de2000']:.2f} / S-CIELAB {o['mean_scielab_de2000']:.2f} / "
                f"coverage {o['coverage_error']:+.3f}")

    d.text((pad, 4), title, fill=(0, 0, 0))
    d.text((pad, 18), f"open loop (paper): {figs(a)}", fill=(0, 0, 0))
    d.text((pad, 30), f"compensated:       {figs(b)}", fill=(0, 0, 0))
    d.text((pad, 42), f"gamut floor dE2000 {floor.get('mean_de2000', float('nan')):.2f}; "
           "columns: source | open-loop print | compensated print (cropped, "
           f"x{k})", fill=(90, 90, 90))
    for r, row in enumerate(shown):
        top = head + r * (rh + cap + pad)
        va, vb = ol["report"]["views"][r], co["report"]["views"][r]
        d.text((pad, top), f"view {r}: az {va['azimuth_deg']:.0f} el {va['elevation_deg']:.0f}"
               f"  open loop dE2000 {va['mean_de2000']:.2f}, compensated "
               f"{vb['mean_de2000']:.2f}", fill=(0, 0, 0))
        for c, im in enumerate(row):
            img.paste(Image.fromarray(im), (pad + c * (rw + pad), top + cap))
    return img


def main() -> int:
    from dreamprint_gui.core.printer import DEFAULT_PRINTER
    from dreamprint_gui.proof.compensated import compare_compensation
    from dreamprint_gui.proof.runner import ProofSettings

    ap = argparse.ArgumentParser()
    ap.add_argument("source")
    ap.add_argument("out")
    ap.add_argument("--height-mm", type=float, default=20.0)
    ap.add_argument("--background", default="empty", choices=("clear", "empty"))
    ap.add_argument("--views", type=int, default=2)
    ap.add_argument("--resolution", type=int, default=160)
    ap.add_argument("--spp", type=int, default=64)
    ap.add_argument("--cells", type=int, default=128)
    ap.add_argument("--iterations", type=int, default=4)
    ap.add_argument("--seed", type=int, default=0)
    a = ap.parse_args()
    ps = ProofSettings(source=a.source, height_mm=a.height_mm, background=a.background,
                       views=a.views, resolution=a.resolution, spp=a.spp, max_cells=a.cells,
                       seed=a.seed, noise_floor=False)
    t0, c0 = time.perf_counter(), time.process_time()
    gen = compare_compensation(ps, iterations=a.iterations)
    last = ""
    try:
        while True:
            p = next(gen)
            if p.stage == "compensating" and p.message.startswith("iteration") \
                    and p.message != last:
                last = p.message
                print(f"  {p.message}", file=sys.stderr, flush=True)
    except StopIteration as stop:
        result = stop.value
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    load = open("/proc/loadavg").read().split()[:3]
    title = (f"{Path(a.source).name}, {a.height_mm:g} mm, {DEFAULT_PRINTER}, background "
             f"{a.background}; {a.views} views {a.resolution} px {a.spp} spp")
    sheet(result, title).save(a.out, optimize=True)
    rep = {k: result[k]["report"]["overall"] for k in ("open_loop", "compensated")}
    rep["gamut_floor"] = result["open_loop"]["report"]["gamut_floor"]
    rep["optimiser"] = {k: result["optimiser"][k] for k in ("figures", "seconds",
                                                            "training_views")}
    rep["views"] = {k: [{kk: v[kk] for kk in ("azimuth_deg", "elevation_deg", "mean_de2000",
                                              "mean_scielab_de2000", "coverage_error")}
                        for v in result[k]["report"]["views"]]
                    for k in ("open_loop", "compensated")}
    rep["wall_s"], rep["cpu_s"], rep["load"] = round(wall, 1), round(cpu, 1), load
    Path(a.out).with_suffix(".json").write_text(json.dumps(rep, indent=2, default=float) + "\n")
    o, c = rep["open_loop"], rep["compensated"]
    print(f"open loop dE2000 {o['mean_de2000']:.2f} p95 {o['p95_de2000']:.2f} S-CIELAB "
          f"{o['mean_scielab_de2000']:.2f} cov {o['coverage_error']:+.3f} | compensated "
          f"{c['mean_de2000']:.2f} p95 {c['p95_de2000']:.2f} S-CIELAB "
          f"{c['mean_scielab_de2000']:.2f} cov {c['coverage_error']:+.3f} | wall {wall:.0f} s,"
          f" CPU {cpu:.0f} s, load {' '.join(load)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
