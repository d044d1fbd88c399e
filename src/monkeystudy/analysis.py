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

from .controllers import HorizontalSearch, Integrator, OpenLoop, SequenceGait
from .kernel import layout as L
from .kernel.gait import wrapped_difference
from .robot import SEED2009_TORQUE
from .simulate import (
    RobotLike, Status, as_robot, evaluate_gaits, gait_error, initial_state, run_controller,
)

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


def _section_of(hyb) -> np.ndarray:
    """Section coordinates of a hybrid state; theta2 modulo 2 pi, in [-pi, pi) (a gait may
    turn link 2 a full revolution per cycle)."""
    th2 = (hyb[L.TH2] + math.pi) % (2 * math.pi) - math.pi
    return np.array([th2, hyb[L.DTH1], hyb[L.DTH2]])


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
    return _section_of(res.state), res.status


def search_return_map(z, *, torque: float = SEED2009_TORQUE, robot: RobotLike = "seed2009",
                      integrator: Integrator = TIGHT) -> tuple[np.ndarray, Status]:
    """One cycle of the state-based search controller (swap at B height, motor until the
    cycle-start energy is restored, stop at the vertical) from section state ``z``."""
    res = run_controller(HorizontalSearch(torque), section_state(z), robot=robot,
                         integrator=integrator, log_capacity=0)
    return _section_of(res.state), res.status


def cycle_section_state(gait: SequenceGait, z) -> np.ndarray:
    """Hybrid state on a sequence gait's section: hanging from A at the origin, ``theta1 =
    gait.section_theta1``, ``z = (theta2 [rad], dtheta1, dtheta2 [rad s-1])``."""
    th2, w1, w2 = (float(v) for v in z)
    return initial_state(w1, w2, theta1=gait.section_theta1, theta2=th2)


def check_cycle_frame(gait: SequenceGait, robot) -> None:
    """A cycle ending on end B compares like with like only for mirror-image links."""
    if gait.end_attached() == "B":
        _check_mirror_links(as_robot(robot))


def cycle_return_map(z, gait: SequenceGait, *, robot: RobotLike = "seed2009",
                     integrator: Integrator = TIGHT) -> tuple[np.ndarray, Status]:
    """One cycle of a sequence gait from section state ``z = (theta2, dtheta1, dtheta2)``.

    Returns the section state at the cycle's end (``theta2`` continued from ``z[0]`` across
    whole turns, so the map is smooth) and the run status. A cycle that ends hanging from B
    needs mirror-image links (``ValueError`` otherwise).
    """
    robot = as_robot(robot)
    check_cycle_frame(gait, robot)
    res = run_controller(gait.controller(), cycle_section_state(gait, z), robot=robot,
                         integrator=integrator, cycles=1, log_capacity=0)
    th2 = float(z[0]) + wrapped_difference(res.state[L.TH2], float(z[0]))
    return np.array([th2, res.state[L.DTH1], res.state[L.DTH2]]), res.status


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
    crossing_state: np.ndarray = field(default_factory=lambda: np.zeros((0, 8)))

    def error_vs(self, dtheta1: float, dtheta2: float) -> np.ndarray:
        """Per-cycle error (MODEL.md section 4) against the rates of another gait."""
        return gait_error(self.crossing_state, dtheta1, dtheta2)


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
    err = gait_error(states, dtheta1, dtheta2)
    ke, _ = energies(res.params, states, flipped)
    swaps = log[(log[:, L.L_KIND] == L.LOG_SEGMENT) & (log[:, L.L_ID] == 0)]
    piv = swaps[:, L.L_STATE:L.L_STATE + 8]
    x_prev = np.concatenate([[0.0], piv[:-1, L.X]])
    return CycleRun(err, ke, piv[:, L.Y], piv[:, L.X] - x_prev, obs[:, L.L_T], res.status,
                    states.copy())


# ------------------------------------------------------------------------------------------
# Floquet multipliers from the variational equations (saltation matrices at the events)
# ------------------------------------------------------------------------------------------
def _check_mirror_links(robot):
    par = robot.params()
    if not np.allclose(par[0], par[1], rtol=0, atol=1e-14):
        raise ValueError("one-cycle return maps need mirror-image links (the frame flips at "
                         "every swap); compose two cycles for this robot")


