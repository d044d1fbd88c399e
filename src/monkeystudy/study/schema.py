"""The study file schema (version 1): strict, frozen pydantic v2 models.

A study names a robot (a preset or explicit parameters), a gait with its controller settings,
an integrator and a list of steps. Units are SI and stated in every field's description (they
show up in editors through the exported JSON Schema, ``monkeystudy schema``).

Everything is checked here, before any work: unknown keys (``extra="forbid"``), wrong types
(``strict``: a quoted ``"1e-3"`` is text, not a number; ``no`` is text, not ``false``),
non-finite or non-physical values, empty grids, and references between steps
(:func:`cross_check`). :mod:`monkeystudy.study.loader` turns the errors into
``file:line: key: message`` lines.
"""
from __future__ import annotations

import contextvars
from typing import Annotated, Any, Literal, Optional, Union

import numpy as np
from pydantic import (
    BaseModel, ConfigDict, Discriminator, Field, Tag, ValidationInfo, field_validator,
    model_validator,
)

from ..robot import PRESETS

SCHEMA_VERSION = 1

#: Names become file names (``<out>/<step>.nc``) and folder names (``outputs/<study>``).
NAME_PATTERN = r"^[A-Za-z0-9][A-Za-z0-9_.-]*$"

#: Default Nelder-Mead tolerances: MATLAB ``fminsearch``'s TolX and TolFun, as in the study.
FMINSEARCH_TOL = 1e-4

#: Objective value of a refine iterate whose gait fails (status != ok) [1].
DEFAULT_PENALTY = 1.0e6

# Model classes seen by the "before" hook, keyed by the id of the mapping they validated, so an
# unknown-key error can list the keys its mapping allows (see loader.format_errors).
_SEEN_MODELS: contextvars.ContextVar[dict | None] = contextvars.ContextVar("_SEEN_MODELS",
                                                                          default=None)


class _Model(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, strict=True, allow_inf_nan=False,
                              populate_by_name=True, validate_default=False)

    @model_validator(mode="before")
    @classmethod
    def _remember(cls, data: Any) -> Any:
        seen = _SEEN_MODELS.get()
        if seen is not None and isinstance(data, dict):
            seen[id(data)] = cls
        return data

    @classmethod
    def allowed_keys(cls) -> list[str]:
        return [f.alias or name for name, f in cls.model_fields.items()]


Name = Annotated[str, Field(pattern=NAME_PATTERN, max_length=100,
                            description="letters, digits, '_', '-', '.'; used as a file name")]
Rate = Annotated[float, Field(description="angular rate [rad s-1]")]
Point = Annotated[list[float], Field(min_length=2, max_length=2,
                                     description="(dtheta1, dtheta2) [rad s-1]")]


# --- robot ------------------------------------------------------------------------------------
class LinkParams(_Model):
    """One link. Link 1 carries end A, link 2 end B; ``com`` is measured from the proximal end
    (end A for link 1, the joint for link 2)."""

    mass: float = Field(gt=0, description="mass [kg]")
    length: float = Field(gt=0, description="length [m]")
    com: float = Field(ge=0, description="centre of mass from the proximal end [m], "
                                         "0 <= com <= length")
    inertia: float = Field(gt=0, description="moment of inertia about the centre of mass "
                                             "[kg m2]")

    @field_validator("com")
    @classmethod
    def _on_link(cls, v: float, info: ValidationInfo) -> float:
        length = info.data.get("length")
        if length is not None and v > length:
            raise ValueError(f"must lie on the link (<= length = {length} m), got {v}")
        return v


class JointFriction(_Model):
    viscous: float = Field(0.0, ge=0, description="viscous coefficient [N m s]")
    coulomb: float = Field(0.0, ge=0, description="Coulomb friction torque [N m]")


class FrictionSettings(_Model):
    pivot: JointFriction = Field(default_factory=JointFriction,
                                 description="friction at the attached magnet (pivot)")
    joint: JointFriction = Field(default_factory=JointFriction,
                                 description="friction at the motor joint")


class RobotParams(_Model):
    """Explicit robot parameters (MODEL.md section 1)."""

    name: Name = Field("custom", description="a label for the robot")
    gravity: float = Field(9.81, gt=0, description="gravitational acceleration [m s-2]")
    links: list[LinkParams] = Field(min_length=2, max_length=2,
                                    description="[link 1 (end A), link 2 (end B)]")
    friction: FrictionSettings = Field(default_factory=FrictionSettings)


PresetName = Literal[tuple(sorted(PRESETS))]  # type: ignore[valid-type]


def _robot_tag(v: Any) -> str | None:
    if isinstance(v, str):
        return "preset"
    if isinstance(v, (dict, RobotParams)):
        return "parameters"
    return None


RobotSpec = Annotated[
    Union[Annotated[PresetName, Tag("preset")], Annotated[RobotParams, Tag("parameters")]],
    Discriminator(_robot_tag, custom_error_type="robot_type",
                  custom_error_message="must be a preset name ("
                  + ", ".join(sorted(PRESETS)) + ") or a mapping with gravity, links, "
                  "friction"),
]


# --- gait, integrator -------------------------------------------------------------------------
class Gait(_Model):
    """The gait and its search controller (MODEL.md section 4)."""

    kind: Literal["horizontal"] = Field(description="the gait: 'horizontal' (section 4)")
    motor_torque: float = Field(description="motor torque [N m], signed, on theta2 of the "
                                            "new attachment frame (seed2009: 0.6354)")
    tick: float = Field(0.0, ge=0, le=1.0, description="controller tick [s]; 0 = exact "
                                                       "event timing, 0.001 = the study")

    @field_validator("motor_torque")
    @classmethod
    def _nonzero(cls, v: float) -> float:
        if v == 0.0:
            raise ValueError("must be non-zero (the motor restores the energy lost in the "
                             "swap)")
        return v


GuardName = Literal["time", "free_end_height", "energy_restored", "coord", "energy",
                    "free_end_y", "none"]
CoordName = Literal["x", "y", "theta1", "theta2", "dx", "dy", "dtheta1", "dtheta2"]
Direction = Literal["rising", "falling", "either"]

