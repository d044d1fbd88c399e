"""Per-brachiation measures of AcroMonk: the hardware logs, the lab's nominal trajectories,
and those trajectories run open loop on the model.

Every measure is a function of a time series in the model's frame (a
:class:`~monkeystudy.analysis.measured_replay.ModelSwing`: times, ``theta1``, ``theta2``, their
rates, the torque on ``theta2``, the parameter row), so one set of functions serves a log's
brachiation (:func:`log_brachiations`), a nominal trajectory (:func:`nominal_trajectory`) and a
simulated gait's samples alike (:func:`measures`). docs/acromonk.md, "Brachiations measured",
gives the table and the choices.

**The integrals** are trapezoids on the samples as they come (no resampling): ``∫ τ² dt``
takes ``τ²`` linear between samples, the positive work takes the power ``τ dθ2/dt`` linear
between samples and integrates its positive part exactly (an interval where the power changes
sign contributes the triangle above zero). An interval longer than ``gap_threshold`` is not
hidden: the largest interval is reported and the brachiation is flagged.

**The torque** is the series' own: for a log the servo's current-based estimate, which the
identified model (docs/acromonk.md) says reads ``1 / 0.8087 = 1.24`` times the torque at the
elbow. Nothing is rescaled here: at the elbow, the peak torque is 0.8087 times the logged
one, ``∫ τ² dt`` 0.8087² = 0.654 times and the positive work 0.8087 times (the rates are
measured, not estimated).

**The catch** is the series' last sample: the free end's velocity there, from the kernel's
points (:func:`monkeystudy.simulation.physical_points`) and the rigid-body rule ``v = ω × r``
per link: its speed, its components onward along the ladder (away from the held end) and
down, and its angle below the horizontal counted from onward.
"""
from __future__ import annotations

import gzip
import math
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Sequence

import numpy as np

from ..kernel import layout as L
from ..measured import FLAG_COLUMN, RELEASE, HardwareLog, holding, swings
from ..controllers import Integrator, SequenceGait
from ..robot import Friction, Robot
from ..simulation import Status, run_controller
from ..urdf import reduce_urdf
from .measured_replay import (ACROMONK_FAR_GRIP, ACROMONK_JOINTS, ACROMONK_LINKS, ACROMONK_URDF,
                              PUBLISHED_JOINT, PUBLISHED_PIVOT, ModelSwing, ModelValues, Replay,
                              acromonk_robot, free_end, replay)
from .sections import cycle_section_state

#: the lab's direct-collocation trajectories in a source checkout (data/acromonk/trajectories)
ACROMONK_TRAJECTORIES = ACROMONK_URDF.parents[1] / "trajectories"
NOMINAL_TRAJECTORIES = ("BF", "FB", "ZB", "ZF")
#: an interval between samples longer than this flags a brachiation's integrals [s] (the
#: loggers' intervals are 2-21 ms; their pauses between a catch and a release about 0.2 s)
GAP_THRESHOLD = 0.05
#: the bars' spacing [m] (data/acromonk/trajectories/*/hyperparameters_*.txt, the URDF's sticks)
LADDER_DISTANCE = 0.34
#: the identified model of docs/acromonk.md (``monkeystudy inspect outputs/acromonk``: the
#: hardware_replay step of studies/acromonk.yaml): friction, rotor inertia, torque scale
IDENTIFIED = ModelValues(pivot=Friction(viscous=0.0, coulomb=0.07865),
                         joint=Friction(viscous=0.04144, coulomb=0.0),
                         torque_scale=0.8087, rotor_inertia=2.453e-4)
#: the published damping (data/acromonk/model/acromonk_mujoco.xml), no rotor
PUBLISHED = ModelValues(pivot=PUBLISHED_PIVOT, joint=PUBLISHED_JOINT)
FRICTIONLESS = ModelValues()
#: the share of a nominal trajectory's duration, counted back from its end, in which the
#: open loop's closest approach to the target bar is sought [1]
APPROACH_WINDOW = 0.25


# --- the measures -----------------------------------------------------------------------------
def torque_square_integral(time: np.ndarray, torque: np.ndarray) -> float:
    """``∫ τ² dt`` [N² m² s]: trapezoid on the samples."""
    t, u = np.asarray(time, float), np.asarray(torque, float)
    return float(np.sum(0.5 * (u[1:] ** 2 + u[:-1] ** 2) * np.diff(t)))


