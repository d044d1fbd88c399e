"""AcroMonk's measured swings replayed through the model, and its friction identified.

A swing of a hardware log (:mod:`monkeystudy.measured`) is put in the model's frame
(:func:`model_swing`), replayed from a measured state with the measured elbow torque as the
input (:func:`replay`, one run of the compiled simulator: a program of time segments, one
constant torque each), scored over many starts at fixed horizons (:func:`horizon_errors`) and
over whole swings (:func:`whole_swing_error`), and used to identify the joints' friction by
multiple shooting (:func:`identify`, ``scipy.optimize.least_squares``). docs/acromonk.md,
"Replayed against the model", gives the choices, the evidence and the numbers.

**The frame.** The log's shoulder angle is ``q1`` of the holding link and ``q2 = s e``, the
torque ``u = s tau`` (``s`` the elbow sign of the holding hook, :func:`~monkeystudy.measured.
swing_state`). The URDF's link 1 (``hook_1``, the motor arm) carries end A: a swing from the
motor arm runs in parameter row 0, a swing from the IMU arm in row 1 (the robot hanging from
end B; the flipped frame's ``theta1`` is the holding link's angle, its ``theta2`` the lab's
``q2``). ``theta1 = q1 + shoulder_offset`` with ``shoulder_offset = 0`` by default: the logged
shoulder is the angle of the line from the hook to the elbow (at every catch it sits on the
closed chain of two equal links within 0.01 rad at the log's start), not the URDF's hook-frame
angle, which is 0.0636 rad off that line (``reduce_urdf(...).angles``).

**The torque's hold.** Sample ``k``'s torque is held from midway to the previous sample to
midway to the next (a centred zero-order hold, ``hold="centred"``): it has no half-sample
delay. ``hold="plain"`` holds it from its own sample to the next.

**The start.** A replay starts from the logged angles and the logged rates (the IMU's gyro and
the servo's velocity): integrated, they follow the logged angles to 0.01-0.04 rad over a
swing, while a difference quotient of the IMU's fused angle departs from the gyro by
0.24-0.78 rad/s RMS (:func:`rate_agreement`).

**The checks** (``python tools/acromonk_replay.py --checks``): :func:`chain_closure`,
:func:`torque_sign_errors`, :func:`rate_agreement`, :func:`rest_shoulder` and the inverse
dynamics of the measured swings (:func:`inverse_dynamics`, with the accelerations from a
difference quotient or from :func:`local_quadratic`; :func:`rate_noise` and
:func:`simulated_swing` calibrate what the rates' noise makes of them).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Sequence

import numpy as np

from ..controllers import Integrator, PhaseSequence, Segment
from ..kernel import layout as L
from ..kernel.dynamics import swing_matrices, total_energy8
from ..measured import CATCH, MOTOR_ARM, HardwareLog, Swing, swing_state, swings, swings_by_flag
from ..robot import Friction, Robot, Rotor
from ..simulation import Status, initial_state, physical_points, run_controller
from ..urdf import reduce_urdf

#: AcroMonk's URDF in a source checkout (data/acromonk/model)
ACROMONK_URDF = Path(__file__).resolve().parents[3] / "data" / "acromonk" / "model" / \
    "acromonk.urdf"
#: the URDF's links, joints and far grip as the planar reduction takes them (docs/model.md)
ACROMONK_LINKS = ("hook_1", "link_2")
ACROMONK_JOINTS = ("virtul_joint_hook_1", "joint_1")
ACROMONK_FAR_GRIP = "hook_2"
#: AcroMonk's elbow servo (data/acromonk/hardware/testbench-description.md: an mjbots qdd100,
#: a 6:1 planetary gear) with its housing on the motor arm, link 1: the rotor's geometry,
#: its inertia left to be identified (zero here)
ACROMONK_ROTOR = Rotor(inertia=0.0, gear_ratio=6.0, housing=1)
#: AcroMonk's MuJoCo model (data/acromonk/model/acromonk_mujoco.xml): joint damping [N m s]
#: at the bar (the pivot) and at the elbow (the joint), viscous only
PUBLISHED_PIVOT = Friction(viscous=0.044)
PUBLISHED_JOINT = Friction(viscous=0.06)
#: the horizons of the many-starts error [s]
HORIZONS = (0.1, 0.2, 0.5)
#: replay integrator: its error (~1e-8 rad) is far below the sensors' floor (~1e-3 rad)
REPLAY_INTEGRATOR = Integrator(rtol=1e-8, atol=1e-10)
HOLDS = ("centred", "plain")
#: a replay scored at horizon h runs to h + this [s] (longer than any sample interval in a swing)
HORIZON_MARGIN = 0.05


def acromonk_robot(pivot: Friction | None = None, joint: Friction | None = None,
                   urdf: Path | str = ACROMONK_URDF) -> Robot:
    """AcroMonk's planar robot from its URDF (:meth:`Robot.from_urdf`), with the given
    friction at the pivot (the holding hook on its bar) and the joint (the elbow); zero
    unless given; its elbow servo's rotor geometry (:data:`ACROMONK_ROTOR`, zero inertia)."""
    return Robot.from_urdf(urdf, links=ACROMONK_LINKS, joints=ACROMONK_JOINTS,
                           far_grip=ACROMONK_FAR_GRIP, pivot_friction=pivot,
                           joint_friction=joint, name="acromonk").with_rotor(ACROMONK_ROTOR)


