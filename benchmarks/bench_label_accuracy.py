"""Accuracy guards of labelling (issue 25): what a faster lookup, alignment or halftone may not
change, measured.

1. ``lookup``: dE2000 between the colour of the print job's table lookup (the compiled
   kernel's own table and arithmetic: :func:`dreamprint_gui.gamut.lookup_and_align_into` at a
   solid target, which returns the node mixture undiluted) and the optimiser's direct solve of
   the same colour (the table's objective and intent, :func:`.gamut.evaluation.lut_vs_direct`'s
   rule), at in-gamut colours: ``--samples`` random colours of the sRGB cube and
   ``--per-kind`` foreground colours of each source kind. Guard: p95 <= 0.05. Printed beside
   it: the same for the float64 tetrahedral lookup of the float32 100^3 table (``gamut.lookup``,
   today's table as stored) and the dE2000 between the two lookups. Then the kernel's sigma
   error against the exact alignment (:func:`.gamut.align_density`) at random colours and
   targets (relative; median, p95, max over unclamped voxels).
2. ``halftone``: per kind, a job of ``--voxels`` voxels labelled layer by layer by the job's
   kernel; per region of ``--region`` voxels (z, y, x) and ink, the label count against the
   sum of the voxels' intended concentrations (the kernel's, through the same lookup and
   alignment): z = (|count - sum c| - 1)^+ / sqrt(sum c (1 - c)), the deviation beyond one
   voxel in binomial standard errors. Guard: every z < 5, ``tests/jobs/test_halftone.py``'s
   tolerance for varying concentrations (|count - sum c| < 5 sqrt(var) + 1; the one voxel
   spares the rare inks, whose expected count in a region is a fraction of a voxel).
3. ``determinism``: per kind, the job's slice and manifest hashes (``job_hashes.job_hash``) with
   1 and with 2 workers, and a second run with 2: identical.
4. ``--old CHECKOUT``: the accuracy statement for a new ``job_hashes.py`` BASELINE. The same
   jobs (``job_hashes``' BASELINE kinds and settings: 3e6 voxels, j850-paper, box fit) are
   labelled with the code in CHECKOUT (a child process with that ``PYTHONPATH``) and with this
   code; printed per kind: the share of voxels whose label changed, each ink's count change in
   binomial standard errors, the largest and mean change of a voxel's intended concentration,
   the largest change of the manifest's mean concentrations, and the clamp counts.

    PYTHONPATH=. python benchmarks/bench_label_accuracy.py                  # guards 1-3
    PYTHONPATH=. python benchmarks/bench_label_accuracy.py --only lookup
    git worktree add /tmp/old <commit of the old BASELINE>
    PYTHONPATH=. python benchmarks/bench_label_accuracy.py --only none --old /tmp/old
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_sources import source_path  # noqa: E402
from job_hashes import BASELINE, PLACEMENT, PRINTER, height_for, job_hash  # noqa: E402

LOOKUP_KINDS = ("demo", "openvdb", "metaimage", "nrrd", "vox", "radiance", "inria-sample")
GUARD_DE2000_P95 = 0.05
GUARD_Z = 5.0
SOLID = 1e30  # a target at or above gamut.alignment.SOLID_TARGET: the node mixture undiluted


def _job(kind: str, n_voxels: float, **extra):
    from dreamprint_gui.job.plan import ConvertSettings, prepare_job

    src = source_path(kind)
    return prepare_job(ConvertSettings(source=src, output="unused", printer=PRINTER,
                                       height_mm=height_for(src, n_voxels), workers=1,
                                       **PLACEMENT, **extra))


def _profile_of(ctx):
    from dreamprint_gui.core.profile import load_profile

    return load_profile(ctx.settings.profile).with_settings(
        layer_thickness_mm=ctx.printer.layer_thickness_mm)


def _sampled_layers(ctx, layers: int | None = None):
    """(rgb (L, ny*nx, 3) float32, dens (L, ny*nx) float32, z0) of the whole job or of
    ``layers`` layers in its middle."""
    nx, ny, nz = ctx.shape_xyz
    z0, z1 = 0, nz
    if layers is not None and layers < nz:
        z0 = (nz - layers) // 2
        z1 = z0 + layers
    rgb, dens = ctx.source.sample_slab(ctx.grid, z0, z1)
    n = z1 - z0
    return (np.ascontiguousarray(np.asarray(rgb).reshape(n, -1, 3), np.float32),
            np.ascontiguousarray(np.asarray(dens).reshape(n, -1), np.float32), z0)


def kind_colours(kind: str, count: int, seed: int = 0) -> np.ndarray:
    """``count`` distinct foreground colours (float64 sRGB) of a source kind's job."""
    ctx = _job(kind, 3e6)
    rgb, dens, _ = _sampled_layers(ctx)
    fg = dens.reshape(-1) >= ctx.halftoner.threshold
    cols = np.unique(np.nan_to_num(rgb.reshape(-1, 3)[fg]).clip(0, 1), axis=0)
    pick = np.random.default_rng(seed).permutation(len(cols))[:count]
    return cols[pick].astype(np.float64)


