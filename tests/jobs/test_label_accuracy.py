"""Accuracy guards of the print job's labelling (issue 25; measured at 100^3 on the source kinds
by ``benchmarks/bench_label_accuracy.py``): the compiled kernel's table lookup reproduces the
colours of the stored table, and the labels of every region of a job keep the intended
concentrations (the halftone's tolerance of ``test_halftone.py``: |count - sum c| < 5 standard
errors + 1 voxel). Determinism across workers, slab sizes and schedulers:
``test_pipeline.py::test_byte_identical_across_workers_and_slab_sizes`` and
``test_local_cluster_gives_the_same_slices``."""

import numpy as np
import pytest

from dreamprint_gui.gamut import lookup, lookup_and_align_into
from dreamprint_gui.gamut.alignment import SOLID_TARGET
from dreamprint_gui.gamut.forward import forward_model, mixtures_lab
from dreamprint_gui.job.plan import ConvertSettings, prepare_job
from dreamprint_gui.job.sample_label.layer_kernel import slab_labels
from dreamprint_gui.physics.colorimetry import delta_E2000


@pytest.fixture(scope="module", params=["blue-noise", "random"])
def job(request, tmp_path_factory):
    return prepare_job(ConvertSettings(source="demo", output=tmp_path_factory.mktemp("j") / "J",
                                       height_mm=0.6, table_size=17, seed=5,
                                       halftone=request.param))


def _profile(ctx):
    from dreamprint_gui.core.profile import load_profile

    return load_profile(ctx.settings.profile).with_settings(
        layer_thickness_mm=ctx.printer.layer_thickness_mm)


def test_kernel_lookup_reproduces_the_stored_tables_colours(job):
    # The kernel's table (its storage and float32 arithmetic) against the float64 trilinear
    # interpolation of the stored float32 table: colours within 0.02 dE2000 at p95, so that
    # today's lookup-vs-direct-solve p95 (0.026 at 100^3, docs/physics.md) stays under the
    # guard's 0.05.
    _, tables = job.resources()
    rng = np.random.default_rng(3)
    rgb = rng.random((4000, 3))
    rgb[:200] = np.round(rgb[:200] * 16) / 16  # on the nodes and their faces
    out = np.empty((len(rgb), 6), np.float32)
    lookup_and_align_into(tables, rgb.astype(np.float32),
                          np.full(len(rgb), SOLID_TARGET, np.float32), out)
    np.testing.assert_array_equal(out[:, 5], 0.0)  # solid: undiluted, no Clear
    kern = out[:, :5].astype(np.float64)
    np.testing.assert_allclose(kern.sum(-1), 1.0, atol=1e-5)
    model = forward_model(_profile(job))
    de = delta_E2000(mixtures_lab(model, kern / kern.sum(-1, keepdims=True)),
                     mixtures_lab(model, lookup(tables, rgb.astype(np.float32))))
    assert np.percentile(de, 95) <= 0.02 and de.max() < 0.2, (np.percentile(de, 95), de.max())


def _smooth(rng, shape, scale):
    from scipy.ndimage import gaussian_filter

    return gaussian_filter(rng.random(shape), scale, mode="wrap")


def test_label_fractions_per_region_keep_the_intended_concentrations(job):
    _, tables = job.resources()
    rng = np.random.default_rng(8)
    nz, ny, nx = 16, 96, 128
    rgb = np.stack([_smooth(rng, (nz, ny, nx), 6) for _ in range(3)], axis=-1)
    rgb = ((rgb - rgb.min()) / (rgb.max() - rgb.min())).astype(np.float32)
    dens = (60.0 * _smooth(rng, (nz, ny, nx), 4) ** 3).astype(np.float32)
    dens[:, :, :9] = 0.0  # background columns
    rgb = rgb.reshape(nz, -1, 3)
    dens = dens.reshape(nz, -1)
    labels = np.empty((nz, ny, nx), np.uint8)
    counts = np.zeros(7, np.int64)
    slab_labels(rgb, dens, 3, *job.kernel_args(), labels, counts, np.zeros((nz, 7)),
                np.zeros(4))
    fg = (dens >= job.halftoner.threshold).reshape(nz, ny, nx)
    assert 0.2 < fg.mean() < 0.95
    conc = np.zeros((nz, ny, nx, 6))
    sub = np.empty((int(fg.sum()), 6), np.float32)
    lookup_and_align_into(tables, rgb.reshape(-1, 3)[fg.ravel()], dens.ravel()[fg.ravel()], sub)
    conc[fg] = sub
    assert (conc[..., 5] > 0.1).mean() > 0.1 and (conc[..., 3] > 0.01).mean() > 0.05
    worst = 0.0
    for z0 in range(0, nz, 8):
        for y0 in range(0, ny, 32):
            for x0 in range(0, nx, 32):
                box = np.s_[z0:z0 + 8, y0:y0 + 32, x0:x0 + 32]
                f = fg[box]
                for m in range(6):
                    c = conc[box][..., m][f]
                    n = int(np.sum(labels[box][f] == m))
                    dev = max(abs(n - c.sum()) - 1.0, 0.0)
                    worst = max(worst, dev / np.sqrt(max(np.sum(c * (1 - c)), 1e-12)))
    assert worst < 5.0, worst
    assert np.all(labels[~fg] == job.halftoner.bg_label)
