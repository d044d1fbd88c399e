"""Jacobians of return maps by variational equations, with saltation matrices at the events.

:func:`sequence_variational_jacobian` differentiates the return map of any
:class:`~monkeystudy.controllers.SequenceGait`: swings, flights, catches with either end,
energy-latched and clock-timed guards, viscous and Coulomb friction. The horizontal gait is one
(:func:`~monkeystudy.controllers.horizontal_gait`); :func:`variational_jacobian` names its two
controllers (its open-loop replay and its state-based search controller).

The method (the standard one for hybrid systems):

1. One kernel run (:func:`~monkeystudy.simulation.run_controller`) gives the event sequence:
   which segments ran, and when. The kernel's times only seed the event location; the state
   and its transition matrix are integrated afresh here, leg by leg (scipy ``solve_ivp``,
   DOP853), on the full 8-state ``[x, y, th1, th2, dx, dy, dth1, dth2]`` in *both* phases
   (swinging, ``(x, y)`` and ``(dx, dy)`` do not move), so every transition matrix is 8 x n
   and every reset is an 8 -> 8 map. Field Jacobians ``A = df/dx`` are complex steps of the
   kernel's own accelerations (:mod:`monkeystudy.kernel.variational`).
2. At an event at time ``t_e`` with entry actions ``R`` (the next segment's magnets: flip,
   plastic impact, stop), the fixed-time transition matrix jumps by

       Phi+ = DR Phi- + (DR f- - f+) dt_e,

   ``dt_e = d t_e / d x0`` a row vector: for a state guard ``g(x) = ref``,
   ``dt_e = -(grad g . Phi- - d ref / d x0) / (grad g . f-)`` (``ref`` is the latched energy
   for ``energy_restored``, itself a function of the start); for a time guard, the derivative
   of the controller clock's origin (0, or an earlier exit time after ``clock="reset"``); for a
   segment that ends at once (a level guard already met on entry, a time already past), the
   previous event's ``dt_e``, so that its two resets compose exactly.
3. A Coulomb friction event (the kernel logs each: a slipping DOF's speed reaches zero, or a
   stuck DOF's holding torque reaches the limit) has no reset, ``R = I``; the field changes
   from ``f-`` to ``f+`` (the new friction mode), so ``Phi+ = Phi- + (f- - f+) dt_e`` with
   the guard's ``dt_e`` (the DOF's speed; ``|hold| - c``). A stick zeroes the speed's row
   of ``Phi``; at a break-away ``f+ = f-`` (the friction supplies exactly ``c`` on both
   sides). Where sticking and slipping trade places (the holding torque at ``c`` when the
   DOF is at rest) the map has a kink and the function refuses.
4. The section (``theta1 = c``, free time) projects: ``Phi + f- dt_e``. The start perturbs
   ``(theta2, dtheta1, dtheta2)`` (columns 3, 6, 7 of the 8-state); the answer is rows 3, 6, 7.
   The full map (``height=True``) adds the attached end's height ``y`` (column and row 1):
   ``(y, theta2, dtheta1, dtheta2)``.
"""
from __future__ import annotations

import math

import numpy as np

from ..controllers import Integrator, SequenceGait, horizontal_gait, open_loop_gait
from ..kernel import layout as L
from ..kernel.dynamics import total_energy8
from ..kernel.variational import (
    energy8_gradient, entry_reset, field8, field8_jacobian, guard8, guard8_gradient,
    holding_torque8, holding_torque8_gradient, variational_rhs8,
)
from ..robot import SEED2009_TORQUE
from ..simulation import RobotLike, Status, as_robot, run_controller
from .sections import TIGHT, check_cycle_frame, cycle_section_state, full_map_gait

