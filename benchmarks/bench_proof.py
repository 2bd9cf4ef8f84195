"""Print proof speed and noise, and the error of the block-averaged medium.

Default: the demo volume at 40 mm (the default object proof), one 256 x 256 view at the default
spp and sampler: prints the seconds of each stage (labels, source render, print render per view
after Mitsuba's JIT warm-up) and the proof's noise floor: the print rendered as the proof does
(two halves of the samples at seeds s, s + 1, ``print_render.render_print_halves``), mean and
p95 per-pixel dE2000 and S-CIELAB dE2000 (at the proof's viewing distance) of the floor from
the halves (``compare.noise_floor_from_halves``), and the wall and CPU seconds (all threads,
Mitsuba's too) of the view's print; the warm-up (1 spp) and each row say how many Dr.Jit kernels
they compiled and the seconds of LLVM that took (the LLVM variant compiles a scene's kernels
once, kept in ``~/.drjit``; a row's seconds are the render's own when it compiled none).
``--variant llvm|scalar``: Mitsuba's ``llvm_ad_rgb`` or ``scalar_rgb`` (default: the proof's,
``proof.mitsuba_setup``); a process renders with one (Mitsuba's variant is process-wide), so
compare them in separate runs, interleaved. Targets: floor <= 0.5 mean S-CIELAB dE2000, <= 60 s per
view on CPU. ``--floor-check``: also the floor as defined until 2026-12 (two full renders at
other seeds, figures between them), beside it. ``--reference-spp N``: the view rendered at N
spp (two halves of N / 2, seeds 99 and 100); each row prints its figures against the source
(dE2000 and S-CIELAB overall, inside the source, in the block body; coverage error; the dE2000
mean less the render's noise, ``dE nc``, ``proof.compare.noise_corrected_de2000``) minus the
reference's: the bias of the proof's figures at its spp. ``--reference-file F.npz``: the
reference read from F when it is of the same print, view and spp, else rendered and saved
there. ``--bands 12,6``: fewer spectral bands (the bias then includes theirs).
``--spp 16,64 --thick-spp 0,48 --samplers independent,multijitter`` sweeps (the measurement
behind the defaults); ``--thick-spp``: more samples on the tiles where the print is optically
thick (``runner.THICK_T``);
``--faint-pass both``: the faint last pass at a quarter of the spp and at all of it;
``--bricks adaptive,16,32``: the medium cut by the cost model (``proof.bricks``, the proof's) or
into cubes of so many cells; ``--source FILE --height-mm H``: another source than the demo.

``--layouts rgb,mono``: the bands a Mitsuba pass carries (``print_render.pass_bands``): three
a pass (the proof's) or one band in all three channels (12 passes, no spectral MIS between
bands).

``--contract``: issue 49's target as whole processes in one run: ``dreamprint convert SOURCE
--height-mm H`` twice (the first may compile Numba's kernels; the second is the warm figure)
and ``dreamprint proof SOURCE --height-mm H`` at its defaults (``--proof-args "..."`` adds
options), each a fresh process; prints wall and CPU seconds (``getrusage`` of the children),
the proof's stages (``proof.json`` ``timings_s``), its noise floor and the ratio proof / warm
convert (target <= 6).

``--block-error``: a small job (demo, 3 mm) whose print is rendered from the full-resolution
labels (one cell per printer voxel) and from blocks of the default 40 mm job's size (4 x 11 x 22
voxels): prints dE2000 between the two print images (mean, 95th percentile over the object).

    python benchmarks/bench_proof.py [--height-mm 40] [--resolution 256] [--spp 16[,64]]
                                     [--thick-spp 0[,48]] [--samplers independent[,...]]
    python benchmarks/bench_proof.py --height-mm 20 --resolution 128 --spp 64 --floor-check \
        --reference-spp 1024 [--bands 12,6]
    python benchmarks/bench_proof.py --variant llvm|scalar   # llvm_ad_rgb or scalar_rgb
    python benchmarks/bench_proof.py --block-error
    python benchmarks/bench_proof.py --contract [--height-mm 40] [--proof-args "--spp 32"]
"""

from __future__ import annotations

import argparse
import os
import time

import numpy as np


def _medium(lab, block, layers_per_block):
    from dreamprint_gui.proof.medium import block_fractions

    return block_fractions(lab.layer, lab.shape_xyz, lab.voxel_mm, block, layers_per_block)


