"""A long-lived worker (a Dask cluster's) keeps a job's source and tables for the next job of
the same source, but reopens a source file that was changed since."""

import os
import pickle

import numpy as np

from dreamprint_gui.job.plan import ConvertSettings, prepare_job


def _grid(path, value):
    n = 8
    np.savez(path, sigma=np.full((n, n, n), value, np.float32),
             rgb=np.full((n, n, n, 3), 0.5, np.float32),
             bounds=np.array([[0, 0, 0], [1, 1, 1]], float))


def test_worker_reopens_a_source_changed_since_its_last_job(tmp_path):
    src = tmp_path / "grid.npz"
    _grid(src, 1.0)
    settings = ConvertSettings(source=str(src), output=str(tmp_path / "JOB"), height_mm=2.0)
    ctx = prepare_job(settings)
    shipped = pickle.dumps(ctx)  # what a worker receives: no source, no tables
    first, _ = pickle.loads(shipped).resources()
    again, _ = pickle.loads(pickle.dumps(prepare_job(settings))).resources()  # the next job
    assert again is first  # the same file: kept
    _grid(src, 3.0)
    st = os.stat(src)
    os.utime(src, ns=(st.st_atime_ns, st.st_mtime_ns + 10**9))
    changed, _ = pickle.loads(pickle.dumps(prepare_job(settings))).resources()
    assert changed is not first
    g = ctx.grid
    assert changed.sample_slab(g, 0, 1)[1].max() > first.sample_slab(g, 0, 1)[1].max()