#: rows/columns of the section coordinates ``z = (theta2, dtheta1, dtheta2)`` in the 8-state
SECTION_INDEX = (L.TH2, L.DTH1, L.DTH2)
#: rows/columns of a running clock's section state ``(theta1, theta2, dtheta1, dtheta2)``
CLOCKED_INDEX = (L.TH1, L.TH2, L.DTH1, L.DTH2)
#: rows/columns of the full section state ``(y, theta2, dtheta1, dtheta2)``: the attached
#: end's height [m] with the section coordinates
FULL_INDEX = (L.Y, L.TH2, L.DTH1, L.DTH2)
#: largest relative difference between the re-integrated states and the kernel's log: beyond
#: it the two did not follow the same event sequence
_STATE_TOL = 1e-7
#: a segment's condition within this relative distance of its threshold on entry counts as
#: on it (the kernel's own band is 1e-12; the re-integration differs from it by ~1e-12)
_THRESHOLD_MARGIN = 1e-9


#: the friction DOFs: name, speed's row in the 8-state
_FRICTION_DOFS = (("pivot", L.DTH1), ("joint", L.DTH2))


# --- any sequence gait ------------------------------------------------------------------------
def _field(phase: int, p: np.ndarray, tau: float, fm: np.ndarray, s: np.ndarray) -> np.ndarray:
    f = np.empty(8)
    field8(phase, p, tau, fm, s, f)
    return f


def _flow(phase: int, p: np.ndarray, tau: float, fm: np.ndarray, s: np.ndarray,
          Phi: np.ndarray, t0: float, t1: float, rtol: float) -> tuple[np.ndarray, np.ndarray]:
    """State and transition matrix carried from ``t0`` to ``t1`` [s] in one phase and one
    set of friction modes ``fm``."""
    if t1 <= t0 or phase == L.PHASE_FIXED:
        return s.copy(), Phi.copy()
    # scipy.integrate loads in ~0.2 s: only the callers that integrate variations pay it
    from scipy.integrate import solve_ivp

    m = Phi.shape[1]
    Y0 = np.concatenate([s, Phi.ravel()])
    dY = np.empty_like(Y0)
    fm = fm.copy()

    def fun(t, Y):
        variational_rhs8(phase, p, tau, fm, Y, dY)
        return dY.copy()

    # atol two decades below rtol: the transition matrix has entries of order 1 that pass
    # through zero, and the angles are O(1) rad
    sol = solve_ivp(fun, (t0, t1), Y0, method="DOP853", rtol=rtol, atol=rtol * 1e-2)
    if not sol.success:
        raise RuntimeError(f"variational integration failed: {sol.message}")
    Y = sol.y[:, -1]
    return Y[:8].copy(), Y[8:].reshape(8, m).copy()


def _check_state(mine: np.ndarray, kernel: np.ndarray, what: str) -> np.ndarray:
    """Compare the re-integrated state with the kernel's log (same event sequence?); returns
    ``mine`` with theta1 on the kernel's branch (a flip wraps theta1 to [-pi, pi), and at
    +-pi round-off may pick either side)."""
    mine = mine.copy()
    turns = np.round((kernel[L.TH1] - mine[L.TH1]) / (2 * np.pi))
    mine[L.TH1] += 2 * np.pi * turns
    err = np.max(np.abs(mine - kernel))
    if not err <= _STATE_TOL * (1.0 + np.max(np.abs(kernel))):
        raise RuntimeError(f"re-integrated state departs from the kernel's at {what} "
                           f"(max difference {err:.3g}): event sequences differ")
    return mine


def _check_zero_length(kind, index, value, p, s, eref, t, dt, clock0, dclock, seg):
    """A segment that ends on entry is smooth in the start only if it ends on entry for every
    nearby start: its condition must hold with a margin (or, for a time exactly reached,
    move with the entry). On its threshold the map has a kink: a start on one side runs the
    segment for a time proportional to the distance (e.g. a collisionless swap, where the
    robot is momentarily at rest, followed by a motor until the energy is restored)."""
    if kind == L.G_ENERGY_RESTORED:
        g = guard8(kind, index, value, p, s, eref)
        if g > _THRESHOLD_MARGIN * (1.0 + abs(eref) + abs(value)):
            return
        raise ValueError(f"segment {seg}'s energy guard is met exactly on entry (E - E_ref - "
                         f"value = {g:.3g} J): the return map has a kink at this start, no "
                         "Jacobian")
    if kind == L.G_TIME:
        t_target = clock0 + value
        tol = _THRESHOLD_MARGIN * (1.0 + abs(t))
        if t_target < t - tol or (t_target <= t + tol and np.allclose(dclock, dt, rtol=0,
                                                                      atol=1e-12)):
            return
        if t_target <= t + tol:
            raise ValueError(f"segment {seg}'s time is reached exactly on entry, and the two "
                             "move differently with the start: the return map has a kink here")
    raise RuntimeError(f"segment {seg} ends on entry in the kernel but not here (guard kind "
                       f"{kind})")