def _print_xyz(medium, bands, view, res, spp, seeds, sampler=None, rr_depth=None,
               thick_spp=0, faint=True, brick=None, halves=False, layout="rgb"):
    """The print of one view rendered at each of ``seeds``: (XYZ per seed, coverage, wall s,
    render info with ``cpu_s``), the thick tiles rendered ``thick_spp`` more. ``halves``: the
    proof's render instead (``render_print_halves`` at ``seeds[0]``): XYZ of (the mean, half a,
    half b)."""
    from dreamprint_gui.proof.medium import medium_coefficients
    from dreamprint_gui.proof.print_render import (
        DEFAULT_SAMPLER,
        pass_spp,
        render_print_halves,
        render_print_seeds,
        thick_tiles,
    )
    from dreamprint_gui.proof.runner import THICK_T, print_xyz
    from dreamprint_gui.proof.source_render import optical_depth

    st, al = medium_coefficients(medium.fractions, bands.K, bands.S)
    lo, hi = medium.box_mm
    T = optical_depth(st, lo, medium.cell_mm, view, res, sub=3)
    y_w = bands.xyz_weights[:, 1] / bands.xyz_weights[:, 1].sum()
    extra = [(0, r) for r in thick_tiles(T @ y_w, THICK_T)]
    import drjit as dr

    # Dr.Jit's kernel history (LLVM variant; empty with the scalar one): the LLVM compile of
    # kernels not found in its caches, apart from the render's own seconds
    dr.set_flag(dr.JitFlag.KernelHistory, True)
    dr.kernel_history()
    t0, c0 = time.perf_counter(), time.process_time()
    per_pass = (pass_spp(bands.xyz_weights, spp, layout=layout) if faint
                else spp)
    if halves:
        mean, (a, b), info = render_print_halves(
            st, al, lo, hi, [view], res, per_pass, seeds[0], sampler=sampler or DEFAULT_SAMPLER,
            extra=extra, extra_spp=thick_spp, brick=brick, rr_depth=rr_depth, layout=layout)
        imgs = [mean, a, b]
    else:
        imgs, info = render_print_seeds(st, al, lo, hi, [view], res, per_pass, tuple(seeds),
                                        sampler=sampler or DEFAULT_SAMPLER, rr_depth=rr_depth,
                                        extra=extra, extra_spp=thick_spp,
                                        brick=brick, layout=layout)
    t = time.perf_counter() - t0
    # CPU seconds of all this process's threads (Mitsuba's too): on a shared machine the wall
    # time says more about the other processes than about the render
    info["cpu_s"] = time.process_time() - c0
    hist = [h for h in dr.kernel_history() if h["type"] == dr.KernelType.JIT]
    fresh = [h for h in hist if not h.get("cache_hit")]
    info["compiled"] = len(fresh)
    info["compile_s"] = sum(h.get("backend_time", 0.0) for h in fresh) / 1e3
    dr.set_flag(dr.JitFlag.KernelHistory, False)
    return [print_xyz(bands, im[0], T, False) for im in imgs], 1.0 - T @ y_w, t, info


def _figures(src_xyz, src_alpha, prn_xyz, prn_alpha, obs, spd, halves=None) -> dict:
    """The proof's figures of one view against the source: overall, inside the source and in
    the block body (where the source is empty); with ``halves`` (the print's two halves, XYZ)
    the dE2000 mean less the render's noise too (``dE nc``, overall and inside the source)."""
    from dreamprint_gui.proof.compare import compare_view, inside_source, noise_corrected_figures

    f, de = compare_view(src_xyz, prn_xyz, src_alpha, prn_alpha, obs, spd)
    body = f["empty_source_fraction"]
    nc = {}
    if halves is not None:
        g = noise_corrected_figures(src_xyz, *halves, src_alpha, prn_alpha, obs, de=de)
        nc = {"dE nc": g["nc_mean_de2000"], "dE nc in": g["inside_source_nc_mean_de2000"]}
    return {**nc, "dE": f["mean_de2000"], "S": f["mean_scielab_de2000"],
            "dE in": inside_source(f, "mean_de2000") or 0.0,
            "S in": inside_source(f, "mean_scielab_de2000") or 0.0,
            "dE body": f["empty_source_de2000"] / body if body > 0 else 0.0,
            "S body": f["empty_source_scielab_de2000"] / body if body > 0 else 0.0,
            "coverage": f["coverage_error"]}


