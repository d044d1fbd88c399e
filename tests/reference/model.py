"""A plain numpy/scipy MonkeyBot: the reference the kernel tests compare against.

* Equations of motion: the sympy-derived ``M``, ``C qdot``, ``G`` of :mod:`.symbolic`, solved
  with ``numpy.linalg.solve``; generalized forces as docs/model.md section 2 (motor on the theta2
  row, viscous + Coulomb friction on theta1 (swing only) and theta2).
* Impact: ``qdot+ = P qdot-`` with the explicit projection ``P = I - M^-1 J^T (J M^-1 J^T)^-1 J``
  (docs/model.md section 3); the flip as docs/model.md section 3.
* Hybrid runs: chained ``solve_ivp(method="DOP853")`` calls, one per segment, each ending on a
  terminal event with its direction (scipy locates events with ``brentq`` to 4 eps).

Nothing here imports the kernel; the robot comes in as plain numbers.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
from scipy.integrate import solve_ivp

from .symbolic import derivation

# status codes of docs/model.md section 4 (the same meaning as the kernel's, written out here)
OK, NO_SWITCH, ENERGY_NOT_RESTORED, NO_RETURN = 0, 1, 2, 3


def wrap(a: float) -> float:
    """Angle in [-pi, pi)."""
    return (a + math.pi) % (2.0 * math.pi) - math.pi


@dataclass(frozen=True)
class RefRobot:
    m1: float
    m2: float
    L1: float
    L2: float
    r1: float
    r2: float
    I1: float
    I2: float
    g: float = 9.81
    b_pivot: float = 0.0
    c_pivot: float = 0.0
    b_joint: float = 0.0
    c_joint: float = 0.0
    sigma1: float = 0.0     # CG offsets across the links [m] (docs/model.md section 1)
    sigma2: float = 0.0
    rotor: float = 0.0      # the joint motor's rotor inertia [kg m^2], gear ratio, and 1.0 when
    gear: float = 1.0       # its housing is on link 1, 0.0 on link 2 (docs/model.md section 2)
    housing1: float = 1.0

    # -- construction ---------------------------------------------------------------------
    @classmethod
    def from_robot(cls, robot) -> "RefRobot":
        """From a ``monkeystudy.Robot`` (reads its dataclass fields, not the kernel rows)."""
        l1, l2 = robot.link1, robot.link2
        return cls(l1.mass, l2.mass, l1.length, l2.length, l1.com, l2.com, l1.inertia,
                   l2.inertia, robot.gravity, robot.pivot_friction.viscous,
                   robot.pivot_friction.coulomb, robot.joint_friction.viscous,
                   robot.joint_friction.coulomb, l1.com_across, l2.com_across,
                   robot.rotor.inertia, robot.rotor.gear_ratio,
                   1.0 if robot.rotor.housing == 1 else 0.0)

    @property
    def prm(self):
        return (self.m1, self.m2, self.L1, self.L2, self.r1, self.r2, self.I1, self.I2, self.g,
                self.sigma1, self.sigma2, self.rotor, self.gear, self.housing1)

    def flipped(self) -> "RefRobot":
        """The same robot seen from end B (docs/model.md section 3); friction stays with its joint."""
        return replace(self, m1=self.m2, m2=self.m1, L1=self.L2, L2=self.L1, I1=self.I2,
                       I2=self.I1, r1=self.L2 - self.r2, r2=self.L1 - self.r1,
                       sigma1=-self.sigma2, sigma2=-self.sigma1, housing1=1.0 - self.housing1)

    # -- matrices -------------------------------------------------------------------------
    def flight_matrices(self, s8):
        d = derivation()
        q, qd = s8[:4], s8[4:]
        M = np.array(d.f_M_flight(q, qd, self.prm), dtype=float)
        Cq = np.array(d.f_Cq_flight(q, qd, self.prm), dtype=float).reshape(4)
        G = np.array(d.f_G_flight(q, qd, self.prm), dtype=float).reshape(4)
        return M, Cq, G

    def swing_matrices(self, th, w):
        d = derivation()
        M = np.array(d.f_M_swing(th, w, self.prm), dtype=float)
        Cq = np.array(d.f_Cq_swing(th, w, self.prm), dtype=float).reshape(2)
        G = np.array(d.f_G_swing(th, w, self.prm), dtype=float).reshape(2)
        return M, Cq, G

    # -- forces and accelerations -----------------------------------------------------------
    def swing_forces(self, w, tau, fmode=(1.0, 1.0)):
        return np.array([-self.b_pivot * w[0] - self.c_pivot * fmode[0],
                         tau - self.b_joint * w[1] - self.c_joint * fmode[1]])

    def flight_forces(self, w, tau, fmode=(1.0, 1.0)):
        return np.array([0.0, 0.0, 0.0, tau - self.b_joint * w[1] - self.c_joint * fmode[1]])

    @staticmethod
    def _solve_locked(M, rhs, locked):
        """``M a = rhs`` with the locked DOFs held at zero acceleration (their rows dropped)."""
        free = [i for i in range(len(rhs)) if i not in locked]
        a = np.zeros(len(rhs))
        if free:
            a[free] = np.linalg.solve(M[np.ix_(free, free)], rhs[free])
        return a

    def swing_accel(self, y4, tau=0.0, fmode=(1.0, 1.0)):
        th, w = y4[:2], y4[2:]
        M, Cq, G = self.swing_matrices(th, w)
        rhs = self.swing_forces(w, tau, fmode) - Cq - G
        locked = [k for k in range(2) if fmode[k] == 0.0]
        return self._solve_locked(M, rhs, locked)

    def flight_accel(self, s8, tau=0.0, fmode=(1.0, 1.0)):
        M, Cq, G = self.flight_matrices(s8)
        rhs = self.flight_forces(s8[6:], tau, fmode) - Cq - G
        locked = [3] if fmode[1] == 0.0 else []
        return self._solve_locked(M, rhs, locked)

    def swing_holding_torque(self, y4, tau, fmode, k):
        """Friction torque holding swing DOF ``k`` at zero acceleration (its Coulomb term off)."""
        fm = list(fmode)
        fm[k] = 0.0
        th, w = y4[:2], y4[2:]
        M, Cq, G = self.swing_matrices(th, w)
        rhs = self.swing_forces(w, tau, fm) - Cq - G
        a = self._solve_locked(M, rhs, [j for j in range(2) if fm[j] == 0.0])
        return M[k] @ a - rhs[k]

    def swing_rhs(self, tau=0.0, fmode=(1.0, 1.0)):
        def f(t, y):
            return np.concatenate([y[2:], self.swing_accel(y, tau, fmode)])
        return f

    def flight_rhs(self, tau=0.0, fmode=(1.0, 1.0)):
        def f(t, y):
            return np.concatenate([y[4:], self.flight_accel(y, tau, fmode)])
        return f

    # -- energy, kinematics -------------------------------------------------------------------
    def energy8(self, s8):
        d = derivation()
        q, qd = s8[:4], s8[4:]
        return float(d.f_K(q, qd, self.prm)) + float(d.f_V(q, qd, self.prm))

    def kinetic8(self, s8):
        return float(derivation().f_K(s8[:4], s8[4:], self.prm))

    def potential8(self, s8):
        return float(derivation().f_V(s8[:4], s8[4:], self.prm))

    def points8(self, s8):
        """World positions (5, 2): (x, y) end, CG1, joint, CG2, free end."""
        return np.array(derivation().f_points(s8[:4], s8[4:], self.prm), dtype=float)

    def free_end_height(self, th1, th2):
        return -self.L1 * math.cos(th1) - self.L2 * math.cos(th1 + th2)

    # -- impact and flip (docs/model.md section 3) -----------------------------------------------------
    def projection(self, s8):
        M, _, _ = self.flight_matrices(s8)
        Minv = np.linalg.inv(M)
        J = np.zeros((2, 4))
        J[0, 0] = J[1, 1] = 1.0
        return np.eye(4) - Minv @ J.T @ np.linalg.inv(J @ Minv @ J.T) @ J

    def attach(self, s8):
        out = np.array(s8, dtype=float)
        out[4:] = self.projection(s8) @ s8[4:]
        return out

    def flip8(self, s8, wrap_theta1=True):
        """State about the free end; ``self`` is the robot of the frame before the flip.

        docs/model.md section 3 verbatim, except that ``theta1' = pi + theta1 + theta2`` is taken
        into [-pi, pi) (so that "theta1 crosses 0" means the new link 1 passes the downward
        vertical). ``theta2' = -theta2`` is *not* wrapped: the joint angle stays a continuous
        function of the motion, so the gait error ``theta2_final^2 + ...`` is too.
        """
        x, y, th1, th2, vx, vy, w1, w2 = s8
        L1, L2 = self.L1, self.L2
        s1, c1, s12, c12 = math.sin(th1), math.cos(th1), math.sin(th1 + th2), math.cos(th1 + th2)
        a1 = math.pi + th1 + th2
        a2 = -th2
        if wrap_theta1:
            a1 = wrap(a1)
        return np.array([x + L1 * s1 + L2 * s12, y - L1 * c1 - L2 * c12, a1, a2,
                         vx + L1 * c1 * w1 + L2 * c12 * (w1 + w2),
                         vy + L1 * s1 * w1 + L2 * s12 * (w1 + w2), w1 + w2, -w2])


def swing8(pivot, y4):
    return np.array([pivot[0], pivot[1], y4[0], y4[1], 0.0, 0.0, y4[2], y4[3]])


def next_tick(t, tick, phase=0.0):
    """First tick ``phase + k tick`` at or after ``t``; a time within 1e-9 tick after a tick
    is taken to be on it (round-off)."""
    k = math.ceil((t - phase) / tick - 1e-9)
    return phase + k * tick


@dataclass
class SegmentResult:
    t: float                 # exit time (nan if the horizon was reached)
    y: np.ndarray            # packed state at exit (or at the horizon)
    nfev: int = 0
    recovered: int = 0       # crossings scipy stepped over, found at the guard's extremum


def _first_crossing(rhs, t, y, t_end, guard, direction, rate, rtol, atol, max_step):
    """Earliest crossing of ``guard`` in ``direction`` after ``t``, as (t, y, nfev, recovered).

    scipy's events only compare the guard's signs at step ends, so a guard that crosses and
    re-crosses within one step is missed. With ``rate`` (the guard's time derivative) the
    guard's extrema in the crossing direction are recorded too (a non-terminal event): an
    extremum beyond zero before the first detected crossing means a crossing was stepped over;
    it lies in the extremum's step, before the extremum, and is located there with ``brentq``
    on the dense output (scipy's own event method).
    """
    from scipy.optimize import brentq

    def g_ev(tt, yy):
        return guard(yy)
    g_ev.terminal = True
    g_ev.direction = direction
    events = [g_ev]
    if rate is not None and direction != 0:
        def r_ev(tt, yy):
            return rate(yy)
        r_ev.terminal = False
        r_ev.direction = -direction
        events.append(r_ev)
    sol = solve_ivp(rhs, (t, t_end), y, method="DOP853", rtol=rtol, atol=atol,
                    events=events, max_step=max_step, dense_output=rate is not None)
    if len(sol.t_events) > 1:
        for te, ye in zip(sol.t_events[1], sol.y_events[1]):
            if direction * guard(ye) <= 0.0:
                continue                       # an extremum short of zero
            # stepped over a crossing: it is in the extremum's step, before the extremum
            k = np.searchsorted(sol.t, te) - 1
            ta = sol.t[max(k, 0)]
            assert direction * guard(sol.sol(ta)) < 0.0
            tc = brentq(lambda s: guard(sol.sol(s)), ta, te, xtol=4 * np.finfo(float).eps,
                        rtol=4 * np.finfo(float).eps)
            return tc, sol.sol(tc), sol.nfev, 1
    if sol.status != 1:
        return math.nan, sol.y[:, -1], sol.nfev, 0
    return sol.t_events[0][0], sol.y_events[0][0], sol.nfev, 0


def run_segment(rhs, t0, y0, guard, direction, *, horizon, rtol, atol, tick=0.0,
                tick_phase=0.0, max_step=np.inf, rate=None):
    """Integrate until ``guard`` crosses zero in ``direction`` (terminal), as chained solve_ivp.

    With ``tick > 0`` the crossing is acted on at the first tick at or after it, if the
    condition still holds there; else the search goes on from the tick (the kernel's rule).
    """
    t_end = t0 + horizon
    nfev = 0
    recovered = 0
    t, y = t0, np.asarray(y0, float)
    while True:
        tc, yc, n, rec = _first_crossing(rhs, t, y, t_end, guard, direction, rate, rtol, atol,
                                         max_step)
        nfev += n
        recovered += rec
        if not math.isfinite(tc):
            return SegmentResult(math.nan, yc, nfev, recovered)
        if tick <= 0.0:
            return SegmentResult(tc, yc, nfev, recovered)
        sign_before = 1.0 if guard(y) > 0.0 else -1.0   # no crossing between t and tc
        tk = next_tick(tc, tick, tick_phase)
        if tk > t_end:
            return SegmentResult(math.nan, yc, nfev, recovered)
        if tk <= tc:                 # the crossing is on the tick (to round-off): act
            return SegmentResult(tk, yc, nfev, recovered)
        if tk > tc:
            sol2 = solve_ivp(rhs, (tc, tk), yc, method="DOP853", rtol=rtol, atol=atol,
                             max_step=max_step)
            nfev += sol2.nfev
            yk = sol2.y[:, -1]
        else:
            yk = yc
        gk = guard(yk)
        if (direction > 0 and gk >= 0.0) or (direction < 0 and gk <= 0.0) or \
                (direction == 0 and gk * sign_before <= 0.0):
            return SegmentResult(tk, yk, nfev, recovered)
        t, y = tk, yk  # the condition no longer holds at the tick: keep looking


@dataclass
class GaitRef:
    status: int
    error: float = math.nan
    t_switch: float = math.nan
    t_motor: float = math.nan
    t_end: float = math.nan
    final_state: np.ndarray = None
    e0: float = math.nan
    e_after_impact: float = math.nan
    swap_state: np.ndarray = None       # flipped, projected 8-state right after the swap
    motor_off_state: np.ndarray = None  # 8-state at motor off
    recovered: int = 0                  # grazing crossings scipy's own events missed


def horizontal_gait(robot: RefRobot, d1, d2, tau, *, tick=0.0, rtol=1e-13, atol=1e-13,
                    max_time=3.0, max_step=np.inf):
    """The horizontal gait of docs/model.md section 4, as three chained solve_ivp calls.

    1. swing about A (at the origin) from theta = 0 until B rises to A's height;
    2. swap (flip + projection), motor torque ``tau`` until the energy is back to E0;
    3. swing until theta1 crosses 0 (exact, never ticked).
    """
    fl = robot.flipped()
    s0 = np.array([0.0, 0.0, 0.0, 0.0, 0.0, 0.0, d1, d2])
    e0 = robot.energy8(s0)
    out = GaitRef(NO_SWITCH, e0=e0)

    def height(y):
        return robot.free_end_height(y[0], y[1])

    def height_rate(y):
        return (robot.L1 * math.sin(y[0]) * y[2]
                + robot.L2 * math.sin(y[0] + y[1]) * (y[2] + y[3]))

    seg = run_segment(robot.swing_rhs(0.0), 0.0, s0[[2, 3, 6, 7]], height, +1,
                      horizon=max_time, rtol=rtol, atol=atol, tick=tick, max_step=max_step,
                      rate=height_rate)
    out.recovered = seg.recovered
    if not math.isfinite(seg.t):
        return out
    out.t_switch = ts = seg.t
    s8 = robot.flip8(swing8((0.0, 0.0), seg.y))
    s8 = fl.attach(s8)
    out.swap_state = s8.copy()
    pivot = (s8[0], s8[1])
    out.e_after_impact = fl.energy8(s8)

    def energy_gap(y):
        return fl.energy8(swing8(pivot, y)) - e0

    y = s8[[2, 3, 6, 7]]
    if energy_gap(y) >= 0.0:      # level condition: already restored (no motor time)
        tm = ts
    else:
        seg = run_segment(fl.swing_rhs(tau), ts, y, energy_gap, +1, horizon=max_time,
                          rtol=rtol, atol=atol, tick=tick, max_step=max_step)
        if not math.isfinite(seg.t):
            out.status = ENERGY_NOT_RESTORED
            return out
        tm, y = seg.t, seg.y
    out.t_motor = tm - ts
    out.motor_off_state = swing8(pivot, y)
    seg = run_segment(fl.swing_rhs(0.0), tm, y, lambda y: y[0], 0, horizon=max_time,
                      rtol=rtol, atol=atol, max_step=max_step)
    if not math.isfinite(seg.t):
        out.status = NO_RETURN
        return out
    out.t_end = seg.t
    yf = seg.y
    out.final_state = swing8(pivot, yf)
    out.error = yf[1] ** 2 + (d1 - yf[2]) ** 2 + (d2 - yf[3]) ** 2
    out.status = OK
    return out


def first_height_maximum(robot: RefRobot, d1, d2, *, rtol=1e-13, atol=1e-13, horizon=3.0):
    """Time and height of the first local maximum of B's height above A in the gait's first
    swing (None if there is none within the horizon)."""
    def rate(t, y):
        return (robot.L1 * math.sin(y[0]) * y[2]
                + robot.L2 * math.sin(y[0] + y[1]) * (y[2] + y[3]))
    rate.terminal = True
    rate.direction = -1
    sol = solve_ivp(robot.swing_rhs(0.0), (0.0, horizon), [0.0, 0.0, d1, d2], method="DOP853",
                    rtol=rtol, atol=atol, events=[rate])
    if sol.status != 1:
        return None
    y = sol.y_events[0][0]
    return sol.t_events[0][0], robot.free_end_height(y[0], y[1])


def grazing_point(robot: RefRobot, u1, u2, delta, s_lo, s_hi):
    """``(d1, d2) = s (u1, u2)`` whose first swing lifts B to ``delta`` [m] above A at its
    highest (``delta`` small: a grazing swap). ``[s_lo, s_hi]`` must bracket it."""
    from scipy.optimize import brentq

    def f(s):
        r = first_height_maximum(robot, s * u1, s * u2)
        return (r[1] if r is not None else -1.0) - delta
    s = brentq(f, s_lo, s_hi, xtol=1e-15, rtol=1e-15)
    return s * u1, s * u2


# ----------------------------------------------------------------------------------------------
# Coulomb stick-slip (docs/model.md section 2: "treat sticking properly (an event)")
# ----------------------------------------------------------------------------------------------
@dataclass
class FrictionRun:
    events: list          # (t, dof, "stop" | "break", new mode)
    pieces: list          # (t0, t1, fmode, OdeSolution) covering [0, t_end]
    fmode: tuple          # modes at the end
    y: np.ndarray         # packed swing state at the end


def _initial_modes(robot, y, tau):
    c = (robot.c_pivot, robot.c_joint)
    fm = [1.0, 1.0]
    for k in range(2):
        if c[k] > 0.0 and y[2 + k] != 0.0:
            fm[k] = 1.0 if y[2 + k] > 0.0 else -1.0
    for k in range(2):
        if c[k] > 0.0 and y[2 + k] == 0.0:
            hold = robot.swing_holding_torque(y, tau, fm, k)
            fm[k] = 0.0 if abs(hold) <= c[k] else (-1.0 if hold > 0.0 else 1.0)
    return fm


def swing_with_friction(robot: RefRobot, y0, tau, t_end, *, rtol=1e-13, atol=1e-13,
                        max_events=200):
    """A swing with viscous and Coulomb friction as chained solve_ivp calls.

    The Coulomb force of a slipping DOF has the sign of its slip direction (held constant); its
    speed reaching zero is a terminal event, after which it sticks if the torque needed to hold
    it is within the Coulomb limit and otherwise slips the other way. A stuck DOF is held at
    zero acceleration until the holding torque reaches the limit (terminal event), then slips
    in the direction the unheld DOF would move.
    """
    c = (robot.c_pivot, robot.c_joint)
    y = np.array(y0, float)
    fm = _initial_modes(robot, y, tau)
    t = 0.0
    events, pieces = [], []
    while t < t_end and len(events) < max_events:
        guards = []
        for k in range(2):
            if c[k] <= 0.0:
                continue
            if fm[k] != 0.0:
                def g(tt, yy, k=k, s=fm[k]):
                    return yy[2 + k] * s
                g.direction = -1
                g.kind = "stop"
            else:
                def g(tt, yy, k=k, fmode=tuple(fm)):
                    return abs(robot.swing_holding_torque(yy, tau, fmode, k)) - c[k]
                g.direction = 1
                g.kind = "break"
            g.terminal = True
            g.dof = k
            guards.append(g)
        sol = solve_ivp(robot.swing_rhs(tau, tuple(fm)), (t, t_end), y, method="DOP853",
                        rtol=rtol, atol=atol, events=guards or None, dense_output=True)
        t1 = sol.t[-1]
        pieces.append((t, t1, tuple(fm), sol.sol))
        y = sol.y[:, -1].copy()
        t = t1
        if sol.status != 1:
            break
        i = next(j for j, te in enumerate(sol.t_events) if len(te))
        g = guards[i]
        k = g.dof
        y = sol.y_events[i][0].copy()
        y[2 + k] = 0.0
        hold = robot.swing_holding_torque(y, tau, fm, k)
        if g.kind == "stop" and abs(hold) <= c[k]:
            fm[k] = 0.0
        else:
            fm[k] = -1.0 if hold > 0.0 else 1.0
        events.append((t, k, g.kind, fm[k]))
    return FrictionRun(events, pieces, tuple(fm), y)


def friction_state_at(run: FrictionRun, t):
    for t0, t1, fm, sol in run.pieces:
        if t0 <= t <= t1:
            y = sol(t)
            for k in range(2):
                if fm[k] == 0.0:
                    y[2 + k] = 0.0
            return y
    raise ValueError(t)
