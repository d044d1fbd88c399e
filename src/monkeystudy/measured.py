"""AcroMonk's hardware logs: one log read into SI arrays, its sampling, its swings, the lab's
state convention per swing, and the sensor floor.

The logs are the DFKI AcroMonk's real-system CSV files shipped in ``data/acromonk/logs``
(docs/acromonk.md describes them). Two column layouts occur:

- ``store`` (the state-machine logger): ``meas_time`` first, measured and desired shoulder and
  elbow position and velocity, four elbow torques (``elbow_des_tau_store``,
  ``elbow_meas_tau``, ``elbow_cmd_tau``, ``elbow_clipped_tau``), the raw IMU roll and roll
  rate, the TVLQR gains ``k1_store``..``k4_store`` and, in the 5x files,
  ``state_machine_flag`` (0 release, 1 swing, 2 catch).
- ``trajectory`` (the earlier single-manoeuvre logger): the desired trajectory row it tracked
  (``shoulder_des_*``, ``elbow_des_*``, ``elbow_des_tau``, ``elbow_des_tau_tvlqr``,
  ``des_time``, the gains ``k1``..``k4``, ``k0``) beside the measured ``shoulder_meas_*``,
  ``elbow_meas_*`` and ``meas_time``.

The elbow torque the motor applied is ``elbow_meas_tau``, the servo's own torque reading: in
the PD runs the servo's internal position loop makes the torque and the commanded columns hold
0, and during the first part of each catch the logger records the catch torque as commanded
and clipped while the servo is sent 0 (the measured torque there is about 0). The other torque
columns are kept in :attr:`HardwareLog.columns`.

Run ``python3 -m monkeystudy.measured data/acromonk/logs`` (or ``python
tools/acromonk_logs.py data/acromonk/logs``) for the summary tables.
"""
from __future__ import annotations

import gzip
import math
import sys
from dataclasses import dataclass, field
from pathlib import Path
from types import MappingProxyType
from typing import Mapping

import numpy as np

#: the shipped logs' folder in a source checkout (data/acromonk/logs beside src/)
SHIPPED_LOGS = Path(__file__).resolve().parents[2] / "data" / "acromonk" / "logs"
#: the store layout's columns, in file order (the flag column is optional, last)
STORE_COLUMNS = (
    "meas_time", "shoulder_des_pos_store", "shoulder_meas_pos", "shoulder_des_vel_store",
    "shoulder_meas_vel", "elbow_des_pos_store", "elbow_meas_pos", "elbow_des_vel_store",
    "elbow_meas_vel", "elbow_des_tau_store", "elbow_meas_tau", "elbow_cmd_tau",
    "elbow_clipped_tau", "raw_imu_pos", "raw_imu_vel", "k1_store", "k2_store", "k3_store",
    "k4_store",
)
FLAG_COLUMN = "state_machine_flag"
#: the trajectory layout's columns, in file order
TRAJECTORY_COLUMNS = (
    "shoulder_des_pos", "shoulder_des_vel", "shoulder_des_acc", "shoulder_des_jerk",
    "shoulder_des_tau", "elbow_des_pos", "elbow_des_vel", "elbow_des_acc", "elbow_des_jerk",
    "elbow_des_tau", "elbow_des_tau_tvlqr", "des_time", "shoulder_meas_pos",
    "shoulder_meas_vel", "elbow_meas_pos", "elbow_meas_vel", "elbow_meas_tau", "meas_time",
    "k1", "k2", "k3", "k4", "k0",
)
#: measured columns: a NaN in one of them is an error (the logger writes them every row)
MEASURED_COLUMNS = ("meas_time", "shoulder_meas_pos", "shoulder_meas_vel", "elbow_meas_pos",
                    "elbow_meas_vel", "elbow_meas_tau")
#: the flag's values: release (both hooks on, the release torque), swing, catch
RELEASE, SWING, CATCH = 0, 1, 2
#: the elbow encoder's step [rad]: 1/65536 of a rotor turn through the servo's 6:1 gear
ELBOW_ENCODER_STEP = 2.0 * math.pi / (6 * 65536)
#: the hooks: the arm carrying the IMU and computer, or the other one
IMU_ARM, MOTOR_ARM = "imu_arm", "motor_arm"


