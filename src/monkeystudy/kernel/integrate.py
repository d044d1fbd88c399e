"""Embedded explicit Runge-Kutta steps with dense output (compiled).

The step-size controller, error norms and initial-step selection follow
``scipy.integrate._ivp.rk`` line for line (SAFETY 0.9, factors in [0.2, 10], the
``atol + rtol * max(|y|, |y_new|)`` scale, DOP853's combined 5th/3rd-order estimate), so that
for the same vector field our accepted steps coincide with ``solve_ivp``'s: the tests compare
them one by one (the default controller; :func:`pi_factor` is the opt-in PI controller).
Work arrays are preallocated by the caller; nothing here allocates.

Arrays: ``K`` is ``(16, 8)`` (DOP853 with its three extra dense-output stages; ``(26, 8)`` for
Vern9 with its ten), ``F`` the ``(7, 8)`` dense-output coefficients (``(9, 8)`` for Vern9);
only the first ``n`` columns are used (4 swing, 8 flight). Vern9 (Verner's 9(8) pair) has no
scipy counterpart: it uses the same controller with scipy's RMS error norm.
"""
import math

import numpy as np
from numba import types

from .dynamics import rhs
from .jit import njit
from .layout import METHOD_DOP853, METHOD_RK45, METHOD_VERN9
from .rk_explicit import (
    dop853_dense, dop853_dense4, dop853_error_sq, dop853_error_sq4, dop853_error_sq8, dop853_step,
    dop853_step4, dop853_step8, rk45_error_sq, rk45_error_sq4, rk45_error_sq8, rk45_step,
    rk45_step4, rk45_step8, vern9_error_sq, vern9_error_sq4, vern9_error_sq8, vern9_step,
    vern9_step4, vern9_step8,
)
from .roots import inv_root16
from .tableaux import (
    DOP853_N_STAGES, RK45_N_STAGES, RK45_P, VERN9_A, VERN9_INTERPOLATOR_POWER,
    VERN9_N_STAGES, VERN9_N_STAGES_EXTENDED, VERN9_R,
)

SAFETY = 0.9
MIN_FACTOR = 0.2
MAX_FACTOR = 10.0


@njit(cache=True, forceinline=True, error_model="numpy", _nrt=False)
def error_exponent(method):
    """-1 / (error estimator order + 1): DOP853 7, RK45 4, Vern9 8."""
    if method == METHOD_DOP853:
        return -1.0 / 8.0
    if method == METHOD_VERN9:
        return -1.0 / 9.0
    return -1.0 / 5.0


@njit(cache=True, forceinline=True, error_model="numpy", _nrt=False)
def error_estimator_order(method):
    """Order of the embedded error estimate (for the initial step)."""
    if method == METHOD_DOP853:
        return 7
    if method == METHOD_VERN9:
        return 8
    return 4


@njit(cache=True, forceinline=True, error_model="numpy", _nrt=False)
def error_power_sq(method, en_sq):
    """``en ** error_exponent(method)`` from the squared error norm ``en_sq = en ** 2``, the
    step-size controller's power.

    DOP853's ``en ** (-1/8)`` is ``en_sq ** (-1/16)`` by :func:`.roots.inv_root16`, within
    ~1 ulp (scipy's ``pow`` of the rounded norm is within ~0.5: the factors agree to ~2 ulp,
    the steps to ~1e-16 relative), with a shorter dependent chain than the square roots it
    replaces, paid once per step (see :mod:`.roots` for the measured effect). ``en_sq = 0`` gives ``inf`` (the caller clips it to
    ``MAX_FACTOR``), as ``pow`` does for the others.
    """
    if method == METHOD_DOP853:
        return inv_root16(en_sq)
    return en_sq ** (0.5 * error_exponent(method))


#: Gustafsson's PI gains (Hairer & Wanner, Solving ODEs II, sec. IV.2, eq. 2.43c; Soederlind
#: 2002): the exponents of the new and previous error norms, times 1/k, k = estimator order + 1
PI_ALPHA = 0.7
PI_BETA = 0.4
#: the previous error norm is floored here, as Hairer's DOPRI5 floors FACOLD (a step with a
#: tiny error must not make the next factor explode; MAX_FACTOR clips it in any case)
PI_ERR_FLOOR = 1e-4


