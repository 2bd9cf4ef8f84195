"""A splat file whose Gaussians are all invisible (zero opacity or scale, non-finite) fails with
one line naming the file, not "empty or invalid bounds ((0.0, ...))"; partly invisible ones are
counted by inspect."""

import numpy as np
import pytest

from dreamprint_gui.cli import main
from dreamprint_gui.core.errors import DreamPrintError
from dreamprint_gui.io.volumes import open_source

# antimatter15 .splat record (the format's 32 bytes): centre f32 x3, linear scale f32 x3,
# RGBA u8 x4, rotation u8 x4 (w, x, y, z as q * 128 + 128).
REC = np.dtype([("pos", "<f4", 3), ("scale", "<f4", 3), ("rgba", "u1", 4), ("rot", "u1", 4)])


def _write(path, n=20, scale=0.1, alpha=255, nan_first=False):
    r = np.zeros(n, REC)
    r["pos"] = np.linspace(-1, 1, 3 * n).reshape(n, 3)
    r["scale"] = scale
    r["rgba"] = [200, 30, 30, alpha]
    r["rot"] = [255, 128, 128, 128]
    if nan_first:
        r["pos"][0, 0] = np.nan
    r.tofile(path)
    return path


@pytest.mark.parametrize("kw", [{"alpha": 0}, {"scale": 0.0}])
def test_all_invisible_is_one_clear_error(tmp_path, kw):
    p = _write(tmp_path / "x.splat", **kw)
    with pytest.raises(DreamPrintError, match="none of the 20 Gaussians can be printed"):
        open_source(str(p))


def test_cli_error_names_file(tmp_path, capsys):
    p = _write(tmp_path / "x.splat", alpha=0)
    assert main(["convert", str(p), "-o", str(tmp_path / "J"), "--height-mm", "1"]) == 2
    err = [ln for ln in capsys.readouterr().err.splitlines() if "error" in ln]
    assert len(err) == 1 and err[0].startswith("dreamprint: error: ")
    assert "x.splat" in err[0] and "none of the 20" in err[0]
    assert "invalid bounds" not in err[0]
    assert not (tmp_path / "J").exists()


def test_inspect_counts_skipped(tmp_path, capsys):
    p = _write(tmp_path / "x.splat", nan_first=True)
    assert main(["inspect", str(p)]) == 0
    out = capsys.readouterr().out
    assert "20 Gaussians" in out and "(1 skipped" in out
    assert open_source(str(p)).info()["skipped"] == 1


def test_overflowing_scale_is_skipped_not_spread():
    """A Gaussian whose inverse covariance overflows (log-scale -400: sigma ~1e-174) is skipped
    and counted; it must not blank the voxels of the Gaussians it overlaps (a NaN kernel)."""
    import numpy as np

    from dreamprint_gui.io.volumes import grid_for_source
    from dreamprint_gui.io.volumes.splats.cloud import GaussianCloud

    means = np.zeros((2, 3))
    sig = np.array([[0.3, 0.3, 0.3], [1e-174, 0.3, 0.3]])
    quats = np.array([[1.0, 0, 0, 0], [1.0, 0, 0, 0]])
    both = GaussianCloud("c", "t", means, sig, quats, [0.5, 0.5], [[1, 0, 0], [0, 1, 0]],
                         bounds=((-1, -1, -1), (1, 1, 1)))
    one = GaussianCloud("c", "t", means[:1], sig[:1], quats[:1], [0.5], [[1, 0, 0]],
                        bounds=((-1, -1, -1), (1, 1, 1)))
    assert (both.n_skipped, one.n_skipped) == (1, 0)
    g = grid_for_source(one, (0.1, 0.1, 0.1), size_mm=(2, 2, 2))
    for a, b in zip(both.sample_slab(g, 0, 20), one.sample_slab(g, 0, 20), strict=True):
        assert np.array_equal(a, b)
    assert one.sample_slab(g, 0, 20)[1].max() > 0