class LogError(ValueError):
    """A log that is not one of the two layouts, or holds a bad value (the message names the
    file and its line)."""


@dataclass(frozen=True)
class HardwareLog:
    """One hardware log in SI units.

    Attributes
    ----------
    path : str
        The file read.
    layout : str
        ``"store"`` or ``"trajectory"`` (the module docstring describes both).
    time : ndarray
        Time from the log's first row [s] (``meas_time`` less its first value).
    time_offset : float
        ``meas_time`` of the first row [s] (time since the experiment's start).
    shoulder_angle, shoulder_rate : ndarray
        The shoulder estimate [rad], [rad/s] as logged (IMU and elbow encoder).
    elbow_angle, elbow_rate : ndarray
        The elbow encoder [rad] and the servo's velocity [rad/s], in the motor's frame.
    elbow_torque : ndarray
        The torque the servo applied [N m] (``elbow_meas_tau``), motor frame.
    phase : ndarray or None
        ``state_machine_flag`` as integers (0 release, 1 swing, 2 catch), None without it.
    columns : mapping of str to ndarray
        Every column as read (NaN kept), by its name in the file.
    """

    path: str
    layout: str
    time: np.ndarray
    time_offset: float
    shoulder_angle: np.ndarray
    shoulder_rate: np.ndarray
    elbow_angle: np.ndarray
    elbow_rate: np.ndarray
    elbow_torque: np.ndarray
    phase: np.ndarray | None
    columns: Mapping[str, np.ndarray] = field(repr=False)

    def __len__(self) -> int:
        return len(self.time)

    @property
    def name(self) -> str:
        """The file's name without ``.csv`` / ``.csv.gz``."""
        return Path(self.path).name.removesuffix(".gz").removesuffix(".csv")

    @property
    def desired_elbow(self) -> np.ndarray:
        """The desired elbow angle column [rad] (NaN outside a tracked trajectory)."""
        return self.columns["elbow_des_pos_store" if self.layout == "store"
                            else "elbow_des_pos"]


def _frozen(a: np.ndarray) -> np.ndarray:
    a = np.ascontiguousarray(a, dtype=float)
    a.flags.writeable = False
    return a


def _open_text(path: Path):
    return gzip.open(path, "rt") if path.name.endswith(".gz") else open(path)