@njit(cache=True, forceinline=True, error_model="numpy", _nrt=False)
def pi_factor(en, en_prev, err_order):
    """PI step factor ``SAFETY en^(-0.7/k) en_prev^(0.4/k)``, ``k = err_order + 1``, clipped
    to ``MAX_FACTOR`` (for an accepted step, ``en < 1``).

    The integral term alone (scipy's controller) lets a high-order pair's step grow tenfold
    into a rejection, repeatedly: DOP853 and Vern9 reject 15-19 % of attempted steps on the
    gait (``monkeystudy bench``). The proportional term damps that oscillation.
    """
    if en == 0.0:
        return MAX_FACTOR
    k = err_order + 1.0
    return min(MAX_FACTOR, SAFETY * en ** (-PI_ALPHA / k) * en_prev ** (PI_BETA / k))


@njit(cache=True, error_model="numpy", _nrt=False)
def select_initial_step(phase, p, tau, fmode, t0, y0, f0, n, t_bound, max_step, order,
                        rtol, atol, ytmp, ftmp):
    """Hairer's empirical first step, as ``scipy.integrate._ivp.common.select_initial_step``.

    Costs one right-hand-side evaluation. ``order`` is the error estimator's order.
    """
    interval = abs(t_bound - t0)
    if interval == 0.0:
        return 0.0
    d0 = 0.0
    d1 = 0.0
    for i in range(n):
        sc = atol + abs(y0[i]) * rtol
        d0 += (y0[i] / sc) ** 2
        d1 += (f0[i] / sc) ** 2
    d0 = math.sqrt(d0 / n)
    d1 = math.sqrt(d1 / n)
    if d0 < 1e-5 or d1 < 1e-5:
        h0 = 1e-6
    else:
        h0 = 0.01 * d0 / d1
    h0 = min(h0, interval)
    for i in range(n):
        ytmp[i] = y0[i] + h0 * f0[i]
    rhs(phase, p, tau, fmode, ytmp, ftmp)
    d2 = 0.0
    for i in range(n):
        sc = atol + abs(y0[i]) * rtol
        d2 += ((ftmp[i] - f0[i]) / sc) ** 2
    d2 = math.sqrt(d2 / n) / h0
    if d1 <= 1e-15 and d2 <= 1e-15:
        h1 = max(1e-6, h0 * 1e-3)
    else:
        h1 = (0.01 / max(d1, d2)) ** (1.0 / (order + 1))
    return min(100.0 * h0, h1, interval, max_step)


@njit(cache=True, forceinline=True, error_model="numpy", _nrt=False)
def rk_step(method, phase, p, tau, fmode, y, f, h, n, K, trig, y_new, f_new):
    """One embedded RK step from ``(y, f)`` over ``h``; fills ``K``, ``y_new``, ``f_new``.

    Dispatches to the straight-line steps of :mod:`.rk_explicit` (generated from the
    tableaux; ``n`` 4 means swing, 8 flight). Returns the number of right-hand-side
    evaluations (stages, first-same-as-last reused). ``trig`` (length >= ``N_TRIG``)
    receives the sines and cosines of the angles at ``y_new`` (layout ``T_*``), computed with
    the last stage, for the guards.
    """
    if method == METHOD_DOP853:
        return dop853_step(phase, p, tau, fmode, y, f, h, n, K, trig, y_new, f_new)
    if method == METHOD_VERN9:
        return vern9_step(phase, p, tau, fmode, y, f, h, n, K, trig, y_new, f_new)
    return rk45_step(phase, p, tau, fmode, y, f, h, n, K, trig, y_new, f_new)


@njit(cache=True, forceinline=True, error_model="numpy", _nrt=False)
def error_norm_sq(method, K, h, y, y_new, n, rtol, atol):
    """Square of the scaled norm of the local error estimate (scipy's
    ``_estimate_error_norm``): the controller needs only the square (a step is accepted if it
    is below 1, and :func:`error_power_sq` takes its power), which spares a square root per
    step."""
    if method == METHOD_DOP853:
        return dop853_error_sq(K, h, y, y_new, n, rtol, atol)
    if method == METHOD_VERN9:
        return vern9_error_sq(K, h, y, y_new, n, rtol, atol)
    return rk45_error_sq(K, h, y, y_new, n, rtol, atol)


