"""Explicit 16 x float32 vector steps for the compiled print-job kernels (numba intrinsics).

Defines
-------
- :func:`weighted_sum16`: ``out[d:d+16] = ((w0 a0 + w1 a1) + w2 a2) + ... + w_{N-1} a_{N-1}``
  where ``a_n = src[o_n:o_n+16]``: the interpolation of one voxel's 16 table lanes from its N
  nodes (4: tetrahedral).
- :func:`transpose16x13`: 16 rows of 16 floats (voxel-major) -> their first 13 columns as rows
  (lane-major), the layout in which the alignment pass vectorises across voxels.
- :func:`prefetch`: a hint that a cache line of an array will be read soon (the table lookup's
  nodes, a few voxels ahead; the splat rasteriser's next Gaussians).
- :func:`accumulate8`: ``acc[8 j : 8 j + 8] += src[o : o + 8]`` in float64, the step of a sum
  kept as 8 partial sums (a float reduction written as a loop stays one add at a time: LLVM may
  not reorder float additions).

Why not plain loops: written as a 16-step loop, LLVM's vectoriser guards each voxel with a
run-time overlap check between the table and the output (numba cannot state that two arrays do
not alias), spilling registers around it; it turns the strided reads of a transposition into
gathers, slow on current x86 cores; and it keeps a loop that reads a small table at computed
indices scalar (one voxel at a time), judging gathers too dear. Here the vectors are LLVM
``<16 x float>`` values, lowered to one AVX-512 register, two AVX registers or four SSE
registers as the CPU has. The arithmetic is plain IEEE ``fmul`` / ``fadd`` in a fixed order,
without fast-math flags (no fused multiply-add contraction, no reassociation), so every CPU
computes the same bits, equal to the scalar expression above in float32 (a job's slices are
tested equal with the kernels compiled for baseline x86-64). No bounds checks: callers pass
offsets inside the arrays.
"""

from __future__ import annotations

from llvmlite import ir
from numba import types
from numba.extending import intrinsic

__all__ = ["weighted_sum16", "transpose16x13", "accumulate8", "prefetch"]

_F32 = ir.FloatType()
_I32 = ir.IntType(32)
_I64 = ir.IntType(64)
_F64 = ir.DoubleType()
_V16 = ir.VectorType(_F32, 16)


def _data(context, builder, aty, value):
    return context.make_array(aty)(context, builder, value=value).data


def _vec_at(builder, base, index):
    """Pointer to 16 floats starting at element ``index`` of float pointer ``base``."""
    return builder.bitcast(builder.gep(base, [index], inbounds=True), _V16.as_pointer())


def _is_i64(t) -> bool:
    return isinstance(t, types.Integer) and t.bitwidth == 64


def _array_1d(t, dtypes) -> bool:
    return isinstance(t, types.Array) and t.dtype in dtypes and t.ndim == 1


def _f32_array(t) -> bool:
    return _array_1d(t, (types.float32,))


def _mask(values):
    return ir.Constant(ir.VectorType(_I32, 16), list(values))


@intrinsic
def weighted_sum16(typingctx, src, offsets, weights, out, d):
    """``src`` float32 1-D array, ``offsets`` N-tuple of uint64, ``weights`` N-tuple of
    float32, ``out`` float32 1-D array, ``d`` uint64: writes ``out[d:d+16]``."""
    if not (_f32_array(src) and _f32_array(out) and _is_i64(d)
            and isinstance(offsets, types.UniTuple) and _is_i64(offsets.dtype)
            and isinstance(weights, types.UniTuple) and weights.count == offsets.count
            and weights.dtype == types.float32):
        return None
    sig = types.void(src, offsets, weights, out, d)

    def codegen(context, builder, signature, args):
        base = _data(context, builder, signature.args[0], args[0])
        dst = _data(context, builder, signature.args[3], args[3])
        acc = None
        for n in range(signature.args[1].count):
            o = builder.extract_value(args[1], n)
            w = builder.insert_element(ir.Constant(_V16, None),
                                       builder.extract_value(args[2], n), ir.Constant(_I32, 0))
            w = builder.shuffle_vector(w, ir.Constant(_V16, None), _mask([0] * 16))
            term = builder.fmul(w, builder.load(_vec_at(builder, base, o), align=4))
            acc = term if acc is None else builder.fadd(acc, term)
        builder.store(acc, _vec_at(builder, dst, args[4]), align=4)
        return context.get_dummy_value()

    return sig, codegen


