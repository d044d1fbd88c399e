"""Fused multiply-add, the bits of a double and vector row sums, for compiled code and for
the interpreter.

Each is a Python function (used when numba's JIT is disabled) with a numba overload lowering
it to a few LLVM instructions:

* ``fma``, ``as_bits``, ``from_bits``: one ``llvm.fma.f64`` (one rounding) or a ``bitcast``
  (a register move); the Python versions are exact, so the interpreted kernel computes the same
  bits as the compiled one;
* ``combine_rows4``/``8``: weighted sums of rows of a 2-D array as ``<4 x double>`` or
  ``<8 x double>`` operations (the Runge-Kutta stage sums); interpreted, the same sums rounded
  term by term.
"""
import struct
from fractions import Fraction

from llvmlite import ir
from numba import types
from numba.core import cgutils
from numba.extending import intrinsic, overload

from .jit import OVERLOAD_OPTIONS

_U64 = 0xFFFFFFFFFFFFFFFF


def fma(a, b, c):
    """``a * b + c`` rounded once."""
    a, b, c = float(a), float(b), float(c)
    if all(abs(v) < float("inf") for v in (a, b, c)):
        # exact in rationals, then one correctly rounded conversion
        return float(Fraction(a) * Fraction(b) + Fraction(c))
    return a * b + c  # inf or nan somewhere: the products' specials are the same


def as_bits(x):
    """The IEEE-754 bits of a float64, as a (signed) int64."""
    return struct.unpack("<q", struct.pack("<d", float(x)))[0]


def from_bits(b):
    """The float64 whose IEEE-754 bits are the low 64 bits of the integer ``b``."""
    return struct.unpack("<d", struct.pack("<Q", int(b) & _U64))[0]


@intrinsic
def _fma(typingctx, a, b, c):
    sig = types.float64(types.float64, types.float64, types.float64)

    def codegen(context, builder, signature, args):
        return builder.fma(*args)

    return sig, codegen


def _bitcast(to_type, from_type, llvm_to):
    @intrinsic
    def bitcast(typingctx, x):
        def codegen(context, builder, signature, args):
            return builder.bitcast(args[0], llvm_to)

        return to_type(from_type), codegen

    return bitcast


_as_bits = _bitcast(types.int64, types.float64, ir.IntType(64))
_from_bits = _bitcast(types.float64, types.int64, ir.DoubleType())


@overload(fma, jit_options={"forceinline": True, **OVERLOAD_OPTIONS})
def _ol_fma(a, b, c):
    if all(isinstance(t, types.Float) for t in (a, b, c)):
        return lambda a, b, c: _fma(a, b, c)
    return None


@overload(as_bits, jit_options={"forceinline": True, **OVERLOAD_OPTIONS})
def _ol_as_bits(x):
    if isinstance(x, types.Float):
        return lambda x: _as_bits(x)
    return None


@overload(from_bits, jit_options={"forceinline": True, **OVERLOAD_OPTIONS})
def _ol_from_bits(b):
    if isinstance(b, types.Integer):
        return lambda b: _from_bits(b)
    return None


def _combine_rows(K, rows, coefs, width):
    acc = [coefs[0] * K[rows[0], i] for i in range(width)]
    for r, c in zip(rows[1:], coefs[1:]):
        for i in range(width):
            acc[i] = acc[i] + c * K[r, i]
    return tuple(acc)


def combine_rows4(K, rows, coefs):
    """``sum_j coefs[j] * K[rows[j], :4]`` as four floats, summed in order.

    Compiled: one ``<4 x double>`` multiply and a multiply-add per row, the rows loaded as
    vectors (numba leaves LLVM's straight-line vectoriser off, so the scalar sums of a stage
    cost four times the instructions). Interpreted: the same sums with a rounding per product
    and per sum, as the interpreter evaluates the scalar code around it.

    ``K`` must be C-contiguous (a row is one vector load; other layouts are a typing error)
    with at least 4 columns, and ``rows`` in range: like numba's indexing, neither is checked.
    """
    return _combine_rows(K, rows, coefs, 4)


def combine_rows8(K, rows, coefs):
    """:func:`combine_rows4` over ``K[rows[j], :8]``."""
    return _combine_rows(K, rows, coefs, 8)


def _combine_rows_intrinsic(width):
    @intrinsic
    def combine(typingctx, K, rows, coefs):
        if not (isinstance(K, types.Array) and K.ndim == 2 and K.layout == "C"
                and isinstance(rows, types.BaseTuple) and isinstance(coefs, types.BaseTuple)
                and len(rows) == len(coefs) >= 1):
            return None
        ret = types.UniTuple(types.float64, width)

        def codegen(context, builder, signature, args):
            arr = context.make_array(signature.args[0])(context, builder, args[0])
            stride = cgutils.unpack_tuple(builder, arr.strides, 2)[0]
            base = builder.bitcast(arr.data, ir.IntType(8).as_pointer())
            vty = ir.VectorType(ir.DoubleType(), width)
            fma_v = cgutils.get_or_insert_function(
                builder.module, ir.FunctionType(vty, [vty, vty, vty]), f"llvm.fma.v{width}f64")
            zeros = ir.Constant(ir.VectorType(ir.IntType(32), width), [0] * width)
            acc = None
            for j in range(len(rows)):
                r = context.cast(builder, builder.extract_value(args[1], j), signature.args[1][j],
                                 types.intp)
                c = context.cast(builder, builder.extract_value(args[2], j), signature.args[2][j],
                                 types.float64)
                ptr = builder.gep(base, [builder.mul(r, stride)])
                row = builder.load(builder.bitcast(ptr, vty.as_pointer()), align=8)
                one = builder.insert_element(ir.Constant(vty, ir.Undefined), c,
                                             ir.Constant(ir.IntType(32), 0))
                splat = builder.shuffle_vector(one, one, zeros)
                acc = builder.fmul(splat, row) if acc is None else builder.call(
                    fma_v, [splat, row, acc])
            vals = [builder.extract_element(acc, ir.Constant(ir.IntType(32), i))
                    for i in range(width)]
            return context.make_tuple(builder, ret, vals)

        return ret(K, rows, coefs), codegen

    return combine


_combine_rows4 = _combine_rows_intrinsic(4)
_combine_rows8 = _combine_rows_intrinsic(8)


@overload(combine_rows4, jit_options={"forceinline": True, **OVERLOAD_OPTIONS})
def _ol_combine_rows4(K, rows, coefs):
    return lambda K, rows, coefs: _combine_rows4(K, rows, coefs)


@overload(combine_rows8, jit_options={"forceinline": True, **OVERLOAD_OPTIONS})
def _ol_combine_rows8(K, rows, coefs):
    return lambda K, rows, coefs: _combine_rows8(K, rows, coefs)
