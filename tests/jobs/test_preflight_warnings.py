"""Pre-flight warnings: never contradictory, suggestions that keep the content's intent.

The warnings are a function of the pre-flight's figures (:func:`preflight._warnings`), checked
here on the cases the issue met (a splat scene 98.4 % Clear with clamped cores; a donut 32 %
clamped; a solid) and on a real demo job at the scale a warning names."""

import re

import pytest

from dreamprint_gui.job.preflight import Preflight, _warnings


def _pf(**kw) -> Preflight:
    base = dict(grid_shape=(10, 10, 10), size_mm=(1.0, 1.0, 1.0), slices=10, total_voxels=1000,
                disk_bytes=0, fractions={"C": 0.1, "M": 0.0, "Y": 0.0, "K": 0.0, "W": 0.0,
                                         "Cl": 0.9, "empty": 0.0},
                sampled_voxels=1000, clamped_fraction=0.0, clamped_voxels=0,
                safe_density_scale=None, out_of_gamut_fraction=0.0, worst_dE2000=0.0,
                seconds=1.0, rate_voxels_per_s=1e6, rate_source="test",
                content={"mode": "fog"}, density_scale=1.0, background="clear")
    base.update(kw)
    return Preflight(**base)


def _scales(ws) -> list[float]:
    """Every --density-scale value the warnings suggest."""
    return [float(v) for w in ws for v in re.findall(r"--density-scale ([0-9.e+-]+)", w.message)]


MOSTLY_CLEAR = {"C": 0.008, "M": 0.0, "Y": 0.008, "K": 0.0, "W": 0.0, "Cl": 0.984,
                "empty": 0.0}


def test_haze_with_clamped_cores_is_told_solid_and_no_lower_scale():
    # the biker: 98.4 % Clear and some clamped voxels; a lower scale would thin it further
    pf = _pf(fractions=MOSTLY_CLEAR, clamped_voxels=12, clamped_fraction=0.012,
             clamped_printed_fraction=0.75, safe_density_scale=0.0455, lost_at_safe_scale=0.6,
             printed_fraction=0.016)
    ws = _warnings(pf)
    assert {w.code for w in ws} == {"mostly-clear", "clamped"}
    assert "--content solid" in ws[0].message
    assert _scales(ws) == []  # neither warning suggests a scale
    assert ws[1].numbers["density_scale_without_clamping"] == 0.0455  # the figure stays


def test_dense_object_is_not_told_a_scale_that_makes_it_haze():
    # the donut: 32 % of its printed voxels clamped; the safe scale would thin it 22-fold
    pf = _pf(clamped_voxels=320, clamped_fraction=0.032, clamped_printed_fraction=0.32,
             safe_density_scale=0.0455, lost_at_safe_scale=0.7, printed_fraction=0.1)
    (w,) = _warnings(pf)
    assert w.code == "clamped"
    assert "the scale is kept" in w.message and "--content solid" in w.message
    assert "--density-scale 0.0455 would avoid" in w.message and "22-fold" in w.message
    assert "or less avoids it" not in w.message


def test_a_few_clamped_voxels_are_told_the_safe_scale():
    pf = _pf(clamped_voxels=5, clamped_fraction=0.005, clamped_printed_fraction=0.05,
             safe_density_scale=0.8, lost_at_safe_scale=0.01, printed_fraction=0.1)
    (w,) = _warnings(pf)
    assert "--density-scale 0.8 or less avoids it" in w.message


def test_a_solid_gets_no_scale_advice():
    pf = _pf(content={"mode": "solid"}, clamped_voxels=5, clamped_fraction=0.005,
             clamped_printed_fraction=0.05, safe_density_scale=0.8, lost_at_safe_scale=0.0)
    assert _scales(_warnings(pf)) == []
    pf = _pf(content={"mode": "solid"}, fractions=MOSTLY_CLEAR)
    (w,) = _warnings(pf)
    assert "check the source" in w.message and "--density-scale" not in w.message


@pytest.mark.parametrize(("up", "suggested"), [(20.0, True), (1.2, False), (None, False)])
def test_a_faint_fog_is_told_how_far_the_scale_may_rise(up, suggested):
    pf = _pf(fractions=MOSTLY_CLEAR, max_unclamped_density_scale=up, printed_fraction=0.5)
    (w,) = _warnings(pf)
    assert "--content solid" in w.message
    assert ("larger --density-scale (up to 20 clamps none" in w.message) is suggested


def test_the_named_scale_keeps_the_demo_printed(tmp_path):
    """On a real job: the dense demo at scale 50 (clamped): whatever scale a warning names,
    converting at it keeps the job printed (not mostly Clear) and clamps nothing."""
    from dreamprint_gui.job.plan import ConvertSettings
    from dreamprint_gui.job.preflight import preflight

    pf = preflight(ConvertSettings(source="demo", height_mm=1.2, table_size=17,
                                   density_scale=50.0), sample_voxels=30_000)
    assert pf.clamped_voxels > 0
    for scale in _scales(pf.warnings):
        again = preflight(ConvertSettings(source="demo", height_mm=1.2, table_size=17,
                                          density_scale=scale * 0.999), sample_voxels=30_000)
        assert again.clamped_voxels == 0
        assert "mostly-clear" not in {w.code for w in again.warnings}
