"""The embedded Runge-Kutta integrator (``kernel/integrate.py``) against scipy and theory.

* Every step of a scipy ``RK45``/``DOP853`` solve is recomputed with the kernel's one-step
  primitives from the same ``(t_old, y_old, h)``: stages, new state, error norm, initial step
  and dense output agree to round-off (the kernel's straight-line steps may contract
  multiply-adds, so not bit for bit).
* A whole unforced segment run by the hybrid loop takes exactly the steps ``solve_ivp`` takes
  with the same vector field: same accepted steps and the same number of evaluations.
* Orders: global error of fixed-step integration ~ h^5 (RK45) and h^8 (DOP853); local error of
  the dense output ~ h^5 (RK45's 4th-order interpolant) and h^8 (DOP853's 7th-order one).
"""
import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.integrate._ivp import rk
from scipy.integrate._ivp.common import select_initial_step as scipy_initial_step

from monkeystudy import Integrator, PhaseSequence, Segment, initial_state, run_controller
from monkeystudy.kernel import dynamics as dyn
from monkeystudy.kernel.integrate import (
    dense_eval, dense_prepare, error_norm, rk_step, select_initial_step,
)
from monkeystudy.kernel.layout import (
    K_NFEV, K_REJECTED, K_STEPS, METHOD_DOP853, METHOD_RK45, PHASE_FLIGHT, PHASE_SWING,
    ST_END_TIME,
)

from .helpers import ROBOTS

pytestmark = pytest.mark.nojit

METHODS = {"RK45": (METHOD_RK45, rk.RK45, "rk45", 6),
           "DOP853": (METHOD_DOP853, rk.DOP853, "dop853", 12)}
FM = np.array([1.0, 1.0])
EPS = np.finfo(float).eps


def _arrays():
    return (np.zeros((16, 8)), np.zeros((7, 8)), np.zeros(8), np.zeros(8), np.zeros(8),
            np.zeros(8), np.zeros(8))


def _fun(phase, p, tau=0.0):
    n = 4 if phase == PHASE_SWING else 8

    def f(t, y):
        dy = np.empty(n)
        dyn.rhs(phase, p, tau, FM, np.asarray(y, float), dy)
        return dy
    return f


CASES = [  # (phase, robot, packed start, duration)
    (PHASE_SWING, "seed2009", [0.0, 0.0, 1.0, 6.0], 3.0),
    (PHASE_SWING, "uniform_rod", [0.3, -0.2, 4.0, -9.0], 4.0),
    (PHASE_SWING, "asymmetric", [0.0, 0.0, 0.2, 0.1], 2.0),
    (PHASE_FLIGHT, "asymmetric", [0.0, 0.0, 0.4, 0.9, 0.5, 1.0, 3.0, -4.0], 1.5),
]


