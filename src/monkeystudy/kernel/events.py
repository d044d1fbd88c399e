"""Guard functions and their location on the dense output (compiled).

A guard ``g`` is a scalar function of the packed state; an event is a crossing of zero in a
given direction. Crossings are detected on each accepted step from the exact end-point values
*and* rates ``dg/dt`` (a cubic Hermite model flags an excursion that leaves and re-enters
inside one step, and any turning point it puts near zero), confirmed by sign checks on the
dense output, and located by Newton's method (Brent's as fall-back) on the interpolant to
``4 eps`` in time (scipy's ``solve_event_equation`` tolerance).

Sign convention (half open): a rising crossing between samples ``a < b`` needs ``g(a) < 0 <=
g(b)``; falling ``g(a) > 0 >= g(b)``; "either" one of the two. A guard exactly zero at the start
of a segment therefore does not fire there; the hybrid loop clamps a start value inside a tiny
band to exactly zero so that round-off cannot re-trigger it either.
"""
import math

import numpy as np

from .dynamics import (
    angle_trig, free_end_height_rate_s, free_end_height_s, free_end_y_rate_s, free_end_y_s,
    guard_params, kinetic_rot_s, kinetic_trans_s, potential_s, rhs, unpack,
)
from .integrate import dense_eval
from .jit import njit
from .layout import (
    G_COORD, G_ENERGY, G_ENERGY_RESTORED, G_FREE_END_HEIGHT, G_FREE_END_Y, G_SLIP_STOP,
    G_STICK_BREAK, PHASE_FLIGHT, PHASE_SWING, T_C1, T_C12, T_C2, T_S1, T_S12, T_S2,
)

EPS = 2.220446049250313e-16
N_SCAN = 8  # dense-output sub-intervals checked when a step is flagged
#: an interior extremum of the guard's cubic model nearer zero than this many times the
#: model's variation on the step is checked on the dense output (:func:`hermite_flags`)
GRAZE_MARGIN = 8.0


@njit(cache=True, forceinline=True, error_model="numpy", _nrt=False)
def _needs_trig(kind):
    return (kind == G_FREE_END_HEIGHT or kind == G_FREE_END_Y or kind == G_ENERGY_RESTORED
            or kind == G_ENERGY)


@njit(cache=True, forceinline=True, error_model="numpy", _nrt=False)
def guard(kind, index, value, phase, p, tau, fmode, y, pivot, eref):
    """Value of a state guard (layout ``G_*``; time guards are handled as step bounds)."""
    if _needs_trig(kind):
        x, yy, th1, th2, vx, vy, w1, w2 = unpack(phase, y, pivot)
        s1, c1, s2, c2, s12, c12 = angle_trig(th1, th2)
        return guard_t(kind, index, value, phase, p, tau, fmode, y, pivot, eref, s1, c1, s2, c2,
                       s12, c12)
    return guard_t(kind, index, value, phase, p, tau, fmode, y, pivot, eref, 0.0, 0.0, 0.0,
                   0.0, 0.0, 0.0)


@njit(cache=True, forceinline=True, error_model="numpy", _nrt=False)
def guard_trig(kind, index, value, phase, p, tau, fmode, y, pivot, eref, trig):
    """:func:`guard` with the sines and cosines of the angles given (``trig``, layout
    ``T_*``, as a step leaves them): bit for bit the same value, without the trigonometry."""
    return guard_t(kind, index, value, phase, p, tau, fmode, y, pivot, eref, trig[T_S1],
                   trig[T_C1], trig[T_S2], trig[T_C2], trig[T_S12], trig[T_C12])


@njit(cache=True, forceinline=True, error_model="numpy", _nrt=False)
def guard_t(kind, index, value, phase, p, tau, fmode, y, pivot, eref, s1, c1, s2, c2, s12,
            c12):
    """:func:`guard` from the sines and cosines of ``theta1``, ``theta2``, ``theta1 + theta2``
    (only read by the kinds that need them)."""
    x, yy, th1, th2, vx, vy, w1, w2 = unpack(phase, y, pivot)
    w = w1 if index == 0 else w2
    fm = fmode[0] if index == 0 else fmode[1]
    L1, L2, g, mt, a, a_s, m2r2, m2s2, h, hs, k11, k22, j11, j12, j22, _, _, _, _ = \
        guard_params(p)
    return guard_s(kind, index, value, eref, x, yy, th1, th2, vx, vy, w1, w2, s1, c1, s2, c2,
                   s12, c12, L1, L2, g, mt, a, a_s, m2r2, m2s2, h, hs, k11, k22, j11, j12, j22,
                   w * fm)