def lookup_guard(kinds, samples: int, per_kind: int) -> bool:
    from dreamprint_gui.gamut import lookup, lookup_and_align_into
    from dreamprint_gui.gamut.evaluation import IN_GAMUT_DE2000
    from dreamprint_gui.gamut.forward import N_COLOUR_INKS, forward_model, mixtures_lab
    from dreamprint_gui.gamut.mapping import intent_map
    from dreamprint_gui.gamut.optimise import solve, solve_xyz, srgb_to_xyz, targets_for
    from dreamprint_gui.physics.colorimetry import delta_E2000

    ctx = _job("demo", 1e6)
    _, tables = ctx.resources()
    profile = _profile_of(ctx)
    model = forward_model(profile)
    sets = {"sRGB cube": np.random.default_rng(0).random((samples, 3))}
    for k in kinds:
        sets[k] = kind_colours(k, per_kind)
    print(f"lookup vs direct solve, dE2000 at in-gamut colours ({tables.size}^3 "
          f"{tables.objective}, {tables.intent}); guard: kernel p95 <= {GUARD_DE2000_P95}")
    print(f"{'colours':>14} {'in gamut':>9} {'kernel mean':>11} {'p95':>7} {'max':>7} "
          f"{'table mean':>10} {'p95':>7} {'kernel vs table p95':>19} {'max':>7}")
    ok = True
    every = []
    for name, rgb in list(sets.items()) + [("all", None)]:
        if rgb is None:
            d_k, d_t, d_kt = (np.concatenate([e[i] for e in every]) for i in range(3))
            n_in, n_all = len(d_k), sum(e[3] for e in every)
        else:
            start = np.full(N_COLOUR_INKS, 0.2)
            direct, _, _ = solve(model, tables.objective, rgb, start, max_iter=300)
            de_target = delta_E2000(mixtures_lab(model, direct),
                                    targets_for(model, "cielab", rgb))
            imap = intent_map(model, tables.intent)
            if imap is not None:
                direct, _, _ = solve_xyz(model, tables.objective,
                                         imap.map_xyz(srgb_to_xyz(model, rgb)), start,
                                         max_iter=300)
            inside = de_target <= IN_GAMUT_DE2000
            conc6 = np.empty((len(rgb), 6), np.float32)
            lookup_and_align_into(tables, rgb.astype(np.float32),
                                  np.full(len(rgb), SOLID, np.float32), conc6)
            kern = conc6[:, :N_COLOUR_INKS].astype(np.float64)
            kern /= kern.sum(-1, keepdims=True)
            lab_direct = mixtures_lab(model, direct)[inside]
            lab_kern = mixtures_lab(model, kern)[inside]
            lab_tab = mixtures_lab(model, lookup(tables, rgb))[inside]
            d_k = delta_E2000(lab_kern, lab_direct)
            d_t = delta_E2000(lab_tab, lab_direct)
            d_kt = delta_E2000(lab_kern, lab_tab)
            n_in, n_all = int(inside.sum()), len(rgb)
            every.append((d_k, d_t, d_kt, n_all))
        if n_in == 0:
            print(f"{name:>14} {'0/' + str(n_all):>9}")
            continue
        p95 = float(np.percentile(d_k, 95))
        ok &= p95 <= GUARD_DE2000_P95
        print(f"{name:>14} {f'{n_in}/{n_all}':>9} {d_k.mean():>11.4f} {p95:>7.4f} "
              f"{d_k.max():>7.4f} {d_t.mean():>10.4f} {np.percentile(d_t, 95):>7.4f} "
              f"{np.percentile(d_kt, 95):>19.4f} {d_kt.max():>7.4f}", flush=True)
    sigma_error(tables, profile)
    return ok