def positive_work(time: np.ndarray, torque: np.ndarray, rate: np.ndarray) -> float:
    """``∫ max(τ dθ2/dt, 0) dt`` [J]: the power linear between samples, its positive part
    integrated exactly (where it changes sign within an interval, the part above zero)."""
    t = np.asarray(time, float)
    p = np.asarray(torque, float) * np.asarray(rate, float)
    a, b, h = p[:-1], p[1:], np.diff(t)
    both = np.where((a >= 0) & (b >= 0), 0.5 * (a + b) * h, 0.0)
    mixed = (a * b < 0)
    hi = np.maximum(a, b)
    span = np.where(mixed, np.abs(a) + np.abs(b), 1.0)
    part = np.where(mixed, 0.5 * hi * hi / span * h, 0.0)
    return float(np.sum(both) + np.sum(part))


def positive_work_held(time: np.ndarray, torque: np.ndarray, angle: np.ndarray,
                       rate: np.ndarray) -> float:
    """``∫ max(τ dθ2/dt, 0) dt`` [J] of a torque held constant between samples (a simulated
    sequence gait: constant per segment, its changes at repeated sample times).

    On each interval ``τ`` is constant, so the integral is ``τ Δθ2`` over each stretch where
    ``dθ2/dt`` keeps its sign: exact from the angle, whatever the sampling. Where the rate
    changes sign inside an interval, the turning point of ``θ2`` is taken on the cubic Hermite
    interpolant of ``(θ2, dθ2/dt)`` at its ends (error ``O(h⁴)`` in the angle there). An
    interval of zero length (a torque change at an event) adds nothing; one of positive length
    whose ends carry different torques is refused (``ValueError``): the torque is not held.
    """
    t = np.asarray(time, float)
    u = np.asarray(torque, float)
    th = np.asarray(angle, float)
    w = np.asarray(rate, float)
    h = np.diff(t)
    if np.any((h > 0) & (u[1:] != u[:-1])):
        k = int(np.flatnonzero((h > 0) & (u[1:] != u[:-1]))[0])
        raise ValueError(f"the torque changes within the interval {t[k]:.6g}..{t[k + 1]:.6g} "
                         "s: not held between samples")
    total = 0.0
    for k in np.flatnonzero(h > 0):
        tau, dt = u[k], h[k]
        ta, tb, ra, rb = th[k], th[k + 1], w[k], w[k + 1]
        if ra * rb < 0.0:
            tm = _hermite_turning_angle(ta, tb, ra * dt, rb * dt)
            total += max(tau * (tm - ta), 0.0) + max(tau * (tb - tm), 0.0)
        else:
            total += max(tau * (tb - ta), 0.0)
    return float(total)


def _hermite_turning_angle(ta: float, tb: float, ma: float, mb: float) -> float:
    """The value at the turning point inside ``(0, 1)`` of the cubic Hermite interpolant with
    end values ``ta``, ``tb`` and end slopes (per unit of ``s``) ``ma``, ``mb`` of opposite
    signs (its derivative, a quadratic, has exactly one root there)."""
    d = tb - ta
    a2, a1, a0 = -6.0 * d + 3.0 * (ma + mb), 6.0 * d - 4.0 * ma - 2.0 * mb, ma
    if abs(a2) <= 1e-14 * (abs(a1) + abs(a0)):
        s = -a0 / a1
    else:
        roots = np.roots([a2, a1, a0])
        roots = roots[np.abs(roots.imag) <= 1e-12].real
        s = float(roots[np.argmin(np.abs(roots - np.clip(roots, 0.0, 1.0)))])
    s = min(max(s, 0.0), 1.0)
    h00, h10 = 2 * s ** 3 - 3 * s ** 2 + 1, s ** 3 - 2 * s ** 2 + s
    h01, h11 = -2 * s ** 3 + 3 * s ** 2, s ** 3 - s ** 2
    return h00 * ta + h10 * ma + h01 * tb + h11 * mb


def free_end_velocity(robot: Robot, theta1, theta2, theta1_rate, theta2_rate,
                      flipped: int) -> tuple[np.ndarray, np.ndarray]:
    """The free end's position [m] and velocity [m s-1], (n, 2) each, with the held end at
    rest at the origin: ``v = w1 × (joint - held) + (w1 + w2) × (free - joint)`` on the
    kernel's points (each link turns rigidly about its proximal point)."""
    held, joint, free = free_end(robot, theta1, theta2, flipped)
    w1 = np.atleast_1d(np.asarray(theta1_rate, float))
    w12 = w1 + np.atleast_1d(np.asarray(theta2_rate, float))
    r1, r2 = joint - held, free - joint
    v = np.column_stack([-w1 * r1[:, 1] - w12 * r2[:, 1], w1 * r1[:, 0] + w12 * r2[:, 0]])
    return free, v


