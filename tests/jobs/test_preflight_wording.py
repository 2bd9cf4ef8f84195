"""Wording of the pre-flight summary: time estimates read as English, the clamping hint is
honest about being estimated from a sample."""

import numpy as np

from dreamprint_gui.job.preflight import Preflight, PreflightWarning, _warnings


def _pf(seconds: float, clamped: int = 0, safe: float | None = None,
        lost: float | None = None) -> Preflight:
    fr = {"C": 0.1, "M": 0.1, "Y": 0.1, "K": 0.1, "W": 0.1, "Cl": 0.5, "empty": 0.0}
    return Preflight(
        grid_shape=(10, 10, 10), size_mm=(1.0, 1.0, 1.0), slices=10, total_voxels=1000,
        disk_bytes=2000, fractions=fr, sampled_voxels=1000, clamped_fraction=clamped / 1000,
        clamped_voxels=clamped, safe_density_scale=safe, out_of_gamut_fraction=0.0,
        worst_dE2000=0.0, seconds=seconds, rate_voxels_per_s=1e6, rate_source="benchmark",
        content={"mode": "fog", "reason": "test"}, density_scale=50.0, background="clear",
        printed_fraction=0.5, clamped_printed_fraction=clamped / 500, lost_at_safe_scale=lost)


def test_sub_second_estimate_is_not_about_under():
    pf = _pf(0.3)
    text = "\n".join(pf.summary_lines()) + "\n" + pf.short_line()
    assert "about under" not in text
    assert "conversion: under 1 s at" in text
    assert ", under 1 s;" in pf.short_line()


def test_longer_estimates_keep_about():
    assert "conversion: about 7 s at" in "\n".join(_pf(7.2).summary_lines())
    assert "about 2.0 min" in _pf(120.0).short_line()


def test_clamp_hint_says_it_is_a_sample_estimate():
    w = {x.code: x for x in _warnings(_pf(5.0, clamped=40, safe=3.29, lost=0.01))}
    msg = w["clamped"].message
    assert isinstance(w["clamped"], PreflightWarning)
    assert "--density-scale 3.29 or less" in msg and "sampled" in msg and "\n" not in msg


def test_clamp_hint_keeps_a_dense_object_dense():
    """A lower scale that would turn much of the object to background is not suggested."""
    w = {x.code: x for x in _warnings(_pf(5.0, clamped=40, safe=3.29, lost=0.3))}
    msg = w["clamped"].message
    assert "or less" not in msg and "the scale is kept" in msg and "30 %" in msg


def test_a_named_scale_limit_is_rounded_down():
    """A scale named as clamping nothing never exceeds the measured limit."""
    from dreamprint_gui.job.preflight import _at_most

    assert _at_most(0.24750321925095606) == "0.247"
    assert _at_most(0.25) == "0.25"
    assert _at_most(19.999) == "19.9"
    for v in 10.0 ** np.random.default_rng(0).uniform(-4, 4, 500):
        assert float(_at_most(v)) <= v * (1 + 1e-12)


def test_a_slow_preparation_is_in_the_time_said():
    """A first build of the colour tables (about 60 s) is no longer hidden behind "under 1 s"
    (issue 46): the line gives the conversion and the whole job."""
    pf = _pf(0.4)
    pf.prepared_seconds = 61.0
    line = pf.short_line()
    assert "under 1 s to convert, about 61 s in all (preparing took 61 s" in line  # GUI
    assert any(x.startswith("time: under 1 s to convert") for x in pf.summary_lines())
    assert pf.to_json()["prepared_seconds"] == 61.0
    pf.prepared_seconds = 0.2                      # a prepared context: as before
    assert ", under 1 s;" in pf.short_line()
