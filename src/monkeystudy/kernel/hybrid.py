"""The hybrid simulation loop (compiled): integrate, locate the earliest event, reset, go on.

One function, :func:`simulate`, serves every study. The controller is a *program*: a table of
segments (layout ``S_*``), each saying what to do on entry (magnets, motor torque, latch the
reference energy) and which guard ends it (time on the controller clock, free end at the
attached end's height, energy restored, a coordinate or the energy crossing a value). Observers
(layout ``O_*``) are guards whose crossings are only logged. Everything that evolves (state,
phase, which end the frame hangs from, segment, torque, clock, latched energy, friction modes)
is a float vector (layout ``H_*``) that goes in and comes out, so a run can be continued.
Each integration method is its own compiled specialisation of the loop
(:func:`simulate_implementation`), chosen by the type of the ``method`` argument
(:func:`.integrate.method_scalar`), so a study compiles only the steps it integrates with.

Semantics worth knowing (docs/model.md sections 4 and 6):

* A segment guard with ``S_TICKED`` on a tick ``h > 0`` is located exactly, then acted on at
  the first tick ``phase + k h`` at or after the crossing *if its condition still holds there*
  (the study's controller samples its conditions on a 1 ms loop). Time guards on a tick fire
  at the first tick at or after their time.
* A catch on a bar (``G_BAR``) is the free end's height guard, falling, never ticked; a
  crossing is a catch only within ``S_BAR_WINDOW`` of the bar horizontally (else the search
  goes on past it), and after the catch's swap the new attached end is snapped onto the bar
  (a translation; the log row keeps the state before it).
* Time guards are integration bounds: steps end exactly on them (no interpolation).
* ``S_DELAY`` moves a segment's exit: a time guard's instant (after the tick) by the delay,
  either sign (never before the segment's start); a state guard's exit waits the delay after
  the guard fires (the segment's torque and magnets stay), a latency. Zero: no change.
* ``G_ENERGY_RESTORED`` is a level condition: already restored at entry (a collisionless
  swap) fires at once, with zero motor time. Other guards are crossings; one exactly zero at a
  segment start (within the relative band ``C_ZERO_BAND``) does not fire there.
* A terminal event restarts the integrator at the event (new initial step, as chained
  ``solve_ivp`` calls do); observers and trajectory samples never alter the step sequence.
* Coulomb friction: a slipping DOF keeps its sign until its speed reaches zero (an event);
  there it sticks if the holding torque is within the Coulomb limit, else slips the other way;
  a stuck DOF breaks away when the holding torque reaches the limit (an event located on sign
  changes at step ends and the dense output; its rate is not used).
"""
import math
from types import FunctionType

import numpy as np
from numba import typeof, types
from numba.core.imputils import lower_builtin
from numba.extending import type_callable

from .dynamics import (
    TWO_LINK, attach_xy_end, flip_state, free_end_offset, holding_torque, pack, rhs,
    total_energy8, unpack, unpack_into,
)
from .events import (
    crosses, guard_and_rate_step, guard_rate_field, guard_rate_trig_value,
    guard_rate_value, guard_trig_value, guard_value, hermite_flags, locate_first,
    rate_uses_field,
)
from .integrate import (
    MAX_FACTOR, METHOD_KERNELS, MIN_FACTOR, PI_ERR_FLOOR, SAFETY, SWING_DENSE_PREPARE,
    choice_of_type, dense_eval, error_estimator_order, error_power_sq, pi_factor,
    select_initial_step,
)
from .jit import Model, njit, specialised, specialised_globals
from .layout import (
    C_ATOL, C_CONTROLLER, C_MAX_CYCLES, C_MAX_DROP, C_MAX_SEGMENT_TIME, C_MAX_STEP, C_MAX_STEPS,
    C_RTOL, C_SAMPLE_DT, C_T_END, C_TICK, C_TICK_PHASE, C_ZERO_BAND, CONTROLLER_PI, DTH1, DTH2,
    DX, DY, FLIES,
    G_BAR, G_ENERGY_RESTORED, G_FREE_END_HEIGHT, G_FREE_END_Y, G_NONE, G_SLIP_STOP,
    G_STICK_BREAK, G_TIME,
    H_CLOCK, H_CYCLES, H_EREF,
    H_FLIPPED, H_FMODE0, H_FMODE1, H_PHASE, H_SEG, H_T, H_TORQUE, H_Y_REF, K_CYCLES, K_EVENTS,
    K_LOG, K_NFEV, K_REJECTED, K_SAMPLES, K_STATUS, K_STEPS, L_CYCLE, L_E_AFTER, L_E_BEFORE,
    L_FLIPPED, L_ID, L_KIND, L_PHASE, L_STATE, L_T, LOG_FRICTION, LOG_OBSERVER, LOG_SEGMENT,
    M_FLIPPED, M_PHASE, M_SEGMENT, M_TORQUE, METHOD_DOP853, METHOD_RK45, METHOD_VERN9, O_GDIR,
    O_GINDEX, O_GUARD, O_GVALUE, O_SEGMENT, P_C_JOINT, P_C_PIVOT, PHASE_FIXED, PHASE_FLIGHT,
    PHASE_SWING, S_BAR_DX, S_BAR_WINDOW, S_CLOCK, S_CYCLE, S_DELAY, S_FAIL, S_GDIR, S_GINDEX,
    S_GUARD, S_GVALUE, S_RISE,
    S_MAG_A, S_MAG_B, S_NEXT, S_SET_EREF, S_SWAP, S_TICKED, S_TORQUE, ST_BUFFER_FULL,
    ST_END_TIME, ST_FELL, ST_HORIZON, ST_NONFINITE, ST_OK, ST_STEP_FAILURE, N_STATE, X, Y,
)
from .tableaux import VERN9_INTERPOLATOR_POWER, VERN9_N_STAGES_EXTENDED

EPS = 2.220446049250313e-16
TICK_SNAP = 1e-9  # a time within this fraction of a tick of a tick is on it (round-off)


@njit(cache=True, error_model="numpy", _nrt=False)
def next_tick(t, tick, tick_phase):
    """First controller tick at or after ``t`` [s]."""
    k = math.ceil((t - tick_phase) / tick - TICK_SNAP)
    return tick_phase + k * tick


@njit(cache=True, error_model="numpy", _nrt=False)
def apply_magnets(par, s8, phase, flipped, mag_a, mag_b, swap):
    """Entry magnet actions; returns the new ``(phase, flipped)``; ``s8`` changed in place.

    Attaching an end that was free is a plastic impact (docs/model.md section 3): the frame is
    first flipped if that end is not the frame's (x, y) end, then projected. Both magnets on
    stops all motion; releasing every magnet starts a flight with the current velocities.
    """
    xy_is_a = flipped == 0
    att_xy = phase == PHASE_SWING or phase == PHASE_FIXED
    att_other = phase == PHASE_FIXED
    att_a = att_xy if xy_is_a else att_other
    att_b = att_other if xy_is_a else att_xy
    if swap:
        if phase != PHASE_SWING:
            return phase, flipped  # nothing to swap: the program asks the impossible, ignore
        new_a = not att_a
        new_b = not att_b
    else:
        new_a = att_a if mag_a < 0 else mag_a > 0
        new_b = att_b if mag_b < 0 else mag_b > 0
    if new_a and new_b:
        if not (att_a and att_b):
            s8[DX] = s8[DY] = s8[DTH1] = s8[DTH2] = 0.0
        return PHASE_FIXED, flipped
    if new_a or new_b:
        want_xy_is_a = new_a
        if want_xy_is_a != xy_is_a:
            flip_state(par[flipped], s8)
            flipped = 1 - flipped
        was_attached = att_a if new_a else att_b
        if not was_attached:
            attach_xy_end(par[flipped], s8)
        else:
            s8[DX] = 0.0
            s8[DY] = 0.0
        return PHASE_SWING, flipped
    if phase == PHASE_FIXED:
        s8[DX] = s8[DY] = s8[DTH1] = s8[DTH2] = 0.0
    return PHASE_FLIGHT, flipped


