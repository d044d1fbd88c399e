"""The ``hardware_replay`` step: a URDF robot's hardware logs replayed through the model
(:mod:`monkeystudy.analysis.measured_replay`; docs/acromonk.md, "Replayed against the model").

The joints' friction (and, if asked, a scale on the measured torque and an offset on the
logged shoulder) is identified on the training logs by multiple shooting; then every log,
training and held out, is replayed with its measured elbow torque from starts every
``start_every`` seconds through each swing and from each swing's first sample, for three
models: the identified one, the published damping and no friction. Deterministic: the
dataset is bit-reproducible.
"""
from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated, Any, Literal, Sequence

import numpy as np
from pydantic import AfterValidator, Field, PrivateAttr, ValidationInfo, field_validator, \
    model_validator

from ...analysis.measured_replay import (
    FRICTION, HORIZON_MARGIN, PARAMETERS, REPLAY_INTEGRATOR, ModelValues, horizon_errors,
    identify, identify_evaluations, model_swings, replay,
)
from ...measured import LogError, read_log, sensor_floor, swings
from ...robot import Friction, Robot
from .. import datasets as D
from .. import provenance
from ..blocks import Task
from ..counts import task_phase, task_units
from ..models import FrictionSettings, JointFriction, Name, StrictModel, UrdfRobotParams, unique
from ..spec import GaitSpec
from .base import Figure, StepContext, StepKind

#: the models compared, in the dataset's order
MODELS = ("identified", "published_damping", "frictionless")
JOINTS = ("shoulder", "elbow")
#: the horizons of the many-starts error [s] (docs/acromonk.md)
HARDWARE_HORIZONS = [0.1, 0.2, 0.5]
BOUNDS = ("lower", "upper")
#: AcroMonk's MuJoCo model (data/acromonk/model/acromonk_mujoco.xml, ``damping`` of the
#: hook's and the elbow's joints): viscous only [N m s]
PUBLISHED_DAMPING = {"pivot": {"viscous": 0.044}, "joint": {"viscous": 0.06}}


# --- the study file ------------------------------------------------------------------------------
def log_path(text: str, info: ValidationInfo) -> Path:
    """A log file a study names: relative to the study file's folder (the validation
    context's ``study_dir``, the working directory without one)."""
    base = Path((info.context or {}).get("study_dir", "."))
    return (base / Path(text).expanduser()).resolve()


def readable_log(text: str, info: ValidationInfo) -> str:
    """A validator: the log reads (:func:`monkeystudy.measured.read_log`) and has a swing;
    read once per validation (kept in the context's ``hardware_logs``)."""
    path = log_path(text, info)
    cache = (info.context if info.context is not None else {}).setdefault("hardware_logs", {})
    key = str(path)
    if key not in cache:
        if not path.is_file():
            cache[key] = f"no such file: {path}"
        else:
            try:
                log = read_log(path)
                cache[key] = log if swings(log) else f"{path}: no swing to replay"
            except (LogError, OSError) as exc:
                cache[key] = str(exc)
    if isinstance(cache[key], str):
        raise ValueError(cache[key])
    return text


def log_name(text: str) -> str:
    """A log's name: its file name without ``.csv`` / ``.csv.gz``."""
    return Path(text).name.removesuffix(".gz").removesuffix(".csv")


LogFile = Annotated[str, Field(min_length=1), AfterValidator(readable_log)]


class IdentifySettings(StrictModel):
    """The identification on the training logs (:func:`monkeystudy.analysis.measured_replay.
    identify`): least squares over multiple-shooting windows, each replayed from its
    measured start, every later sample's angle error a residual."""

    parameters: list[Literal[tuple(PARAMETERS)]] = Field(  # type: ignore[valid-type]
        list(FRICTION), min_length=1,
        description="the parameters fitted: " + ", ".join(
            f"{n} [{u}]" for n, (u, *_) in PARAMETERS.items())
        + " (the others keep the frictionless model's values: 0, a torque scale of 1, the "
        "study robot's rotor inertia)")
    window: float = Field(0.3, gt=0, le=5.0, description="length of a shooting window [s]")
    every: float = Field(0.1, gt=0, le=5.0, description="a window starts every this many "
                                                       "seconds of each swing [s]")
    max_evaluations: int = Field(60, ge=1, le=10_000,
                                 description="residual evaluations of least_squares at most")

    @field_validator("parameters")
    @classmethod
    def _distinct(cls, v: list) -> list:
        return unique(v, "parameters")


