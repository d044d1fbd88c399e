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

* the robot senses it has arrived: its believed position (the estimate along the wall, on
  the staircase's row nearest the estimate's height: what it plans from) within the goal's
  disc. It *arrived* when the true catch lies there too (``missed_goal`` otherwise: the
  sensing misled it);
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
from typing import Sequence

import numpy as np

from ..controllers import (
    Integrator, Segment, SequenceGait, kernel_method, settings_vector, torques_from_motor_frame,
)
from ..kernel import layout as L
from ..kernel.noise import PER_RUN_CYCLE, standard_draw
from ..kernel.survival import LATENCY_SLOT, CYCLE_LOG_ROWS
from ..kernel.walk import walk_step
from ..robot import Robot
from ..simulation import as_robot, energies, physical_points, status_name
from ..wall import Wall
from .route import AtlasGait, NoRoute, Route, Transition, mirrored_name, replan
from .sections import cycle_return_map, cycle_section_state
from .sensing import Exact, sensor_draws
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
    samples : tuple
        With ``sample_dt``: the trajectory, ``(t [s], state (n, 8), mode (n, 4))`` in the
        kernel's frames, and ``params`` the run's robot parameters (for
        :func:`~monkeystudy.simulation.physical_points`).
    """

    arrived: bool
    failure: str
    gaits: tuple
    catches: np.ndarray
    sensed: np.ndarray
    time: float
    energy: float
    failed_at: tuple
    samples: tuple = ()
    params: np.ndarray | None = None


def _energy_change(log: np.ndarray) -> tuple[float, float]:
    """``(energy at the cycle's end [J], energy the impacts took [J])`` of a cycle's log."""
    lost = float(np.sum(np.maximum(log[:, L.L_E_BEFORE] - log[:, L.L_E_AFTER], 0.0)))
    return float(log[-1, L.L_E_AFTER]), lost


@dataclass(frozen=True)
class StepResult:
    """One step a :class:`Walker` took.

    Attributes
    ----------
    status : int
        The cycle's status (``ST_OK``: it caught and returned to its section).
    position : ndarray (2,)
        The attached magnet where the step ended [m] (the new one after a catch).
    attached : str
        The end attached there (``A`` or ``B``).
    catch_angles : tuple of float
        ``(theta1, theta2)`` [rad] at the catch, in the frame of the magnet the robot hung
        from (NaN without a catch).
    duration : float
        The step's time [s].
    energy : float
        The motor's net work over the step [J] (NaN when it failed).
    """

    status: int
    position: np.ndarray
    attached: str
    catch_angles: tuple
    duration: float
    energy: float


class Walker:
    """One run's robot on the wall: its build, its actuation latency and its hybrid state,
    stepping gait after gait.

    Step ``k`` of run ``run`` has the noise of cycle ``k`` of survival run ``run``
    (:mod:`monkeystudy.kernel.walk`); the build and the latency are the run's.

    Parameters
    ----------
    gait : WalkGait
        The gait the robot starts in: it starts on its section at its fixed point, plus the
        run's initial-state noise.
    position : sequence of float
        The attached magnet at the start [m].
    attached : {"A", "B"}
        The end attached there.
    """

    def __init__(self, gait: WalkGait, position, attached: str = "A", *,
                 robot: Robot | str = "seed2009", integrator: Integrator = Integrator(),
                 tick: float = 0.0, noise: Noise = Noise(), seed: int = 0, run: int = 0,
                 sample_dt: float = 0.0):
        self.robot = as_robot(robot)
        self.noise_vector = noise.vector()
        self.seed, self.run, self.tick = int(seed), int(run), float(tick)
        self.params = run_robot(self.robot, noise, self.seed, self.run).params()
        v = self.noise_vector
        self.latency = 0.0
        if v[L.NZ_LATENCY] > 0.0:    # as a survival run draws it
            self.latency = v[L.NZ_LATENCY] * 0.5 * (
                standard_draw(self.seed, self.run, PER_RUN_CYCLE, LATENCY_SLOT, True) + 1.0)
        self.settings = settings_vector(integrator, tick=self.tick, sample_dt=sample_dt)
        self.sample_dt = float(sample_dt)
        self.max_time = float(integrator.max_time)
        #: with ``sample_dt`` > 0: each step's samples ``(t, state, mode)``
        self.samples: list[tuple] = []
        self.programs: dict[str, tuple] = {}
        x, y = (float(c) for c in position)
        hyb = cycle_section_state(gait.gait, gait.z, height=y)
        hyb[L.X] = x
        hyb[L.H_FLIPPED] = 0.0 if attached == "A" else 1.0
        uniform = v[L.NZ_UNIFORM] > 0.0
        for i, source in ((L.TH2, L.NZ_THETA2), (L.DTH1, L.NZ_DTHETA1),
                          (L.DTH2, L.NZ_DTHETA2)):
            if v[source] > 0.0:
                hyb[i] += v[source] * standard_draw(self.seed, self.run, PER_RUN_CYCLE,
                                                    i - L.TH2, uniform)
        self.hyb = hyb
        kinetic, potential = energies(self.params, hyb[None, :8],
                                      np.array([int(hyb[L.H_FLIPPED] > 0.5)]))
        self.energy_now = float(kinetic[0] + potential[0])
        self.steps = 0

    @property
    def position(self) -> np.ndarray:
        """The attached magnet [m]."""
        return np.array([self.hyb[L.X], self.hyb[L.Y]], float)

    @property
    def attached(self) -> str:
        return "B" if self.hyb[L.H_FLIPPED] > 0.5 else "A"

    @property
    def time(self) -> float:
        """Since the start [s]."""
        return float(self.hyb[L.H_T])

    def step(self, gait: WalkGait, height: float) -> StepResult:
        """One cycle of ``gait`` from where the robot is, its catch at the world ``height``
        [m] (the guard's, as the robot judges it)."""
        if gait.name not in self.programs:
            prog, obs = gait.program(self.tick)
            # the noise roles read the rows' kinds only, not the catch height set per step
            self.programs[gait.name] = (prog, obs, noise_roles(prog))
        prog, obs, roles = self.programs[gait.name]
        cycle = with_catch_height(prog, height)
        hyb = self.hyb
        flipped = float(hyb[L.H_FLIPPED])
        hyb[L.H_SEG] = 0.0
        t0 = float(hyb[L.H_T])
        counts = np.zeros(L.N_COUNTS, dtype=np.int64)
        log = np.empty((CYCLE_LOG_ROWS, L.N_LOG_COLS))
        method = kernel_method(self.settings, cycle, hyb[L.H_PHASE])
        n = 0 if self.sample_dt <= 0.0 else \
            int(len(cycle) * self.max_time / self.sample_dt) + 64
        start = hyb.copy()
        while True:
            st, sy, sm = np.empty(n), np.empty((n, 8)), np.empty((n, L.N_MODE_COLS))
            status = int(walk_step(method, self.params, cycle, obs, self.settings, hyb,
                                   roles, self.noise_vector, self.seed, self.run,
                                   self.steps, float(self.latency), counts, log, st, sy, sm))
            if status != L.ST_BUFFER_FULL or n == 0:
                break
            hyb[:] = start        # the samples outgrew the buffer: the step again, larger
            n *= 2
        if n:
            k = int(counts[L.K_SAMPLES])
            self.samples.append((st[:k].copy(), sy[:k].copy(), sm[:k].copy()))
        self.steps += 1
        rows = log[:int(counts[L.K_LOG])]
        energy = math.nan
        if status == L.ST_OK:
            e_end, lost = _energy_change(rows)
            energy = e_end - self.energy_now + lost
            self.energy_now = e_end
        return StepResult(status, self.position, self.attached,
                          _catch_state(rows, cycle, flipped), float(hyb[L.H_T]) - t0, energy)


def walk_route(wall: Wall, gaits: Sequence[WalkGait], atlas: Sequence[AtlasGait],
               transitions: Sequence[Transition] = (), *, robot: Robot | str = "seed2009",
               integrator: Integrator = Integrator(), tick: float = 0.0,
               noise: Noise = Noise(), seed: int = 0, run: int = 0, sensor=None,
               max_steps: int = 100, height_step: float = 0.1,
               plan: dict | None = None, sample_dt: float = 0.0) -> Walk:
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
        How the robot estimates the attached magnet (a model of
        :mod:`monkeystudy.analysis.sensing`, its draws keyed by ``(seed, run, catch)``;
        None: :class:`~monkeystudy.analysis.sensing.Exact`, it knows it exactly).
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
    sample_dt : float
        > 0: record the trajectory every ``sample_dt`` [s] (:attr:`Walk.samples`).
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
    lengths = (robot.link1.length, robot.link2.length)
    true_pos = np.array(wall.start.position, float)
    if sensor is None:
        sensor = Exact()
    estimate = np.asarray(sensor.initial(true_pos, sensor_draws(seed, run, 0)), float)
    attached = wall.start.attached
    catches, sensed, names = [], [], []
    walker: Walker | None = None
    current = None
    energy, time_done = 0.0, 0.0     # over the completed steps

    def ended(arrived, failure, where=(math.nan, math.nan)):
        samples = ()
        if walker is not None and walker.samples:
            samples = tuple(np.concatenate(part) for part in zip(*walker.samples))
        return Walk(bool(arrived), failure, tuple(names),
                    np.array(catches, float).reshape(-1, 2),
                    np.array(sensed, float).reshape(-1, 2), time_done, energy, tuple(where),
                    samples, None if walker is None else walker.params)

    for step in range(int(max_steps) + 1):
        # the planned heights are the world's staircase: the estimate's row of it
        row = wall.start.position[1] + height_step * round(
            (estimate[1] - wall.start.position[1]) / height_step)
        believed = (float(estimate[0]), float(row))
        if wall.goal.distance(np.array(believed))[0] == 0.0:
            # it believes it has arrived: where it plans from is in the goal's disc
            arrived = wall.goal.distance(true_pos)[0] == 0.0
            return ended(arrived, ARRIVED if arrived else MISSED_GOAL,
                         (math.nan, math.nan) if arrived else tuple(true_pos))
        if step == int(max_steps):
            break
        if not wall.on_steel(believed)[0]:       # it believes itself off the wall
            return ended(False, NO_ROUTE, tuple(true_pos))
        try:
            route: Route = replan(wall, atlas, transitions, position=believed,
                                  attached=attached, gait=current, **plan)
        except NoRoute:
            return ended(False, NO_ROUTE, tuple(true_pos))
        first = route.steps[0]
        gait = by_name[first.gait]
        if walker is None:     # the walk starts on this gait's section, at its fixed point
            walker = Walker(gait, true_pos, attached, robot=robot, integrator=integrator,
                            tick=tick, noise=noise, seed=seed, run=run, sample_dt=sample_dt)
        # the planned catch is in the robot's belief; its height guard reads the belief
        hung_from = walker.attached
        result = walker.step(gait, float(first.catch[1]) - float(estimate[1] - true_pos[1]))
        names.append(gait.name)
        if result.status != L.ST_OK:
            return ended(False, status_name(result.status), tuple(result.position))
        before, true_pos, attached = true_pos, result.position, result.attached
        if not wall.can_catch(true_pos)[0]:
            return ended(False, OFF_STEEL, tuple(true_pos))
        energy += result.energy
        time_done = walker.time
        estimate = np.asarray(sensor.update(
            estimate, before, true_pos, result.catch_angles, sensor_draws(seed, run, step),
            lengths=lengths, attached=hung_from), float)
        catches.append(true_pos.copy())
        sensed.append(estimate.copy())
        current = gait.name
    return ended(False, MAX_STEPS, tuple(true_pos))


@dataclass(frozen=True)
class SwitchRuns:
    """Runs of a fixed sequence of steps (:func:`switch_runs`).

    Attributes
    ----------
    failed : ndarray of bool
        Per run: a step failed.
    failed_step : ndarray of int
        The step of the plan that failed (from 0; -1 when none did).
    """

    failed: np.ndarray
    failed_step: np.ndarray


def switch_runs(plan: Sequence[tuple], runs, *, min_advance: float = 0.5,
                height_tolerance: float = math.inf, robot: Robot | str = "seed2009",
                integrator: Integrator = Integrator(), tick: float = 0.0,
                noise: Noise = Noise(), seed: int = 0) -> SwitchRuns:
    """Runs of a fixed sequence of steps, e.g. a switch between gaits: ``plan`` lists each
    step's ``(gait, rise [m], advance [m])``, from the first gait's fixed point (under each
    run's noise, so a switch comes from where that gait's noisy steps leave the robot), each
    catch aimed at the staircase (the sum of the rises so far). A switch is measured this
    way, not assumed: the state one gait leaves need not lie in the next one's basin.

    A step fails when its cycle stops with a status other than ok, when it advances less
    than ``min_advance`` times its ``advance`` (signed: the way its gait travels), or when
    its catch lands more than ``height_tolerance`` [m] from its planned height.
    """
    runs = np.asarray(runs, dtype=np.int64).ravel()
    failed = np.zeros(len(runs), bool)
    failed_step = np.full(len(runs), -1, np.int64)
    for i, run in enumerate(runs):
        walker = Walker(plan[0][0], (0.0, 0.0), "A", robot=robot, integrator=integrator,
                        tick=tick, noise=noise, seed=seed, run=int(run))
        height = 0.0
        for k, (gait, rise, advance) in enumerate(plan):
            height += float(rise)
            x0 = walker.position[0]
            r = walker.step(gait, height)
            moved = math.copysign(1.0, advance) * (r.position[0] - x0)
            if (r.status != L.ST_OK or not moved >= min_advance * abs(advance)
                    or not abs(r.position[1] - height) <= height_tolerance):
                failed[i], failed_step[i] = True, k
                break
    return SwitchRuns(failed, failed_step)


@dataclass(frozen=True)
class SwitchDesign:
    """A switch step (:func:`design_switch`).

    Attributes
    ----------
    gait : SequenceGait
        The step, torques in the kernel's frame.
    spec : dict
        The same as a study's ``gait:`` block (torques in the motor frame).
    catch_torque, after_torque : float
        The motor torque [N m] from the section to the catch, and after the catch.
    after_time : float
        How long the second torque acts after the catch [s].
    rise : float
        The catch's height above the attached magnet's planned height [m].
    end : ndarray (3,)
        The section state the step reaches from the first gait's fixed point.
    residual : float
        Its distance from the second gait's fixed point (2-norm, ``theta2`` wrapped)
        [rad, rad s-1].
    """

    gait: SequenceGait
    spec: dict
    catch_torque: float
    after_torque: float
    after_time: float
    rise: float
    end: np.ndarray
    residual: float


def switch_spec(catch_torque: float, after_torque: float, after_time: float,
                rise: float) -> dict:
    """The ``gait:`` block of a switch step: from the section (link 1 vertical, either way)
    the motor torque ``catch_torque`` [N m] until the free magnet rises through ``rise`` [m]
    above the attached one's planned height, where it catches (the clock restarting there);
    the magnets swap and ``after_torque`` acts for ``after_time`` [s]; then the motor is off
    to the next section. Torques in the motor frame."""
    return {"kind": "sequence", "torque_frame": "motor",
            "section": {"theta1": 0.0, "direction": "either"},
            "segments": [
                {"until": "free_end_y", "value": float(rise), "direction": "rising",
                 "torque": float(catch_torque), "clock": "reset"},
                {"until": "time", "value": float(after_time), "magnets": "swap",
                 "torque": float(after_torque)}]}


def design_switch(before: WalkGait, after: WalkGait, *, rise: float, torque_limit: float,
                  robot: Robot | str = "seed2009", integrator: Integrator = Integrator(),
                  max_time: float = 1.5, tol: float = 1e-9) -> SwitchDesign:
    """A one-step switch from ``before``'s cycle into ``after``'s: the step of
    :func:`switch_spec` whose three numbers (two motor torques within ``torque_limit``
    [N m], the second's duration up to ``max_time`` [s]) take ``before``'s fixed point to
    ``after``'s on the section, by bounded least squares (scipy) from a grid of starts.

    It stops at the first start that meets ``after``'s fixed point to ``tol`` (2-norm);
    otherwise it returns the least residual found: a step that lands near ``after``'s
    fixed point, inside its basin or not (:func:`switch_runs` measures that).
    """
    # scipy's optimiser only when designing: the walks themselves need none of it
    import itertools
    from scipy.optimize import least_squares

    robot = as_robot(robot)
    limit = float(torque_limit)
    target = np.asarray(after.z, float)

    def residual(p):
        z, status = cycle_return_map(before.z, switch_gait(*p, rise), robot=robot,
                                     integrator=integrator)
        if status != L.ST_OK:
            return np.full(3, 10.0)     # no cycle: far from any fixed point
        d = np.asarray(z, float) - target
        d[0] = (d[0] + math.pi) % (2.0 * math.pi) - math.pi
        return d

    best = None
    # the residual has many local minima: a grid of starts, the first that meets tol wins
    grid = tuple(f * limit for f in (-0.95, -0.75, -0.5, -0.3, -0.1, 0.1, 0.3, 0.5, 0.75, 0.95))
    for x0 in itertools.product(grid, grid, (0.2, 0.35, 0.5)):
        fit = least_squares(residual, x0, bounds=([-limit, -limit, 0.02],
                                                  [limit, limit, float(max_time)]),
                            xtol=1e-15, ftol=1e-15, gtol=1e-15, max_nfev=200)
        if best is None or fit.cost < best.cost:
            best = fit
        if math.sqrt(2.0 * best.cost) <= tol:
            break
    catch_torque, after_torque, after_time = (float(v) for v in best.x)
    d = residual(best.x)
    return SwitchDesign(switch_gait(catch_torque, after_torque, after_time, rise),
                        switch_spec(catch_torque, after_torque, after_time, rise),
                        catch_torque, after_torque, after_time, float(rise), target + d,
                        float(np.linalg.norm(d)))


def switch_gait(catch_torque: float, after_torque: float, after_time: float,
                rise: float) -> SequenceGait:
    """The switch step of :func:`switch_spec` as the kernel runs it (the torque after the
    swap in the new attached end's frame: the motor's torque negated,
    :func:`~monkeystudy.controllers.torques_from_motor_frame`)."""
    return torques_from_motor_frame(SequenceGait(
        [Segment("free_end_y", value=float(rise), direction="rising",
                 torque=float(catch_torque), clock="reset"),
         Segment("time", value=float(after_time), magnets="swap", torque=float(after_torque))],
        section_theta1=0.0, section_direction="either"))


def walk_trajectory(walk: Walk) -> dict | None:
    """A sampled walk's trajectory in the world (None without samples): ``time`` [s], the
    positions ``A``, ``joint``, ``B`` (n, 2) [m], ``attached_end`` (0: A, 1: B), ``phase``
    and ``motor_torque`` [N m] (on theta2 of the frame of the end attached)."""
    if not walk.samples:
        return None
    t, y, mode = walk.samples
    flipped = mode[:, L.M_FLIPPED]
    pts = physical_points(walk.params, y, flipped)
    return {"time": t, "A": pts["A"], "joint": pts["joint"], "B": pts["B"],
            "attached_end": flipped.astype(np.int8),
            "phase": mode[:, L.M_PHASE].astype(np.int8), "motor_torque": mode[:, L.M_TORQUE]}


def _catch_state(rows: np.ndarray, prog: np.ndarray, flipped: float) -> tuple[float, float]:
    """``(theta1, theta2)`` [rad] at the catch, in the frame of the magnet the robot hung from
    (``flipped``: that frame's flag): the state logged where the catch row exits, taken back
    through the flip when the log states it after the swap (docs/model.md section 3:
    ``theta1' = pi + theta1 + theta2``, ``theta2' = -theta2``)."""
    catch = set(catch_rows(prog).tolist())
    for r in rows:
        if r[L.L_KIND] == L.LOG_SEGMENT and int(r[L.L_ID]) in catch:
            th1, th2 = float(r[L.L_STATE + L.TH1]), float(r[L.L_STATE + L.TH2])
            if r[L.L_FLIPPED] != flipped:
                th2 = -th2
                th1 = (th1 - th2 - 2.0 * math.pi) % (2.0 * math.pi) - math.pi
            return th1, th2
    return math.nan, math.nan


__all__ = ["ARRIVED", "MAX_STEPS", "MISSED_GOAL", "NO_ROUTE", "OFF_STEEL", "StepResult",
           "SwitchDesign", "SwitchRuns", "Walk", "WalkGait", "Walker", "catch_rows",
           "design_switch", "mirrored_gait", "switch_gait", "switch_runs", "switch_spec",
           "walk_route", "walk_trajectory", "with_catch_height"]
