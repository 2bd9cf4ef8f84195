"""The compiled log2 / exp2 of the alignment kernel against numpy's (C library) values."""

import numpy as np
from numba import njit

from dreamprint_gui.core.kernels.vector_math import exp2_f32, exp2_f64, log2_f32, log2_f64


@njit(error_model="numpy")
def _log2_all(x, out):
    for i in range(x.shape[0]):
        out[i] = log2_f64(x[i])


@njit(error_model="numpy")
def _exp2_all(y, out):
    for i in range(y.shape[0]):
        out[i] = exp2_f64(y[i])


def test_log2_matches_numpy_over_many_decades():
    rng = np.random.default_rng(1)
    x = np.concatenate([np.exp(rng.uniform(-700, 700, 200_000)),
                        [1.0, 2.0, 0.5, np.sqrt(2.0), np.nextafter(np.sqrt(2.0), 2), 1e-300]])
    out = np.empty_like(x)
    _log2_all(x, out)
    np.testing.assert_allclose(out, np.log2(x), rtol=0, atol=1e-10)
    assert out[-6:-3].tolist() == [0.0, 1.0, -1.0]  # exact at powers of two


def test_exp2_matches_numpy_and_clamps_nonsense():
    rng = np.random.default_rng(2)
    y = np.concatenate([rng.uniform(-1000, 1000, 200_000), [-5.0, 0.0, 1.0, -0.5]])
    out = np.empty_like(y)
    _exp2_all(y, out)
    np.testing.assert_allclose(out, np.exp2(y), rtol=1e-11)
    assert out[-4:-1].tolist() == [1 / 32, 1.0, 2.0]
    odd = np.array([np.nan, -np.inf, np.inf])
    res = np.empty(3)
    _exp2_all(odd, res)
    assert np.all(np.isfinite(res))  # a discarded vector lane never faults or poisons


@njit(error_model="numpy")
def _log2_all32(x, out):
    for i in range(x.shape[0]):
        out[i] = log2_f32(x[i])


@njit(error_model="numpy")
def _exp2_all32(y, out):
    for i in range(y.shape[0]):
        out[i] = exp2_f32(y[i])


def test_log2_f32_matches_numpy_to_float32_precision():
    rng = np.random.default_rng(3)
    x = np.concatenate([np.exp(rng.uniform(-80, 80, 200_000)),
                        [1.0, 2.0, 0.5, np.sqrt(2.0), 1e-30]]).astype(np.float32)
    out = np.empty_like(x)
    _log2_all32(x, out)
    ref = np.log2(x.astype(np.float64))
    err = np.abs(out - ref) / np.maximum(1.0, np.abs(ref))
    assert err.max() < 3e-7, err.max()
    assert out[-5:-2].tolist() == [0.0, 1.0, -1.0]  # exact at powers of two


def test_exp2_f32_matches_numpy_and_clamps_nonsense():
    rng = np.random.default_rng(4)
    y = np.concatenate([rng.uniform(-120, 120, 200_000), [-5.0, 0.0, 1.0, -0.5]]
                       ).astype(np.float32)
    out = np.empty_like(y)
    _exp2_all32(y, out)
    np.testing.assert_allclose(out, np.exp2(y.astype(np.float64)), rtol=3e-7)
    assert out[-4:-1].tolist() == [1 / 32, 1.0, 2.0]
    odd = np.array([np.nan, -np.inf, np.inf], np.float32)
    res = np.empty(3, np.float32)
    _exp2_all32(odd, res)
    assert np.all(np.isfinite(res))


def test_numpy_array_versions_give_the_compiled_bits():
    """log2_f64_array / exp2_f64_array (tables built once, e.g. the sRGB encoding's segment
    lines) repeat the compiled functions' steps: the same bits, not numpy's CPU-dispatched
    log2 / exp2."""
    from dreamprint_gui.core.kernels.vector_math import exp2_f64_array, log2_f64_array

    rng = np.random.default_rng(11)
    x = np.concatenate([10.0 ** rng.uniform(-300, 300, 20000), [1.0, 2.0, 0.5, np.sqrt(2.0)]])
    y = np.concatenate([rng.uniform(-1100, 1100, 20000),
                        [0.0, -0.5, 0.5, 1023.0, -1022.0, np.nan, np.inf, -np.inf]])
    want_log, want_exp = np.empty_like(x), np.empty_like(y)
    _log2_all(x, want_log)
    _exp2_all(y, want_exp)
    np.testing.assert_array_equal(log2_f64_array(x).view(np.int64), want_log.view(np.int64))
    np.testing.assert_array_equal(exp2_f64_array(y).view(np.int64), want_exp.view(np.int64))
