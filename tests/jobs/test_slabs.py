"""How a job is cut into slabs: ~DEFAULT_SLAB_VOXELS each, >= 4 per worker, and the layers a
source asks for (``slab_layers``) where its layers are big, within MAX_SLAB_VOXELS."""

from types import SimpleNamespace

from dreamprint_gui.job.plan import DEFAULT_SLAB_VOXELS, MAX_SLAB_VOXELS, slab_plan


def _ctx(shape, want=None, fixed=None):
    src = SimpleNamespace() if want is None else SimpleNamespace(slab_layers=want)
    return SimpleNamespace(shape_xyz=shape, settings=SimpleNamespace(slab_layers=fixed),
                           source=src)


def _steps(slabs, nz):
    assert slabs[0][0] == 0 and slabs[-1][1] == nz
    assert all(a[1] == b[0] for a, b in zip(slabs[:-1], slabs[1:], strict=True))  # no gaps
    return {z1 - z0 for z0, z1 in slabs[:-1]}


def test_a_plain_source_gets_slabs_by_size():
    assert _steps(slab_plan(_ctx((831, 2604, 4624)), 2), 4624) == {1}      # 1e10 voxels
    assert _steps(slab_plan(_ctx((386, 1209, 2146)), 2), 2146) == {DEFAULT_SLAB_VOXELS
                                                               // (386 * 1209)}   # 1e9


def test_a_source_asking_for_layers_gets_them_within_the_memory_cap():
    # 1e10 voxels: 2.16e6 a layer, 1 layer by size; asked for 8, 7 fit in 2 workers' share
    steps = _steps(slab_plan(_ctx((831, 2604, 4624), want=8), 2), 4624)
    assert steps == {MAX_SLAB_VOXELS // 2 // (831 * 2604)} == {7}
    # layers of 5e6 voxels: 3 fit
    assert _steps(slab_plan(_ctx((2000, 2500, 600), want=8), 2), 600) == {3}
    # a layer beyond the cap: one layer a slab, as by size
    assert _steps(slab_plan(_ctx((5000, 5000, 300), want=8), 2), 300) == {1}
    # many workers share the cap (down to DEFAULT_SLAB_VOXELS each): memory stays bounded
    assert _steps(slab_plan(_ctx((831, 2604, 4624), want=8), 8), 4624) == {1}
    assert _steps(slab_plan(_ctx((831, 2604, 4624), want=8), 4), 4624) == {3}
    # small jobs keep >= 4 slabs per worker
    assert len(slab_plan(_ctx((181, 356, 47), want=8), 2)) >= 8
    assert len(slab_plan(_ctx((181, 356, 9), want=8), 2)) >= 8
    # already as many layers by size: unchanged; a fixed --slab-layers wins
    assert _steps(slab_plan(_ctx((386, 1209, 2146), want=8), 2), 2146) == {8}
    assert _steps(slab_plan(_ctx((831, 2604, 4624), want=8, fixed=2), 2), 4624) == {2}


def test_slabs_tile_the_job_within_the_cap_for_any_shape():
    # contiguous, non-empty, and no larger than by size or MAX_SLAB_VOXELS, whatever the
    # layer size, height and workers
    for nx, ny in ((1, 1), (300, 700), (831, 2604), (2000, 2500), (6000, 5000)):
        for nz in (1, 7, 9, 47, 255, 4624):
            for workers in (1, 2, 64):
                plain = slab_plan(_ctx((nx, ny, nz)), workers)
                asked = slab_plan(_ctx((nx, ny, nz), want=8), workers)
                _steps(asked, nz)
                assert all(z1 > z0 for z0, z1 in asked)
                size = (asked[0][1] - asked[0][0]) * nx * ny
                assert size <= max(MAX_SLAB_VOXELS // workers, DEFAULT_SLAB_VOXELS,
                                   (plain[0][1] - plain[0][0]) * nx * ny)
                assert len(asked) >= min(len(plain), 4 * workers)
                assert asked[0][1] - asked[0][0] <= max(8, plain[0][1] - plain[0][0])