@njit(cache=True, error_model="numpy", _nrt=False)
def init_friction(phase, p, tau, s8, fmode, y, pivot):
    """Friction modes at a phase start: slip with the speed's sign, or stick test at rest."""
    for k in range(2):
        c = p[P_C_PIVOT] if k == 0 else p[P_C_JOINT]
        if c <= 0.0 or (k == 0 and phase != PHASE_SWING):
            fmode[k] = 1.0
            continue
        w = s8[DTH1 + k]
        if w != 0.0:
            fmode[k] = 1.0 if w > 0.0 else -1.0
    for k in range(2):
        c = p[P_C_PIVOT] if k == 0 else p[P_C_JOINT]
        if c <= 0.0 or (k == 0 and phase != PHASE_SWING):
            continue
        if s8[DTH1 + k] == 0.0:
            pack(phase, s8, y)
            hold = holding_torque(phase, p, tau, fmode, y, k)
            if abs(hold) <= c:
                fmode[k] = 0.0
            else:
                fmode[k] = -1.0 if hold > 0.0 else 1.0


@njit(cache=True, error_model="numpy", _nrt=False)
def friction_guard(k, phase, p, tau, fmode, y, pivot):
    """Guard of friction DOF ``k`` in its current mode: speed x slip sign, or |hold| - c."""
    if fmode[k] == 0.0:
        c = p[P_C_PIVOT] if k == 0 else p[P_C_JOINT]
        return abs(holding_torque(phase, p, tau, fmode, y, k)) - c
    return slip_speed(k, phase, fmode, y, pivot)


@njit(cache=True, forceinline=True, error_model="numpy", _nrt=False)
def slip_speed(k, phase, fmode, y, pivot):
    """The slip-stop guard of friction DOF ``k``: its speed times its slip sign (the
    ``G_SLIP_STOP`` guard of :mod:`.events`, bit for bit, without the other kinds' code)."""
    x, yy, th1, th2, vx, vy, w1, w2 = unpack(phase, y, pivot)
    w = w1 if k == 0 else w2
    fm = fmode[0] if k == 0 else fmode[1]
    return w * fm


@njit(cache=True, forceinline=True, error_model="numpy", _nrt=False)
def friction_active(k, phase, p):
    if phase == PHASE_FIXED:
        return False
    if k == 0:
        return phase == PHASE_SWING and p[P_C_PIVOT] > 0.0
    return p[P_C_JOINT] > 0.0


@njit(cache=True, error_model="numpy", _nrt=False)
def segment_event_in_step(gkind, gindex, gvalue, gdir, t, t_new, g_seg, gb, r_seg, rb, method,
                          Fd, y, h, n, phase, p, tau, fmode, pivot, eref, ybuf, work, ticked,
                          tick, tick_phase, pending, pending_sign, bar, bar_dx, bar_window):
    """The segment guard's event in the step ``(t, t_new]``, whose guard values (``g_seg``,
    ``gb``) and rates flag a possible crossing; the dense output is prepared in ``Fd``.

    Returns ``(t_ev, pending, pending_sign)``: the event's time (inf: none in this step); a
    ticked guard found crossing is acted on at the first tick at or after the crossing where
    its condition still holds, and a tick past ``t_new`` is left ``pending`` with the guard's
    sign before the crossing (module docstring). With ``bar`` (a ``G_BAR`` row, never ticked),
    a crossing is a catch only if the free end is then within ``bar_window`` [m] of
    ``bar_dx`` [m] horizontally from the attached end; outside, the hook passes the bar and
    the search goes on from the crossing.
    """
    t_ev = np.inf
    ta = t
    ga = g_seg
    ra = r_seg
    while True:
        tc = locate_first(gkind, gindex, gvalue, gdir, ta, t_new, ga, gb, ra, rb, method, Fd, y,
                          t, h, n, phase, p, tau, fmode, pivot, eref, ybuf, work)
        if tc == np.inf:
            break
        sign_before = 1.0 if ga > 0.0 else -1.0
        if bar:
            dense_eval(method, Fd, y, h, (tc - t) / h, n, ybuf)
            _, _, th1, th2, _, _, _, _ = unpack(phase, ybuf, pivot)
            ox, _ = free_end_offset(p, th1, th2)
            if abs(ox - bar_dx) <= bar_window:
                t_ev = tc
                break
            if tc <= ta or tc >= t_new:
                break
            # the search goes on past this crossing: from a guard of exactly zero, the
            # half-open sign rule cannot find the same crossing again
            ta = tc
            ga = 0.0
            ra = guard_rate_value(gkind, gindex, phase, p, tau, fmode, ybuf, pivot, work)
            continue
        if not ticked:
            t_ev = tc
            break
        tk = next_tick(tc, tick, tick_phase)
        if tk <= tc:
            # the tick is the crossing itself, to round-off (next_tick snaps within
            # TICK_SNAP): act. Testing the condition a hair before the root fails, and the
            # search would find the same root and tick again, forever.
            t_ev = tk if tk >= t else t
            break
        if tk > t_new:
            pending = tk
            pending_sign = sign_before
            break
        if tk == t_new:
            gk = gb
        else:
            dense_eval(method, Fd, y, h, (tk - t) / h, n, ybuf)
            gk = guard_value(gkind, gindex, gvalue, phase, p, tau, fmode, ybuf, pivot, eref)
        if (gdir > 0 and gk >= 0.0) or (gdir < 0 and gk <= 0.0) or \
                (gdir == 0 and gk * sign_before <= 0.0):
            t_ev = tk
            break
        if tk >= t_new:
            break
        ta = tk
        ga = gk
        ra = guard_rate_value(gkind, gindex, phase, p, tau, fmode, ybuf, pivot,
                              work) if tk < t_new else rb
    return t_ev, pending, pending_sign


@njit(cache=True, error_model="numpy", _nrt=False)
def change_friction_mode(k, phase, flipped, p, tau, fmode, s8, y, t, cycles, counts, log,
                         n_log):
    """Friction DOF ``k`` at its event at ``t`` [s]: slipping, its speed reached zero (it
    sticks if the holding torque is within the Coulomb limit, else slips the other way);
    stuck, the holding torque reached the limit (it slips). Logged. Returns
    ``(n_log, status)`` (``ST_BUFFER_FULL`` if the log is full, else -1)."""
    s8[DTH1 + k] = 0.0  # zero speed exactly at the event
    pack(phase, s8, y)
    c = p[P_C_PIVOT] if k == 0 else p[P_C_JOINT]
    if fmode[k] == 0.0:
        hold = holding_torque(phase, p, tau, fmode, y, k)
        fmode[k] = -1.0 if hold > 0.0 else 1.0
        s8[DTH1 + k] = 0.0
    else:
        hold = holding_torque(phase, p, tau, fmode, y, k)
        if abs(hold) <= c:
            fmode[k] = 0.0
        else:
            fmode[k] = -1.0 if hold > 0.0 else 1.0
    counts[K_EVENTS] += 1
    status = -1
    if n_log < log.shape[0]:
        e = total_energy8(p, s8)
        write_log(log, n_log, t, np.int64(LOG_FRICTION), k, cycles, phase, flipped, e, e, s8)
        n_log += 1
    elif log.shape[0] > 0:
        status = ST_BUFFER_FULL
    return n_log, status


