"""Fused multiply-add and the bits of a double, for compiled code and for the interpreter.

Each is a Python function (exact, used when numba's JIT is disabled, so the interpreted kernel
computes the same bits as the compiled one) with a numba overload lowering it to one LLVM
instruction: ``llvm.fma.f64`` (one rounding) or a ``bitcast`` (a register move).
"""
import struct
from fractions import Fraction

from llvmlite import ir
from numba import types
from numba.extending import intrinsic, overload

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


@overload(fma, jit_options={"forceinline": True})
def _ol_fma(a, b, c):
    if all(isinstance(t, types.Float) for t in (a, b, c)):
        return lambda a, b, c: _fma(a, b, c)
    return None


@overload(as_bits, jit_options={"forceinline": True})
def _ol_as_bits(x):
    if isinstance(x, types.Float):
        return lambda x: _as_bits(x)
    return None


@overload(from_bits, jit_options={"forceinline": True})
def _ol_from_bits(b):
    if isinstance(b, types.Integer):
        return lambda b: _from_bits(b)
    return None
