"""``monkeystudy bench``'s arithmetic (the timings themselves are not tested: no wall clocks)."""
import numpy as np
import pytest

from monkeystudy.bench import cost_split


def test_cost_split_recovers_fixed_and_marginal_cost():
    nfev = np.array([284.0, 442.0, 674.0, 1042.0])
    fixed, marginal = 7.2e-6, 41.3e-9
    got = cost_split(nfev, fixed + marginal * nfev)
    assert got == pytest.approx((fixed, marginal), rel=1e-10)


def test_cost_split_is_the_least_squares_line():
    rng = np.random.default_rng(3)
    nfev = np.array([281.0, 599.0, 1356.0])
    seconds = 5e-6 + 50e-9 * nfev + rng.normal(0.0, 1e-7, 3)
    fixed, marginal = cost_split(nfev, seconds)
    residual = seconds - (fixed + marginal * nfev)
    # normal equations: the residual is orthogonal to both columns
    assert abs(residual.sum()) < 1e-15
    assert abs((residual * nfev).sum()) < 1e-12


def test_sincos_chains_compute_the_same_recurrence():
    """The bench's two sine-and-cosine chains differ only in whose sines they use: the same
    recurrence, the same result to round-off (so their times compare like with like)."""
    from monkeystudy.bench import _sincos_chain_kernel, _sincos_chain_libm

    a = _sincos_chain_kernel(2000, 0.3, 2.6)
    b = _sincos_chain_libm(2000, 0.3, 2.6)
    assert a == pytest.approx(b, rel=1e-12)
    assert a != _sincos_chain_kernel(2001, 0.3, 2.6)