def speed(args) -> None:
    from dreamprint_gui.proof.cameras import orbit_views
    from dreamprint_gui.proof.compare import noise_floor, noise_floor_from_halves
    from dreamprint_gui.proof.medium import block_for_cell
    from dreamprint_gui.proof.methods import method_labels
    from dreamprint_gui.proof.mitsuba_setup import load_mitsuba
    from dreamprint_gui.proof.print_render import DEFAULT_SAMPLER
    from dreamprint_gui.proof.runner import (
        DEFAULT_SPP,
        DEFAULT_THICK_SPP,
        THICK_T,
        ProofSettings,
    )
    from dreamprint_gui.proof.scielab import samples_per_degree
    from dreamprint_gui.proof.source_render import render_source, sample_source
    from dreamprint_gui.proof.spectral import spectral_bands

    _, _, note = load_mitsuba(args.variant)
    import drjit as dr

    # both variants render on Dr.Jit's thread pool (nanothread): the scalar one a path per
    # thread, the LLVM one a wavefront per thread; CPU s / wall s of a row says how busy it is
    print(f"{note}; Dr.Jit thread pool {dr.thread_count()} threads")
    spps = [int(x) for x in (args.spp or str(DEFAULT_SPP)).split(",")]
    samplers = (args.samplers or DEFAULT_SAMPLER).split(",")
    rrs = [None] if args.rr_depths is None else [int(x) for x in args.rr_depths.split(",")]
    thicks = [int(x) for x in (args.thick_spp or str(DEFAULT_THICK_SPP)).split(",")]
    faints = [False, True] if args.faint_pass == "both" else [args.faint_pass == "quarter"]
    bricks = [None if x == "adaptive" else int(x)
              for x in (args.bricks or "adaptive").split(",")]
    bands_n = [int(x) for x in (args.bands or "12").split(",")]
    layouts = (args.layouts or "rgb").split(",")
    s = ProofSettings(source=args.source, height_mm=args.height_mm, resolution=args.resolution)
    print(f"{args.source} at {args.height_mm} mm, {args.resolution} x {args.resolution}, "
          f"spp {spps}, samplers {samplers}, {os.cpu_count()} cores, load average "
          f"{os.getloadavg()[0]:.1f} (shared machine)")
    t0 = time.perf_counter()
    lab = method_labels(s)
    t1 = time.perf_counter()
    size = tuple(n * v for n, v in zip(lab.shape_xyz, lab.voxel_mm, strict=True))
    block = block_for_cell(lab.voxel_mm, size, s.max_cells)
    med = _medium(lab, block, s.layers_per_block)
    t2 = time.perf_counter()
    print(f"prepare (tables, kernels)     {t1 - t0:7.1f} s")
    print(f"labels -> block fractions     {t2 - t1:7.1f} s  ({med.layers_read} layers, "
          f"cells {med.cells_xyz}, block {med.block_xyz} voxels)")
    bands = spectral_bands(lab.profile, s.bands)
    view = orbit_views(med.print_size_mm, 1)[0]
    t3 = time.perf_counter()
    field = sample_source(lab.source, lab.grid, med.block_xyz, lab.density_scale, med.cells_xyz,
                          med.box_mm[0])
    src_rgb, src_alpha = render_source(field, view, args.resolution)
    src_xyz = src_rgb @ np.linalg.inv(bands.observer.xyz_to_linear_srgb).T
    print(f"source render (per view)      {time.perf_counter() - t3:7.1f} s")
    spd = samples_per_degree(2 * view.half_mm / args.resolution, s.viewing_distance_mm)
    print(f"S-CIELAB at {s.viewing_distance_mm:.0f} mm: {spd:.1f} pixels per degree")
    ref = None
    if args.reference_spp:
        # what the reference is of: a saved one serves only the same print, view and render
        # rendered as two halves (seeds 99, 100), as the proof is: its own noise's share of
        # the dE2000 mean can then be taken out too (dE nc)
        key = repr((args.source, args.height_mm, args.resolution, args.reference_spp, bands.n,
                    med.cells_xyz, tuple(np.round(med.box_mm[0], 4)), view,
                    float(med.fractions.sum()), "halves"))
        saved = args.reference_file and os.path.exists(args.reference_file)
        if saved:
            z = np.load(args.reference_file)
            if str(z["key"]) != key:
                raise SystemExit(f"{args.reference_file}: a reference of another print or "
                                 f"render ({z['key']}), not of {key}")
            ref, alpha, t, cpu = z["xyz"], z["alpha"], float(z["wall_s"]), float(z["cpu_s"])
            ref_halves = (z["half_a"], z["half_b"])
        else:
            (ref, *ref_halves), alpha, t, info = _print_xyz(
                med, bands, view, args.resolution, args.reference_spp, (99,), faint=False,
                halves=True)
            cpu = info["cpu_s"]
            if args.reference_file:
                np.savez_compressed(args.reference_file, xyz=ref, alpha=alpha, key=key,
                                    half_a=ref_halves[0], half_b=ref_halves[1],
                                    wall_s=t, cpu_s=cpu)
        ref_fig = _figures(src_xyz, src_alpha, ref, alpha, bands.observer, spd, ref_halves)
        print(f"reference: {args.reference_spp} spp in every pass (two halves), seeds 99, 100"
              f"{' (read from ' + args.reference_file + ')' if saved else ''}: {t:.1f} s, "
              f"{cpu:.1f} CPU s; figures "
              + ", ".join(f"{k} {v:.3f}" for k, v in ref_fig.items()), flush=True)
    print("s/view, CPU s: one proof's print of the view (both halves); floor: from the halves "
          "(proof.json's); old floor: two full renders at seeds 5, 6 (--floor-check), "
          "s/render one of them; bias: the proof's figures minus the reference's")
    print(f"{'sampler':12s} {'layout':>6s} {'bricks':>8s} {'bands':>5s} {'spp':>5s} "
          f"{'thick':>5s} "
          f"{'s/view':>7s} {'CPU s':>6s} "
          f"{'floor dE00 mean':>16s} {'p95':>6s} {'S-CIELAB mean':>14s} {'p95':>6s}  spp per pass")
    for sampler, rr, brick, layout in [(a, b, c, d) for a in samplers for b in rrs
                                       for c in bricks for d in layouts]:
        # JIT warm-up (the LLVM variant traces and compiles, or finds in ~/.drjit, the
        # passes' kernels here; the rows below run them)
        _, _, t_w, info_w = _print_xyz(med, bands, view, args.resolution, 1, (0,), sampler, rr,
                                       brick=brick, layout=layout)
        print(f"warm-up (1 spp): {t_w:.1f} s, {info_w['cpu_s']:.1f} CPU s, "
              f"{info_w['compiled']} kernels compiled ({info_w['compile_s']:.1f} s of LLVM)",
              flush=True)
        for spp, thick, faint, nb in [(a, b, c, d) for a in spps for b in thicks for c in faints
                                      for d in bands_n]:
            bnd = bands if nb == bands.n else spectral_bands(lab.profile, nb)
            (m, a, b), alpha, t, info = _print_xyz(med, bnd, view, args.resolution, spp, (1,),
                                                   sampler, rr, thick, faint, brick, halves=True,
                                                   layout=layout)
            f = noise_floor_from_halves(a, b, alpha, bnd.observer, spd)
            print(f"{sampler:12s} {layout:>6s} {str(info['bricks']):>8s} {nb:5d} {spp:5d} "
                  f"{thick:5d} {t:7.1f} "
                  f"{info['cpu_s']:6.1f} {f['mean_de2000']:16.2f} "
                  f"{f['p95_de2000']:6.2f} {f['mean_scielab_de2000']:14.2f} "
                  f"{f['p95_scielab_de2000']:6.2f}  {info['pass_spp']}"
                  f"  ({info['compiled']} kernels compiled, {info['compile_s']:.1f} s)",
                  flush=True)
            if args.floor_check:
                (x, y), _, t_old, info_old = _print_xyz(med, bnd, view, args.resolution, spp,
                                                        (5, 6), sampler, rr, thick, faint,
                                                        brick, layout=layout)
                g = noise_floor(x, y, alpha, bnd.observer, spd)
                print(f"{'':12s} old floor (two full renders): dE00 mean {g['mean_de2000']:.2f}"
                      f" p95 {g['p95_de2000']:.2f}, S-CIELAB mean "
                      f"{g['mean_scielab_de2000']:.2f} p95 {g['p95_scielab_de2000']:.2f}; "
                      f"{t_old / 2:.1f} s/render, {info_old['cpu_s'] / 2:.1f} CPU s/render",
                      flush=True)
            if ref is not None:
                fig = _figures(src_xyz, src_alpha, m, alpha, bnd.observer, spd, (a, b))
                print(f"{'':12s} bias against {args.reference_spp} spp: "
                      + ", ".join(f"{k} {fig[k] - ref_fig[k]:+.3f}" for k in fig)
                      + f"; dE nc in against the reference's raw dE in "
                        f"{fig['dE nc in'] - ref_fig['dE in']:+.3f}", flush=True)
    share = info["extra_pixels"] / args.resolution ** 2
    print(f"({info['variant']}, {info['passes']} Mitsuba passes per half; thick tiles "
          f"(direct transmittance < {THICK_T}) {share:.0%} of the frame; "
          f"load average now {os.getloadavg()[0]:.1f})")