#: :func:`observe_step`'s answer when a crossing needs the step's dense output first
NEED_DENSE = -2


@njit(cache=True, error_model="numpy", _nrt=False)
def observe_step(first, obs, seg, t, t_new, t_cut, h, dense, method, Fd, y, y_new, trig_new,
                 n, phase, p, tau, fmode, pivot, eref, work, ybuf, g_obs, log, n_log, cycles,
                 flipped, counts):
    """The observers' crossings in the accepted step ``[t, t_new]`` [s], logged up to
    ``t_cut`` (the step's event, or its end), from observer ``first`` on: each observer
    watching this segment is flagged by a sign change or the cubic model of its guard, its
    crossings located on the dense output and logged (``LOG_OBSERVER``), and its guard value
    kept for the next step.

    Returns ``(n_log, status, k)``: status -1 (``k`` = the number of observers), or
    ``ST_BUFFER_FULL``; or :data:`NEED_DENSE` when observer ``k`` is flagged and the step's
    dense output is not prepared (``dense`` false): the loop prepares it and calls again from
    ``k``, whose guards, computed again from the same values, give the same bits.
    """
    n_obs = obs.shape[0]
    log_cap = log.shape[0]
    status = -1
    for k in range(first, n_obs):
        if obs[k, O_SEGMENT] >= 0 and int(obs[k, O_SEGMENT]) != seg:
            continue
        okind = int(obs[k, O_GUARD])
        oidx = int(obs[k, O_GINDEX])
        oval = obs[k, O_GVALUE]
        odir = obs[k, O_GDIR]
        gb = guard_trig_value(okind, oidx, oval, phase, p, tau, fmode, y_new, pivot, eref,
                              trig_new)
        ga = g_obs[k]
        ra = guard_rate_value(okind, oidx, phase, p, tau, fmode, y, pivot, work)
        rb = guard_rate_trig_value(okind, oidx, phase, p, tau, fmode, y_new, pivot, work,
                                   trig_new)
        if crosses(ga, gb, odir) or hermite_flags(ga, ra, gb, rb, h, odir):
            if not dense:
                return n_log, NEED_DENSE, k
            # searched over the whole step, so that an observer watching the same guard as
            # the segment event finds the same root; crossings up to the event (plus
            # round-off) are logged, later ones belong to the next leg
            slack = 8.0 * EPS * (1.0 + abs(t_cut))
            ta = t
            for _rep in range(4):
                if ta >= t_cut:
                    break
                tc = locate_first(okind, oidx, oval, odir, ta, t_new, ga, gb, ra, rb, method,
                                  Fd, y, t, h, n, phase, p, tau, fmode, pivot, eref, ybuf,
                                  work)
                if tc == np.inf or tc > t_cut + slack:
                    break
                tc = min(tc, t_cut)
                if n_log >= log_cap:
                    if log_cap > 0:
                        status = ST_BUFFER_FULL
                    break
                dense_eval(method, Fd, y, h, (tc - t) / h, n, ybuf)
                unpack_into(phase, ybuf, pivot, work)
                e = total_energy8(p, work)
                write_log(log, n_log, tc, np.int64(LOG_OBSERVER), k, cycles, phase, flipped,
                          e, e, work)
                n_log += 1
                counts[K_EVENTS] += 1
                ta = tc
                ga = 0.0
                ra = guard_rate_value(okind, oidx, phase, p, tau, fmode, ybuf, pivot, work)
        g_obs[k] = gb
    return n_log, status, n_obs


@njit(cache=True, error_model="numpy", _nrt=False)
def exit_segment(par, prog, seg, t, s8, phase, flipped, tau, gvalue, clock0, cycles,
                 max_cycles, counts, seg_times, log, n_log, sampling, samp_t, samp_y, samp_mode,
                 n_samp):
    """Segment ``seg``'s guard fired at ``t`` [s]: record the exit, sample, advance the
    controller clock and the cycle count, then end the run (no next segment, or the cycles
    are done) or apply the next segment's magnets (the impact) and log the transition.

    Returns ``(status, seg, phase, flipped, clock0, cycles, n_log, n_samp)``: status -1 to go
    on into the (new) segment ``seg``, else ``ST_OK`` or ``ST_BUFFER_FULL``.
    """
    log_cap = log.shape[0]
    counts[K_EVENTS] += 1
    seg_times[seg] = t
    e_before = total_energy8(par[flipped], s8)
    if sampling:
        n_samp = write_sample(samp_t, samp_y, samp_mode, n_samp, t, s8, phase, flipped, tau,
                              seg)
        if n_samp < 0:
            return ST_BUFFER_FULL, seg, phase, flipped, clock0, cycles, n_log, n_samp
    clock_mode = int(prog[seg, S_CLOCK])
    if clock_mode == 1:
        clock0 = t
    elif clock_mode == 2:
        clock0 += gvalue
    if prog[seg, S_CYCLE] > 0:
        cycles += 1
    nxt = int(prog[seg, S_NEXT])
    last = seg
    status = -1
    if nxt < 0 or (max_cycles > 0 and cycles >= max_cycles):
        status = ST_OK
        if n_log < log_cap:
            write_log(log, n_log, t, np.int64(LOG_SEGMENT), last, cycles, phase, flipped,
                      e_before, e_before, s8)
            n_log += 1
        elif log_cap > 0:
            status = ST_BUFFER_FULL
        return status, seg, phase, flipped, clock0, cycles, n_log, n_samp
    seg = nxt
    # the log row shows the state after the next segment's entry actions (the impact)
    phase, flipped = apply_magnets(par, s8, phase, flipped, prog[seg, S_MAG_A],
                                   prog[seg, S_MAG_B], prog[seg, S_SWAP] > 0)
    if n_log < log_cap:
        write_log(log, n_log, t, np.int64(LOG_SEGMENT), last, cycles, phase, flipped, e_before,
                  total_energy8(par[flipped], s8), s8)
        n_log += 1
    elif log_cap > 0:
        status = ST_BUFFER_FULL
    return status, seg, phase, flipped, clock0, cycles, n_log, n_samp


@njit(cache=True, error_model="numpy", _nrt=False)
def write_log(log, row, t, kind, ident, cycle, phase, flipped, e_before, e_after, s8):
    log[row, L_T] = t
    log[row, L_KIND] = kind
    log[row, L_ID] = ident
    log[row, L_CYCLE] = cycle
    log[row, L_PHASE] = phase
    log[row, L_FLIPPED] = flipped
    log[row, L_E_BEFORE] = e_before
    log[row, L_E_AFTER] = e_after
    for i in range(N_STATE):
        log[row, L_STATE + i] = s8[i]