@intrinsic
def transpose16x13(typingctx, src, s0, dst, d0, stride):
    """``src[s0 + 16 r + q]`` (r, q < 16) -> ``dst[d0 + q * stride + r]`` for q < 13; ``src``
    and ``dst`` float32 1-D arrays, ``s0``, ``d0``, ``stride`` int64."""
    if not (_f32_array(src) and _f32_array(dst) and _is_i64(s0) and _is_i64(d0)
            and _is_i64(stride)):
        return None
    sig = types.void(src, s0, dst, d0, stride)

    def codegen(context, builder, signature, args):
        sb = _data(context, builder, signature.args[0], args[0])
        db = _data(context, builder, signature.args[2], args[2])
        rows = [builder.load(_vec_at(builder, sb, builder.add(args[1], ir.Constant(_I64, 16 * r))),
                             align=4) for r in range(16)]
        # Swap the off-diagonal h x h blocks of every 2h x 2h block, h = 8, 4, 2, 1: a 16 x 16
        # transposition in 64 two-source shuffles (those of the unused rows are dropped by LLVM).
        h = 8
        while h:
            new = list(rows)
            for r in range(16):
                if r & h:
                    continue
                new[r] = builder.shuffle_vector(
                    rows[r], rows[r + h], _mask(c if not c & h else 16 + c - h for c in range(16)))
                new[r + h] = builder.shuffle_vector(
                    rows[r], rows[r + h], _mask(c + h if not c & h else 16 + c for c in range(16)))
            rows = new
            h //= 2
        for q in range(13):
            at = builder.add(args[3], builder.mul(args[4], ir.Constant(_I64, q)))
            builder.store(rows[q], _vec_at(builder, db, at), align=4)
        return context.get_dummy_value()

    return sig, codegen


@intrinsic
def accumulate8(typingctx, src, o, acc, j):
    """``acc[8 j + l] += float64(src[o + l])`` for l < 8; ``src`` float32 and ``acc`` float64
    1-D arrays, ``o`` and ``j`` int64."""
    if not (_f32_array(src) and isinstance(acc, types.Array) and acc.ndim == 1
            and acc.dtype == types.float64 and _is_i64(o) and _is_i64(j)):
        return None
    sig = types.void(src, o, acc, j)
    f8 = ir.VectorType(_F32, 8)
    d8 = ir.VectorType(_F64, 8)

    def codegen(context, builder, signature, args):
        sb = _data(context, builder, signature.args[0], args[0])
        ab = _data(context, builder, signature.args[2], args[2])
        x = builder.load(builder.bitcast(builder.gep(sb, [args[1]], inbounds=True),
                                         f8.as_pointer()), align=4)
        at = builder.bitcast(builder.gep(ab, [builder.mul(args[3], ir.Constant(_I64, 8))],
                                         inbounds=True), d8.as_pointer())
        builder.store(builder.fadd(builder.load(at, align=8), builder.fpext(x, d8)), at, align=8)
        return context.get_dummy_value()

    return sig, codegen


@intrinsic
def prefetch(typingctx, src, i):
    """A hint (``llvm.prefetch``: read, locality 2, data cache; x86 ``prefetcht1``, into the
    L2 cache) that the cache line holding ``src[i]`` (a 1-D float32, float64 or int64 array,
    ``i`` uint64/int64) will be read soon. No effect on any value; an address outside the array
    is not an error but a wasted hint."""
    if not (_array_1d(src, (types.float32, types.float64, types.int64)) and _is_i64(i)):
        return None
    sig = types.void(src, i)

    def codegen(context, builder, signature, args):
        base = _data(context, builder, signature.args[0], args[0])
        ptr = builder.bitcast(builder.gep(base, [args[1]], inbounds=True),
                              ir.IntType(8).as_pointer())
        fnty = ir.FunctionType(ir.VoidType(), [ptr.type, _I32, _I32, _I32])
        fn = builder.module.declare_intrinsic("llvm.prefetch", [ptr.type], fnty)
        builder.call(fn, [ptr, ir.Constant(_I32, 0), ir.Constant(_I32, 2), ir.Constant(_I32, 1)])
        return context.get_dummy_value()

    return sig, codegen