def sigma_error(tables, profile, n: int = 20000) -> None:
    """The kernel's alignment against the exact one: relative sigma error (unclamped voxels)."""
    from dreamprint_gui.gamut import align_density, lookup, lookup_and_align_into
    from dreamprint_gui.gamut.tables import mixture_sigma

    rng = np.random.default_rng(7)
    rgb = rng.random((n, 3)).astype(np.float32)
    target = np.exp(rng.uniform(np.log(0.2), np.log(60.0), n)).astype(np.float32)
    out = np.empty((n, 6), np.float32)
    lookup_and_align_into(tables, rgb, target, out)
    r64 = rgb.astype(np.float64)
    exact = align_density(tables, r64, lookup(tables, r64), target, profile)
    ok = exact.clamped == 0
    rel = np.abs(mixture_sigma(profile, out.astype(np.float64))[ok] - target[ok]) / target[ok]
    print(f"kernel sigma vs target (exact alignment unclamped, {int(ok.sum())} of {n}): "
          f"relative error median {np.median(rel):.2e}, p95 {np.percentile(rel, 95):.2e}, "
          f"max {rel.max():.2e}; concentration sum - 1: max "
          f"{np.abs(out.astype(np.float64).sum(-1) - 1).max():.1e}", flush=True)


def labels_and_concentrations(kind: str, n_voxels: float, layers: int | None = None,
                              seed: int = 0) -> dict:
    """The job's labels (L, ny, nx) from its compiled layer kernel, the foreground mask and the
    foreground voxels' intended concentrations (N, 6) (the same lookup and alignment), and the
    kernel's counts and clamp report."""
    from dreamprint_gui.gamut import lookup_and_align_into
    from dreamprint_gui.job.sample_label.layer_kernel import slab_labels

    ctx = _job(kind, n_voxels, seed=seed)
    _, tables = ctx.resources()
    nx, ny, _ = ctx.shape_xyz
    rgb, dens, z0 = _sampled_layers(ctx, layers)
    n = rgb.shape[0]
    labels = np.empty((n, ny, nx), np.uint8)
    counts = np.zeros(7, np.int64)
    stats = np.zeros(4)
    slab_labels(rgb, dens, z0, *ctx.kernel_args(), labels, counts, np.zeros((n, 7)), stats)
    fg = dens.reshape(-1) >= ctx.halftoner.threshold
    conc = np.empty((int(fg.sum()), 6), np.float32)
    lookup_and_align_into(tables, rgb.reshape(-1, 3)[fg], dens.reshape(-1)[fg], conc)
    return {"labels": labels, "fg": fg.reshape(labels.shape), "conc": conc, "counts": counts,
            "stats": stats, "bg_label": ctx.halftoner.bg_label}