#: the status a segment's horizon reports, by guard (the study's names where they fit)
SEGMENT_FAIL = {"free_end_height": "no_switch", "energy_restored": "energy_not_restored"}


class SegmentSpec(_Model):
    """One segment of a phase-sequence gait (``monkeystudy.controllers.Segment``): entry
    actions (magnets, motor torque, energy latch), then the guard that ends it."""

    until: GuardName = Field(description="guard ending the segment: time (value [s] on the "
                             "controller clock, which restarts at the section), "
                             "free_end_height (free end value [m] above the attached end), "
                             "energy_restored (energy back to the latched reference + value "
                             "[J]), coord (coord crosses value), energy (total energy "
                             "crosses value [J]), free_end_y (free end's world height "
                             "crosses value [m]), none (only the horizon)")
    value: float = Field(0.0, description="guard value, in the guard's units (s, m, J, rad, "
                                          "rad s-1 or m s-1)")
    coord: CoordName = Field("theta1", description="the coordinate of a coord guard (frame "
                                                   "of the attached end)")
    direction: Direction = Field("rising", description="crossing direction of the guard")
    magnets: Literal["keep", "swap", "A", "B", "both", "none"] = Field(
        "keep", description="entry action: keep, swap (attach the free end, release the "
                            "other: a plastic impact), A, B (only that end on), both, none "
                            "(release: free flight)")
    torque: float = Field(0.0, description="motor torque from entry on [N m], on theta2 of "
                                           "the frame after the entry action")
    latch_energy: bool = Field(False, description="latch the total energy on entry as the "
                                                  "reference of energy_restored guards")
    ticked: bool = Field(True, description="act on the controller tick (when the gait has "
                                           "one)")

    def segment(self):
        from ..controllers import Segment
        from ..kernel.layout import STATUS_NAMES

        fail = STATUS_NAMES.index(SEGMENT_FAIL.get(self.until, "horizon"))
        return Segment(self.until, value=self.value, coord=self.coord,
                       direction=self.direction, magnets=self.magnets, torque=self.torque,
                       latch_energy=self.latch_energy, ticked=self.ticked, fail_status=fail)


class SectionSpec(_Model):
    """The Poincare section closing a sequence gait's cycle, and the start on it."""

    theta1: float = Field(0.0, ge=-3.2, le=3.2, description="link 1 angle of the section "
                          "[rad], in the frame of the end attached there (0: vertical)")
    direction: Direction = Field("either", description="crossing direction that ends the "
                                                       "cycle")
    torque: float = Field(0.0, description="motor torque on the last leg, up to the section "
                                           "[N m]")
    theta2: float = Field(0.0, ge=-3.2, le=3.2, description="link 2 angle at the cycle start "
                          "[rad] (grid and refine vary dtheta1, dtheta2; floquet frees it)")


class SequenceGaitSpec(_Model):
    """A gait written as a phase sequence (``monkeystudy.controllers.SequenceGait``): from the
    section hanging from A, the segments in order, then the section ends the cycle. Gait
    error: the section error, wrap(theta2_f - theta2)^2 + (dtheta1_f - dtheta1)^2 +
    (dtheta2_f - dtheta2)^2."""

    kind: Literal["sequence"] = Field(description="the gait: 'sequence' (a phase sequence)")
    segments: list[SegmentSpec] = Field(min_length=1, max_length=64,
                                        description="the cycle's segments, in order")
    section: SectionSpec = Field(default_factory=SectionSpec)
    tick: float = Field(0.0, ge=0, le=1.0, description="controller tick [s]; 0 = exact "
                                                       "event timing")

    @model_validator(mode="after")
    def _closes(self) -> "SequenceGaitSpec":
        self.gait()  # a cycle that reaches its section in flight or pinned is refused here
        return self

    def gait(self):
        from ..controllers import SequenceGait

        sec = self.section
        return SequenceGait([s.segment() for s in self.segments], section_theta1=sec.theta1,
                            section_direction=sec.direction, section_torque=sec.torque,
                            theta2=sec.theta2, tick=self.tick)


GaitSpec = Annotated[Union[Gait, SequenceGaitSpec], Field(discriminator="kind")]


class IntegratorSettings(_Model):
    """Integrator settings (scipy ``solve_ivp`` semantics for rtol/atol)."""

    method: Literal["dop853", "rk45", "vern9"] = Field("dop853", description="Runge-Kutta pair")
    rtol: float = Field(1e-10, ge=100 * np.finfo(float).eps, lt=1.0,
                        description="relative tolerance [1]")
    atol: float = Field(1e-12, gt=0, description="absolute tolerance [rad, rad s-1]")
    max_time: float = Field(3.0, gt=0, le=1.0e4,
                            description="horizon of one controller phase [s]")
    controller: Literal["scipy", "pi"] = Field(
        "scipy", description="step-size controller: scipy's (steps equal solve_ivp's) or "
                             "Gustafsson's PI (fewer rejected steps)")


# --- steps ------------------------------------------------------------------------------------
class Axis(_Model):
    """``num`` evenly spaced values from ``start`` to ``stop`` inclusive (numpy.linspace)."""

    start: float = Field(description="first value [rad s-1]")
    stop: float = Field(description="last value [rad s-1]")
    num: int = Field(ge=1, le=1_000_000, description="number of values")

    @model_validator(mode="after")
    def _single(self) -> "Axis":
        if self.num == 1 and self.start != self.stop:
            raise ValueError("num: 1 needs start == stop")
        return self

    def values(self) -> np.ndarray:
        return np.linspace(self.start, self.stop, self.num)