@njit(cache=True, forceinline=True, error_model="numpy", _nrt=False)
def guard_s(kind, index, value, eref, x, yy, th1, th2, vx, vy, w1, w2, s1, c1, s2, c2, s12,
            c12, L1, L2, g, mt, a, a_s, m2r2, m2s2, h, hs, k11, k22, j11, j12, j22, slip):
    """:func:`guard` from scalars only: the unpacked state, the sines and cosines, the
    parameters it reads, and ``slip`` (the slipping DOF's speed times its mode)."""
    if kind == G_FREE_END_HEIGHT:
        # ``value``: the height above the attached end to reach [m] (0: the study's swap)
        return free_end_height_s(L1, L2, c1, c12) - value
    if kind == G_ENERGY_RESTORED or kind == G_ENERGY:
        # G_ENERGY_RESTORED's ``value``: energy to add to the latched reference [J] (a climb of
        # dh needs M g dh); the same arithmetic as dynamics.total_energy8, bit for bit
        e = kinetic_rot_s(h, hs, k11, k22, j11, j12, j22, s2, c2, w1, w2)
        if vx != 0.0 or vy != 0.0:
            e += kinetic_trans_s(a, a_s, m2r2, m2s2, mt, c1, s1, c12, s12, vx, vy, w1, w2)
        e = e + potential_s(g, mt, a, a_s, m2r2, m2s2, yy, s1, c1, s12, c12)
        if kind == G_ENERGY_RESTORED:
            return e - eref - value
        return e - value
    if kind == G_FREE_END_Y:
        return free_end_y_s(yy, L1, L2, c1, c12) - value
    if kind == G_COORD:
        if index == 0:
            return x - value
        if index == 1:
            return yy - value
        if index == 2:
            return th1 - value
        if index == 3:
            return th2 - value
        if index == 4:
            return vx - value
        if index == 5:
            return vy - value
        if index == 6:
            return w1 - value
        return w2 - value
    if kind == G_SLIP_STOP:
        # zero speed of the slipping DOF, signed so that it falls to zero
        return slip
    if kind == G_STICK_BREAK:
        return 0.0  # evaluated by the hybrid loop (needs the holding torque)
    return 0.0


@njit(cache=True, forceinline=True, error_model="numpy", _nrt=False)
def guard_and_rate_step(kind, index, value, phase, p, tau, fmode, y, pivot, eref, trig):
    """``(guard, rate)`` at a step's new point, from the sines and cosines the step left in
    ``trig``, for a guard whose rate needs no vector field (``rate_uses_field`` false); ``y``
    has 8 slots (a swing state uses the first 4).

    Bit for bit :func:`guard_trig` and :func:`guard_rate_kin`. Every array element it may need
    is read first, in straight-line code (with reads inside the kind branches, numba's own
    inlining keeps atomic reference-count operations on every step).
    Compiled without reference counting and inlined by LLVM.
    """
    L1, L2, g, mt, a, a_s, m2r2, m2s2, h, hs, k11, k22, j11, j12, j22, bj, cj, bp, cp = \
        guard_params(p)
    fm0 = fmode[0]
    fm1 = fmode[1]
    s1 = trig[T_S1]
    c1 = trig[T_C1]
    s2 = trig[T_S2]
    c2 = trig[T_C2]
    s12 = trig[T_S12]
    c12 = trig[T_C12]
    y0 = y[0]
    y1 = y[1]
    y2 = y[2]
    y3 = y[3]
    y4 = y[4]
    y5 = y[5]
    y6 = y[6]
    y7 = y[7]
    px = pivot[0]
    py = pivot[1]
    if phase == PHASE_FLIGHT:
        x, yy, th1, th2, vx, vy, w1, w2 = y0, y1, y2, y3, y4, y5, y6, y7
    else:
        x, yy, th1, th2, vx, vy, w1, w2 = px, py, y0, y1, 0.0, 0.0, y2, y3
    w = w1 if index == 0 else w2
    fm = fm0 if index == 0 else fm1
    gv = guard_s(kind, index, value, eref, x, yy, th1, th2, vx, vy, w1, w2, s1, c1, s2, c2, s12,
                 c12, L1, L2, g, mt, a, a_s, m2r2, m2s2, h, hs, k11, k22, j11, j12, j22,
                 w * fm)
    r = rate_kin_s(kind, index, phase, tau, vx, vy, w1, w2, s1, s12, L1, L2, bj, cj, bp, cp,
                   fm0, fm1)
    return gv, r


