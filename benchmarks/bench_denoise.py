"""A denoiser on the proof's print, judged against a 1024-spp reference (issue 49, lever d).

Not the product: Intel Open Image Denoise through ``pyoidn`` (PyPI, an 88 MB wheel with the
library inside), which the product does not depend on; give its install folder with
``--oidn-path`` (``pip install --target DIR pyoidn``) or install it.

The print of one view (``bench_proof``'s: the demo or ``--source`` at ``--height-mm``, 128 px,
two halves, the faint pass at a quarter) rendered at each ``--spp``, then per Mitsuba pass
(three bands as one HDR image, the direct transmittance added after, as the proof does):

- ``raw``: the proof's print as it is;
- ``oidn``: denoised without a guide;
- ``oidn+albedo``: denoised with a noise-free albedo guide (``clean_aux``): per pixel and band
  the expected single-scattering albedo at the camera ray's first collision, ray-marched
  through the cells (midpoint steps of a quarter cell, ``T_k`` the transmittance before step
  ``k``, ``p_k = 1 - exp(-sigma_t h)``)::

      a = sum_k T_k p_k albedo_k / (1 - T_end)      (0 where 1 - T_end < 1e-3)

Each row prints the bias of the proof's figures (``bench_proof._figures``: dE2000 and
S-CIELAB overall, inside the source, in the block body; coverage) against the reference read
from ``--reference-file`` (``bench_proof.py --reference-spp 1024 --reference-file F`` renders
and saves it), the print's CPU seconds and the floor from the halves (undenoised: the floor of
a denoised proof is not defined by its halves). Issue 49's targets: |bias| <= 0.3 S-CIELAB and
0.5 dE2000; the halftone at the pixel's scale kept (``tests/proof/test_print_render.py``).

    python benchmarks/bench_denoise.py --reference-file REF.npz [--source FILE] \\
        [--height-mm 40] [--spp 16,32] [--oidn-path DIR]
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import time

import numba as nb
import numpy as np

from dreamprint_gui.proof.source_render import ray_box


@nb.njit(cache=True)
def _first_collision_albedo(origins, d, lo, cell, st, al, h, out):
    """Per ray and band: the expected albedo at the first collision (module docstring)."""
    nz, ny, nx, nc = st.shape
    hi = np.empty(3)
    shape = (nx, ny, nz)
    for a in range(3):
        hi[a] = lo[a] + shape[a] * cell[a]
    for r in range(origins.shape[0]):
        o = origins[r]
        t0, t1 = ray_box(o, d, lo, hi)
        for c in range(nc):
            out[r, c] = 0.0
        if t1 <= t0:
            continue
        n = int(math.ceil((t1 - t0) / h))
        hh = (t1 - t0) / n
        for c in range(nc):
            T = 1.0
            acc = 0.0
            for k in range(n):
                t = t0 + (k + 0.5) * hh
                x = int(math.floor((o[0] + t * d[0] - lo[0]) / cell[0]))
                y = int(math.floor((o[1] + t * d[1] - lo[1]) / cell[1]))
                z = int(math.floor((o[2] + t * d[2] - lo[2]) / cell[2]))
                if 0 <= x < nx and 0 <= y < ny and 0 <= z < nz:
                    p = 1.0 - math.exp(-hh * st[z, y, x, c])
                    acc += T * p * al[z, y, x, c]
                    T *= 1.0 - p
                if T < 1e-4:
                    break
            out[r, c] = acc / (1.0 - T) if 1.0 - T > 1e-3 else 0.0


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--source", default="demo")
    ap.add_argument("--height-mm", type=float, default=40.0)
    ap.add_argument("--resolution", type=int, default=128)
    ap.add_argument("--spp", default="16,32")
    ap.add_argument("--reference-file", required=True)
    ap.add_argument("--oidn-path", default=None, help="a folder holding pyoidn (pip --target)")
    args = ap.parse_args()
    if args.oidn_path:
        sys.path.append(args.oidn_path)
    try:
        import pyoidn
    except ImportError:
        raise SystemExit("bench_denoise needs pyoidn (pip install pyoidn, or --oidn-path)"
                         ) from None
    sys.path.insert(0, os.path.dirname(__file__))
    import bench_proof as bp

    from dreamprint_gui.proof.cameras import orbit_views
    from dreamprint_gui.proof.compare import noise_floor_from_halves
    from dreamprint_gui.proof.medium import block_for_cell, medium_coefficients
    from dreamprint_gui.proof.methods import method_labels
    from dreamprint_gui.proof.print_render import pass_bands, pass_spp, render_print_halves
    from dreamprint_gui.proof.runner import ProofSettings, print_xyz
    from dreamprint_gui.proof.scielab import samples_per_degree
    from dreamprint_gui.proof.source_render import optical_depth, render_source, sample_source
    from dreamprint_gui.proof.spectral import spectral_bands

    res = args.resolution
    s = ProofSettings(source=args.source, height_mm=args.height_mm, resolution=res)
    lab = method_labels(s)
    size = tuple(n * v for n, v in zip(lab.shape_xyz, lab.voxel_mm, strict=True))
    med = bp._medium(lab, block_for_cell(lab.voxel_mm, size, s.max_cells), s.layers_per_block)
    bands = spectral_bands(lab.profile, s.bands)
    obs = bands.observer
    view = orbit_views(med.print_size_mm, 1)[0]
    spd = samples_per_degree(2 * view.half_mm / res, s.viewing_distance_mm)
    field = sample_source(lab.source, lab.grid, med.block_xyz, lab.density_scale,
                          med.cells_xyz, med.box_mm[0])
    src_rgb, src_alpha = render_source(field, view, res)
    src_xyz = src_rgb @ np.linalg.inv(obs.xyz_to_linear_srgb).T
    z = np.load(args.reference_file)
    ref, alpha = z["xyz"], z["alpha"]
    if ref.shape[:2] != (res, res):
        raise SystemExit(f"{args.reference_file}: a {ref.shape[0]} px reference, not {res} px")
    ref_fig = bp._figures(src_xyz, src_alpha, ref, alpha, obs, spd)
    st, al = medium_coefficients(med.fractions, bands.K, bands.S)
    lo, hi = med.box_mm
    T = optical_depth(st, lo, med.cell_mm, view, res, sub=3)
    o, d = view.rays(res, 3)
    flat = np.ascontiguousarray(o.reshape(-1, 3))
    g = np.empty((flat.shape[0], st.shape[-1]))
    c0 = time.process_time()
    _first_collision_albedo(flat, np.ascontiguousarray(d), np.asarray(lo, np.float64),
                            np.asarray(med.cell_mm, np.float64),
                            np.ascontiguousarray(st, np.float32),
                            np.ascontiguousarray(al, np.float32),
                            0.25 * float(np.min(med.cell_mm)), g)
    guide = g.reshape(res, 3, res, 3, -1).mean(axis=(1, 3)).astype(np.float32)
    print(f"{args.source} at {args.height_mm:g} mm, {res} px, one view; the guide "
          f"{time.process_time() - c0:.1f} CPU s; load {os.getloadavg()[0]:.1f}; reference "
          + ", ".join(f"{k} {v:.3f}" for k, v in ref_fig.items()), flush=True)
    render_print_halves(st, al, lo, hi, [view], res, 1, 0)      # Dr.Jit's warm-up
    for spp in (int(x) for x in args.spp.split(",")):
        c0 = time.process_time()
        mean, (a, b), _ = render_print_halves(st, al, lo, hi, [view], res,
                                              pass_spp(bands.xyz_weights, spp), 1)
        cpu = time.process_time() - c0
        f = noise_floor_from_halves(print_xyz(bands, a[0], T, False),
                                    print_xyz(bands, b[0], T, False), alpha, obs, spd)
        for name in ("raw", "oidn", "oidn+albedo"):
            img = mean[0].astype(np.float32)
            if name != "raw":
                out = np.empty_like(img)
                for grp in pass_bands(img.shape[-1]):
                    ch = list(grp)
                    aux = ({"albedo": np.ascontiguousarray(guide[..., ch]), "clean_aux": True}
                           if name == "oidn+albedo" else {})
                    out[..., ch] = pyoidn.denoise(np.ascontiguousarray(img[..., ch]), hdr=True,
                                                  **aux)
                img = out
            fig = bp._figures(src_xyz, src_alpha, print_xyz(bands, img, T, False), alpha, obs,
                              spd)
            print(f"spp {spp:4d} ({cpu:5.1f} CPU s, floor {f['mean_scielab_de2000']:.2f}) "
                  f"{name:12s} bias: "
                  + ", ".join(f"{k} {fig[k] - ref_fig[k]:+.3f}" for k in fig), flush=True)
    print(f"load average now {os.getloadavg()[0]:.1f}")


if __name__ == "__main__":
    main()
