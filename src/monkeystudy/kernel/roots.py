"""``x ** (-1/16)`` for the step-size controller (compiled).

DOP853's controller scales the step by ``SAFETY * en ** (-1/8)`` after every attempted step, and
the next step cannot start before that factor is known: its latency is paid once per step.
``pow`` is a library call, and ``1 / sqrt(sqrt(sqrt(en)))`` after a norm that ends in its own
square root and division is a dependent chain of four square roots and two divisions. Taking
the power of the *squared* norm, ``en ** (-1/8) = (en ** 2) ** (-1/16)``, spares the norm's
square root, and :func:`inv_root16` evaluates the power in straight-line code (integer splits
of the bits, one table load, five dependent multiply-adds).

``x = 2**k m`` with ``k = 16 q + j`` (``0 <= j < 16``) and ``m`` in [1, 2); ``m = (1 + r) / c_i``
with ``1 / c_i`` the double nearest the reciprocal of the centre of ``m``'s bucket (64 buckets)
and ``r = m / c_i - 1`` computed exactly by a fused multiply-add (``|r| < 2**-7``). Then

    x ** (-1/16) = 2**-q * [2**(-j/16) (1/c_i) ** (1/16)] * (1 + r) ** (-1/16),

the bracket one table entry (16 x 64, each correctly rounded from 60-digit decimal values),
the last factor ``1 + r Q(r)`` with ``Q`` the binomial series to degree 6 (truncation
< 2e-17 relative), added to the table entry in one final multiply-add so that the value near 1
is never rounded on its own. Measured against 120-bit values: within 1.02 ulp
(``tests/kernel/test_roots.py``); scipy's ``en ** (-1/8)`` of the rounded ``en`` is within
0.5 ulp of its own exact value, so the two controllers' factors agree to ~2 ulp and their steps
to ~1e-16 relative.

Zero and subnormal arguments, infinity, negative numbers and NaN take a separate branch (never
on a gait's path; the branch is predicted and costs no latency): ``inf``, a scaled evaluation,
``0`` and NaN.
"""
from decimal import Decimal, localcontext
from fractions import Fraction

import numpy as np

from .intrinsics import as_bits, fma, from_bits
from .jit import njit

#: mantissa buckets: ``2 ** BUCKET_BITS``
BUCKET_BITS = 6
N_BUCKETS = 1 << BUCKET_BITS
#: degree of the series of ``(1 + r) ** (-1/16)``
SERIES_DEGREE = 6
MIN_NORMAL = 2.2250738585072014e-308
#: subnormal arguments are scaled by 2**64 (the root by 2**-4)
SUBNORMAL_SCALE = 18446744073709551616.0


def _tables():
    """``(inverse centres, root table, series coefficients)``, computed exactly.

    The table entries are ``2**(-j/16) * inv_i**(1/16)`` for the *stored* double ``inv_i``
    (so that ``m inv_i = 1 + r`` exactly, the entry is the exact root of what was divided
    out), evaluated to 60 significant digits and rounded once to double.
    """
    inv = np.array([1.0 / (1.0 + (i + 0.5) / N_BUCKETS) for i in range(N_BUCKETS)])
    table = np.empty(16 * N_BUCKETS)
    with localcontext() as ctx:
        ctx.prec = 60
        sixteenth = Decimal(1) / 16
        for j in range(16):
            two_j = Decimal(2) ** (-Decimal(j) / 16)
            for i in range(N_BUCKETS):
                exact = Fraction(float(inv[i]))
                inv_dec = Decimal(exact.numerator) / Decimal(exact.denominator)
                table[j * N_BUCKETS + i] = float(two_j * inv_dec ** sixteenth)
    # binomial series (1 + r)^a = sum_k C(a, k) r^k, a = -1/16; Q(r) = sum_{k>=1} C(a, k) r^(k-1)
    coeffs = []
    c = Fraction(1)
    a = Fraction(-1, 16)
    for k in range(SERIES_DEGREE):
        c = c * (a - k) / (k + 1)
        coeffs.append(float(c))
    return inv, table, tuple(coeffs)


INV_CENTRE, ROOT_TABLE, _Q = _tables()
Q0, Q1, Q2, Q3, Q4, Q5 = _Q


@njit(cache=True, forceinline=True, error_model="numpy", _nrt=False)
def _inv_root16_normal(x):
    """``x ** (-1/16)`` for a positive normal double ``x`` (no special cases)."""
    b = as_bits(x)
    k = (b >> 52) - 1023
    q = k >> 4          # floor(k / 16): k = 16 q + j
    j = k & 15
    i = (b >> (52 - BUCKET_BITS)) & (N_BUCKETS - 1)
    m = from_bits((b & 0x000FFFFFFFFFFFFF) | 0x3FF0000000000000)
    r = fma(m, INV_CENTRE[i], -1.0)
    # 2**-q has the biased exponent 1023 - q (|q| <= 64: always normal)
    t = ROOT_TABLE[j * N_BUCKETS + i] * from_bits((1023 - q) << 52)
    tr = t * r
    # Q(r) by Estrin's scheme: three dependent multiply-adds after r^2 and r^4
    r2 = r * r
    r4 = r2 * r2
    qr = fma(r2, fma(Q3, r, Q2), fma(Q1, r, Q0))
    qr = fma(r4, fma(Q5, r, Q4), qr)
    return fma(tr, qr, t)


@njit(cache=True, error_model="numpy")
def _inv_root16_special(x):
    if x != x or x < 0.0:
        return np.nan
    if x == 0.0:
        return np.inf
    if x == np.inf:
        return 0.0
    # subnormal: (x 2^64)^(-1/16) = x^(-1/16) 2^-4
    return _inv_root16_normal(x * SUBNORMAL_SCALE) * 16.0


@njit(cache=True, forceinline=True, error_model="numpy", _nrt=False)
def inv_root16(x):
    """``x ** (-1/16)`` within ~1 ulp (see the module docstring); ``inf`` at 0, ``0`` at
    ``inf``, NaN for NaN and negative ``x``."""
    if MIN_NORMAL <= x < np.inf:
        return _inv_root16_normal(x)
    return _inv_root16_special(x)