def read_log(path: str | Path) -> HardwareLog:
    """Read one AcroMonk log (``.csv`` or ``.csv.gz``).

    Parameters
    ----------
    path : str or Path
        The file.

    Returns
    -------
    HardwareLog

    Raises
    ------
    LogError
        The header is neither layout; a row has the wrong number of fields or a field that
        is not a number; a measured column is NaN or infinite; ``meas_time`` decreases; a
        flag is not 0, 1 or 2. The message starts ``<file>:<line>:``.
    """
    path = Path(path)
    try:
        with _open_text(path) as fh:
            lines = fh.read().splitlines()
    except (OSError, EOFError, UnicodeDecodeError) as exc:
        raise LogError(f"{path}: cannot read: {exc}") from None
    if not lines:
        raise LogError(f"{path}:1: empty file")
    header = [h.strip() for h in lines[0].split(",")]
    if tuple(header) in (STORE_COLUMNS, STORE_COLUMNS + (FLAG_COLUMN,)):
        layout = "store"
    elif tuple(header) == TRAJECTORY_COLUMNS:
        layout = "trajectory"
    else:
        raise LogError(f"{path}:1: header is not an AcroMonk log's (store layout: "
                       f"{', '.join(STORE_COLUMNS[:3])}, ...; trajectory layout: "
                       f"{', '.join(TRAJECTORY_COLUMNS[:3])}, ...): got "
                       f"{', '.join(header[:3])}, ...")
    rows = []
    for number, line in enumerate(lines[1:], start=2):
        if not line.strip():
            continue
        fields = line.split(",")
        if len(fields) != len(header):
            raise LogError(f"{path}:{number}: {len(fields)} fields, the header has "
                           f"{len(header)}")
        try:
            rows.append([float(x) for x in fields])
        except ValueError:
            bad = next(h for h, x in zip(header, fields) if not _is_number(x))
            raise LogError(f"{path}:{number}: {bad}: not a number: "
                           f"{fields[header.index(bad)]!r}") from None
        rows[-1].append(number)
    if not rows:
        raise LogError(f"{path}:2: no data rows")
    data = np.array(rows, dtype=float)
    line_of = data[:, -1].astype(int)
    cols = {h: data[:, i] for i, h in enumerate(header)}
    for name in MEASURED_COLUMNS:
        bad = np.flatnonzero(~np.isfinite(cols[name]))
        if bad.size:
            raise LogError(f"{path}:{line_of[bad[0]]}: {name}: {float(cols[name][bad[0]])} "
                           f"(a measured value must be finite; {bad.size} rows)")
    t = cols["meas_time"]
    back = np.flatnonzero(np.diff(t) < 0)
    if back.size:
        i = back[0] + 1
        raise LogError(f"{path}:{line_of[i]}: meas_time: {float(t[i])!r} s is before the "
                       f"previous row's {float(t[i - 1])!r} s")
    phase = None
    if FLAG_COLUMN in cols:
        flag = cols[FLAG_COLUMN]
        bad = np.flatnonzero(~np.isin(flag, (RELEASE, SWING, CATCH)))
        if bad.size:
            raise LogError(f"{path}:{line_of[bad[0]]}: {FLAG_COLUMN}: {float(flag[bad[0]])!r} is "
                           f"not 0 (release), 1 (swing) or 2 (catch)")
        phase = flag.astype(np.int8)
        phase.flags.writeable = False
    frozen = {h: _frozen(v) for h, v in cols.items()}
    return HardwareLog(
        path=str(path), layout=layout, time=_frozen(t - t[0]), time_offset=float(t[0]),
        shoulder_angle=frozen["shoulder_meas_pos"], shoulder_rate=frozen["shoulder_meas_vel"],
        elbow_angle=frozen["elbow_meas_pos"], elbow_rate=frozen["elbow_meas_vel"],
        elbow_torque=frozen["elbow_meas_tau"], phase=phase,
        columns=MappingProxyType(frozen))


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def log_paths(folder: str | Path) -> list[Path]:
    """The logs of a folder (``*.csv`` and ``*.csv.gz``), sorted by name."""
    folder = Path(folder)
    return sorted([*folder.glob("*.csv"), *folder.glob("*.csv.gz")])


# --- sampling ------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Sampling:
    """A log's sample intervals [s]: median, 95th percentile, largest, smallest, and how
    many are zero (two rows with one time stamp)."""

    median: float
    p95: float
    max: float
    min: float
    zero: int

    @property
    def median_rate(self) -> float:
        """1 / median interval [Hz]."""
        return 1.0 / self.median


def sampling(log: HardwareLog) -> Sampling:
    """The distribution of a log's sample intervals (``numpy.percentile``, linear)."""
    dt = np.diff(log.time)
    return Sampling(median=float(np.median(dt)), p95=float(np.percentile(dt, 95)),
                    max=float(dt.max()), min=float(dt.min()), zero=int(np.sum(dt == 0.0)))


# --- swings ----------------------------------------------------------------------------------
@dataclass(frozen=True)
class Swing:
    """One swing: rows ``start`` to ``stop - 1`` of its log (a slice).

    ``start`` is the first row after the release (the swing hook is off its bar); ``stop``
    is the first row of the catch (the tracked trajectory has ended with the swing hook at
    the next bar), or the log's length when the log ends there.
    """

    start: int
    stop: int
    rule: str

    @property
    def rows(self) -> slice:
        return slice(self.start, self.stop)


def _runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """The maximal runs of True in ``mask`` as (start, stop) row pairs."""
    edges = np.diff(np.r_[0, mask.astype(np.int8), 0])
    return list(zip(np.flatnonzero(edges == 1).tolist(), np.flatnonzero(edges == -1).tolist()))