@njit(cache=True, forceinline=True, error_model="numpy", _nrt=False)
def error_norm(method, K, h, y, y_new, n, rtol, atol):
    """Scaled norm of the local error estimate (scipy's ``_estimate_error_norm``)."""
    return math.sqrt(error_norm_sq(method, K, h, y, y_new, n, rtol, atol))


@njit(cache=True, error_model="numpy", _nrt=False)
def dense_prepare(method, phase, p, tau, fmode, t_old, h, y_old, y_new, f_new, n, K, Fd, ytmp):
    """Dense-output coefficients of the last step into ``Fd``; returns extra RHS evaluations.

    DOP853: the 7th-order interpolant (three extra stages); RK45: the 4th-order free
    interpolant ``Q = K^T P``; Vern9: the 9th-order interpolant (nine extra stages beyond
    ``f_new``, which the step left in ``K[16]``), ``Fd[k] = sum_i R[i, k] k_i``, the last
    coefficient closing it on ``y_new``.

    Compiles all three; the hybrid loop calls the one of its method (:data:`METHOD_KERNELS`).
    """
    if method == METHOD_VERN9:
        return vern9_dense_prepare(phase, p, tau, fmode, t_old, h, y_old, y_new, f_new, n, K, Fd,
                                   ytmp)
    if method == METHOD_DOP853:
        return dop853_dense_prepare(phase, p, tau, fmode, t_old, h, y_old, y_new, f_new, n, K,
                                    Fd, ytmp)
    return rk45_dense_prepare(phase, p, tau, fmode, t_old, h, y_old, y_new, f_new, n, K, Fd, ytmp)


@njit(cache=True, error_model="numpy", _nrt=False)
def dop853_dense_prepare(phase, p, tau, fmode, t_old, h, y_old, y_new, f_new, n, K, Fd, ytmp):
    """DOP853's dense-output coefficients (:func:`dense_prepare`): written out
    (kernel/rk_explicit.py), as the generic loops multiply through the zeros of the tableau,
    and an event costs one of these."""
    return dop853_dense(p, tau, fmode, y_old, y_new, f_new, h, n, K, Fd)


@njit(cache=True, error_model="numpy", _nrt=False)
def vern9_dense_prepare(phase, p, tau, fmode, t_old, h, y_old, y_new, f_new, n, K, Fd, ytmp):
    """Vern9's dense-output coefficients (:func:`dense_prepare`)."""
    for s in range(VERN9_N_STAGES + 1, VERN9_N_STAGES_EXTENDED):
        for i in range(n):
            acc = 0.0
            for j in range(s):
                acc += K[j, i] * VERN9_A[s, j]
            ytmp[i] = y_old[i] + acc * h
        rhs(phase, p, tau, fmode, ytmp, K[s])
    last = VERN9_INTERPOLATOR_POWER - 1
    for i in range(n):
        low = 0.0
        for r in range(last):
            acc = 0.0
            for j in range(VERN9_N_STAGES_EXTENDED):
                acc += VERN9_R[j, r] * K[j, i]
            Fd[r, i] = acc
            low += acc
        # the theta^9 coefficient closes the polynomial on the step's end: the weights
        # b_i(1) = sum_k R[i, k] equal b_i only to ~1e-12 in double precision (terms of
        # ~1e4 cancel), a jump at step ends that event location would see
        Fd[last, i] = (y_new[i] - y_old[i]) / h - low
    return VERN9_N_STAGES_EXTENDED - VERN9_N_STAGES - 1


@njit(cache=True, error_model="numpy", _nrt=False)
def rk45_dense_prepare(phase, p, tau, fmode, t_old, h, y_old, y_new, f_new, n, K, Fd, ytmp):
    """RK45's dense-output coefficients (:func:`dense_prepare`)."""
    for i in range(n):
        for r in range(4):
            acc = 0.0
            for j in range(RK45_N_STAGES + 1):
                acc += K[j, i] * RK45_P[j, r]
            Fd[r, i] = acc
    return 0


