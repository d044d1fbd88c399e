"""Fixed points of a gait's return map under a parametrised program (compiled).

A design is a controller program and a robot; its gait is a fixed point of the return map on
the section. :func:`fixed_point` finds it by Newton's method on ``F(u) = 0`` with

* ``u = (w, q)``: the section state ``w`` and, when ``balance`` is set, one program parameter
  ``q`` the program depends on affinely (``prog = prog0 + q * dprog``: a pulse's torque, or
  the times after a pulse that lengthens);
* ``F = (P(w) - w, y')``: the map's defect and, with ``balance``, the height ``y'`` [m] of
  the attached end after the cycle, so that the solved gait stays horizontal (an open-loop
  schedule fixes no height: its fixed points generally climb or sink a little every cycle).

The section state is ``w = (theta2, dtheta1, dtheta2)`` on ``theta1 = theta1_section`` (the
program's clock restarts there). The cycle starts hanging from end A at the origin and ends in
the frame of the end attached then, with ``theta2`` continued across whole turns so the map is
smooth.

Newton's Jacobian is second-order central differences (a relative step ``h`` ~ 1e-5 leaves
an error ~1e-10, which still converges as fast as Newton to the tolerance); the multipliers'
matrix ``DP = dP/dw`` at the solution is fourth order (Richardson on ``h`` and ``2h``). The
whole solve stays in compiled code. A start that leads nowhere is given up early: most
designs of a landscape have no gait, and a Newton run that stalls costs a full solve per
iteration (see :func:`fixed_point`).
"""
import math

import numpy as np

from .gait import start_state, wrapped_difference
from .hybrid import simulate_loop
from .jit import njit
from .layout import (
    C_MAX_CYCLES, DTH1, DTH2, H_T, K_LOG, K_NFEV, L_E_AFTER, L_E_BEFORE, L_KIND, LOG_SEGMENT,
    N_COUNTS, N_HYB, N_LOG_COLS, N_MODE_COLS, ST_OK, TH1, TH2, X, Y,
)

#: dimension of the section state ``(theta2, dtheta1, dtheta2)``
N_SECTION = 3

#: outcomes of :func:`fixed_point`
DS_OK = 0             # converged: |F| within the tolerance
DS_NO_CYCLE = 1       # the program does not complete a cycle from the start
DS_STENCIL = 2        # a finite-difference point left the gait (an event appeared or vanished)
DS_NOT_CONVERGED = 3  # no Newton step reduced |F| further, or the iterations ran out
DESIGN_STATUS_NAMES = ("ok", "no_cycle", "stencil_failed", "not_converged")

# columns of a fixed point's record (``info``)
I_ITERATIONS = 0   # Newton iterations taken
I_DEFECT = 1       # |F| at the solution [rad, rad s-1, m]
I_ERROR = 2        # squared section error |P(w) - w|^2 (the study's error measure)
I_RISE = 3         # height of the attached end after one cycle [m]
I_ADVANCE = 4      # horizontal advance of the attached end per cycle [m]
I_LOSS = 5         # energy lost at the cycle's resets (impacts) [J]
I_PERIOD = 6       # duration of the cycle [s]
I_MAP_STATUS = 7   # kernel status ``ST_*`` of the run that failed (ST_OK otherwise)
I_NFEV = 8         # right-hand-side evaluations of the whole solve
N_INFO = 9

#: event-log rows one cycle may use
LOG_ROWS = 64
#: step halvings of Newton's line search before it gives up (a step of 2**-10 that does not
#: reduce |F| marks a start far from any gait)
MAX_HALVINGS = 10
#: Newton gives up when |F| fell by less than STALL_FACTOR over the last STALL_STEPS steps.
#: On 338 Newton runs of the design landscape's first designs (studies/design_landscape.yaml)
#: every run that converged within 12 steps kept shrinking |F| faster than this, while most
#: that did not sat on a plateau for their remaining steps, each costing a full stencil.
STALL_STEPS = 4
STALL_FACTOR = 1.25


