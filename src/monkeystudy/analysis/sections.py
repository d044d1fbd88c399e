"""Poincare sections and return maps of gaits (the horizontal gait is one sequence gait).

Return maps live on the section "link 1 passes the vertical" (``theta1 = 0``; a sequence gait
names its own ``theta1``). The section state is ``z = (theta2, dtheta1, dtheta2)``: ``theta1``
is fixed by the section, the attached end's position is neutral (the gait is translation
invariant, so height and x drop out), and after a cycle the frame has flipped to the other end,
which plays the same role when the links are mirror images.

Everything here asks the one simulation path (:func:`monkeystudy.simulation.run_controller`)
for what it needs; nothing integrates on its own.
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from ..controllers import Integrator, SequenceGait, horizontal_gait, open_loop_gait
from ..kernel import layout as L
from ..kernel.gait import wrapped_difference
from ..robot import SEED2009_TORQUE
from ..simulation import RobotLike, Status, as_robot, initial_state, run_controller

#: Tight integrator for analysis: the return map must be far more accurate than the finite
#: difference steps used on it.
TIGHT = Integrator(method="dop853", rtol=1e-13, atol=1e-13)


def section_state(z) -> np.ndarray:
    """Hybrid state on the section: hanging from the frame's (x, y) end at the origin with
    ``theta1 = 0`` and ``z = (theta2, dtheta1, dtheta2)``."""
    th2, w1, w2 = (float(v) for v in z)
    return initial_state(w1, w2, theta2=th2)


def open_loop_return_map(z, *, t_switch: float, t_motor: float,
                         torque: float = SEED2009_TORQUE, robot: RobotLike = "seed2009",
                         integrator: Integrator = TIGHT, tick: float = 0.0,
                         tick_phase: float = 0.0) -> tuple[np.ndarray, Status]:
    """One cycle of the horizontal gait's open-loop replay, the clock restarted at the
    vertical: :func:`cycle_return_map` of :func:`~monkeystudy.controllers.open_loop_gait` of
    :func:`~monkeystudy.controllers.horizontal_gait` (motor ``torque`` [N m]).

    From ``z`` on the section: swap at ``t_switch``, motor for ``t_motor`` [s], then on to
    the next vertical crossing. Returns the next section state and the run status.
    """
    gait = open_loop_gait(horizontal_gait(torque, tick, tick_phase=tick_phase),
                          [t_switch, t_switch + t_motor])
    return cycle_return_map(z, gait, robot=robot, integrator=integrator)


def search_return_map(z, *, torque: float = SEED2009_TORQUE, robot: RobotLike = "seed2009",
                      integrator: Integrator = TIGHT) -> tuple[np.ndarray, Status]:
    """One cycle of the state-based search controller (swap at B height, motor until the
    cycle-start energy is restored, stop at the vertical) from section state ``z``:
    :func:`cycle_return_map` of :func:`~monkeystudy.controllers.horizontal_gait`."""
    return cycle_return_map(z, horizontal_gait(torque), robot=robot, integrator=integrator)


def cycle_section_state(gait: SequenceGait, z, *, height: float = 0.0) -> np.ndarray:
    """Hybrid state on a sequence gait's section: hanging from A at ``(0, height)`` [m],
    ``theta1 = gait.section_theta1``, ``z = (theta2 [rad], dtheta1, dtheta2 [rad s-1])``; with
    a running clock (``gait.clocked``) ``z = (theta1, theta2 [rad], dtheta1, dtheta2
    [rad s-1])`` at clock phase zero."""
    if gait.clocked:
        th1, th2, w1, w2 = (float(v) for v in z)
        return initial_state(w1, w2, theta1=th1, theta2=th2, y=float(height))
    th2, w1, w2 = (float(v) for v in z)
    return initial_state(w1, w2, theta1=gait.section_theta1, theta2=th2, y=float(height))


def check_cycle_frame(gait: SequenceGait, robot) -> None:
    """A cycle ending on end B compares like with like only for mirror-image links."""
    if gait.end_attached() == "B":
        check_mirror_links(as_robot(robot))


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


def cycle_map_error(z, gait: SequenceGait, *, robot: RobotLike = "seed2009",
                    integrator: Integrator = TIGHT, factor: float = 10.0) -> float:
    """The error level of :func:`cycle_return_map` at ``z`` on ``integrator``: ``|P(z) -
    P'(z)|`` (2-norm, units of ``z``), ``P'`` the same map with ``rtol`` and ``atol`` divided
    by ``factor`` (``rtol`` not below 100 eps, the integrator's limit). The error of a
    tolerance-controlled integration falls with its tolerance, so the difference estimates
    the error of ``P`` itself. NaN when either cycle fails; 0 when ``rtol`` cannot be
    tightened.
    """
    fine = replace(integrator, rtol=max(integrator.rtol / factor, 100 * np.finfo(float).eps),
                   atol=integrator.atol / factor)
    if fine.rtol >= integrator.rtol:
        return 0.0
    p, st = cycle_return_map(z, gait, robot=robot, integrator=integrator)
    pf, stf = cycle_return_map(z, gait, robot=robot, integrator=fine)
    if st != Status.OK or stf != Status.OK:
        return float("nan")
    return float(np.linalg.norm(p - pf))


def has_bar_catches(gait: SequenceGait) -> bool:
    """Whether any segment of ``gait`` ends on a bar (``until: bar``)."""
    return any(seg.until == "bar" for seg in gait.segments)


def rows_on_start_end(gait: SequenceGait) -> list[int]:
    """Rows of ``gait.segments`` that run hanging from the end the cycle starts from: those
    up to the first whose exit enters a segment that acts on the magnets (none if the first
    segment acts on them on entry)."""
    rows = gait.all_segments()
    if rows[0].magnets != "keep":
        return []
    out = []
    for k in range(len(gait.segments)):
        out.append(k)
        if rows[k + 1].magnets != "keep":
            break
    return out


def full_map_gait(gait: SequenceGait, y: float) -> SequenceGait:
    """The gait run by the full map from the attached end's height ``y`` [m]: the ladder is
    fixed in the world, the bar the cycle starts from at the origin, so a bar caught while
    the robot still hangs from the start's end is ``y`` lower relative to it than the bar's
    ``dy`` (each bar is given relative to the bar the robot hangs from). The gait itself
    when it catches no bar, or when ``y`` is 0."""
    if y == 0.0 or not has_bar_catches(gait):
        return gait
    on_start = set(rows_on_start_end(gait))
    segs = tuple(replace(seg, value=seg.value - y) if k in on_start and seg.until == "bar"
                 else seg for k, seg in enumerate(gait.segments))
    return replace(gait, segments=segs)


def cycle_full_map(w, gait: SequenceGait, *, robot: RobotLike = "seed2009",
                   integrator: Integrator = TIGHT) -> tuple[np.ndarray, Status]:
    """One cycle of a sequence gait in the full section state ``w = (y [m], theta2 [rad],
    dtheta1, dtheta2 [rad s-1])``, ``y`` the attached end's height (the cycle starts hanging
    from A at ``(0, y)``).

    The reduced map (:func:`cycle_return_map`) leaves the height out: for a gait whose
    guards sense only the joint angles, rates, relative heights and time, every guard, the
    dynamics and the impacts are invariant under ``y -> y + c``, so the full map's
    y-column is exactly ``e_y`` (a multiplier 1: the height is neutral). A guard on a world
    height (``free_end_y``) breaks that symmetry and can hold the height.

    A gait that catches bars (``until: bar``) runs on a ladder fixed in the world
    (:func:`full_map_gait`): ``y`` is the start's height off the bar it hangs from, and each
    catch puts the new attached end on its bar whatever the state, so a cycle that ends on
    a bar it caught ends at that bar's height: the y-row of the Jacobian is zero (the
    height's multiplier 0), not a translation.

    A gait with a ``rise`` [m per cycle] measures the height from the route's staircase
    (:class:`~monkeystudy.controllers.SequenceGait`): ``y`` is the start's height above its
    planned height (0), and the cycle ends ``y`` of the end attached there less ``rise``,
    the next cycle's planned height. Its ``free_end_y`` catch is at its planned world
    height whatever the start, so its height row has the catch's correction in it, as a
    level gait's catch at the start's height has.

    Returns the full state at the cycle's end (``y`` of the end attached there, less the
    gait's ``rise``; ``theta2`` continued from ``w[1]`` across whole turns) and the run
    status. Needs a clock that
    restarts at the section (``ValueError`` for a running clock) and, for a cycle ending on
    B, mirror-image links.
    """
    robot = as_robot(robot)
    if gait.clocked:
        raise ValueError("the full map (height included) is defined on a section, not at a "
                         "running clock's phase")
    check_cycle_frame(gait, robot)
    w = np.asarray(w, float)
    res = run_controller(full_map_gait(gait, float(w[0])).controller(),
                         cycle_section_state(gait, w[1:], height=w[0]),
                         robot=robot, integrator=integrator, cycles=1, log_capacity=0)
    th2 = float(w[1]) + wrapped_difference(res.state[L.TH2], float(w[1]))
    # the next cycle's planned height is one rise up the route's staircase
    y = res.state[L.Y] - gait.rise if gait.rise != 0.0 else res.state[L.Y]
    return np.array([y, th2, res.state[L.DTH1], res.state[L.DTH2]]), res.status


def check_mirror_links(robot):
    if not robot.is_mirror_image:
        raise ValueError("one-cycle return maps need mirror-image links (the frame flips at "
                         "every swap); compose two cycles for this robot")



@dataclass(frozen=True)
class CycleCatches:
    """The bar catches of one cycle, in the order they happen (arrays of one value per
    catch).

    Attributes
    ----------
    segment : numpy.ndarray of int
        Row of ``gait.segments`` (from 0) whose ``until: bar`` guard made the catch.
    offset : numpy.ndarray
        Horizontal position of the free end relative to its bar at the catch [m] (positive:
        beyond the bar in +x), the kernel's crossing on its dense output.
    window : numpy.ndarray
        The bar's window [m].
    margin : numpy.ndarray
        ``window - |offset|`` [m]: positive, the hook caught the bar; the smaller it is, the
        closer the gait is to missing it.
    speed : numpy.ndarray
        Speed of the free end just before the catch [m s-1] (the attached end at rest).
    velocity : numpy.ndarray, shape (n, 2)
        The free end's velocity just before the catch, ``(x, y)`` [m s-1].
    status : Status
        How the cycle's run ended.
    """

    segment: np.ndarray
    offset: np.ndarray
    window: np.ndarray
    margin: np.ndarray
    speed: np.ndarray
    velocity: np.ndarray
    status: Status


def cycle_catches(z, gait: SequenceGait, *, robot: RobotLike = "seed2009",
                  integrator: Integrator = TIGHT) -> CycleCatches:
    """The bar catches of one cycle of ``gait`` from section state ``z`` (as
    :func:`cycle_return_map`): for each catch its offset from the bar, its offset margin
    and the hook's speed just before it.

    A catch is the exit of an ``until: bar`` segment into one that swaps the attached end
    (docs/model.md section 6, "A catch on a bar"); the state just before it is the run's
    sample at the exit (written before the next segment's impact), its free end measured
    from the attached end in that frame. A cycle that does not complete has the catches it
    made before it stopped.
    """
    robot = as_robot(robot)
    check_cycle_frame(gait, robot)
    prog, _ = gait.program()
    # one sample per exit: a sampling step longer than the run adds none between events
    res = run_controller(gait.controller(), cycle_section_state(gait, z), robot=robot,
                         integrator=integrator, cycles=1, sample_dt=1e6, log_capacity=64)
    log = res.log[res.log[:, L.L_KIND] == L.LOG_SEGMENT]
    seg_t, seg_id = res.sample_t, res.sample_segment
    segment, offset, window, velocity = [], [], [], []
    flipped = 0
    for row in log:
        k = int(row[L.L_ID])
        after = int(row[L.L_FLIPPED])
        if (int(prog[k, L.S_GUARD]) == L.G_BAR and after != flipped
                and k < len(gait.segments)):
            i = np.flatnonzero((seg_t == row[L.L_T]) & (seg_id == k))[0]
            s = res.sample_state[i]
            p = res.params[flipped]
            l1, l2, w1, w12 = p[L.P_L1], p[L.P_L2], s[L.DTH1], s[L.DTH1] + s[L.DTH2]
            th1, th12 = s[L.TH1], s[L.TH1] + s[L.TH2]
            ox = l1 * np.sin(th1) + l2 * np.sin(th12)
            segment.append(k)
            offset.append(ox - prog[k, L.S_BAR_DX])
            window.append(prog[k, L.S_BAR_WINDOW])
            velocity.append((l1 * np.cos(th1) * w1 + l2 * np.cos(th12) * w12,
                             l1 * np.sin(th1) * w1 + l2 * np.sin(th12) * w12))
        flipped = after
    offset_a, window_a = np.array(offset, float), np.array(window, float)
    vel = np.array(velocity, float).reshape(-1, 2)
    return CycleCatches(np.array(segment, int), offset_a, window_a,
                        window_a - np.abs(offset_a), np.hypot(vel[:, 0], vel[:, 1]), vel,
                        res.status)


def bar_catch_rows(gait: SequenceGait) -> list[int]:
    """Rows of ``gait.segments`` (from 0) that catch a bar: an ``until: bar`` segment whose
    exit enters one that acts on the magnets (the swap of docs/model.md section 6)."""
    rows = gait.all_segments()
    return [k for k in range(len(gait.segments))
            if rows[k].until == "bar" and rows[k + 1].magnets != "keep"]