def _integrate_variational(p, tau, y0, Phi0, t0, t1, rtol):
    """State and transition matrix of the swing phase from ``t0`` to ``t1``."""
    from scipy.integrate import solve_ivp

    from .kernel.variational import swing_variational_rhs

    fm = np.ones(2)
    dY = np.empty(20)

    def fun(t, Y):
        swing_variational_rhs(p, tau, fm, Y, dY)
        return dY.copy()

    Y0 = np.concatenate([y0, Phi0.ravel()])
    if t1 <= t0:
        return y0.copy(), Phi0.copy()
    sol = solve_ivp(fun, (t0, t1), Y0, method="DOP853", rtol=rtol, atol=rtol * 1e-2)
    Y = sol.y[:, -1]
    return Y[:4].copy(), Y[4:].reshape(4, 4).copy()


def variational_jacobian(controller: str, z, *, t_switch: float = math.nan,
                         t_motor: float = math.nan, torque: float = SEED2009_TORQUE,
                         robot: RobotLike = "seed2009", integrator: Integrator = TIGHT,
                         rtol: float = 1e-12) -> np.ndarray:
    """Jacobian of the return map on ``theta1 = 0`` by variational equations.

    ``controller`` is ``"open_loop"`` (exact times ``t_switch``, ``t_motor``, clock reset at
    the vertical) or ``"search"`` (the state-based controller). Event times come from one
    kernel run; the state and its transition matrix ``Phi`` are then integrated through each
    phase (``dPhi/dt = A Phi``, ``A`` by complex step), and at each event

    * a time-triggered swap maps ``Phi -> DR Phi`` (``DR`` the flip-and-impact Jacobian);
    * a state-triggered swap (guard ``g``) uses the saltation matrix
      ``S = DR + (f+ - DR f-) grad(g)^T / (grad(g) . f-)``;
    * motor off when the energy is restored (``g = E(x) - E(x0)``, whose reference depends on
      the start): ``Phi -> Phi + (f+ - f-)(grad E^T Phi - grad E0^T) / (grad E . f-)``;
    * the section itself (``theta1 = 0``, free end time): ``(I - f e1^T / f_1) Phi``.
    """
    from .kernel.variational import (
        swap_jacobian, swap_state, swing_energy_gradient, swing_field,
    )

    robot = as_robot(robot)
    _check_mirror_links(robot)
    par = robot.params()
    z = np.asarray(z, float)
    if controller == "open_loop":
        ctrl = OpenLoop(t_switch, t_motor, torque, clock="reset_at_vertical")
        res = run_controller(ctrl, section_state(z), robot=robot, integrator=integrator,
                             cycles=1, log_capacity=16)
    elif controller == "search":
        res = run_controller(HorizontalSearch(torque), section_state(z), robot=robot,
                             integrator=integrator, log_capacity=16)
    else:
        raise ValueError(f"controller must be 'open_loop' or 'search', got {controller!r}")
    if res.status != Status.OK:
        raise RuntimeError(f"no cycle from z (status {res.status.name})")
    t_sw, t_off, t_end = res.segment_times[:3]
    L1, L2 = par[0][L.P_L1], par[0][L.P_L2]
    y0 = np.array([0.0, z[0], z[1], z[2]])
    fa, fb = np.empty(4), np.empty(4)
    # swing about A until the swap
    y, Phi = _integrate_variational(par[0], 0.0, y0, np.eye(4), 0.0, t_sw, rtol)
    DR = np.empty((4, 4))
    swap_jacobian(par[0], par[1], y, DR)
    y_plus = swap_state(par[0], par[1], y)
    if controller == "search":
        swing_field(par[0], 0.0, np.ones(2), y, fa)
        swing_field(par[1], torque, np.ones(2), y_plus, fb)
        s1, s12 = math.sin(y[0]), math.sin(y[0] + y[1])
        grad = np.array([L1 * s1 + L2 * s12, L2 * s12, 0.0, 0.0])
        Phi = (DR + np.outer(fb - DR @ fa, grad) / (grad @ fa)) @ Phi
    else:
        Phi = DR @ Phi
    y = y_plus
    # motor on until it stops
    y, Phi = _integrate_variational(par[1], torque, y, Phi, t_sw, t_off, rtol)
    if controller == "search" and t_off > t_sw:
        swing_field(par[1], torque, np.ones(2), y, fa)
        swing_field(par[1], 0.0, np.ones(2), y, fb)
        gE, gE0 = np.empty(4), np.empty(4)
        swing_energy_gradient(par[1], 0.0, y, gE)
        swing_energy_gradient(par[0], 0.0, y0, gE0)
        Phi = Phi + np.outer(fb - fa, gE @ Phi - gE0) / (gE @ fa)
    # to the vertical; the section's crossing time is free
    y, Phi = _integrate_variational(par[1], 0.0, y, Phi, t_off, t_end, rtol)
    swing_field(par[1], 0.0, np.ones(2), y, fa)
    e1 = np.array([1.0, 0.0, 0.0, 0.0])
    M = (np.eye(4) - np.outer(fa, e1) / fa[0]) @ Phi
    return M[1:, 1:]