def swings_by_flag(log: HardwareLog) -> list[Swing]:
    """Swings from ``state_machine_flag``: a run of flag 1 (swing) that follows a flag-0 row
    (release) and is followed by a flag-2 row (catch). A swing starts at its first flag-1
    row and stops at the first flag-2 row (the catch; the swing hook is at the next bar).

    Raises
    ------
    ValueError
        The log has no flag column.
    """
    if log.phase is None:
        raise ValueError(f"{log.path}: no {FLAG_COLUMN} column")
    out = []
    for a, b in _runs(log.phase == SWING):
        if a > 0 and log.phase[a - 1] == RELEASE and b < len(log) and log.phase[b] == CATCH:
            out.append(Swing(a, b, "flag"))
    return out


def swings_by_desired(log: HardwareLog) -> list[Swing]:
    """Swings from the desired trajectory, for logs without the flag.

    Store layout: a swing is a maximal run of rows whose desired elbow angle is finite (the
    logger writes the desired columns only while it tracks a trajectory; release and catch
    rows hold NaN). Trajectory layout: the swing starts at the last row whose ``des_time``
    is 0 (the trajectory's first point; rows before it, if any, are the release) and runs to
    the log's end (this logger stops with the trajectory).
    """
    if log.layout == "store":
        return [Swing(a, b, "desired") for a, b in _runs(np.isfinite(log.desired_elbow))]
    des_time = log.columns["des_time"]
    zero = np.flatnonzero(des_time == 0.0)
    start = int(zero[-1]) if zero.size else 0
    return [Swing(start, len(log), "desired")]


def swings(log: HardwareLog) -> list[Swing]:
    """The log's swings: by the flag where the log has it, else by the desired trajectory."""
    return swings_by_flag(log) if log.phase is not None else swings_by_desired(log)


def cut_agreement(log: HardwareLog) -> np.ndarray:
    """For a flagged log, the desired-trajectory rule's cut times less the flag's
    [s], one row per swing: (start difference, stop difference).

    Raises
    ------
    ValueError
        The log has no flag, or the two rules find different numbers of swings.
    """
    by_flag, by_desired = swings_by_flag(log), swings_by_desired(log)
    if len(by_flag) != len(by_desired):
        raise ValueError(f"{log.path}: {len(by_flag)} swings by the flag, "
                         f"{len(by_desired)} by the desired trajectory")
    t = np.r_[log.time, np.nan]          # a stop at the log's end has no time
    return np.array([[t[d.start] - t[f.start], t[d.stop] - t[f.stop]]
                     for f, d in zip(by_flag, by_desired)]).reshape(-1, 2)


# --- roles and signs -------------------------------------------------------------------------
def wrap(angle):
    """An angle [rad] wrapped into [-pi, pi)."""
    return (np.asarray(angle) + np.pi) % (2.0 * np.pi) - np.pi


@dataclass(frozen=True)
class Holding:
    """Which hook holds during a swing, and the evidence.

    ``imu_swings`` and ``imu_holds`` are the largest |shoulder - estimate| [rad] over the
    swing's rows for the two ways the logger forms the shoulder angle from the IMU roll
    ``r`` and the elbow encoder ``e``: ``wrap(r - e)`` (the IMU arm swings; its roll is
    q1 + q2) and ``wrap(r - pi)`` (the IMU arm holds; its roll less pi is q1). NaN without
    the raw IMU columns, where the hook is the lab's start configuration (``assumed``).
    """

    hook: str
    imu_swings: float
    imu_holds: float
    assumed: bool

    @property
    def elbow_sign(self) -> int:
        """+1 or -1: the lab's q2 (and torque) is this times the motor-frame elbow angle."""
        return 1 if self.hook == MOTOR_ARM else -1


def holding(log: HardwareLog, swing: Swing) -> Holding:
    """The hook a swing hangs from, from the logger's shoulder estimate (see :class:`Holding`).

    Without raw IMU data (the trajectory layout) the swing is taken to hang from the motor
    arm with the IMU arm swinging: the lab runs its single-manoeuvre scripts from that
    configuration.
    """
    rows = swing.rows
    if "raw_imu_pos" not in log.columns or not np.all(
            np.isfinite(log.columns["raw_imu_pos"][rows])):
        return Holding(MOTOR_ARM, math.nan, math.nan, assumed=True)
    roll, sh, el = log.columns["raw_imu_pos"][rows], log.shoulder_angle[rows], \
        log.elbow_angle[rows]
    swings_res = float(np.max(np.abs(wrap(roll - el - sh))))
    holds_res = float(np.max(np.abs(wrap(roll - np.pi - sh))))
    return Holding(MOTOR_ARM if swings_res < holds_res else IMU_ARM, swings_res, holds_res,
                   assumed=False)