@dataclass(frozen=True)
class ModelSwing:
    """One measured swing in the model's frame.

    Attributes
    ----------
    time : ndarray
        Sample times from the swing's first row [s].
    theta1, theta2 : ndarray
        The holding link's angle from the downward vertical and the swing link's angle
        relative to it [rad] (the frame of the attached end).
    theta1_rate, theta2_rate : ndarray
        Their measured rates [rad s-1].
    torque : ndarray
        The measured elbow torque on ``theta2`` of the frame [N m].
    flipped : int
        The parameter row: 0 the robot hangs from end A (the motor arm, URDF ``hook_1``),
        1 from end B (the IMU arm).
    name : str
        ``<log>#<swing number from 1>``.
    """

    time: np.ndarray
    theta1: np.ndarray
    theta2: np.ndarray
    theta1_rate: np.ndarray
    theta2_rate: np.ndarray
    torque: np.ndarray
    flipped: int
    name: str

    def __len__(self) -> int:
        return int(self.time.size)

    @property
    def angles(self) -> np.ndarray:
        """(n, 2) rows [theta1, theta2] [rad]."""
        return np.column_stack([self.theta1, self.theta2])

    @property
    def duration(self) -> float:
        """Time from the first to the last sample [s]."""
        return float(self.time[-1] - self.time[0])


def model_swing(log: HardwareLog, swing: Swing, *, shoulder_offset: float = 0.0,
                name: str | None = None) -> ModelSwing:
    """A log's swing in the model's frame (see the module docstring).

    Parameters
    ----------
    log, swing
        The log and one of its swings (:func:`monkeystudy.measured.swings`).
    shoulder_offset : float
        Added to the logged shoulder angle to give ``theta1`` [rad].
    name : str, optional
        The swing's label (default ``<log>#?``).
    """
    st = swing_state(log, swing)
    return ModelSwing(time=st.time, theta1=st.q1 + float(shoulder_offset), theta2=st.q2,
                      theta1_rate=st.q1_rate, theta2_rate=st.q2_rate, torque=st.torque,
                      flipped=0 if st.hook == MOTOR_ARM else 1,
                      name=name or f"{log.name}#?")


def model_swings(log: HardwareLog, *, shoulder_offset: float = 0.0) -> list[ModelSwing]:
    """Every swing of a log in the model's frame (:func:`model_swing`), named
    ``<log>#1``, ``<log>#2``, ..."""
    return [model_swing(log, s, shoulder_offset=shoulder_offset, name=f"{log.name}#{k}")
            for k, s in enumerate(swings(log), start=1)]


def with_shoulder_offset(ms: ModelSwing, offset: float) -> ModelSwing:
    """The same swing with ``offset`` [rad] added to ``theta1``."""
    return replace(ms, theta1=ms.theta1 + float(offset))


# --- the torque's hold --------------------------------------------------------------------------
def held_torque(times: np.ndarray, torques: np.ndarray, hold: str = "centred"):
    """The piecewise-constant torque a hold makes of samples.

    Parameters
    ----------
    times : ndarray
        Sample times [s], non-decreasing, from the replay's start (``times[0] = 0``).
    torques : ndarray
        The torque at each sample [N m].
    hold : str
        ``centred``: sample k's torque from midway to sample k-1 to midway to sample k+1 (the
        first from ``times[0]``); ``plain``: from sample k to sample k+1.

    Returns
    -------
    ends : ndarray
        The end of each constant piece [s] (the last is ``times[-1]``), increasing.
    values : ndarray
        The torque of each piece [N m].
    """
    t = np.asarray(times, float)
    u = np.asarray(torques, float)
    if hold not in HOLDS:
        raise ValueError(f"hold must be one of {HOLDS}, got {hold!r}")
    if t.size < 2:
        raise ValueError("a hold needs at least two samples")
    if hold == "centred":
        ends = np.r_[0.5 * (t[:-1] + t[1:]), t[-1]]
        values = u.copy()
    else:
        ends, values = t[1:].copy(), u[:-1].copy()
    keep = np.r_[np.diff(ends) > 0, True] & (ends > t[0])   # a repeated time stamp: no piece
    return ends[keep], values[keep]


# --- one replay ---------------------------------------------------------------------------------
@dataclass(frozen=True)
class Replay:
    """A replay from sample ``start`` of a swing: at each later sample within the horizon,
    its time after the start [s], the simulated and the measured angles (n, 2) [rad], and the
    simulated rates (n, 2) [rad s-1]."""

    time: np.ndarray
    simulated: np.ndarray
    measured: np.ndarray
    simulated_rates: np.ndarray

    @property
    def error(self) -> np.ndarray:
        """(n, 2) simulated less measured angles [rad]."""
        return self.simulated - self.measured