@njit(cache=True, forceinline=True, error_model="numpy", _nrt=False)
def guard_rate(kind, index, phase, p, tau, fmode, y, pivot, work):
    """Time derivative of a guard along the flow [guard units / s]; ``work`` is an 8-vector."""
    if rate_uses_field(kind, index):
        return guard_rate_field(kind, index, phase, p, tau, fmode, y, work)
    if kind == G_FREE_END_HEIGHT or kind == G_FREE_END_Y:
        x, yy, th1, th2, vx, vy, w1, w2 = unpack(phase, y, pivot)
        s1, _, _, _, s12, _ = angle_trig(th1, th2)
        return guard_rate_kin(kind, index, phase, p, tau, fmode, y, pivot, s1, s12)
    return guard_rate_kin(kind, index, phase, p, tau, fmode, y, pivot, 0.0, 0.0)


@njit(cache=True, forceinline=True, error_model="numpy", _nrt=False)
def guard_rate_trig(kind, index, phase, p, tau, fmode, y, pivot, work, trig):
    """:func:`guard_rate` with the sines and cosines given (see :func:`guard_trig`)."""
    if rate_uses_field(kind, index):
        return guard_rate_field(kind, index, phase, p, tau, fmode, y, work)
    return guard_rate_kin(kind, index, phase, p, tau, fmode, y, pivot, trig[T_S1], trig[T_S12])


@njit(cache=True, error_model="numpy", _nrt=False)
def guard_value(kind, index, value, phase, p, tau, fmode, y, pivot, eref):
    """:func:`guard` compiled once as a function of its own, for the hybrid loop's calls off
    the step loop (a leg's start, an event's located point): inlined at each of those sites
    it would multiply the loop's compile time, for no measurable speed."""
    return guard(kind, index, value, phase, p, tau, fmode, y, pivot, eref)


@njit(cache=True, error_model="numpy", _nrt=False)
def guard_rate_value(kind, index, phase, p, tau, fmode, y, pivot, work):
    """:func:`guard_rate` compiled once as a function of its own (see :func:`guard_value`)."""
    return guard_rate(kind, index, phase, p, tau, fmode, y, pivot, work)


@njit(cache=True, error_model="numpy", _nrt=False)
def guard_trig_value(kind, index, value, phase, p, tau, fmode, y, pivot, eref, trig):
    """:func:`guard_trig` compiled once as a function of its own (see :func:`guard_value`)."""
    return guard_trig(kind, index, value, phase, p, tau, fmode, y, pivot, eref, trig)


@njit(cache=True, error_model="numpy", _nrt=False)
def guard_rate_trig_value(kind, index, phase, p, tau, fmode, y, pivot, work, trig):
    """:func:`guard_rate_trig` compiled once as a function of its own (see
    :func:`guard_value`)."""
    return guard_rate_trig(kind, index, phase, p, tau, fmode, y, pivot, work, trig)


@njit(cache=True, forceinline=True, error_model="numpy", _nrt=False)
def rate_uses_field(kind, index):
    """Whether a guard's rate needs the vector field (an acceleration)."""
    return (kind == G_COORD and index >= 4) or kind == G_SLIP_STOP