@dataclass(frozen=True)
class Measures:
    """One brachiation's measures (:func:`measures`).

    Attributes
    ----------
    name : str
        The series' name.
    duration : float
        From the series' first sample to its last (the catch instant) [s].
    positive_work : float
        ``∫ max(τ dθ2/dt, 0) dt`` [J].
    torque_square : float
        ``∫ τ² dt`` [N² m² s], the electrical-loss proxy.
    peak_torque : float
        Largest ``|τ|`` [N m].
    catch_speed : float
        The free end's speed at the last sample [m s-1].
    catch_onward, catch_down : float
        Its velocity's components [m s-1] along the ladder away from the held end (onward) and
        downward.
    catch_angle : float
        The angle of its velocity below the horizontal [rad], counted from the onward
        direction: 0 onward, pi/2 straight down, pi back toward the held bar, negative rising.
    catch_position : tuple of float
        The free end at the last sample from the held end (x, y) [m].
    largest_gap : float
        The longest interval between samples [s].
    gapped : bool
        ``largest_gap`` exceeds the threshold the measures were taken with.
    """

    name: str
    duration: float
    positive_work: float
    torque_square: float
    peak_torque: float
    catch_speed: float
    catch_onward: float
    catch_down: float
    catch_angle: float
    catch_position: tuple[float, float]
    largest_gap: float
    gapped: bool


def measures(robot: Robot, series: ModelSwing, *, gap_threshold: float = GAP_THRESHOLD,
             held: bool = False) -> Measures:
    """The per-brachiation measures of a series from its first sample to its last, which is
    taken as the catch instant (see the module docstring for the integrals and the torque).

    ``held``: the torque is held constant between samples (a simulation's,
    :func:`gait_brachiations`): the positive work is :func:`positive_work_held`, exact from
    the angle, and the trapezoid of ``τ²`` is exact too (``τ²`` constant on each interval)."""
    t = np.asarray(series.time, float)
    if t.size < 2:
        raise ValueError(f"{series.name}: a brachiation needs at least two samples")
    pos, vel = free_end_velocity(robot, series.theta1[-1], series.theta2[-1],
                                 series.theta1_rate[-1], series.theta2_rate[-1], series.flipped)
    onward = math.copysign(1.0, float(pos[0, 0])) * float(vel[0, 0])
    down = -float(vel[0, 1])
    gap = float(np.max(np.diff(t)))
    return Measures(name=series.name, duration=float(t[-1] - t[0]),
                    positive_work=(positive_work_held(t, series.torque, series.theta2,
                                                      series.theta2_rate) if held else
                                   positive_work(t, series.torque, series.theta2_rate)),
                    torque_square=torque_square_integral(t, series.torque),
                    peak_torque=float(np.max(np.abs(series.torque))),
                    catch_speed=math.hypot(onward, down), catch_onward=onward,
                    catch_down=down, catch_angle=math.atan2(down, onward),
                    catch_position=(float(pos[0, 0]), float(pos[0, 1])),
                    largest_gap=gap, gapped=gap > gap_threshold)


# --- the logs' brachiations -------------------------------------------------------------------
def log_brachiations(log: HardwareLog, *, with_release: bool = True) -> list[ModelSwing]:
    """Each brachiation of a log as a series in the model's frame, up to and including its
    catch instant.

    With the flag (``state_machine_flag``), a brachiation runs from the first row of the
    release (the flag-0 run before the swing; ``with_release=False``: the swing's first row)
    to the first catch row (flag 2), the instant the tracked trajectory has ended with the
    swing hook at the next bar. Without the flag it is the swing as
    :func:`monkeystudy.measured.swings` cuts it by the desired trajectory, to the row after it
    (the catch's first row) where the log goes on, else to the log's last row. The holding
    hook, and so the frame, is the swing's (:func:`monkeystudy.measured.holding`): the
    logger's shoulder is the new holding link's from the release on and still the finished
    swing's on the first catch row (docs/acromonk.md, "Roles and signs after a catch").
    Names: ``<log>#<swing number from 1>``.
    """
    out = []
    for k, sw in enumerate(swings(log), start=1):
        start = sw.start
        if with_release and log.phase is not None:
            while start > 0 and log.phase[start - 1] == RELEASE:
                start -= 1
        stop = min(sw.stop + 1, len(log))
        rows = slice(start, stop)
        s = holding(log, sw).elbow_sign
        out.append(ModelSwing(time=log.time[rows] - log.time[start],
                              theta1=log.shoulder_angle[rows].copy(),
                              theta2=s * log.elbow_angle[rows],
                              theta1_rate=log.shoulder_rate[rows].copy(),
                              theta2_rate=s * log.elbow_rate[rows],
                              torque=s * log.elbow_torque[rows],
                              flipped=0 if s == 1 else 1, name=f"{log.name}#{k}"))
    return out


def has_flag(log: HardwareLog) -> bool:
    """Whether the log has the state machine's flag (:data:`monkeystudy.measured.FLAG_COLUMN`)."""
    return FLAG_COLUMN in log.columns