def replay(robot: Robot, ms: ModelSwing, start: int, horizon: float, *,
           hold: str = "centred", torque_scale: float = 1.0,
           integrator: Integrator = REPLAY_INTEGRATOR) -> Replay:
    """Replay a measured swing from sample ``start`` for ``horizon`` [s] (to the swing's end
    at most) with the measured torque, held as ``hold`` says (:func:`held_torque`), times
    ``torque_scale``, as the input.

    The simulator runs one program of time segments: one per constant piece of the torque,
    split at every sample time so that the state there is the segment exit's, exact.
    """
    if not 0 <= start < len(ms) - 1:
        raise ValueError(f"{ms.name}: start {start} outside 0..{len(ms) - 2}")
    t = ms.time[start:] - ms.time[start]
    n = int(np.searchsorted(t, horizon * (1 + 1e-12), side="right"))
    t, u = t[:n], torque_scale * ms.torque[start:start + n]
    ends, values = held_torque(t, u, hold)
    samples = np.unique(t[1:][t[1:] > 0])
    cuts = np.union1d(ends, samples)
    piece = np.minimum(np.searchsorted(ends, cuts, side="left"), ends.size - 1)
    segs = [Segment("time", value=float(c), torque=float(values[k]), ticked=False)
            for c, k in zip(cuts, piece)]
    segs[-1] = replace(segs[-1], next=-1)
    hyb = initial_state(ms.theta1_rate[start], ms.theta2_rate[start],
                        theta1=ms.theta1[start], theta2=ms.theta2[start])
    hyb[L.H_FLIPPED] = ms.flipped
    res = run_controller(PhaseSequence(segs, observers=()), hyb, robot=robot,
                         integrator=integrator, log_capacity=2 * len(segs) + 16)
    if res.status != Status.OK:
        raise RuntimeError(f"{ms.name}: replay from sample {start} ended "
                           f"{res.status.name.lower()}: {res.status.message}")
    ev = res.log[res.log[:, L.L_KIND] == 0]
    at = np.searchsorted(ev[:, L.L_T], samples - 1e-12)
    state = ev[at][:, L.L_STATE:L.L_STATE + 8]
    rows = start + np.searchsorted(t, samples)
    return Replay(time=samples, simulated=state[:, [L.TH1, L.TH2]], measured=ms.angles[rows],
                  simulated_rates=state[:, [L.DTH1, L.DTH2]])


# --- errors over many starts ----------------------------------------------------------------
@dataclass(frozen=True)
class HorizonErrors:
    """Angle errors of replays from many starts of many swings.

    ``errors[h]`` is an (n_starts, 2) array of the simulated less measured [theta1, theta2]
    [rad] at the first sample at or after ``h`` [s] past each start (starts whose swing ends
    before that are left out); ``swing`` names each start's swing, ``start_time`` its time in
    the swing [s].
    """

    horizons: tuple[float, ...]
    errors: dict
    swing: dict
    start_time: dict

    def rms(self, h: float) -> np.ndarray:
        """RMS error per joint at horizon ``h`` [rad]."""
        return np.sqrt(np.mean(np.square(self.errors[h]), axis=0))

    def median_abs(self, h: float) -> np.ndarray:
        """Median absolute error per joint at horizon ``h`` [rad]."""
        return np.median(np.abs(self.errors[h]), axis=0)

    def count(self, h: float) -> int:
        """Starts scored at horizon ``h``."""
        return int(self.errors[h].shape[0])


def start_rows(ms: ModelSwing, every: float, horizon: float = 0.0) -> np.ndarray:
    """The sample at or after each multiple of ``every`` [s] from the swing's start whose
    time plus ``horizon`` [s] is within the swing."""
    times = np.arange(0.0, ms.duration - horizon + 1e-12, every)
    rows = np.unique(np.searchsorted(ms.time - ms.time[0], times - 1e-12))
    return rows[rows < len(ms) - 1]


def horizon_errors(robot: Robot, swings_: Sequence[ModelSwing], *,
                   horizons: Sequence[float] = HORIZONS, every: float = 0.1,
                   hold: str = "centred", torque_scale: float = 1.0) -> HorizonErrors:
    """Replay every swing from a start every ``every`` [s] for the longest horizon and score
    each start at every horizon it reaches (:class:`HorizonErrors`)."""
    hs = tuple(float(h) for h in horizons)
    err = {h: [] for h in hs}
    names = {h: [] for h in hs}
    starts = {h: [] for h in hs}
    for ms in swings_:
        for row in start_rows(ms, every, min(hs)):
            # past the longest horizon by more than a sample interval (<= 21 ms in a swing),
            # so that the first sample at or after it is in the replay
            rep = replay(robot, ms, int(row), max(hs) + HORIZON_MARGIN, hold=hold,
                         torque_scale=torque_scale)
            t0 = float(ms.time[row] - ms.time[0])
            for h in hs:
                k = int(np.searchsorted(rep.time, h - 1e-9))
                if k >= rep.time.size:
                    continue
                err[h].append(rep.error[k])
                names[h].append(ms.name)
                starts[h].append(t0)
    return HorizonErrors(hs, {h: np.array(err[h]).reshape(-1, 2) for h in hs},
                         {h: np.array(names[h]) for h in hs},
                         {h: np.array(starts[h]) for h in hs})