# ----------------------------------------------------------------------------------------------
# step by step beside scipy
# ----------------------------------------------------------------------------------------------
@pytest.mark.parametrize("name", list(METHODS))
@pytest.mark.parametrize("case", CASES[::3], ids=["swing", "flight"])
def test_every_step_beside_scipy(name, case):
    method, solver_cls, _, ns = METHODS[name]
    phase, rname, y0, T = case
    p = ROBOTS[rname].params()[0]
    n = len(y0)
    fun = _fun(phase, p)
    rtol, atol = 1e-8, 1e-9
    solver = solver_cls(fun, 0.0, np.array(y0, float), T, rtol=rtol, atol=atol)
    # initial step, as scipy's select_initial_step
    K, Fd, y, f, ytmp, ynew, fnew = _arrays()
    y[:n] = y0
    dyn.rhs(phase, p, 0.0, FM, y, f)
    h0 = select_initial_step(phase, p, 0.0, FM, 0.0, y, f, n, T, np.inf,
                             solver_cls.error_estimator_order, rtol, atol, ytmp, fnew)
    assert h0 == pytest.approx(solver.h_abs, rel=1e-14)
    steps = 0
    while solver.status == "running":
        solver.step()
        steps += 1
        t_old, y_old, t_new = solver.t_old, solver.y_old, solver.t
        h = t_new - t_old
        K, Fd, y, f, ytmp, ynew, fnew = _arrays()
        y[:n] = y_old
        f[:n] = solver.K[0]
        assert rk_step(method, phase, p, 0.0, FM, y, f, h, n, K, ytmp, ynew, fnew) == ns
        # norm-wise round-off agreement: the stages are evaluated at arguments that differ in
        # the last bits (multiply-add contraction), and DOP853's weights amplify that
        scale = np.max(np.abs(y_old) + abs(h) * np.abs(solver.B) @ np.abs(solver.K[:ns]))
        assert np.max(np.abs(ynew[:n] - solver.y)) <= 1e-13 * scale
        np.testing.assert_allclose(K[:ns + 1, :n], solver.K,
                                   rtol=1e-13, atol=1e-13 * np.abs(solver.K).max())
        # the error norm of the accepted step (below 1), as scipy's _estimate_error_norm, on
        # scipy's stages (the estimate is a small difference of stage sums: on our own stages,
        # equal to 1e-13, it may differ in the 5th digit, which the step counts below show
        # is harmless)
        sc = atol + np.maximum(np.abs(y_old), np.abs(solver.y)) * rtol
        want = solver._estimate_error_norm(solver.K, h, sc)
        Ks = np.zeros((16, 8))
        Ks[:ns + 1, :n] = solver.K
        ys = np.zeros(8)
        ys[:n] = solver.y
        got = error_norm(method, Ks, h, y, ys, n, rtol, atol)
        # round-off of the estimate: its sums sum_j E_j K_j cancel, each to ~eps sum_j |E_j K_j|
        bound = 0.0
        for E in ((solver.E,) if ns == 6 else (solver.E5, solver.E3)):
            bound = max(bound, np.sqrt(np.mean((abs(h) * (np.abs(E) @ np.abs(solver.K)) / sc)**2)))
        assert abs(got - want) <= 32 * EPS * bound, (got, want, bound)
        assert got < 1.0
        # dense output on the step
        dense_prepare(method, phase, p, 0.0, FM, t_old, h, y, ynew, fnew, n, K, Fd, ytmp)
        interp = solver.dense_output()
        for x in (0.0, 0.25, 0.5, 0.9, 1.0):
            out = np.empty(8)
            dense_eval(method, Fd, y, h, x, n, out)
            np.testing.assert_allclose(out[:n], interp(t_old + x * h), rtol=0,
                                       atol=1e-14 * np.max(scale))
    assert solver.status == "finished" and steps > 5


def test_error_norm_is_scipy_on_random_stages():
    """Random stage matrices (the error norm is pure arithmetic on them)."""
    rng = np.random.default_rng(31)
    for name, (method, solver_cls, _, ns) in METHODS.items():
        s = solver_cls(lambda t, y: -y, 0.0, np.ones(8), 1.0)
        for _ in range(50):
            n = rng.choice([4, 8])
            K = np.zeros((16, 8))
            K[:ns + 1, :n] = rng.normal(size=(ns + 1, n)) * 10.0 ** rng.uniform(-3, 3)
            y = rng.normal(size=8)
            ynew = y + rng.normal(size=8) * 1e-3
            h = 10.0 ** rng.uniform(-4, 0)
            rtol, atol = 10.0 ** rng.uniform(-12, -4), 10.0 ** rng.uniform(-12, -4)
            sc = atol + np.maximum(np.abs(y[:n]), np.abs(ynew[:n])) * rtol
            want = s._estimate_error_norm(K[:ns + 1, :n], h, sc)
            got = error_norm(method, K, h, y, ynew, n, rtol, atol)
            assert got == pytest.approx(want, rel=1e-13)