# --- the nominal trajectories -----------------------------------------------------------------
def read_trajectory(path: str | Path) -> dict[str, np.ndarray]:
    """A direct-collocation trajectory file (gzip CSV with a header row) as columns."""
    with gzip.open(Path(path), "rt") as f:
        header = f.readline().strip().split(",")
        values = np.loadtxt(f, delimiter=",", ndmin=2)
    return dict(zip(header, values.T))


def nominal_trajectory(name: str, *, folder: str | Path = ACROMONK_TRAJECTORIES,
                       urdf: str | Path = ACROMONK_URDF) -> ModelSwing:
    """The lab's nominal trajectory ``name`` (BF, FB, ZB, ZF) in the model's frame.

    The files give the URDF's joint angles (``shoulder_pos``: the grip joint of ``hook_1``,
    the motor arm, which holds; ``elbow_pos``: the motor joint), their rates and the planned
    elbow torque at 1 ms; the URDF's angle map (:class:`monkeystudy.urdf.UrdfAngles`) takes
    them to ``theta1``, ``theta2`` of parameter row 0 (tests/test_urdf.py checks the knots'
    accelerations against this model).
    """
    cols = read_trajectory(Path(folder) / name / f"{name}_traj.csv.gz")
    a = reduce_urdf(urdf, links=ACROMONK_LINKS, joints=ACROMONK_JOINTS,
                    far_grip=ACROMONK_FAR_GRIP).angles
    th1, th2 = a.model_angles(cols["shoulder_pos"], cols["elbow_pos"])
    return ModelSwing(time=cols["time"] - cols["time"][0], theta1=th1, theta2=th2,
                      theta1_rate=cols["shoulder_vel"].copy(),
                      theta2_rate=a.theta2_sign * cols["elbow_vel"],
                      torque=a.theta2_sign * cols["elbow_torque"], flipped=0, name=name)


# --- open loop --------------------------------------------------------------------------------
@dataclass(frozen=True)
class OpenLoop:
    """A nominal trajectory run open loop (:func:`open_loop`).

    Attributes
    ----------
    name : str
        The trajectory and the model.
    time : ndarray
        The plan's sample times after its first [s].
    free_end, planned_free_end : ndarray
        The simulated and the planned free end (n, 2) from the held end [m].
    final_miss : float
        Their distance at the plan's final time [m].
    target : tuple of float
        The target bar from the held bar (x, y) [m]: :data:`LADDER_DISTANCE` on the side of
        the plan's final free end.
    closest : float
        The simulated free end's closest approach to the target bar over the last
        :data:`APPROACH_WINDOW` of the plan's duration [m].
    closest_time : float
        When [s].
    planned_closest : float
        The plan's own closest approach over the same window [m].
    final_state, planned_final_state : ndarray
        ``[theta1, theta2, dtheta1, dtheta2]`` at the final time, simulated and planned.
    elbow_peak : float
        The largest ``|theta2|`` of the run [rad] (the model has no joint limit; the plans'
        hyperparameters state ``theta_limit=[2.094, 2.880]`` rad).
    """

    name: str
    time: np.ndarray
    free_end: np.ndarray
    planned_free_end: np.ndarray
    final_miss: float
    target: tuple[float, float]
    closest: float
    closest_time: float
    planned_closest: float
    final_state: np.ndarray
    planned_final_state: np.ndarray
    elbow_peak: float

    def caught(self, capture_radius: float) -> bool:
        """The capture rule: the free end comes within ``capture_radius`` [m] of the target
        bar in the approach window."""
        return bool(self.closest <= capture_radius)