class GridStep(_Model):
    """Evaluate the gait at every combination of the axes, or at an explicit list of points."""

    name: Name
    kind: Literal["grid"]
    dtheta1: Optional[Axis] = Field(None, description="axis of initial dtheta1 [rad s-1]")
    dtheta2: Optional[Axis] = Field(None, description="axis of initial dtheta2 [rad s-1]")
    points: Optional[list[Point]] = Field(None, min_length=1,
                                          description="explicit (dtheta1, dtheta2) points "
                                                      "[rad s-1], instead of the axes")
    block_size: Optional[int] = Field(
        None, ge=1, le=1_000_000,
        description="points per block (unit of work and of resume); default: about 64 blocks "
                    "per grid, 512 to 8192 points each (fewer, larger shards on big grids)")
    skip_unreachable: bool = Field(True, description="mark points that provably cannot reach "
                                                     "the swap without integrating them")

    @model_validator(mode="after")
    def _axes_or_points(self) -> "GridStep":
        axes = (self.dtheta1 is not None, self.dtheta2 is not None)
        if self.points is not None:
            if any(axes):
                raise ValueError("give either the axes dtheta1 and dtheta2 or points, not both")
        elif not all(axes):
            raise ValueError("give both axes dtheta1 and dtheta2 (or points)")
        return self

    @property
    def n_points(self) -> int:
        if self.points is not None:
            return len(self.points)
        return self.dtheta1.num * self.dtheta2.num

    @property
    def points_per_block(self) -> int:
        """``block_size`` if given, else ~64 blocks of 512..8192 points. Depends on the study
        alone (never on the worker count), so block ids stay deterministic."""
        if self.block_size is not None:
            return self.block_size
        return int(min(8192, max(512, -(-self.n_points // 64))))

    @property
    def n_blocks(self) -> int:
        return -(-self.n_points // self.points_per_block)


class BestOfGrid(_Model):
    """Start from the ``best`` lowest-error minima of an earlier grid step."""

    from_: Name = Field(alias="from", description="an earlier grid step")
    best: int = Field(1, ge=1, le=1000, description="number of grid minima to refine "
                                                    "(one refinement each, dim 'start')")


def _start_tag(v: Any) -> str | None:
    if isinstance(v, list):
        return "point"
    if isinstance(v, (dict, BestOfGrid)):
        return "grid"
    return None


StartSpec = Annotated[
    Union[Annotated[Point, Tag("point")], Annotated[BestOfGrid, Tag("grid")]],
    Discriminator(_start_tag, custom_error_type="start_type",
                  custom_error_message="must be a point [dtheta1, dtheta2] or "
                                       "{from: <grid step>, best: k}"),
]


class RefineStep(_Model):
    """Nelder-Mead on the gait error (scipy.optimize.minimize), every iterate recorded."""

    name: Name
    kind: Literal["refine"]
    method: Literal["nelder-mead"] = Field("nelder-mead", description="the minimizer")
    start: StartSpec = Field(description="[dtheta1, dtheta2] [rad s-1], or {from: <grid "
                                         "step>, best: k}")
    xatol: float = Field(FMINSEARCH_TOL, gt=0, description="absolute tolerance on the point "
                                                           "[rad s-1] (fminsearch TolX)")
    fatol: float = Field(FMINSEARCH_TOL, gt=0, description="absolute tolerance on the error "
                                                           "[1] (fminsearch TolFun)")
    maxiter: Optional[int] = Field(None, ge=1, description="iteration limit (default 400)")
    maxfev: Optional[int] = Field(None, ge=1, description="evaluation limit (default 400)")
    penalty: float = Field(DEFAULT_PENALTY, gt=0,
                           description="objective value where the gait fails [1]")


#: how a multi-cycle step runs the gait (``monkeystudy.replay``)
Replay = Annotated[Optional[Literal["gait", "open_loop"]], Field(
    description="how the gait is run: open_loop (its recorded segment times, the clock "
                "restarting at each section crossing; the horizontal gait's only replay and "
                "its default) or gait (a sequence gait's own controller, guards and all; a "
                "sequence gait's default)")]


class OpenLoopSettings(_Model):
    tick: Optional[float] = Field(None, ge=0, le=1.0,
                                  description="controller tick [s] (default: the gait's)")
    clock: Literal["reset_at_vertical", "run_on"] = Field(
        "reset_at_vertical", description="restart the clock at each vertical crossing, or "
                                         "let it run on with period = the gait's t_end")


class StabilityStep(_Model):
    """Repeat a refined gait open-loop from its recorded times for ``cycles`` cycles."""

    name: Name
    kind: Literal["stability"]
    from_: Name = Field(alias="from", description="an earlier refine step (a sequence gait: "
                                                  "or a floquet step, its fixed point)")
    cycles: int = Field(ge=1, le=100_000, description="number of cycles")
    controller: OpenLoopSettings = Field(default_factory=OpenLoopSettings)
    replay: Replay = None
    start_index: Optional[int] = Field(None, ge=0, description="which start of a multi-start "
                                       "refine step (default: the lowest error)")
    sample_dt: float = Field(0.005, gt=0, le=1.0,
                             description="trajectory sampling interval [s]")
    max_drop: Optional[float] = Field(None, gt=0, description="stop ('fell') when the "
                                      "attached end sinks this far [m] (default: link 1's "
                                      "length)")


# --- analysis steps (docs/datasets.md "Analysis steps") -----------------------------------------
#: the tolerance ladder of the work-precision step (``monkeystudy.precision.RTOLS``)
WORK_PRECISION_RTOLS = [1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10, 1e-11, 1e-12, 1e-13]

#: the state-based controller's attracting gait (theta2 [rad], dtheta1, dtheta2 [rad s-1]),
#: found by a 1000-cycle run of seed2009 at 0.6354 N m
SEARCH_START = [0.0248, -1.0869, 16.0168]

SectionPoint = Annotated[list[float], Field(min_length=3, max_length=3,
                                            description="(theta2 [rad], dtheta1 [rad s-1], "
                                                        "dtheta2 [rad s-1]) on the section "
                                                        "theta1 = 0")]


def _unique(v: list, what: str) -> list:
    dup = sorted({repr(x) for x in v if v.count(x) > 1})
    if dup:
        raise ValueError(f"{what} must be distinct, repeated: {', '.join(dup)}")
    return v


class ShootStep(_Model):
    """Exact fixed points of the horizontal gait (Newton shooting, ``monkeystudy.analysis``).

    ``grazing``: Newton on (dtheta1, dtheta2, t) for end B at end A's height at rest (the
    collisionless swap on the grazing border; an exact, motorless fixed point for mirror-image
    links), from the swap time of the gait at the start (exact events). ``gauss_newton``:
    Gauss-Newton on the gait's repeatability residual. One task per start; solutions closer
    than ``dedup_tol`` are merged (the lower error kept).
    """

    name: Name
    kind: Literal["shoot"]
    starts: Optional[list[Point]] = Field(None, min_length=1,
                                          description="start points (dtheta1, dtheta2) "
                                                      "[rad s-1]")
    from_: Optional[Name] = Field(None, alias="from",
                                  description="an earlier refine step: its lowest-error "
                                              "result is the start (instead of starts)")
    method: Literal["grazing", "gauss_newton", "both"] = Field(
        "both", description="grazing (collisionless swap), gauss_newton (gait residual) or "
                            "both from every start")
    dedup_tol: float = Field(1e-6, gt=0, description="solutions closer than this in "
                                                     "(dtheta1, dtheta2) are one [rad s-1]")
    tol: float = Field(1e-14, gt=0, lt=1.0, description="Newton stops when the residual "
                                                        "norm or the step falls below this "
                                                        "[1]")
    max_iter: int = Field(40, ge=1, le=1000, description="Newton iteration limit")

    @model_validator(mode="after")
    def _starts_or_from(self) -> "ShootStep":
        if (self.starts is None) == (self.from_ is None):
            raise ValueError("give either starts: [[dtheta1, dtheta2], ...] or from: <refine "
                             "step>, not both" if self.starts is not None else
                             "give starts: [[dtheta1, dtheta2], ...] or from: <refine step>")
        return self


class FloquetStep(_Model):
    """Floquet multipliers of a gait's return map on theta1 = 0: variational equations
    (saltation matrices) beside fourth-order central differences.

    ``open_loop``: the shoot step's best solution replayed with its times (motor torque 0
    when ``t_motor`` is 0). ``search``: the state-based controller's own fixed point,
    polished by Newton from ``search_start``.
    """

    name: Name
    kind: Literal["floquet"]
    from_: Optional[Name] = Field(None, alias="from",
                                  description="an earlier shoot step (needed by open_loop)")
    controllers: list[Literal["open_loop", "search", "sequence"]] = Field(
        ["open_loop", "search"], min_length=1,
        description="return maps to analyse: open_loop, search (horizontal gaits); sequence "
                    "(a sequence gait's cycle: its only one, and its default)")
    search_start: SectionPoint = Field(SEARCH_START, description="start of the Newton "
                                       "polish of the search controller's fixed point "
                                       "(theta2 [rad], dtheta1, dtheta2 [rad s-1])")
    solution: Optional[int] = Field(None, ge=0, description="which solution of the shoot "
                                    "step (default: the lowest error)")
    fd_step: float = Field(1e-5, gt=0, le=1e-2, description="relative finite-difference "
                                                            "step [1]")

    @field_validator("controllers")
    @classmethod
    def _distinct(cls, v: list) -> list:
        return _unique(v, "controllers")

    @model_validator(mode="after")
    def _from_for_open_loop(self) -> "FloquetStep":
        if "open_loop" in self.controllers and self.from_ is None:
            raise ValueError("the open_loop controller needs from: <shoot step>")
        return self

    def controllers_for(self, gait_kind: str) -> list[str]:
        """The controllers analysed for a study's gait: a sequence gait's default is its own
        cycle."""
        if gait_kind == "sequence" and "controllers" not in self.model_fields_set:
            return ["sequence"]
        return list(self.controllers)


class TickSweepStep(_Model):
    """The controller-tick question: the exact gait replayed open-loop with its times
    rounded to a controller tick, one run per tick, error per cycle. A sequence gait runs from
    its floquet step's fixed point, as its own controller (its guards acted on at the ticks)
    or open-loop (``replay``)."""

    name: Name
    kind: Literal["tick_sweep"]
    from_: Name = Field(alias="from", description="an earlier shoot step (a sequence gait: "
                                                  "a floquet step, its fixed point)")
    replay: Replay = None
    ticks: list[Annotated[float, Field(ge=0, le=1.0)]] = Field(
        [1e-3, 1e-4, 1e-5, 0.0], min_length=1, description="controller ticks [s]; 0 = exact "
                                                            "timing")
    cycles: int = Field(80, ge=1, le=100_000, description="cycles per run")
    error_bound: float = Field(1e-2, gt=0, description="a run has left the gait at the "
                                                       "first cycle whose error exceeds "
                                                       "this [1]")
    floquet: Optional[Name] = Field(None, description="an earlier floquet step (open_loop) "
                                    "of the same shoot step: its leading multiplier instead "
                                    "of a finite-difference one")
    solution: Optional[int] = Field(None, ge=0, description="which solution of the shoot "
                                    "step (default: the lowest error)")
    max_drop: Optional[float] = Field(None, gt=0, description="stop ('fell') when the "
                                      "attached end sinks this far [m] (default: link 1's "
                                      "length)")

    @field_validator("ticks")
    @classmethod
    def _distinct(cls, v: list) -> list:
        return _unique(v, "ticks")


class BasinOffsets(_Model):
    d_dtheta1: Axis = Field(description="offsets of the start's dtheta1 [rad s-1]")
    d_dtheta2: Axis = Field(description="offsets of the start's dtheta2 [rad s-1]")


#: a basin with more points than this runs as blocks of rows on the pool (else one task)
BASIN_TASK_POINTS = 400

#: points per basin block (whole rows of d_dtheta2, at least one row)
BASIN_BLOCK_POINTS = 100


class BasinStep(_Model):
    """Cycles an open-loop replay of the gait (a sequence gait: ``replay``) survives from
    perturbed starts. More than
    ``BASIN_TASK_POINTS`` points are split into blocks of whole rows (about
    ``BASIN_BLOCK_POINTS`` points each) on the pool, each saved as a shard (resumable)."""

    name: Name
    kind: Literal["basin"]
    from_: Name = Field(alias="from", description="an earlier shoot step (a sequence gait: "
                                                  "a floquet step, its fixed point)")
    replay: Replay = None
    offsets: BasinOffsets = Field(description="start offsets (d_dtheta1, d_dtheta2) [rad s-1]")
    max_cycles: int = Field(60, ge=1, le=100_000, description="cycles per run (a start that "
                            "never fails scores this)")
    error_bound: float = Field(1e-2, gt=0, description="failure: error against the "
                               "unperturbed gait above this [1]")
    tick: Optional[float] = Field(None, ge=0, le=1.0, description="controller tick [s] "
                                  "(default: the gait's)")
    solution: Optional[int] = Field(None, ge=0, description="which solution of the shoot "
                                    "step (default: the lowest error)")

    @property
    def n_points(self) -> int:
        return self.offsets.d_dtheta1.num * self.offsets.d_dtheta2.num

    @property
    def rows_per_block(self) -> int:
        """Rows of d_dtheta1 per task: all of them up to ``BASIN_TASK_POINTS`` points."""
        n1, n2 = self.offsets.d_dtheta1.num, self.offsets.d_dtheta2.num
        if self.n_points <= BASIN_TASK_POINTS:
            return n1
        return max(1, BASIN_BLOCK_POINTS // n2)


#: continuation parameters of the horizontal gait's collisionless family (mirror-symmetric)
GRAZING_PARAMETERS = ("com", "inertia", "gravity")


class ContinuationStep(_Model):
    """Pseudo-arclength continuation of a gait family in one parameter, with the Floquet
    multipliers along the branch and its folds and bifurcations.

    Horizontal gait (``from:`` a shoot step): the collisionless (grazing) family in a
    mirror-symmetric parameter (com, inertia, gravity). Sequence gait (``from:`` a floquet
    step, whose Newton-polished fixed point starts the branch at the section's theta2): any
    parameter, ``monkeystudy.continuation``.
    """

    name: Name
    kind: Literal["continuation"]
    from_: Name = Field(alias="from", description="an earlier step: a shoot step (horizontal "
                                                  "gait: its best grazing solution) or a "
                                                  "floquet step (sequence gait: its fixed "
                                                  "point)")
    parameter: Literal["com", "inertia", "gravity", "torque", "mass_ratio", "joint_viscous",
                       "pivot_viscous"] = Field(
        description="com: link 1's CG from A [m] (link 2's mirrored); inertia: both links' "
                    "[kg m2]; gravity [m s-2]; sequence gaits also: torque (the first motor "
                    "segment's [N m], the others scaled with it), mass_ratio (link 2's mass "
                    "over link 1's at the same total mass, inertias scaled with the masses "
                    "[1]), joint_viscous, pivot_viscous (viscous friction [N m s])")
    ds: float = Field(description="first arclength step in (dtheta1, dtheta2, [t_switch,] "
                                  "parameter) [mixed units]; its sign picks the direction")
    ds_max: Optional[float] = Field(None, gt=0, description="sequence gaits: largest |ds| "
                                    "the adaptive step may grow to (default |ds|); a failed "
                                    "corrector halves the step down to |ds| / 256")
    steps: int = Field(20, ge=1, le=100_000, description="continuation steps")
    bounds: Optional[list[float]] = Field(None, min_length=2, max_length=2,
                                          description="[lo, hi]: stop when the parameter "
                                                      "leaves them (units of the parameter)")

    @field_validator("ds")
    @classmethod
    def _nonzero(cls, v: float) -> float:
        if v == 0.0:
            raise ValueError("must be non-zero")
        return v

    @field_validator("bounds")
    @classmethod
    def _ordered(cls, v):
        if v is not None and not v[0] < v[1]:
            raise ValueError(f"must be [lo, hi] with lo < hi, got {v}")
        return v


class PointAxes(_Model):
    dtheta1: Axis = Field(description="axis of dtheta1 [rad s-1]")
    dtheta2: Axis = Field(description="axis of dtheta2 [rad s-1]")


def _points_tag(v: Any) -> str | None:
    if isinstance(v, list):
        return "list"
    if isinstance(v, (dict, PointAxes)):
        return "axes"
    return None


PointsSpec = Annotated[
    Union[Annotated[list[Point], Tag("list")], Annotated[PointAxes, Tag("axes")]],
    Discriminator(_points_tag, custom_error_type="points_type",
                  custom_error_message="must be a list of points [[dtheta1, dtheta2], ...] "
                                       "or {dtheta1: {start, stop, num}, dtheta2: {...}}"),
]


class WorkPrecisionStep(_Model):
    """Run time per gait against error, for kernel integrators over a tolerance ladder and
    scipy solve_ivp on a subset (``monkeystudy.precision.work_precision``). Timings depend on
    the machine and its load: this step's dataset is not bit-reproducible."""

    name: Name
    kind: Literal["work_precision"]
    points: PointsSpec = Field(description="gait start points [rad s-1]: a list or axes")
    methods: list[Literal["rk45", "dop853", "vern9", "rk45+pi", "dop853+pi", "vern9+pi"]] = Field(
        ["rk45", "dop853"], min_length=1,
        description="kernel integrators; '+pi': with the PI step-size controller")
    rtols: list[Annotated[float, Field(ge=100 * np.finfo(float).eps, lt=1.0)]] = Field(
        WORK_PRECISION_RTOLS, min_length=1, description="relative tolerances [1]")
    atol_ratio: float = Field(1e-2, gt=0, le=1.0, description="atol = rtol * atol_ratio "
                                                             "[rad, rad s-1]")
    repeat: int = Field(3, ge=1, le=100, description="timed repetitions (the best is kept)")
    scipy_methods: list[Literal["RK45", "DOP853", "LSODA"]] = Field(
        ["RK45", "DOP853", "LSODA"], min_length=1, description="scipy solve_ivp methods")
    scipy_rtols: list[Annotated[float, Field(ge=100 * np.finfo(float).eps, lt=1.0)]] = Field(
        [1e-6, 1e-8, 1e-10], min_length=1, description="scipy relative tolerances [1]")
    scipy_points: int = Field(4, ge=1, le=10_000, description="points run by scipy (the "
                              "first ones kept)")
    first_swing_only: bool = Field(True, description="keep gaits that swap on the first "
                                   "swing and end before 1.2 s (well-conditioned ones)")

    @field_validator("methods", "rtols", "scipy_methods", "scipy_rtols")
    @classmethod
    def _distinct(cls, v: list, info: ValidationInfo) -> list:
        return _unique(v, info.field_name)

    @property
    def n_points(self) -> int:
        if isinstance(self.points, PointAxes):
            return self.points.dtheta1.num * self.points.dtheta2.num
        return len(self.points)

    def point_array(self) -> np.ndarray:
        if isinstance(self.points, PointAxes):
            g1, g2 = np.meshgrid(self.points.dtheta1.values(), self.points.dtheta2.values(),
                                 indexing="ij")
            return np.stack([g1.ravel(), g2.ravel()], axis=1)
        return np.array(self.points, dtype=np.float64).reshape(-1, 2)


#: defaults of the stress step's scenarios (``monkeystudy.stress``)
STRESS_RTOLS = [1e-8, 1e-10, 1e-12]
STRESS_START = [0.902, 10.935]
STRESS_POINTS = [[0.5, 11.0], [2.0, 6.0], [5.0, -3.0], [0.1, 0.1], [0.902, 10.935]]
STRESS_CASES = ["mass_ratio_1_100", "mass_ratio_100_1", "tiny_inertia", "cg_at_the_ends",
                "huge_velocities", "coulomb_sticking"]


class EnergyDriftScenario(_Model):
    """Unforced, frictionless runs of the study's robot (``monkeystudy.stress.energy_drift``):
    relative energy drift at log-spaced checkpoints, one run per phase and tolerance."""

    phases: list[Literal["swing", "flight"]] = Field(
        ["swing", "flight"], min_length=1, description="swing: hanging from end A, started "
        "at (dtheta1, dtheta2) = (1, 0) rad s-1; flight: a tumbling free fall")
    rtols: list[Annotated[float, Field(ge=100 * np.finfo(float).eps, lt=1.0)]] = Field(
        STRESS_RTOLS, min_length=1, description="relative tolerances [1] (atol = rtol * "
                                                "atol_ratio)")
    atol_ratio: float = Field(1e-2, gt=0, le=1.0, description="atol = rtol * atol_ratio "
                                                             "[rad, rad s-1, m, m s-1]")
    periods: float = Field(10000.0, ge=10.0, le=1.0e6, description="run length in "
                           "reference periods of the phase (swing: ~1.6 s for seed2009)")
    checkpoints: int = Field(13, ge=4, le=200, description="log-spaced checkpoints from one "
                             "period to the end")

    @field_validator("phases", "rtols")
    @classmethod
    def _distinct(cls, v: list, info: ValidationInfo) -> list:
        return _unique(v, info.field_name)


class LongRunScenario(_Model):
    """The study's gait replayed for many cycles open loop (ticked and exact) and by the
    looped state-based controller (exact and ticked); every run must end with a status."""

    cycles: int = Field(1000, ge=1, le=100_000, description="cycles per run")
    start: Point = Field(STRESS_START, description="gait start (dtheta1, dtheta2) [rad s-1] "
                         "(hanging from A); the open-loop runs replay the gait evaluated here")
    tick: float = Field(1e-3, gt=0, le=1.0, description="controller tick of the ticked runs "
                                                        "[s]")
    max_drop: Optional[float] = Field(None, gt=0, description="stop ('fell') when the "
                                      "attached end sinks this far [m] (default: link 1's "
                                      "length)")
    max_steps: int = Field(20_000_000, ge=1000, le=1_000_000_000,
                           description="integrator step budget per run")


class ExtremeScenario(_Model):
    """Extreme parameters (``monkeystudy.stress.EXTREME_CASES``): status counts per case and
    whether every result marked ok is finite."""

    cases: list[Literal[tuple(STRESS_CASES)]] = Field(  # type: ignore[valid-type]
        STRESS_CASES, min_length=1, description="cases to run: " + ", ".join(STRESS_CASES))
    points: list[Point] = Field(STRESS_POINTS, min_length=1,
                                description="gait starts (dtheta1, dtheta2) [rad s-1] of "
                                            "the parameter cases")
    max_steps: int = Field(200_000, ge=1000, le=1_000_000_000,
                           description="integrator step budget per gait evaluation")

    @field_validator("cases")
    @classmethod
    def _distinct(cls, v: list) -> list:
        return _unique(v, "cases")


class StressStep(_Model):
    """Numerical stress tests (``monkeystudy.stress``): energy drift of unforced runs, long
    controller runs, extreme parameters. Every scenario runs, with its defaults unless
    given. Deterministic (no timings): the dataset is bit-reproducible."""

    name: Name
    kind: Literal["stress"]
    energy_drift: EnergyDriftScenario = Field(default_factory=EnergyDriftScenario)
    long_runs: LongRunScenario = Field(default_factory=LongRunScenario)
    extreme: ExtremeScenario = Field(default_factory=ExtremeScenario)


ANALYSIS_STEPS = (ShootStep, FloquetStep, TickSweepStep, BasinStep, ContinuationStep,
                  WorkPrecisionStep, StressStep)


Step = Annotated[Union[GridStep, RefineStep, StabilityStep, ShootStep, FloquetStep,
                       TickSweepStep, BasinStep, ContinuationStep, WorkPrecisionStep,
                       StressStep],
                 Field(discriminator="kind")]

STEP_KINDS = {"grid": GridStep, "refine": RefineStep, "stability": StabilityStep,
              "shoot": ShootStep, "floquet": FloquetStep, "tick_sweep": TickSweepStep,
              "basin": BasinStep, "continuation": ContinuationStep,
              "work_precision": WorkPrecisionStep, "stress": StressStep}


class Study(_Model):
    """A MonkeyBot study (schema version 1)."""

    model_config = ConfigDict(title="MonkeyBot study", json_schema_extra={
        "$schema": "https://json-schema.org/draft/2020-12/schema",
    })

    schema_version: Literal[1] = Field(description="version of this schema (1)")
    name: Name = Field(description="study name (output folder outputs/<name>)")
    description: str = Field("", description="free text")
    robot: RobotSpec = Field(description="a preset name or explicit parameters")
    gait: GaitSpec
    integrator: IntegratorSettings = Field(default_factory=IntegratorSettings)
    steps: list[Step] = Field(min_length=1, description="steps, run in dependency order")

    def step(self, name: str):
        for s in self.steps:
            if s.name == name:
                return s
        raise KeyError(name)


def cross_check(study: Study) -> list[tuple[tuple, str]]:
    """Checks across fields and steps: ``[(path, message), ...]`` (empty when all is well)."""
    problems: list[tuple[tuple, str]] = []
    seen: dict[str, Any] = {}
    for i, s in enumerate(study.steps):
        if s.name in seen:
            problems.append((("steps", i, "name"), f"duplicate step name {s.name!r}"))
        if isinstance(s, RefineStep) and isinstance(s.start, BestOfGrid):
            ref = seen.get(s.start.from_)
            if not isinstance(ref, GridStep):
                problems.append((("steps", i, "start", "from"),
                                 _no_earlier(s.start.from_, "grid", ref)))
            elif s.start.best > ref.n_points:
                problems.append((("steps", i, "start", "best"),
                                 f"must be <= the {ref.n_points} points of {ref.name!r}"))
        if isinstance(s, StabilityStep) and study.gait.kind != "sequence":
            if s.replay == "gait":
                problems.append((("steps", i, "replay"), "the horizontal gait is replayed "
                                 "open-loop (replay: gait needs a sequence gait)"))
            ref = seen.get(s.from_)
            if not isinstance(ref, RefineStep):
                problems.append((("steps", i, "from"), _no_earlier(s.from_, "refine", ref)))
            elif s.start_index is not None:
                k = ref.start.best if isinstance(ref.start, BestOfGrid) else 1
                if s.start_index >= k:
                    problems.append((("steps", i, "start_index"),
                                     f"must be < {k} (the starts of {ref.name!r})"))
        if study.gait.kind == "sequence":
            problems.extend(_check_sequence(study, i, s, seen))
        elif isinstance(s, ANALYSIS_STEPS):
            problems.extend(_check_analysis(study, i, s, seen))
        seen.setdefault(s.name, s)
    return problems


#: steps a sequence gait supports (the others replay or benchmark the horizontal gait)
SEQUENCE_STEPS = ("grid", "refine", "floquet", "continuation", "stability", "tick_sweep",
                  "basin")


def _check_sequence(study: Study, i: int, s, seen: dict) -> list[tuple[tuple, str]]:
    """What a study with a sequence gait can run: grid, refine, floquet from a refine,
    continuation, tick_sweep and basin from a floquet step, stability from either."""
    if s.kind not in SEQUENCE_STEPS:
        return [(("steps", i, "kind"), f"a {s.kind} step needs a horizontal gait (a sequence "
                 f"gait supports {', '.join(SEQUENCE_STEPS)})")]
    if isinstance(s, ContinuationStep):
        return _check_sequence_continuation(study, i, s, seen)
    if isinstance(s, (StabilityStep, TickSweepStep, BasinStep)):
        return _check_sequence_replay(study, i, s, seen)
    if not isinstance(s, FloquetStep):
        return []
    out: list[tuple[tuple, str]] = []
    if s.controllers_for("sequence") != ["sequence"]:
        out.append((("steps", i, "controllers"), "a sequence gait has one return map: "
                    "controllers: [sequence] (the default)"))
    if s.from_ is None or not isinstance(seen.get(s.from_), RefineStep):
        out.append((("steps", i, "from"),
                    "a sequence gait's floquet step needs from: <refine step>"
                    if s.from_ is None else _no_earlier(s.from_, "refine", seen.get(s.from_))))
    if study.gait.gait().end_attached() == "B":
        problem = mirror_problem(study)
        if problem:
            out.append((("steps", i, "kind"), f"a floquet step of a cycle ending on end B "
                        f"{problem}"))
    return out


def _check_sequence_replay(study: Study, i: int, s, seen: dict) -> list[tuple[tuple, str]]:
    """A sequence gait's multi-cycle runs start from a floquet step's fixed point (a
    stability step also from a refine step's start)."""
    out: list[tuple[tuple, str]] = []
    ref = seen.get(s.from_)
    kinds = (FloquetStep, RefineStep) if isinstance(s, StabilityStep) else (FloquetStep,)
    if not isinstance(ref, kinds):
        out.append((("steps", i, "from"), _no_earlier(
            s.from_, "floquet or refine" if isinstance(s, StabilityStep) else "floquet", ref)))
    if isinstance(s, StabilityStep):
        if s.controller.clock != "reset_at_vertical":
            out.append((("steps", i, "controller", "clock"), "a sequence gait's clock "
                        "restarts at each section crossing (reset_at_vertical)"))
        if s.start_index is not None and isinstance(ref, RefineStep):
            k = ref.start.best if isinstance(ref.start, BestOfGrid) else 1
            if s.start_index >= k:
                out.append((("steps", i, "start_index"),
                            f"must be < {k} (the starts of {ref.name!r})"))
        elif s.start_index is not None:
            out.append((("steps", i, "start_index"), "start_index picks a refine step's "
                        "start; a floquet step has one fixed point"))
    if isinstance(s, (TickSweepStep, BasinStep)) and s.solution is not None:
        out.append((("steps", i, "solution"), "solution picks a shoot step's solution; a "
                    "floquet step has one fixed point"))
    if isinstance(s, TickSweepStep) and s.floquet is not None:
        out.append((("steps", i, "floquet"), "a sequence gait's tick_sweep takes its fixed "
                    "point and multipliers from its from: floquet step"))
    if study.gait.gait().end_attached() == "B":
        problem = mirror_problem(study)
        if problem:
            out.append((("steps", i, "kind"), f"a {s.kind} step of a cycle ending on end B "
                        f"{problem}"))
    return out


def _check_sequence_continuation(study: Study, i: int, s: "ContinuationStep",
                                 seen: dict) -> list[tuple[tuple, str]]:
    out: list[tuple[tuple, str]] = []
    if not isinstance(seen.get(s.from_), FloquetStep):
        out.append((("steps", i, "from"), _no_earlier(s.from_, "floquet", seen.get(s.from_))))
    gait = study.gait.gait()
    if gait.tick != 0.0:
        out.append((("steps", i, "kind"), "continuation needs exact event timing (gait tick "
                    "0): on a tick the return map is not differentiable"))
    from .runner import study_robot

    rb = study_robot(study)
    if rb.pivot_friction.coulomb or rb.joint_friction.coulomb:
        out.append((("steps", i, "kind"), "continuation needs a smooth flow: Coulomb "
                    "friction is not (the variational equations refuse it)"))
    if s.parameter == "torque" and all(seg.torque == 0.0 for seg in gait.segments) \
            and gait.section_torque == 0.0:
        out.append((("steps", i, "parameter"), "the gait never runs its motor (every torque "
                    "is 0): the motor torque does not move its fixed points"))
    if gait.end_attached() == "B":
        if s.parameter == "mass_ratio":
            out.append((("steps", i, "parameter"), "mass_ratio != 1 breaks the mirror "
                        "symmetry a cycle ending on end B needs: continue a cycle with two "
                        "swaps (ending on A) instead"))
        problem = mirror_problem(study)
        if problem:
            out.append((("steps", i, "kind"), f"a continuation of a cycle ending on end B "
                        f"{problem}"))
    return out


def _check_analysis(study: Study, i: int, s, seen: dict) -> list[tuple[tuple, str]]:
    """References and robot requirements of the analysis steps."""
    out: list[tuple[tuple, str]] = []
    if isinstance(s, ShootStep):
        if s.from_ is not None and not isinstance(seen.get(s.from_), RefineStep):
            out.append((("steps", i, "from"), _no_earlier(s.from_, "refine",
                                                          seen.get(s.from_))))
        return out
    if isinstance(s, (WorkPrecisionStep, StressStep)):
        return out
    if s.from_ is not None and not isinstance(seen.get(s.from_), ShootStep):
        out.append((("steps", i, "from"), _no_earlier(s.from_, "shoot", seen.get(s.from_))))
    if isinstance(s, (TickSweepStep, BasinStep)) and s.replay == "gait":
        out.append((("steps", i, "replay"), "the horizontal gait is replayed open-loop "
                    "(replay: gait needs a sequence gait)"))
    if isinstance(s, TickSweepStep) and s.floquet is not None:
        ref = seen.get(s.floquet)
        if not isinstance(ref, FloquetStep):
            out.append((("steps", i, "floquet"), _no_earlier(s.floquet, "floquet", ref)))
        elif "open_loop" not in ref.controllers:
            out.append((("steps", i, "floquet"),
                        f"{ref.name!r} has no open_loop controller"))
        elif ref.from_ != s.from_:
            out.append((("steps", i, "floquet"),
                        f"{ref.name!r} analyses shoot step {ref.from_!r}, this step "
                        f"{s.from_!r}: they must be the same"))
    if isinstance(s, ContinuationStep) and s.parameter not in GRAZING_PARAMETERS:
        out.append((("steps", i, "parameter"), f"the horizontal gait's collisionless family "
                    f"is continued in {', '.join(GRAZING_PARAMETERS)} (it is motorless and "
                    f"needs mirror-image links); {s.parameter} needs a sequence gait"))
    if isinstance(s, ContinuationStep) and s.ds_max is not None:
        out.append((("steps", i, "ds_max"), "the collisionless family is continued with a "
                    "fixed step; ds_max applies to sequence gaits"))
    if isinstance(s, FloquetStep) and "sequence" in s.controllers:
        out.append((("steps", i, "controllers"), "the sequence controller needs a sequence "
                    "gait (gait: {kind: sequence, ...})"))
    if isinstance(s, (FloquetStep, ContinuationStep)):
        problem = mirror_problem(study)
        if problem:
            out.append((("steps", i, "kind"), f"a {s.kind} step {problem}"))
    return out


def mirror_problem(study: Study) -> str | None:
    """Why the study's robot cannot have one-cycle return maps (``None`` if it can).

    The frame flips to the other end at every swap, so a one-cycle return map compares like
    with like only when the links are mirror images (``monkeystudy.analysis``).
    """
    from .runner import study_robot

    par = study_robot(study).params()
    if np.allclose(par[0], par[1], rtol=0, atol=1e-14):
        return None
    return ("needs mirror-image links (same mass, length, inertia and friction; link 2's "
            "com = its length - link 1's com): the frame flips at every swap, so a one-cycle "
            "return map is defined only for them")


def _no_earlier(name: str, kind: str, found) -> str:
    if found is None:
        return f"no earlier step named {name!r}"
    return f"{name!r} is a {found.kind} step, expected a {kind} step"


def json_schema() -> dict:
    """The JSON Schema of study files (``monkeystudy schema``)."""
    return Study.model_json_schema(by_alias=True)


def resolved_max_drop(step: StabilityStep, link1_length: float) -> float:
    return step.max_drop if step.max_drop is not None else float(link1_length)


__all__ = [
    "ANALYSIS_STEPS", "Axis", "BasinOffsets", "BasinStep", "BestOfGrid", "ContinuationStep",
    "EnergyDriftScenario", "ExtremeScenario", "FMINSEARCH_TOL", "FloquetStep", "Gait",
    "GridStep", "IntegratorSettings", "LinkParams", "LongRunScenario", "PointAxes",
    "RefineStep", "RobotParams", "SCHEMA_VERSION", "SectionSpec", "SegmentSpec",
    "SequenceGaitSpec", "STEP_KINDS", "ShootStep", "StabilityStep",
    "StressStep", "Study", "TickSweepStep", "WorkPrecisionStep", "cross_check", "json_schema",
    "mirror_problem",
]