@dataclass
class FixedPointResult:
    """Fixed point of a return map by Newton's method (residual history per iteration)."""

    z: np.ndarray
    defect: float
    converged: bool
    history: list
    jacobian: np.ndarray


def solve_fixed_point(fmap, z0, *, jacobian=None, rtol: float = 1e-12,
                      max_iter: int = 30, rcond: float = 1e-7) -> FixedPointResult:
    """Newton on ``P(z) - z = 0`` with a least-squares step.

    A neutral multiplier (the energy level of the state-based controller, which restores
    every cycle's start energy) makes ``DP - I`` singular: fixed points come in a family.
    The minimum-norm step moves across the family, not along it, and still converges
    quadratically to one of its members. ``jacobian(z)`` defaults to finite differences.
    Converged when ``|P(z) - z| <= rtol * max(1, |z|)``: the map itself is only accurate to
    about its integrator's tolerance times ``|z|`` (1e-13 for :data:`TIGHT`), so ``rtol``
    sits one decade above that noise floor. ``rcond``: singular values of ``DP - I`` below
    ``rcond`` times the largest are taken as zero. The neutral one is zero only to the
    Jacobian's accuracy (~1e-9 by variational equations at rtol 1e-12); kept, it would turn
    the part of ``P(z) - z`` that lies off the family's range into a step ~1e9 times too
    long.
    """
    jac = jacobian or (lambda q: jacobian_fd(fmap, q))
    z = np.asarray(z0, float).copy()
    zn, st = fmap(z)
    if st != Status.OK:
        raise RuntimeError(f"no cycle from the start (status {Status(st).name})")
    F = zn - z
    history = [float(np.linalg.norm(F))]
    J = np.full((z.size, z.size), np.nan)
    converged = False
    for _ in range(max_iter):
        J = jac(z)
        step, *_ = np.linalg.lstsq(J - np.eye(z.size), -F, rcond=rcond)
        lam = 1.0
        for _ in range(20):
            zt = z + lam * step
            zn, st = fmap(zt)
            if st == Status.OK and np.linalg.norm(zn - zt) < history[-1]:
                break
            lam *= 0.5
        else:
            break
        z = zt
        F = zn - z
        history.append(float(np.linalg.norm(F)))
        if history[-1] <= rtol * max(1.0, float(np.abs(z).max())):
            converged = True
            break
    return FixedPointResult(z, history[-1], converged, history, J)


# ------------------------------------------------------------------------------------------
# basins: cycles to failure around a gait
# ------------------------------------------------------------------------------------------
def basin(dtheta1: float, dtheta2: float, *, t_switch: float, t_motor: float, torque: float,
          offsets1, offsets2, max_cycles: int = 60, error_bound: float = 1e-2,
          robot: RobotLike = "seed2009", integrator: Integrator = TIGHT,
          tick: float = 0.0) -> np.ndarray:
    """Cycles an open-loop replay survives from perturbed starts (a basin map).

    Start ``(dtheta1 + a, dtheta2 + b)`` for ``a`` in ``offsets1``, ``b`` in ``offsets2``
    [rad s-1]; the run fails at the first vertical crossing whose error against the
    *unperturbed* gait exceeds ``error_bound``, or when it falls or stops. Returns an int array
    ``[len(offsets1), len(offsets2)]``; ``max_cycles`` means it never failed.
    """
    out = np.zeros((len(offsets1), len(offsets2)), np.int32)
    for i, a in enumerate(offsets1):
        for j, b in enumerate(offsets2):
            run = open_loop_cycles(dtheta1 + a, dtheta2 + b, t_switch=t_switch,
                                   t_motor=t_motor, cycles=max_cycles, torque=torque,
                                   robot=robot, integrator=integrator, tick=tick)
            err = run.error_vs(dtheta1, dtheta2)
            bad = np.flatnonzero(~(err <= error_bound))
            out[i, j] = int(bad[0]) if bad.size else len(err)
    return out


