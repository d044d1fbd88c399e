"""Gait analysis beyond the 2009 study: exact fixed points, return maps, Floquet multipliers,
and the controller-tick question.

Everything here asks the one simulation path (:func:`monkeystudy.simulate.evaluate_gaits` and
:func:`monkeystudy.simulate.run_controller`) for what it needs; nothing integrates on its own.

Return maps live on the Poincare section "link 1 passes the vertical" (``theta1 = 0``). The
section state is ``z = (theta2, dtheta1, dtheta2)``: ``theta1`` is fixed by the section, the
attached end's position is neutral (the gait is translation invariant, so height and x drop
out), and after a cycle the frame has flipped to the other end, which plays the same role.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from .controllers import HorizontalSearch, Integrator, OpenLoop
from .kernel import layout as L
from .robot import SEED2009_TORQUE
from .simulate import RobotLike, Status, as_robot, evaluate_gaits, initial_state, run_controller

#: Tight integrator for analysis: the return map must be far more accurate than the finite
#: difference steps used on it.
TIGHT = Integrator(method="dop853", rtol=1e-13, atol=1e-13)


# ------------------------------------------------------------------------------------------
# Newton (Gauss-Newton) shooting for the horizontal gait
# ------------------------------------------------------------------------------------------
@dataclass
class ShootResult:
    """Fixed point of the horizontal gait (MODEL.md section 4) found by shooting.

    ``residual`` is ``(theta2_f, dtheta1_f - dtheta1, dtheta2_f - dtheta2)`` [rad, rad s-1,
    rad s-1]; the study's error is its squared norm. ``history`` holds the residual norm per
    iteration (quadratic convergence shows as the exponent doubling).
    """

    dtheta1: float
    dtheta2: float
    error: float
    residual: np.ndarray
    status: Status
    t_switch: float
    t_motor: float
    t_end: float
    converged: bool
    iterations: int
    history: list = field(default_factory=list)
    jacobian: np.ndarray = field(default_factory=lambda: np.zeros((3, 2)))
    message: str = ""


def _residuals(points, robot, torque, integrator):
    r = evaluate_gaits(points, robot=robot, torque=torque, integrator=integrator,
                       skip_unreachable=True)
    fs = r["final_state"]
    pts = np.asarray(points, float).reshape(-1, 2)
    res = np.column_stack([fs[:, L.TH2], fs[:, L.DTH1] - pts[:, 0], fs[:, L.DTH2] - pts[:, 1]])
    res[r["status"] != 0] = np.nan
    return res, r


def shoot_horizontal(start, *, robot: RobotLike = "seed2009", torque: float = SEED2009_TORQUE,
                     integrator: Integrator = TIGHT, tol: float = 1e-14, max_iter: int = 40,
                     fd_step: float = 1e-6) -> ShootResult:
    """Solve the horizontal gait's repeatability residual for ``(dtheta1, dtheta2)``.

    Three residuals, two unknowns: the motor restores the energy, which ties the residuals
    together, so an exact gait is a zero of all three (a square system on the energy surface).
    Gauss-Newton with a central-difference Jacobian and a backtracking line search on the
    residual norm (a step that crosses the grazing border, where the swap jumps a whole swing,
    raises the norm and is cut back, so the iterate stays on its side of the border).
    Stops when the step or the residual norm falls below ``tol``; a minimum that is not a
    zero shows as a residual norm that stalls above ``tol`` with a vanishing step.
    """
    robot = as_robot(robot)
    x = np.array(start, dtype=float).reshape(2)
    r, info = _residuals(x[None], robot, torque, integrator)
    r = r[0]
    if not np.all(np.isfinite(r)):
        return ShootResult(x[0], x[1], math.nan, r, Status(int(info["status"][0])), math.nan,
                           math.nan, math.nan, False, 0, [], np.full((3, 2), np.nan),
                           "no gait at the start point")
    history = [float(np.linalg.norm(r))]
    J = np.full((3, 2), np.nan)
    converged = False
    message = "maximum iterations reached"
    it = 0
    for it in range(1, max_iter + 1):
        h = fd_step * np.maximum(1.0, np.abs(x))
        pts = np.array([x + [h[0], 0], x - [h[0], 0], x + [0, h[1]], x - [0, h[1]]])
        rr, _ = _residuals(pts, robot, torque, integrator)
        if not np.all(np.isfinite(rr)):
            message = "finite-difference stencil left the gait region (grazing border)"
            break
        J = np.column_stack([(rr[0] - rr[1]) / (2 * h[0]), (rr[2] - rr[3]) / (2 * h[1])])
        step, *_ = np.linalg.lstsq(J, -r, rcond=None)
        lam = 1.0
        accepted = False
        for _ in range(30):
            xn = x + lam * step
            rn, _ = _residuals(xn[None], robot, torque, integrator)
            rn = rn[0]
            if np.all(np.isfinite(rn)) and np.linalg.norm(rn) < np.linalg.norm(r):
                accepted = True
                break
            lam *= 0.5
        if not accepted:
            message = "no decrease along the Gauss-Newton step: a non-zero minimum or the " \
                      "limit of the integrator"
            converged = history[-1] < 1e3 * tol
            break
        x = xn
        r = rn
        history.append(float(np.linalg.norm(r)))
        if history[-1] <= tol or np.linalg.norm(lam * step) <= tol * max(1.0, np.abs(x).max()):
            converged = True
            message = "converged"
            break
    _, info = _residuals(x[None], robot, torque, integrator)
    return ShootResult(float(x[0]), float(x[1]), float(r @ r), r, Status(int(info["status"][0])),
                       float(info["t_switch"][0]), float(info["t_motor"][0]),
                       float(info["t_end"][0]), converged, it, history, J, message)


def free_end_after(dtheta1: float, dtheta2: float, t: float, *, robot: RobotLike = "seed2009",
                   integrator: Integrator = TIGHT) -> np.ndarray:
    """Free end B relative to A after swinging freely for ``t`` [s] from the vertical:
    ``(height above A [m], vx [m s-1], vy [m s-1])``."""
    from .controllers import PhaseSequence, Segment

    robot = as_robot(robot)
    ctrl = PhaseSequence([Segment("time", value=float(t), ticked=False, next=-1)], ())
    res = run_controller(ctrl, initial_state(dtheta1, dtheta2), robot=robot,
                         integrator=integrator, log_capacity=0)
    s = res.state
    p = res.params[int(s[L.H_FLIPPED])]
    L1, L2 = p[L.P_L1], p[L.P_L2]
    th1, th2, w1, w2 = s[L.TH1], s[L.TH2], s[L.DTH1], s[L.DTH2]
    height = -L1 * math.cos(th1) - L2 * math.cos(th1 + th2)
    vx = L1 * math.cos(th1) * w1 + L2 * math.cos(th1 + th2) * (w1 + w2)
    vy = L1 * math.sin(th1) * w1 + L2 * math.sin(th1 + th2) * (w1 + w2)
    return np.array([height, vx, vy])


@dataclass
class GrazingResult:
    """A collisionless swap: B reaches A's height at rest (the grazing border's zero-cost
    point). ``residual`` = (height, vx, vy) of B at ``t_switch``."""

    dtheta1: float
    dtheta2: float
    t_switch: float
    residual: np.ndarray
    converged: bool
    history: list


def shoot_grazing(start, t_guess: float, *, robot: RobotLike = "seed2009",
                  integrator: Integrator = TIGHT, tol: float = 1e-14,
                  max_iter: int = 30) -> GrazingResult:
    """Newton on ``(dtheta1, dtheta2, t)`` for B at A's height with zero velocity.

    The horizontal gait's error is not smooth on the grazing border (the swap time has a
    square-root singularity there, and just outside it the swap jumps a whole swing), so its
    zero cannot be reached by a local method on the error. Its equations can: three smooth
    conditions, no events. For a robot whose links are mirror images (``seed2009``), the
    motion after a collisionless swap retraces the approach in mirror image, so the gait
    returns to the vertical with its start velocities and needs no motor: an exact fixed
    point of the open-loop return map with ``t_switch`` and ``t_motor = 0``.
    """
    robot = as_robot(robot)
    u = np.array([start[0], start[1], t_guess], float)
    F = free_end_after(*u, robot=robot, integrator=integrator)
    history = [float(np.linalg.norm(F))]
    converged = False
    for _ in range(max_iter):
        J = np.empty((3, 3))
        for j in range(3):
            h = 1e-6 * max(1.0, abs(u[j]))
            e = np.zeros(3)
            e[j] = h
            J[:, j] = (free_end_after(*(u + e), robot=robot, integrator=integrator)
                       - free_end_after(*(u - e), robot=robot, integrator=integrator)) / (2 * h)
        step = np.linalg.solve(J, -F)
        lam = 1.0
        for _ in range(30):
            Fn = free_end_after(*(u + lam * step), robot=robot, integrator=integrator)
            if np.linalg.norm(Fn) < np.linalg.norm(F):
                break
            lam *= 0.5
        else:
            break
        u = u + lam * step
        F = Fn
        history.append(float(np.linalg.norm(F)))
        if history[-1] <= tol or np.linalg.norm(lam * step) <= tol * max(1.0, abs(u).max()):
            converged = True
            break
    return GrazingResult(float(u[0]), float(u[1]), float(u[2]), F, converged, history)


# ------------------------------------------------------------------------------------------
# return maps and Floquet multipliers
# ------------------------------------------------------------------------------------------
def section_state(z) -> np.ndarray:
    """Hybrid state on the section: hanging from the frame's (x, y) end at the origin with
    ``theta1 = 0`` and ``z = (theta2, dtheta1, dtheta2)``."""
    th2, w1, w2 = (float(v) for v in z)
    return initial_state(w1, w2, theta2=th2)


def open_loop_return_map(z, *, t_switch: float, t_motor: float,
                         torque: float = SEED2009_TORQUE, robot: RobotLike = "seed2009",
                         integrator: Integrator = TIGHT, tick: float = 0.0,
                         tick_phase: float = 0.0) -> tuple[np.ndarray, Status]:
    """One cycle of the open-loop controller with its clock reset at the vertical.

    From ``z`` on the section: swap at ``t_switch``, motor ``torque`` for ``t_motor``, then on
    to the next vertical crossing. Returns the next section state and the run status.
    """
    ctrl = OpenLoop(t_switch, t_motor, torque, tick=tick, tick_phase=tick_phase,
                    clock="reset_at_vertical")
    res = run_controller(ctrl, section_state(z), robot=robot, integrator=integrator, cycles=1,
                         log_capacity=0)
    s = res.state
    return np.array([s[L.TH2], s[L.DTH1], s[L.DTH2]]), res.status


def search_return_map(z, *, torque: float = SEED2009_TORQUE, robot: RobotLike = "seed2009",
                      integrator: Integrator = TIGHT) -> tuple[np.ndarray, Status]:
    """One cycle of the state-based search controller (swap at B height, motor until the
    cycle-start energy is restored, stop at the vertical) from section state ``z``."""
    res = run_controller(HorizontalSearch(torque), section_state(z), robot=robot,
                         integrator=integrator, log_capacity=0)
    s = res.state
    return np.array([s[L.TH2], s[L.DTH1], s[L.DTH2]]), res.status


def jacobian_fd(fmap, z, step: float = 1e-5) -> np.ndarray:
    """Central-difference Jacobian of a return map ``fmap(z) -> (z', status)``.

    Fourth-order (Richardson on steps ``h`` and ``2h``): truncation ~``h^4``, round-off
    ~``delta / h`` with ``delta`` the map's accuracy (~1e-13 at the tight tolerance).
    """
    z = np.asarray(z, float)
    n = z.size
    J = np.empty((n, n))
    for j in range(n):
        h = step * max(1.0, abs(z[j]))
        cols = []
        for hh in (h, 2 * h):
            e = np.zeros(n)
            e[j] = hh
            fp, sp = fmap(z + e)
            fm, sm = fmap(z - e)
            if sp != Status.OK or sm != Status.OK:
                raise RuntimeError("the finite-difference stencil left the gait (status "
                                   f"{Status(sp).name}/{Status(sm).name})")
            cols.append((fp - fm) / (2 * hh))
        J[:, j] = (4 * cols[0] - cols[1]) / 3
    return J


@dataclass
class FloquetResult:
    """Multipliers of a gait's return map on the section ``theta1 = 0``."""

    fixed_point: np.ndarray
    map_defect: float          # |P(z*) - z*|
    jacobian: np.ndarray
    multipliers: np.ndarray    # eigenvalues, sorted by decreasing modulus
    stable: bool               # all |lambda| < 1 (neutral directions excluded, see below)
    neutral: int               # multipliers within 1e-6 of 1 (the energy level for the
                               # state-based controller)


def floquet(fmap, z_star, *, step: float = 1e-5, neutral_tol: float = 1e-6) -> FloquetResult:
    """Floquet multipliers of ``fmap`` at ``z_star`` by finite differences."""
    z_star = np.asarray(z_star, float)
    zn, st = fmap(z_star)
    if st != Status.OK:
        raise RuntimeError(f"no cycle from the fixed point (status {Status(st).name})")
    J = jacobian_fd(fmap, z_star, step)
    lam = np.linalg.eigvals(J)
    lam = lam[np.argsort(-np.abs(lam))]
    neutral = np.abs(lam - 1.0) < neutral_tol
    stable = bool(np.all(np.abs(lam[~neutral]) < 1.0))
    return FloquetResult(z_star, float(np.linalg.norm(zn - z_star)), J, lam, stable,
                         int(neutral.sum()))


# ------------------------------------------------------------------------------------------
# open-loop runs: error per cycle
# ------------------------------------------------------------------------------------------
@dataclass
class CycleRun:
    """Per-cycle record of an open-loop run (MODEL.md section 4, the study's figs. 5-7)."""

    error: np.ndarray            # at each vertical crossing, vs the gait start
    kinetic_energy: np.ndarray   # [J] at each vertical crossing
    pivot_height: np.ndarray     # [m] attached end after each swap
    x_advance: np.ndarray        # [m] attached-end displacement per swap
    t_cross: np.ndarray          # [s]
    status: Status


def open_loop_cycles(dtheta1: float, dtheta2: float, *, t_switch: float, t_motor: float,
                     cycles: int, torque: float = SEED2009_TORQUE,
                     robot: RobotLike = "seed2009", integrator: Integrator = TIGHT,
                     tick: float = 0.0, tick_phase: float = 0.0,
                     clock: str = "reset_at_vertical", period: float = math.nan,
                     max_drop: float | None = None, theta2: float = 0.0) -> CycleRun:
    """Replay a gait's times open-loop for ``cycles`` cycles and measure it per cycle."""
    from .simulate import energies

    robot = as_robot(robot)
    if max_drop is None:
        max_drop = robot.link1.length
    ctrl = OpenLoop(t_switch, t_motor, torque, tick=tick, tick_phase=tick_phase, clock=clock,
                    period=period)
    res = run_controller(ctrl, initial_state(dtheta1, dtheta2, theta2=theta2), robot=robot,
                         integrator=integrator, cycles=cycles, max_drop=max_drop,
                         log_capacity=8 * cycles + 16)
    log = res.log
    obs = log[log[:, L.L_KIND] == L.LOG_OBSERVER]
    states = obs[:, L.L_STATE:L.L_STATE + 8]
    flipped = obs[:, L.L_FLIPPED]
    err = (states[:, L.TH2] ** 2 + (dtheta1 - states[:, L.DTH1]) ** 2
           + (dtheta2 - states[:, L.DTH2]) ** 2)
    ke, _ = energies(res.params, states, flipped)
    swaps = log[(log[:, L.L_KIND] == L.LOG_SEGMENT) & (log[:, L.L_ID] == 0)]
    piv = swaps[:, L.L_STATE:L.L_STATE + 8]
    x_prev = np.concatenate([[0.0], piv[:-1, L.X]])
    return CycleRun(err, ke, piv[:, L.Y], piv[:, L.X] - x_prev, obs[:, L.L_T], res.status)
