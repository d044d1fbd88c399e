"""The hybrid-simulation API: evaluate gaits and simulate controllers.

Thin wrappers that validate arguments, build the kernel's arrays, call the one compiled
:func:`~monkeystudy.kernel.hybrid.simulate`, and label what comes back. Drivers (grid, refine,
stability, ...) use :func:`evaluate_cycle_gaits` and :func:`run_controller`, which return plain
numpy; :func:`evaluate_gaits` is the horizontal gait's evaluation under its own names;
:func:`simulate` builds an :class:`xarray.Dataset` for people.

The kernel's plain numbers have names here (:class:`Status`, :data:`STATUS_NAMES`,
:class:`Phase`, :class:`StateIndex`, the properties of :class:`RunResult`), so that the layers
above read results without importing the kernel.
"""
from __future__ import annotations

import math
import sys
from dataclasses import dataclass
from enum import IntEnum
from typing import Union

import numpy as np
from numba.core.dispatcher import Dispatcher

from .controllers import (
    HorizontalSearch, Integrator, OpenLoop, PhaseSequence, SequenceGait, horizontal_gait,
    kernel_method, settings_vector,
)
from .kernel import dynamics
from .kernel import layout as L
from .kernel.dynamics import points8, potential_energy, total_energy8
from .kernel.gait import start_state
from .kernel.gait import (
    N_CYCLE_RESULT, Q_ERROR, Q_FINAL, Q_FLIPPED, Q_NFEV, Q_REJECTED, Q_STATUS, Q_STEPS, Q_T_END,
    cycle_gait_batch,
)
from .kernel.hybrid import hybrid_loops, simulate as _simulate
from .robot import SEED2009_TORQUE, Robot


class Status(IntEnum):
    """Outcome of a run (stored in datasets as CF ``flag_values``/``flag_meanings``)."""

    OK = L.ST_OK
    NO_SWITCH = L.ST_NO_SWITCH
    ENERGY_NOT_RESTORED = L.ST_ENERGY_NOT_RESTORED
    NO_RETURN_TO_VERTICAL = L.ST_NO_RETURN
    NON_FINITE = L.ST_NONFINITE
    UNREACHABLE = L.ST_UNREACHABLE
    STEP_FAILURE = L.ST_STEP_FAILURE
    BUFFER_FULL = L.ST_BUFFER_FULL
    END_TIME = L.ST_END_TIME
    HORIZON = L.ST_HORIZON
    FELL = L.ST_FELL

    @property
    def message(self) -> str:
        """What this outcome means, in a sentence."""
        return STATUS_MESSAGES[self]


STATUS_MESSAGES = {
    Status.OK: "the run ended as its controller intends",
    Status.NO_SWITCH: (
        "no swap: the free end never rose through the attached end's height within the "
        "integrator's max_time (a start on the grazing border, where the free end only touches "
        "that height, is one: the rising crossing the search controller waits for never "
        "comes)"),
    Status.ENERGY_NOT_RESTORED: ("the motor never restored the gait-start energy within the "
                                 "integrator's max_time"),
    Status.NO_RETURN_TO_VERTICAL: ("link 1 never returned to the vertical after the swap "
                                   "within the integrator's max_time"),
    Status.NON_FINITE: "the state became infinite or NaN",
    Status.UNREACHABLE: ("not integrated: the start's energy cannot lift the free end to the "
                         "attached end's height"),
    Status.STEP_FAILURE: "the integrator's step size underflowed or its step budget ran out",
    Status.BUFFER_FULL: "the event log or sample buffer was too small",
    Status.END_TIME: "ran to the end time",
    Status.HORIZON: "a segment reached its horizon before its guard fired",
    Status.FELL: "the attached end sank farther than the fall bound",
}

#: every status's name as datasets and reports write it (CF ``flag_meanings``), in code order:
#: ``STATUS_NAMES[code] == Status(code).name.lower()``
STATUS_NAMES = tuple(s.name.lower() for s in Status)


