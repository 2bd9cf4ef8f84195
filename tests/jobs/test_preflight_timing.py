"""The pre-flight times the job's own slabs: as thick as the job cuts them (a Gaussian-splat
job's set-up is paid per slab), one from each of n equal runs of slabs, n by the time budget."""

import threading

import pytest

from dreamprint_gui.job import preflight as pf_module
from dreamprint_gui.job.plan import ConvertSettings, prepare_job, slab_plan
from dreamprint_gui.job.preflight import preflight


@pytest.fixture(scope="module")
def splat_ctx(shared_data):
    ply = shared_data / "splats" / "inria3dgs_iter7000_sh3_9080.ply"
    return prepare_job(ConvertSettings(source=str(ply), height_mm=5.0, workers=2))


def _timed_slabs(monkeypatch, ctx):
    calls = []
    real = pf_module.encode_slab

    def spy(c, z0, z1):
        # off the main thread, as the job's workers: a source that spreads a call over the
        # cores from the main thread (InstantNGP) then runs as in the job
        assert threading.current_thread() is not threading.main_thread()
        calls.append((z0, z1))
        return real(c, z0, z1)

    monkeypatch.setattr(pf_module, "encode_slab", spy)
    pf = preflight(ctx, sample_voxels=20_000)
    return pf, calls


def test_a_splat_job_is_timed_on_its_multi_layer_slabs(monkeypatch, splat_ctx):
    slabs = slab_plan(splat_ctx, 2)
    assert slabs[0][1] - slabs[0][0] > 1          # the sampler asked for several layers
    monkeypatch.setattr(pf_module, "_timed_count", lambda n, t: min(4, n))
    pf, calls = _timed_slabs(monkeypatch, splat_ctx)
    assert calls[0] == slabs[len(slabs) // 2]     # the middle slab warms the caches first
    timed = calls[1:]
    assert len(timed) == 4 and set(timed) <= set(slabs)
    # the middle slab of each quarter of the job: its sparse ends count as much as its middle
    index = sorted(slabs.index(c) for c in timed)
    assert all(abs(i - (k + 0.5) * len(slabs) / 4) <= 1 for k, i in enumerate(index)), index
    layers = sum(z1 - z0 for z0, z1 in timed)
    assert f"timed on 4 of this job's slabs, {layers} layers, 2 workers" in pf.rate_source
    assert pf.seconds > 0 and pf.disk_bytes > 0


def test_the_time_budget_sets_how_many_slabs_are_timed(monkeypatch, splat_ctx):
    slabs = slab_plan(splat_ctx, 2)
    monkeypatch.setattr(pf_module, "TIMED_SECONDS", 1e9)
    _, calls = _timed_slabs(monkeypatch, splat_ctx)
    assert len(calls) - 1 == min(16, len(slabs)) == len(set(calls[1:]))


def test_slow_slabs_are_timed_fewer():
    budget = pf_module.TIMED_SECONDS
    count = pf_module._timed_count
    assert count(100, budget / 50) == 16             # quick slabs: the budget, up to 16
    assert count(100, budget / 6.5) == 6
    assert count(100, budget) == 4                   # at least 4 while 4 take <= 10 budgets
    assert count(100, budget * 2.4) == 4
    assert count(100, budget * 4) == 2               # slower: fewer, down to one
    assert count(100, budget * 100) == 1
    assert count(3, budget / 50) == 3                # never more than the job has


def test_workers_are_the_slabs_that_run_at_once(shared_data):
    ply = str(shared_data / "splats" / "inria3dgs_iter7000_sh3_9080.ply")
    two = prepare_job(ConvertSettings(source=ply, height_mm=5.0, workers=8, slab_layers=100))
    assert len(slab_plan(two, 8)) == 2
    assert "2 workers" in preflight(two, sample_voxels=20_000).rate_source
    sync = prepare_job(ConvertSettings(source=ply, height_mm=5.0, workers=2, scheduler="sync"))
    assert "1 worker" in preflight(sync, sample_voxels=20_000).rate_source