def whole_swing_error(robot: Robot, ms: ModelSwing, *, hold: str = "centred",
                      torque_scale: float = 1.0) -> np.ndarray:
    """RMS over a whole swing [rad] of the error of one replay from its first sample to its
    last, per joint [theta1, theta2]."""
    rep = replay(robot, ms, 0, ms.duration + 1.0, hold=hold, torque_scale=torque_scale)
    return np.sqrt(np.mean(np.square(rep.error), axis=0))


# --- identification ---------------------------------------------------------------------------
#: the parameters :func:`identify` can fit: name -> (units, lower bound, upper bound, start,
#: scale: the size of a change the fit resolves, which sets its difference step)
PARAMETERS = {
    "pivot_viscous": ("N m s", 0.0, 1.0, 0.02, 1.0),
    "pivot_coulomb": ("N m", 0.0, 1.0, 0.02, 1.0),
    "joint_viscous": ("N m s", 0.0, 1.0, 0.02, 1.0),
    "joint_coulomb": ("N m", 0.0, 1.0, 0.02, 1.0),
    "shoulder_offset": ("rad", -0.2, 0.2, 0.0, 1.0),
    "torque_scale": ("1", 0.2, 2.0, 1.0, 1.0),
    # the elbow servo's rotor inertia about its axis (reflected to the elbow: 36 times it)
    "rotor_inertia": ("kg m2", 0.0, 1e-3, 0.0, 1e-4),
}
FRICTION = ("pivot_viscous", "pivot_coulomb", "joint_viscous", "joint_coulomb")


@dataclass(frozen=True)
class ModelValues:
    """A model's values beyond the URDF: friction at the pivot and the joint, an offset added
    to the logged shoulder angle [rad], a scale on the measured torque [1] and the elbow
    servo's rotor inertia [kg m^2] (None: the base robot's; a value replaces the inertia of
    the base robot's rotor, whose gear ratio and housing stay)."""

    pivot: Friction = Friction()
    joint: Friction = Friction()
    shoulder_offset: float = 0.0
    torque_scale: float = 1.0
    rotor_inertia: float | None = None

    @classmethod
    def from_vector(cls, names: Sequence[str], x, base: "ModelValues | None" = None):
        """The values with the named parameters (:data:`PARAMETERS`) set from ``x``."""
        v = dict(zip(names, (float(a) for a in x)))
        b = base or cls()
        return cls(Friction(v.get("pivot_viscous", b.pivot.viscous),
                            v.get("pivot_coulomb", b.pivot.coulomb)),
                   Friction(v.get("joint_viscous", b.joint.viscous),
                            v.get("joint_coulomb", b.joint.coulomb)),
                   v.get("shoulder_offset", b.shoulder_offset),
                   v.get("torque_scale", b.torque_scale),
                   v.get("rotor_inertia", b.rotor_inertia))

    def robot(self, base: Robot) -> Robot:
        """``base`` with this friction and rotor inertia."""
        robot = base.with_friction(self.pivot, self.joint)
        if self.rotor_inertia is None:
            return robot
        return robot.with_rotor(replace(base.rotor, inertia=self.rotor_inertia))

    def swings(self, swings_: Sequence[ModelSwing]) -> list[ModelSwing]:
        """The swings with this shoulder offset added."""
        if self.shoulder_offset == 0.0:
            return list(swings_)
        return [with_shoulder_offset(ms, self.shoulder_offset) for ms in swings_]


def errors_of(values: ModelValues, base: Robot, swings_: Sequence[ModelSwing],
              **kwargs) -> HorizonErrors:
    """:func:`horizon_errors` of a model (its friction, shoulder offset and torque scale)."""
    return horizon_errors(values.robot(base), values.swings(swings_),
                          torque_scale=values.torque_scale, **kwargs)


@dataclass(frozen=True)
class Identification:
    """The result of :func:`identify`.

    Attributes
    ----------
    names : tuple of str
        The fitted parameters (:data:`PARAMETERS`).
    values : ndarray
        Their fitted values.
    ci95 : ndarray
        (p, 2) 95 % intervals from the swing-clustered sandwich covariance (the windows of
        one swing share its errors: the scores are summed per swing before their outer
        product, scaled by G/(G-1), with Student's t on G-1 degrees of freedom, G swings).
    ci95_iid : ndarray
        (p, 2) the intervals as if every residual were independent (for comparison: too
        narrow).
    covariance : ndarray
        (p, p) the clustered covariance.
    model : ModelValues
        The fitted model.
    rms : float
        RMS residual over every window sample and joint at the fit [rad].
    windows, residuals, swings : int
        Windows, residual values and swings (clusters) used.
    nfev : int
        Residual evaluations of ``least_squares``.
    """

    names: tuple
    values: np.ndarray
    ci95: np.ndarray
    ci95_iid: np.ndarray
    covariance: np.ndarray
    model: ModelValues
    rms: float
    windows: int
    residuals: int
    swings: int
    nfev: int

    def table(self) -> str:
        """One line per parameter: value, clustered and independent-residual intervals."""
        out = []
        for k, n in enumerate(self.names):
            lo, hi = self.ci95[k]
            ilo, ihi = self.ci95_iid[k]
            f = ".4f" if PARAMETERS[n][4] >= 1e-2 else ".3e"
            out.append(f"{n:<16} {self.values[k]:9{f}} {PARAMETERS[n][0]:<6} 95 % "
                       f"[{lo:8{f}}, {hi:8{f}}] (swing-clustered)  [{ilo:8{f}}, {ihi:8{f}}] "
                       f"(windows independent)")
        return "\n".join(out)