@njit(cache=True, error_model="numpy", _nrt=False)
def dense_eval(method, Fd, y_old, h, x, n, out):
    """Interpolated state at ``t_old + x h`` (``0 <= x <= 1``) into ``out``."""
    if method == METHOD_VERN9:
        for i in range(n):
            acc = Fd[VERN9_INTERPOLATOR_POWER - 1, i]
            for r in range(VERN9_INTERPOLATOR_POWER - 2, -1, -1):
                acc = acc * x + Fd[r, i]
            out[i] = y_old[i] + h * x * acc
        return
    if method == METHOD_DOP853:
        for i in range(n):
            acc = 0.0
            for k in range(7):
                acc += Fd[6 - k, i]
                if k % 2 == 0:
                    acc *= x
                else:
                    acc *= 1.0 - x
            out[i] = acc + y_old[i]
        return
    for i in range(n):
        acc = 0.0
        xp = 1.0
        for r in range(4):
            xp *= x
            acc += Fd[r, i] * xp
        out[i] = y_old[i] + h * acc


# --- the method as a compile-time choice -----------------------------------------------------
# Kernels that integrate take the method as a numpy scalar whose *type* names it, and whether
# the run can fly (:func:`method_scalar`): numba compiles one specialisation per type, its
# dispatcher picks it from the argument's type at no cost, and the hybrid loop of that
# specialisation calls only that method's steps and dense output (:data:`METHOD_KERNELS`),
# and only the swing ones when the run cannot fly, so a study compiles what it integrates
# with (Vern9's straight-line steps and DOP853's flight step take seconds each to compile).
_SCALAR_TYPES = {
    (METHOD_RK45, True): (np.uint16, types.uint16),
    (METHOD_DOP853, True): (np.uint8, types.uint8),
    (METHOD_VERN9, True): (np.uint32, types.uint32),
    (METHOD_RK45, False): (np.int16, types.int16),
    (METHOD_DOP853, False): (np.int8, types.int8),
    (METHOD_VERN9, False): (np.int32, types.int32),
}
_CHOICE_OF_TYPE = {numba_type: choice for choice, (_, numba_type) in _SCALAR_TYPES.items()}


def method_scalar(method: int, flies: bool = True):
    """``method`` (``METHOD_*``) as the scalar the integrating kernels take: its value is the
    code; its type names the method and whether the run may enter flight (``flies`` False: the
    swing steps only are compiled, and a run that releases every magnet stops with
    ``ST_STEP_FAILURE``)."""
    return _SCALAR_TYPES[(int(method), bool(flies))][0](method)


def choice_of_type(method_type):
    """``(METHOD_*, flies)`` that a numba scalar type names (None: not a method scalar)."""
    return _CHOICE_OF_TYPE.get(method_type)


@njit(cache=True, error_model="numpy", _nrt=False)
def dop853_dense_prepare_swing(phase, p, tau, fmode, t_old, h, y_old, y_new, f_new, n, K, Fd,
                               ytmp):
    """:func:`dop853_dense_prepare` of a swing step (``n`` 4), for runs that cannot fly."""
    dop853_dense4(p, tau, fmode, y_old, y_new, f_new, h, K, Fd)
    return 3


#: per method: the swing and flight steps, their squared error norms, the dense-output
#: preparation (:func:`dense_prepare`'s signature without ``method``) and the right-hand-side
#: evaluations of a step (first-same-as-last reused)
METHOD_KERNELS = {
    METHOD_DOP853: (dop853_step4, dop853_step8, dop853_error_sq4, dop853_error_sq8,
                    dop853_dense_prepare, DOP853_N_STAGES),
    METHOD_VERN9: (vern9_step4, vern9_step8, vern9_error_sq4, vern9_error_sq8,
                   vern9_dense_prepare, VERN9_N_STAGES),
    METHOD_RK45: (rk45_step4, rk45_step8, rk45_error_sq4, rk45_error_sq8, rk45_dense_prepare,
                  RK45_N_STAGES),
}
#: per method: the dense-output preparation of a swing step (the generic loops of RK45 and
#: Vern9 serve both phases)
SWING_DENSE_PREPARE = {METHOD_DOP853: dop853_dense_prepare_swing,
                       METHOD_VERN9: vern9_dense_prepare, METHOD_RK45: rk45_dense_prepare}