def status_name(code: int) -> str:
    """The name of a status code as datasets and reports write it.

    Parameters
    ----------
    code : int
        A :class:`Status` value (an ``int`` or a numpy integer read from a dataset).

    Returns
    -------
    str
        ``Status(code).name.lower()``, e.g. ``"no_switch"``.

    Raises
    ------
    ValueError
        If ``code`` is not a :class:`Status` value.
    """
    return Status(int(code)).name.lower()


class Phase(IntEnum):
    """Phase of motion of a hybrid state (:attr:`RunResult.sample_phase`; a dataset's
    ``phase``, whose ``flag_meanings`` are these names in lower case)."""

    SWING = L.PHASE_SWING     # one end attached: 2 degrees of freedom
    FLIGHT = L.PHASE_FLIGHT   # nothing attached: 4 degrees of freedom
    FIXED = L.PHASE_FIXED     # both ends attached: no motion


class StateIndex(IntEnum):
    """Index of each component of a frame state ``[x, y, theta1, theta2, x_dot, y_dot,
    theta1_dot, theta2_dot]`` (the first 8 values of a hybrid state, a row of
    :attr:`RunResult.sample_state`, :attr:`GaitResult.final_state`), named as
    :func:`simulate`'s variables: ``x``, ``y`` [m] of the attached end, ``theta1`` [rad] of
    link 1 from the downward vertical, ``theta2`` [rad] of link 2 relative to link 1, their
    rates [m s-1, rad s-1]."""

    X = L.X
    Y = L.Y
    THETA1 = L.TH1
    THETA2 = L.TH2
    X_DOT = L.DX
    Y_DOT = L.DY
    THETA1_DOT = L.DTH1
    THETA2_DOT = L.DTH2


RobotLike = Union[Robot, str]
Controller = Union[HorizontalSearch, OpenLoop, PhaseSequence]


def loaded_kernels() -> int:
    """How many compiled kernel signatures this process has loaded (compiled or read from
    the cache): a resident pool compares it before and after a warm-up to see whether its
    workers, forked earlier, lack a kernel."""
    count = sum(len(loop.overloads) for loop in hybrid_loops() if isinstance(loop, Dispatcher))
    for name, module in list(sys.modules.items()):
        if name.startswith(__package__ + ".kernel.") and module is not None:
            count += sum(len(obj.overloads) for obj in vars(module).values()
                         if isinstance(obj, Dispatcher))
    return count


def as_robot(robot: RobotLike) -> Robot:
    return Robot.preset(robot) if isinstance(robot, str) else robot


def _finite(name: str, value: float) -> float:
    value = float(value)
    if not math.isfinite(value):
        raise ValueError(f"{name} must be finite, got {value!r}")
    return value


@dataclass(frozen=True)
class GaitResult:
    """One horizontal-gait evaluation (docs/model.md section 4).

    ``error`` is NaN unless ``status`` is OK. Times [s]: ``t_switch`` the swap after the gait
    start, ``t_motor`` the motor-on duration, ``t_end`` the vertical crossing ending the gait.
    ``final_state`` is ``[x, y, th1, th2, dx, dy, dth1, dth2]`` in the frame after the swap.
    ``message`` says in a sentence why a gait without an error ended as it did.
    """

    dtheta1: float
    dtheta2: float
    error: float
    status: Status
    t_switch: float
    t_motor: float
    t_end: float
    steps: int
    nfev: int
    rejected: int
    final_state: np.ndarray

    @property
    def message(self) -> str:
        """``status`` in a sentence (:attr:`Status.message`)."""
        return self.status.message


