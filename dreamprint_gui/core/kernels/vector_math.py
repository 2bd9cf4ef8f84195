"""log2 and exp2 for compiled per-voxel loops: vectorisable and the same bits on every machine.

Defines
-------
- :func:`log2_f64`, :func:`exp2_f64`: numba functions (inlined) built from IEEE-754 additions,
  multiplications, one division and bit manipulation only.
- :func:`log2_f32`, :func:`exp2_f32`: the same in float32 (twice the voxels per vector
  instruction), to float32's precision: log2's series to s^9 (truncation < 2e-9), exp2's
  argument reduced to f in [-1/2, 1/2] (n = round(y)) and its Taylor series to degree 7
  (truncation < 6e-9).
- :func:`log2_f64_array`, :func:`exp2_f64_array`: :func:`log2_f64`, :func:`exp2_f64` of numpy
  arrays, the same steps and bits, for tables built once (the sRGB encoding's segment lines).
- :data:`bits_f32`: a float32's bits as an int32 in compiled code (a table index).

Why not ``math.log2`` / ``2.0 ** x``: inside a numba loop those are calls into the C library,
which stop LLVM from vectorising the loop (one voxel at a time, ~20 ns each), and a vector maths
library (Intel SVML) picks its code path by CPU, so a mixed Dask cluster could disagree in the
last bit and halftone a voxel differently. Plain arithmetic without fused multiply-adds (numba
compiles without fast-math, so LLVM does not contract) rounds identically on every x86-64 and
ARM CPU, vectorised or not.

- log2: x = 2^e m with m in [sqrt(1/2), sqrt(2)); log2 m = (2 / ln 2) atanh(s), s = (m - 1) /
  (m + 1), |s| <= 0.1716, by its odd series to s^11 (truncation < 3e-11; Abramowitz & Stegun
  4.1.27).
- exp2: 2^y = 2^n 2^f with n = floor(y), f in [0, 1); 2^f = exp(f ln 2) by its Taylor series to
  degree 12 in Horner form (truncation < 2e-12); 2^n written into the exponent field.

Both are meant for positive, finite, normal arguments (log2) and y in [-1022, 1023] (exp2);
other inputs give a finite, meaningless number rather than an exception, so that lanes of a
vector whose result is discarded by a select cannot fault.
"""

from __future__ import annotations

import math

import numpy as np
from llvmlite import ir
from numba import njit, types
from numba.extending import intrinsic

__all__ = ["log2_f64", "exp2_f64", "log2_f32", "exp2_f32", "bits_f32", "log2_f64_array",
           "exp2_f64_array"]

_LN2 = math.log(2.0)
_INV_LN2_2 = 2.0 / _LN2
_SQRT2 = math.sqrt(2.0)
_MANT = np.int64(0x000FFFFFFFFFFFFF)
_ONE_BITS = np.int64(0x3FF0000000000000)
_EXP_BITS = np.int64(0x7FF)
# exp(f ln 2) = sum (f ln 2)^k / k!, k = 0..12
_E = tuple(_LN2 ** k / math.factorial(k) for k in range(13))


@intrinsic
def _bits(typingctx, x):
    if x != types.float64:
        return None

    def codegen(context, builder, signature, args):
        return builder.bitcast(args[0], ir.IntType(64))

    return types.int64(types.float64), codegen


@intrinsic
def _from_bits(typingctx, b):
    if b != types.int64:
        return None

    def codegen(context, builder, signature, args):
        return builder.bitcast(args[0], ir.DoubleType())

    return types.float64(types.int64), codegen


@intrinsic
def _bits32(typingctx, x):
    if x != types.float32:
        return None

    def codegen(context, builder, signature, args):
        return builder.bitcast(args[0], ir.IntType(32))

    return types.int32(types.float32), codegen


@intrinsic
def _from_bits32(typingctx, b):
    """The float32 whose bits are the low 32 bits of the integer ``b``."""
    if not isinstance(b, types.Integer):
        return None

    def codegen(context, builder, signature, args):
        v = args[0]
        if b.bitwidth != 32:
            v = builder.trunc(v, ir.IntType(32)) if b.bitwidth > 32 else builder.zext(
                v, ir.IntType(32))
        return builder.bitcast(v, ir.FloatType())

    return types.float32(b), codegen


# The bits of a float32 as an int32, in compiled code (the index of a table over float32 bit
# patterns: ..io.volumes.srgb_encode).
bits_f32 = _bits32

_MANT32 = np.int32(0x007FFFFF)
_ONE_BITS32 = np.int32(0x3F800000)
_EXP_BITS32 = np.int32(0xFF)
_F = tuple(np.float32(c) for c in (_INV_LN2_2, 1.0 / 3.0, 1.0 / 5.0, 1.0 / 7.0, 1.0 / 9.0))
_E32 = tuple(np.float32(c) for c in _E[:8])