def _published_default() -> FrictionSettings:
    return FrictionSettings(pivot=JointFriction(**PUBLISHED_DAMPING["pivot"]),
                            joint=JointFriction(**PUBLISHED_DAMPING["joint"]))


class HardwareReplayStep(StrictModel):
    """The study's URDF robot replayed against hardware logs with their measured elbow
    torque: friction (and, if asked, the motor's rotor inertia, a torque scale, a shoulder
    offset) identified on the training logs, then the replay's angle error over
    many starts and whole swings for the identified model, the published damping and no
    friction (monkeystudy.analysis.measured_replay; docs/acromonk.md). Deterministic: the
    dataset is bit-reproducible."""

    name: Name
    kind: Literal["hardware_replay"]
    train: list[LogFile] = Field(
        min_length=1, description="the logs the parameters are identified on (.csv or "
        ".csv.gz, relative to the study file's folder); at least one with a "
        "state_machine_flag column (the sensor floor is measured on its catches)")
    held_out: list[LogFile] = Field(
        min_length=1, description="the logs only replayed (relative to the study file's "
                                  "folder)")
    horizons: list[Annotated[float, Field(gt=0, le=5.0)]] = Field(
        HARDWARE_HORIZONS, min_length=1,
        description="times after a measured start at which the replay's angle error is "
                    "taken [s], increasing")
    start_every: float = Field(0.1, gt=0, le=5.0, description="a replay starts every this "
                               "many seconds of each swing [s]")
    identify: IdentifySettings = Field(default_factory=IdentifySettings)
    published: FrictionSettings = Field(
        default_factory=_published_default,
        description="the published damping (default: AcroMonk's MuJoCo model, "
                    "data/acromonk/model/acromonk_mujoco.xml: 0.044 N m s at the hook, "
                    "0.06 N m s at the elbow, viscous)")
    _paths: dict = PrivateAttr(default_factory=dict)
    #: a training log marks its catches (None: not every log was read)
    _flagged: bool | None = PrivateAttr(None)

    @field_validator("horizons")
    @classmethod
    def _increasing(cls, v: list) -> list:
        if any(b <= a for a, b in zip(v, v[1:])):
            raise ValueError("must be increasing")
        return v

    @model_validator(mode="after")
    def _logs(self, info: ValidationInfo) -> "HardwareReplayStep":
        cache = (info.context or {}).get("hardware_logs", {})
        self._paths = {t: str(log_path(t, info)) for t in self.train + self.held_out}
        logs = [cache.get(self._paths[t]) for t in self.train]
        self._flagged = (any(log.phase is not None for log in logs)
                         if all(log is not None for log in logs) else None)
        return self

    def problems(self, index: int) -> list[tuple[tuple, str]]:
        """Problems across its logs (``index``: the step's place in the study): two logs
        with one name, no training log that marks its catches."""
        out: list[tuple[tuple, str]] = []
        seen: dict[str, str] = {}
        for key, items in (("train", self.train), ("held_out", self.held_out)):
            for k, t in enumerate(items):
                name = log_name(t)
                if name in seen:
                    out.append((("steps", index, key, k),
                                f"{name!r} is also the name of {seen[name]!r} (a log is named "
                                "by its file name without .csv/.csv.gz)"))
                seen.setdefault(name, t)
        if self._flagged is False:
            out.append((("steps", index, "train"),
                        "no log has a state_machine_flag column (the sensor floor is "
                        "measured on the catches it marks)"))
        return out

    def log_files(self) -> dict[str, str]:
        """Every log's name (its file name without ``.csv``/``.csv.gz``) and absolute
        path, training logs first, in the study's order."""
        return {log_name(p): p for p in (self._paths[t] for t in self.train + self.held_out)}

    def train_names(self) -> list[str]:
        """The training logs' names."""
        return list(self.log_files())[:len(self.train)]

    def published_values(self) -> ModelValues:
        """The published damping as a model."""
        p, j = self.published.pivot, self.published.joint
        return ModelValues(Friction(p.viscous, p.coulomb), Friction(j.viscous, j.coulomb))