def evaluate_gaits(points, *, robot: RobotLike = "seed2009", torque: float | None = None,
                   tick: float = 0.0, tick_phase: float = 0.0,
                   integrator: Integrator = Integrator(),
                   skip_unreachable: bool = True) -> dict[str, np.ndarray]:
    """Evaluate the horizontal gait at many ``(dtheta1, dtheta2)`` [rad s-1] points.

    One cycle of :func:`~monkeystudy.controllers.horizontal_gait` (motor ``torque`` [N m],
    default the 2009 study's; controller ``tick``, ``tick_phase`` [s]) by
    :func:`evaluate_cycle_gaits`. Returns plain arrays (``error``, ``status``, ``t_switch``,
    ``t_motor``, ``t_end``, ``steps``, ``nfev``, ``rejected``, ``final_state``), one entry
    per point; the times as :func:`swap_motor_times` names them. Serial and compiled:
    parallelism belongs to the caller (blocks of points on workers).
    """
    torque = SEED2009_TORQUE if torque is None else _finite("torque", torque)
    r = evaluate_cycle_gaits(points, horizontal_gait(torque, tick, tick_phase=tick_phase),
                             robot=robot, integrator=integrator,
                             skip_unreachable=skip_unreachable)
    return {"error": r["error"], "status": r["status"], **swap_motor_times(r["t_segment"]),
            "steps": r["steps"], "nfev": r["nfev"], "rejected": r["rejected"],
            "final_state": r["final_state"]}


def swap_motor_times(t_segment: np.ndarray) -> dict[str, np.ndarray]:
    """The horizontal gait's times [s] from its segment exit times ``t_segment[n, 3]``:
    ``t_switch`` (the swap), ``t_motor`` (how long the motor ran), ``t_end`` (the vertical
    crossing ending the gait); NaN where the cycle never got there."""
    t = np.asarray(t_segment, np.float64)
    return {"t_switch": t[:, 0].copy(), "t_motor": t[:, 1] - t[:, 0], "t_end": t[:, 2].copy()}


def evaluate_cycle_gaits(points, gait: SequenceGait, *, robot: RobotLike = "seed2009",
                         integrator: Integrator = Integrator(),
                         skip_unreachable: bool = True) -> dict[str, np.ndarray]:
    """One cycle of a phase-sequence gait at many ``(dtheta1, dtheta2)`` [rad s-1] starts.

    Each start is on the gait's section (``theta1 = gait.section_theta1``, ``theta2 =
    gait.theta2``, hanging from A at the origin). Returns plain arrays, one entry per point:
    ``error`` (the section error, :class:`~monkeystudy.controllers.SequenceGait`, wrapped or
    not as the gait says; NaN unless ok), ``status``, ``t_end`` (the section crossing ending
    the cycle, or the time the run failed) [s], ``t_segment[n, k]`` (exit time of segment
    ``k``, the section last; NaN if never left) [s], ``x_advance``, ``y_advance``
    (displacement of the attached end over the cycle) [m], ``steps``, ``nfev``, ``rejected``,
    ``flipped`` (1: hanging from B at the end) and ``final_state``.

    With ``skip_unreachable`` and a gait whose starts below the swap energy floor cannot
    reach its first guard (``gait.unreachable_below_floor``), such starts are not
    integrated: status ``unreachable``, no steps, every value NaN.
    """
    robot = as_robot(robot)
    pts = np.ascontiguousarray(points, dtype=np.float64).reshape(-1, 2)
    if not np.all(np.isfinite(pts)):
        raise ValueError("points must be finite (dtheta1, dtheta2) pairs")
    prog, obs = gait.program()
    settings = settings_vector(integrator, tick=gait.tick, tick_phase=gait.tick_phase,
                               max_cycles=1)
    out = np.empty((pts.shape[0], N_CYCLE_RESULT))
    seg = np.empty((pts.shape[0], prog.shape[0]))
    run = np.ones(pts.shape[0], bool)
    if skip_unreachable and gait.unreachable_below_floor:
        run = ~below_swap_floor(pts, gait, robot)
        out[~run] = np.nan
        out[~run, Q_STATUS] = L.ST_UNREACHABLE
        for col in (Q_STEPS, Q_NFEV, Q_REJECTED, Q_FLIPPED):
            out[~run, col] = 0.0
        seg[~run] = np.nan
    if run.all():
        cycle_gait_batch(kernel_method(settings, prog, L.PHASE_SWING), robot.params(), prog,
                         obs, settings, gait.section_theta1, gait.theta2, pts, out, seg)
    elif run.any():
        o, sg = out[run], seg[run]
        cycle_gait_batch(kernel_method(settings, prog, L.PHASE_SWING), robot.params(), prog,
                         obs, settings, gait.section_theta1, gait.theta2,
                         np.ascontiguousarray(pts[run]), o, sg)
        out[run], seg[run] = o, sg
    final = out[:, Q_FINAL:Q_FINAL + 8].copy()
    if not gait.wrap_theta2:
        # the kernel's error wraps theta2; this one is the difference as it is (the same
        # floating-point expression as the 2009 error, docs/model.md section 4)
        d = final[:, L.TH2] - gait.theta2
        err = d * d + (pts[:, 0] - final[:, L.DTH1]) ** 2 + (pts[:, 1] - final[:, L.DTH2]) ** 2
        out[:, Q_ERROR] = np.where(out[:, Q_STATUS] == L.ST_OK, err, np.nan)
    return {
        "error": out[:, Q_ERROR].copy(),
        "status": out[:, Q_STATUS].astype(np.int8),
        "t_end": out[:, Q_T_END].copy(),
        "t_segment": seg,
        "x_advance": final[:, L.X].copy(),
        "y_advance": final[:, L.Y].copy(),
        "steps": out[:, Q_STEPS].astype(np.int64),
        "nfev": out[:, Q_NFEV].astype(np.int64),
        "rejected": out[:, Q_REJECTED].astype(np.int64),
        "flipped": out[:, Q_FLIPPED].astype(np.int8),
        "final_state": final,
    }