def shooting_windows(swings_: Sequence[ModelSwing], window: float, every: float):
    """(swing index, start row) of every window of ``window`` [s] starting every ``every``
    [s] that fits in its swing."""
    return [(i, int(r)) for i, ms in enumerate(swings_)
            for r in start_rows(ms, every, window)]


def identify_evaluations(max_nfev: int, n_parameters: int) -> int:
    """The most residual evaluations :func:`identify` makes (each a replay of every
    window): ``least_squares`` evaluates at most ``max_nfev`` points (its ``nfev``) and
    after each at most one forward-difference Jacobian of ``n_parameters`` more (which its
    ``nfev`` does not count), then :func:`identify` evaluates the fit once more."""
    return int(max_nfev) * (1 + int(n_parameters)) + 1


def identify(base: Robot, swings_: Sequence[ModelSwing], *, names: Sequence[str] = FRICTION,
             fixed: ModelValues = ModelValues(), window: float = 0.3, every: float = 0.1,
             hold: str = "centred", x0=None, max_nfev: int = 60,
             evaluated: Callable[[int], None] | None = None) -> Identification:
    """Fit the named parameters (:data:`PARAMETERS`) by least squares over multiple-shooting
    windows of the swings: each window is replayed from its measured start state for
    ``window`` [s] and every later sample's angle error of both joints is a residual [rad].

    ``fixed`` gives the parameters not fitted. The fit is
    ``scipy.optimize.least_squares`` (trust-region reflective, bounds from
    :data:`PARAMETERS`, a forward-difference Jacobian with steps of 1e-3 of each
    parameter's scale times ``max(1, |x|)``: far above the replay's integration error; the
    parameters scaled by those scales). ``evaluated(1)`` after each residual evaluation (at
    most :func:`identify_evaluations`), for a count of the fit as it goes.
    """
    # scipy only where a fit runs: importing the replay stays light
    from scipy.optimize import least_squares
    from scipy.stats import t as student_t

    names = tuple(names)
    for n in names:
        if n not in PARAMETERS:
            raise ValueError(f"unknown parameter {n!r}; known: {sorted(PARAMETERS)}")
    wins = shooting_windows(swings_, window, every)
    if not wins:
        raise ValueError(f"no window of {window} s fits in the swings")
    lo = np.array([PARAMETERS[n][1] for n in names])
    hi = np.array([PARAMETERS[n][2] for n in names])
    start = np.array([PARAMETERS[n][3] for n in names]) if x0 is None else np.asarray(x0, float)
    scale = np.array([PARAMETERS[n][4] for n in names])
    groups: list[int] = []

    def residuals(x):
        mv = ModelValues.from_vector(names, x, fixed)
        robot = mv.robot(base)
        sws = mv.swings(swings_)
        out = []
        groups.clear()
        for i, row in wins:
            rep = replay(robot, sws[i], row, window, hold=hold, torque_scale=mv.torque_scale)
            out.append(rep.error.ravel())
            groups.extend([i] * rep.error.size)
        if evaluated is not None:
            evaluated(1)
        return np.concatenate(out)

    fit = least_squares(residuals, np.clip(start, lo, hi), bounds=(lo, hi),
                        diff_step=1e-3 * scale, x_scale=scale, max_nfev=max_nfev, method="trf")
    r = residuals(fit.x)
    J = fit.jac
    g = np.array(groups)
    bread = np.linalg.pinv(J.T @ J)
    clusters = np.unique(g)
    meat = np.zeros((len(names), len(names)))
    for c in clusters:
        s = J[g == c].T @ r[g == c]
        meat += np.outer(s, s)
    G = clusters.size
    cov = bread @ meat @ bread * (G / max(G - 1, 1))
    q = float(student_t.ppf(0.975, max(G - 1, 1)))
    half = q * np.sqrt(np.clip(np.diag(cov), 0.0, None))
    sigma2 = float(r @ r) / max(r.size - len(names), 1)
    half_iid = 1.96 * np.sqrt(np.clip(np.diag(bread) * sigma2, 0.0, None))
    x = fit.x
    # an interval is cut at the parameter's bound (a friction is >= 0)
    return Identification(names=names, values=x.copy(),
                          ci95=np.clip(np.column_stack([x - half, x + half]), lo[:, None],
                                       hi[:, None]),
                          ci95_iid=np.clip(np.column_stack([x - half_iid, x + half_iid]),
                                           lo[:, None], hi[:, None]),
                          covariance=cov, model=ModelValues.from_vector(names, x, fixed),
                          rms=float(np.sqrt(np.mean(r * r))), windows=len(wins),
                          residuals=int(r.size), swings=int(G), nfev=int(fit.nfev))


# --- checks of the frame and the signals (tools/acromonk_replay.py --checks) ------------------
#: the last seconds of a catch that count as both hooks resting on their bars [s]
CATCH_REST = 0.05