# --- tasks (run on the workers) ------------------------------------------------------------------
def evaluate_log(values: ModelValues, base: Robot, path: str, *, horizons: Sequence[float],
                 every: float, series: bool = False) -> dict[str, Any]:
    """A model's replays of one log: the angle error at each horizon from starts every
    ``every`` [s] through each swing, and each swing's replay from its first sample.

    Returns
    -------
    dict
        ``swing`` (names), ``hook`` (``motor_arm`` or ``imu_arm`` per swing),
        ``start_swing``, ``start_time`` [s] and ``start_error`` ((n, 2 joints,
        horizons) [rad], NaN where the horizon passes the swing's end), ``rms``,
        ``median_abs`` ((2, horizons) [rad], NaN without a start), ``count`` (per horizon),
        ``whole_rms`` ((swings, 2) [rad]) and with ``series`` the whole-swing replays:
        ``time``, ``measured_angle``, ``simulated_angle``, ``measured_rate``,
        ``simulated_rate``, ``torque`` (lists per swing).
    """
    hs = tuple(float(h) for h in horizons)
    log = read_log(path)
    sws = values.swings(model_swings(log))
    robot = values.robot(base)
    errs = horizon_errors(robot, sws, horizons=hs, every=every,
                          torque_scale=values.torque_scale)
    order = {ms.name: i for i, ms in enumerate(sws)}
    keys = sorted({(order[str(n)], float(t)) for h in hs
                   for n, t in zip(errs.swing[h], errs.start_time[h])})
    index = {k: i for i, k in enumerate(keys)}
    start_error = np.full((len(keys), 2, len(hs)), np.nan)
    for j, h in enumerate(hs):
        for n, t, e in zip(errs.swing[h], errs.start_time[h], errs.errors[h]):
            start_error[index[(order[str(n)], float(t))], :, j] = e
    nan2 = np.full(2, np.nan)
    out: dict[str, Any] = {
        "swing": [ms.name for ms in sws],
        "hook": ["motor_arm" if ms.flipped == 0 else "imu_arm" for ms in sws],
        "start_swing": [sws[i].name for i, _ in keys],
        "start_time": np.array([t for _, t in keys]),
        "start_error": start_error,
        "rms": np.column_stack([errs.rms(h) if errs.count(h) else nan2 for h in hs]),
        "median_abs": np.column_stack([errs.median_abs(h) if errs.count(h) else nan2
                                       for h in hs]),
        "count": np.array([errs.count(h) for h in hs]),
    }
    whole, parts = [], {k: [] for k in ("time", "measured_angle", "simulated_angle",
                                        "measured_rate", "simulated_rate", "torque")}
    for ms in sws:
        # one replay from the first sample to the last (whole_swing_error's)
        rep = replay(robot, ms, 0, ms.duration + 1.0, torque_scale=values.torque_scale)
        whole.append(np.sqrt(np.mean(np.square(rep.error), axis=0)))
        if series:
            t = ms.time - ms.time[0]
            rows = np.r_[0, np.searchsorted(t, rep.time)]
            rates = np.column_stack([ms.theta1_rate, ms.theta2_rate])
            parts["time"].append(t[rows])
            parts["measured_angle"].append(ms.angles[rows])
            parts["simulated_angle"].append(np.vstack([ms.angles[:1], rep.simulated]))
            parts["measured_rate"].append(rates[rows])
            parts["simulated_rate"].append(np.vstack([rates[:1], rep.simulated_rates]))
            parts["torque"].append(ms.torque[rows])
    out["whole_rms"] = np.array(whole).reshape(-1, 2)
    if series:
        out.update(parts)
    return out