def below_swap_floor(points, gait: SequenceGait, robot: Robot) -> np.ndarray:
    """Which ``(dtheta1, dtheta2)`` [rad s-1] starts on ``gait``'s section have less total
    energy than the robot's swap energy floor (:meth:`~monkeystudy.Robot.
    swap_energy_floor`, less a relative 1e-12 so a start on the floor is integrated): with
    no motor and no swap, such a swing never brings the free end to the attached end's
    height.

    Decided on the kernel's own energy (:func:`~monkeystudy.kernel.dynamics.total_energy8`),
    as the compiled horizontal-gait evaluation decides: a start on the section swings
    (``dx = dy = 0``), so its energy is a quadratic form in the rates plus a constant, which
    sorts every start far from the floor at once; the few within 1e-9 of it are evaluated
    one by one by the kernel.
    """
    pts = np.asarray(points, np.float64).reshape(-1, 2)
    floor = robot.swap_energy_floor()
    bound = floor - 1e-12 * (1.0 + abs(floor))
    par = robot.params()[0]
    state = np.zeros(8)
    state[L.TH1], state[L.TH2] = gait.section_theta1, gait.theta2

    def energy(w1: float, w2: float) -> float:
        state[L.DTH1], state[L.DTH2] = w1, w2
        return float(total_energy8(par, state))

    e0 = energy(0.0, 0.0)
    k1, k2 = energy(1.0, 0.0) - e0, energy(0.0, 1.0) - e0
    k12 = energy(1.0, 1.0) - e0 - k1 - k2
    w1, w2 = pts[:, 0], pts[:, 1]
    approx = e0 + k1 * w1 * w1 + k12 * w1 * w2 + k2 * w2 * w2
    below = approx < bound
    near = np.flatnonzero(np.abs(approx - bound) <= 1e-9 * (1.0 + abs(bound) + np.abs(approx)))
    for i in near:
        below[i] = energy(w1[i], w2[i]) < bound
    return below