@dataclass(frozen=True)
class ChainClosure:
    """Where the model puts the free end at the close of a log's first catch (both hooks on
    bars at one height): ``free_end`` (x along the ladder, y up) [m] from the holding hook,
    with the logged shoulder as ``theta1``; ``free_end_urdf`` with the URDF's hook-frame
    offset (``urdf_offset`` [rad]) added to it."""

    free_end: tuple[float, float]
    free_end_urdf: tuple[float, float]
    urdf_offset: float


def free_end(robot: Robot, theta1, theta2, flipped: int) -> tuple[np.ndarray, np.ndarray,
                                                                   np.ndarray]:
    """The held end, the joint and the free end [m] ((n, 2) each, x along the ladder, y up)
    of frame angles [rad], with the held end at the origin (the kernel's points)."""
    th1, th2 = np.atleast_1d(np.asarray(theta1, float)), np.atleast_1d(np.asarray(theta2, float))
    s = np.zeros((th1.size, 8))
    s[:, L.TH1], s[:, L.TH2] = th1, th2
    pts = physical_points(robot.params(), s, np.full(th1.size, float(flipped)))
    held, free = ("A", "B") if flipped == 0 else ("B", "A")
    return pts[held], pts["joint"], pts[free]


def chain_closure(robot: Robot, log: HardwareLog, urdf: Path | str = ACROMONK_URDF
                  ) -> ChainClosure:
    """The model's free end over the last :data:`CATCH_REST` seconds of a flagged log's first
    catch, in the frame of the swing that catch closes (mean logged shoulder and elbow there).

    The shoulder is still that swing's ``q1`` during its catch (docs/acromonk.md, "Roles and
    signs"); a free end at the bar's height says the logged shoulder is the angle the model's
    ``theta1`` is (the line hook-to-elbow), and one well off it says it is not.
    """
    first = swings_by_flag(log)[0]
    stop = first.stop
    while stop < len(log) and log.phase[stop] == CATCH:
        stop += 1
    rows = np.arange(first.stop, stop)
    rows = rows[log.time[rows] >= log.time[stop - 1] - CATCH_REST]
    ms = model_swing(log, first)
    s = 1 if ms.flipped == 0 else -1
    th1 = float(np.mean(log.shoulder_angle[rows]))
    th2 = float(np.mean(s * log.elbow_angle[rows]))
    offset = reduce_urdf(urdf, links=ACROMONK_LINKS, joints=ACROMONK_JOINTS,
                         far_grip=ACROMONK_FAR_GRIP).angles.theta1_offset
    return ChainClosure(tuple(float(v) for v in free_end(robot, th1, th2, ms.flipped)[2][0]),
                        tuple(float(v) for v in free_end(robot, th1 + offset, th2,
                                                        ms.flipped)[2][0]),
                        float(offset))


def torque_sign_errors(robot: Robot, ms: ModelSwing, horizon: float = 0.1,
                       every: float = 0.1) -> tuple[float, float]:
    """The elbow's RMS replay error [rad] at ``horizon`` [s] over starts every ``every`` [s]
    of a swing, with the measured torque as logged and with its sign reversed."""
    reversed_ = replace(ms, torque=-ms.torque)
    return tuple(float(horizon_errors(robot, [m], horizons=(horizon,), every=every)
                       .rms(horizon)[1]) for m in (ms, reversed_))


@dataclass(frozen=True)
class RateAgreement:
    """A swing's logged rates against its logged angles, per joint [theta1, theta2]:
    ``integrated`` the largest |angle - (first angle + trapezoidal integral of the rate)|
    [rad]; ``quotient`` the RMS of each interval's difference quotient of the angle less the
    mean of the rates at its ends [rad s-1]."""

    integrated: np.ndarray
    quotient: np.ndarray


def _distinct_times(ms: ModelSwing) -> np.ndarray:
    """The rows of a swing without a repeated time stamp (the first of each kept)."""
    return np.flatnonzero(np.r_[True, np.diff(ms.time) > 0])


def rate_agreement(ms: ModelSwing) -> RateAgreement:
    """How the logged rates (the IMU's gyro, the servo's velocity) follow the logged angles
    (the IMU's fused estimate, the elbow encoder) over a swing (:class:`RateAgreement`)."""
    k = _distinct_times(ms)
    t = ms.time[k]
    th = ms.angles[k]
    w = np.column_stack([ms.theta1_rate, ms.theta2_rate])[k]
    dt = np.diff(t)[:, None]
    integral = th[0] + np.vstack([np.zeros((1, 2)),
                                  np.cumsum(0.5 * (w[1:] + w[:-1]) * dt, axis=0)])
    quotient = np.diff(th, axis=0) / dt - 0.5 * (w[1:] + w[:-1])
    return RateAgreement(np.max(np.abs(integral - th), axis=0),
                         np.sqrt(np.mean(quotient * quotient, axis=0)))