@njit(cache=True, error_model="numpy", _nrt=False)
def write_sample(samp_t, samp_y, samp_mode, row, t, s8, phase, flipped, tau, seg):
    """Store one trajectory sample at ``row``; returns the next row, or -1 if full."""
    if row >= samp_t.shape[0]:
        return -1
    samp_t[row] = t
    for i in range(N_STATE):
        samp_y[row, i] = s8[i]
    samp_mode[row, M_PHASE] = phase
    samp_mode[row, M_FLIPPED] = flipped
    samp_mode[row, M_TORQUE] = tau
    samp_mode[row, M_SEGMENT] = seg
    return row + 1


@njit(cache=True, forceinline=True, error_model="numpy", _nrt=False)
def _min_step(t):
    """scipy's smallest step at ``t``: ten units in the last place [s]."""
    return 10.0 * abs(np.nextafter(t, np.inf) - t)


@njit(cache=True, forceinline=True, error_model="numpy", _nrt=False)
def _finite(y, n):
    # one exit, no early return: numba then drops the per-step reference counting of ``y``
    # (x * 0 is 0 for finite x, NaN for inf and NaN)
    acc = 0.0
    for i in range(n):
        acc += y[i] * 0.0
    return acc == 0.0


def loop_method_kernels(method_code, flies=True):
    """The steps, error norms, dense-output preparation and stage count the loop of
    ``method_code`` (``METHOD_*``) calls (:data:`.integrate.METHOD_KERNELS`); without
    ``flies``, the dense output of a swing step (the loop stops before a flight, and its copy
    without flight, :func:`without_flight`, never types the flight step)."""
    step4, step8, error_sq4, error_sq8, dense_prepare_of_method, n_stages = \
        METHOD_KERNELS[method_code]
    if not flies:
        dense_prepare_of_method = SWING_DENSE_PREPARE[method_code]
    return step4, step8, error_sq4, error_sq8, dense_prepare_of_method, n_stages


#: the suffix and constants of the kernels' copies for runs that never fly
WITHOUT_FLIGHT = ("without_flight", {"FLIES": False})


def without_flight(kernel):
    """``kernel`` as runs that never fly compile it: a copy reading ``FLIES`` as False, itself
    and through the kernels it calls (:func:`.jit.specialised`), named
    ``<name>_without_flight``; ``kernel`` itself when nothing it calls reads ``FLIES``.
    Numba drops the flight branches of such a copy unread: the flight accelerations in the
    vector field and the holding torque are a large part of the loop's compile, and every
    compiled caller links them again."""
    suffix, constants = WITHOUT_FLIGHT
    return specialised(kernel, suffix, **constants)


def loop_callees(method_code):
    """The separately compiled functions the loop of ``method_code`` calls in runs that never
    fly (:func:`without_flight`), each with the numba types of its arguments there, in the
    order the loop's compile first reaches them.

    For compiling ahead (:mod:`monkeystudy.compiling`): another process compiles these into the
    shared cache, last first, while the study's process compiles the loop and reaches them in
    order, loading each one the other has saved. Every function compiled that way must have
    one signature in the loop (numba rewrites a function's whole cache index on each save, so
    two processes saving different signatures of one function at once could each lose or
    misfile the other's); ``tests/test_compiling.py`` checks this list against the loop.
    """
    F, I, B = types.float64, types.int64, types.boolean
    V, M, C = types.float64[::1], types.float64[:, ::1], types.int64[::1]
    method = types.literal(method_code)  # the loop passes its method as a constant
    step4, _, error_sq4, _, dense_prepare_swing, _ = loop_method_kernels(method_code, False)
    return tuple((without_flight(kernel), argtypes) for kernel, argtypes in (
        (apply_magnets, (M, V, I, I, F, F, B)),
        (total_energy8, (V, V)),
        (pack, (I, V, V)),
        (init_friction, (I, V, F, V, V, V, V)),
        (write_sample, (V, M, M, I, F, V, I, I, F, I)),
        (next_tick, (F, F, F)),
        (guard_value, (I, I, F, I, V, F, V, V, V, F)),
        (friction_guard, (I, I, V, F, V, V, V)),
        (rhs, (I, V, F, V, V, V)),
        (select_initial_step, (I, V, F, V, F, V, V, I, F, F, I, F, F, V, V)),
        (guard_rate_value, (I, I, I, V, F, V, V, V, V)),
        (guard_rate_field, (I, I, I, V, F, V, V, V)),
        (step4, (V, F, V, V, V, F, M, V, V, V)),
        (error_sq4, (M, F, V, V, F, F)),
        (guard_trig_value, (I, I, F, I, V, F, V, V, V, F, V)),
        (dense_prepare_swing, (I, V, F, V, F, F, V, V, V, I, M, M, V)),
        (locate_first, (I, I, F, F, F, F, F, F, F, F, method, M, V, F, F, I, I, V, F, V, V, F,
                        V, V)),
        (segment_event_in_step, (I, I, F, F, F, F, F, F, F, F, method, M, V, F, I, I, V, F, V,
                                 V, F, V, V, B, F, F, F, F, B, F, F)),
        (guard_rate_trig_value, (I, I, I, V, F, V, V, V, V, V)),
        (_locate_friction, (I, I, F, F, F, F, method, M, V, F, I, I, V, F, V, V, V)),
        (unpack_into, (I, V, V, V)),
        (dense_eval, (method, M, V, F, F, I, V)),
        (holding_torque, (I, V, F, V, V, I)),
        (write_log, (M, I, F, I, I, I, I, I, F, F, V)),
        (change_friction_mode, (I, I, I, V, F, V, V, V, F, I, C, M, I)),
        (observe_step, (I, M, I, F, F, F, F, B, method, M, V, V, V, I, I, V, F, V, V, F, V,
                        V, V, M, I, I, I, C)),
        (exit_segment, (M, M, I, F, V, I, I, F, F, F, I, I, C, V, M, I, B, V, M, M, I)),
    ))


def simulate_implementation(method_code, flies=True, model: Model = TWO_LINK):
    """The hybrid loop of :func:`simulate` for one integration method (``METHOD_*``), as a
    plain function whose step, error norm and dense output are that method's own (and only
    the swing ones unless ``flies``), and whose model of the robot is ``model``'s kernels:
    :func:`hybrid_loop` compiles it (one specialisation per method, phase set and model,
    which compiles only those steps); interpreted (``NUMBA_DISABLE_JIT``), it runs as it is.

    The model's kernels are globals of the loop's copy, and of copies of every callee that
    calls one of them (:func:`.jit.specialised_globals`, suffix the model's name), as the
    method's steps are; the two-link model's are the kernels every module imports, so its
    loops copy nothing for it.

    The loop: enter a segment (its magnets, :func:`apply_magnets`, then torque, reference
    energy and friction modes), integrate one leg step by step, locating the segment guard's
    event in a step (:func:`segment_event_in_step`), friction events (:func:`_locate_friction`,
    then :func:`change_friction_mode`) and observer crossings on the dense output
    (:func:`observe_step`), and act on the leg's end: a segment's exit (:func:`exit_segment`:
    the controller's clock and cycle count, the next segment's magnets, the impact, the log)
    or a bound. Each named piece is
    compiled on its own. The segment's entry stays in the loop: called as a function of its
    own it makes a gait slower, and inlining the pieces makes a first run longer.
    """
    step4, step8, error_sq4, error_sq8, dense_prepare_of_method, n_stages = \
        loop_method_kernels(method_code, flies)
    scope = dict(globals(), method_code=method_code, n_stages=n_stages,
                 step4=step4, step8=step8, error_sq4=error_sq4, error_sq8=error_sq8,
                 dense_prepare_of_method=dense_prepare_of_method)
    scope = specialised_globals(_hybrid_loop.__code__, scope, model.name, model.kernels)
    if not flies:
        scope = specialised_globals(_hybrid_loop.__code__, scope, *WITHOUT_FLIGHT)
    # the specialisation's choices are globals of its own copy of the loop, not closure
    # cells: numba keys its disk cache on a closure's pickled cells, and a dispatcher
    # pickles differently in every process, so a closure would never load from the cache
    name = f"hybrid_loop_{_METHOD_NAMES[method_code]}_{'flight' if flies else 'swing'}"
    if model != TWO_LINK:
        name += f"_{model.name}"
    loop = FunctionType(_hybrid_loop.__code__, scope, name)
    loop.__qualname__ = name     # numba names its cache files after it
    return loop


