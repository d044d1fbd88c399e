"""The kernel's intrinsics (:mod:`monkeystudy.kernel.intrinsics`): vector row combinations
against an exact scalar evaluation of the same sums."""
import numpy as np
import pytest
from numba import njit
from numba.core.errors import TypingError

from monkeystudy.kernel.intrinsics import combine_rows4, combine_rows8, fma

ROWS = (0, 5, 6, 7, 8, 9, 10, 11)
#: DOP853's fifth-order error weights: large, of both signs, summing to almost nothing
COEFS = (0.01312004499419488, -1.2251564463762044, -0.4957589496572502, 1.6643771824549864,
         -0.35032884874997366, 0.3341791187130175, 0.08192320648511571, -0.022355307863886294)


@njit
def _combine4(K):
    return combine_rows4(K, (0, 5, 6, 7, 8, 9, 10, 11),
                         (0.01312004499419488, -1.2251564463762044, -0.4957589496572502,
                          1.6643771824549864, -0.35032884874997366, 0.3341791187130175,
                          0.08192320648511571, -0.022355307863886294))


@njit
def _combine8(K, rows, coefs):
    return combine_rows8(K, rows, coefs)


@njit
def _combine4_runtime(K, rows, coefs):
    return combine_rows4(K, rows, coefs)


def _chain(K, rows, coefs, i):
    """The compiled sum's roundings: a product, then one multiply-add per further row."""
    acc = coefs[0] * K[rows[0], i]
    for r, c in zip(rows[1:], coefs[1:]):
        acc = fma(c, K[r, i], acc)
    return acc


def _stages(shape, seed):
    rng = np.random.default_rng(seed)
    return rng.standard_normal(shape) * 10.0 ** rng.uniform(-3, 3, shape)


def test_four_wide_is_a_product_then_multiply_adds_in_row_order():
    for seed in range(20):
        K = _stages((26, 8), seed)
        got = _combine4(K)
        assert got == tuple(_chain(K, ROWS, COEFS, i) for i in range(4))


def test_eight_wide_runtime_rows_and_an_odd_row_stride():
    # rows out of order and repeated, a row length (13) that is not the vector width, and a
    # view starting three rows in: the row stride and the data pointer come from the array
    base = _stages((30, 13), 7)
    K = base[3:]
    rows = (4, 0, 4, 19, 2)
    coefs = (0.5, -3.25, 1e-3, 7.0, -0.125)
    got = _combine8(K, rows, coefs)
    assert got == tuple(_chain(K, rows, coefs, i) for i in range(8))
    assert _combine4_runtime(K, (1,), (2.0,)) == tuple(2.0 * K[1, :4])


def test_interpreted_sums_agree_to_rounding():
    # the pure-Python path (NUMBA_DISABLE_JIT) rounds each product and sum: within a few
    # roundings of the terms' magnitude
    for seed in range(20):
        K = _stages((26, 8), 100 + seed)
        interpreted = np.array(combine_rows8(K, ROWS, COEFS))
        exact = np.array([_chain(K, ROWS, COEFS, i) for i in range(8)])
        scale = np.abs(np.array(COEFS)) @ np.abs(K[list(ROWS), :8])
        assert np.all(np.abs(interpreted - exact) <= 8 * np.finfo(float).eps * scale)


def test_strided_rows_are_a_typing_error():
    K = _stages((26, 16), 3)[:, ::2]  # not C-contiguous: a row is not one vector load
    with pytest.raises(TypingError):
        _combine4_runtime(K, (0, 1), (1.0, 2.0))
