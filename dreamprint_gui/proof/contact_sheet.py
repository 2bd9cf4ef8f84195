"""The proof's contact sheet: per view, source | print | dE2000 map, with the figures."""

from __future__ import annotations

import numpy as np
from PIL import Image, ImageDraw

from dreamprint_gui.proof.compare import DE_MAP_MAX, headline, noise_corrected_text

__all__ = ["contact_sheet"]


def contact_sheet(rows: list[tuple[np.ndarray, np.ndarray, np.ndarray]], report: dict
                  ) -> Image.Image:
    """One image: a header (the job, the headline figures with the dE2000 mean less the
    render's noise, all object pixels' figures, the columns), then a row per view (three
    images and its figures)."""
    res = rows[0][0].shape[0]
    pad = 6
    head = 58
    text_w = 230
    w = 3 * res + 4 * pad + text_w
    h = head + len(rows) * (res + pad) + pad
    sheet = Image.new("RGB", (w, h), (255, 255, 255))
    draw = ImageDraw.Draw(sheet)
    o = report["overall"]
    draw.text((pad, 4), f"{report['source']}  method {report['method']}  "
              f"{' x '.join(f'{x:.1f}' for x in report['print_size_mm'])} mm  "
              f"spp {report['renderer']['spp']}", fill=(0, 0, 0))
    h = headline(o)
    draw.text((pad, 18), f"{h['where']}: dE2000 mean {h['mean_de2000']:.2f}"
              f"{noise_corrected_text(h)}  p95 "
              f"{h['p95_de2000']:.2f}  S-CIELAB {h['mean_scielab_de2000']:.2f}  coverage "
              f"{h['coverage_error']:+.3f}", fill=(0, 0, 0))
    draw.text((pad, 30), f"all object pixels: dE2000 mean {o['mean_de2000']:.2f}  PSNR "
              f"{o['psnr_db']:.1f} dB  SSIM {o['ssim']:.3f}", fill=(0, 0, 0))
    draw.text((pad, 44), f"columns: source (emission-absorption) | print (Mitsuba volpath) | "
              f"dE2000 0..{DE_MAP_MAX:g}", fill=(90, 90, 90))
    for r, (src, prn, de) in enumerate(rows):
        y = head + r * (res + pad)
        for c, img in enumerate((src, prn, de)):
            sheet.paste(Image.fromarray(img), (pad + c * (res + pad), y))
        v = report["views"][r]
        x = 3 * (res + pad) + pad
        lines = [f"view {r}  az {v['azimuth_deg']:.0f}  el {v['elevation_deg']:.0f}",
                 f"{headline(v)['where']}: dE2000 {headline(v)['mean_de2000']:.2f}",
                 f"all: dE2000 mean {v['mean_de2000']:.2f}", f"dE2000 p95 {v['p95_de2000']:.2f}",
                 f"PSNR {v['psnr_db']:.1f} dB", f"SSIM {v['ssim']:.3f}",
                 f"coverage {v['source_coverage']:.2f} -> {v['print_coverage']:.2f}"]
        for k, line in enumerate(lines):
            draw.text((x, y + 4 + 14 * k), line, fill=(0, 0, 0))
    return sheet