def evaluate_horizontal_gait(dtheta1: float, dtheta2: float, **kwargs) -> GaitResult:
    """Evaluate the horizontal gait at one point; keywords as :func:`evaluate_gaits`."""
    d1 = _finite("dtheta1", dtheta1)
    d2 = _finite("dtheta2", dtheta2)
    r = evaluate_gaits([[d1, d2]], **kwargs)
    return GaitResult(d1, d2, float(r["error"][0]), Status(int(r["status"][0])),
                      float(r["t_switch"][0]), float(r["t_motor"][0]), float(r["t_end"][0]),
                      int(r["steps"][0]), int(r["nfev"][0]), int(r["rejected"][0]),
                      r["final_state"][0])


@dataclass
class RunResult:
    """Raw outcome of :func:`run_controller` (numpy only).

    The named properties read the raw arrays: the run's counts (:attr:`steps`, :attr:`nfev`,
    :attr:`rejected`, :attr:`cycles`) and each sample's mode (:attr:`sample_phase`,
    :attr:`sample_flipped`, :attr:`sample_torque`, :attr:`sample_segment`).
    """

    status: Status
    state: np.ndarray        # final hybrid state (layout H_*), feed back to continue
    counts: np.ndarray       # layout K_*
    segment_times: np.ndarray
    log: np.ndarray          # (n_events, N_LOG_COLS)
    sample_t: np.ndarray
    sample_state: np.ndarray
    sample_mode: np.ndarray
    params: np.ndarray       # (2, N_PARAMS) rows used

    @property
    def steps(self) -> int:
        """Accepted integration steps of the run."""
        return int(self.counts[L.K_STEPS])

    @property
    def nfev(self) -> int:
        """Evaluations of the equations of motion."""
        return int(self.counts[L.K_NFEV])

    @property
    def rejected(self) -> int:
        """Rejected integration steps."""
        return int(self.counts[L.K_REJECTED])

    @property
    def cycles(self) -> int:
        """Cycles the controller completed."""
        return int(self.counts[L.K_CYCLES])

    @property
    def sample_phase(self) -> np.ndarray:
        """Each sample's phase of motion (:class:`Phase` values, as floats; a view)."""
        return self.sample_mode[:, L.M_PHASE]

    @property
    def sample_flipped(self) -> np.ndarray:
        """Which end each sample's frame hangs from (0: A, 1: B; as floats; a view)."""
        return self.sample_mode[:, L.M_FLIPPED]

    @property
    def sample_torque(self) -> np.ndarray:
        """The motor torque [N m] at each sample, on theta2 of the frame (a view)."""
        return self.sample_mode[:, L.M_TORQUE]

    @property
    def sample_segment(self) -> np.ndarray:
        """The controller program row of each sample (as floats; a view)."""
        return self.sample_mode[:, L.M_SEGMENT]


def initial_state(dtheta1: float = 0.0, dtheta2: float = 0.0, *, theta1: float = 0.0,
                  theta2: float = 0.0, x: float = 0.0, y: float = 0.0) -> np.ndarray:
    """Hybrid state hanging from end A at ``(x, y)`` [m] with the given angles and rates."""
    hyb = np.empty(L.N_HYB)
    start_state(_finite("dtheta1", dtheta1), _finite("dtheta2", dtheta2), hyb)
    hyb[L.X], hyb[L.Y] = _finite("x", x), _finite("y", y)
    hyb[L.TH1], hyb[L.TH2] = _finite("theta1", theta1), _finite("theta2", theta2)
    return hyb