def _process(argv: list[str]) -> tuple[float, float, int]:
    """Run ``python -m dreamprint_gui.cli ARGV`` as a fresh process: (wall s, CPU s of the
    process and its threads and children, exit status)."""
    import resource
    import subprocess
    import sys

    r0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    done = subprocess.run([sys.executable, "-m", "dreamprint_gui.cli", *argv],
                          stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    wall = time.perf_counter() - t0
    r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (r1.ru_utime - r0.ru_utime) + (r1.ru_stime - r0.ru_stime)
    if done.returncode:
        print(f"  dreamprint {' '.join(argv)}: exit {done.returncode}: "
              f"{done.stderr.strip()[-400:]}")
    return wall, cpu, done.returncode


def contract(args) -> None:
    """Issue 49's target as whole processes: ``dreamprint convert SOURCE --height-mm H`` (twice:
    the first may compile Numba's kernels, the second is the warm figure) and ``dreamprint
    proof SOURCE --height-mm H`` at its defaults (plus ``--proof-args``), each a fresh process
    in this run; the proof's wall and CPU seconds over the warm convert's (target <= 6), its
    noise floor (target <= 0.5 mean S-CIELAB) and its stages (``proof.json`` ``timings_s``)."""
    import json
    import shlex
    import tempfile
    from pathlib import Path

    h = f"{args.height_mm:g}"
    extra = shlex.split(args.proof_args or "")
    print(f"{args.source} at {h} mm; load average {os.getloadavg()} at the start; "
          f"{os.cpu_count()} cores (shared machine: CPU s say more than wall s)", flush=True)
    with tempfile.TemporaryDirectory(prefix="dp-contract-") as tmp:
        conv = []
        for k in range(2):
            w, c, rc = _process(["convert", args.source, "--height-mm", h, "-o",
                                 str(Path(tmp) / f"job{k}"), "--json"])
            conv.append((w, c))
            print(f"convert run {k + 1}: {w:.1f} s wall, {c:.1f} CPU s "
                  f"(load {os.getloadavg()[0]:.1f})", flush=True)
        out = Path(tmp) / "proof"
        w, c, rc = _process(["proof", args.source, "--height-mm", h, "-o", str(out), "--json",
                             *extra])
        print(f"proof {' '.join(extra) or '(defaults)'}: {w:.1f} s wall, {c:.1f} CPU s "
              f"(load {os.getloadavg()[0]:.1f})", flush=True)
        if rc:
            return
        rep = json.loads((out / "proof.json").read_text())
    cw, cc = conv[-1]
    t = rep["timings_s"]
    nf = rep.get("noise_floor") or {}
    ren = rep["renderer"]
    print("proof stages (s wall): " + ", ".join(f"{k} {v:.1f}" for k, v in t.items())
          + f"; process start and writing {w - t['total']:.1f}")
    print(f"renderer: {ren.get('variant')}, spp per pass {ren.get('pass_spp')}, "
          f"layout {ren.get('layout', 'rgb')}, {rep['settings']['views']} views at "
          f"{rep['settings']['resolution']} px")
    print(f"RATIO proof / warm convert: {w / cw:.1f} x wall, {c / cc:.1f} x CPU s (target <= 6); "
          f"noise floor {nf.get('mean_scielab_de2000', float('nan')):.2f} mean S-CIELAB "
          f"(target <= 0.5), inside the source "
          f"{nf.get('inside_source_mean_scielab_de2000', float('nan')):.2f}; "
          f"load average now {os.getloadavg()}")


def block_error(args) -> None:
    from dreamprint_gui.physics.colorimetry import delta_E2000
    from dreamprint_gui.proof.cameras import orbit_views
    from dreamprint_gui.proof.methods import method_labels
    from dreamprint_gui.proof.runner import ProofSettings
    from dreamprint_gui.proof.spectral import spectral_bands

    s = ProofSettings(source="demo", height_mm=3.0)
    lab = method_labels(s)
    bands = spectral_bands(lab.profile, s.bands)
    full = _medium(lab, (1, 1, 1), 0)
    view = orbit_views(full.print_size_mm, 1)[0]
    res = 96
    spp = int(args.spp or 16) * 4
    (a,), alpha, _, _ = _print_xyz(full, bands, view, res, spp, (1,))
    obs = bands.observer
    obj = alpha > 0.05

    def de_to(xyz):
        de = delta_E2000(obs.XYZ_to_Lab(np.maximum(a, 0)), obs.XYZ_to_Lab(np.maximum(xyz, 0)))
        return f"mean {de[obj].mean():.2f}, p95 {np.percentile(de[obj], 95):.2f}"

    print(f"demo 3 mm, full resolution {full.cells_xyz} cells (one per printer voxel), {res} px, "
          f"spp {spp}; dE2000 over the object against the full-resolution render:")
    (b,), *_ = _print_xyz(full, bands, view, res, spp, (2,))
    print(f"  full resolution, another seed (noise floor): {de_to(b)}")
    for block in ((2, 6, 11), (4, 11, 22)):
        med = _medium(lab, block, 0)
        (b,), *_ = _print_xyz(med, bands, view, res, spp, (1,))
        cell = ", ".join(f"{c:.3f}" for c in med.cell_mm)
        print(f"  blocks of {block} voxels ({cell} mm, {med.cells_xyz} cells): {de_to(b)}")
    med = _medium(lab, (4, 11, 22), 2)
    (b,), *_ = _print_xyz(med, bands, view, res, spp, (1,))
    print(f"  blocks of (4, 11, 22), 2 layers read per block (the default): {de_to(b)}")


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--source", default="demo", help="a volume file (default: the demo)")
    ap.add_argument("--height-mm", type=float, default=40.0)
    ap.add_argument("--bricks", default=None, help="'adaptive' (the proof's, proof.bricks) or "
                    "cells per brick edge (cubes, one Mitsuba medium each), comma-separated")
    ap.add_argument("--resolution", type=int, default=256)
    ap.add_argument("--spp", default=None, help="spp, or a comma-separated list (default: "
                    "the proof's default)")
    ap.add_argument("--thick-spp", default=None, help="extra spp on the optically thick tiles, "
                    "or a comma-separated list (default: the proof's)")
    ap.add_argument("--rr-depths", default=None, help="Mitsuba's rr_depth (Russian roulette "
                    "from this bounce on), comma-separated (default: the proof's)")
    ap.add_argument("--faint-pass", choices=("quarter", "full", "both"), default="quarter",
                    help="the faint 650-730 nm pass at a quarter of the spp (the proof's, "
                    "print_render.pass_spp), at the full spp, or both rows")
    ap.add_argument("--samplers", default=None, help="Mitsuba samplers, comma-separated "
                    "(default: the proof's)")
    ap.add_argument("--bands", default=None, help="spectral bands, comma-separated (default "
                    "12, the proof's)")
    ap.add_argument("--layouts", default=None, help="bands per Mitsuba pass: 'rgb' (three "
                    "bands a pass) or 'mono' (one band a pass in all three channels), "
                    "comma-separated (print_render.pass_bands; default: the proof's)")
    ap.add_argument("--floor-check", action="store_true", help="also the floor as it was "
                    "defined until 2026-12: two full renders at seeds 5, 6, figures between them")
    ap.add_argument("--reference-spp", type=int, default=0, help="render the view once at "
                    "this spp (every pass) and print each row's figures minus its (bias)")
    ap.add_argument("--reference-file", default=None, help="with --reference-spp: read the "
                    "reference render from this .npz when it holds the same print, view and "
                    "spp, else render it and save it there (a 1024-spp reference at 128 px "
                    "costs 230-550 CPU s)")
    ap.add_argument("--block-error", action="store_true")
    ap.add_argument("--variant", choices=("llvm", "scalar"), default=None,
                    help="Mitsuba's variant: scalar_rgb or llvm_ad_rgb (default: the proof's, "
                         "proof.mitsuba_setup)")
    ap.add_argument("--contract", action="store_true", help="issue 49's target: convert "
                    "and proof of --source at --height-mm as fresh processes, the ratio")
    ap.add_argument("--proof-args", default=None, help="with --contract: more options for "
                    "the proof (one string)")
    args = ap.parse_args()
    if args.contract:
        contract(args)
    elif args.block_error:
        block_error(args)
    else:
        speed(args)


if __name__ == "__main__":
    main()
