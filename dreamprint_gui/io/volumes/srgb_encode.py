"""Linear -> sRGB encoding of colour samples: compiled, vectorisable, the same bits on every CPU.

Defines :func:`srgb_encode32` (one value, inlined into compiled loops), :func:`encode_where`
(a layer's colour rows in place where its density reaches a threshold), :func:`clip_where`
(the same for colour stored sRGB-encoded: clipped only), :func:`prepare_staged` (either, on the
staged colours of a block of foreground voxels: the fused job paths, :data:`AS_IS`,
:data:`CLIP`, :data:`ENCODE`) and :func:`encode_inplace` (a whole array).

The encoding is IEC 61966-2-1's: ``12.92 x`` for ``x <= 0.0031308``, else
``1.055 x^(1/2.4) - 0.055``, after clipping ``x`` to [0, 1] (NaN stays NaN; 1 encodes to
``1.055 - 0.055`` in float32). Above 0.0031308 the curve is a line per segment of float32 bit
patterns, ``a_i + b_i x`` (float32, rounded once each): a segment is the values sharing the
exponent and the first 8 mantissa bits (256 per octave, 2151 segments down to 0.0031308, 17 kB
in the L1 cache), its line the minimax line of the curve there (the secant's slope, moved up by
half the curve's largest gap above the secant). Against a correctly rounded reference (float64
``**``, rounded in float32 steps) the encoded value is within 3e-7, 2.7e-8 on average
(every float32 of (0.0031308, 1] compared in tests/io/volumes/test_srgb_encode.py), a
thirty-thousandth of the 100^3 colour table's node spacing. Speed: 3.0 ns per value in the
cache on an AVX2 Zen 1 core, against 5.8 for the ``exp2(log2(x) / 2.4)`` of float32 series
that it replaces (docs/print-jobs.md, "On an AVX2 Zen 1 core").

The segment lines are computed once, at import (under a millisecond), in float64 by
:mod:`...core.kernels.vector_math`'s ``log2_f64_array`` / ``exp2_f64_array`` (plain IEEE
arithmetic) and then rounded: the same table on every machine. Why not ``np.power(x, 1/2.4,
dtype=np.float32)`` (what the slab path used before), or numpy's float64 ``**`` for the table:
numpy dispatches ``power`` by CPU. On an AVX-512 CPU it runs Intel's SVML, elsewhere the C
library's ``powf``, and the two disagree in the last bit for 20 % of the values in
(0.0031308, 1] (all 70,439,397 float32 values there compared on the project's VM, numpy 2.4).
A Dask cluster of mixed machines would then label some voxels of a linear-colour source
differently, and a compiled loop that calls ``powf`` cannot be vectorised. Plain IEEE
arithmetic (no fused multiply-adds: numba compiles without fast-math) rounds identically
everywhere, vectorised or not.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from dreamprint_gui.core.kernels.vector_math import bits_f32, exp2_f64_array, log2_f64_array

__all__ = ["srgb_encode32", "encode_where", "clip_where", "prepare_staged", "encode_inplace",
           "AS_IS", "CLIP", "ENCODE"]

# What :func:`prepare_staged` does to a colour: nothing, clip to [0, 1], sRGB-encode.
AS_IS, CLIP, ENCODE = 0, 1, 2

_E = float(np.float32(1 / 2.4))
_LOW = np.float32(0.0031308)
_SLOPE = np.float32(12.92)
_A = np.float32(1.055)
_B = np.float32(0.055)
_ONE = _A - _B           # the encoding of 1, float32 steps
# A segment: float32 values equal in all but their last _SEG_SHIFT bits (8 mantissa bits kept).
_SEG_SHIFT = 15


def _curve(x: np.ndarray) -> np.ndarray:
    """1.055 x^(1/2.4) - 0.055 in float64 (relative error ~1e-10), plain IEEE steps."""
    return 1.055 * exp2_f64_array(log2_f64_array(x) * _E) - 0.055


def _from_segment(seg: np.ndarray) -> np.ndarray:
    """The smallest float32 of each segment ``seg`` (bit patterns ``>> _SEG_SHIFT``), float64."""
    return (np.asarray(seg, np.int64) << _SEG_SHIFT).astype(np.int32).view(np.float32) \
        .astype(np.float64)


def _segment_lines(first: int, n: int) -> tuple[np.ndarray, np.ndarray]:
    """(a, b) float64 (n,) of segments ``first .. first + n - 1``: the minimax line ``a + b x``
    of :func:`_curve` (concave) on each segment's [x0, x1]."""
    seg = np.arange(first, first + n)
    x0, x1 = _from_segment(seg), _from_segment(seg + 1)
    y0 = _curve(x0)
    b = (_curve(x1) - y0) / (x1 - x0)
    # the curve's largest gap above the secant, where its slope 1.055 E x^(E - 1) is b
    xm = exp2_f64_array(log2_f64_array(b / (1.055 * _E)) / (_E - 1.0))
    gap = _curve(xm) - (y0 + b * (xm - x0))
    return y0 - b * x0 + 0.5 * gap, b