# what each compiled loop takes from simulate_implementation, as globals of its own: these
# module-level names are placeholders that no compiled loop sees
method_code = n_stages = None
step4 = step8 = error_sq4 = error_sq8 = dense_prepare_of_method = None


def _hybrid_loop(method, par, prog, obs, settings, hyb_rows, counts_rows, seg_rows, log,
                 samp_t, samp_y, samp_mode):
    """The hybrid loop (:func:`simulate_implementation`), written once: each specialisation
    runs this code with its own ``method_code``, ``FLIES``, steps and error norms."""
    method = method_code  # a constant of this specialisation (the argument names it too)
    rtol = settings[C_RTOL]
    atol = settings[C_ATOL]
    max_seg_time = settings[C_MAX_SEGMENT_TIME]
    t_end = settings[C_T_END]
    max_cycles = int(settings[C_MAX_CYCLES])
    tick = settings[C_TICK]
    tick_phase = settings[C_TICK_PHASE]
    sample_dt = settings[C_SAMPLE_DT]
    max_steps = settings[C_MAX_STEPS]
    max_step = settings[C_MAX_STEP]
    max_drop = settings[C_MAX_DROP]
    band = settings[C_ZERO_BAND]
    err_order = error_estimator_order(method)
    pi_control = settings[C_CONTROLLER] == CONTROLLER_PI

    n_obs = obs.shape[0]
    sampling = sample_dt > 0.0 and samp_t.shape[0] > 0

    K = np.zeros((VERN9_N_STAGES_EXTENDED, 8))   # the largest method's stages
    Fd = np.zeros((VERN9_INTERPOLATOR_POWER, 8))
    # the work vectors are rows of one array, the pairs rows of another: one allocation each
    # per run, not one per vector
    vectors = np.zeros((9, 8))
    y = vectors[0]
    f = vectors[1]
    y_new = vectors[2]
    f_new = vectors[3]
    trig_new = vectors[4]  # sines and cosines at y_new (N_TRIG), left by the step for guards
    ytmp = vectors[5]
    ybuf = vectors[6]
    work = vectors[7]
    s8 = vectors[8]
    pairs = np.zeros((3, 2))
    pivot = pairs[0]
    fmode = pairs[1]
    g_fric = pairs[2]
    g_obs = np.zeros(max(n_obs, 1))

    status = -1
    for run in range(hyb_rows.shape[0]):
        # each row is a run of its own, from work arrays as a new call's
        hyb = hyb_rows[run]
        counts = counts_rows[run]
        seg_times = seg_rows[run]
        if run > 0:
            K[:, :] = 0.0
            Fd[:, :] = 0.0
            vectors[:, :] = 0.0
            pairs[:, :] = 0.0
            g_obs[:] = 0.0
        en_prev = 1.0  # the PI controller's previous accepted error norm
        for i in range(N_STATE):
            s8[i] = hyb[i]
        t = hyb[H_T]
        phase = int(hyb[H_PHASE])
        flipped = int(hyb[H_FLIPPED])
        seg = int(hyb[H_SEG])
        tau = hyb[H_TORQUE]
        eref = hyb[H_EREF]
        clock0 = hyb[H_CLOCK]
        fmode[0] = hyb[H_FMODE0]
        fmode[1] = hyb[H_FMODE1]
        cycles = int(hyb[H_CYCLES])
        y_ref = hyb[H_Y_REF]
        if not math.isfinite(y_ref):
            y_ref = s8[Y]
        for i in range(seg_times.shape[0]):
            seg_times[i] = np.nan

        n_log = int(counts[K_LOG])
        n_samp = int(counts[K_SAMPLES])
        next_k = 0
        if sampling:
            next_k = int(math.floor(t / sample_dt)) + 1  # the entry sample covers t itself

        status = -1
        entering = True
        magnets_done = False  # entry magnet actions already applied (to log the impact)
        seg_start = t
        pending = np.inf      # tick at which a located ticked guard will be acted on
        pending_sign = 0.0    # guard sign before that crossing ("either" direction)
        delayed_exit = np.inf  # a state guard fired: the exit waits until then (S_DELAY)
        n = 4

        while status < 0:
            p = par[flipped]
            if entering:
                if not magnets_done:
                    phase, flipped = apply_magnets(par, s8, phase, flipped, prog[seg, S_MAG_A],
                                                   prog[seg, S_MAG_B], prog[seg, S_SWAP] > 0)
                magnets_done = False
                if not FLIES and phase == PHASE_FLIGHT:
                    # compiled without the flight steps: the caller said the program cannot
                    # release every magnet (controllers.program_may_fly), and it did
                    status = ST_STEP_FAILURE
                    break
                p = par[flipped]
                tau = prog[seg, S_TORQUE]
                if prog[seg, S_SET_EREF] > 0:
                    eref = total_energy8(p, s8)
                n = pack(phase, s8, y)
                pivot[0] = s8[X]
                pivot[1] = s8[Y]
                init_friction(phase, p, tau, s8, fmode, y, pivot)
                seg_start = t
                pending = np.inf
                if sampling:
                    n_samp = write_sample(samp_t, samp_y, samp_mode, n_samp, t, s8, phase,
                                          flipped, tau, seg)
                    if n_samp < 0:
                        status = ST_BUFFER_FULL
                        break
                # the fall is measured from the route's planned height of this cycle
                y_plan = y_ref
                if prog[seg, S_RISE] != 0.0:
                    y_plan = y_ref + cycles * prog[seg, S_RISE]
                if phase == PHASE_SWING and s8[Y] < y_plan - max_drop:
                    status = ST_FELL
                    break
            # ------------------------------------------------------------------ one leg
            gkind = int(prog[seg, S_GUARD])
            gindex = int(prog[seg, S_GINDEX])
            gvalue = prog[seg, S_GVALUE]
            gdir = prog[seg, S_GDIR]
            if gkind == G_FREE_END_Y and prog[seg, S_RISE] != 0.0:
                # a world height on the route's staircase: cycle k's is k rises higher
                gvalue = gvalue + cycles * prog[seg, S_RISE]
            # a catch on a bar is the free end's height guard with a window and a snap; the
            # hook meets the bar when it does, never on a controller tick
            bar = gkind == G_BAR
            if bar:
                gkind = G_FREE_END_HEIGHT
            ticked = prog[seg, S_TICKED] > 0 and tick > 0.0 and not bar
            state_guard = gkind != G_NONE and gkind != G_TIME
            horizon = seg_start + max_seg_time
            t_limit = min(horizon, t_end)
            t_target = np.inf
            if delayed_exit < np.inf:
                # the guard has fired; only the latency is left: a time leg without a guard
                state_guard = False
                gkind = G_TIME
                t_target = delayed_exit
            elif gkind == G_TIME:
                t_target = clock0 + gvalue
                if ticked:
                    t_target = next_tick(t_target, tick, tick_phase)
                if prog[seg, S_DELAY] != 0.0:
                    t_target += prog[seg, S_DELAY]
                if t_target < t:
                    t_target = t
            t_stop = min(t_limit, t_target)
            n = pack(phase, s8, y)
            pivot[0] = s8[X]
            pivot[1] = s8[Y]

            fired = False       # the segment's guard fired at time t (state at t in y/s8)
            # a friction mode change at time t. np.int64, here and for the log kinds: numba
            # types a bare constant as a literal and compiles each callee it reaches once
            # more for that literal (holding_torque, write_log)
            fric_k = np.int64(-1)
            level_fire = False
            if state_guard:
                g_seg = guard_value(gkind, gindex, gvalue, phase, p, tau, fmode, y, pivot, eref)
                scale = 1.0 + abs(gvalue)
                if gkind == G_ENERGY_RESTORED:
                    scale = 1.0 + abs(eref) + abs(gvalue)
                if entering and abs(g_seg) <= band * scale:
                    g_seg = 0.0
                if gkind == G_ENERGY_RESTORED and entering and g_seg >= 0.0:
                    level_fire = True
            else:
                g_seg = 0.0
            for k in range(n_obs):
                if obs[k, O_SEGMENT] >= 0 and int(obs[k, O_SEGMENT]) != seg:
                    continue
                g_obs[k] = guard_value(int(obs[k, O_GUARD]), int(obs[k, O_GINDEX]),
                                       obs[k, O_GVALUE], phase, p, tau, fmode, y, pivot, eref)
                if abs(g_obs[k]) <= band * (1.0 + abs(obs[k, O_GVALUE])):
                    g_obs[k] = 0.0
            # friction DOFs watched on this leg (fixed along it; tested once, not on every step)
            fric0 = friction_active(0, phase, p)
            fric1 = friction_active(1, phase, p)
            for k in range(2):
                if fric0 if k == 0 else fric1:
                    g_fric[k] = friction_guard(k, phase, p, tau, fmode, y, pivot)
            entering = False

            if level_fire or (gkind == G_TIME and t_target <= t):
                fired = True
            elif phase == PHASE_FIXED:
                # nothing moves: only time passes (samples stay put)
                t_new = t_stop
                if sampling:
                    while next_k * sample_dt <= t_new:
                        n_samp = write_sample(samp_t, samp_y, samp_mode, n_samp,
                                              next_k * sample_dt, s8, phase, flipped, tau, seg)
                        if n_samp < 0:
                            status = ST_BUFFER_FULL
                            break
                        next_k += 1
                t = t_new
                if t == t_target:
                    fired = True
            else:
                rhs(phase, p, tau, fmode, y, f)
                h_abs = select_initial_step(phase, p, tau, fmode, t, y, f, n, t_stop, max_step,
                                            err_order, rtol, atol, ytmp, f_new)
                counts[K_NFEV] += 2
                en_prev = 1.0  # a leg starts the PI controller afresh, as the integrator restarts
                r_seg = 0.0
                if state_guard:
                    r_seg = guard_rate_value(gkind, gindex, phase, p, tau, fmode, y, pivot, work)
                while True:
                    bound = min(t_stop, pending)
                    if t >= bound:
                        break
                    # ---- one adaptive step (scipy's RungeKutta._step_impl) ----
                    # scipy's min_step, 10 ulp(t), is at most 10 eps |t| (+ a subnormal at t = 0):
                    # the nextafter call is only needed for a step below that
                    tiny = 10.0 * EPS * abs(t) + 1e-300
                    if h_abs > max_step:
                        h_abs = max_step
                    elif h_abs < tiny and h_abs < _min_step(t):
                        h_abs = _min_step(t)
                    rejected = False
                    ok = True
                    while True:
                        if h_abs < tiny and h_abs < _min_step(t):
                            ok = False
                            break
                        t_new = t + h_abs
                        if t_new > bound:
                            t_new = bound
                        h = t_new - t
                        h_abs = abs(h)
                        # the method's straight-line steps, called directly: through a wrapper
                        # (inlined or called) numba reference-counts the eight arrays on every
                        # step (atomic operations). The controller works on the squared norm
                        # en_sq (see integrate.error_power_sq). A loop that never flies has no
                        # flight step.
                        if not FLIES or n == 4:
                            step4(p, tau, fmode, y, f, h, K, trig_new, y_new, f_new)
                            en_sq = error_sq4(K, h, y, y_new, rtol, atol)
                        else:
                            step8(p, tau, fmode, y, f, h, K, trig_new, y_new, f_new)
                            en_sq = error_sq8(K, h, y, y_new, rtol, atol)
                        counts[K_NFEV] += n_stages
                        if en_sq < 1.0:
                            if pi_control:
                                en = math.sqrt(en_sq)
                                factor = pi_factor(en, en_prev, err_order)
                                en_prev = max(en, PI_ERR_FLOOR)
                            else:
                                # en_sq = 0 gives an infinite power: MAX_FACTOR
                                factor = min(MAX_FACTOR, SAFETY * error_power_sq(method, en_sq))
                            if rejected:
                                factor = min(1.0, factor)
                            h_abs *= factor
                            break
                        h_abs *= max(MIN_FACTOR, SAFETY * error_power_sq(method, en_sq))
                        rejected = True
                        counts[K_REJECTED] += 1
                    if not ok:
                        status = ST_STEP_FAILURE
                        break
                    counts[K_STEPS] += 1
                    if counts[K_STEPS] > max_steps:
                        status = ST_STEP_FAILURE
                        break
                    if not _finite(y_new, n):
                        status = ST_NONFINITE
                        break
                    dense = False
                    t_ev = np.inf
                    # ---- segment guard ----
                    if state_guard and pending == np.inf:
                        # guard and rate from the step's sines and cosines; the vector field's
                        # call kept out of inlined code (numba would reference-count its arrays)
                        if rate_uses_field(gkind, gindex):
                            gb = guard_trig_value(gkind, gindex, gvalue, phase, p, tau, fmode,
                                                  y_new, pivot, eref, trig_new)
                            rb = guard_rate_field(gkind, gindex, phase, p, tau, fmode, y_new, work)
                        else:
                            gb, rb = guard_and_rate_step(gkind, gindex, gvalue, phase, p, tau,
                                                         fmode, y_new, pivot, eref, trig_new)
                        if (crosses(g_seg, gb, gdir)
                                or hermite_flags(g_seg, r_seg, gb, rb, h, gdir)):
                            if not dense:
                                counts[K_NFEV] += dense_prepare_of_method(
                                    phase, p, tau, fmode, t, h, y, y_new, f_new, n, K, Fd, ytmp)
                                dense = True
                            t_ev, pending, pending_sign = segment_event_in_step(
                                gkind, gindex, gvalue, gdir, t, t_new, g_seg, gb, r_seg, rb,
                                method, Fd, y, h, n, phase, p, tau, fmode, pivot, eref, ybuf,
                                work, ticked, tick, tick_phase, pending, pending_sign, bar,
                                prog[seg, S_BAR_DX], prog[seg, S_BAR_WINDOW])
                        g_seg = gb
                        r_seg = rb
                    elif state_guard and t_new == pending:
                        gb = guard_trig_value(gkind, gindex, gvalue, phase, p, tau, fmode, y_new,
                                              pivot, eref, trig_new)
                        if (gdir > 0 and gb >= 0.0) or (gdir < 0 and gb <= 0.0) or \
                                (gdir == 0 and gb * pending_sign <= 0.0):
                            t_ev = t_new
                        pending = np.inf
                        g_seg = gb
                        r_seg = guard_rate_trig_value(gkind, gindex, phase, p, tau, fmode, y_new,
                                                      pivot, work, trig_new)
                    if t_new == t_target and t_target < t_ev:
                        t_ev = t_new
                    seg_event = t_ev < np.inf
                    # ---- friction events (earliest, strictly before any segment event) ----
                    fric_k = np.int64(-1)
                    for k in range(2):
                        if not (fric0 if k == 0 else fric1):
                            continue
                        gb = friction_guard(k, phase, p, tau, fmode, y_new, pivot)
                        fkind = G_STICK_BREAK if fmode[k] == 0.0 else G_SLIP_STOP
                        fdir = 1.0 if fkind == G_STICK_BREAK else -1.0
                        if crosses(g_fric[k], gb, fdir):
                            if not dense:
                                counts[K_NFEV] += dense_prepare_of_method(
                                    phase, p, tau, fmode, t, h, y, y_new, f_new, n, K, Fd, ytmp)
                                dense = True
                            tc = _locate_friction(k, fkind, t, t_new, g_fric[k], gb, method, Fd,
                                                  y, h, n, phase, p, tau, fmode, pivot, ybuf)
                            if tc < t_ev:
                                t_ev = tc
                                fric_k = k
                                seg_event = False
                        g_fric[k] = gb
                    # ---- observers (non-terminal, up to the event) ----
                    t_cut = min(t_ev, t_new)
                    if n_obs > 0:
                        # one call site: a second one, after dense = True, would pass a
                        # literal and compile the piece once more
                        k_obs = np.int64(0)
                        for _pass in range(2):
                            n_log, ostatus, k_obs = observe_step(
                                k_obs, obs, seg, t, t_new, t_cut, h, dense, method, Fd, y,
                                y_new, trig_new, n, phase, p, tau, fmode, pivot, eref, work,
                                ybuf, g_obs, log, n_log, cycles, flipped, counts)
                            if ostatus != NEED_DENSE:
                                break
                            counts[K_NFEV] += dense_prepare_of_method(
                                phase, p, tau, fmode, t, h, y, y_new, f_new, n, K, Fd, ytmp)
                            dense = True
                        if ostatus >= 0:
                            status = ostatus
                    if status >= 0:
                        break
                    # ---- samples on the grid, up to the event ----
                    if sampling:
                        while next_k * sample_dt <= t_cut:
                            ts = next_k * sample_dt
                            if not dense:
                                counts[K_NFEV] += dense_prepare_of_method(
                                    phase, p, tau, fmode, t, h, y, y_new, f_new, n, K, Fd, ytmp)
                                dense = True
                            dense_eval(method, Fd, y, h, (ts - t) / h, n, ybuf)
                            unpack_into(phase, ybuf, pivot, work)
                            n_samp = write_sample(samp_t, samp_y, samp_mode, n_samp, ts, work,
                                                  phase, flipped, tau, seg)
                            if n_samp < 0:
                                status = ST_BUFFER_FULL
                                break
                            next_k += 1
                        if status >= 0:
                            break
                    # ---- advance ----
                    if t_ev < np.inf:
                        if t_ev == t_new:
                            for i in range(n):
                                y[i] = y_new[i]
                        else:
                            dense_eval(method, Fd, y, h, (t_ev - t) / h, n, ybuf)
                            for i in range(n):
                                y[i] = ybuf[i]
                        t = t_ev
                        if seg_event:
                            fired = True
                        break
                    t = t_new
                    for i in range(n):
                        y[i] = y_new[i]
                        f[i] = f_new[i]
                unpack_into(phase, y, pivot, s8)
                if status >= 0:
                    break

            # ------------------------------------------------------------------ leg outcome
            if fric_k >= 0:
                n_log, status = change_friction_mode(fric_k, phase, flipped, p, tau, fmode, s8,
                                                     y, t, cycles, counts, log, n_log)
                continue
            if fired and delayed_exit == np.inf and int(prog[seg, S_GUARD]) != G_TIME and \
                    prog[seg, S_DELAY] > 0.0:
                delayed_exit = t + prog[seg, S_DELAY]
                continue
            if fired:
                delayed_exit = np.inf
                # a catch's bar, in the world: dx, dy from the end the robot hangs from
                caught = bar and phase == PHASE_SWING
                bar_x = s8[X] + prog[seg, S_BAR_DX]
                bar_y = s8[Y] + gvalue
                flipped_before = flipped
                status, seg, phase, flipped, clock0, cycles, n_log, n_samp = exit_segment(
                    par, prog, seg, t, s8, phase, flipped, tau, gvalue, clock0, cycles,
                    max_cycles, counts, seg_times, log, n_log, sampling, samp_t, samp_y,
                    samp_mode, n_samp)
                if status >= 0:
                    break
                if caught and phase == PHASE_SWING and flipped != flipped_before:
                    # the snap: the groove guides the bar in, a rigid translation of the
                    # robot putting the new attached end on the bar (angles and rates kept);
                    # the log row holds the state before it, so the catch offset is an output
                    s8[X] = bar_x
                    s8[Y] = bar_y
                entering = True
                magnets_done = True   # the next segment's magnets (the impact, in the log)
                continue
            # no event: the leg ended on a bound
            if t >= t_end:
                status = ST_END_TIME
            elif t >= horizon:
                fail = int(prog[seg, S_FAIL])
                status = fail if fail > 0 else ST_HORIZON

        # ---------------------------------------------------------------------- write back
        for i in range(N_STATE):
            hyb[i] = s8[i]
        hyb[H_T] = t
        hyb[H_PHASE] = phase
        hyb[H_FLIPPED] = flipped
        hyb[H_SEG] = seg
        hyb[H_TORQUE] = tau
        hyb[H_EREF] = eref
        hyb[H_CLOCK] = clock0
        hyb[H_FMODE0] = fmode[0]
        hyb[H_FMODE1] = fmode[1]
        hyb[H_CYCLES] = cycles
        hyb[H_Y_REF] = y_ref
        counts[K_CYCLES] = cycles
        counts[K_LOG] = n_log
        counts[K_SAMPLES] = n_samp
        counts[K_STATUS] = status
    return status