def test_initial_step_is_scipy():
    rng = np.random.default_rng(32)
    for i in range(40):
        phase = PHASE_SWING if i % 2 else PHASE_FLIGHT
        n = 4 if phase == PHASE_SWING else 8
        p = list(ROBOTS.values())[i % 3].params()[0]
        y = np.zeros(8)
        y[:n] = rng.normal(size=n) * 3
        f = np.zeros(8)
        dyn.rhs(phase, p, 0.0, FM, y, f)
        for name, (method, solver_cls, _, _) in METHODS.items():
            order = solver_cls.error_estimator_order
            rtol, atol = 10.0 ** rng.uniform(-13, -3), 10.0 ** rng.uniform(-13, -3)
            t_bound = rng.uniform(0.01, 5.0)
            max_step = rng.choice([np.inf, rng.uniform(1e-3, 1.0)])
            got = select_initial_step(phase, p, 0.0, FM, 0.0, y, f, n, t_bound, max_step, order,
                                      rtol, atol, np.zeros(8), np.zeros(8))
            want = scipy_initial_step(_fun(phase, p), 0.0, y[:n], t_bound, max_step, f[:n],
                                      1.0, order, rtol, atol)
            assert got == pytest.approx(want, rel=1e-13)


# ----------------------------------------------------------------------------------------------
# whole segments: the hybrid loop takes solve_ivp's steps
# ----------------------------------------------------------------------------------------------
@pytest.mark.parametrize("name", list(METHODS))
@pytest.mark.parametrize("rtol", [1e-6, 1e-9, 1e-12])
@pytest.mark.parametrize("case", CASES, ids=["seed", "rod", "asym", "flight"])
@pytest.mark.parametrize("max_step", [np.inf, 0.05])
def test_segment_step_count_equals_solve_ivp(name, rtol, case, max_step):
    method, _, mname, ns = METHODS[name]
    phase, rname, y0, T = case
    robot = ROBOTS[rname]
    p = robot.params()[0]
    sol = solve_ivp(_fun(phase, p), (0.0, T), y0, method=name, rtol=rtol, atol=rtol,
                    max_step=max_step)
    if phase == PHASE_SWING:
        hyb = initial_state(y0[2], y0[3], theta1=y0[0], theta2=y0[1])
        prog = PhaseSequence([Segment("none")], observers=())
    else:
        hyb = initial_state(y0[6], y0[7], theta1=y0[2], theta2=y0[3])
        hyb[4:6] = y0[4:6]  # a swing state with a moving pivot: released into flight at once
        prog = PhaseSequence([Segment("none", magnets="none")], observers=())
    res = run_controller(prog, hyb, robot=robot, t_end=T,
                         integrator=Integrator(mname, rtol, rtol, max_time=2 * T,
                                               max_step=max_step))
    assert res.status == ST_END_TIME
    c = res.counts
    assert c[K_STEPS] == len(sol.t) - 1
    assert c[K_NFEV] == sol.nfev
    assert c[K_NFEV] == 2 + ns * (c[K_STEPS] + c[K_REJECTED])
    got = res.state[[2, 3, 6, 7]] if phase == PHASE_SWING else res.state[:8]
    np.testing.assert_allclose(got, sol.y[:, -1], rtol=1e-9, atol=1e-9)


# ----------------------------------------------------------------------------------------------
# convergence orders
# ----------------------------------------------------------------------------------------------
SEED = ROBOTS["seed2009"].params()[0]


def _fixed_steps(method, y0, T, N, p=SEED):
    K, Fd, y, f, ytmp, ynew, fnew = _arrays()
    y[:4] = y0
    dyn.rhs(PHASE_SWING, p, 0.0, FM, y, f)
    h = T / N
    for _ in range(N):
        rk_step(method, PHASE_SWING, p, 0.0, FM, y, f, h, 4, K, ytmp, ynew, fnew)
        y[:] = ynew
        f[:] = fnew
    return y[:4].copy()


def _slope(hs, errs):
    return np.polyfit(np.log(hs), np.log(errs), 1)[0]


