"""Linear -> sRGB encoding of colour samples: compiled, vectorisable, the same bits on every CPU.

Defines :func:`srgb_encode32` (one value, inlined into compiled loops), :func:`encode_where`
(a layer's colour rows in place where its density reaches a threshold), :func:`clip_where`
(the same for colour stored sRGB-encoded: clipped only), :func:`prepare_staged` (either, on the
staged colours of a block of foreground voxels: the fused job paths, :data:`AS_IS`,
:data:`CLIP`, :data:`ENCODE`) and :func:`encode_inplace` (a whole array).

The encoding is IEC 61966-2-1's: ``12.92 x`` for ``x <= 0.0031308``, else
``1.055 x^(1/2.4) - 0.055``, after clipping ``x`` to [0, 1] (NaN stays NaN), in float32 steps
(``x * 12.92``; ``p = x^(1/2.4)``, ``p * 1.055``, ``- 0.055``, each rounded to float32, the
constants float32 too). ``p`` is ``exp2_f32(log2_f32(x) e)`` with ``e`` = float32(1/2.4), from
:mod:`...core.kernels.vector_math`: float32 arithmetic, 8 values per AVX2 instruction. Against
a correctly rounded reference (float64 ``**`` rounded to float32) the encoded value is within
2^-23 (1.2e-7; every float32 of (0.0031308, 1] compared, 35 % of them differ, by 1-8 units in
the last place), a thousandth of the 100^3 colour table's node spacing
(tests/io/volumes/test_srgb_encode.py). Speed: ~1.7 ns per value in the cache (5.2 ns per
voxel's three; with float64 ``exp2(log2)`` correctly rounded but for 6 in a million values, as
until issue 25: 10.4).

Why not ``np.power(x, 1/2.4, dtype=np.float32)`` (what the slab path used before): numpy
dispatches float32 ``power`` by CPU. On an AVX-512 CPU it runs Intel's SVML, elsewhere the C
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

from dreamprint_gui.core.kernels.vector_math import exp2_f32, log2_f32

__all__ = ["srgb_encode32", "encode_where", "clip_where", "prepare_staged", "encode_inplace",
           "AS_IS", "CLIP", "ENCODE"]

# What :func:`prepare_staged` does to a colour: nothing, clip to [0, 1], sRGB-encode.
AS_IS, CLIP, ENCODE = 0, 1, 2

_E = np.float32(1 / 2.4)
_LOW = np.float32(0.0031308)
_SLOPE = np.float32(12.92)
_A = np.float32(1.055)
_B = np.float32(0.055)


@njit(cache=True, nogil=True, inline="always", error_model="numpy")
def srgb_encode32(x):
    """sRGB encoding of one linear float32 value (module docstring), clipped to [0, 1]."""
    zero = np.float32(0.0)
    one = np.float32(1.0)
    c = x if x > zero else zero
    c = c if c < one else one
    c = x if x != x else c                              # NaN stays NaN, as np.clip
    lin = c * _SLOPE
    p = exp2_f32(log2_f32(c if c > _LOW else one) * _E)
    enc = p * _A - _B
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