@njit(cache=True, error_model="numpy")
def cycle_map(method, par, prog, obs, settings, theta1_section, w, w_next, log, counts):
    """One cycle of ``prog`` from the section state ``w``; writes the next section state into
    ``w_next`` and returns ``(status, y', x', energy lost [J], duration [s])``.

    ``settings[C_MAX_CYCLES]`` must be 1. ``log`` (capacity 0: none) receives the cycle's
    events (for the energy lost at resets).
    """
    hyb = np.empty(N_HYB)
    start_state(w[1], w[2], hyb)
    hyb[TH1] = theta1_section
    hyb[TH2] = w[0]
    counts[K_LOG] = 0
    seg_times = np.empty(prog.shape[0])
    status = simulate_loop(method, par, prog, obs, settings, hyb.reshape((1, N_HYB)),
                           counts.reshape((1, N_COUNTS)), seg_times.reshape((1, prog.shape[0])),
                           log, np.empty(0), np.empty((0, 8)), np.empty((0, N_MODE_COLS)))
    loss = 0.0
    for r in range(int(counts[K_LOG])):
        if log[r, L_KIND] == LOG_SEGMENT:
            loss += log[r, L_E_BEFORE] - log[r, L_E_AFTER]
    w_next[0] = w[0] + wrapped_difference(hyb[TH2], w[0])
    w_next[1] = hyb[DTH1]
    w_next[2] = hyb[DTH2]
    return status, hyb[Y], hyb[X], loss, hyb[H_T]


@njit(cache=True, error_model="numpy")
def clocked_map(method, par, prog, obs, settings, x, x_next, counts):
    """One cycle of a running-clock program (its last row ends at a fixed clock time) from
    ``x = (theta1, theta2 [rad], dtheta1, dtheta2 [rad s-1])`` at clock phase zero, hanging
    from A at the origin; writes the state at the cycle's end (in the frame of the end
    attached then, angles continued across whole turns) into ``x_next`` and returns the
    kernel status. ``settings[C_MAX_CYCLES]`` must be 1."""
    hyb = np.empty(N_HYB)
    start_state(x[2], x[3], hyb)
    hyb[TH1] = x[0]
    hyb[TH2] = x[1]
    seg_times = np.empty(prog.shape[0])
    status = simulate_loop(method, par, prog, obs, settings, hyb.reshape((1, N_HYB)),
                           counts.reshape((1, N_COUNTS)), seg_times.reshape((1, prog.shape[0])),
                           np.empty((0, N_LOG_COLS)), np.empty(0), np.empty((0, 8)),
                           np.empty((0, N_MODE_COLS)))
    x_next[0] = x[0] + wrapped_difference(hyb[TH1], x[0])
    x_next[1] = x[1] + wrapped_difference(hyb[TH2], x[1])
    x_next[2] = hyb[DTH1]
    x_next[3] = hyb[DTH2]
    return status


@njit(cache=True, error_model="numpy")
def clocked_jacobian(method, par, prog, obs, settings, x, h, DP, x_next):
    """The running-clock map's value at ``x`` (into ``x_next``) and its Jacobian ``dP/dx``
    (into ``DP``) by fourth-order central differences (relative steps ``h`` and ``2 h``);
    returns ``(status, right-hand-side evaluations)``: ``ST_OK`` or the status of the first
    run that failed."""
    n = x.shape[0]
    settings1 = settings.copy()
    settings1[C_MAX_CYCLES] = 1.0
    counts = np.zeros(N_COUNTS, dtype=np.int64)
    DP[:, :] = np.nan
    status = clocked_map(method, par, prog, obs, settings1, x, x_next, counts)
    if status != ST_OK:
        return status, counts[K_NFEV]
    xp = x.copy()
    fp = np.empty(n)
    fm = np.empty(n)
    col = np.empty((2, n))
    for j in range(n):
        hj = h * max(1.0, abs(x[j]))
        for k in range(2):
            step = hj * (k + 1)
            xp[j] = x[j] + step
            sp = clocked_map(method, par, prog, obs, settings1, xp, fp, counts)
            xp[j] = x[j] - step
            sm = clocked_map(method, par, prog, obs, settings1, xp, fm, counts)
            xp[j] = x[j]
            if sp != ST_OK:
                return sp, counts[K_NFEV]
            if sm != ST_OK:
                return sm, counts[K_NFEV]
            for i in range(n):
                col[k, i] = (fp[i] - fm[i]) / (2.0 * step)
        for i in range(n):
            DP[i, j] = (4.0 * col[0, i] - col[1, i]) / 3.0
    return ST_OK, counts[K_NFEV]