@njit(cache=True, forceinline=True, error_model="numpy", _nrt=False)
def guard_rate_kin(kind, index, phase, p, tau, fmode, y, pivot, s1, s12):
    """Rate of a guard that does not need the vector field (kinematics and power), from
    ``sin(theta1)`` and ``sin(theta1 + theta2)``."""
    x, yy, th1, th2, vx, vy, w1, w2 = unpack(phase, y, pivot)
    L1, L2, _, _, _, _, _, _, _, _, _, _, _, _, _, bj, cj, bp, cp = guard_params(p)
    return rate_kin_s(kind, index, phase, tau, vx, vy, w1, w2, s1, s12, L1, L2, bj, cj, bp, cp,
                      fmode[0], fmode[1])


@njit(cache=True, forceinline=True, error_model="numpy", _nrt=False)
def rate_kin_s(kind, index, phase, tau, vx, vy, w1, w2, s1, s12, L1, L2, bj, cj, bp, cp, fm0,
               fm1):
    """:func:`guard_rate_kin` from scalars only."""
    if kind == G_FREE_END_HEIGHT:
        return free_end_height_rate_s(L1, L2, s1, s12, w1, w2)
    if kind == G_FREE_END_Y:
        return free_end_y_rate_s(vy, L1, L2, s1, s12, w1, w2)
    if kind == G_ENERGY_RESTORED or kind == G_ENERGY:
        # dE/dt [W]: motor work tau dth2 less viscous and Coulomb dissipation
        pw = tau * w2 - bj * w2 * w2 - cj * fm1 * w2
        if phase == PHASE_SWING:
            pw -= bp * w1 * w1 + cp * fm0 * w1
        return pw
    if kind == G_COORD:
        if index == 2:
            return w1
        if index == 3:
            return w2
        if index == 0:
            return vx
        if index == 1:
            return vy
    return 0.0


@njit(cache=True, error_model="numpy", _nrt=False)
def guard_rate_field(kind, index, phase, p, tau, fmode, y, work):
    """Rate of a guard on a velocity (an acceleration) or of a slip-stop guard.

    Not inlined: it calls the vector field, and a call inside an inlined function makes numba
    keep atomic reference counts of all that function's arrays on every evaluation.
    """
    rhs(phase, p, tau, fmode, y, work)
    if kind == G_COORD:
        if phase == PHASE_FLIGHT:
            return work[index]
        if index == 6:
            return work[2]
        if index == 7:
            return work[3]
        return 0.0
    if phase == PHASE_FLIGHT:
        return work[6 + index] * fmode[index]
    return work[2 + index] * fmode[index]


@njit(cache=True, forceinline=True, error_model="numpy", _nrt=False)
def crosses(ga, gb, direction):
    """Half-open sign rule for a crossing from ``ga`` to ``gb`` (see module docstring)."""
    if direction > 0:
        return ga < 0.0 <= gb
    if direction < 0:
        return ga > 0.0 >= gb
    return (ga < 0.0 <= gb) or (ga > 0.0 >= gb)


@njit(cache=True, forceinline=True, error_model="numpy", _nrt=False)
def _hermite_value(s, ga, da, gb, db):
    s2 = s * s
    s3 = s2 * s
    return ((2.0 * s3 - 3.0 * s2 + 1.0) * ga + (s3 - 2.0 * s2 + s) * da
            + (-2.0 * s3 + 3.0 * s2) * gb + (s3 - s2) * db)


@njit(cache=True, forceinline=True, error_model="numpy", _nrt=False)
def _hermite_extrema(ga, ra, gb, rb, h):
    """Interior extrema ``s`` in (0, 1) of the cubic Hermite model of ``g`` on a step:
    ``(n, s1, s2)`` with ``n`` the number found (0, 1 or 2)."""
    da = h * ra
    db = h * rb
    # g'(s) h = c2 s^2 + c1 s + c0 for the cubic Hermite interpolant on s in [0, 1]
    c2 = -6.0 * (gb - ga) + 3.0 * da + 3.0 * db
    c1 = 6.0 * (gb - ga) - 4.0 * da - 2.0 * db
    c0 = da
    disc = c1 * c1 - 4.0 * c2 * c0
    if disc < 0.0:
        return 0, 0.0, 0.0
    # the cancellation-free pair of roots; c2 = 0 (a quadratic model, e.g. a turning point
    # in the middle of the step) leaves the single root -c0 / c1
    q = -0.5 * (c1 + math.copysign(math.sqrt(disc), c1))
    if q == 0.0:
        return 0, 0.0, 0.0
    n = 0
    s1 = 0.0
    s2 = 0.0
    for s in (c0 / q, q / c2 if c2 != 0.0 else -1.0):
        if 0.0 < s < 1.0:
            if n == 0:
                s1 = s
            else:
                s2 = s
            n += 1
    return n, s1, s2


