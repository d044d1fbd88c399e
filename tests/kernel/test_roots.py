"""``x ** (-1/16)`` of the step-size controller (:mod:`monkeystudy.kernel.roots`) against
120-bit values, at the arguments a controller sees and across the whole double range."""
import math

import mpmath
import numpy as np
import pytest
from numba import njit

from monkeystudy.kernel import roots

#: table entry (0.5 ulp) plus the final multiply-add (0.5 ulp) plus the series' rounding
#: (relative ~1e-3 ulp): measured 1.02 at worst
MAX_ULP = 1.1


@njit(cache=True)
def _inv_root16_array(x, out):
    for i in range(x.size):
        out[i] = roots.inv_root16(x[i])


def _ulp_errors(x):
    got = np.empty_like(x)
    _inv_root16_array(x, got)
    mpmath.mp.prec = 120
    err = np.empty(x.size)
    for i, (xi, gi) in enumerate(zip(x, got)):
        ref = mpmath.power(mpmath.mpf(float(xi)), mpmath.mpf(-1) / 16)
        err[i] = float(abs(mpmath.mpf(float(gi)) - ref)) / np.spacing(float(ref))
    return err


def test_within_an_ulp_and_a_tenth():
    rng = np.random.default_rng(11)
    # every bucket and exponent residue: squared norms of accepted steps lie in (0, 1), of
    # rejected ones above 1; plus the whole normal range
    x = np.concatenate([
        rng.uniform(0.0, 1.0, 6000), rng.uniform(1.0, 2.0, 3000),
        10.0 ** rng.uniform(-307, 308, 6000),
        np.ldexp(1.0 + (np.arange(64) + 0.5) / 64, np.arange(64) - 32),     # bucket centres
        np.ldexp(1.0 + np.arange(65) / 64, np.arange(65) % 16),             # bucket edges
        [np.nextafter(2.0, 0.0), np.nextafter(1.0, 0.0), 1.0, 2.0, 65536.0,
         np.finfo(float).max, np.finfo(float).tiny],
    ])
    err = _ulp_errors(x[x > 0.0])
    assert err.max() <= MAX_ULP, (err.max(), x[x > 0.0][err.argmax()])


def test_exact_at_powers_of_two_to_the_sixteenth():
    # (2^(16 q))^(-1/16) = 2^-q: the table's j = 0 column and an empty series
    x = np.array([2.0 ** (16 * q) for q in range(-60, 61)])
    got = np.empty_like(x)
    _inv_root16_array(x, got)
    assert np.array_equal(got, [2.0 ** -q for q in range(-60, 61)])


def test_special_values():
    x = np.array([0.0, -0.0, math.inf, math.nan, -1.0, -math.inf, 5e-324, 1e-310])
    got = np.empty_like(x)
    _inv_root16_array(x, got)
    assert got[0] == math.inf and got[1] == math.inf
    assert got[2] == 0.0
    assert np.isnan(got[3:6]).all()
    # subnormals, by the scaled path
    for xi, gi in zip(x[6:], got[6:]):
        assert gi == pytest.approx(xi ** (-1.0 / 16.0), rel=4e-16)


def test_tables_are_the_exact_values_rounded_once():
    mpmath.mp.prec = 120
    for j in (0, 1, 7, 15):
        for i in (0, 13, 63):
            inv = roots.INV_CENTRE[i]
            exact = mpmath.power(2, mpmath.mpf(-j) / 16) * mpmath.power(mpmath.mpf(inv),
                                                                         mpmath.mpf(1) / 16)
            assert roots.ROOT_TABLE[j * roots.N_BUCKETS + i] == float(exact)
        # the bucket's reciprocal centre keeps r = m / c - 1 within 2^-7
        assert abs(1.0 / roots.INV_CENTRE[i] - (1.0 + (i + 0.5) / 64)) < 1e-15