# ------------------------------------------------------------------------------------------
# continuation of the collisionless gait family
# ------------------------------------------------------------------------------------------
def mirror_robot(base: RobotLike, parameter: str, value: float):
    """The ``base`` robot with one mirror-symmetric parameter set to ``value``.

    ``com``: link 1's CG at ``value`` from A, link 2's at ``L - value`` from the joint (both
    links' CGs the same distance from the motor); ``inertia``: both inertias; ``gravity``.
    Mirror images keep the one-cycle return map meaningful.
    """
    from dataclasses import replace

    r = as_robot(base)
    l1, l2 = r.link1, r.link2
    if parameter == "com":
        return replace(r, link1=replace(l1, com=value), link2=replace(l2, com=l2.length - value),
                       name=f"{r.name}:com={value:.6g}")
    if parameter == "inertia":
        return replace(r, link1=replace(l1, inertia=value), link2=replace(l2, inertia=value),
                       name=f"{r.name}:inertia={value:.6g}")
    if parameter == "gravity":
        return replace(r, gravity=value, name=f"{r.name}:g={value:.6g}")
    raise ValueError(f"parameter must be 'com', 'inertia' or 'gravity', got {parameter!r}")


@dataclass
class Branch:
    """A continued family of collisionless gaits: one row per point on the branch."""

    parameter: str
    value: np.ndarray          # the parameter along the branch
    dtheta1: np.ndarray        # [rad s-1]
    dtheta2: np.ndarray
    t_switch: np.ndarray       # [s]
    multipliers: np.ndarray    # (n, 3) complex, sorted by modulus
    residual: np.ndarray       # |G| after correction
    folds: list                # indices where the parameter turns back
    period_doublings: list     # indices where a real multiplier crosses -1


def continue_grazing(start: GrazingResult, parameter: str, value0: float, *,
                     robot: RobotLike = "seed2009", ds: float = 0.01, steps: int = 20,
                     bounds=(-math.inf, math.inf), integrator: Integrator = TIGHT,
                     multipliers: bool = True) -> Branch:
    """Pseudo-arclength continuation of ``G(dtheta1, dtheta2, t; mu) = 0`` (B at A's height
    at rest after ``t``) in ``mu`` = ``parameter``, starting from a converged point at
    ``value0``.

    Tangent: the null vector of ``DG`` (3x4, by central differences), oriented along the
    previous one; corrector: Newton on ``[G; tangent . (u - u_pred)]``. Along the branch the
    open-loop return map's multipliers are computed by variational equations; a fold is where
    ``d mu / ds`` changes sign, a period doubling where a real multiplier crosses -1.
    """
    base = as_robot(robot)

    def G(u):
        rb = mirror_robot(base, parameter, u[3])
        return free_end_after(u[0], u[1], u[2], robot=rb, integrator=integrator)

    def DG(u):
        J = np.empty((3, 4))
        for j in range(4):
            h = 1e-7 * max(1.0, abs(u[j]))
            e = np.zeros(4)
            e[j] = h
            J[:, j] = (G(u + e) - G(u - e)) / (2 * h)
        return J

    def tangent(J, prev):
        _, _, vt = np.linalg.svd(J)
        t = vt[-1]
        if prev is None:
            return t if t[3] >= 0 else -t
        return t if t @ prev >= 0 else -t

    u = np.array([start.dtheta1, start.dtheta2, start.t_switch, value0], float)
    rows, res_norm, tau = [], [], None
    for k in range(steps + 1):
        J = DG(u)
        tau = tangent(J, tau)
        rows.append(u.copy())
        res_norm.append(float(np.linalg.norm(G(u))))
        if k == steps:
            break
        up = u + ds * tau
        v = up.copy()
        for _ in range(12):
            F = np.concatenate([G(v), [tau @ (v - up)]])
            if np.linalg.norm(F) < 1e-13:
                break
            A = np.vstack([DG(v), tau])
            v = v - np.linalg.solve(A, F)
        if not (bounds[0] <= v[3] <= bounds[1]) or not np.all(np.isfinite(v)):
            break
        u = v
    U = np.array(rows)
    mult = np.full((len(U), 3), np.nan, complex)
    if multipliers:
        for i, (d1, d2, ts, mu) in enumerate(U):
            rb = mirror_robot(base, parameter, mu)
            Jm = variational_jacobian("open_loop", np.array([0.0, d1, d2]), t_switch=ts,
                                      t_motor=0.0, torque=0.0, robot=rb, integrator=integrator)
            lam = np.linalg.eigvals(Jm)
            mult[i] = lam[np.argsort(-np.abs(lam))]
    dmu = np.diff(U[:, 3])
    folds = [int(i + 1) for i in np.flatnonzero(np.sign(dmu[1:]) != np.sign(dmu[:-1]))]
    pd = []
    for i in range(1, len(U)):
        for a, b in zip(mult[i - 1], mult[i]):
            if abs(a.imag) < 1e-9 and abs(b.imag) < 1e-9 and (a.real + 1) * (b.real + 1) < 0:
                pd.append(i)
    return Branch(parameter, U[:, 3], U[:, 0], U[:, 1], U[:, 2], mult, np.array(res_norm),
                  folds, sorted(set(pd)))