@njit(cache=True, nogil=True, inline="always", error_model="numpy")
def log2_f32(x):
    """log2(x) for a positive, finite, normal float32 (absolute error < 3e-7)."""
    bits = _bits32(x)
    e = np.float32(np.int32(((bits >> np.int32(23)) & _EXP_BITS32) - np.int32(127)))
    m = _from_bits32((bits & _MANT32) | _ONE_BITS32)  # [1, 2)
    big = m > np.float32(_SQRT2)
    m = m * np.float32(0.5) if big else m
    e = e + np.float32(1.0) if big else e
    s = (m - np.float32(1.0)) / (m + np.float32(1.0))
    s2 = s * s
    series = np.float32(1.0) + s2 * (_F[1] + s2 * (_F[2] + s2 * (_F[3] + s2 * _F[4])))
    return e + _F[0] * s * series


@njit(cache=True, nogil=True, inline="always", error_model="numpy")
def exp2_f32(y):
    """2**y for y in [-126, 127] (relative error < 3e-7); clamped there (NaN -> 2^-126)."""
    y = y if y > np.float32(-126.0) else np.float32(-126.0)
    y = y if y < np.float32(127.0) else np.float32(127.0)
    n = np.floor(y + np.float32(0.5))
    f = y - n  # [-1/2, 1/2]
    p = _E32[7]
    p = _E32[6] + f * p
    p = _E32[5] + f * p
    p = _E32[4] + f * p
    p = _E32[3] + f * p
    p = _E32[2] + f * p
    p = _E32[1] + f * p
    p = _E32[0] + f * p
    # 32-bit integers (n + 127 is in [1, 254]): a 64-bit one here halves the vector width
    # of a loop that calls this (align_rows: 4.9 -> 4.0 ns per voxel)
    return p * _from_bits32((np.int32(n) + np.int32(127)) << np.int32(23))


@njit(cache=True, nogil=True, inline="always", error_model="numpy")
def log2_f64(x):
    """log2(x) for a positive, finite, normal float64 (absolute error < 1e-10)."""
    bits = _bits(x)
    e = np.float64(((bits >> np.int64(52)) & _EXP_BITS) - np.int64(1023))
    m = _from_bits((bits & _MANT) | _ONE_BITS)  # [1, 2)
    big = m > _SQRT2
    m = m * 0.5 if big else m
    e = e + 1.0 if big else e
    s = (m - 1.0) / (m + 1.0)
    s2 = s * s
    series = 1.0 + s2 * (1.0 / 3.0 + s2 * (1.0 / 5.0 + s2 * (1.0 / 7.0 + s2 * (
        1.0 / 9.0 + s2 * (1.0 / 11.0)))))
    return e + _INV_LN2_2 * s * series


@njit(cache=True, nogil=True, inline="always", error_model="numpy")
def exp2_f64(y):
    """2**y for y in [-1022, 1023] (relative error < 1e-11); clamped there (NaN -> 2^-1022)."""
    y = y if y > -1022.0 else -1022.0
    y = y if y < 1023.0 else 1023.0
    n = np.floor(y)
    f = y - n
    p = _E[12]
    p = _E[11] + f * p
    p = _E[10] + f * p
    p = _E[9] + f * p
    p = _E[8] + f * p
    p = _E[7] + f * p
    p = _E[6] + f * p
    p = _E[5] + f * p
    p = _E[4] + f * p
    p = _E[3] + f * p
    p = _E[2] + f * p
    p = _E[1] + f * p
    p = _E[0] + f * p
    return p * _from_bits((np.int64(n) + np.int64(1023)) << np.int64(52))


def log2_f64_array(x: np.ndarray) -> np.ndarray:
    """:func:`log2_f64` of a float64 array in numpy, the same steps in the same order: the same
    bits (numpy's own ``log2`` is dispatched by CPU). For tables built once, not per voxel."""
    x = np.asarray(x, np.float64)
    bits = x.view(np.int64)
    e = (((bits >> np.int64(52)) & _EXP_BITS) - np.int64(1023)).astype(np.float64)
    m = ((bits & _MANT) | _ONE_BITS).view(np.float64)
    big = m > _SQRT2
    m = np.where(big, m * 0.5, m)
    e = np.where(big, e + 1.0, e)
    s = (m - 1.0) / (m + 1.0)
    s2 = s * s
    series = 1.0 + s2 * (1.0 / 3.0 + s2 * (1.0 / 5.0 + s2 * (1.0 / 7.0 + s2 * (
        1.0 / 9.0 + s2 * (1.0 / 11.0)))))
    return e + _INV_LN2_2 * s * series


def exp2_f64_array(y: np.ndarray) -> np.ndarray:
    """:func:`exp2_f64` of a float64 array in numpy, the same steps: the same bits."""
    y = np.asarray(y, np.float64)
    y = np.where(y > -1022.0, y, -1022.0)  # NaN -> -1022, as the compiled selects
    y = np.where(y < 1023.0, y, 1023.0)
    n = np.floor(y)
    f = y - n
    p = np.full_like(f, _E[12])
    for k in range(11, -1, -1):
        p = _E[k] + f * p
    return p * ((n.astype(np.int64) + np.int64(1023)) << np.int64(52)).view(np.float64)
