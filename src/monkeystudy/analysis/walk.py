"""Walking a route under noise: each step's gait chosen from where the robot senses it is.

A planned route (:mod:`monkeystudy.analysis.route`) is a sequence of catches on a lattice; a
real robot's catches land where its dynamics put them. :func:`walk_route` walks the route the
way a robot would: before each step it replans from its *estimate* of the attached magnet
(:func:`~monkeystudy.analysis.route.replan`, the gait it is walking included, so a switch is
one the atlas allows), runs one cycle of the chosen gait from its actual hybrid state with
that step's noise (:func:`monkeystudy.kernel.walk.walk_step`: the tick, jitter, latency, the
run's build, sensor noise on the guards), and updates its estimate from its sensor
(:mod:`monkeystudy.analysis.sensing`).

The catch of every gait here is a ``free_end_y`` guard: the free magnet switches on when it
rises through a world height. In a walk that height is the planned catch's: the first step of
the route replanned from the estimate, whose lattice is anchored at the estimate. The robot
reads its height from its estimate, so with an estimate ``e`` [m] above the truth its catch
fires ``e`` too low: the guard's world height is the planned one less the estimate's error.

A run ends when

* the robot senses it has arrived: its estimate within the goal's disc. It *arrived* when
  the true catch lies there too (``missed_goal`` otherwise: the sensing misled it);
* a step's cycle stops with a status other than ok (its name: ``fell``, ``no_switch``, ...);
* a catch lands where the magnet cannot hold (``off_steel``: its footprint not on one
  region, :meth:`monkeystudy.wall.Wall.can_catch`); the robot falls;
* no route leads from the estimate to the goal (``no_route``);
* ``max_steps`` steps were taken (``max_steps``).

Every draw is keyed by ``(seed, run, step)``: a run's walk does not depend on which worker
walks it or on the other runs.

The atlas gaits start where their own cycles start: on the section (link 1 vertical), with
the section state of the gait's fixed point. A walk starts there, moving, with the first
planned gait's state (plus the run's initial-state noise); the swing-up from rest is not
part of it.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Callable, Sequence

import numpy as np

from ..controllers import Integrator, SequenceGait, kernel_method, settings_vector
from ..kernel import layout as L
from ..kernel.noise import PER_RUN_CYCLE, standard_draw
from ..kernel.survival import LATENCY_SLOT, CYCLE_LOG_ROWS
from ..kernel.walk import walk_step
from ..robot import Robot
from ..simulation import as_robot, energies, status_name
from ..wall import Wall
from .route import AtlasGait, NoRoute, Route, Transition, mirrored_name, replan
from .sections import cycle_section_state
from .survival import Noise, noise_roles, run_robot

#: how a run that arrived is named in ``failure``
ARRIVED = ""
#: the failures a walk names itself (a cycle's failures are its status names)
OFF_STEEL, NO_ROUTE, MAX_STEPS, MISSED_GOAL = "off_steel", "no_route", "max_steps", "missed_goal"


# ------------------------------------------------------------------------------------------
# gaits walked either way
# ------------------------------------------------------------------------------------------
def mirrored_gait(gait: SequenceGait) -> SequenceGait:
    """The mirror image of a sequence gait: the same gait walked the other way along the wall.

    The dynamics are symmetric under the reflection ``x -> -x`` of the wall's plane, which
    takes ``theta1, theta2`` and their rates to their negatives and a torque to its negative;
    heights, times and energies are unchanged. So every torque is negated, a coordinate
    guard watches the negated value in the opposite direction, a bar lies on the other side,
    and the section's start ``theta2`` is negated. From the mirrored fixed point (the section
    state negated) the mirrored gait's every state is the original's reflected: its step
    advances ``-dx`` and rises ``dy``.
    """
    flip = {"rising": "falling", "falling": "rising", "either": "either"}

    def seg(s):
        if s.until == "coord":
            s = replace(s, value=-s.value, direction=flip[s.direction])
        return replace(s, torque=-s.torque, bar_dx=-s.bar_dx)

    return replace(gait, segments=[seg(s) for s in gait.segments],
                   section_theta1=-gait.section_theta1,
                   section_direction=flip[gait.section_direction],
                   section_torque=-gait.section_torque, theta2=-gait.theta2)


@dataclass(frozen=True)
class WalkGait:
    """An atlas gait as a walk runs it.

    Parameters
    ----------
    name : str
        Its name in the atlas (:class:`~monkeystudy.analysis.route.AtlasGait`).
    gait : SequenceGait
        Its cycle, torques in the kernel's frame; every catch a ``free_end_y`` guard.
    z : tuple of float
        Its fixed point on the section ``(theta2 [rad], dtheta1, dtheta2 [rad s-1])``.
    """

    name: str
    gait: SequenceGait
    z: tuple

    def __post_init__(self) -> None:
        z = tuple(float(v) for v in self.z)
        if len(z) != 3 or not all(map(math.isfinite, z)):
            raise ValueError(f"gait {self.name!r}: z must be 3 finite numbers "
                             f"(theta2, dtheta1, dtheta2), got {self.z!r}")
        object.__setattr__(self, "z", z)
        if self.gait.clocked:
            raise ValueError(f"gait {self.name!r}: a walk's gait restarts its clock at the "
                             f"section (no running clock)")
        if not any(s.until == "free_end_y" for s in self.gait.segments):
            raise ValueError(f"gait {self.name!r}: a walk's gait catches at a planned world "
                             f"height (a free_end_y guard); it has none")
        if not any(s.magnets == "swap" for s in self.gait.segments):
            raise ValueError(f"gait {self.name!r}: a walk's step swaps the magnets; it has "
                             f"no swap")

    def mirrored(self) -> "WalkGait":
        """The same gait walked the other way (:func:`mirrored_gait`)."""
        return WalkGait(mirrored_name(self.name), mirrored_gait(self.gait),
                        tuple(-v for v in self.z))

    def program(self, tick: float) -> tuple[np.ndarray, np.ndarray]:
        """``(program, observers)`` of one cycle on the controller ``tick`` [s], ending on the
        exact section crossing; the catch rows' world heights are set per step
        (:func:`with_catch_height`), so the program's own rise is cleared."""
        seq = replace(self.gait, tick=float(tick), rise=0.0)
        prog, obs = seq.loop_controller(seq.section_observers()).program()
        return prog, obs