@njit(cache=True, forceinline=True, error_model="numpy", _nrt=False)
def hermite_flags(ga, ra, gb, rb, h, direction):
    """True when the cubic Hermite model of ``g`` on the step may cross zero inside it, or
    has an interior extremum near zero (so a crossing between same-signed ends is possible).

    Catches an excursion that leaves and re-enters between two same-signed end values
    (the grazing swap), including the case of two interior extrema that end-point rates
    alone cannot reveal. An extremum whose model value lies farther from zero than
    ``GRAZE_MARGIN`` times the model's own variation on the step (``|g_s - g_a| + |g_s -
    g_b|``) is not checked on the dense output: the cubic's error there is a small fraction
    of that variation on any step that resolves the guard (on the study's swings at most 0.43
    of it at rtol 1e-3, 0.03 at 1e-6, 0.007 at 1e-10; ``tests/kernel/test_events.py``). Only
    the screen is approximate: a flagged step is searched on the dense output.
    """
    n, s1, s2 = _hermite_extrema(ga, ra, gb, rb, h)
    if n == 0:
        return ra * rb < 0.0  # an extremum the model lost to round-off: check the step
    for k in range(n):
        s = s1 if k == 0 else s2
        gs = _hermite_value(s, ga, h * ra, gb, h * rb)
        if crosses(ga, gs, direction) or crosses(gs, gb, direction) or crosses(ga, gs, 0.0):
            return True
        if abs(gs) <= GRAZE_MARGIN * (abs(gs - ga) + abs(gs - gb)):
            return True
    return False


@njit(cache=True, forceinline=True, error_model="numpy", _nrt=False)
def _hermite_root(ga, da, gb, db):
    """Root ``s`` in [0, 1] of a monotone cubic Hermite model with ends of opposite signs.

    Newton's method from the secant estimate, kept inside the shrinking bracket (a step
    leaving it bisects). The estimate only seeds :func:`newton_root` on the dense output, whose own error
    dominates long before the cubic's root is resolved to round-off.
    """
    lo = 0.0
    hi = 1.0
    glo = ga
    s = ga / (ga - gb)
    if not (0.0 < s < 1.0):
        s = 0.5
    for _ in range(12):
        s2 = s * s
        gm = _hermite_value(s, ga, da, gb, db)
        if gm == 0.0:
            return s
        if (gm > 0.0) == (glo > 0.0):
            lo = s
            glo = gm
        else:
            hi = s
        # the model's slope: d/ds of the Hermite basis combination
        dm = ((6.0 * s2 - 6.0 * s) * (ga - gb) + (3.0 * s2 - 4.0 * s + 1.0) * da
              + (3.0 * s2 - 2.0 * s) * db)
        step = gm / dm if dm != 0.0 else math.inf
        if abs(step) <= 1e-13:
            return s
        s_new = s - step
        if not (lo < s_new < hi):
            s_new = 0.5 * (lo + hi)
        s = s_new
    return s


@njit(cache=True, error_model="numpy", _nrt=False)
def hermite_monotone(ga, ra, gb, rb, h):
    """True when the cubic Hermite model of ``g`` has no extremum inside the step."""
    if ra * rb <= 0.0:
        return False
    n, s1, s2 = _hermite_extrema(ga, ra, gb, rb, h)
    return n == 0


@njit(cache=True, error_model="numpy", _nrt=False)
def guard_at(kind, index, value, method, Fd, y_old, t_old, h, t, n, phase, p, tau, fmode,
             pivot, eref, ybuf):
    """Guard on the dense output at time ``t`` (state left in ``ybuf``)."""
    dense_eval(method, Fd, y_old, h, (t - t_old) / h, n, ybuf)
    return guard_value(kind, index, value, phase, p, tau, fmode, ybuf, pivot, eref)