def identify_task(spec: GaitSpec, train: list[str], logs: list[str], *, names: Sequence[str],
                  window: float, every: float, max_nfev: int, horizons: Sequence[float],
                  start_every: float) -> dict[str, Any]:
    """Identify ``names`` on the swings of the ``train`` logs (paths;
    :func:`~monkeystudy.analysis.measured_replay.identify` with the study's robot, its
    friction replaced), then replay every log of ``logs`` with the identified model
    (:func:`evaluate_log`, with the whole-swing series).

    Two phases, each with its count (:func:`~monkeystudy.study.counts.task_phase`):
    ``identify`` counts the fit's residual evaluations against the most it can make
    (:func:`~monkeystudy.analysis.measured_replay.identify_evaluations`, worded "at most":
    a fit that converges sooner completes the count), ``replays`` the logs replayed."""
    base = spec.robot
    sws = [ms for p in train for ms in model_swings(read_log(p))]
    most = identify_evaluations(max_nfev, len(names))
    # the most, not what the fit will make (on studies/acromonk.yaml about a fifth): the
    # count and its eta say so
    task_phase("identify", most, "residual evaluations at most")
    evaluated = [0]

    def count(n: int) -> None:
        evaluated[0] += n
        task_units(n)
    fit = identify(base, sws, names=tuple(names), window=window, every=every,
                   max_nfev=max_nfev, evaluated=count)
    task_units(most - evaluated[0])
    task_phase("replays", len(logs), "logs")
    replayed = []
    for p in logs:
        replayed.append(evaluate_log(fit.model, base, p, horizons=horizons, every=start_every,
                                     series=True))
        task_units(1)
    return {"fit": fit, "logs": replayed}


def model_task(spec: GaitSpec, values: ModelValues, path: str, *, horizons: Sequence[float],
               start_every: float) -> dict[str, Any]:
    """A fixed model's replays of one log (:func:`evaluate_log`) with the study's robot, its
    friction replaced by ``values``'."""
    return evaluate_log(values, spec.robot, path, horizons=horizons, every=start_every)


# --- the dataset ---------------------------------------------------------------------------------
#: the sensor floor at horizon h: the training logs' largest std per joint, for the shoulder
#: plus its largest drift times h (docs/acromonk.md, "Sensor floor")
FLOOR_NOTE = ("the training logs' largest sensor std over the last 0.05 s of their catches; "
              "for the shoulder plus the largest drift of the IMU estimate times the horizon")

PARAMETER_UNITS_NOTE = "mixed: each parameter's units are parameter_units"