def catch_rows(prog: np.ndarray) -> np.ndarray:
    """The rows of a program whose guard is a world height (``free_end_y``): the catch."""
    return np.flatnonzero(prog[:, L.S_GUARD] == L.G_FREE_END_Y)


def with_catch_height(prog: np.ndarray, height: float) -> np.ndarray:
    """A copy of ``prog`` whose world-height guards fire at ``height`` [m]."""
    out = prog.copy()
    out[catch_rows(prog), L.S_GVALUE] = float(height)
    return out


# ------------------------------------------------------------------------------------------
# one walk
# ------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Walk:
    """One walk of a route.

    Attributes
    ----------
    arrived : bool
        The true catch the robot stopped at lies in the goal's disc.
    failure : str
        Why it stopped: :data:`ARRIVED` (``""``) when it arrived, else the failure's name.
    gaits : tuple of str
        The gait of each step taken (a failed step included).
    catches, sensed : ndarray (n, 2)
        The attached magnet after each completed step: the truth and the robot's estimate [m].
    time : float
        From the start to the last completed catch's cycle end [s].
    energy : float
        The motor's net work over the completed steps [J]: the mechanical energy gained plus
        what the catches' impacts took (a frictionless robot's motor work).
    failed_at : tuple of float
        Where a failed run failed [m]: the catch off steel, or the attached magnet when the
        step failed or no route was left (NaN when it arrived).
    """

    arrived: bool
    failure: str
    gaits: tuple
    catches: np.ndarray
    sensed: np.ndarray
    time: float
    energy: float
    failed_at: tuple