#: the name of each method in the names of its compiled loops
_METHOD_NAMES = {METHOD_RK45: "rk45", METHOD_DOP853: "dop853", METHOD_VERN9: "vern9"}


#: the compiled loop of each (method, flies, model) made in this process: :func:`hybrid_loop`
_LOOPS = {}


def hybrid_loop(method_code, flies=True, model: Model = TWO_LINK):
    """The compiled hybrid loop of one integration method (``METHOD_*``), phase set (only
    the swing steps unless ``flies``) and model of the robot (:class:`.jit.Model`, the
    two-link robot of :mod:`.dynamics` by default): a numba dispatcher of
    :func:`simulate_implementation`, named ``hybrid_loop_<method>_<swing|flight>`` (with
    ``_<model>`` after it for a model other than the two-link one), made once per process
    (two dispatchers of one function, both loading its cached compile, would define the same
    symbols twice).

    Cached on disk under its name: :func:`simulate` and every compiled caller (gait
    evaluations, survival, design), in any process, link that one compile, where a loop
    compiled as part of each caller would be compiled again by each process that needs it
    (the loop is most of a first run's compile). Its own name gives each specialisation its
    own cache index, so processes saving different specialisations at once cannot misfile
    them. :func:`simulate` and the compiled callers (:func:`simulate_loop`) run the two-link
    model's loops.
    """
    key = (int(method_code), bool(flies), model)
    if key not in _LOOPS:
        _LOOPS[key] = njit(cache=True, error_model="numpy")(simulate_implementation(*key))
    return _LOOPS[key]


