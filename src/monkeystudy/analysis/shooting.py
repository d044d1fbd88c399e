"""Exact fixed points of a gait by shooting (docs/model.md section 4).

:func:`shoot_cycle` solves the repeatability residual of one cycle of any gait (its section's
``theta2`` held) by Gauss-Newton, :func:`shoot_horizontal` the horizontal gait's;
:func:`shoot_grazing` solves the grazing border's own equations (end B at end A's height at
rest), whose solution is an exact, motorless, collisionless gait for mirror-image links.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..controllers import Integrator, PhaseSequence, Segment, SequenceGait, horizontal_gait
from ..kernel import layout as L
from ..kernel.gait import wrapped_difference
from ..robot import SEED2009_TORQUE
from ..simulation import (
    RobotLike, Status, as_robot, evaluate_cycle_gaits, initial_state, run_controller,
    swap_motor_times,
)
from .sections import TIGHT


@dataclass
class ShootResult:
    """Fixed point of a gait's cycle (docs/model.md section 4) found by shooting.

    ``residual`` is ``(theta2_f - theta2, dtheta1_f - dtheta1, dtheta2_f - dtheta2)`` [rad,
    rad s-1, rad s-1] (the theta2 difference wrapped as the gait's error wraps it); the
    error is its squared norm. Times of the cycle [s]: ``t_switch`` the first segment's exit
    (the swap), ``t_motor`` the second segment's duration (the motor phase), ``t_end`` the
    section. ``history`` holds the residual norm per iteration (quadratic convergence shows as
    the exponent doubling).
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


def _residuals(points, gait, robot, integrator):
    r = evaluate_cycle_gaits(points, gait, robot=robot, integrator=integrator)
    fs = r["final_state"]
    pts = np.asarray(points, float).reshape(-1, 2)
    d2 = fs[:, L.TH2] - gait.theta2
    if gait.wrap_theta2:
        d2 = np.array([wrapped_difference(th2, gait.theta2) for th2 in fs[:, L.TH2]])
    res = np.column_stack([d2, fs[:, L.DTH1] - pts[:, 0], fs[:, L.DTH2] - pts[:, 1]])
    res[r["status"] != 0] = np.nan
    return res, dict(r, **swap_motor_times(r["t_segment"][:, [0, 1, -1]]))


def shoot_horizontal(start, *, robot: RobotLike = "seed2009", torque: float = SEED2009_TORQUE,
                     integrator: Integrator = TIGHT, tol: float = 1e-14, max_iter: int = 40,
                     fd_step: float = 1e-6) -> ShootResult:
    """:func:`shoot_cycle` of the horizontal gait (:func:`~monkeystudy.controllers.
    horizontal_gait`, motor ``torque`` [N m], exact events): its repeatability residual in
    ``(dtheta1, dtheta2)`` [rad s-1] from ``start``."""
    return shoot_cycle(start, horizontal_gait(torque), robot=robot, integrator=integrator,
                       tol=tol, max_iter=max_iter, fd_step=fd_step)


def shoot_cycle(start, gait: SequenceGait, *, robot: RobotLike = "seed2009",
                integrator: Integrator = TIGHT, tol: float = 1e-14, max_iter: int = 40,
                fd_step: float = 1e-6) -> ShootResult:
    """Solve the repeatability residual of one cycle of ``gait`` (a gait with at least two
    segments before its section) for the start's ``(dtheta1, dtheta2)`` [rad s-1], its
    ``theta2`` held at the section's.

    Three residuals, two unknowns: a motor that restores the energy ties the residuals
    together, so an exact gait is a zero of all three (a square system on the energy surface).
    Gauss-Newton with a central-difference Jacobian and a backtracking line search on the
    residual norm (a step that crosses the grazing border, where the swap jumps a whole swing,
    raises the norm and is cut back, so the iterate stays on its side of the border).
    Stops when the step or the residual norm falls below ``tol``; a minimum that is not a
    zero shows as a residual norm that stalls above ``tol`` with a vanishing step.
    """
    robot = as_robot(robot)
    x = np.array(start, dtype=float).reshape(2)
    r, info = _residuals(x[None], gait, robot, integrator)
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
        rr, _ = _residuals(pts, gait, robot, integrator)
        if not np.all(np.isfinite(rr)):
            message = "finite-difference stencil left the gait region (grazing border)"
            break
        J = np.column_stack([(rr[0] - rr[1]) / (2 * h[0]), (rr[2] - rr[3]) / (2 * h[1])])
        step, *_ = np.linalg.lstsq(J, -r, rcond=None)
        lam = 1.0
        accepted = False
        for _ in range(30):
            xn = x + lam * step
            rn, _ = _residuals(xn[None], gait, robot, integrator)
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
    _, info = _residuals(x[None], gait, robot, integrator)
    return ShootResult(float(x[0]), float(x[1]), float(r @ r), r, Status(int(info["status"][0])),
                       float(info["t_switch"][0]), float(info["t_motor"][0]),
                       float(info["t_end"][0]), converged, it, history, J, message)


def free_end_after(dtheta1: float, dtheta2: float, t: float, *, robot: RobotLike = "seed2009",
                   integrator: Integrator = TIGHT) -> np.ndarray:
    """Free end B relative to A after swinging freely for ``t`` [s] from the vertical:
    ``(height above A [m], vx [m s-1], vy [m s-1])``."""
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