#: the variables of a hardware_replay dataset (docs/datasets.md)
VARIABLES = {
    "model": D.label_coordinate("model", "model replayed: identified (fitted on the training "
                                "logs), published_damping, frictionless"),
    "log": D.label_coordinate("log", "hardware log (file name without .csv/.csv.gz)"),
    "joint": D.label_coordinate("joint", "joint: shoulder (theta1, the holding link from the "
                                "downward vertical), elbow (theta2)"),
    "horizon": D.Variable(("horizon",), np.float64, "s",
                          "time after a measured start at which the error is taken"),
    "parameter": D.label_coordinate("parameter", "identified parameter"),
    "bound": D.label_coordinate("bound", "interval bound: lower, upper"),
    "swing": D.label_coordinate("swing", "swing: <log>#<number from 1>"),
    "sample": D.index_coordinate("sample", "sample of a swing from its first"),
    "start": D.index_coordinate("start", "measured start of a replay"),
    # logs
    "held_out": D.Variable(("log",), np.int8, "1",
                           "1: held out (only replayed); 0: a training log"),
    "log_swings": D.Variable(("log",), np.int32, "1", "swings of the log"),
    # the comparison
    "rms_error": D.Variable(("model", "log", "joint", "horizon"), np.float64, "rad",
                            "RMS over the log's starts of the replay's angle error "
                            "(simulated less measured) at the horizon (NaN: no start)"),
    "median_abs_error": D.Variable(("model", "log", "joint", "horizon"), np.float64, "rad",
                                   "median over the log's starts of the replay's absolute "
                                   "angle error at the horizon (NaN: no start)"),
    "start_count": D.Variable(("log", "horizon"), np.int32, "1",
                              "starts of the log whose replay reaches the horizon within its "
                              "swing"),
    "whole_swing_rms": D.Variable(("model", "log", "joint"), np.float64, "rad",
                                  "root mean square over the log's swings of swing_rms: the "
                                  "angle error of one replay from each swing's first sample "
                                  "to its last"),
    "sensor_floor": D.Variable(("joint", "horizon"), np.float64, "rad",
                               "sensor floor: " + FLOOR_NOTE),
    # swings
    "swing_log": D.Variable(("swing",), str, "1", "the swing's log"),
    "swing_hook": D.Variable(("swing",), str, "1",
                             "the holding hook: motor_arm (the model hangs from end A) or "
                             "imu_arm (from end B)"),
    "swing_samples": D.Variable(("swing",), np.int32, "1",
                                "samples of the swing with distinct times (sample < this)"),
    "swing_rms": D.Variable(("model", "swing", "joint"), np.float64, "rad",
                            "RMS over the swing's samples after its first of the angle error "
                            "of one replay from its first sample to its last"),
    "time": D.Variable(("swing", "sample"), np.float64, "s",
                       "time from the swing's first sample (NaN past its last)"),
    "measured_angle": D.Variable(("swing", "sample", "joint"), np.float64, "rad",
                                 "measured angle in the identified model's frame (theta1 = "
                                 "logged shoulder + its shoulder_offset)"),
    "simulated_angle": D.Variable(("swing", "sample", "joint"), np.float64, "rad",
                                  "the identified model's replay from the swing's first "
                                  "sample with the measured torque"),
    "measured_rate": D.Variable(("swing", "sample", "joint"), np.float64, D.RATE,
                                "measured rate (the IMU's gyro, the servo's velocity)"),
    "simulated_rate": D.Variable(("swing", "sample", "joint"), np.float64, D.RATE,
                                 "the identified model's replayed rate"),
    "measured_torque": D.Variable(("swing", "sample"), np.float64, "N m",
                                  "measured elbow torque on theta2 (before any torque_scale)"),
    # starts
    "start_swing": D.Variable(("start",), str, "1", "the start's swing"),
    "start_time": D.Variable(("start",), np.float64, "s",
                             "the start's time from its swing's first sample"),
    "start_error": D.Variable(("model", "start", "joint", "horizon"), np.float64, "rad",
                              "the replay's angle error (simulated less measured) at the "
                              "horizon after the start (NaN: past the swing's end)"),
    # the identification
    "parameter_units": D.Variable(("parameter",), str, "1", "units of the parameter"),
    "identified_value": D.Variable(("parameter",), np.float64, PARAMETER_UNITS_NOTE,
                                   "identified value"),
    "ci95_clustered": D.Variable(("parameter", "bound"), np.float64, PARAMETER_UNITS_NOTE,
                                 "95 % interval, swing-clustered sandwich covariance "
                                 "(Student's t, swings - 1 degrees of freedom), cut at the "
                                 "parameter's bounds"),
    "ci95_independent": D.Variable(("parameter", "bound"), np.float64, PARAMETER_UNITS_NOTE,
                                   "95 % interval as if every residual were independent "
                                   "(too narrow: for comparison), cut at the parameter's "
                                   "bounds"),
    "model_value": D.Variable(("model", "parameter"), np.float64, PARAMETER_UNITS_NOTE,
                              "the parameter's value in each model"),
}


def parameter_value(values: ModelValues, name: str, robot: Robot) -> float:
    """A model's value of parameter ``name`` (:data:`~monkeystudy.analysis.measured_replay.
    PARAMETERS`) on the study's ``robot``."""
    if name == "rotor_inertia":
        return float(values.robot(robot).rotor.inertia)
    return float({"pivot_viscous": values.pivot.viscous, "pivot_coulomb": values.pivot.coulomb,
                  "joint_viscous": values.joint.viscous, "joint_coulomb": values.joint.coulomb,
                  "shoulder_offset": values.shoulder_offset,
                  "torque_scale": values.torque_scale}[name])