def hybrid_loops():
    """The compiled loops :func:`hybrid_loop` has made in this process (numba dispatchers)."""
    return tuple(_LOOPS.values())


def simulate(method, par, prog, obs, settings, hyb, counts, seg_times, log, samp_t, samp_y,
             samp_mode):
    """Run a controller program from the hybrid state ``hyb``, or from each row of a batch of
    them; returns a status ``ST_*`` (the last row's; each row's is in ``counts[:, K_STATUS]``).

    The entry for Python callers: calls the compiled loop of the method and phase set that
    ``method``'s type names (:func:`hybrid_loop`). Compiled kernels call
    :func:`simulate_loop`, which calls the same compiled loop. A batch (a gait map's points)
    is one call: no compiled function of its own links the loop (a first run's compile), and
    no Python between two runs.

    Parameters
    ----------
    method : numpy scalar
        The integrator (``settings[C_METHOD]`` as :func:`.integrate.method_scalar`): its type
        makes each method, with or without flight, its own specialisation, which compiles only
        those steps.
    par : float64[2, N_PARAMS]
        Robot parameters, row 0 as given, row 1 flipped (docs/model.md section 3).
    prog : float64[n_seg, N_SEG_COLS]
        Controller program (layout ``S_*``).
    obs : float64[n_obs, N_OBS_COLS]
        Observers: guards whose crossings are logged (layout ``O_*``).
    settings : float64[N_SETTINGS]
        Integrator and run settings (layout ``C_*``).
    hyb : float64[N_HYB] or float64[n_runs, N_HYB]
        Hybrid state (layout ``H_*``), updated in place to the final state. On input,
        ``hyb[H_SEG]`` is the segment to enter at ``hyb[H_T]``. A batch: one run per row.
    counts : int64[N_COUNTS] or int64[n_runs, N_COUNTS]
        Accumulated counters (steps, rejected steps, RHS evaluations, events, ...) and the
        run's status (``K_STATUS``).
    seg_times : float64[n_seg] or float64[n_runs, n_seg]
        Time of the latest exit from each segment [s] (NaN if never left).
    log : float64[cap, N_LOG_COLS]
        Event log: segment exits, observer crossings, friction changes (capacity 0: none).
        The runs of a batch share it, each writing from its own ``counts[K_LOG]``.
    samp_t, samp_y, samp_mode : float64 arrays
        Trajectory samples every ``C_SAMPLE_DT`` from the dense output, plus the states just
        before and after each segment transition (capacity 0: none). Shared as ``log`` is.
    """
    choice = choice_of_type(typeof(method))
    if choice is None:
        raise TypeError("method must be a scalar of integrate.method_scalar, not "
                        f"{type(method).__name__}")
    if hyb.ndim == 1:    # one run: a batch of one (views, updated in place)
        hyb, counts, seg_times = hyb[None], counts[None], seg_times[None]
    return hybrid_loop(*choice)(method, par, prog, obs, settings, hyb, counts, seg_times, log,
                                samp_t, samp_y, samp_mode)


