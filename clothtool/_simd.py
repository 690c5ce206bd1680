"""Four-float SIMD values (LLVM ``<4 x float>``) for numba kernels: a particle row at a time.

A particle is four float32 (x, y, z, inverse mass) in a C-contiguous (n, 4) array, 16 bytes:
one SSE register (float64 state, the default precision, uses <4 x double>). numba has no
vector types and leaves LLVM's SLP vectoriser off (it was switched off for miscompiling,
numba PR #8852), so scalar code reading a row costs four loads and writing it three stores;
the loop vectoriser cannot help either, because a constraint loop gathers and scatters rows
through index arrays. These intrinsics load, combine and store a row as one vector, which
halves the fabric kernel's instructions per constraint.

Only what the kernels need: ``load4``/``store4`` on the flattened (n*4,) view at a float
offset, lane-wise ``vadd``/``vsub``/``vmul`` (multiply-add pairs fuse, as ``fastmath=
{"contract"}`` lets scalar code fuse), ``fill``, ``lane``, ``keep_w``, and ``transpose4`` /
``w_lanes`` (one lane of four particles as one vector, to work on four constraints at once), and
``is_double`` (a compile-time test of an array's precision, for arithmetic that differs by it).
The values never leave a kernel (no boxing), so a numba type with a primitive data model is
all they need. The kernel cache is keyed on the contents of every clothtool source
(clothtool._kernel_cache), so an edit here recompiles the kernels that inline it.
"""

from __future__ import annotations

import numba
from llvmlite import ir
from numba import types
from numba.extending import intrinsic, models, register_model

_I32 = ir.IntType(32)
_LLVM_FLOAT = {types.float32: ir.FloatType(), types.float64: ir.DoubleType()}


class Vec4(types.Type):
    """Four floats of one dtype (float64: the default state; float32: the faster precision option)."""

    def __init__(self, dtype):
        self.dtype = dtype
        super().__init__(name=f"clothtool.vec4[{dtype}]")


@register_model(Vec4)
class _Vec4Model(models.PrimitiveModel):
    def __init__(self, dmm, fe_type):
        super().__init__(dmm, fe_type, ir.VectorType(_LLVM_FLOAT[fe_type.dtype], 4))


def _is_flat_float(array) -> bool:
    return isinstance(array, types.Array) and array.dtype in _LLVM_FLOAT and array.ndim == 1 and array.layout == "C"


def _row_pointer(context, builder, array_type, array, index_type, index):
    """Address of element ``index`` of a flat float array, as a vector pointer."""
    data = context.make_array(array_type)(context, builder, array).data
    offset = context.cast(builder, index, index_type, types.intp)
    vector = ir.VectorType(_LLVM_FLOAT[array_type.dtype], 4)
    return builder.bitcast(builder.gep(data, [offset]), vector.as_pointer())