@dataclass(frozen=True)
class SwingState:
    """A swing in the lab's convention (data/acromonk/hardware/acrm-equations.md): q1 the
    holding link's angle from the downward vertical [rad], q2 the swing link's angle relative
    to it [rad], their rates [rad/s], the elbow torque u [N m] (B = [0, 1]^T), time from the
    swing's first row [s], and the holding hook."""

    time: np.ndarray
    q1: np.ndarray
    q2: np.ndarray
    q1_rate: np.ndarray
    q2_rate: np.ndarray
    torque: np.ndarray
    hook: str

    @property
    def state(self) -> np.ndarray:
        """(n, 4) rows [q1, q2, q1', q2']."""
        return np.column_stack([self.q1, self.q2, self.q1_rate, self.q2_rate])


def swing_state(log: HardwareLog, swing: Swing) -> SwingState:
    """A swing's measured state and torque in the lab's convention.

    The logger's shoulder estimate is already q1 of the holding link; the elbow angle, rate
    and torque are the motor's, whose sense relative to the holding link flips with the
    roles: q2 = s e, q2' = s e', u = s tau, with s = +1 when the motor arm holds and -1 when
    the IMU arm holds (:func:`holding`).
    """
    rows, held = swing.rows, holding(log, swing)
    s = held.elbow_sign
    return SwingState(time=log.time[rows] - log.time[swing.start],
                      q1=log.shoulder_angle[rows].copy(), q2=s * log.elbow_angle[rows],
                      q1_rate=log.shoulder_rate[rows].copy(), q2_rate=s * log.elbow_rate[rows],
                      torque=s * log.elbow_torque[rows], hook=held.hook)


def closed_chain_shoulder(q2) -> np.ndarray:
    """q1 [rad] with both hooks on bars at one height, from q2 [rad] (lab convention, equal
    link lengths): cos q1 + cos(q1 + q2) = 0, so q1 = (pi - q2)/2 for q2 > 0 and
    -(pi + q2)/2 for q2 < 0."""
    q2 = np.asarray(q2, dtype=float)
    return np.where(q2 > 0, (np.pi - q2) / 2.0, -(np.pi + q2) / 2.0)


@dataclass(frozen=True)
class HandOver:
    """The logged values on either side of one hand-over (the last catch row before a
    release and the release's first row): shoulder and elbow angle [rad] and elbow torque
    [N m] as logged, and the shoulder the closed chain predicts from the elbow after the
    hand-over in the new roles; the clipped (commanded) torque [N m] says which schedule
    runs: the catch torque before, the release torque after."""

    time: float
    shoulder_before: float
    shoulder_after: float
    elbow_before: float
    elbow_after: float
    clipped_torque_before: float
    clipped_torque_after: float
    chain_shoulder_after: float


def hand_overs(log: HardwareLog) -> list[HandOver]:
    """Every catch-to-release transition of a flagged log (both hooks on the bars)."""
    if log.phase is None:
        raise ValueError(f"{log.path}: no {FLAG_COLUMN} column")
    out = []
    sws = swings_by_flag(log)
    for i in np.flatnonzero((log.phase[:-1] == CATCH) & (log.phase[1:] == RELEASE)):
        nxt = [s for s in sws if s.start > i]
        s = holding(log, nxt[0]).elbow_sign if nxt else 1
        out.append(HandOver(
            time=float(log.time[i + 1]), shoulder_before=float(log.shoulder_angle[i]),
            shoulder_after=float(log.shoulder_angle[i + 1]),
            elbow_before=float(log.elbow_angle[i]), elbow_after=float(log.elbow_angle[i + 1]),
            clipped_torque_before=float(log.columns["elbow_clipped_tau"][i]),
            clipped_torque_after=float(log.columns["elbow_clipped_tau"][i + 1]),
            chain_shoulder_after=float(closed_chain_shoulder(s * log.elbow_angle[i + 1]))))
    return out