def simulate_loop(method, par, prog, obs, settings, hyb, counts, seg_times, log, samp_t,
                  samp_y, samp_mode):
    """:func:`simulate` for compiled kernels: a call of the compiled loop that ``method``'s
    type names (typed and lowered below as a call of :func:`hybrid_loop`'s dispatcher, whose
    cached compile the caller links; interpreted, it is :func:`simulate`). ``hyb``,
    ``counts`` and ``seg_times`` are batches (2-d), a single run's a batch of one
    (``hyb.reshape((1, N_HYB))``)."""
    return simulate(method, par, prog, obs, settings, hyb, counts, seg_times, log, samp_t,
                    samp_y, samp_mode)


def _loop_call_type(typing_context, args):
    """The dispatcher type of the loop that ``args[0]`` (a method scalar type) names and its
    signature for ``args`` (compiling or loading it), or None for another type."""
    choice = choice_of_type(args[0])
    if choice is None:
        return None, None   # not a method scalar: numba reports no implementation
    loop_type = types.Dispatcher(hybrid_loop(*choice))
    return loop_type, loop_type.get_call_type(typing_context, args, {})


@type_callable(simulate_loop)
def _type_simulate_loop(context):
    def typer(method, par, prog, obs, settings, hyb, counts, seg_times, log, samp_t, samp_y,
              samp_mode):
        _, sig = _loop_call_type(context, (method, par, prog, obs, settings, hyb, counts,
                                           seg_times, log, samp_t, samp_y, samp_mode))
        return None if sig is None else sig.return_type
    return typer


@lower_builtin(simulate_loop, types.VarArg(types.Any))
def _lower_simulate_loop(context, builder, sig, args):
    loop_type, loop_sig = _loop_call_type(context.typing_context, sig.args)
    args = [context.cast(builder, value, have, want)
            for value, have, want in zip(args, sig.args, loop_sig.args)]
    return context.get_function(loop_type, loop_sig)(builder, args)


@njit(cache=True, error_model="numpy", _nrt=False)
def _locate_friction(k, fkind, t0, t1, ga, gb, method, Fd, y_old, h, n, phase, p, tau, fmode,
                     pivot, ybuf):
    """Bisection-secant (Illinois) root of a friction guard bracketed on [t0, t1]."""
    a = t0
    b = t1
    fa = ga
    fb = gb
    side = 0
    for _ in range(200):
        if abs(b - a) <= 4e-16 * (1.0 + abs(b)):
            break
        c = (a * fb - b * fa) / (fb - fa)
        if not (a < c < b):
            c = 0.5 * (a + b)
        dense_eval(method, Fd, y_old, h, (c - t0) / h, n, ybuf)
        if fmode[k] == 0.0:
            cc = p[P_C_PIVOT] if k == 0 else p[P_C_JOINT]
            fc = abs(holding_torque(phase, p, tau, fmode, ybuf, k)) - cc
        else:
            fc = slip_speed(k, phase, fmode, ybuf, pivot)
        if fc == 0.0:
            return c
        if (fc > 0.0) == (fb > 0.0):
            b = c
            fb = fc
            if side == 1:
                fa *= 0.5
            side = 1
        else:
            a = c
            fa = fc
            if side == -1:
                fb *= 0.5
            side = -1
    return b