@njit(cache=True, error_model="numpy", _nrt=False)
def rate_at(kind, index, method, Fd, y_old, t_old, h, t, n, phase, p, tau, fmode, pivot,
            ybuf, work):
    dense_eval(method, Fd, y_old, h, (t - t_old) / h, n, ybuf)
    return guard_rate_value(kind, index, phase, p, tau, fmode, ybuf, pivot, work)


@njit(cache=True, error_model="numpy", _nrt=False)
def guard_rate_at(kind, index, value, method, Fd, y_old, t_old, h, t, n, phase, p, tau, fmode,
                  pivot, eref, ybuf, work):
    """Guard and its rate on the dense output at ``t`` from one interpolation."""
    dense_eval(method, Fd, y_old, h, (t - t_old) / h, n, ybuf)
    return (guard_value(kind, index, value, phase, p, tau, fmode, ybuf, pivot, eref),
            guard_rate_value(kind, index, phase, p, tau, fmode, ybuf, pivot, work))


@njit(cache=True, error_model="numpy", _nrt=False)
def newton_root(kind, index, value, a, b, ga, gb, x0, method, Fd, y_old, t_old, h, n, phase,
                p, tau, fmode, pivot, eref, ybuf, work):
    """Root of the guard on the dense output in the bracket [a, b] (``ga``, ``gb`` of opposite
    signs or one zero), by Newton steps with the analytic rate, safeguarded by bisection.

    The rate along the flow differs from the derivative of the interpolant only by the
    interpolation error, so the iteration contracts by ~rtol per step: two or three dense
    evaluations reach ``4 eps`` in time. Falls back to Brent if it stalls.
    """
    if ga == 0.0:
        return a
    if gb == 0.0:
        return b
    x = x0
    if not (a < x < b):
        x = a - ga * (b - a) / (gb - ga)
        if not (a < x < b):
            x = 0.5 * (a + b)
    for _ in range(40):
        gx, rx = guard_rate_at(kind, index, value, method, Fd, y_old, t_old, h, x, n, phase, p,
                               tau, fmode, pivot, eref, ybuf, work)
        if gx == 0.0:
            return x
        if (gx > 0.0) == (ga > 0.0):
            a = x
            ga = gx
        else:
            b = x
            gb = gx
        tol = 4.0 * EPS * (1.0 + abs(x))
        if b - a <= tol:
            return b if abs(gb) <= abs(ga) else a
        if rx != 0.0:
            step = gx / rx
            if abs(step) <= tol:
                return x  # converged (a further step would be below the time resolution)
            xn = x - step
            if not (a < xn < b):
                xn = 0.5 * (a + b)
        else:
            xn = 0.5 * (a + b)
        x = xn
    return brent(GUARD_ROOT, kind, index, value, a, b, ga, gb, method, Fd, y_old, t_old, h, n,
                 phase, p, tau, fmode, pivot, eref, ybuf, work)


# what :func:`brent` finds a root of; int64 values, not literals, so that numba compiles it once
# (a literal argument makes a specialisation of its own)
GUARD_ROOT, RATE_ROOT = np.int64(0), np.int64(1)