def run_controller(controller: Controller, state: np.ndarray, *,
                   robot: RobotLike = "seed2009", integrator: Integrator = Integrator(),
                   t_end: float = math.inf, cycles: int = 0, sample_dt: float = 0.0,
                   max_drop: float = math.inf, log_capacity: int = 4096) -> RunResult:
    """Run a controller from a hybrid state until it stops, ``t_end`` [s] or ``cycles``.

    ``sample_dt`` [s] > 0 records a trajectory from the dense output (it never changes the
    steps taken). Buffers grow and the run is repeated if they were too small.
    """
    robot = as_robot(robot)
    if sample_dt < 0 or not math.isfinite(sample_dt):
        raise ValueError(f"sample_dt must be finite and >= 0, got {sample_dt!r}")
    prog, obs = controller.program()
    if not (math.isfinite(t_end) or cycles > 0 or np.any(prog[:, L.S_NEXT] < 0)):
        raise ValueError("give t_end or cycles: this controller never stops by itself")
    settings = settings_vector(integrator, tick=controller.tick,
                               tick_phase=controller.tick_phase, t_end=t_end,
                               max_cycles=cycles, sample_dt=sample_dt, max_drop=max_drop)
    par = robot.params()
    state = np.asarray(state, dtype=np.float64)
    if state.shape != (L.N_HYB,):
        raise ValueError(f"state must be a hybrid state vector of length {L.N_HYB}")
    n_samp = 0
    if sample_dt > 0:
        horizon = t_end if math.isfinite(t_end) else max(cycles, 1) * 2.0 * integrator.max_time
        n_samp = int((horizon - state[L.H_T]) / sample_dt) + 64 + 8 * max(cycles, 1)
    while True:
        hyb = state.copy()
        counts = np.zeros(L.N_COUNTS, dtype=np.int64)
        seg_times = np.empty(prog.shape[0])
        log = np.empty((log_capacity, L.N_LOG_COLS))
        st = np.empty(n_samp)
        sy = np.empty((n_samp, 8))
        sm = np.empty((n_samp, L.N_MODE_COLS))
        status = _simulate(kernel_method(settings, prog, state[L.H_PHASE]), par, prog, obs,
                           settings, hyb, counts, seg_times, log, st, sy, sm)
        if status != L.ST_BUFFER_FULL:
            break
        if counts[L.K_LOG] >= log_capacity:
            log_capacity *= 4
        if sample_dt > 0 and counts[L.K_SAMPLES] >= n_samp:
            n_samp *= 2
    n_log = int(counts[L.K_LOG])
    ns = int(counts[L.K_SAMPLES])
    return RunResult(Status(status), hyb, counts, seg_times, log[:n_log].copy(), st[:ns].copy(),
                     sy[:ns].copy(), sm[:ns].copy(), par)


def physical_points(params: np.ndarray, states: np.ndarray, flipped: np.ndarray) -> dict:
    """World positions [m] of end A, the joint, end B and both CGs for frame states."""
    n = states.shape[0]
    pts = np.empty((n, 5, 2))
    buf = np.empty((5, 2))
    for i in range(n):
        points8(params[int(flipped[i])], states[i], buf)
        pts[i] = buf
    fl = flipped.astype(bool)
    a = np.where(fl[:, None], pts[:, 4], pts[:, 0])
    b = np.where(fl[:, None], pts[:, 0], pts[:, 4])
    cg1 = np.where(fl[:, None], pts[:, 3], pts[:, 1])   # CG of physical link 1 (carries A)
    cg2 = np.where(fl[:, None], pts[:, 1], pts[:, 3])
    return {"A": a, "joint": pts[:, 2], "B": b, "cg1": cg1, "cg2": cg2}


def gait_error(states, dtheta1: float, dtheta2: float) -> np.ndarray:
    """The study's repeatability error (docs/model.md section 4) of frame states at a vertical
    crossing: ``theta2^2 + (dtheta1 - dtheta1_f)^2 + (dtheta2 - dtheta2_f)^2``.

    ``states[..., 8]`` are ``[x, y, th1, th2, dx, dy, dth1, dth2]``; the one-cycle evaluation
    of a gait that does not wrap theta2 (:func:`evaluate_cycle_gaits`) computes the same
    expression.
    """
    s = np.asarray(states, dtype=np.float64)
    return s[..., L.TH2] ** 2 + (dtheta1 - s[..., L.DTH1]) ** 2 + (dtheta2 - s[..., L.DTH2]) ** 2