def padded(parts: list[np.ndarray], n: int) -> np.ndarray:
    """Arrays of different lengths along their first axis stacked, NaN past each one's
    end."""
    shape = (len(parts), n) + parts[0].shape[1:]
    out = np.full(shape, np.nan)
    for i, p in enumerate(parts):
        out[i, :len(p)] = p
    return out


def floor_of(paths: Sequence[str], horizons: Sequence[float]) -> tuple[np.ndarray, list[str]]:
    """The sensor floor (:data:`FLOOR_NOTE`; joints x horizons [rad]) from the logs among
    ``paths`` that mark their catches, and their names."""
    logs = [read_log(p) for p in paths]
    floors = [(log.name, sensor_floor(log)) for log in logs if log.phase is not None]
    sh = max(f.shoulder_std for _, f in floors)
    el = max(f.elbow_std for _, f in floors)
    drift = max(abs(f.offset_drift) for _, f in floors if np.isfinite(f.offset_drift))
    h = np.asarray(horizons, float)
    return np.vstack([sh + drift * h, np.full(h.size, el)]), [n for n, _ in floors]


def write_hardware_replay(path: Path, attrs: dict, step: HardwareReplayStep, fitted: dict,
                          others: dict[tuple[str, str], dict]) -> dict[str, Any]:
    """Write a hardware_replay dataset (docs/datasets.md) from :func:`identify_task`'s
    result and :func:`model_task`'s per (model, log); returns the numbers of the summary
    line."""
    files = step.log_files()
    names = list(files)
    n_train = len(step.train)
    hs = [float(h) for h in step.horizons]
    fit = fitted["fit"]
    per = {("identified", n): r for n, r in zip(names, fitted["logs"])} | others
    ident = fitted["logs"]
    swing_names = [s for r in ident for s in r["swing"]]
    swing_log = [n for n, r in zip(names, ident) for _ in r["swing"]]
    lengths = [len(t) for r in ident for t in r["time"]]
    n_sample = max(lengths)
    start_swing = [s for r in ident for s in r["start_swing"]]
    floor, floor_logs = floor_of([files[n] for n in names[:n_train]], hs)
    published = step.published_values()
    models = {"identified": fit.model, "published_damping": published,
              "frictionless": ModelValues()}

    def stack(key):
        return np.array([[per[(m, n)][key] for n in names] for m in MODELS])

    with D.atomic_netcdf(path) as nc:
        def write(name, data):
            D.write_declared(nc, VARIABLES, name, data)

        D.write_coordinate(nc, VARIABLES, "model", list(MODELS))
        D.write_coordinate(nc, VARIABLES, "log", names)
        D.write_coordinate(nc, VARIABLES, "joint", list(JOINTS))
        D.write_coordinate(nc, VARIABLES, "horizon", np.array(hs))
        D.write_coordinate(nc, VARIABLES, "parameter", list(fit.names))
        D.write_coordinate(nc, VARIABLES, "bound", list(BOUNDS))
        D.write_coordinate(nc, VARIABLES, "swing", swing_names)
        D.write_coordinate(nc, VARIABLES, "sample", np.arange(n_sample))
        D.write_coordinate(nc, VARIABLES, "start", np.arange(len(start_swing)))
        write("held_out", np.array([0] * n_train + [1] * (len(names) - n_train)))
        write("log_swings", [len(r["swing"]) for r in ident])
        write("rms_error", stack("rms"))
        write("median_abs_error", stack("median_abs"))
        write("start_count", np.array([r["count"] for r in ident]))
        swing_rms = np.array([np.vstack([per[(m, n)]["whole_rms"] for n in names])
                              for m in MODELS])
        write("whole_swing_rms", np.array([[np.sqrt(np.mean(per[(m, n)]["whole_rms"] ** 2,
                                                             axis=0)) for n in names]
                                           for m in MODELS]))
        write("sensor_floor", floor)
        write("swing_log", np.array(swing_log, object))
        write("swing_hook", np.array([h for r in ident for h in r["hook"]], object))
        write("swing_samples", lengths)
        write("swing_rms", swing_rms)
        write("time", padded([t for r in ident for t in r["time"]], n_sample))
        for key in ("measured_angle", "simulated_angle", "measured_rate", "simulated_rate"):
            write(key, padded([a for r in ident for a in r[key]], n_sample))
        write("measured_torque", padded([a for r in ident for a in r["torque"]], n_sample))
        write("start_swing", np.array(start_swing, object))
        write("start_time", np.concatenate([r["start_time"] for r in ident]))
        write("start_error", np.array([np.concatenate([per[(m, n)]["start_error"]
                                                       for n in names]) for m in MODELS]))
        write("parameter_units", np.array([PARAMETERS[n][0] for n in fit.names], object))
        write("identified_value", fit.values)
        write("ci95_clustered", fit.ci95)
        write("ci95_independent", fit.ci95_iid)
        robot = Robot.from_dict(attrs["robot"])
        write("model_value", np.array([[parameter_value(models[m], n, robot)
                                        for n in fit.names] for m in MODELS]))
        D.set_global_attrs(nc, dict(
            attrs, train=names[:n_train], held_out_logs=names[n_train:],
            log_files=list(step.train + step.held_out),
            log_sha256={n: provenance.file_sha256(files[n]) for n in names},
            start_every=step.start_every, identify_window=step.identify.window,
            identify_every=step.identify.every,
            identify_max_evaluations=step.identify.max_evaluations,
            fit_rms=fit.rms, fit_windows=fit.windows, fit_residuals=fit.residuals,
            fit_swings=fit.swings, fit_evaluations=fit.nfev,
            published_damping=step.published.model_dump(mode="json"),
            floor_logs=floor_logs, hold="centred",
            replay_integrator=f"{REPLAY_INTEGRATOR.method} rtol {REPLAY_INTEGRATOR.rtol:g} "
                              f"atol {REPLAY_INTEGRATOR.atol:g}",
            horizon_margin=HORIZON_MARGIN, bit_reproducible=1))
    held = slice(n_train, len(names))
    rms = stack("rms")
    below = rms[0, held] < rms[1, held]
    return {"fit": fit, "below": int(below.sum()), "rows": int(below.size)}