# --- sensor floor ------------------------------------------------------------------------------
@dataclass(frozen=True)
class SensorFloor:
    """A flagged log's sensor floor, from the closing stretch of every catch (both hooks on
    the bars, the catch torque holding the hook in its groove).

    Attributes
    ----------
    stretches : int
        Stretches used.
    shoulder_std, elbow_std : float
        Median over stretches of the residual std about a straight line [rad].
    shoulder_offset : ndarray
        Per stretch, mean shoulder less the closed-chain shoulder from the elbow [rad]
        (:func:`closed_chain_shoulder`): the IMU estimate's bias plus any mismatch of the
        hooks' geometry with equal link lengths.
    offset_drift : float
        Slope of ``shoulder_offset`` against the stretches' times [rad/s] (NaN for fewer
        than two stretches).
    elbow_step : float
        The smallest nonzero change of the elbow angle between rows over the whole log [rad].
    """

    stretches: int
    shoulder_std: float
    elbow_std: float
    shoulder_offset: np.ndarray
    offset_drift: float
    elbow_step: float


def elbow_step(log: HardwareLog) -> float:
    """The smallest nonzero change of the logged elbow angle between rows [rad]."""
    d = np.abs(np.diff(log.elbow_angle))
    return float(d[d > 0].min())


def elbow_grid_deviation(log: HardwareLog) -> float:
    """The largest distance of a logged elbow angle from the encoder's grid, in steps of
    :data:`ELBOW_ENCODER_STEP` (0: every angle is a whole number of steps)."""
    steps = log.elbow_angle / ELBOW_ENCODER_STEP
    return float(np.max(np.abs(steps - np.round(steps))))


def _line_residual_std(t: np.ndarray, y: np.ndarray) -> float:
    coef = np.polyfit(t - t.mean(), y, 1)
    return float(np.std(y - np.polyval(coef, t - t.mean()), ddof=2))


def sensor_floor(log: HardwareLog, window: float = 0.05) -> SensorFloor:
    """The sensor floor from the last ``window`` seconds [s] of every catch of a flagged log.

    The hold is the quietest stretch the logs have (the robot is never left hanging still
    for long); what moves in it counts as noise, so the stds are upper bounds.
    """
    if log.phase is None:
        raise ValueError(f"{log.path}: no {FLAG_COLUMN} column")
    sh_std, el_std, offsets, times = [], [], [], []
    for a, b in _runs(log.phase == CATCH):
        rows = np.arange(a, b)[log.time[a:b] >= log.time[b - 1] - window]
        if rows.size < 5:
            continue
        t = log.time[rows]
        sh, el = log.shoulder_angle[rows], log.elbow_angle[rows]
        sh_std.append(_line_residual_std(t, sh))
        el_std.append(_line_residual_std(t, el))
        s = _catch_sign(log, a)
        offsets.append(float(np.mean(sh - closed_chain_shoulder(s * el))))
        times.append(float(t.mean()))
    offsets_a = np.array(offsets)
    drift = float(np.polyfit(times, offsets_a, 1)[0]) if len(times) >= 2 else math.nan
    return SensorFloor(stretches=len(offsets), shoulder_std=float(np.median(sh_std)),
                       elbow_std=float(np.median(el_std)), shoulder_offset=offsets_a,
                       offset_drift=drift, elbow_step=elbow_step(log))


def _catch_sign(log: HardwareLog, catch_row: int) -> int:
    """The elbow sign of the swing a catch closes (the shoulder is still that swing's q1)."""
    before = [s for s in swings_by_flag(log) if s.stop <= catch_row]
    return holding(log, before[-1]).elbow_sign if before else 1