def _friction_active(k: int, phase: int, coulomb) -> bool:
    """Whether Coulomb friction DOF ``k`` (0 pivot, 1 joint) acts in ``phase``: a limit above
    zero, the pivot only while swinging, nothing in the fixed phase (the hybrid loop's
    ``friction_active``)."""
    return (coulomb[k] > 0.0 and phase != L.PHASE_FIXED
            and (k == 1 or phase == L.PHASE_SWING))


def _check_coulomb_margin(hold: float, c: float, k: int, where: str, t: float) -> None:
    """A DOF at rest whose holding torque ``hold`` [N m] is at its Coulomb limit ``c`` [N m]
    is on the boundary between sticking and slipping: nearby starts stick on one side and
    slip on the other (or stick for a time proportional to the distance), so the return map
    has a kink there. Raises ``ValueError`` naming the event."""
    if abs(abs(hold) - c) > _THRESHOLD_MARGIN * (1.0 + c):
        return
    name = _FRICTION_DOFS[k][0]
    raise ValueError(f"the {name} is at rest at {where} (t = {t:.15g} s) with its holding "
                     f"torque at the Coulomb limit (|{hold:.12g}| N m vs {c:.12g} N m): "
                     "whether it sticks or slips changes with the start, the return map is "
                     "not differentiable here")


def _init_friction(phase: int, p: np.ndarray, tau: float, fm: np.ndarray, s: np.ndarray,
                   coulomb, where: str, t: float, start: bool) -> None:
    """Friction modes on entering a segment, as the hybrid loop's ``init_friction`` sets
    them (in place): a moving DOF slips with its speed's sign; one at rest sticks if its
    holding torque is within the Coulomb limit, else slips against that torque.

    A DOF at rest on entry is at rest for every nearby start when the entry follows a
    stick or a stop (a fixed phase): smooth unless the holding torque is at the limit
    (:func:`_check_coulomb_margin`). At the ``start`` of the cycle its rest is a
    coordinate of the start itself: a kink, refused."""
    for k in range(2):
        if not (coulomb[k] > 0.0 and (k == 1 or phase == L.PHASE_SWING)):
            fm[k] = 1.0
            continue
        w = s[_FRICTION_DOFS[k][1]]
        if w != 0.0:
            fm[k] = 1.0 if w > 0.0 else -1.0
    for k in range(2):
        if not (coulomb[k] > 0.0 and (k == 1 or phase == L.PHASE_SWING)):
            continue
        if s[_FRICTION_DOFS[k][1]] == 0.0:
            hold = float(holding_torque8(phase, p, tau, fm, s, k))
            if start and phase != L.PHASE_FIXED:
                raise ValueError(f"the {_FRICTION_DOFS[k][0]} starts at rest with Coulomb "
                                 "friction: a start moving either way slips for a time "
                                 "proportional to its speed, the return map is not "
                                 "differentiable here")
            if _friction_active(k, phase, coulomb):
                _check_coulomb_margin(hold, coulomb[k], k, where, t)
            if abs(hold) <= coulomb[k]:
                fm[k] = 0.0
            else:
                fm[k] = -1.0 if hold > 0.0 else 1.0