@njit(cache=True, error_model="numpy", _nrt=False)
def brent(which, kind, index, value, a, b, fa, fb, method, Fd, y_old, t_old, h, n, phase, p,
          tau, fmode, pivot, eref, ybuf, work):
    """Brent's root of the guard (``which == 0``) or of its rate (``which == 1``) on [a, b].

    Requires a sign change. Terminates when the bracket is below ``4 eps (1 + |t|)``.
    """
    if fa == 0.0:
        return a
    if fb == 0.0:
        return b
    c = a
    fc = fa
    d = b - a
    e = d
    for _ in range(200):
        if fb * fc > 0.0:
            c = a
            fc = fa
            d = b - a
            e = d
        if abs(fc) < abs(fb):
            a, b, c = b, c, b
            fa, fb, fc = fb, fc, fb
        tol = 2.0 * EPS * abs(b) + 2.0 * EPS
        m = 0.5 * (c - b)
        if abs(m) <= tol or fb == 0.0:
            return b
        if abs(e) < tol or abs(fa) <= abs(fb):
            d = m
            e = m
        else:
            s = fb / fa
            if a == c:
                pp = 2.0 * m * s
                q = 1.0 - s
            else:
                q = fa / fc
                r = fb / fc
                pp = s * (2.0 * m * q * (q - r) - (b - a) * (r - 1.0))
                q = (q - 1.0) * (r - 1.0) * (s - 1.0)
            if pp > 0.0:
                q = -q
            else:
                pp = -pp
            if 2.0 * pp < min(3.0 * m * q - abs(tol * q), abs(e * q)):
                e = d
                d = pp / q
            else:
                d = m
                e = m
        a = b
        fa = fb
        if abs(d) > tol:
            b += d
        else:
            b += tol if m > 0 else -tol
        if which == 0:
            fb = guard_at(kind, index, value, method, Fd, y_old, t_old, h, b, n, phase, p,
                          tau, fmode, pivot, eref, ybuf)
        else:
            fb = rate_at(kind, index, method, Fd, y_old, t_old, h, b, n, phase, p, tau,
                         fmode, pivot, ybuf, work)
    return b


@njit(cache=True, error_model="numpy", _nrt=False)
def locate_first(kind, index, value, direction, t_a, t_b, g_a, g_b, r_a, r_b, method, Fd,
                 y_old, t_old, h, n, phase, p, tau, fmode, pivot, eref, ybuf, work):
    """Earliest crossing of the guard in ``(t_a, t_b]`` on the dense output, or ``inf``.

    ``[t_a, t_b]`` lies inside the step ``[t_old, t_old + h]`` whose coefficients are ``Fd``;
    ``g_*``, ``r_*`` are the guard and its rate at the ends. If the ends bracket a crossing
    and the cubic Hermite model is monotone, the crossing is unique: its Hermite estimate is
    polished by :func:`newton_root`. Otherwise ``N_SCAN`` sub-intervals are scanned; inside
    each, a sign change is located directly, and a rate sign change without one is checked at
    the extremum (a grazing touch that re-enters within the sub-interval).
    """
    span = t_b - t_a
    if crosses(g_a, g_b, direction) and hermite_monotone(g_a, r_a, g_b, r_b, span):
        x0 = t_a + _hermite_root(g_a, span * r_a, g_b, span * r_b) * span
        return newton_root(kind, index, value, t_a, t_b, g_a, g_b, x0, method, Fd, y_old,
                           t_old, h, n, phase, p, tau, fmode, pivot, eref, ybuf, work)
    ta = t_a
    ga = g_a
    ra = r_a
    for k in range(1, N_SCAN + 1):
        if k == N_SCAN:
            tb = t_b
            gb = g_b
            rb = r_b
        else:
            tb = t_a + span * k / N_SCAN
            gb, rb = guard_rate_at(kind, index, value, method, Fd, y_old, t_old, h, tb, n,
                                   phase, p, tau, fmode, pivot, eref, ybuf, work)
        if crosses(ga, gb, direction):
            return newton_root(kind, index, value, ta, tb, ga, gb, -1.0, method, Fd, y_old,
                               t_old, h, n, phase, p, tau, fmode, pivot, eref, ybuf, work)
        if ra * rb < 0.0:
            te = brent(RATE_ROOT, kind, index, value, ta, tb, ra, rb, method, Fd, y_old, t_old,
                       h, n, phase, p, tau, fmode, pivot, eref, ybuf, work)
            ge = guard_at(kind, index, value, method, Fd, y_old, t_old, h, te, n, phase, p,
                          tau, fmode, pivot, eref, ybuf)
            if crosses(ga, ge, direction):
                return newton_root(kind, index, value, ta, te, ga, ge, -1.0, method, Fd,
                                   y_old, t_old, h, n, phase, p, tau, fmode, pivot, eref, ybuf,
                                   work)
        ta = tb
        ga = gb
        ra = rb
    return np.inf