# --- the kind ------------------------------------------------------------------------------------
class HardwareReplayKind(StepKind):
    name = "hardware_replay"
    model = HardwareReplayStep
    variables = VARIABLES
    gait_kinds = ("horizontal", "sequence")
    # the logs' measured torque drives the robot: no gait, and a fixed integrator
    runs_gait = False
    own_integrator = REPLAY_INTEGRATOR
    unit = "tasks"
    figures = (
        Figure("swings_train"),
        Figure("swings_held_out"),
        Figure("residuals"),
        Figure("parameters"),
        Figure("held_out"),
    )

    def check_step(self, study, index: int, step, ref, seen) -> list:
        problems = step.problems(index)
        if not isinstance(study.robot, UrdfRobotParams):
            what = (f"the preset {study.robot!r}" if isinstance(study.robot, str)
                    else "explicit parameters")
            return [(("robot",), f"a hardware_replay step replays a robot read from its URDF "
                                 f"(robot: {{urdf: ...}}), whose links say which hook is end A; "
                                 f"got {what}")] + problems
        return problems

    def input_files(self, step: HardwareReplayStep) -> tuple[str, ...]:
        """The logs: a dataset is current only while their contents are unchanged."""
        return tuple(step.log_files().values())

    def n_tasks(self, step: HardwareReplayStep, gait) -> int:
        return 1 + 2 * len(step.log_files())

    def start(self, ctx: StepContext) -> list[Task]:
        st = ctx.step
        files = st.log_files()
        paths = list(files.values())
        opts = {"horizons": [float(h) for h in st.horizons], "start_every": st.start_every}
        idf = st.identify
        tasks = [Task(0, identify_task, (ctx.spec, paths[:len(st.train)], paths),
                      dict(opts, names=list(idf.parameters), window=idf.window,
                           every=idf.every, max_nfev=idf.max_evaluations))]
        fixed = {"published_damping": st.published_values(), "frictionless": ModelValues()}
        plan = [(m, n) for m in fixed for n in files]
        ctx.state["plan"] = plan
        tasks += [Task(1 + i, model_task, (ctx.spec, fixed[m], files[n]), dict(opts))
                  for i, (m, n) in enumerate(plan)]
        return tasks

    def finish(self, ctx: StepContext, attrs: dict) -> str:
        results = ctx.task_results()
        others = dict(zip(ctx.state["plan"], results[1:]))
        r = write_hardware_replay(ctx.path, attrs, ctx.step, results[0], others)
        fit = r["fit"]
        values = ", ".join(f"{n} {v:.4g} [{lo:.3g}, {hi:.3g}]" for n, v, (lo, hi) in
                           zip(fit.names, fit.values, fit.ci95))
        return (f"identified on {fit.swings} swings ({fit.windows} windows, rms "
                f"{fit.rms:.4f} rad): {values}; held out: identified below the published "
                f"damping in {r['below']} of {r['rows']} (log, joint, horizon) rows")

    def own_setup(self, ds) -> str:
        """The replays in words, their integrator from attr ``replay_integrator``
        (``<method> rtol <rtol> atol <atol>``)."""
        words = str(ds.attrs.get("replay_integrator", "")).split()
        integ = (", ".join([words[0].upper()] + [f"{k} {v}" for k, v in
                                                  zip(words[1::2], words[2::2])])
                 if words else "an integrator its dataset does not record")
        return ("replays each log's measured elbow torque through the robot with each model's "
                f"friction (identified, published damping, none), integrated with {integ}")

    def describe(self, ds) -> list[str]:
        out = [f"identified on {', '.join(json.loads(ds.attrs['train']))} "
               f"({ds.attrs['fit_swings']} swings, {ds.attrs['fit_windows']} windows, "
               f"rms {float(ds.attrs['fit_rms']):.4f} rad):"]
        for k, n in enumerate(ds["parameter"].values):
            lo, hi = ds["ci95_clustered"].values[k]
            ilo, ihi = ds["ci95_independent"].values[k]
            pub = float(ds["model_value"].values[1, k])
            out.append(f"  {n} {float(ds['identified_value'][k]):.4g} "
                       f"{ds['parameter_units'].values[k]}: 95 % swing-clustered "
                       f"[{lo:.4g}, {hi:.4g}], windows independent [{ilo:.4g}, {ihi:.4g}]; "
                       f"published {pub:.4g}")
        hs = ds["horizon"].values
        out.append("RMS replay error [rad] at " + "/".join(f"{h:g}" for h in hs)
                   + " s and whole swing, identified / published_damping / frictionless; "
                   "floor")
        rms = ds["rms_error"].values
        whole = ds["whole_swing_rms"].values
        floor = ds["sensor_floor"].values
        below = total = 0
        for i, log in enumerate(ds["log"].values):
            tag = "held out" if int(ds["held_out"][i]) else "train"
            for j, joint in enumerate(ds["joint"].values):
                cells = "  ".join("/".join(f"{rms[m, i, j, k]:.3f}" for m in range(3))
                                  for k in range(hs.size))
                out.append(f"  {log} ({tag}) {joint}: {cells}  whole "
                           + "/".join(f"{whole[m, i, j]:.3g}" for m in range(3))
                           + "  floor " + "/".join(f"{f:.1e}" for f in floor[j]))
                if tag == "held out":
                    below += int(np.sum(rms[0, i, j] < rms[1, i, j]))
                    total += hs.size
        out.append(f"held out: identified below published_damping in {below} of {total} "
                   "(log, joint, horizon) rows")
        out.append("the identified model's whole-swing RMS error per swing [rad], shoulder/"
                   "elbow (m: from the motor arm, i: from the IMU arm)")
        swing_rms = ds["swing_rms"].values[0]
        hooks = ds["swing_hook"].values
        swing_log = ds["swing_log"].values
        for log in ds["log"].values:
            cells = ", ".join(f"{swing_rms[i, 0]:.2f}/{swing_rms[i, 1]:.2f} "
                              f"{'m' if hooks[i] == 'motor_arm' else 'i'}"
                              for i in np.flatnonzero(swing_log == log))
            out.append(f"  {log}: {cells}")
        return out
