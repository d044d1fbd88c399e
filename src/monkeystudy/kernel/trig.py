"""Sine and cosine of one angle for the vector fields and guards (compiled).

Why not ``np.sin``/``np.cos``: numba lowers them to calls into the C library, and the right-hand
side of a swing needs the sines and cosines of two angles at every stage. A call clobbers every
floating-point register (all are caller-saved on x86-64), so the stage sums are spilled and
reloaded around each call, and the two angles cannot be evaluated side by side. Here the
reduction and both polynomials are straight-line code the compiler inlines and interleaves
(``monkeystudy bench`` times a dependent chain of two sines and cosines both ways, line "sine
and cosine of two angles as a dependent chain", and the swing right-hand side with it).

Algorithm, for ``|x| < REDUCE_BOUND``: ``k = round(x 2/pi)``, ``r = x - k pi/2`` by Cody-Waite
reduction with ``pi/2`` split into three doubles (each product exact inside a fused
multiply-add), then ``sin r`` and ``cos r`` on ``[-pi/4, pi/4]`` by fdlibm's kernel polynomials
(``k_sin.c``, ``k_cos.c``, same coefficients, evaluated by Estrin's scheme) and the quadrant
``k mod 4`` chosen by selects and sign flips, without branches. The reduced argument is one
double, without fdlibm's tail, so the error is up to ~1.3 ulp instead of fdlibm's ~1
(``tests/kernel/test_trig.py`` measures it against 120-bit values, including arguments next to
multiples of pi/2, where the third piece of pi/2 matters). Larger arguments, infinities and NaN
go to the C library.

The same bits wherever it is inlined: :func:`sincos` is compiled on its own, strictly (no
fast-math flags), and LLVM keeps those per-instruction flags when it inlines it, so the
``contract`` flag of the Runge-Kutta steps does not reach it, and the sines a step leaves for
the guards equal those :func:`.dynamics.trig_of` computes (tested). The polynomial steps are
explicit fused multiply-adds (``llvm.fma``, one rounding each) for speed and accuracy, not left
to contraction.

Complex arguments (the complex-step derivatives of :mod:`.variational`) go to ``np.sin`` /
``np.cos``: only real evaluations need to be fast.
"""
import math

import numpy as np
from numba import types
from numba.extending import overload

from .intrinsics import as_bits, fma, from_bits
from .jit import OVERLOAD_OPTIONS, njit


# fdlibm k_sin.c: sin r = r + r^3 (S1 + r^2 S2 + ... + r^10 S6) on [-pi/4, pi/4]
S1 = -1.66666666666666324348e-01
S2 = 8.33333333332248946124e-03
S3 = -1.98412698298579493134e-04
S4 = 2.75573137070700676789e-06
S5 = -2.50507602534068634195e-08
S6 = 1.58969099521155010221e-10
# fdlibm k_cos.c: cos r = 1 - r^2/2 + r^4 (C1 + r^2 C2 + ... + r^10 C6)
C1 = 4.16666666666666019037e-02
C2 = -1.38888888888741095749e-03
C3 = 2.48015872894767294178e-05
C4 = -2.75573143513906633035e-07
C5 = 2.08757232129817482790e-09
C6 = -1.13596475577881948265e-11
INV_PIO2 = 6.36619772367581382433e-01
#: pi/2 = PIO2_1 + PIO2_2 + PIO2_3 to ~1e-49 (PIO2_1 is the double nearest pi/2)
PIO2_1 = 1.5707963267948966
PIO2_2 = 6.123233995736766e-17
PIO2_3 = -1.4973849048591698e-33
#: adding and subtracting 1.5 * 2**52 rounds to the nearest integer, which then sits in the
#: low bits of the sum
TO_INT = 6755399441055744.0
#: below 2**-27, sin x = x and cos x = 1 after rounding
TINY = 7.450580596923828e-09
#: below this |x| the three-piece reduction is accurate (k < 2**17: k * PIO2_1 is exact in the
#: fused product and x - k PIO2_1 needs no more than 53 bits); beyond, the C library
REDUCE_BOUND = 1.0e5


@njit(cache=True, inline="always", fastmath=False, error_model="numpy")
def _sincos_reduced(x):
    """``(sin x, cos x)`` for ``|x| < REDUCE_BOUND``, without branches."""
    kf = fma(x, INV_PIO2, TO_INT)
    quadrant = as_bits(kf) & 3
    k = kf - TO_INT
    r = fma(-k, PIO2_1, x)
    r = fma(-k, PIO2_2, r)
    r = fma(-k, PIO2_3, r)
    z = r * r
    # the polynomials by Estrin's scheme (pairs, then powers z^2): three dependent multiply-adds
    # instead of Horner's five, and the stage's next step waits on this latency
    z2 = z * z
    poly_s = fma(z2, fma(z2, fma(z, S6, S5), fma(z, S4, S3)), fma(z, S2, S1))
    sin_r = fma(z * r, poly_s, r)
    poly_c = fma(z2, fma(z2, fma(z, C6, C5), fma(z, C4, C3)), fma(z, C2, C1))
    half_z = 0.5 * z
    w = 1.0 - half_z
    # fdlibm's cos form: 1 - z/2 rounded, plus what that rounding lost, plus the tail z^2 poly
    cos_r = w + fma(z2, poly_c, (1.0 - w) - half_z)
    # x = k pi/2 + r: odd quadrants swap sine and cosine; the sign bits follow k mod 4
    odd = (quadrant & 1) == 1
    s = cos_r if odd else sin_r
    c = sin_r if odd else cos_r
    s = from_bits(as_bits(s) ^ ((quadrant & 2) << 62))
    c = from_bits(as_bits(c) ^ (((quadrant + 1) & 2) << 62))
    # sin x rounds to x below 2**-27; taking x keeps the sign of zero (sin -0 = -0), which
    # the polynomial loses (a select, not a branch)
    s = x if abs(x) < TINY else s
    return s, c


@njit(cache=True, inline="always", fastmath=False, error_model="numpy")
def _sincos_real(x):
    """``(sin x, cos x)`` of a float: reduced here, or by the C library beyond the bound."""
    if abs(x) < REDUCE_BOUND:  # false for inf and nan too
        return _sincos_reduced(x)
    return math.sin(x), math.cos(x)


def sincos(x):
    """``(sin x, cos x)`` of one angle [rad]; for compiled code (see the module docstring)."""
    return np.sin(x), np.cos(x)


@overload(sincos, jit_options={"forceinline": True, "fastmath": False, "error_model": "numpy",
                                **OVERLOAD_OPTIONS})
def _ol_sincos(x):
    if isinstance(x, types.Complex):
        return lambda x: (np.sin(x), np.cos(x))
    if isinstance(x, (types.Float, types.Integer)):
        return lambda x: _sincos_real(float(x))
    return None


@njit(cache=True, error_model="numpy")
def sincos_array(x, s, c):
    """:func:`sincos` elementwise: ``s[i], c[i] = sin x[i], cos x[i]`` (tests, Python use)."""
    for i in range(x.size):
        s[i], c[i] = sincos(x[i])
