"""The ablation methods: labels through the job's halftoner, their defining rules."""

import numpy as np

from dreamprint_gui.job.plan import ConvertSettings
from dreamprint_gui.proof.methods import (
    BruteForceLabels,
    JointLabels,
    _softmax,
)
from dreamprint_gui.proof.runner import ProofSettings


def _settings(method):
    ps = ProofSettings(source="demo", height_mm=1.5, method=method, table_size=17, seed=4)
    return ConvertSettings.from_spec(ps.spec)


def test_brute_force_hypervoxels_share_their_concentrations():
    lab = BruteForceLabels(_settings("brute-force"))
    nx, ny, nz = lab.shape_xyz
    z = nz // 2
    a = lab.layer(z)
    assert a.shape == (ny, nx) and a.max() <= 6
    np.testing.assert_array_equal(a, lab.layer(z))  # deterministic
    # the colour fit of an ink's own colour is that ink (simplex NNLS, exact in the hull)
    n = lab._lut_n - 1
    for i in range(5):
        rgb = lab.ink_rgb[i]
        if np.all(rgb <= 1):
            w = lab._lut[tuple(np.rint(rgb * n).astype(int))]
            assert abs(w @ lab.ink_rgb - rgb).max() < 1.5 / n + 0.05


class _SmallJointLabels(JointLabels):
    """The same solve on a coarser grid (5^3 RGB x 4 densities, 500 targets instead of 8,748):
    what is tested is the solve, and the full grid takes minutes at the profile's 1 nm."""

    N_RGB = 5
    N_SIGMA = 4


def test_joint_solve_lowers_its_objective():
    lab = _SmallJointLabels(_settings("no-alignment"))
    g = lab._table.reshape(-1, 6)
    assert np.allclose(g.sum(-1), 1) and g.min() >= 0
    # against the start (uniform mixture) the fitted table is much better on its own objective
    R, G, B, LS = np.meshgrid(lab._g_rgb, lab._g_rgb, lab._g_rgb, lab._g_ls, indexing="ij")
    rgb = np.stack([R, G, B], -1).reshape(-1, 3)
    obs = lab._obs
    lab_t = obs.XYZ_to_Lab(obs.sRGB_to_XYZ(rgb))
    start = lab._objective(_softmax(np.zeros((rgb.shape[0], 6))), lab_t, LS.reshape(-1)).mean()
    assert lab.fit_objective_mean < 0.5 * start
    nx, ny, nz = lab.shape_xyz
    out = lab.layer(nz // 2)
    assert out.shape == (ny, nx) and out.max() <= 6