def energies(params: np.ndarray, states: np.ndarray, flipped: np.ndarray):
    """Kinetic and potential energy [J] of frame states (world frame)."""
    k = np.empty(states.shape[0])
    v = np.empty(states.shape[0])
    for i, s in enumerate(states):
        p = params[int(flipped[i])]
        k[i] = dynamics.kinetic_energy(p, s[2], s[3], s[4], s[5], s[6], s[7])
        v[i] = potential_energy(p, s[1], s[2], s[3])
    return k, v


def kinetic_energy(robot: RobotLike, state, *, flipped: bool = False) -> float:
    """Kinetic energy [J] of one frame state, as the kernel computes it.

    Parameters
    ----------
    robot : Robot or str
        The robot, or the name of a preset.
    state : array_like
        The frame state ``[x, y, theta1, theta2, x_dot, y_dot, theta1_dot, theta2_dot]``
        (:class:`StateIndex`) [m, rad, m s-1, rad s-1].
    flipped : bool
        Whether the frame hangs from end B (the robot's parameters flipped).

    Returns
    -------
    float
        The kinetic energy [J].
    """
    p = as_robot(robot).params()[int(flipped)]
    s = np.asarray(state, np.float64)
    return float(dynamics.kinetic_energy(p, s[2], s[3], s[4], s[5], s[6], s[7]))


#: the hybrid state's components as dataset variables: (name, index, units, what)
STATE_VARIABLES = (
    ("x", L.X, "m", "x of the attached end"), ("y", L.Y, "m", "y of the attached end"),
    ("theta1", L.TH1, "rad", "link 1's angle from the downward vertical"),
    ("theta2", L.TH2, "rad", "link 2's angle relative to link 1"),
    ("x_dot", L.DX, "m s-1", "rate of x of the attached end (0 unless flying)"),
    ("y_dot", L.DY, "m s-1", "rate of y of the attached end (0 unless flying)"),
    ("theta1_dot", L.DTH1, "rad s-1", "rate of link 1's angle"),
    ("theta2_dot", L.DTH2, "rad s-1", "rate of link 2's relative angle"),
)


