"""Verner's 9(8) pair ("vern9", ``kernel/tableaux.py``): the transcribed coefficients satisfy
every order condition, the generated step converges with order 9 and its interpolant with
order 9, and whole gaits agree with scipy's DOP853 at tight tolerance (event times included:
events are located on the 9th-order interpolant).

Order conditions are checked on all rooted trees (486 up to order 9): ``b . Phi(t) = 1 /
gamma(t)``, with ``Phi`` the elementary weights built from ``A`` (Butcher's B-series theory).
"""
import numpy as np
import pytest

from monkeystudy import Integrator, evaluate_horizontal_gait
from monkeystudy.kernel import dynamics as dyn
from monkeystudy.kernel import tableaux as tb
from monkeystudy.kernel.integrate import dense_eval, dense_prepare, rk_step
from monkeystudy.kernel.layout import METHOD_DOP853, METHOD_VERN9, PHASE_SWING

from .helpers import ROBOTS

FM = np.array([1.0, 1.0])
SEED = ROBOTS["seed2009"].params()[0]


# ----------------------------------------------------------------------------------------------
# order conditions
# ----------------------------------------------------------------------------------------------
def _trees(max_order):
    """Rooted trees by order, each a sorted tuple of its subtrees (a leaf is ``()``)."""
    def grow(t):
        out = [tuple(sorted(t + ((),)))]
        for k, sub in enumerate(t):
            for g in grow(sub):
                out.append(tuple(sorted(t[:k] + (g,) + t[k + 1:])))
        return out
    by = {1: [()]}
    for n in range(2, max_order + 1):
        by[n] = sorted({g for t in by[n - 1] for g in grow(t)})
    return by


def _gamma(t):
    order = 1 + sum(_order(s) for s in t)
    g = order
    for s in t:
        g *= _gamma(s)
    return g


def _order(t):
    return 1 + sum(_order(s) for s in t)


def _phi(t, A):
    """Stage vector of elementary weights of tree ``t``: prod over subtrees of ``A Phi(s)``."""
    v = np.ones(A.shape[0])
    for s in t:
        v = v * (A @ _phi(s, A))
    return v


TREES = _trees(10)


def test_tree_counts():
    assert [len(TREES[n]) for n in range(1, 11)] == [1, 1, 2, 4, 9, 20, 48, 115, 286, 719]


def test_nodes_are_row_sums():
    np.testing.assert_allclose(tb.VERN9_A.sum(axis=1), tb.VERN9_C, rtol=0, atol=1e-14)


def _residuals(b, A, order, theta=1.0):
    return np.array([b @ _phi(t, A) - theta ** n / _gamma(t)
                     for n in range(1, order + 1) for t in TREES[n]])


def test_weights_order_9_and_embedded_order_8():
    ns = tb.VERN9_N_STAGES
    A = tb.VERN9_A[:ns, :ns]
    b = tb.VERN9_B
    bhat = tb.VERN9_B - tb.VERN9_E
    assert np.abs(_residuals(b, A, 9)).max() <= 2e-15
    assert np.abs(_residuals(bhat, A, 8)).max() <= 2e-15
    # and not higher: the estimate is a genuine 8th-order one (its error is what is measured)
    order9 = np.array([bhat @ _phi(t, A) - 1.0 / _gamma(t) for t in TREES[9]])
    assert np.abs(order9).max() > 1e-6
    order10 = np.array([b @ _phi(t, A) - 1.0 / _gamma(t) for t in TREES[10]])
    assert np.abs(order10).max() > 1e-8


@pytest.mark.parametrize("theta", [0.1, 0.37, 0.5, 0.81, 1.0])
def test_interpolant_order_9(theta):
    """``b(theta) . Phi(t) = theta^|t| / gamma(t)`` for |t| <= 9 (coefficients up to ~1e4:
    the residuals are round-off of those sums)."""
    bt = tb.VERN9_R @ theta ** np.arange(1, tb.VERN9_INTERPOLATOR_POWER + 1)
    assert bt[tb.VERN9_N_STAGES - 1] == 0.0      # the error-estimate stage is not used
    assert np.abs(_residuals(bt, tb.VERN9_A, 9, theta)).max() <= 2e-11
    # stage 16 (row 16) is the new point: the step's weights
    np.testing.assert_array_equal(tb.VERN9_A[tb.VERN9_N_STAGES, :tb.VERN9_N_STAGES], tb.VERN9_B)


# ----------------------------------------------------------------------------------------------
# measured orders of the compiled step and interpolant
# ----------------------------------------------------------------------------------------------
def _arrays():
    return (np.zeros((tb.VERN9_N_STAGES_EXTENDED, 8)), np.zeros((9, 8)), np.zeros(8),
            np.zeros(8), np.zeros(8), np.zeros(8), np.zeros(8))


def _fixed_steps(method, y0, T, N):
    K, Fd, y, f, ytmp, ynew, fnew = _arrays()
    y[:4] = y0
    dyn.rhs(PHASE_SWING, SEED, 0.0, FM, y, f)
    h = T / N
    for _ in range(N):
        rk_step(method, PHASE_SWING, SEED, 0.0, FM, y, f, h, 4, K, ytmp, ynew, fnew)
        y[:] = ynew
        f[:] = fnew
    return y[:4].copy()


