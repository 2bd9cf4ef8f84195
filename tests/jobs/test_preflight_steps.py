"""The pre-flight says each step as it starts (issue 46: a minute without a line on a
7.6e8-voxel demo under load); the conversion relays the step under way every 2 s."""

import time

from dreamprint_gui.core import progress
from dreamprint_gui.job import preflight as pf_module
from dreamprint_gui.job.plan import ConvertSettings, prepare_job
from dreamprint_gui.job.preflight import preflight
from dreamprint_gui.job.run import run_conversion


def test_preflight_notifies_each_step(monkeypatch, tmp_path):
    ctx = prepare_job(ConvertSettings(source="demo", height_mm=2.0, table_size=9, workers=2))
    monkeypatch.setattr(pf_module, "_timed_count", lambda n, t: min(3, n))
    said: list[str] = []
    preflight(ctx, sample_voxels=5_000, notify=said.append)
    assert said[0].startswith("pre-flight: sampling ")
    assert said[0].endswith(" voxels of the job's materials")
    assert said[1].startswith("pre-flight: timing the job's middle slab (layers ")
    assert [m.split(" (")[0] for m in said[2:]] == [
        f"pre-flight: timing slab {k} of 3" for k in (1, 2, 3)]


def test_a_slow_preflight_is_relayed_while_it_runs(monkeypatch, tmp_path):
    real = pf_module.encode_slab

    def slow(c, z0, z1):  # a slab of a slow source, under load
        time.sleep(0.3)
        return real(c, z0, z1)

    monkeypatch.setattr(pf_module, "encode_slab", slow)
    monkeypatch.setattr(pf_module, "_timed_count", lambda n, t: min(3, n))
    monkeypatch.setattr(progress, "HEARTBEAT_S", 0.2)
    s = ConvertSettings(source="demo", output=tmp_path / "JOB", height_mm=2.0, table_size=9)
    msgs = []
    gen = run_conversion(s)
    for p in gen:
        if p.stage == "preflight":
            gen.close()
            break
        msgs.append(p.message)
    during = [m for m in msgs if m.startswith("pre-flight: timing ")]
    assert len(during) >= 3 and during[-1].endswith(" s)")
    assert any("slab 3 of 3" in m for m in during)


def test_a_slow_preparation_says_the_step_under_way(monkeypatch, tmp_path):
    """Between its notices (placing a slow source, loading tables: 16.6 s without a line on
    the 40 mm demo at load 7), the preparation repeats the step under way every HEARTBEAT_S
    with its elapsed time; each notice still comes as it is made."""
    from dreamprint_gui.job import run

    class Stop(Exception):
        pass

    def slow_prepare(settings, notify=None):
        notify("opened the source demo in 4.2 s; placing it (its up axis, its occupied "
               "bounds) ...")
        time.sleep(0.9)
        notify("building colour tables:  10 %")
        raise Stop

    monkeypatch.setattr(run, "prepare_job", slow_prepare)
    monkeypatch.setattr(progress, "HEARTBEAT_S", 0.2)
    msgs = []
    try:
        for p in run._prepare(ConvertSettings(source="demo", height_mm=2.0), time.perf_counter()):
            msgs.append(p.message)
    except Stop:
        pass
    assert msgs[0].endswith("placing it (its up axis, its occupied bounds) ...")
    during = msgs[1:-1]
    assert 2 <= len(during) <= 5
    assert all(m.startswith("opened the source demo in 4.2 s; placing it") and
               m.endswith(" s)") and "..." not in m for m in during)
    assert msgs[-1] == "building colour tables:  10 %"