def open_loop(robot: Robot, plan: ModelSwing, *, horizon: float | None = None,
              torque_scale: float = 1.0, name: str | None = None) -> OpenLoop:
    """Run a plan open loop on ``robot``: from its first state, its torque times
    ``torque_scale`` the only input, for ``horizon`` [s] (default: the whole plan).

    The torque is held centred on each 1 ms sample (:func:`~monkeystudy.analysis.
    measured_replay.held_torque`, ``centred``): the plan's torque is linear within each
    collocation segment, and a centred hold of a linear function has its impulse over each
    piece exactly, so the held input departs from the plan's by at most half a sample's
    change (below 0.004 N m on the four plans) with no drift. The simulator is the measured replay's
    (:func:`~monkeystudy.analysis.measured_replay.replay`), sampled at the plan's times.
    """
    t_end = plan.duration if horizon is None else float(horizon)
    rep: Replay = replay(robot, plan, 0, t_end, torque_scale=torque_scale)
    rows = np.searchsorted(plan.time, rep.time - 1e-12)
    _, _, sim = free_end(robot, rep.simulated[:, 0], rep.simulated[:, 1], plan.flipped)
    _, _, want = free_end(robot, plan.theta1[rows], plan.theta2[rows], plan.flipped)
    _, _, last = free_end(robot, plan.theta1[-1], plan.theta2[-1], plan.flipped)
    target = (math.copysign(LADDER_DISTANCE, float(last[0, 0])), 0.0)
    window = rep.time >= (1.0 - APPROACH_WINDOW) * plan.duration
    if not window.any():
        window = rep.time >= rep.time[-1]
    d_sim = np.hypot(sim[:, 0] - target[0], sim[:, 1] - target[1])
    d_plan = np.hypot(want[:, 0] - target[0], want[:, 1] - target[1])
    k = int(np.argmin(np.where(window, d_sim, np.inf)))
    final = np.r_[rep.simulated[-1], rep.simulated_rates[-1]]
    r = int(rows[-1])
    planned = np.array([plan.theta1[r], plan.theta2[r], plan.theta1_rate[r], plan.theta2_rate[r]])
    return OpenLoop(name=name or plan.name, time=rep.time, free_end=sim, planned_free_end=want,
                    final_miss=float(np.hypot(*(sim[-1] - want[-1]))), target=target,
                    closest=float(d_sim[k]), closest_time=float(rep.time[k]),
                    planned_closest=float(np.min(np.where(window, d_plan, np.inf))),
                    final_state=final, planned_final_state=planned,
                    elbow_peak=float(np.max(np.abs(rep.simulated[:, 1]))))


#: the models the nominal trajectories are run on: name -> values (on :func:`acromonk_robot`)
OPEN_LOOP_MODELS = {"identified": IDENTIFIED, "published": PUBLISHED,
                    "frictionless": FRICTIONLESS}


def closed_chain(robot: Robot, distance: float = LADDER_DISTANCE,
                 urdf: str | Path = ACROMONK_URDF) -> tuple[float, float, float, float]:
    """The pose with the held end and the free end on bars ``distance`` [m] apart at one
    height, hanging below them: ``(theta1, theta2)`` of parameter row 0 and the URDF's joint
    angles ``(q1, q2)`` [rad] (the triangle of the two links and the bars' chord)."""
    l1, l2, d = robot.link1.length, robot.link2.length, float(distance)
    alpha = math.acos((l1 * l1 + d * d - l2 * l2) / (2.0 * l1 * d))
    th1 = 0.5 * math.pi - alpha
    th12 = math.atan2(d - l1 * math.sin(th1), -l1 * math.cos(th1))
    th2 = th12 - th1
    a = reduce_urdf(urdf, links=ACROMONK_LINKS, joints=ACROMONK_JOINTS,
                    far_grip=ACROMONK_FAR_GRIP).angles
    q1, q2 = a.urdf_angles(th1, th2)
    return th1, th2, float(q1), float(q2)


def open_loop_models(base: Robot | None = None) -> dict[str, Robot]:
    """:data:`OPEN_LOOP_MODELS` as robots on ``base`` (default :func:`acromonk_robot`)."""
    b = base or acromonk_robot()
    return {k: v.robot(b) for k, v in OPEN_LOOP_MODELS.items()}


def catch_distances(robot: Robot, series: Sequence[ModelSwing]) -> np.ndarray:
    """The free end's distance [m] from the bar :data:`LADDER_DISTANCE` away (on its side) at
    each series' last sample (for a log's brachiation: its catch instant)."""
    out = []
    for ms in series:
        _, _, p = free_end(robot, ms.theta1[-1], ms.theta2[-1], ms.flipped)
        x, y = float(p[0, 0]), float(p[0, 1])
        out.append(math.hypot(x - math.copysign(LADDER_DISTANCE, x), y))
    return np.array(out)


def open_loop_series(robot: Robot, plan: ModelSwing, *, torque_scale: float = 1.0,
                     name: str | None = None) -> ModelSwing:
    """A plan run open loop (:func:`open_loop`) as a series: the plan's first state, then
    the simulated angles and rates at the plan's later samples, the plan's torque times
    ``torque_scale`` (the input is its centred hold, within half a sample's change of it)."""
    rep: Replay = replay(robot, plan, 0, plan.duration, torque_scale=torque_scale)
    rows = np.r_[0, np.searchsorted(plan.time, rep.time - 1e-12)]
    return ModelSwing(time=np.r_[0.0, rep.time],
                      theta1=np.r_[plan.theta1[0], rep.simulated[:, 0]],
                      theta2=np.r_[plan.theta2[0], rep.simulated[:, 1]],
                      theta1_rate=np.r_[plan.theta1_rate[0], rep.simulated_rates[:, 0]],
                      theta2_rate=np.r_[plan.theta2_rate[0], rep.simulated_rates[:, 1]],
                      torque=torque_scale * plan.torque[rows], flipped=plan.flipped,
                      name=name or plan.name)


