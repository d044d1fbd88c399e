"""Counter-based random numbers (compiled): the same draw for the same key, in any process.

Noise in a survival run must not depend on which worker runs it, in what order, or whether
the run was resumed. A counter-based generator gives that by construction: a draw is a pure
function of its key. Here the key is ``(seed, run, cycle, slot)`` and the function is
Philox4x32-10 (Salmon, Moraes, Dror & Shaw, "Parallel random numbers: as easy as 1, 2, 3",
SC 2011; the generator of Random123, cuRAND and numpy's ``Philox`` family), checked against
Random123's known-answer vectors in the tests.

Layout of a draw: the 64-bit ``seed`` is Philox's key; the counter is ``(run, cycle, slot,
0)`` as unsigned 32-bit words. One call gives 128 random bits: two uniform doubles with 53
random bits each, or two independent standard normals (Box-Muller).
"""
import math

import numpy as np

from .jit import njit

MASK32 = 0xFFFFFFFF
PHILOX_M0 = 0xD2511F53
PHILOX_M1 = 0xCD9E8D57
PHILOX_W0 = 0x9E3779B9   # the key schedule's Weyl increments (golden ratio, sqrt(3) - 1)
PHILOX_W1 = 0xBB67AE85
PHILOX_ROUNDS = 10
TWO_PI = 2.0 * math.pi
INV_2_53 = 1.0 / 9007199254740992.0

#: the cycle word of the draws made once per run (initial state, robot parameters)
PER_RUN_CYCLE = MASK32


@njit(cache=True, error_model="numpy", _nrt=False)
def philox4x32(c0, c1, c2, c3, k0, k1):
    """Philox4x32-10 of counter ``(c0, c1, c2, c3)`` under key ``(k0, k1)``.

    All arguments and the four returned words are unsigned 32-bit values held in int64.
    """
    # unsigned 64-bit arithmetic throughout: a 32 x 32-bit product is exact in it (numba
    # would turn a mix of signed and unsigned operands into floats)
    m = np.uint64(MASK32)
    x0 = np.uint64(c0) & m
    x1 = np.uint64(c1) & m
    x2 = np.uint64(c2) & m
    x3 = np.uint64(c3) & m
    y0 = np.uint64(k0) & m
    y1 = np.uint64(k1) & m
    for r in range(PHILOX_ROUNDS):
        if r > 0:
            y0 = (y0 + np.uint64(PHILOX_W0)) & m
            y1 = (y1 + np.uint64(PHILOX_W1)) & m
        p0 = np.uint64(PHILOX_M0) * x0
        p1 = np.uint64(PHILOX_M1) * x2
        hi0 = p0 >> np.uint64(32)
        hi1 = p1 >> np.uint64(32)
        x0, x1, x2, x3 = hi1 ^ x1 ^ y0, p1 & m, hi0 ^ x3 ^ y1, p0 & m
    return np.int64(x0), np.int64(x1), np.int64(x2), np.int64(x3)


@njit(cache=True, error_model="numpy", _nrt=False)
def uniform_pair(seed, run, cycle, slot):
    """Two independent uniform doubles in [0, 1) for key ``(seed, run, cycle, slot)``."""
    w0, w1, w2, w3 = philox4x32(run, cycle, slot, 0, seed & MASK32, (seed >> 32) & MASK32)
    u = ((w0 >> 5) * 67108864 + (w1 >> 6)) * INV_2_53
    v = ((w2 >> 5) * 67108864 + (w3 >> 6)) * INV_2_53
    return u, v


@njit(cache=True, error_model="numpy", _nrt=False)
def normal_pair(seed, run, cycle, slot):
    """Two independent standard normal draws for key ``(seed, run, cycle, slot)``
    (Box-Muller on :func:`uniform_pair`)."""
    u, v = uniform_pair(seed, run, cycle, slot)
    radius = math.sqrt(-2.0 * math.log(1.0 - u))   # 1 - u in (0, 1]: the log is finite
    return radius * math.cos(TWO_PI * v), radius * math.sin(TWO_PI * v)


@njit(cache=True, error_model="numpy", _nrt=False)
def standard_draw(seed, run, cycle, slot, uniform):
    """One draw of unit scale for a key: a standard normal, or (``uniform``) a uniform on
    [-1, 1). Each key's other half is left unused, so every draw has its own key."""
    if uniform:
        u, _ = uniform_pair(seed, run, cycle, slot)
        return 2.0 * u - 1.0
    z, _ = normal_pair(seed, run, cycle, slot)
    return z