def _friction_guard(k: int, phase: int, p: np.ndarray, tau: float, fm: np.ndarray,
                    s: np.ndarray, c: float) -> tuple[float, np.ndarray]:
    """The guard of friction DOF ``k``'s next event and its gradient w.r.t. the 8-state: a
    slipping DOF's speed (it stops at zero), a stuck DOF's ``|hold| - c`` (it breaks away at
    zero; ``hold`` the holding torque [N m], ``c`` the Coulomb limit)."""
    row = _FRICTION_DOFS[k][1]
    grad = np.zeros(8)
    if fm[k] != 0.0:
        grad[row] = 1.0
        return float(s[row]), grad
    hold = float(holding_torque8(phase, p, tau, fm, s, k))
    holding_torque8_gradient(phase, p, tau, fm, s, k, grad)
    sign = 1.0 if hold > 0.0 else -1.0
    return abs(hold) - c, sign * grad


def sequence_variational_jacobian(gait: SequenceGait, z, *, robot: RobotLike = "seed2009",
                                  integrator: Integrator = TIGHT, rtol: float = 1e-12,
                                  height: bool = False) -> np.ndarray:
    """Jacobian of :func:`~monkeystudy.analysis.cycle_return_map` by variational equations
    (with ``height``, of :func:`~monkeystudy.analysis.cycle_full_map`).

    Parameters
    ----------
    gait : SequenceGait
        The gait; its ``tick`` must be 0 (exact event timing: on a tick the map is piecewise
        constant in the event times, not differentiable).
    z : array_like, shape (3,) or (4,)
        Section state ``(theta2 [rad], dtheta1 [rad s-1], dtheta2 [rad s-1])`` on
        ``theta1 = gait.section_theta1``; with a running clock (``gait.clocked``) the state
        ``(theta1, theta2, dtheta1, dtheta2)`` at clock phase zero (the cycle ends at a fixed
        time: no projection onto a section).
    robot : Robot or str
        The robot. Viscous friction is part of the vector field; Coulomb friction enters
        through its events (a slipping DOF stops: it sticks or slips back; a stuck DOF breaks
        away), each crossed with its saltation matrix (docs/model.md section 7). A cycle that
        ends hanging from B needs mirror-image links (as
        :func:`~monkeystudy.analysis.cycle_return_map`).
    integrator : Integrator
        Settings of the kernel run that finds the event sequence.
    rtol : float
        Relative tolerance of the variational integration (absolute: ``rtol / 100``).
    height : bool
        Differentiate the full map: ``z = (y [m], theta2 [rad], dtheta1, dtheta2
        [rad s-1])``, ``y`` the attached end's height at the start (the cycle starts hanging
        from A at ``(0, y)``) and at the end (the end attached there). Not with a running
        clock.

    Returns
    -------
    numpy.ndarray, shape (3, 3) or (4, 4)
        ``d z' / d z``, with ``z'`` the section state at the end of the cycle.

    Raises
    ------
    ValueError
        ``gait.tick > 0``, a cycle ending on B with non-mirror links, or a start on a kink of
        the map: a segment whose condition is met exactly on entry (e.g. a collisionless
        swap followed by a motor until the energy is restored); a Coulomb DOF at rest with
        its holding torque at the Coulomb limit (at a stop or a segment's entry: it sticks
        or slips depending on the start), a stick of zero length, a friction event tangent
        to its guard, or a start with a Coulomb DOF at rest.
    RuntimeError
        The cycle does not complete (status not OK), or the re-integration departs from the
        kernel's event sequence.
    """
    robot = as_robot(robot)
    if gait.tick != 0.0:
        raise ValueError(f"the return map is differentiable only with exact event timing "
                         f"(tick 0), got tick={gait.tick!r}")
    par = robot.params()
    coulomb = (float(par[0, L.P_C_PIVOT]), float(par[0, L.P_C_JOINT]))
    check_cycle_frame(gait, robot)
    if height and gait.clocked:
        raise ValueError("the full map (height included) is defined on a section, not at a "
                         "running clock's phase")
    cols = list(FULL_INDEX if height else CLOCKED_INDEX if gait.clocked else SECTION_INDEX)
    z = np.asarray(z, dtype=float).reshape(len(cols))
    # the full map of a bar gait runs on a ladder fixed in the world (sections.full_map_gait)
    prog, _ = (full_map_gait(gait, float(z[0])) if height else gait).program()
    hyb0 = (cycle_section_state(gait, z[1:], height=z[0]) if height
            else cycle_section_state(gait, z))
    res = run_controller(gait.controller(), hyb0, robot=robot, integrator=integrator,
                         cycles=1, log_capacity=64)
    if res.status != Status.OK:
        raise RuntimeError(f"no cycle from this point (status {res.status.name.lower()})")
    log = res.log[(res.log[:, L.L_KIND] == L.LOG_SEGMENT)
                  | (res.log[:, L.L_KIND] == L.LOG_FRICTION)]

    n = len(cols)
    s = hyb0[:8].copy()
    phase, flipped = L.PHASE_SWING, 0
    fm = np.ones(2)                   # friction modes: slip sign +-1, 0 stuck
    stuck_since = [np.nan, np.nan]    # when each friction DOF last stuck [s]
    Phi = np.eye(8)[:, cols]          # d s / d z at fixed time
    t, dt = 0.0, np.zeros(n)          # time of the latest event and d t / d z
    clock0, dclock = 0.0, np.zeros(n)
    eref, deref = np.nan, np.zeros(n)
    out, DR = np.empty(8), np.empty((8, 8))
    grad = np.empty(8)
    A = np.empty((8, 8))
    # d (x, y) / d z of the bar the robot hangs from, where the bars it catches are placed:
    # the start's bar is fixed in the world (the start's height, in the full map, is its
    # height off that bar); an attachment other than a catch makes the new attached end the
    # reference, as the kernel places bars from it
    ref_rows = np.zeros((2, n))

    def enter(seg, f_minus, dt_e, start=False):
        """Entry actions of ``seg`` at an event: reset the state, set the friction modes and
        jump Phi."""
        nonlocal s, phase, flipped, Phi, eref, deref, ref_rows
        ph, fl = entry_reset(par, s, phase, flipped, prog[seg, L.S_MAG_A],
                             prog[seg, L.S_MAG_B], prog[seg, L.S_SWAP] > 0, out, DR)
        phase, flipped = int(ph), int(fl)
        s = out.copy()
        tau = prog[seg, L.S_TORQUE]
        was_stuck = fm == 0.0
        _init_friction(phase, par[flipped], tau, fm, s, coulomb, f"the entry of segment {seg}",
                       t, start)
        for k in range(2):
            if fm[k] == 0.0 and not was_stuck[k]:
                stuck_since[k] = t
        f_plus = _field(phase, par[flipped], tau, fm, s)
        Phi = DR @ Phi + np.outer(DR @ f_minus - f_plus, dt_e)
        if prog[seg, L.S_MAG_A] >= 0 or prog[seg, L.S_MAG_B] >= 0 or prog[seg, L.S_SWAP] > 0:
            ref_rows = Phi[[L.X, L.Y], :].copy()
        if prog[seg, L.S_SET_EREF] > 0:
            # the latched energy moves with the start through the state *and* the entry time
            eref = total_energy8(par[flipped], s)
            energy8_gradient(par[flipped], s, grad)
            deref = grad @ (Phi + np.outer(f_plus, dt_e))

    def locate(g_of, p, tau, t_e):
        """Newton from the kernel's time ``t_e`` to the crossing of the guard ``g_of(s) ->
        (g, grad)`` on this trajectory (they differ by round-off and the integrators'
        errors, ~1e-13 s; first-order Taylor steps are exact to O(dt^2) ~ 1e-26); returns
        the crossing's time, the guard's gradient and the field there."""
        nonlocal s, Phi
        for _ in range(3):
            g, gr = g_of(s)
            f = _field(phase, p, tau, fm, s)
            delta = -g / (gr @ f)
            field8_jacobian(phase, p, tau, fm, s, A)
            s = s + f * delta
            Phi = Phi + (A @ Phi) * delta
            t_e += delta
        _, gr = g_of(s)
        return t_e, gr, _field(phase, p, tau, fm, s)

    def segment_guard(kind, index, value, p):
        def g_of(x):
            gr = np.empty(8)
            guard8_gradient(kind, index, value, p, x, eref, gr)
            return guard8(kind, index, value, p, x, eref), gr
        return g_of

    seg = int(hyb0[L.H_SEG])
    enter(seg, np.zeros(8), dt, start=True)   # the start is at t = 0 whatever z: dt = 0
    t_kernel_prev = 0.0
    for k, row in enumerate(log):
        p = par[flipped]
        tau = prog[seg, L.S_TORQUE]
        t_kernel = row[L.L_T]
        if row[L.L_KIND] == L.LOG_FRICTION:
            # a Coulomb event: a guard crossing with no jump of the state, across which the
            # field changes (docs/model.md section 7, "Coulomb friction")
            j = int(row[L.L_ID])
            name, speed = _FRICTION_DOFS[j]
            c = coulomb[j]
            stuck = fm[j] == 0.0
            s, Phi = _flow(phase, p, tau, fm, s, Phi, t, t_kernel, rtol)
            t_e, grad_g, f_minus = locate(
                lambda x: _friction_guard(j, phase, p, tau, fm, x, c), p, tau, t_kernel)
            what = (f"the {name}'s break-away" if stuck else f"the {name}'s stop") + \
                f" (t = {t_e:.15g} s)"
            if not abs(t_e - t_kernel) <= 1e-8 * (1.0 + abs(t_kernel)):
                raise RuntimeError(f"{what} here, at {float(t_kernel):.15g} s in the kernel: "
                                   "event sequences differ")
            s[speed] = 0.0    # the kernel's state at the event, exactly at rest
            hold = float(holding_torque8(phase, p, tau, fm, s, j))
            if stuck:
                if not t_e - stuck_since[j] > _THRESHOLD_MARGIN * (1.0 + abs(t_e)):
                    raise ValueError(f"{what} ends a stick of zero length: nearby starts do "
                                     "not stick at all, the return map is not "
                                     "differentiable here")
                fm[j] = -1.0 if hold > 0.0 else 1.0
            else:
                _check_coulomb_margin(hold, c, j, f"its stop in segment {seg}", t_e)
                if abs(hold) <= c:
                    fm[j] = 0.0
                    stuck_since[j] = t_e
                else:
                    fm[j] = -1.0 if hold > 0.0 else 1.0
            rate = float(grad_g @ f_minus)
            if not abs(rate) > 0.0:
                raise ValueError(f"{what} is tangent to its guard (rate {rate:.3g}): the "
                                 "return map is not differentiable here")
            dt_e = -(grad_g @ Phi) / rate
            # saltation: the state is continuous, the field jumps from f- to f+ (a stick
            # zeroes the speed's row: perturbations along it are absorbed)
            f_plus = _field(phase, p, tau, fm, s)
            Phi = Phi + np.outer(f_minus - f_plus, dt_e)
            s = _check_state(s, row[L.L_STATE:L.L_STATE + 8], what)
            t, dt = t_e, dt_e
            t_kernel_prev = t_kernel
            continue
        if int(row[L.L_ID]) != seg:
            raise RuntimeError(f"kernel log row {k} exits segment {int(row[L.L_ID])}, "
                               f"expected {seg}")
        kind = int(prog[seg, L.S_GUARD])
        index = int(prog[seg, L.S_GINDEX])
        value = prog[seg, L.S_GVALUE]
        if t_kernel == t_kernel_prev:
            # ended at once (energy already restored on entry, or a time already past): the
            # exit moves with the entry, and the two resets compose exactly
            _check_zero_length(kind, index, value, p, s, eref, t, dt, clock0, dclock, seg)
            t_e, dt_e = t, dt
        elif kind == L.G_TIME:
            t_e, dt_e = clock0 + value, dclock.copy()
            s, Phi = _flow(phase, p, tau, fm, s, Phi, t, t_e, rtol)
        elif kind in (L.G_FREE_END_HEIGHT, L.G_ENERGY_RESTORED, L.G_COORD, L.G_ENERGY,
                      L.G_FREE_END_Y, L.G_BAR):
            s, Phi = _flow(phase, p, tau, fm, s, Phi, t, t_kernel, rtol)
            t_e, grad_g, f = locate(segment_guard(kind, index, value, p), p, tau, t_kernel)
            if kind == L.G_ENERGY_RESTORED:
                dref = deref
            elif kind == L.G_BAR:
                # the guard's value is the bar's rise above the attached end
                dref = ref_rows[1] - Phi[L.Y]
            else:
                dref = 0.0
            dt_e = -(grad_g @ Phi - dref) / (grad_g @ f)
        else:
            raise ValueError(f"segment {seg} has no guard that can end it (kind {kind})")
        if not abs(t_e - t_kernel) <= 1e-8 * (1.0 + abs(t_kernel)):
            raise RuntimeError(f"segment {seg} exits at {float(t_e):.15g} s here, "
                               f"{float(t_kernel):.15g} s in the kernel: event sequences "
                               "differ")
        f_minus = _field(phase, p, tau, fm, s)
        t_kernel_prev = t_kernel
        t, dt = t_e, dt_e
        clock_mode = int(prog[seg, L.S_CLOCK])
        if clock_mode == 1:
            clock0, dclock = t_e, dt_e.copy()
        elif clock_mode == 2:
            clock0 += value
        if k == len(log) - 1:
            # the section: the crossing time is free, so the state moves along the flow (a
            # running clock's end is at a fixed time: dt_e = 0 and M = Phi)
            s = _check_state(s, res.state[:8], "the section")
            M = Phi + np.outer(f_minus, dt_e)
            return M[cols, :]
        caught = kind == L.G_BAR and phase == L.PHASE_SWING
        bar = s[L.X] + prog[seg, L.S_BAR_DX], s[L.Y] + value
        bar_rows = ref_rows.copy()
        flipped_before = flipped
        seg = int(prog[seg, L.S_NEXT])
        enter(seg, f_minus, dt_e)
        s = _check_state(s, row[L.L_STATE:L.L_STATE + 8], f"the exit of segment "
                         f"{int(row[L.L_ID])}")
        if phase != int(row[L.L_PHASE]) or flipped != int(row[L.L_FLIPPED]):
            raise RuntimeError(f"phase/frame after segment {int(row[L.L_ID])} differ from "
                               "the kernel's")
        if caught and phase == L.PHASE_SWING and flipped != flipped_before:
            # the snap onto the bar (the kernel's log holds the state before it): the new
            # pivot is the bar, a fixed offset from the bar the robot hung from, so it moves
            # as that bar did (not at all for a bar of the world-fixed ladder)
            s[L.X], s[L.Y] = bar
            Phi[[L.X, L.Y], :] = bar_rows
            ref_rows = bar_rows
    raise RuntimeError("the kernel log has no segment exits")


def variational_jacobian(controller: str, z, *, t_switch: float = math.nan,
                         t_motor: float = math.nan, torque: float = SEED2009_TORQUE,
                         robot: RobotLike = "seed2009", integrator: Integrator = TIGHT,
                         rtol: float = 1e-12) -> np.ndarray:
    """Jacobian of the horizontal gait's return map on ``theta1 = 0`` by variational
    equations: :func:`sequence_variational_jacobian` of
    :func:`~monkeystudy.controllers.horizontal_gait` (motor ``torque`` [N m]).

    ``controller`` is ``"open_loop"`` (its open-loop replay: swap at ``t_switch``, motor off
    at ``t_switch + t_motor`` [s], the clock restarting at the vertical) or ``"search"`` (the
    state-based controller). ``z = (theta2 [rad], dtheta1, dtheta2 [rad s-1])``.
    """
    gait = horizontal_gait(torque)
    if controller == "open_loop":
        gait = open_loop_gait(gait, [t_switch, t_switch + t_motor])
    elif controller != "search":
        raise ValueError(f"controller must be 'open_loop' or 'search', got {controller!r}")
    return sequence_variational_jacobian(gait, z, robot=robot, integrator=integrator,
                                         rtol=rtol)