def local_quadratic(t: np.ndarray, y: np.ndarray, half_width: float
                    ) -> tuple[np.ndarray, np.ndarray]:
    """A smoothing differentiator for unevenly sampled data: at each sample, the least-squares
    quadratic in time through the samples within ``half_width`` [s] of it (a Savitzky-Golay
    filter on the actual sample times); returns its value and its slope there.

    Parameters
    ----------
    t : ndarray
        Sample times [s], increasing.
    y : ndarray
        The samples.
    half_width : float
        Half the window [s]; a window with fewer than 3 samples is an error.
    """
    t = np.asarray(t, float)
    y = np.asarray(y, float)
    lo = np.searchsorted(t, t - half_width * (1 + 1e-12), side="left")
    hi = np.searchsorted(t, t + half_width * (1 + 1e-12), side="right")
    if np.any(hi - lo < 3):
        raise ValueError(f"a window of +-{half_width} s holds fewer than 3 samples")
    value = np.empty(t.size)
    slope = np.empty(t.size)
    for k in range(t.size):
        d = t[lo[k]:hi[k]] - t[k]
        A = np.column_stack([np.ones_like(d), d, d * d])
        c = np.linalg.lstsq(A, y[lo[k]:hi[k]], rcond=None)[0]
        value[k], slope[k] = c[0], c[1]
    return value, slope


#: how :func:`inverse_dynamics` differentiates the logged rates
DIFFERENTIATORS = ("difference", "local_quadratic")


@dataclass(frozen=True)
class InverseDynamics:
    """A swing's inverse dynamics: at each scored sample, ``M q'' + C q' + G`` plus the
    model's friction torque, of the pivot row (``pivot``; zero for the model on a pin) and of
    the elbow row (``elbow``; the torque the model needs at the elbow) [N m], the
    measured torque on ``theta2`` (``torque``) [N m], gravity's torque in the pivot row
    (``gravity``) [N m], the sample times (``time``) [s] and the rates used (``rates``,
    (n, 2) [rad s-1])."""

    time: np.ndarray
    rates: np.ndarray
    pivot: np.ndarray
    elbow: np.ndarray
    torque: np.ndarray
    gravity: np.ndarray

    @property
    def pivot_rms(self) -> float:
        """RMS of the pivot row [N m]."""
        return float(np.sqrt(np.mean(self.pivot ** 2)))

    @property
    def gravity_rms(self) -> float:
        """RMS of gravity's torque in the pivot row [N m]."""
        return float(np.sqrt(np.mean(self.gravity ** 2)))

    @property
    def elbow_rms(self) -> float:
        """RMS of the elbow row less the measured torque [N m]."""
        return float(np.sqrt(np.mean((self.elbow - self.torque) ** 2)))

    @property
    def torque_factor(self) -> float:
        """The least-squares factor k of ``elbow = k torque`` [1]."""
        return float(self.elbow @ self.torque / (self.torque @ self.torque))


def inverse_dynamics(robot: Robot, ms: ModelSwing, *, differentiator: str = "difference",
                     half_width: float = 0.02, flipped: int | None = None) -> InverseDynamics:
    """The rows of ``M q'' + C q' + G`` plus the robot's friction torque (``b w + c sgn w``
    per joint; docs/model.md section 2) along a measured swing, the accelerations from its
    logged rates: the pivot row is what the model leaves unbalanced, the elbow row the torque
    it needs.

    Parameters
    ----------
    robot : Robot
        The model, with its friction.
    ms : ModelSwing
        The swing.
    differentiator : str
        ``difference``: central difference quotients of the logged rates on the actual
        sample times (``numpy.gradient``), the rates as logged; ``local_quadratic``: the
        slope of :func:`local_quadratic` over ``half_width``, the rates its values.
    half_width : float
        Both differentiators are scored only on the samples at least this far [s] from the
        swing's ends (where the local fit is whole; the release and the catch are left out
        alike), so the two are compared on the same samples.
    flipped : int, optional
        The parameter row (default: the swing's own); the other row tests the roles.
    """
    if differentiator not in DIFFERENTIATORS:
        raise ValueError(f"differentiator must be one of {DIFFERENTIATORS}, "
                         f"got {differentiator!r}")
    k = _distinct_times(ms)
    t = ms.time[k]
    th = ms.angles[k]
    w = np.column_stack([ms.theta1_rate, ms.theta2_rate])[k]
    if differentiator == "difference":
        a = np.gradient(w, t, axis=0)
    else:
        fits = [local_quadratic(t, w[:, j], half_width) for j in (0, 1)]
        w = np.column_stack([f[0] for f in fits])
        a = np.column_stack([f[1] for f in fits])
    p = robot.params()[ms.flipped if flipped is None else int(flipped)]
    inside = np.flatnonzero((t >= t[0] + half_width) & (t <= t[-1] - half_width))
    rows = np.empty((inside.size, 2))
    gravity = np.empty(inside.size)
    for i, r in enumerate(inside):
        M, bias = swing_matrices(p, th[r, 0], th[r, 1], w[r, 0], w[r, 1])
        rows[i] = M @ a[r] + bias
        gravity[i] = swing_matrices(p, th[r, 0], th[r, 1], 0.0, 0.0)[1][0]
    for j, f in enumerate((robot.pivot_friction, robot.joint_friction)):
        rows[:, j] += f.viscous * w[inside, j] + f.coulomb * np.sign(w[inside, j])
    return InverseDynamics(time=t[inside], rates=w[inside], pivot=rows[:, 0], elbow=rows[:, 1],
                           torque=ms.torque[k][inside], gravity=gravity)