# Each case: a smooth swing, and a range of N whose errors lie between the pre-asymptotic
# regime and round-off (found by looking at the local slopes; they are printed on failure).
ORDER_CASES = [
    ("RK45", 5, [0.0, 0.0, 1.5, 4.0], 1.0, [64, 91, 128, 181, 256, 362, 512]),
    ("RK45", 5, [0.0, 0.0, 1.0, 2.0], 1.0, [64, 91, 128, 181, 256, 362, 512]),
    ("DOP853", 8, [0.0, 0.0, 3.0, 8.0], 0.5, [11, 13, 16, 19, 23, 27]),
    ("DOP853", 8, [0.0, 0.0, 2.5, 3.0], 3.0, [45, 54, 64, 76, 91]),
]


@pytest.mark.parametrize("name,order,y0,T,Ns", ORDER_CASES)
def test_global_convergence_order(name, order, y0, T, Ns):
    method = METHODS[name][0]
    y0 = np.array(y0)
    exact = _fixed_steps(METHOD_DOP853, y0, T, 16 * Ns[-1])  # error ~ 16^-8 of the smallest
    errs = np.array([np.max(np.abs(_fixed_steps(method, y0, T, N) - exact)) for N in Ns])
    hs = T / np.array(Ns, float)
    assert errs.min() > 1e-13, errs   # above round-off
    slope = _slope(hs, errs)
    local = np.diff(np.log(errs)) / np.diff(np.log(hs))
    assert abs(slope - order) <= 0.3, (slope, local, errs)


def _dense_error(method, y0, h, x):
    K, Fd, y, f, ytmp, ynew, fnew = _arrays()
    y[:4] = y0
    dyn.rhs(PHASE_SWING, SEED, 0.0, FM, y, f)
    rk_step(method, PHASE_SWING, SEED, 0.0, FM, y, f, h, 4, K, ytmp, ynew, fnew)
    dense_prepare(method, PHASE_SWING, SEED, 0.0, FM, 0.0, h, y, ynew, fnew, 4, K, Fd, ytmp)
    out = np.empty(8)
    dense_eval(method, Fd, y, h, x, 4, out)
    exact = _fixed_steps(METHOD_DOP853, y0, x * h, 64)
    return np.max(np.abs(out[:4] - exact))


# Local error of the interpolant after one step from an exact state: O(h^(q+1)) for an
# interpolant of order q. The leading coefficient depends on the state and can nearly vanish:
# from theta = 0 (gravity terms zero) RK45's h^5 term is tiny and the slope reads ~6; from rest
# at an angle DOP853's h^8 term is tiny and it reads ~9. The cases below are states where the
# leading term is generic and the local slopes have settled (within 0.1 of q + 1).
DENSE_CASES = [
    ("RK45", 5, [1.0, -0.5, 0.0, 0.0], 0.25, 0.2 * 2.0 ** -np.arange(2.0, 5.01, 0.5)),
    ("RK45", 5, [1.0, -0.5, 0.0, 0.0], 0.75, 0.2 * 2.0 ** -np.arange(2.0, 5.01, 0.5)),
    ("RK45", 5, [2.0, 1.0, 1.0, 1.0], 0.5, 0.2 * 2.0 ** -np.arange(3.0, 5.01, 0.5)),
    ("DOP853", 8, [0.0, 0.0, 1.5, 4.0], 0.5, 0.2 * 2.0 ** -np.arange(1.5, 3.51, 0.5)),
    ("DOP853", 8, [0.0, 0.0, 1.5, 4.0], 0.8, 0.2 * 2.0 ** -np.arange(1.5, 3.51, 0.5)),
    ("DOP853", 8, [2.0, 1.0, 1.0, 1.0], 0.25, 0.4 * 2.0 ** -np.arange(2.0, 3.51, 0.5)),
]


@pytest.mark.parametrize("name,order,y0,x,hs", DENSE_CASES)
def test_dense_output_order(name, order, y0, x, hs):
    method = METHODS[name][0]
    errs = np.array([_dense_error(method, np.array(y0), h, x) for h in hs])
    assert errs.min() > 1e-13, errs
    slope = _slope(hs, errs)
    assert abs(slope - order) <= 0.3, (slope, np.diff(np.log(errs)) / np.diff(np.log(hs)))
