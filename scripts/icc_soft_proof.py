"""The README's ICC soft-proof figure: the demo's colours proofed outside DreamPrint (issue 48).

Writes the ICC profile of the default ink profile's print (``dreamprint icc``'s code,
:func:`dreamprint_gui.gamut.icc.build_icc`, the colorimetric 100^3 table), then one PNG of four
panels of the demo seen from the front (its colours composited over white):

1. the source's sRGB colours;
2. DreamPrint's own prediction of their print (table lookup, eq. 7 colour, as the preview and
   ``dreamprint lookup``), shown as sRGB;
3. the soft proof made outside DreamPrint: Pillow's ImageCms (Little CMS) transforming the
   image's RGB numbers, unchanged, from the ICC profile to sRGB, ICC-absolute colorimetric
   ("simulate paper colour" in Photoshop's proof setup);
4. the same, media-relative colorimetric (the printable white shown as the display's white).

It prints the CIEDE2000 between panels 2 and 3 over the cloud's pixels (8-bit sRGB both), and
the same for Little CMS without its precalculated 8-bit transform (``NOOPTIMIZE``): for 8-bit
RGB to RGB, Little CMS resamples the whole transform after "prelinearisation" curves taken from
its grey axis, which the print's flat top (RGB above about 0.75 all prints near the printable
white) makes coarse there.

    PYTHONPATH=. python scripts/icc_soft_proof.py OUT.png [--icc PROFILE.icc]
"""

from __future__ import annotations

import argparse
import io
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))


def demo_image(n: int = 128):
    """(n, n, 3) sRGB of the demo seen from the front (composited along y over white, z up),
    and the mask of the pixels it covers."""
    import numpy as np

    from dreamprint_gui.io.volumes.grids.demo import DemoCloud

    grid = np.asarray(DemoCloud(seed=7, resolution=n).volume.data, dtype=np.float64)
    dens = grid[..., 0]
    col = np.where(dens[..., None] > 1e-9, grid[..., 1:] / np.maximum(dens, 1e-9)[..., None], 0)
    alpha = 1.0 - np.exp(-dens / n)  # the optical depth of a cell at the design height
    out = np.zeros((n, n, 3))
    trans = np.ones((n, n))
    for z in range(n):
        a = alpha[::-1, z, :]
        out += (trans * a)[..., None] * col[::-1, z, :]
        trans *= 1.0 - a
    out += trans[..., None] * 1.0
    return np.clip(out, 0.0, 1.0), trans < 0.9


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("out")
    ap.add_argument("--icc", help="also keep the profile here")
    args = ap.parse_args()
    import numpy as np
    from PIL import Image, ImageCms, ImageDraw

    from dreamprint_gui.core.profile import default_profile
    from dreamprint_gui.gamut import get_tables
    from dreamprint_gui.gamut.forward import forward_model
    from dreamprint_gui.gamut.icc import build_icc, write_atomically
    from dreamprint_gui.gamut.tables import printed_xyz
    from dreamprint_gui.physics.colorimetry import delta_E2000, observer_for

    profile = default_profile()
    tables = get_tables(profile)
    data = build_icc(profile, tables, printer="Stratasys J850")
    if args.icc:
        write_atomically(args.icc, data)
    src, mask = demo_image()
    n = src.shape[0]
    obs = observer_for(profile.wavelengths_nm)
    own = np.clip(obs.XYZ_to_sRGB(printed_xyz(tables, forward_model(profile),
                                              src.reshape(-1, 3))), 0, 1).reshape(src.shape)
    src8 = Image.fromarray((src * 255).round().astype(np.uint8), "RGB")
    icc = ImageCms.ImageCmsProfile(io.BytesIO(data))
    srgb = ImageCms.createProfile("sRGB")
    proofs = []
    for intent in (ImageCms.Intent.ABSOLUTE_COLORIMETRIC, ImageCms.Intent.RELATIVE_COLORIMETRIC):
        xf = ImageCms.buildTransform(icc, srgb, "RGB", "RGB", renderingIntent=intent)
        proofs.append(ImageCms.applyTransform(src8, xf))
    own8 = (own * 255).round().astype(np.uint8)
    lab_own = obs.XYZ_to_Lab(obs.sRGB_to_XYZ(own8[mask] / 255.0))
    exact = ImageCms.applyTransform(src8, ImageCms.buildTransform(
        icc, srgb, "RGB", "RGB", renderingIntent=ImageCms.Intent.ABSOLUTE_COLORIMETRIC,
        flags=ImageCms.Flags.NOOPTIMIZE))
    for what, im in (("default 8-bit transform (precalculated with gray-axis "
                      "prelinearisation)", proofs[0]), ("NOOPTIMIZE", exact)):
        lab_lcms = obs.XYZ_to_Lab(obs.sRGB_to_XYZ(np.asarray(im)[mask] / 255.0))
        de = delta_E2000(lab_own, lab_lcms)
        print(f"{mask.sum()} pixels of the demo, Little CMS soft proof (absolute, "
              f"{what}) vs DreamPrint's own prediction: dE2000 mean {de.mean():.3f}, p95 "
              f"{np.percentile(de, 95):.3f}, max {de.max():.3f} (8-bit sRGB both)")
    scale, pad, head = 2, 12, 40
    panels = [src8, Image.fromarray(own8, "RGB"), *proofs]
    titles = ["source (sRGB)", "DreamPrint's prediction", "Little CMS soft proof,",
              "Little CMS soft proof,"]
    subtitles = ["", "of the print", "ICC-absolute colorimetric", "relative colorimetric"]
    w = n * scale
    sheet = Image.new("RGB", (4 * w + 5 * pad, w + head + pad), "white")
    draw = ImageDraw.Draw(sheet)
    for i, (im, t, s) in enumerate(zip(panels, titles, subtitles, strict=True)):
        x = pad + i * (w + pad)
        sheet.paste(im.resize((w, w), Image.Resampling.NEAREST), (x, head))
        draw.text((x, 6), t, fill="black")
        draw.text((x, 20), s, fill="black")
    sheet.save(args.out)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