def rest_shoulder(robot: Robot, flipped: int = 0) -> float:
    """The model's ``theta1`` [rad] at rest with the elbow at 0 (``theta2 = 0``): where
    gravity's torque on the pivot vanishes, nearest the downward vertical."""
    # scipy only where a check runs: importing the replay stays light
    from scipy.optimize import brentq

    p = robot.params()[int(flipped)]
    return float(brentq(lambda th1: swing_matrices(p, th1, 0.0, 0.0, 0.0)[1][0], -0.5, 0.5,
                        xtol=1e-14))


def rate_noise(ms: ModelSwing, half_width: float = 0.025) -> np.ndarray:
    """The std [rad s-1] of each logged rate [theta1, theta2] about its
    :func:`local_quadratic` fit over ``half_width`` [s]: the rates' noise (with what of the
    motion a quadratic over the window misses)."""
    k = _distinct_times(ms)
    t = ms.time[k]
    return np.array([float(np.std(w[k] - local_quadratic(t, w[k], half_width)[0]))
                     for w in (ms.theta1_rate, ms.theta2_rate)])


def simulated_swing(robot: Robot, ms: ModelSwing, *, rate_noise_std=(0.0, 0.0),
                    seed: int = 0) -> ModelSwing:
    """The model's own swing: one replay of ``ms`` from its first sample with its measured
    torque, sampled at its (distinct) times, with Gaussian noise of ``rate_noise_std``
    [rad s-1] per joint added to the rates (``numpy.random.default_rng(seed)``). Its inverse
    dynamics in ``robot`` are its friction exactly, so what else they show is the
    differentiator's error."""
    rep = replay(robot, ms, 0, ms.duration + 1.0)
    k = _distinct_times(ms)
    th = np.vstack([ms.angles[:1], rep.simulated])
    w = np.vstack([[ms.theta1_rate[0], ms.theta2_rate[0]], rep.simulated_rates])
    w = w + np.random.default_rng(seed).normal(size=w.shape) * np.asarray(rate_noise_std)
    return ModelSwing(ms.time[k], th[:, 0], th[:, 1], w[:, 0], w[:, 1], ms.torque[k],
                      ms.flipped, ms.name + " simulated")


@dataclass(frozen=True)
class EnergyBalance:
    """A measured swing's energy budget in the model (:func:`energy_balance`) [J].

    Attributes
    ----------
    motor_work : float
        The measured torque's work on the elbow, the trapezoid of ``torque * theta2_rate``.
    energy_change : float
        The model's mechanical energy of the last sample less that of the first.
    dissipated : float
        ``motor_work - energy_change``: what friction (or a torque the sensor overstates) took.
    largest_gain : float
        The largest rise of ``energy_change - motor_work`` from its running minimum: energy the
        swing gained beyond the measured work (0 for a consistent frame and a passive joint).
    """

    motor_work: float
    energy_change: float
    dissipated: float
    largest_gain: float


def energy_balance(robot: Robot, ms: ModelSwing, flipped: int | None = None) -> EnergyBalance:
    """The energy budget of a measured swing in ``robot`` (parameter row ``flipped``, default
    the swing's own): the mechanical energy at every sample from the measured angles and
    rates, against the measured torque's work. Without friction and with a faithful torque
    the two changes are equal; a frame error shows as energy gained beyond the work."""
    p = robot.params()[ms.flipped if flipped is None else int(flipped)]
    state = np.zeros(8)
    energy = np.empty(len(ms))
    for k in range(len(ms)):
        state[2], state[3] = ms.theta1[k], ms.theta2[k]
        state[6], state[7] = ms.theta1_rate[k], ms.theta2_rate[k]
        energy[k] = total_energy8(p, state)
    power = ms.torque * ms.theta2_rate
    work = np.concatenate([[0.0], np.cumsum(0.5 * (power[1:] + power[:-1]) * np.diff(ms.time))])
    excess = energy - energy[0] - work
    return EnergyBalance(float(work[-1]), float(energy[-1] - energy[0]),
                         float(work[-1] - (energy[-1] - energy[0])),
                         float(np.max(excess - np.minimum.accumulate(excess))))


def rate_square_integrals(ms: ModelSwing) -> np.ndarray:
    """``[integral of theta1_rate^2, integral of theta2_rate^2]`` over the swing [rad^2 s-1]
    (trapezoids on the samples): a viscous friction ``b`` at a joint dissipates ``b`` times
    its integral [J]."""
    dt = np.diff(ms.time)
    return np.array([float(np.sum(0.5 * (w[1:] ** 2 + w[:-1] ** 2) * dt))
                     for w in (ms.theta1_rate, ms.theta2_rate)])


def viscous_from_energy(robot: Robot, swings_: Sequence[ModelSwing]) -> np.ndarray:
    """The viscous friction ``[b_pivot, b_joint]`` [N m s] (each >= 0) whose dissipation along
    the measured motions best matches each swing's :func:`energy_balance` (least squares over
    the swings, ``scipy.optimize.nnls``): an estimate from energy alone, without a replay."""
    # scipy only where a check runs: importing the replay stays light
    from scipy.optimize import nnls

    a = np.array([rate_square_integrals(ms) for ms in swings_])
    d = np.array([energy_balance(robot, ms).dissipated for ms in swings_])
    return nnls(a, d)[0]