# --- summary -----------------------------------------------------------------------------------
def summary(paths: list[Path]) -> str:
    """Text tables for the given logs: rows, duration, sampling, swings, cut agreement, the
    hook of each swing and the sensor floor."""
    out = ["log                 layout      rows  duration_s  median_dt_ms  p95_dt_ms  "
           "max_gap_ms  zero_dt  swings  rule     hooks"]
    logs = [read_log(p) for p in paths]
    for log in logs:
        sm, sw = sampling(log), swings(log)
        hooks = "".join("M" if holding(log, s).hook == MOTOR_ARM else "I" for s in sw)
        if any(holding(log, s).assumed for s in sw):
            hooks += " (assumed)"
        out.append(f"{log.name:<19} {log.layout:<10} {len(log):>5}  {log.time[-1]:>10.3f}  "
                   f"{1e3 * sm.median:>12.2f}  {1e3 * sm.p95:>9.2f}  {1e3 * sm.max:>10.1f}  "
                   f"{sm.zero:>7}  {len(sw):>6}  {sw[0].rule if sw else '-':<7}  {hooks}")
    out.append("")
    out.append("swings (s from the log's start; I/M: the IMU arm or the motor arm holds; "
               "residual: max |shoulder - IMU formula| of the chosen and the other formula, "
               "rad)")
    for log in logs:
        for k, s in enumerate(swings(log), start=1):
            h = holding(log, s)
            stop = f"{log.time[s.stop]:.3f}" if s.stop < len(log) else "end"
            chosen, other = (h.imu_swings, h.imu_holds) if h.hook == MOTOR_ARM \
                else (h.imu_holds, h.imu_swings)
            state = swing_state(log, s)
            out.append(f"  {log.name:<19} {k}  start {log.time[s.start]:7.3f}  stop {stop:>7}"
                       f"  rows {s.stop - s.start:4d}  hook {h.hook:<9}  residual "
                       f"{chosen:.1e} / {other:.1e}  q(start) {state.q1[0]:+.3f} "
                       f"{state.q2[0]:+.3f}  q(end) {state.q1[-1]:+.3f} {state.q2[-1]:+.3f}")
    flagged = [log for log in logs if log.phase is not None]
    if flagged:
        out.append("")
        out.append("desired-trajectory rule vs flag (s): max |start difference|, "
                   "max |stop difference|")
        for log in flagged:
            d = np.abs(cut_agreement(log))
            out.append(f"  {log.name:<19} {d[:, 0].max():.4f}  {d[:, 1].max():.4f}")
        out.append("")
        out.append("hand-overs: shoulder before -> after, elbow before -> after (rad), "
                   "closed-chain shoulder after, clipped torque before -> after (N m)")
        for log in flagged:
            for h in hand_overs(log):
                out.append(f"  {log.name:<19} t {h.time:6.3f}  shoulder {h.shoulder_before:+.4f}"
                           f" -> {h.shoulder_after:+.4f}  elbow {h.elbow_before:+.4f} -> "
                           f"{h.elbow_after:+.4f}  chain {h.chain_shoulder_after:+.4f}  "
                           f"torque {h.clipped_torque_before:+.2f} -> "
                           f"{h.clipped_torque_after:+.2f}")
        out.append("")
        out.append("sensor floor (last 0.05 s of each catch): stretches, shoulder std, elbow "
                   "std (rad), shoulder - closed chain per catch (rad), its drift (rad/s), "
                   "elbow step (rad)")
        for log in flagged:
            f = sensor_floor(log)
            offs = " ".join(f"{x:+.4f}" for x in f.shoulder_offset)
            out.append(f"  {log.name:<19} {f.stretches}  {f.shoulder_std:.2e}  "
                       f"{f.elbow_std:.2e}  [{offs}]  {f.offset_drift:+.1e}  "
                       f"{f.elbow_step:.4e}")
    out.append("")
    out.append(f"elbow encoder (step 2 pi/(6 * 65536) = {ELBOW_ENCODER_STEP:.4e} rad): "
               "smallest nonzero change (rad), largest distance from the step grid (steps)")
    for log in logs:
        out.append(f"  {log.name:<19} {elbow_step(log):.4e}  {elbow_grid_deviation(log):.4f}")
    return "\n".join(out)


def main(argv: list[str] | None = None) -> int:
    """``python3 -m monkeystudy.measured FOLDER_OR_FILES...``: print :func:`summary`."""
    args = sys.argv[1:] if argv is None else argv
    if not args:
        print("usage: python3 -m monkeystudy.measured FOLDER_OR_LOG...", file=sys.stderr)
        return 2
    paths: list[Path] = []
    for a in args:
        paths += log_paths(a) if Path(a).is_dir() else [Path(a)]
    try:
        print(summary(paths))
    except LogError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