# --- a simulated gait's brachiations ----------------------------------------------------------
#: the sampling step of a simulated gait's brachiations [s]: samples of the integrator's dense
#: output, the events (segment exits, catches) among them; only the turning points of theta2
#: depend on it (:func:`positive_work_held`)
GAIT_SAMPLE_DT = 1e-3


@dataclass(frozen=True)
class DesignedGait:
    """A sequence gait that catches bars, at its fixed point: what :func:`gait_brachiations`
    runs.

    Attributes
    ----------
    name : str
        How the table names it (the study's name).
    robot : Robot
        The robot it runs on.
    gait : SequenceGait
        The gait, its torques in the kernel's frame.
    section_state : tuple of float
        Its fixed point on the section, ``(theta2 [rad], dtheta1, dtheta2 [rad s-1])``.
    integrator : Integrator
        The integrator it is run with.
    """

    name: str
    robot: Robot
    gait: SequenceGait
    section_state: tuple[float, float, float]
    integrator: Integrator


def gait_brachiations(design: DesignedGait, *, sample_dt: float = GAIT_SAMPLE_DT
                      ) -> list[ModelSwing]:
    """Each brachiation of one cycle of a sequence gait that catches bars, as a series from
    one catch to the next.

    Two cycles are run from the fixed point (identical cycles); a catch is the exit of an
    ``until: bar`` segment where the attached end changes (docs/model.md section 6). A
    brachiation runs from the sample after one catch's impact to the sample before the next
    catch's impact (the state the catch's speed is measured in), in the frame of the end that
    holds (``flipped``), the torque the one the kernel applies on ``theta2`` of that frame;
    one series per catch of a cycle, in the order of the run, from the cycle's first catch.
    Names ``<gait>: A holds`` (end A, the motor arm) or ``B holds``. ``ValueError`` when the
    run fails or the two cycles do not catch alike.
    """
    prog, _ = design.gait.program()
    res = run_controller(design.gait.controller(),
                         cycle_section_state(design.gait, design.section_state),
                         robot=design.robot, integrator=design.integrator, cycles=2,
                         sample_dt=sample_dt)
    if res.status != Status.OK:
        raise ValueError(f"{design.name}: the gait's run stopped: {res.status.name}")
    t, seg, fl = res.sample_t, res.sample_segment.astype(int), res.sample_flipped.astype(int)
    catches = [i for i in range(t.size - 1)
               if t[i + 1] == t[i] and fl[i + 1] != fl[i]
               and int(prog[seg[i], L.S_GUARD]) == L.G_BAR]
    if len(catches) < 2 or len(catches) % 2:
        raise ValueError(f"{design.name}: {len(catches)} catches in two cycles: a gait that "
                         "catches bars catches as often in each cycle")
    out = []
    for a, b in zip(catches[:len(catches) // 2], catches[1:len(catches) // 2 + 1]):
        rows = slice(a + 1, b + 1)
        f = fl[a + 1]
        if np.any(fl[rows] != f):
            raise ValueError(f"{design.name}: the attached end changes between two catches")
        s = res.sample_state[rows]
        out.append(ModelSwing(time=t[rows] - t[a + 1], theta1=s[:, L.TH1].copy(),
                              theta2=s[:, L.TH2].copy(), theta1_rate=s[:, L.DTH1].copy(),
                              theta2_rate=s[:, L.DTH2].copy(),
                              torque=res.sample_torque[rows].copy(), flipped=int(f),
                              name=f"{design.name}: {'AB'[f]} holds"))
    return out


# --- the comparison table (tools/acromonk_brachiation.py) -------------------------------------
#: the open-loop runs of the table: label -> (model, torque scale on the plan's torque)
OPEN_LOOP_RUNS = {"identified": ("identified", 1.0),
                  "identified, torque x0.8087": ("identified", IDENTIFIED.torque_scale),
                  "published": ("published", 1.0),
                  "frictionless": ("frictionless", 1.0)}


def capture_radius(robot: Robot, logs: Sequence[HardwareLog]) -> float:
    """The capture rule's radius [m]: the farthest the free end was from the next bar at the
    catch instant of a brachiation the hardware caught (the flagged logs' brachiations, each
    followed by the state machine's catch; :func:`catch_distances`)."""
    dist = [catch_distances(robot, log_brachiations(log)) for log in logs if has_flag(log)]
    if not dist:
        raise ValueError("no flagged log: the capture radius needs the hardware's catches")
    return float(np.max(np.concatenate(dist)))


def _mean_sd(values: Sequence[float], fmt: str) -> str:
    v = np.asarray(values, float)
    if v.size == 1:
        return f"{v[0]:{fmt}}"
    return f"{v.mean():{fmt}}±{v.std(ddof=1):{fmt.lstrip('+')}}"


def _measure_columns(ms: Sequence[Measures]) -> list[str]:
    return [_mean_sd([m.duration for m in ms], ".3f"),
            _mean_sd([m.positive_work for m in ms], ".2f"),
            _mean_sd([m.torque_square for m in ms], ".2f"),
            _mean_sd([m.peak_torque for m in ms], ".2f"),
            _mean_sd([m.catch_speed for m in ms], ".2f"),
            _mean_sd([m.catch_onward for m in ms], "+.2f"),
            _mean_sd([m.catch_down for m in ms], "+.2f")]


def _table(header: Sequence[str], rows: Sequence[Sequence[str]]) -> list[str]:
    cols = [header] + [list(r) for r in rows]
    width = [max(len(r[k]) for r in cols) for k in range(len(header))]
    return ["  ".join(c.ljust(w) for c, w in zip(r, width)).rstrip() for r in cols]


MEASURE_HEADER = ("n", "duration_s", "work+_J", "int_tau2_N2m2s", "peak_tau_Nm", "catch_m/s",
                  "onward_m/s", "down_m/s")


def at_elbow(m: Measures, scale: float = IDENTIFIED.torque_scale) -> Measures:
    """A log's measures with its torque taken to the elbow: the servo's estimate times
    ``scale`` (the peak and the positive work times ``scale``, ``∫ τ² dt`` times its square;
    the rates are measured, the catch unchanged)."""
    return replace(m, positive_work=scale * m.positive_work,
                   torque_square=scale * scale * m.torque_square,
                   peak_torque=scale * m.peak_torque)


def _plain_mean_columns(ms: Sequence[Measures]) -> list[str]:
    return [f"{np.mean([getattr(m, k) for m in ms]):{fmt}}" for k, fmt in
            (("duration", ".3f"), ("positive_work", ".2f"), ("torque_square", ".2f"),
             ("peak_torque", ".2f"), ("catch_speed", ".2f"), ("catch_onward", "+.2f"),
             ("catch_down", "+.2f"))]


def side_by_side(logs: Sequence[HardwareLog], plans: dict[str, ModelSwing], base: Robot,
                 gait: DesignedGait | None, radius: float) -> list[str]:
    """The table of every source's measures per brachiation with the torque at the elbow:
    the logs (their estimate times :data:`IDENTIFIED`'s scale), the plans run open loop on the
    identified model, and the designed gait's brachiations and their mean."""
    out = ["", f"Side by side, per brachiation, the torque at the elbow (the logs' estimate "
               f"x{IDENTIFIED.torque_scale:.4f}, int tau2 x{IDENTIFIED.torque_scale ** 2:.3f}; "
               "the models' own torque):"]
    rows = []
    for log in logs:
        spans = (("release->catch", True), ("swing->catch", False)) if has_flag(log) else \
            (("swing->catch", False),)
        for span, with_release in spans:
            ms = [at_elbow(measures(base, b))
                  for b in log_brachiations(log, with_release=with_release)]
            rows.append([f"{log.name} (hardware)", span, str(len(ms))] + _measure_columns(ms)
                        + [""])
    identified = IDENTIFIED.robot(base)
    for name, plan in plans.items():
        m = measures(identified, open_loop_series(identified, plan))
        ol = open_loop(identified, plan)
        rows.append([f"{name} plan, open loop, identified model", "plan's span", "1"]
                    + _measure_columns([m])[:4] + ["-", "-", "-"]
                    + [f"no catch: closest {ol.closest:.4f} m" if not ol.caught(radius)
                       else f"caught: closest {ol.closest:.4f} m"])
    if gait is not None:
        series = gait_brachiations(gait)
        ms = [measures(gait.robot, b, held=True) for b in series]
        for b, m in zip(series, ms):
            rows.append([f"{b.name} (model)", "catch->catch", "1"] + _measure_columns([m])
                        + [""])
        rows.append([f"{gait.name}: mean (model)", "catch->catch", str(len(ms))]
                    + _plain_mean_columns(ms) + [f"cycle {sum(m.duration for m in ms):.4f} s"])
    out += _table(("source", "span") + MEASURE_HEADER + ("",), rows)
    return out


def comparison(logs: Sequence[HardwareLog], *, trajectories: Sequence[str] = NOMINAL_TRAJECTORIES,
               base: Robot | None = None, gait: DesignedGait | None = None) -> str:
    """The comparison table of docs/acromonk.md, "Brachiations measured", as text; with
    ``gait``, the designed gait's brachiations in the side-by-side table."""
    base = base or acromonk_robot()
    out = ["Per log (mean±sd over its brachiations; torque as logged, the servo's estimate: at",
           f"the elbow the peak and the work are x{IDENTIFIED.torque_scale:.4f}, "
           f"int tau2 x{IDENTIFIED.torque_scale ** 2:.3f}; the catch: the free end's speed and",
           "its velocity onward along the ladder and down at the catch instant: the first catch",
           "row, or the last row of a log that ends with its trajectory):"]
    rows = []
    for log in logs:
        spans = (("release->catch", True), ("swing->catch", False)) if has_flag(log) else \
            (("swing->catch", False),)
        for span, with_release in spans:
            ms = [measures(base, b) for b in log_brachiations(log, with_release=with_release)]
            gaps = sum(m.gapped for m in ms)
            rows.append([log.name, span, str(len(ms))] + _measure_columns(ms)
                        + [f"{gaps} gapped" if gaps else ""])
    out += _table(("log", "span") + MEASURE_HEADER + ("",), rows)

    plans = {name: nominal_trajectory(name) for name in trajectories}
    out += ["", "Nominal trajectories (the plan's torque; catch: its last sample; free end from "
                "the held end):"]
    rows = []
    for name, plan in plans.items():
        m = measures(base, plan)
        rows.append([name, "1"] + _measure_columns([m])
                    + [f"{m.catch_position[0]:+.4f}", f"{m.catch_position[1]:+.4f}"])
    out += _table(("plan",) + MEASURE_HEADER + ("end_x_m", "end_y_m"), rows)

    th1, th2, q1, q2 = closed_chain(base)
    angles = reduce_urdf(ACROMONK_URDF, links=ACROMONK_LINKS, joints=ACROMONK_JOINTS,
                         far_grip=ACROMONK_FAR_GRIP).angles
    back = np.degrees(angles.urdf_angles(-th1, -th2))
    ends = {name: np.degrees(angles.urdf_angles(p.theta1[-1], p.theta2[-1]))
            for name, p in plans.items()}
    out += ["", f"Both hooks on bars {LADDER_DISTANCE} m apart: theta1 {th1:.4f}, theta2 {th2:.4f} "
                f"rad; URDF (q1, q2) ({math.degrees(q1):.1f}, {math.degrees(q2):.1f}) deg forward, "
                f"({back[0]:.1f}, {back[1]:.1f}) deg backward.",
            "The plans end at URDF (q1, q2) [deg]: " + ", ".join(
                f"{name} ({e[0]:.1f}, {e[1]:.1f})" for name, e in ends.items()) + "."]
    flagged = [catch_distances(base, log_brachiations(log)) for log in logs if has_flag(log)]
    radius = capture_radius(base, logs)
    low = float(np.min(np.concatenate(flagged)))
    out += ["", f"Capture rule: the free end within {radius:.4f} m of the target bar "
                f"({LADDER_DISTANCE} m ahead) in the last {APPROACH_WINDOW:.0%} of the plan: the",
            f"farthest of the flagged logs' catch rows from the bar ({low:.4f}-{radius:.4f} m over "
            f"{sum(d.size for d in flagged)} caught brachiations)."]
    robots = open_loop_models(base)
    rows, results = [], {}
    for name, plan in plans.items():
        for label, (model, scale) in OPEN_LOOP_RUNS.items():
            ol = open_loop(robots[model], plan, torque_scale=scale)
            results[name, label] = ol
            rows.append([name, label, f"{ol.final_miss:.4f}", f"{ol.closest:.4f}",
                         f"{ol.closest_time:.3f}", f"{ol.planned_closest:.4f}",
                         f"{ol.final_state[1]:+.3f}", f"{ol.planned_final_state[1]:+.3f}",
                         f"{ol.elbow_peak:.2f}", "yes" if ol.caught(radius) else "no"])
    out += ["", "Open loop from each plan's first state, its torque held centred on the samples:"]
    out += _table(("plan", "model", "end_miss_m", "closest_m", "at_s", "plan_closest_m",
                   "end_theta2", "plan_theta2", "max_abs_theta2", "caught"), rows)
    if "BF" in plans:
        out += ["", "Brachiations without the tracker (a chain BF, then FB or BF with the roles "
                    "swapped):"]
        for label in OPEN_LOOP_RUNS:
            ol = results["BF", label]
            if ol.caught(radius):
                out.append(f"  {label}: the first BF is caught (closest {ol.closest:.4f} m); "
                           "the chain needs a catch model")
            else:
                out.append(f"  {label}: 0 (the first BF misses: closest {ol.closest:.4f} m, "
                           f"{ol.final_miss:.4f} m from the plan's free end at its end)")
    out += side_by_side(logs, plans, base, gait, radius)
    return "\n".join(out)
