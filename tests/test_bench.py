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