@intrinsic
def load4(typingctx, array, index):
    """array[index : index + 4] as one vector (array: flat C-contiguous float32 or float64)."""
    if not (_is_flat_float(array) and isinstance(index, types.Integer)):
        return None

    def codegen(context, builder, signature, args):
        pointer = _row_pointer(context, builder, signature.args[0], args[0], signature.args[1], args[1])
        return builder.load(pointer, align=array.dtype.bitwidth // 8)

    return Vec4(array.dtype)(array, index), codegen


@intrinsic
def store4(typingctx, array, index, value):
    """array[index : index + 4] = value."""
    if not (_is_flat_float(array) and isinstance(index, types.Integer) and value == Vec4(array.dtype)):
        return None

    def codegen(context, builder, signature, args):
        pointer = _row_pointer(context, builder, signature.args[0], args[0], signature.args[1], args[1])
        builder.store(args[2], pointer, align=array.dtype.bitwidth // 8)
        return context.get_dummy_value()

    return types.none(array, index, value), codegen


def _lanewise(operation: str):
    @intrinsic
    def lanewise(typingctx, a, b):
        if not (isinstance(a, Vec4) and a == b):
            return None

        def codegen(context, builder, signature, args):
            # "contract" lets a multiply feeding an add become one fused multiply-add
            return getattr(builder, operation)(args[0], args[1], flags=("contract",))

        return a(a, b), codegen

    lanewise.__doc__ = f"Lane-wise {operation[1:]} of two vectors."
    return lanewise


vadd = _lanewise("fadd")
vsub = _lanewise("fsub")
vmul = _lanewise("fmul")


@intrinsic
def fill(typingctx, like, x):
    """A vector of like's dtype with x (converted to that dtype) in every lane."""
    if not (isinstance(like, Vec4) and isinstance(x, (types.Float, types.Integer))):
        return None

    def codegen(context, builder, signature, args):
        value = context.cast(builder, args[1], signature.args[1], like.dtype)
        vector = ir.VectorType(_LLVM_FLOAT[like.dtype], 4)
        single = builder.insert_element(ir.Constant(vector, ir.Undefined), value, ir.Constant(_I32, 0))
        return builder.shuffle_vector(single, single, ir.Constant(ir.VectorType(_I32, 4), [0, 0, 0, 0]))

    return like(like, x), codegen


@intrinsic
def lane(typingctx, value, k):
    """Lane k (a constant 0-3) of a vector."""
    if not (isinstance(value, Vec4) and isinstance(k, types.IntegerLiteral) and 0 <= k.literal_value < 4):
        return None
    position = k.literal_value

    def codegen(context, builder, signature, args):
        return builder.extract_element(args[0], ir.Constant(_I32, position))

    return value.dtype(value, k), codegen


@intrinsic
def keep_w(typingctx, new, old):
    """(new.x, new.y, new.z, old.w): a moved particle keeps its inverse mass bit for bit."""
    if not (isinstance(new, Vec4) and new == old):
        return None

    def codegen(context, builder, signature, args):
        return builder.shuffle_vector(args[0], args[1], ir.Constant(ir.VectorType(_I32, 4), [0, 1, 2, 7]))

    return new(new, old), codegen


def _shuffle(builder, a, b, mask):
    return builder.shuffle_vector(a, b, ir.Constant(ir.VectorType(_I32, 4), mask))


# Shuffles of <4 x double> (two 128-bit halves) first pair lanes within each half (one cheap
# unpack instruction each), then swap halves (one cross-half permute each); masks that cross
# halves from the start were lowered to extra loads and permutes, ~10% of the float64 fabric
# kernel. A <4 x float> is one 128-bit register, whose unpacks take the first masks below.


@intrinsic
def transpose4(typingctx, r0, r1, r2, r3):
    """Rows to columns: the x, y, z and w lanes of four vectors as four vectors."""
    if not (isinstance(r0, Vec4) and r0 == r1 == r2 == r3):
        return None
    result = types.UniTuple(r0, 4)
    double = r0.dtype == types.float64

    def codegen(context, builder, signature, args):
        if double:
            even01 = _shuffle(builder, args[0], args[1], [0, 4, 2, 6])  # r0.x r1.x r0.z r1.z
            odd01 = _shuffle(builder, args[0], args[1], [1, 5, 3, 7])  # r0.y r1.y r0.w r1.w
            even23 = _shuffle(builder, args[2], args[3], [0, 4, 2, 6])
            odd23 = _shuffle(builder, args[2], args[3], [1, 5, 3, 7])
            columns = [
                _shuffle(builder, even01, even23, [0, 1, 4, 5]),
                _shuffle(builder, odd01, odd23, [0, 1, 4, 5]),
                _shuffle(builder, even01, even23, [2, 3, 6, 7]),
                _shuffle(builder, odd01, odd23, [2, 3, 6, 7]),
            ]
        else:
            low01 = _shuffle(builder, args[0], args[1], [0, 4, 1, 5])  # r0.x r1.x r0.y r1.y
            high01 = _shuffle(builder, args[0], args[1], [2, 6, 3, 7])  # r0.z r1.z r0.w r1.w
            low23 = _shuffle(builder, args[2], args[3], [0, 4, 1, 5])
            high23 = _shuffle(builder, args[2], args[3], [2, 6, 3, 7])
            columns = [
                _shuffle(builder, low01, low23, [0, 1, 4, 5]),
                _shuffle(builder, low01, low23, [2, 3, 6, 7]),
                _shuffle(builder, high01, high23, [0, 1, 4, 5]),
                _shuffle(builder, high01, high23, [2, 3, 6, 7]),
            ]
        return context.make_tuple(builder, result, columns)

    return result(r0, r1, r2, r3), codegen


@intrinsic
def w_lanes(typingctx, r0, r1, r2, r3):
    """(r0.w, r1.w, r2.w, r3.w): the inverse masses of four particles."""
    if not (isinstance(r0, Vec4) and r0 == r1 == r2 == r3):
        return None
    double = r0.dtype == types.float64

    def codegen(context, builder, signature, args):
        if double:
            w01 = _shuffle(builder, args[0], args[1], [1, 5, 3, 7])  # r0.y r1.y r0.w r1.w
            w23 = _shuffle(builder, args[2], args[3], [1, 5, 3, 7])
            return _shuffle(builder, w01, w23, [2, 3, 6, 7])
        w01 = _shuffle(builder, args[0], args[1], [3, 7, 3, 7])
        w23 = _shuffle(builder, args[2], args[3], [3, 7, 3, 7])
        return _shuffle(builder, w01, w23, [0, 1, 4, 5])

    return r0(r0, r1, r2, r3), codegen


@intrinsic
def is_double(typingctx, array):
    """Whether a float array holds float64 (the default state) rather than float32, as a
    constant of the compiled code: a kernel branching on it keeps only one precision's
    arithmetic (LLVM folds the branch), where numba would type both branches alike."""
    if not (isinstance(array, types.Array) and array.dtype in _LLVM_FLOAT):
        return None
    double = array.dtype == types.float64

    def codegen(context, builder, signature, args):
        return context.get_constant(types.boolean, double)

    return types.boolean(array), codegen



if numba.config.DISABLE_JIT:  # type: ignore[attr-defined]  # set dynamically by numba
    # NUMBA_DISABLE_JIT=1 runs the kernels as plain Python (CI runs the kernel tests once so);
    # intrinsics cannot be called from Python, so the same operations on numpy 4-vectors stand in.
    from clothtool import _simd_python

    globals().update({name: getattr(_simd_python, name) for name in _simd_python.__all__})