def region_z(d: dict, region: tuple[int, int, int]) -> np.ndarray:
    """Per region (boxes of ``region`` voxels, z y x; foreground voxels only) and ink:
    (|label count - sum of intended concentrations| - 1)^+ / sqrt(sum c (1 - c)); NaN where
    the ink's variance is 0 and the count within one voxel of the sum, inf where not."""
    lab = d["labels"]
    fg = d["fg"]
    c = np.zeros(lab.shape + (6,), np.float64)
    c[fg] = d["conc"]
    bz, by, bx = region
    nz, ny, nx = (s - s % b for s, b in zip(lab.shape, region, strict=True))
    shape = (nz // bz, bz, ny // by, by, nx // bx, bx)

    def boxes(a):
        return a[:nz, :ny, :nx].reshape(shape).sum(axis=(1, 3, 5))

    out = []
    for m in range(6):
        cnt = boxes(((lab == m) & fg).astype(np.float64))
        s = boxes(c[..., m])
        v = boxes(c[..., m] * (1.0 - c[..., m]))
        dev = np.maximum(np.abs(cnt - s) - 1.0, 0.0)
        z = np.where(v > 0, dev / np.sqrt(np.where(v > 0, v, 1.0)), np.nan)
        z = np.where((v == 0) & (dev > 0), np.inf, z)
        out.append(z.ravel())
    return np.stack(out, axis=-1)


def halftone_guard(kinds, n_voxels: float, layers: int, region) -> bool:
    print(f"label fractions per region ({region[0]} x {region[1]} x {region[2]} voxels z, y, x; "
          f"{layers} layers of {n_voxels:.0e}-voxel jobs): z = (|count - sum c| - 1)^+ / "
          f"sqrt(sum c (1 - c)) per region and ink; guard: z < {GUARD_Z:g}")
    head = "job bias (count - sum c) / sqrt(var), per ink C M Y K W Cl"
    print(f"{'kind':>14} {'regions':>8} {'max z':>8} {'rms z':>7} {head:>60}")
    ok = True
    for k in kinds:
        d = labels_and_concentrations(k, n_voxels, layers)
        z = region_z(d, region)
        fin = z[np.isfinite(z)]
        worst = float(np.nanmax(np.abs(z))) if np.any(~np.isnan(z)) else 0.0
        ok &= worst < GUARD_Z
        lab = d["labels"][d["fg"]]
        tot = [(np.sum(lab == m) - d["conc"][:, m].sum(dtype=np.float64))
               / max(np.sqrt(np.sum(d["conc"][:, m] * (1.0 - d["conc"][:, m]),
                                    dtype=np.float64)), 1e-300) for m in range(6)]
        print(f"{k:>14} {z.shape[0]:>8} {worst:>8.2f} "
              f"{np.sqrt(np.mean(fin ** 2)) if fin.size else 0.0:>7.3f} "
              f"{' '.join(f'{t:+6.2f}' for t in tot):>60}", flush=True)
    return ok


def determinism_guard(kinds, n_voxels: float) -> bool:
    print(f"determinism: slice and manifest hashes of {n_voxels:.0e}-voxel jobs (seed 0), "
          "1 worker, 2 workers, 2 workers again")
    ok = True
    for k in kinds:
        src = source_path(k)
        h = height_for(src, n_voxels)
        runs = [job_hash(src, h, w, None)[1:] for w in (1, 2, 2)]
        same = runs[0] == runs[1] == runs[2]
        ok &= same
        print(f"{k:>14} slices {runs[0][0]} manifest {runs[0][1]} "
              f"{'identical' if same else 'DIFFER: ' + repr(runs)}", flush=True)
    return ok


# ----------------------------------------------------------------------------- old vs new
def dump(kinds, n_voxels: float, path: str) -> None:
    """Labels, intended concentrations and manifest figures of each kind's job (the code on
    ``PYTHONPATH``), saved for :func:`compare`."""
    from dreamprint_gui.core.generators import drain
    from dreamprint_gui.job.plan import ConvertSettings
    from dreamprint_gui.job.run import run_conversion

    arrays = {}
    meta = {}
    for k in kinds:
        d = labels_and_concentrations(k, n_voxels)
        arrays[f"{k}/labels"] = d["labels"]
        arrays[f"{k}/fg"] = d["fg"]
        arrays[f"{k}/conc"] = d["conc"]
        src = source_path(k)
        with tempfile.TemporaryDirectory(prefix="dp-acc-") as tmp:
            gen = run_conversion(ConvertSettings(
                source=src, output=os.path.join(tmp, "JOB"), height_mm=height_for(src, n_voxels),
                workers=2, printer=PRINTER, **PLACEMENT))
            m = drain(gen)
        meta[k] = {key: m[key] for key in ("voxel_counts", "mean_concentration",
                                           "clamped_density")}
    np.savez_compressed(path, meta=json.dumps(meta), **arrays)


def _load(path: str):
    z = np.load(path)
    return z, json.loads(str(z["meta"]))


def compare(old_checkout: str, kinds, n_voxels: float) -> None:
    with tempfile.TemporaryDirectory(prefix="dp-acc-") as tmp:
        paths = {}
        for tag, code in (("old", os.path.abspath(old_checkout)),
                          ("new", str(Path(__file__).resolve().parent.parent))):
            paths[tag] = os.path.join(tmp, f"{tag}.npz")
            env = dict(os.environ, PYTHONPATH=code)
            subprocess.run([sys.executable, __file__, "--dump", paths[tag], "--kinds",
                            ",".join(kinds), "--voxels", str(n_voxels)], env=env, check=True)
        old, mo = _load(paths["old"])
        new, mn = _load(paths["new"])
        print(f"old ({old_checkout}) vs new labelling, {n_voxels:.0e}-voxel jobs ({PRINTER}, "
              "seed 0, blue noise)")
        print(f"{'kind':>14} {'fg voxels':>10} {'labels changed':>20} "
              f"{'count change / SE per ink C M Y K W Cl':>44} {'max |dc|':>9} {'mean |dc|':>9} "
              f"{'manifest mean c max |d|':>23} {'clamped low/high old -> new':>30}")
        for k in kinds:
            lo, ln = old[f"{k}/labels"], new[f"{k}/labels"]
            fg = new[f"{k}/fg"]
            assert lo.shape == ln.shape and np.array_equal(old[f"{k}/fg"], fg)
            co = old[f"{k}/conc"].astype(np.float64)
            cn = new[f"{k}/conc"].astype(np.float64)
            n_changed = int(np.sum(lo[fg] != ln[fg]))
            se = []
            for m in range(6):
                var = max(float(np.sum(co[:, m] * (1 - co[:, m]))), 1e-300)
                se.append((int(np.sum(ln[fg] == m)) - int(np.sum(lo[fg] == m))) / np.sqrt(var))
            dc = np.abs(cn - co)
            a, b = mo[k]["mean_concentration"], mn[k]["mean_concentration"]
            dman = max(abs(float(a[i]) - float(b[i])) for i in a)
            clo = mo[k]["clamped_density"]
            cln = mn[k]["clamped_density"]

            def cl(c):
                return f"{c.get('n_clamped_low', 0):.0f}/{c.get('n_clamped_high', 0):.0f}"

            changed = f"{n_changed} ({100 * n_changed / max(int(fg.sum()), 1):.4f}%)"
            print(f"{k:>14} {int(fg.sum()):>10} {changed:>20} "
                  f"{' '.join(f'{s:+6.2f}' for s in se):>44} "
                  f"{dc.max() if dc.size else 0:>9.2e} {dc.mean() if dc.size else 0:>9.2e} "
                  f"{dman:>23.2e} {cl(clo) + ' -> ' + cl(cln):>30}", flush=True)


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--only", default="all", help="lookup, halftone, determinism, all or none")
    ap.add_argument("--kinds", default=None)
    ap.add_argument("--samples", type=int, default=2000)
    ap.add_argument("--per-kind", type=int, default=300)
    ap.add_argument("--voxels", type=float, default=None)
    ap.add_argument("--layers", type=int, default=16)
    ap.add_argument("--region", default="16,32,32")
    ap.add_argument("--old", default=None, help="a checkout of the old code: print old vs new")
    ap.add_argument("--dump", default=None, help=argparse.SUPPRESS)
    a = ap.parse_args()
    if a.dump:
        dump(a.kinds.split(","), a.voxels, a.dump)
        return
    only = {"all": ("lookup", "halftone", "determinism"), "none": ()}.get(a.only, (a.only,))
    ok = True
    if "lookup" in only:
        ok &= lookup_guard(a.kinds.split(",") if a.kinds else LOOKUP_KINDS, a.samples,
                           a.per_kind)
    if "halftone" in only:
        ok &= halftone_guard(a.kinds.split(",") if a.kinds else LOOKUP_KINDS, a.voxels or 1e8,
                             a.layers, tuple(int(v) for v in a.region.split(",")))
    if "determinism" in only:
        ok &= determinism_guard(a.kinds.split(",") if a.kinds else list(BASELINE),
                                a.voxels or 3e6)
    if a.old:
        compare(a.old, a.kinds.split(",") if a.kinds else list(BASELINE), a.voxels or 3e6)
    if only:
        print("guards:", "pass" if ok else "FAIL")
        sys.exit(0 if ok else 1)


if __name__ == "__main__":
    main()