def _energy_change(log: np.ndarray) -> tuple[float, float]:
    """``(energy at the cycle's end [J], energy the impacts took [J])`` of a cycle's log."""
    lost = float(np.sum(np.maximum(log[:, L.L_E_BEFORE] - log[:, L.L_E_AFTER], 0.0)))
    return float(log[-1, L.L_E_AFTER]), lost


def walk_route(wall: Wall, gaits: Sequence[WalkGait], atlas: Sequence[AtlasGait],
               transitions: Sequence[Transition] = (), *, robot: Robot | str = "seed2009",
               integrator: Integrator = Integrator(), tick: float = 0.0,
               noise: Noise = Noise(), seed: int = 0, run: int = 0, sensor=None,
               max_steps: int = 100, height_step: float = 0.1,
               plan: dict | None = None) -> Walk:
    """Walk from ``wall``'s start to its goal, replanning before every step.

    Parameters
    ----------
    gaits : sequence of WalkGait
        Every gait the planner may choose, each under its atlas name (mirror images included:
        the planner is called with ``mirror=False``).
    atlas, transitions
        The planner's view of them (:func:`~monkeystudy.analysis.route.plan_route`).
    tick : float
        The controller tick [s].
    noise : Noise
        The noise of every step; its draws keyed by ``(seed, run, step)``.
    sensor
        How the robot estimates the attached magnet (:mod:`monkeystudy.analysis.sensing`;
        None: it knows it exactly).
    max_steps : int
        Steps after which a run stops (:data:`MAX_STEPS`).
    height_step : float
        The planned catch heights are the start's plus whole multiples of this [m] (every
        gait's rise is one): a staircase fixed in the world. Each step is planned from the
        row of it nearest the estimate, so a catch that lands low is followed by one aimed at
        the planned height, not at the low one plus the gait's rise (which would let the
        height's errors add up). Errors beyond half of it put the robot on the wrong row.
    plan : dict
        :func:`~monkeystudy.analysis.route.plan_route`'s options (cost, risk_weight,
        resolution, ...); the walk plans without adding mirror images (``gaits`` and
        ``atlas`` list every gait it may walk).
    """
    robot = as_robot(robot)
    height_step = float(height_step)
    if not (math.isfinite(height_step) and height_step > 0.0):
        raise ValueError(f"height_step must be > 0 [m], got {height_step!r}")
    by_name = {g.name: g for g in gaits}
    missing = [a.name for a in atlas if a.name not in by_name]
    if missing:
        raise ValueError(f"no gait to walk for atlas gait(s) {missing}")
    plan = dict(plan or {})
    plan["mirror"] = False
    vector = noise.vector()
    uniform = vector[L.NZ_UNIFORM] > 0.0
    par = run_robot(robot, noise, seed, run).params()
    lengths = (robot.link1.length, robot.link2.length)
    latency = 0.0
    if vector[L.NZ_LATENCY] > 0.0:    # as a survival run draws it
        latency = vector[L.NZ_LATENCY] * 0.5 * (
            standard_draw(seed, run, PER_RUN_CYCLE, LATENCY_SLOT, True) + 1.0)
    programs = {g.name: g.program(tick) for g in gaits}
    settings = settings_vector(integrator, tick=tick)

    true_pos = np.array(wall.start.position, float)
    estimate = true_pos.copy() if sensor is None else \
        np.asarray(sensor.initial(true_pos, sensor.draws(seed, run, -1)), float)
    attached = wall.start.attached
    catches, sensed, names = [], [], []
    hyb = None
    current = None
    energy = 0.0
    e_now = math.nan

    def ended(arrived, failure, where=(math.nan, math.nan)):
        return Walk(bool(arrived), failure, tuple(names),
                    np.array(catches, float).reshape(-1, 2),
                    np.array(sensed, float).reshape(-1, 2), t_last, energy, tuple(where))

    t_last = 0.0
    for step in range(int(max_steps)):
        # the planned heights are the world's staircase: the estimate's row of it
        row = wall.start.position[1] + height_step * round(
            (estimate[1] - wall.start.position[1]) / height_step)
        try:
            route: Route = replan(wall, atlas, transitions, position=(estimate[0], row),
                                  attached=attached, gait=current, **plan)
        except (NoRoute, ValueError):     # no route, or the row's point is off steel
            return ended(False, NO_ROUTE, tuple(true_pos))
        first = route.steps[0]
        walker = by_name[first.gait]
        prog, obs = programs[walker.name]
        if hyb is None:     # the walk starts on this gait's section, at its fixed point
            hyb = cycle_section_state(walker.gait, walker.z, height=float(true_pos[1]))
            hyb[L.X] = true_pos[0]
            hyb[L.H_FLIPPED] = 0.0 if attached == "A" else 1.0
            for i, source in ((L.TH2, L.NZ_THETA2), (L.DTH1, L.NZ_DTHETA1),
                              (L.DTH2, L.NZ_DTHETA2)):
                if vector[source] > 0.0:
                    hyb[i] += vector[source] * standard_draw(seed, run, PER_RUN_CYCLE,
                                                             i - L.TH2, uniform)
            e_now = _kernel_energy(robot, par, hyb)
        hyb[L.H_SEG] = 0.0
        # the planned catch is in the robot's belief; its height guard reads the belief
        height = float(first.catch[1]) - float(estimate[1] - true_pos[1])
        cycle = with_catch_height(prog, height)
        counts = np.zeros(L.N_COUNTS, dtype=np.int64)
        log = np.empty((CYCLE_LOG_ROWS, L.N_LOG_COLS))
        method = kernel_method(settings, cycle, hyb[L.H_PHASE])
        status = walk_step(method, par, cycle, obs, settings, hyb, noise_roles(cycle),
                           vector, int(seed), int(run), int(step), float(latency), counts,
                           log)
        names.append(walker.name)
        n_log = int(counts[L.K_LOG])
        if status != L.ST_OK:
            return ended(False, status_name(int(status)),
                         (float(hyb[L.X]), float(hyb[L.Y])))
        rows = log[:n_log]
        e_end, lost = _energy_change(rows)
        energy += e_end - e_now + lost
        e_now = e_end
        catch_state = _catch_state(rows, cycle)
        before = true_pos
        true_pos = np.array([hyb[L.X], hyb[L.Y]], float)
        attached = "B" if hyb[L.H_FLIPPED] > 0.5 else "A"
        if not wall.can_catch(true_pos)[0]:
            return ended(False, OFF_STEEL, tuple(true_pos))
        estimate = true_pos.copy() if sensor is None else np.asarray(
            sensor.update(estimate, before, true_pos, catch_state, lengths,
                          sensor.draws(seed, run, step)), float)
        catches.append(true_pos.copy())
        sensed.append(estimate.copy())
        current = walker.name
        t_last = float(hyb[L.H_T])
        if wall.goal.distance(estimate)[0] == 0.0:
            arrived = wall.goal.distance(true_pos)[0] == 0.0
            return ended(arrived, ARRIVED if arrived else MISSED_GOAL,
                         (math.nan, math.nan) if arrived else tuple(true_pos))
    return ended(False, MAX_STEPS, tuple(true_pos))


def _catch_state(rows: np.ndarray, prog: np.ndarray) -> tuple[float, float]:
    """``(theta1, theta2)`` [rad] at the catch, in the frame of the magnet the robot hung from:
    the state logged where the catch row exits."""
    catch = set(catch_rows(prog).tolist())
    for r in rows:
        if r[L.L_KIND] == L.LOG_SEGMENT and int(r[L.L_ID]) in catch:
            s = r[L.L_STATE:L.L_STATE + 8]
            return float(s[L.TH1]), float(s[L.TH2])
    return math.nan, math.nan


def _kernel_energy(robot: Robot, par: np.ndarray, hyb: np.ndarray) -> float:
    kinetic, potential = energies(par, hyb[None, :8], np.array([int(hyb[L.H_FLIPPED] > 0.5)]))
    return float(kinetic[0] + potential[0])


__all__ = ["ARRIVED", "MAX_STEPS", "MISSED_GOAL", "NO_ROUTE", "OFF_STEEL", "Walk", "WalkGait",
           "catch_rows", "mirrored_gait", "walk_route", "with_catch_height"]