def simulate(controller: Controller, *, robot: RobotLike = "seed2009",
             dtheta1: float = 0.0, dtheta2: float = 0.0, state: np.ndarray | None = None,
             t_end: float = math.inf, cycles: int = 0, sample_dt: float = 1e-3,
             integrator: Integrator = Integrator(), max_drop: float = math.inf):
    """Simulate a controller and return its trajectory as an :class:`xarray.Dataset`.

    Samples every ``sample_dt`` [s] on the dense output plus the states just before and after
    every controller transition (so ``time`` may repeat at an impact: it is a coordinate on
    dim ``sample``, not an index). Every variable carries ``units`` and ``long_name``:

    * on dim ``sample``: the state in the frame of the attached end, ``x``, ``y`` [m],
      ``theta1``, ``theta2`` [rad], ``x_dot``, ``y_dot`` [m s-1], ``theta1_dot``,
      ``theta2_dot`` [rad s-1]; ``attached_end`` (0: A, 1: B), ``phase`` (swing, flight,
      fixed), ``segment`` (controller program row), ``motor_torque`` [N m],
      ``kinetic_energy``, ``potential_energy``, ``total_energy`` [J]; world positions of
      ``A``, ``joint``, ``B`` (dims ``sample``, ``xy``) [m];
    * on dim ``event`` (the run's event log): ``event_time`` [s], ``event_kind``,
      ``event_id``, the state after the event as ``event_x`` ... ``event_theta2_dot``,
      ``event_attached_end``, ``event_energy_before``, ``event_energy_after`` [J].

    Attributes: the robot, controller, status, step counts, integrator settings, tick, cycles.
    """
    import xarray as xr  # xarray at the edge only: it loads in ~0.5 s

    robot = as_robot(robot)
    if not sample_dt > 0:
        raise ValueError(f"sample_dt must be > 0, got {sample_dt!r}")
    hyb0 = initial_state(dtheta1, dtheta2) if state is None else np.asarray(state, float)
    res = run_controller(controller, hyb0, robot=robot, integrator=integrator, t_end=t_end,
                         cycles=cycles, sample_dt=sample_dt, max_drop=max_drop)
    flipped = res.sample_mode[:, L.M_FLIPPED]
    pts = physical_points(res.params, res.sample_state, flipped)
    ke, pe = energies(res.params, res.sample_state, flipped)
    log = res.log
    end = {"units": "1", "flag_values": np.array([0, 1], np.int8), "flag_meanings": "A B"}
    data = {
        name: ("sample", res.sample_state[:, i], {"long_name": what + " (frame of the "
                                                  "attached end)", "units": units})
        for name, i, units, what in STATE_VARIABLES}
    data.update({
        "attached_end": ("sample", flipped.astype(np.int8),
                         dict(end, long_name="the end the frame hangs from")),
        "phase": ("sample", res.sample_mode[:, L.M_PHASE].astype(np.int8),
                  {"long_name": "phase of motion", "units": "1",
                   "flag_values": np.array([0, 1, 2], np.int8),
                   "flag_meanings": "swing flight fixed"}),
        "segment": ("sample", res.sample_mode[:, L.M_SEGMENT].astype(np.int16),
                    {"long_name": "controller program row", "units": "1"}),
        "motor_torque": ("sample", res.sample_mode[:, L.M_TORQUE],
                         {"long_name": "motor torque on theta2 of the frame", "units": "N m"}),
        "kinetic_energy": ("sample", ke, {"long_name": "kinetic energy", "units": "J"}),
        "potential_energy": ("sample", pe, {"long_name": "potential energy (world frame)",
                                            "units": "J"}),
        "total_energy": ("sample", ke + pe, {"long_name": "total energy", "units": "J"}),
        "A": (("sample", "xy"), pts["A"], {"long_name": "world position of end A",
                                           "units": "m"}),
        "joint": (("sample", "xy"), pts["joint"], {"long_name": "world position of the joint",
                                                   "units": "m"}),
        "B": (("sample", "xy"), pts["B"], {"long_name": "world position of end B",
                                           "units": "m"}),
        "event_time": ("event", log[:, L.L_T], {"long_name": "time of the event",
                                                "units": "s"}),
        "event_kind": ("event", log[:, L.L_KIND].astype(np.int8),
                       {"long_name": "kind of the event", "units": "1",
                        "flag_values": np.array([0, 1, 2], np.int8),
                        "flag_meanings": "segment_exit observer friction"}),
        "event_id": ("event", log[:, L.L_ID].astype(np.int16),
                     {"long_name": "the segment row, observer or friction DOF of the event",
                      "units": "1"}),
        "event_attached_end": ("event", log[:, L.L_FLIPPED].astype(np.int8),
                               dict(end, long_name="the end the frame hangs from after the "
                                                   "event")),
        "event_energy_before": ("event", log[:, L.L_E_BEFORE],
                                {"long_name": "total energy just before the event",
                                 "units": "J"}),
        "event_energy_after": ("event", log[:, L.L_E_AFTER],
                               {"long_name": "total energy just after the event",
                                "units": "J"}),
    })
    data.update({
        f"event_{name}": ("event", log[:, L.L_STATE + i],
                          {"long_name": what + " after the event", "units": units})
        for name, i, units, what in STATE_VARIABLES})
    ds = xr.Dataset(
        data,
        coords={"time": ("sample", res.sample_t, {"long_name": "time", "units": "s"}),
                "xy": ("xy", ["x", "y"], {"long_name": "world axis", "units": "1"})},
        attrs={"robot": robot.name, "controller": type(controller).__name__,
               "status": Status(res.status).name.lower(), "steps": int(res.counts[L.K_STEPS]),
               "nfev": int(res.counts[L.K_NFEV]), "rejected": int(res.counts[L.K_REJECTED]),
               "method": integrator.method, "rtol": integrator.rtol, "atol": integrator.atol,
               "tick": controller.tick, "cycles": int(res.counts[L.K_CYCLES])},
    )
    return ds
