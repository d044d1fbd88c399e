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
the servo's velocity): integrated, they follow the logged angles to 0.02-0.03 rad over a swing,
while a difference of the IMU's fused angle departs from the gyro by 0.4 rad/s RMS.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Sequence

import numpy as np

from ..controllers import Integrator, PhaseSequence, Segment
from ..kernel import layout as L
from ..measured import MOTOR_ARM, HardwareLog, Swing, swing_state, swings
from ..robot import Friction, Robot
from ..simulation import Status, initial_state, run_controller

#: AcroMonk's URDF in a source checkout (data/acromonk/model)
ACROMONK_URDF = Path(__file__).resolve().parents[3] / "data" / "acromonk" / "model" / \
    "acromonk.urdf"
#: the URDF's links, joints and far grip as the planar reduction takes them (docs/model.md)
ACROMONK_LINKS = ("hook_1", "link_2")
ACROMONK_JOINTS = ("virtul_joint_hook_1", "joint_1")
ACROMONK_FAR_GRIP = "hook_2"
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
    unless given."""
    return Robot.from_urdf(urdf, links=ACROMONK_LINKS, joints=ACROMONK_JOINTS,
                           far_grip=ACROMONK_FAR_GRIP, pivot_friction=pivot,
                           joint_friction=joint, name="acromonk")


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
#: the parameters :func:`identify` can fit: name -> (units, lower bound, upper bound, start)
PARAMETERS = {
    "pivot_viscous": ("N m s", 0.0, 1.0, 0.02),
    "pivot_coulomb": ("N m", 0.0, 1.0, 0.02),
    "joint_viscous": ("N m s", 0.0, 1.0, 0.02),
    "joint_coulomb": ("N m", 0.0, 1.0, 0.02),
    "shoulder_offset": ("rad", -0.2, 0.2, 0.0),
    "torque_scale": ("1", 0.2, 2.0, 1.0),
}
FRICTION = ("pivot_viscous", "pivot_coulomb", "joint_viscous", "joint_coulomb")


@dataclass(frozen=True)
class ModelValues:
    """A model's values beyond the URDF: friction at the pivot and the joint, an offset added
    to the logged shoulder angle [rad] and a scale on the measured torque [1]."""

    pivot: Friction = Friction()
    joint: Friction = Friction()
    shoulder_offset: float = 0.0
    torque_scale: float = 1.0

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
                   v.get("torque_scale", b.torque_scale))

    def robot(self, base: Robot) -> Robot:
        """``base`` with this friction."""
        return base.with_friction(self.pivot, self.joint)

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
            out.append(f"{n:<16} {self.values[k]:9.4f} {PARAMETERS[n][0]:<6} 95 % "
                       f"[{lo:8.4f}, {hi:8.4f}] (swing-clustered)  [{ilo:8.4f}, {ihi:8.4f}] "
                       f"(windows independent)")
        return "\n".join(out)


def shooting_windows(swings_: Sequence[ModelSwing], window: float, every: float):
    """(swing index, start row) of every window of ``window`` [s] starting every ``every``
    [s] that fits in its swing."""
    return [(i, int(r)) for i, ms in enumerate(swings_)
            for r in start_rows(ms, every, window)]


def identify(base: Robot, swings_: Sequence[ModelSwing], *, names: Sequence[str] = FRICTION,
             fixed: ModelValues = ModelValues(), window: float = 0.3, every: float = 0.1,
             hold: str = "centred", x0=None, max_nfev: int = 60) -> Identification:
    """Fit the named parameters (:data:`PARAMETERS`) by least squares over multiple-shooting
    windows of the swings: each window is replayed from its measured start state for
    ``window`` [s] and every later sample's angle error of both joints is a residual [rad].

    ``fixed`` gives the parameters not fitted. The fit is
    ``scipy.optimize.least_squares`` (trust-region reflective, bounds from
    :data:`PARAMETERS`, a forward-difference Jacobian with steps of 1e-3 of
    ``max(1, |x|)``: far above the replay's integration error).
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
        return np.concatenate(out)

    fit = least_squares(residuals, np.clip(start, lo, hi), bounds=(lo, hi), diff_step=1e-3,
                        x_scale=1.0, max_nfev=max_nfev, method="trf")
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