@njit(cache=True, error_model="numpy")
def residual(method, par, prog0, dprog, obs, settings, theta1_section, balance, u, prog, F,
             counts):
    """``F(u)`` into ``F`` (see the module docstring); returns the kernel status of the run.
    ``prog`` is work space for ``prog0 + u[n] * dprog``."""
    n = N_SECTION
    q = u[n] if balance else 0.0
    for i in range(prog.shape[0]):
        for j in range(prog.shape[1]):
            prog[i, j] = prog0[i, j] + q * dprog[i, j]
    w_next = np.empty(n)
    status, rise, _, _, _ = cycle_map(method, par, prog, obs, settings, theta1_section, u[:n],
                                      w_next, np.empty((0, N_LOG_COLS)), counts)
    for i in range(n):
        F[i] = w_next[i] - u[i]
    if balance:
        F[n] = rise
    return status


@njit(cache=True, error_model="numpy")
def jacobian(method, par, prog0, dprog, obs, settings, theta1_section, balance, u, h, prog, J,
             counts, order=4):
    """``dF/du`` by central differences into ``J``: fourth order (steps ``h * max(1, |u_j|)``
    and twice that, Richardson) or, with ``order=2``, second order (the first step alone);
    returns ``ST_OK`` or the status of the first stencil run that failed."""
    m = u.shape[0]
    up = u.copy()
    Fp = np.empty(m)
    Fm = np.empty(m)
    col = np.empty((2, m))
    n_steps = 1 if order == 2 else 2
    for j in range(m):
        hj = h * max(1.0, abs(u[j]))
        for k in range(n_steps):
            step = hj * (k + 1)
            up[j] = u[j] + step
            sp = residual(method, par, prog0, dprog, obs, settings, theta1_section, balance, up,
                          prog, Fp, counts)
            up[j] = u[j] - step
            sm = residual(method, par, prog0, dprog, obs, settings, theta1_section, balance, up,
                          prog, Fm, counts)
            up[j] = u[j]
            if sp != ST_OK:
                return sp
            if sm != ST_OK:
                return sm
            for i in range(m):
                col[k, i] = (Fp[i] - Fm[i]) / (2.0 * step)
        for i in range(m):
            J[i, j] = col[0, i] if n_steps == 1 else (4.0 * col[0, i] - col[1, i]) / 3.0
    return ST_OK


@njit(cache=True, error_model="numpy")
def _norm(v):
    s = 0.0
    for x in v:
        s += x * x
    return math.sqrt(s)


@njit(cache=True, error_model="numpy")
def balance_start(method, par, prog0, dprog, obs, settings, theta1_section, u, prog, F, counts):
    """Secant steps on the balance value ``u[n]`` alone (the state ``u[:n]`` held) towards
    zero height change per cycle; ``u[n]`` is kept unchanged unless the height shrinks."""
    n = N_SECTION
    q0 = u[n]
    s0 = residual(method, par, prog0, dprog, obs, settings, theta1_section, True, u, prog, F,
                  counts)
    if s0 != ST_OK:
        return
    best_q, best_r = q0, abs(F[n])
    r0 = F[n]
    q1 = q0 + 1e-3 * max(1.0, abs(q0))
    for _ in range(12):
        u[n] = q1
        s1 = residual(method, par, prog0, dprog, obs, settings, theta1_section, True, u, prog,
                      F, counts)
        if s1 != ST_OK:
            break
        r1 = F[n]
        if abs(r1) < best_r:
            best_q, best_r = q1, abs(r1)
        if best_r < 1e-12 or r1 == r0:
            break
        q2 = q1 - r1 * (q1 - q0) / (r1 - r0)
        q0, r0 = q1, r1
        q1 = q2
    u[n] = best_q


