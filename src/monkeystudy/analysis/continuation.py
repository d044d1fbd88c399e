"""Gait families: pseudo-arclength continuation in a robot or motor parameter, with the
Floquet multipliers and bifurcations along the branch.

The collisionless family of the horizontal gait (:func:`continue_grazing`) continues the
grazing border's own equations (a grazing swap is a border, not a smooth fixed point of the
return map); its multipliers are those of the motorless open-loop replay's return map. A
sequence gait's family (:func:`continue_cycle`) continues the fixed point of its return map (:func:`monkeystudy.analysis.sections.cycle_return_map`), whose Jacobian comes
from the variational equations through every phase
(:func:`monkeystudy.analysis.variational.sequence_variational_jacobian`).

Unknowns ``u = (theta2, dtheta1, dtheta2, mu)``; equations ``R(u) = P(z; mu) - z`` with
``z = (theta2, dtheta1, dtheta2)``. A gait that latches its energy at the cycle start and
restores it later has a family of fixed points (one multiplier is exactly 1: the energy level
is free), and ``R`` has rank 2: the phase condition ``theta2 = theta2_0`` then picks one
member. A gait with an isolated fixed point (e.g. one that tops its energy up to an absolute
level) keeps ``theta2`` free. Either way the solutions form a curve; Gauss-Newton with
least-squares steps solves the equations, and the tangent is the null vector of their
Jacobian.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

from ..controllers import (
    MIRRORED_MAGNETS, Integrator, SequenceGait, horizontal_gait, open_loop_gait,
)
from ..robot import Robot
from ..simulation import RobotLike, Status, as_robot, energies
from .sections import TIGHT, cycle_return_map, cycle_section_state
from .shooting import GrazingResult, free_end_after
from .variational import sequence_variational_jacobian

# --- the horizontal gait's collisionless family -----------------------------------------------
# ------------------------------------------------------------------------------------------
# continuation of the collisionless gait family
# ------------------------------------------------------------------------------------------
def mirror_robot(base: RobotLike, parameter: str, value: float):
    """The ``base`` robot with one mirror-symmetric parameter set to ``value``.

    ``com``: link 1's CG at ``value`` from A, link 2's at ``L - value`` from the joint (both
    links' CGs the same distance from the motor); ``inertia``: both inertias; ``gravity``.
    Mirror images keep the one-cycle return map meaningful.
    """
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
            # the motorless open-loop replay of the horizontal gait: swap at ts, no motor
            replay = open_loop_gait(horizontal_gait(0.0), [ts, ts])
            Jm = sequence_variational_jacobian(replay, np.array([0.0, d1, d2]), robot=rb,
                                               integrator=integrator)
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


# --- sequence gaits ---------------------------------------------------------------------------
#: parameters a sequence gait can be continued in, with their units
CYCLE_PARAMETERS = {
    "torque": "N m", "mass_ratio": "1", "com": "m", "inertia": "kg m2", "gravity": "m s-2",
    "joint_viscous": "N m s", "pivot_viscous": "N m s",
}

#: one link's own mass [kg], CG distance from its proximal end [m] and inertia about its CG
#: [kg m2] (``link1`` is the link of end A): a robot whose links differ is not its own mirror
#: image, so the family is continued on the gait's cycle of two steps (:func:`two_step_cycle`)
#: and its multipliers are those of two steps, the square of one step's at mirror-image links
LINK_PARAMETERS = {f"{link}_{what}": units for link in ("link1", "link2")
                   for what, units in (("mass", "kg"), ("com", "m"), ("inertia", "kg m2"))}
CYCLE_PARAMETERS.update(LINK_PARAMETERS)

#: least admissible values (a finite-difference stencil must not step below them)
PARAMETER_FLOOR = {"joint_viscous": 0.0, "pivot_viscous": 0.0, "mass_ratio": 1e-6,
                   **{name: 0.0 for name in LINK_PARAMETERS}}

#: multipliers within this of 1 are the neutral energy level, not a stability verdict
NEUTRAL_TOL = 1e-6

#: a family of fixed points survives a change of the parameter only if ``dP/dmu`` lies in
#: the range of ``DP - I``; a part off it larger than this fraction of ``|dP/dmu|`` (finite
#: differences and variational equations are good to ~1e-6 of it) breaks the family [1]
FAMILY_BREAK_TOL = 1e-4


def motor_torque(gait: SequenceGait) -> float:
    """The gait's reference motor torque [N m]: the first non-zero segment torque (the
    section segment's last); ``ValueError`` when the gait never runs its motor."""
    for seg in gait.segments:
        if seg.torque != 0.0:
            return float(seg.torque)
    if gait.section_torque != 0.0:
        return float(gait.section_torque)
    raise ValueError("the gait has no motor segment (every torque is 0): the motor torque "
                     "does not move its fixed points")


def parameter_of(robot: RobotLike, gait: SequenceGait, parameter: str) -> float:
    """The current value of a continuation ``parameter`` (units: :data:`CYCLE_PARAMETERS`).

    ``torque``: :func:`motor_torque`; ``mass_ratio``: link 2's mass over link 1's; ``com``,
    ``inertia``: link 1's (mirror-symmetric, see :func:`~monkeystudy.analysis.mirror_robot`);
    ``joint_viscous``, ``pivot_viscous``: the viscous friction coefficients.
    """
    r = as_robot(robot)
    if parameter == "torque":
        return motor_torque(gait)
    if parameter == "mass_ratio":
        return r.link2.mass / r.link1.mass
    if parameter == "com":
        return r.link1.com
    if parameter == "inertia":
        return r.link1.inertia
    if parameter == "gravity":
        return r.gravity
    if parameter == "joint_viscous":
        return r.joint_friction.viscous
    if parameter == "pivot_viscous":
        return r.pivot_friction.viscous
    if parameter in LINK_PARAMETERS:
        link, what = parameter.split("_")
        return float(getattr(getattr(r, link), what))
    raise ValueError(f"parameter must be one of {sorted(CYCLE_PARAMETERS)}, got {parameter!r}")


def two_step_cycle(gait: SequenceGait) -> SequenceGait:
    """The cycle of two steps of a gait whose cycle ends hanging from B: its segments, the
    section crossing (the clock restarts there, as at the end of a cycle), then its mirror
    image (every ``A`` and ``B`` magnet action exchanged, as a looped run's second cycle has
    them: :meth:`SequenceGait.loop_segments`), each ``free_end_y`` catch of the second step
    one ``rise`` higher; the rise per cycle
    doubles. Its cycle ends hanging from A, so its return map compares like with like for
    any robot, links that differ included. A gait whose cycle ends on A is returned as it
    is. ``ValueError`` for a running clock (its cycle is one period)."""
    if gait.end_attached() == "A":
        return gait
    if gait.clocked:
        raise ValueError("a running clock's cycle is one period: no two-step cycle")
    rows = gait.all_segments()
    n = len(rows)
    middle = replace(rows[-1], cycle_end=False, next=None)

    def mirrored(seg):
        # the second step hangs from B: A and B exchanged, a jump kept within its copy
        nxt = seg.next + n if seg.next is not None and seg.next >= 0 else seg.next
        value = seg.value + gait.rise if seg.until == "free_end_y" else seg.value
        return replace(seg, magnets=MIRRORED_MAGNETS.get(seg.magnets, seg.magnets), next=nxt,
                       value=value)

    first, second = rows[:-1], [mirrored(seg) for seg in rows[:-1]]
    return replace(gait, segments=(*first, middle, *second), rise=2.0 * gait.rise)


def with_parameter(robot: RobotLike, gait: SequenceGait, parameter: str, value: float):
    """``(robot, gait)`` with ``parameter`` set to ``value``.

    ``torque``: every motor torque scaled by ``value / motor_torque(gait)`` (signs and ratios
    kept). ``mass_ratio``: link masses ``M / (1 + q)`` and ``M q / (1 + q)`` at the same total
    mass ``M``, each inertia scaled with its link's mass (same shape, different density).
    ``com``, ``inertia``, ``gravity``: :func:`~monkeystudy.analysis.mirror_robot`. A link's
    own parameter (:data:`LINK_PARAMETERS`): that link's value, the gait's cycle of two steps
    (:func:`two_step_cycle`).
    """
    r = as_robot(robot)
    value = float(value)
    if parameter == "torque":
        scale = value / motor_torque(gait)
        segs = [replace(s, torque=s.torque * scale) for s in gait.segments]
        return r, replace(gait, segments=segs, section_torque=gait.section_torque * scale)
    if parameter == "mass_ratio":
        if not value > 0.0:
            raise ValueError(f"mass_ratio must be > 0, got {value!r}")
        total = r.link1.mass + r.link2.mass
        m1, m2 = total / (1.0 + value), total * value / (1.0 + value)
        l1 = replace(r.link1, mass=m1, inertia=r.link1.inertia * m1 / r.link1.mass)
        l2 = replace(r.link2, mass=m2, inertia=r.link2.inertia * m2 / r.link2.mass)
        return replace(r, link1=l1, link2=l2, name=f"{r.name}:mass_ratio={value:.6g}"), gait
    if parameter in ("com", "inertia", "gravity"):
        return mirror_robot(r, parameter, value), gait
    if parameter == "joint_viscous":
        return r.with_friction(joint=replace(r.joint_friction, viscous=value)), gait
    if parameter == "pivot_viscous":
        return r.with_friction(pivot=replace(r.pivot_friction, viscous=value)), gait
    if parameter in LINK_PARAMETERS:
        link, what = parameter.split("_")
        changed = replace(getattr(r, link), **{what: value})
        return (replace(r, **{link: changed}, name=f"{r.name}:{parameter}={value:.6g}"),
                two_step_cycle(gait))
    raise ValueError(f"parameter must be one of {sorted(CYCLE_PARAMETERS)}, got {parameter!r}")


@dataclass
class CycleBranch:
    """A continued family of a sequence gait's fixed points: one row per branch point.

    ``multipliers`` (n, 3) complex, by decreasing modulus, from the variational equations
    the tangent was taken from (NaN when not asked for); ``neutral`` counts the multipliers within :data:`NEUTRAL_TOL` of 1. Bifurcation
    lists hold branch indices ``i``: the event happened between points ``i - 1`` and ``i``.
    A fold is where the parameter turns back along the branch. With ``theta2`` pinned, a fold
    of the branch need not put a second multiplier at 1 (the energy family may just stop
    reaching the section's ``theta2``); a real multiplier through +1 away from a fold is a
    change of stability on a branch that goes on (transcritical, pitchfork or a degenerate
    fold of the energy family: the multipliers alone do not say which).
    ``stop_reason``: ``steps`` (all taken), ``bounds`` (the parameter left them or its least
    admissible value, e.g. friction 0), ``no_branch`` (the start is on a family of fixed
    points that the parameter breaks: ``dP/dmu`` has a part off the range of ``DP - I``, so
    no fixed point exists at any other value near the start; ``stop_detail`` says by how
    much, and how the section's energy changes per cycle), ``border`` (the map jumps just
    ahead: the cycle's event sequence changes there, e.g. a guard met at a turning point, so
    the smooth family ends) or ``ds_min`` (the corrector failed at the least step for
    another reason, or converged where the map is not differentiable).
    """

    parameter: str
    theta2_pinned: bool        # a family (neutral multiplier): theta2 held at the start's
    value: np.ndarray          # the parameter
    theta2: np.ndarray         # [rad] on the section
    dtheta1: np.ndarray        # [rad s-1]
    dtheta2: np.ndarray        # [rad s-1]
    residual: np.ndarray       # |P(z) - z| after correction
    iterations: np.ndarray     # corrector iterations per point (0 at the start)
    arclength: np.ndarray      # cumulative arclength in (theta2, dtheta1, dtheta2, mu)
    multipliers: np.ndarray
    neutral: np.ndarray
    stable: np.ndarray         # all non-neutral |lambda| < 1
    folds: list = field(default_factory=list)             # d mu / ds changes sign
    period_doublings: list = field(default_factory=list)  # a real multiplier crosses -1
    through_plus_one: list = field(default_factory=list)  # a non-neutral real one crosses +1
    neimark_sacker: list = field(default_factory=list)    # a complex pair crosses |lambda| 1
    stop_reason: str = "steps"
    stop_detail: str = ""      # why a no_branch start has no branch (empty otherwise)


def _nonneutral(lam: np.ndarray) -> np.ndarray:
    """The multipliers left when the one nearest 1 within :data:`NEUTRAL_TOL` is dropped."""
    d = np.abs(lam - 1.0)
    k = int(np.argmin(d))
    return np.delete(lam, k) if d[k] < NEUTRAL_TOL else lam


def _unstable_counts(lam: np.ndarray) -> tuple[int, int, int]:
    """Non-neutral multipliers outside the unit circle: (real > 1, real < -1, complex)."""
    m = _nonneutral(lam)
    real = np.abs(m.imag) <= 1e-9
    return (int(np.sum(real & (m.real > 1.0))), int(np.sum(real & (m.real < -1.0))),
            int(np.sum(~real & (np.abs(m) > 1.0))))


def crossings(m0: np.ndarray, m1: np.ndarray) -> tuple[bool, bool, bool]:
    """(period doubling, through +1, Neimark-Sacker) between two multiplier sets: the number of
    real multipliers beyond -1, real ones beyond +1, or complex ones outside the unit circle
    changed (a complex pair that meets the real axis and leaves through +1 counts as +1)."""
    if not (np.all(np.isfinite(m0)) and np.all(np.isfinite(m1))):
        return False, False, False
    a, b = _unstable_counts(m0), _unstable_counts(m1)
    return a[1] != b[1], a[0] != b[0], a[2] != b[2]


def fold_indices(values) -> list[int]:
    """Branch indices where the parameter turns back (``d mu`` changes sign after them)."""
    dmu = np.diff(np.asarray(values, float))
    return [int(i + 1) for i in np.flatnonzero(np.sign(dmu[1:]) * np.sign(dmu[:-1]) < 0)]


#: index of the parameter in the unknowns ``u = (theta2, dtheta1, dtheta2, mu)``
MU = 3


@dataclass
class CycleEquations:
    """The equations of a sequence gait's fixed points in one parameter ``mu``.

    Unknowns ``u = (theta2, dtheta1, dtheta2, mu)``; equations ``R(u) = P(z; mu) - z`` and,
    for a family of fixed points (``pinned``: a neutral multiplier at the start), the phase
    condition ``theta2 = theta2_0``. The state columns of their Jacobian come from the
    variational equations, the ``mu`` column from central differences (one-sided at a floor
    such as zero friction).
    """

    gait: SequenceGait
    robot: Robot
    parameter: str
    integrator: Integrator
    theta2_0: float
    fd_step: float
    floor: float
    pinned: bool = False

    def setup(self, mu: float):
        return with_parameter(self.robot, self.gait, self.parameter, mu)

    def residual(self, u) -> tuple[np.ndarray, Status]:
        """``P(z) - z`` at ``u`` and the cycle's status."""
        rb, g = self.setup(u[MU])
        zn, st = cycle_return_map(u[:3], g, robot=rb, integrator=self.integrator)
        return zn - u[:3], st

    def state_jacobian(self, u) -> np.ndarray:
        """``d P / d z`` at ``u`` by variational equations."""
        rb, g = self.setup(u[MU])
        return sequence_variational_jacobian(g, u[:3], robot=rb, integrator=self.integrator)

    def equations(self, u) -> tuple[np.ndarray, Status]:
        """The equations: ``P(z) - z`` and, for a family, the phase condition on theta2."""
        r, st = self.residual(u)
        return (np.append(r, u[0] - self.theta2_0) if self.pinned else r), st

    def jacobian(self, u) -> tuple[np.ndarray, np.ndarray]:
        """``(d F / d u, d P / d z)``: variational columns for the state, differences in
        mu."""
        J = self.state_jacobian(u)
        D = np.empty((4 if self.pinned else 3, 4))
        D[:3, :3] = J - np.eye(3)
        if self.pinned:
            D[3] = (1.0, 0.0, 0.0, 0.0)
        h = self.fd_step * max(1.0, abs(u[MU]))
        e = np.zeros(4)
        e[MU] = h
        if u[MU] - h < self.floor:
            # friction cannot go negative: one-sided, second order
            (r0, s0), (r1, s1), (r2, s2) = (self.residual(u), self.residual(u + e),
                                            self.residual(u + 2 * e))
            if Status.OK != s0 or Status.OK != s1 or Status.OK != s2:
                raise RuntimeError("the parameter stencil left the gait")
            D[:3, MU] = (-3.0 * r0 + 4.0 * r1 - r2) / (2 * h)
            return D, J
        rp, sp = self.residual(u + e)
        rm, sm = self.residual(u - e)
        if sp != Status.OK or sm != Status.OK:
            raise RuntimeError("the parameter stencil left the gait")
        D[:3, MU] = (rp - rm) / (2 * h)
        return D, J

    def correct(self, up, tau, *, tol: float, max_iter: int):
        """Gauss-Newton on ``[F(v); tau . (v - up)] = 0`` from the predictor ``up``:
        ``((v, iterations) or None, |F| at the predictor)``."""
        v = up.copy()
        prev = first = math.inf
        for it in range(1, max_iter + 1):
            if v[MU] < self.floor:
                return None, first      # left the admissible parameters (e.g. friction < 0)
            try:
                r, st = self.equations(v)
            except ValueError:
                return None, first      # no such robot (e.g. a CG off its link)
            if st != Status.OK or not np.all(np.isfinite(r)):
                return None, first
            norm = float(np.linalg.norm(r))
            if it == 1:
                first = norm
            if it > 2 and norm > prev:
                return None, first      # diverging: a smaller step will do better
            prev = norm
            if norm <= tol * state_scale(v) and abs(tau @ (v - up)) <= tol:
                return (v, it - 1), first
            try:
                D, _ = self.jacobian(v)
            except (RuntimeError, ValueError):
                return None, first
            A = np.vstack([D, tau])
            b = np.concatenate([r, [tau @ (v - up)]])
            step, *_ = np.linalg.lstsq(A, -b, rcond=None)
            v = v + step
            if not np.all(np.isfinite(v)):
                return None, first
        r, st = self.equations(v)
        if st == Status.OK and np.linalg.norm(r) <= tol * state_scale(v):
            return (v, max_iter), first
        return None, first


def state_scale(u) -> float:
    """``max(1, |z|)``: the scale of the fixed point's size the tolerances are relative to."""
    return max(1.0, float(np.abs(u[:3]).max()))


def branch_tangent(D: np.ndarray, prev: np.ndarray | None, sign: float) -> np.ndarray:
    """The unit null vector of ``D``, oriented along ``prev`` (the first: ``sign`` of its
    parameter component)."""
    _, _, vt = np.linalg.svd(D)
    t = vt[-1] / np.linalg.norm(vt[-1])
    if prev is None:
        return t if t[MU] * sign >= 0 else -t
    return t if t @ prev >= 0 else -t


def branch_events(mu: np.ndarray, lam: np.ndarray):
    """Stability and bifurcations along a branch: ``(neutral, stable, folds, period
    doublings, real multipliers through +1, Neimark-Sacker)`` from the parameter values and
    the multipliers at each point (a fold may send a multiplier through +1: it is named as
    the fold)."""
    n = len(mu)
    neutral = np.array([int(np.sum(np.abs(m - 1.0) < NEUTRAL_TOL)) for m in lam])
    stable = np.array([int(np.all(np.isfinite(m)) and bool(np.all(np.abs(_nonneutral(m)) < 1.0)))
                       for m in lam])
    folds = fold_indices(mu)
    pd, p1, ns = [], [], []
    for i in range(1, n):
        a, b, c = crossings(lam[i - 1], lam[i])
        if a:
            pd.append(i)
        if b and i not in folds and (i - 1) not in folds and (i + 1) not in folds:
            p1.append(i)
        if c:
            ns.append(i)
    return neutral, stable, folds, pd, p1, ns


def family_break(D: np.ndarray, J: np.ndarray) -> float:
    """How far a change of the parameter moves the return map off its family of fixed
    points: the part of ``dP/dmu`` (``D[:3, MU]``) on the left null space of ``DP - I``
    (``J - I``, its singular values below :data:`NEUTRAL_TOL` of the largest), relative to
    ``|dP/dmu|`` [1]. Zero (to the Jacobians' accuracy) when the family persists at nearby
    values, e.g. a motor torque that still restores the latched energy; of order 1 when the
    parameter removes it, e.g. friction, whose work after the motor stops is never
    restored."""
    p_mu = D[:3, MU]
    size = float(np.linalg.norm(p_mu))
    if size == 0.0:
        return 0.0
    left, sv, _ = np.linalg.svd(J - np.eye(3))
    null = left[:, sv <= NEUTRAL_TOL * max(1.0, float(sv[0]))]
    return float(np.linalg.norm(null.T @ p_mu)) / size


def section_energy(robot: Robot, gait: SequenceGait, z) -> float:
    """Total energy [J] of the section state ``z = (theta2, dtheta1, dtheta2)``, hanging from
    the attached end at height 0 (a cycle's end state is in the frame of the end attached
    there: mirror-image links, or end A, so the first parameter row serves both)."""
    state = cycle_section_state(gait, z)
    kinetic, potential = energies(robot.params(), state[None], np.zeros(1))
    return float(kinetic[0] + potential[0])


def no_branch_detail(eqs: "CycleEquations", u: np.ndarray, off: float, sign: float) -> str:
    """Why a pinned start has no branch in its parameter: the part ``off`` of ``dP/dmu`` off
    the family, and the section's energy change over one cycle from the start per unit of
    the parameter (one-sided, a step ``fd_step max(1, |mu|)`` in the direction ``sign``): a
    fixed point returns to its energy."""
    name, units = eqs.parameter, CYCLE_PARAMETERS[eqs.parameter]
    h = math.copysign(eqs.fd_step * max(1.0, abs(u[MU])), sign)
    rb, g = eqs.setup(u[MU] + h)
    zn, st = cycle_return_map(u[:3], g, robot=rb, integrator=eqs.integrator)
    energy = ""
    if st == Status.OK:
        rate = (section_energy(rb, g, zn) - section_energy(rb, g, u[:3])) / h
        energy = (f"; one cycle from the start changes the section's energy by {rate:.4g} J "
                  f"per {'unit' if units == '1' else units} of {name}")
    return (f"{name} moves the return map off the start's family of fixed points (the part "
            f"of dP/d{name} off the range of DP - I: {off:.3g} of it){energy}: no fixed "
            f"point at any other {name} near {u[MU]:.6g}{'' if units == '1' else ' ' + units}")


def continue_cycle(gait: SequenceGait, z0, parameter: str, *, robot: RobotLike = "seed2009",
                   ds: float = 0.01, steps: int = 20, ds_min: float | None = None,
                   ds_max: float | None = None, bounds=(-math.inf, math.inf),
                   integrator: Integrator = TIGHT, tol: float = 1e-11,
                   max_corrector: int = 8, fd_step: float = 1e-6,
                   multipliers: bool = True) -> CycleBranch:
    """Pseudo-arclength continuation of a sequence gait's fixed point in ``parameter``.

    Parameters
    ----------
    gait : SequenceGait
        The gait at the start value of the parameter (its ``tick`` must be 0 for the
        multipliers; the branch itself needs only the map).
    z0 : array_like, shape (3,)
        A fixed point ``(theta2 [rad], dtheta1, dtheta2 [rad s-1])`` on the gait's section
        (e.g. a floquet step's Newton-polished point). When the start has a neutral
        multiplier (a family), ``theta2`` stays at ``z0[0]`` along the branch.
    parameter : str
        One of :data:`CYCLE_PARAMETERS` (see :func:`with_parameter`).
    robot : Robot or str
        The robot at the start value.
    ds : float
        First arclength step in ``(theta2 [rad], dtheta1, dtheta2 [rad s-1], mu)``; its sign picks
        the direction (``mu`` increasing for ``ds > 0``).
    steps : int
        Branch points to add after the start.
    ds_min, ds_max : float, optional
        Least and largest ``|ds|`` (defaults ``|ds| / 256`` and ``|ds|``). A failed corrector
        (no convergence in ``max_corrector`` iterations, or no cycle) halves the step and
        retries; one converging in at most 3 iterations grows it by 1.5, up to ``ds_max``.
    bounds : (float, float)
        Stop when the parameter leaves ``[lo, hi]``, or a predictor steps below its least
        admissible value (:data:`PARAMETER_FLOOR`: friction 0).
    integrator : Integrator
        Kernel settings for the return map (default: :data:`~monkeystudy.analysis.TIGHT`).
    tol : float
        Corrector tolerance on ``|R| / max(1, |z|)`` [1]; the map is accurate to about the
        integrator's rtol times ``|z|``.
    fd_step : float
        Relative central-difference step for ``dR / d mu`` (the state columns come from the
        variational equations).
    multipliers : bool
        Compute the multipliers along the branch (variational equations at every point).

    Returns
    -------
    CycleBranch
        Only the start, stopped ``no_branch``, when the start's family of fixed points (a
        neutral multiplier) does not survive a change of the parameter
        (:func:`family_break` above :data:`FAMILY_BREAK_TOL`): a gait that latches its
        energy and restores it has no fixed point under friction, since what friction takes
        after the motor stops is never restored.
    """
    if parameter not in CYCLE_PARAMETERS:
        raise ValueError(f"parameter must be one of {sorted(CYCLE_PARAMETERS)}, "
                         f"got {parameter!r}")
    if ds == 0.0 or not math.isfinite(ds):
        raise ValueError(f"ds must be finite and non-zero, got {ds!r}")
    base = as_robot(robot)
    z0 = np.asarray(z0, float)
    ds_min = abs(ds) / 256.0 if ds_min is None else float(ds_min)
    ds_max = abs(ds) if ds_max is None else float(ds_max)
    eqs = CycleEquations(gait, base, parameter, integrator, float(z0[0]), fd_step,
                         PARAMETER_FLOOR.get(parameter, -math.inf))
    u = np.array([float(z0[0]), float(z0[1]), float(z0[2]), parameter_of(base, gait, parameter)])
    r0, st0 = eqs.residual(u)
    if st0 != Status.OK:
        raise RuntimeError(f"no cycle from the start (status {Status(st0).name})")
    if np.linalg.norm(r0) > 1e3 * tol * max(1.0, float(np.abs(u[:3]).max())):
        raise ValueError(f"the start is not a fixed point: |P(z) - z| = "
                         f"{np.linalg.norm(r0):.3g} (polish it first, e.g. a floquet step)")
    # a free energy level makes the fixed points a family: pin theta2 to pick one member
    eqs.pinned = bool(np.any(np.abs(np.linalg.eigvals(eqs.state_jacobian(u)) - 1.0)
                             < NEUTRAL_TOL))
    rows, res, iters = [u.copy()], [float(np.linalg.norm(r0))], [0]
    D, J = eqs.jacobian(u)
    jacs = [J]      # each accepted point's Jacobian: the tangent's and the multipliers'
    tau = branch_tangent(D, None, math.copysign(1.0, ds))
    h = abs(ds)
    reason, detail = "steps", ""
    if ds < 0.0 and u[MU] <= eqs.floor:
        reason = "bounds"         # at the parameter's least admissible value, going down
    elif eqs.pinned:
        off = family_break(D, J)
        if off > FAMILY_BREAK_TOL:
            # the pinned equations are regular here: the start is an isolated solution in
            # (z, mu), and the tangent above is no direction of a branch
            reason = "no_branch"
            detail = no_branch_detail(eqs, u, off, math.copysign(1.0, ds))
    while reason == "steps" and len(rows) <= steps:
        if u[MU] + h * tau[MU] < eqs.floor:
            reason = "bounds"     # the parameter's least admissible value (friction 0)
            break
        got, predicted = eqs.correct(u + h * tau, tau, tol=tol, max_iter=max_corrector)
        if got is None:
            h /= 2.0
            if h < ds_min:
                # a continuous map leaves a residual O(h^2) at the predictor; one that jumps
                # there (or has no cycle) has reached a border where the cycle's event
                # sequence changes, e.g. a guard met at a turning point
                jump = not predicted <= 1e-3 * state_scale(u)
                reason = "border" if jump else "ds_min"
                break
            continue
        v, it = got
        if not bounds[0] <= v[MU] <= bounds[1]:
            reason = "bounds"
            break
        try:
            D, J = eqs.jacobian(v)
        except (RuntimeError, ValueError):
            reason = "ds_min"     # converged onto a point where the map is not differentiable
            break
        r, _ = eqs.residual(v)
        rows.append(v.copy())
        res.append(float(np.linalg.norm(r)))
        iters.append(it)
        jacs.append(J)
        tau = branch_tangent(D, tau, 1.0)
        u = v
        if it <= 3:
            h = min(ds_max, 1.5 * h)
    U = np.array(rows)
    arc = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(U, axis=0), axis=1))])
    lam = np.full((len(U), 3), np.nan + 0j)
    if multipliers:
        for i, Ji in enumerate(jacs):
            ev = np.linalg.eigvals(Ji)
            lam[i] = ev[np.argsort(-np.abs(ev), kind="stable")]
    neutral, stable, folds, pd, p1, ns = branch_events(U[:, MU], lam)
    return CycleBranch(parameter, eqs.pinned, U[:, MU], U[:, 0], U[:, 1], U[:, 2],
                       np.array(res), np.array(iters), arc, lam, neutral, stable, folds, pd, p1,
                       ns, reason, detail)


__all__ = ["CYCLE_PARAMETERS", "CycleBranch", "FAMILY_BREAK_TOL", "LINK_PARAMETERS", "PARAMETER_FLOOR",
           "continue_cycle", "family_break", "fold_indices", "motor_torque", "parameter_of",
           "section_energy", "two_step_cycle", "with_parameter"]