def _slope(hs, errs):
    return np.polyfit(np.log(hs), np.log(errs), 1)[0]


def test_global_convergence_order_9():
    y0 = np.array([0.0, 0.0, 3.0, 8.0])
    T = 0.5
    Ns = np.array([6, 7, 8, 10, 12, 14])
    exact = _fixed_steps(METHOD_DOP853, y0, T, 4000)   # DOP853 error ~1e-15 here
    errs = np.array([np.max(np.abs(_fixed_steps(METHOD_VERN9, y0, T, N) - exact)) for N in Ns])
    hs = T / Ns
    assert errs.min() > 1e-12, errs    # above round-off and the reference's error
    slope = _slope(hs, errs)
    assert abs(slope - 9) <= 0.3, (slope, np.diff(np.log(errs)) / np.diff(np.log(hs)), errs)


def _dense_error(y0, h, x):
    K, Fd, y, f, ytmp, ynew, fnew = _arrays()
    y[:4] = y0
    dyn.rhs(PHASE_SWING, SEED, 0.0, FM, y, f)
    rk_step(METHOD_VERN9, PHASE_SWING, SEED, 0.0, FM, y, f, h, 4, K, ytmp, ynew, fnew)
    assert dense_prepare(METHOD_VERN9, PHASE_SWING, SEED, 0.0, FM, 0.0, h, y, ynew, fnew, 4, K,
                         Fd, ytmp) == 9
    out = np.empty(8)
    dense_eval(METHOD_VERN9, Fd, y, h, x, 4, out)
    exact = _fixed_steps(METHOD_DOP853, y0, x * h, 200)
    return np.max(np.abs(out[:4] - exact))


@pytest.mark.parametrize("x", [0.3, 0.5, 0.7])
def test_dense_output_order_9(x):
    """Local error of the interpolant after one step: O(h^10) at least.

    The steps span errors from ~1e-6 to ~1e-11 (larger ones are pre-asymptotic, smaller ones
    reach round-off). The local slopes read 10-11 there rather than settling at 10: Verner's
    interpolant has small leading (h^10) error coefficients, so h^11 terms still weigh in. A
    lower-order interpolant would read 9 or less.
    """
    y0 = np.array([0.0, 0.0, 1.0, 1.0])
    hs = 0.6 * 2.0 ** -np.arange(1.0, 2.51, 0.25)
    errs = np.array([_dense_error(y0, h, x) for h in hs])
    assert errs.min() > 1e-13, errs
    slope = _slope(hs, errs)
    assert 9.7 <= slope <= 11.5, (slope, np.diff(np.log(errs)) / np.diff(np.log(hs)), errs)


def test_dense_output_ends_on_the_step():
    K, Fd, y, f, ytmp, ynew, fnew = _arrays()
    y[:4] = [0.3, -0.4, 2.0, 7.0]
    dyn.rhs(PHASE_SWING, SEED, 0.0, FM, y, f)
    h = 0.05
    rk_step(METHOD_VERN9, PHASE_SWING, SEED, 0.0, FM, y, f, h, 4, K, ytmp, ynew, fnew)
    dense_prepare(METHOD_VERN9, PHASE_SWING, SEED, 0.0, FM, 0.0, h, y, ynew, fnew, 4, K, Fd, ytmp)
    out = np.empty(8)
    dense_eval(METHOD_VERN9, Fd, y, h, 0.0, 4, out)
    np.testing.assert_array_equal(out[:4], y[:4])
    dense_eval(METHOD_VERN9, Fd, y, h, 1.0, 4, out)
    np.testing.assert_allclose(out[:4], ynew[:4], rtol=0, atol=1e-13)


# ----------------------------------------------------------------------------------------------
# whole gaits beside scipy
# ----------------------------------------------------------------------------------------------
@pytest.mark.parametrize("d1,d2", [(0.902, 10.935), (1.2, 11.3), (1.0, 11.0)])
def test_gait_agrees_with_scipy_dop853(d1, d2):
    """Vern9 at rtol 1e-12 against scipy's DOP853 at 1e-13 (a different method and code):
    event times located on the interpolant agree to the tolerances' level."""
    from monkeystudy.reference.scipy_gait import ScipyGait
    from monkeystudy.robot import SEED2009_TORQUE, Robot

    ref = ScipyGait(Robot.preset("seed2009"), SEED2009_TORQUE).gait(d1, d2, 1e-13, 1e-13)
    for rtol, tol_t, tol_e in ((1e-12, 2e-11, 1e-9), (1e-10, 2e-9, 1e-7)):
        k = evaluate_horizontal_gait(d1, d2, integrator=Integrator("vern9", rtol, rtol * 1e-2))
        assert k.status == 0
        assert k.t_switch == pytest.approx(ref[1], abs=tol_t)
        assert k.t_motor == pytest.approx(ref[2], abs=tol_t)
        assert k.t_end == pytest.approx(ref[3], abs=tol_t)
        assert k.error == pytest.approx(ref[0], abs=tol_e * (1 + abs(ref[0])))
