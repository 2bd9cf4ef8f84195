"""The finished job's line about clamped voxels (issue 46): near-empty voxels printed as Clear
are not counted; the share is of the too-dense ones; it says what to do."""

from dreamprint_gui.job.clamp_report import clamp_summary


def _manifest(low, high, counts, pf=None):
    m = {"clamped_density": {"n_clamped_low": low, "n_clamped_high": high,
                             "max_shortfall_low": 0.4, "max_shortfall_high": 12.5},
         "total_voxels": sum(counts.values()), "voxel_counts": counts}
    if pf is not None:
        m["preflight"] = pf
    return m


def test_near_empty_voxels_printed_as_clear_are_not_counted():
    # an MR head's job: 130 M voxels, 44 M near-empty ones clamped low (printed as Clear)
    counts = {"C": 10_000_000, "M": 10_000_000, "Y": 0, "K": 0, "W": 20_000_000,
              "Cl": 90_000_000, "empty": 0}
    line = clamp_summary(_manifest(44_000_000, 400_000, counts))
    assert line.startswith("clamped: 400,000 voxels too dense (0.31 % of the job, 1.00 % of "
                           "its coloured voxels)")
    assert "44,000,000" not in line and "12.5/mm less dense" in line
    assert clamp_summary(_manifest(44_000_000, 0, counts)) is None


def test_the_line_says_which_density_scale_prints_them_as_stated():
    counts = {"C": 100, "Cl": 900}
    line = clamp_summary(_manifest(0, 50, counts, {"density_scale": 50.0,
                                                    "density_scale_without_clamping": 7.25}))
    assert line.endswith("; --density-scale 7.25 prints them as stated")
    assert "--density-scale" not in clamp_summary(_manifest(0, 50, counts))