_SEG_FIRST = int(np.asarray(_LOW).view(np.int32)) >> _SEG_SHIFT
_SEG_LAST = int(np.asarray(np.float32(1.0)).view(np.int32)) >> _SEG_SHIFT
_SEG_A, _SEG_B = (v.astype(np.float32) for v in _segment_lines(_SEG_FIRST,
                                                               _SEG_LAST - _SEG_FIRST + 1))
_SEG_FIRST32 = np.int32(_SEG_FIRST)
_SEG_TOP = np.int32(_SEG_LAST - _SEG_FIRST)


@njit(cache=True, nogil=True, inline="always", error_model="numpy")
def srgb_encode32(x):
    """sRGB encoding of one linear float32 value (module docstring), clipped to [0, 1]."""
    zero = np.float32(0.0)
    one = np.float32(1.0)
    c = x if x > zero else zero
    c = c if c < one else one
    c = x if x != x else c                              # NaN stays NaN, as np.clip
    lin = c * _SLOPE
    i = (bits_f32(c) >> np.int32(_SEG_SHIFT)) - _SEG_FIRST32
    i = i if i > np.int32(0) else np.int32(0)           # (below 0.0031308 or NaN: unused)
    i = i if i < _SEG_TOP else _SEG_TOP
    enc = _SEG_A[i] + _SEG_B[i] * c
    enc = _ONE if c == one else enc
    return lin if (c <= _LOW or c != c) else enc


@njit(cache=True, nogil=True, error_model="numpy")
def encode_where(rgb, dens, threshold, nx):
    """``rgb`` (N, 3) float32 linear -> sRGB in place in every row of ``nx`` voxels that holds a
    voxel whose ``dens`` (N,) reaches ``threshold`` (the voxels the labelling reads; rows
    without one keep whatever they held). Whole rows, so that the loop is vectorised: ~3 ns
    per value (a loop with a test per voxel runs one value at a time, ~22 ns)."""
    flat = rgb.reshape(-1)
    for base in range(0, dens.shape[0], nx):
        fg = False
        for i in range(base, base + nx):
            fg |= dens[i] >= threshold
        if fg:  # a view indexed from 0: LLVM vectorises this loop, not one over [3 base, ..)
            row = flat[3 * base:3 * (base + nx)]
            for t in range(row.shape[0]):
                row[t] = srgb_encode32(row[t])


@njit(cache=True, nogil=True, error_model="numpy")
def clip_where(rgb, dens, threshold, nx):
    """``rgb`` (N, 3) float32 clipped to [0, 1] in place (NaN kept, as ``np.clip``) in the rows
    :func:`encode_where` converts: the colour of a source that stores it sRGB-encoded."""
    zero = np.float32(0.0)
    one = np.float32(1.0)
    flat = rgb.reshape(-1)
    for base in range(0, dens.shape[0], nx):
        fg = False
        for i in range(base, base + nx):
            fg |= dens[i] >= threshold
        if fg:
            row = flat[3 * base:3 * (base + nx)]
            for t in range(row.shape[0]):
                x = row[t]
                y = x if x > zero else zero
                y = y if y < one else one
                row[t] = x if x != x else y


@njit(cache=True, nogil=True, inline="always")
def _clip32(x):
    """``x`` clipped to [0, 1], NaN kept (``np.clip``)."""
    y = x if x > np.float32(0.0) else np.float32(0.0)
    y = y if y < np.float32(1.0) else np.float32(1.0)
    return x if x != x else y


@njit(cache=True, nogil=True, error_model="numpy")
def prepare_staged(col, m, stride, op):
    """The colours of ``m`` staged voxels (``col`` float32, channel ``c`` of voxel ``k`` at
    ``c * stride + k``) in place: sRGB-encoded (``op`` :data:`ENCODE`, :func:`srgb_encode32`),
    clipped (:data:`CLIP`, as :func:`clip_where`) or left (:data:`AS_IS`). The voxels the
    labelling reads and no others, each channel one contiguous run (vectorised): encoding the
    whole rows that hold foreground (:func:`encode_where`) converted 1.7x as many values on a
    smoke cloud's layers. The same values as the row variants give those voxels."""
    if op == AS_IS:
        return
    for c in range(3):
        row = col[c * stride:c * stride + m]  # a view from 0: the loop vectorises
        if op == ENCODE:
            for t in range(m):
                row[t] = srgb_encode32(row[t])
        else:
            for t in range(m):
                row[t] = _clip32(row[t])


@njit(cache=True, nogil=True, error_model="numpy")
def _encode_flat(x):
    for q in range(x.shape[0]):
        x[q] = srgb_encode32(x[q])


def encode_inplace(c: np.ndarray) -> np.ndarray:
    """sRGB encoding of a C-contiguous float32 array of linear values, in place."""
    if c.dtype != np.float32 or not c.flags.c_contiguous:
        raise ValueError("encode_inplace needs a C-contiguous float32 array")
    _encode_flat(c.reshape(-1))
    return c