@njit(cache=True, error_model="numpy")
def fixed_point(method, par, prog0, dprog, obs, settings, theta1_section, balance, u0, tol,
                max_iter, h, u, DP, info):
    """Newton's method on ``F(u) = 0`` from ``u0``; the solution in ``u``, the map's Jacobian
    ``dP/dw`` at fixed program parameter in ``DP``, the record in ``info`` (``I_*``).
    Returns ``DS_*``.

    Each step solves ``J du = -F`` (``J`` second order) in the least-squares sense and is
    halved up to :data:`MAX_HALVINGS` times until ``|F|`` decreases. Converged when ``|F| <=
    tol``; ``h`` is the relative finite-difference step. Not converged when no halved step
    decreases ``|F|``, when ``|F|`` fell by less than :data:`STALL_FACTOR` over the last
    :data:`STALL_STEPS` steps, or after ``max_iter`` steps. ``DP`` is re-evaluated at the
    solution with the fourth-order stencil (NaN if it failed).
    """
    n = N_SECTION
    m = n + 1 if balance else n
    settings1 = settings.copy()
    settings1[C_MAX_CYCLES] = 1.0
    prog = np.empty_like(prog0)
    counts = np.zeros(N_COUNTS, dtype=np.int64)
    F = np.empty(m)
    Ft = np.empty(m)
    J = np.empty((m, m))
    for i in range(m):
        u[i] = u0[i]
    info[:] = np.nan
    DP[:, :] = np.nan
    info[I_ITERATIONS] = 0.0
    info[I_MAP_STATUS] = ST_OK
    result = DS_NOT_CONVERGED
    if balance:
        # the balance first, the state held: a secant on the height alone puts Newton's start
        # near the gait's energy level (an open-loop schedule far from it falls or stalls)
        balance_start(method, par, prog0, dprog, obs, settings1, theta1_section, u, prog, F,
                      counts)
    status = residual(method, par, prog0, dprog, obs, settings1, theta1_section, balance, u,
                      prog, F, counts)
    if status != ST_OK:
        info[I_MAP_STATUS] = status
        info[I_NFEV] = counts[K_NFEV]
        return DS_NO_CYCLE
    norm = _norm(F)
    history = np.full(max_iter + 1, np.inf)   # |F| before each step
    ut = np.empty(m)
    for it in range(max_iter):
        history[it] = norm
        if norm <= tol:
            result = DS_OK
            break
        if it >= STALL_STEPS and norm * STALL_FACTOR > history[it - STALL_STEPS]:
            break
        status = jacobian(method, par, prog0, dprog, obs, settings1, theta1_section, balance, u,
                          h, prog, J, counts, 2)
        if status != ST_OK:
            info[I_MAP_STATUS] = status
            result = DS_STENCIL
            break
        du = np.linalg.lstsq(J, -F, 1e-12)[0]
        lam = 1.0
        improved = False
        for _ in range(MAX_HALVINGS + 1):
            for i in range(m):
                ut[i] = u[i] + lam * du[i]
            status = residual(method, par, prog0, dprog, obs, settings1, theta1_section,
                              balance, ut, prog, Ft, counts)
            if status == ST_OK and _norm(Ft) < norm:
                improved = True
                break
            lam *= 0.5
        info[I_ITERATIONS] = it + 1.0
        if not improved:
            break
        for i in range(m):
            u[i] = ut[i]
            F[i] = Ft[i]
        norm = _norm(F)
    if norm <= tol:
        result = DS_OK
    info[I_DEFECT] = norm
    # the record of the cycle at the solution: its error, height, advance, losses, duration
    q = u[n] if balance else 0.0
    for i in range(prog.shape[0]):
        for j in range(prog.shape[1]):
            prog[i, j] = prog0[i, j] + q * dprog[i, j]
    w_next = np.empty(n)
    log = np.empty((LOG_ROWS, N_LOG_COLS))
    status, rise, advance, loss, period = cycle_map(method, par, prog, obs, settings1,
                                                    theta1_section, u[:n], w_next, log, counts)
    err = 0.0
    for i in range(n):
        err += (w_next[i] - u[i]) ** 2
    info[I_ERROR] = err
    info[I_RISE] = rise
    info[I_ADVANCE] = advance
    info[I_LOSS] = loss
    info[I_PERIOD] = period
    if result == DS_OK:
        # dP/dw at the fixed program: the state columns of dF/du, plus the identity
        prog_q = prog.copy()
        Jw = np.empty((n, n))
        status = jacobian(method, par, prog_q, dprog, obs, settings1, theta1_section, False,
                          u[:n].copy(), h, prog, Jw, counts)
        if status != ST_OK:
            info[I_MAP_STATUS] = status
            result = DS_STENCIL
        else:
            for i in range(n):
                for j in range(n):
                    DP[i, j] = Jw[i, j] + (1.0 if i == j else 0.0)
    info[I_NFEV] = counts[K_NFEV]
    return result
