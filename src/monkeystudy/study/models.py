"""Building blocks of the study schema: the strict base model, field types, and the robot, gait
and integrator sections of a study file (schema version 1).

Every model is a frozen pydantic v2 model with ``extra="forbid"`` and ``strict`` types: unknown
keys, a quoted ``"1e-3"`` (text, not a number), ``no`` (text, not ``false``) and non-finite
values are refused where they enter, with the key named. Units are SI and stated in every
field's description (editors show them through the exported JSON Schema, ``monkeystudy
schema``). The step models live with their step kinds (:mod:`monkeystudy.study.steps`); the
study itself in :mod:`monkeystudy.study.schema`.
"""
from __future__ import annotations

import contextvars
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Annotated, Any, ClassVar, Literal, Optional, Union

import numpy as np
from pydantic import (
    AfterValidator, BaseModel, ConfigDict, Discriminator, Field, PrivateAttr,
    SerializerFunctionWrapHandler, Tag, ValidationInfo, field_validator, model_serializer,
    model_validator,
)

from ..controllers import (
    TORQUE_FRAMES, Integrator, Segment, SequenceGait, horizontal_gait,
    torques_from_motor_frame,
)
from ..robot import PRESETS, Friction, Link, Motor, Robot, Rotor
from ..simulation import STATUS_NAMES
from ..urdf import UrdfError, check_names, load_urdf, reduce_urdf

SCHEMA_VERSION = 1

#: Names become file names (``<out>/<step>.nc``) and folder names (``outputs/<study>``).
NAME_PATTERN = r"^[A-Za-z0-9][A-Za-z0-9_.-]*$"


# Model classes seen by the "before" hook, keyed by the id of the mapping they validated, so an
# unknown-key error can list the keys its mapping allows (see loader.format_errors).
SEEN_MODELS: contextvars.ContextVar[dict | None] = contextvars.ContextVar("SEEN_MODELS",
                                                                          default=None)


class StrictModel(BaseModel):
    """Base of every study model: unknown keys, loose types and non-finite values are errors;
    instances are frozen."""

    model_config = ConfigDict(extra="forbid", frozen=True, strict=True, allow_inf_nan=False,
                              populate_by_name=True, validate_default=False)

    @model_validator(mode="before")
    @classmethod
    def _remember(cls, data: Any) -> Any:
        seen = SEEN_MODELS.get()
        if seen is not None and isinstance(data, dict):
            seen[id(data)] = cls
        return data

    @classmethod
    def allowed_keys(cls) -> list[str]:
        return [f.alias or name for name, f in cls.model_fields.items()]

    #: keys added to schema version 1 after studies without them were run: a model's dump
    #: (the ``step`` and ``gait`` attributes of its datasets, the step keys) names them only
    #: when the study file sets them, so a study that does not use them keeps its step keys
    #: and its datasets' attributes
    recorded_when_set: ClassVar[frozenset[str]] = frozenset()

    @model_serializer(mode="wrap")
    def _without_unset_later_keys(self, handler: SerializerFunctionWrapHandler) -> Any:
        data = handler(self)
        if self.recorded_when_set and isinstance(data, dict):
            fields = type(self).model_fields
            for name in self.recorded_when_set - self.model_fields_set:
                data.pop(fields[name].alias or name, None)
        return data


Name = Annotated[str, Field(pattern=NAME_PATTERN, max_length=100,
                            description="letters, digits, '_', '-', '.'; used as a file name")]
Rate = Annotated[float, Field(description="angular rate [rad s-1]")]
Point = Annotated[list[float], Field(min_length=2, max_length=2,
                                     description="(dtheta1, dtheta2) [rad s-1]")]


SectionPoint = Annotated[list[float], Field(min_length=3, max_length=3,
                                            description="(theta2 [rad], dtheta1 [rad s-1], "
                                                        "dtheta2 [rad s-1]) on the section "
                                                        "theta1 = 0")]


def unique(v: list, what: str) -> list:
    dup = sorted({repr(x) for x in v if v.count(x) > 1})
    if dup:
        raise ValueError(f"{what} must be distinct, repeated: {', '.join(dup)}")
    return v


class Axis(StrictModel):
    """``num`` evenly spaced values from ``start`` to ``stop`` inclusive (numpy.linspace)."""

    start: float = Field(description="first value [rad s-1]")
    stop: float = Field(description="last value [rad s-1]")
    num: int = Field(ge=1, le=1_000_000, description="number of values")

    @model_validator(mode="after")
    def _single(self) -> "Axis":
        if self.num == 1 and self.start != self.stop:
            raise ValueError("num: 1 needs start == stop")
        if self.start > self.stop:
            raise ValueError(f"start must not exceed stop (got start {self.start:g} > stop "
                             f"{self.stop:g}): an axis runs from start up to stop")
        return self

    def values(self) -> np.ndarray:
        return np.linspace(self.start, self.stop, self.num)


# --- robot ------------------------------------------------------------------------------------
class LinkParams(StrictModel):
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


class JointFriction(StrictModel):
    viscous: float = Field(0.0, ge=0, description="viscous coefficient [N m s]")
    coulomb: float = Field(0.0, ge=0, description="Coulomb friction torque [N m]")


class FrictionSettings(StrictModel):
    pivot: JointFriction = Field(default_factory=JointFriction,
                                 description="friction at the attached magnet (pivot)")
    joint: JointFriction = Field(default_factory=JointFriction,
                                 description="friction at the motor joint")


class RotorParams(StrictModel):
    """The joint motor's rotor (docs/model.md section 2, "The motor's rotor")."""

    inertia: float = Field(0.0, ge=0, description="the rotor's inertia about its axis [kg m2] "
                                                  "(0: no rotor)")
    gear_ratio: float = Field(1.0, gt=0, description="rotor turns per turn of the joint [1]")
    housing: Literal[1, 2] = Field(1, description="the link that holds the motor's housing")

    def to_rotor(self) -> Rotor:
        return Rotor(self.inertia, self.gear_ratio, self.housing)


class MotorParams(StrictModel):
    """The joint motor's limits (``monkeystudy.Motor``); a field left out states none (a
    URDF robot: the motor joint's ``<limit>``)."""

    torque_limit: Optional[float] = Field(None, gt=0, allow_inf_nan=False,
                                          description="the largest torque magnitude the motor "
                                                      "gives [N m]")
    speed_limit: Optional[float] = Field(None, gt=0, allow_inf_nan=False,
                                         description="the largest joint speed |dtheta2/dt| "
                                                     "[rad s-1]")

    def to_motor(self, base: Motor = Motor()) -> Motor:
        """``base`` with the limits these parameters state."""
        return Motor(base.torque_limit if self.torque_limit is None else self.torque_limit,
                     base.speed_limit if self.speed_limit is None else self.speed_limit)


class RobotParams(StrictModel):
    """Explicit robot parameters (docs/model.md section 1)."""

    name: Name = Field("custom", description="a label for the robot")
    gravity: float = Field(9.81, gt=0, description="gravitational acceleration [m s-2]")
    links: list[LinkParams] = Field(min_length=2, max_length=2,
                                    description="[link 1 (end A), link 2 (end B)]")
    friction: FrictionSettings = Field(default_factory=FrictionSettings)
    rotor: RotorParams = Field(default_factory=RotorParams,
                               description="the joint motor's rotor (none by default)")
    motor: MotorParams = Field(default_factory=MotorParams,
                               description="the joint motor's limits (none by default)")

    def to_robot(self) -> Robot:
        """The :class:`~monkeystudy.Robot` these parameters describe."""
        links = [Link(lk.mass, lk.length, lk.com, lk.inertia) for lk in self.links]
        f = self.friction
        return Robot(links[0], links[1], gravity=self.gravity,
                     pivot_friction=Friction(f.pivot.viscous, f.pivot.coulomb),
                     joint_friction=Friction(f.joint.viscous, f.joint.coulomb), name=self.name,
                     rotor=self.rotor.to_rotor(), motor=self.motor.to_motor())


def urdf_path(text: str, info: ValidationInfo) -> Path:
    """The URDF file a study names: relative to the study file's folder (the validation
    context's ``study_dir``, the working directory without one)."""
    base = Path((info.context or {}).get("study_dir", "."))
    return base / Path(text).expanduser()


def parsed_urdf(text: str, info: ValidationInfo):
    """The parsed URDF a study names, parsed once per validation (kept in the validation
    context's ``urdfs`` when there is a context); ``UrdfError`` if it cannot be read."""
    path = urdf_path(text, info)
    if info.context is None:
        return load_urdf(path)
    cache = info.context.setdefault("urdfs", {})
    key = str(path.resolve())
    if key not in cache:
        try:
            cache[key] = load_urdf(path)
        except UrdfError as exc:
            cache[key] = exc
    if isinstance(cache[key], UrdfError):
        raise cache[key]
    return cache[key]


def _urdf_name(kind: str):
    """A validator: the name is a ``kind`` (``links``, ``joints``, ``far_grip``) of the study's
    URDF (a URDF that cannot be read is reported at ``urdf``, not here)."""
    def check(name: str, info: ValidationInfo) -> str:
        text = info.data.get("urdf")
        if text is None:
            return name
        try:
            urdf = parsed_urdf(text, info)
        except UrdfError:
            return name
        problems = check_names(urdf, **{kind: name if kind == "far_grip" else [name]})
        if problems:
            raise ValueError(problems[0][1])
        return name
    return check


class UrdfRobotParams(StrictModel):
    """A robot read from a URDF file and reduced to the planar two-link model (docs/model.md
    section 1, "A robot from its URDF"): the file, which of its links and joints are the two
    links and the two joints, and the link whose origin is the far grip."""

    urdf: str = Field(min_length=1, description="the URDF file, relative to the study file's "
                                                "folder")
    links: list[Annotated[str, AfterValidator(_urdf_name("links"))]] = Field(
        min_length=2, max_length=2,
        description="URDF link names: [link 1 (hangs from the grip joint, end A), link 2]")
    joints: list[Annotated[str, AfterValidator(_urdf_name("joints"))]] = Field(
        min_length=2, max_length=2,
        description="URDF joint names: [the grip joint (end A), the motor joint]")
    far_grip: str = Field(description="the URDF link welded to link 2 whose origin is end B")
    name: Optional[Name] = Field(None, description="a label for the robot (default: the "
                                                   "URDF's robot name)")
    gravity: float = Field(9.81, gt=0, description="gravitational acceleration [m s-2]")
    friction: FrictionSettings = Field(default_factory=FrictionSettings,
                                       description="joint friction (a URDF without "
                                       "<dynamics> states none)")
    rotor: RotorParams = Field(default_factory=RotorParams,
                               description="the joint motor's rotor (a URDF does not state "
                                           "one; none by default)")
    motor: MotorParams = Field(default_factory=MotorParams,
                               description="the joint motor's limits (default: the motor "
                                           "joint's <limit effort velocity> in the URDF)")
    _robot: Robot = PrivateAttr()

    @field_validator("urdf")
    @classmethod
    def _readable(cls, v: str, info: ValidationInfo) -> str:
        try:
            parsed_urdf(v, info)
        except UrdfError as exc:
            raise ValueError(str(exc)) from None
        return v

    @field_validator("far_grip")
    @classmethod
    def _far_grip_named(cls, v: str, info: ValidationInfo) -> str:
        return _urdf_name("far_grip")(v, info)

    @model_validator(mode="after")
    def _reduced(self, info: ValidationInfo) -> "UrdfRobotParams":
        try:
            reduction = reduce_urdf(parsed_urdf(self.urdf, info), links=tuple(self.links),
                                    joints=tuple(self.joints), far_grip=self.far_grip)
        except UrdfError as exc:
            raise ValueError(str(exc)) from None
        f = self.friction
        self._robot = Robot.from_urdf(reduction, gravity=self.gravity, name=self.name,
                                      pivot_friction=Friction(f.pivot.viscous, f.pivot.coulomb),
                                      joint_friction=Friction(f.joint.viscous, f.joint.coulomb)
                                      ).with_rotor(self.rotor.to_rotor())
        self._robot = self._robot.with_motor(self.motor.to_motor(self._robot.motor))
        return self

    def to_robot(self) -> Robot:
        """The :class:`~monkeystudy.Robot` the URDF reduces to (reduced once, when the study
        was validated)."""
        return self._robot


PresetName = Literal[tuple(sorted(PRESETS))]  # type: ignore[valid-type]


def _robot_tag(v: Any) -> str | None:
    if isinstance(v, str):
        return "preset"
    if isinstance(v, UrdfRobotParams) or (isinstance(v, dict) and "urdf" in v):
        return "from_urdf"
    if isinstance(v, (dict, RobotParams)):
        return "parameters"
    return None


RobotSpec = Annotated[
    Union[Annotated[PresetName, Tag("preset")], Annotated[RobotParams, Tag("parameters")],
          Annotated[UrdfRobotParams, Tag("from_urdf")]],
    Discriminator(_robot_tag, custom_error_type="robot_type",
                  custom_error_message="must be a preset name ("
                  + ", ".join(sorted(PRESETS)) + "), a mapping with gravity, links, "
                  "friction, or a mapping with urdf, links, joints, far_grip"),
]


def to_robot(spec: str | RobotParams | UrdfRobotParams) -> Robot:
    """The robot of a study's ``robot`` field: a preset name, explicit parameters or a URDF."""
    return Robot.preset(spec) if isinstance(spec, str) else spec.to_robot()


# --- gait, integrator -------------------------------------------------------------------------
@dataclass(frozen=True)
class Conventions:
    """How the study's steps name and run a kind of gait where the 2009 study's conventions
    and a sequence gait's differ. Each gait model declares its own
    (:attr:`Gait.conventions`, :attr:`SequenceGaitSpec.conventions`); the steps read them,
    never the gait's kind.

    Attributes
    ----------
    name : str
        The gait in a message (``horizontal gait``).
    swap_motor_times : bool
        Datasets name a cycle's times as the 2009 study did, ``t_switch`` (the swap),
        ``t_motor`` (the motor phase), ``t_end`` (the vertical; NaN when the cycle fails), and
        say whether the swap comes on the first swing (``vertical_passes``); else per segment,
        ``t_segment`` (dim ``segment``), with the cycle's advance.
    replay : str
        How a multi-cycle step runs the gait by default (``open_loop``: its recorded
        schedule; ``gait``: its own controller).
    replays : tuple of str
        The replays stability, tick_sweep and basin steps accept.
    clocks : tuple of str
        The open-loop clock modes a multi-cycle step accepts (``controller.clock``).
    clock : str
        How datasets name a clock restarting at each cycle's end.
    floquet_controllers : tuple of str
        The return maps a floquet step analyses (its default, and all it accepts): the
        open-loop replay of a shoot step's gait (``open_loop``), the gait's own controller
        polished from ``search_start`` (``search``) or from a refine step's start
        (``sequence``).
    """

    name: str
    swap_motor_times: bool
    replay: str
    replays: tuple[str, ...]
    clocks: tuple[str, ...]
    clock: str
    floquet_controllers: tuple[str, ...]


#: the horizontal gait's conventions: the 2009 study's
HORIZONTAL_CONVENTIONS = Conventions(
    name="horizontal gait", swap_motor_times=True, replay="open_loop", replays=("open_loop",),
    clocks=("reset_at_vertical", "run_on"), clock="reset_at_vertical",
    floquet_controllers=("open_loop", "search"))

#: a sequence gait's conventions
SEQUENCE_CONVENTIONS = Conventions(
    name="sequence gait", swap_motor_times=False, replay="gait", replays=("gait", "open_loop"),
    clocks=("reset_at_vertical",), clock="reset_at_section",
    floquet_controllers=("sequence",))


class Gait(StrictModel):
    """The gait and its search controller (docs/model.md section 4)."""

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

    #: how the study's steps name and run it
    conventions: ClassVar[Conventions] = HORIZONTAL_CONVENTIONS

    def gait(self) -> SequenceGait:
        """The horizontal gait as the phase sequence every step runs
        (:func:`~monkeystudy.controllers.horizontal_gait`)."""
        return horizontal_gait(self.motor_torque, self.tick)


GuardName = Literal["time", "free_end_height", "energy_restored", "coord", "energy",
                    "free_end_y", "bar", "none"]
CoordName = Literal["x", "y", "theta1", "theta2", "dx", "dy", "dtheta1", "dtheta2"]
Direction = Literal["rising", "falling", "either"]

#: the status a segment's horizon reports, by guard (the study's names where they fit)
SEGMENT_FAIL = {"free_end_height": "no_switch", "energy_restored": "energy_not_restored"}


class BarSpec(StrictModel):
    """The bar a ``until: bar`` segment catches, from the bar the robot hangs from (docs/model.md
    section 6, "A catch on a bar"): a ladder's equal spacing is ``dx`` = the spacing, a higher
    bar ``dy`` > 0, a missing bar ``dx`` = two spacings."""

    dx: float = Field(description="the bar's horizontal offset from the attached end [m], "
                                  "world x, signed by the direction of travel")
    dy: float = Field(0.0, description="the bar's height above the bar the robot hangs "
                                       "from [m]")
    window: float = Field(gt=0.0, le=1.0, description="the largest horizontal distance of "
                          "the free end from the bar at which the hook catches it [m]")


class SegmentSpec(StrictModel):
    """One segment of a phase-sequence gait (``monkeystudy.controllers.Segment``): entry
    actions (magnets, motor torque, energy latch), then the guard that ends it."""

    until: GuardName = Field(description="guard ending the segment: time (value [s] on the "
                             "controller clock, which restarts at the section), "
                             "free_end_height (free end value [m] above the attached end), "
                             "energy_restored (energy back to the latched reference + value "
                             "[J]), coord (coord crosses value), energy (total energy "
                             "crosses value [J]), free_end_y (free end's world height "
                             "crosses value [m]), bar (the hook comes down onto the bar "
                             "given by bar), none (only the horizon)")
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
    clock: Literal["keep", "reset"] = Field(
        "keep", description="the controller clock at this segment's exit: keep it, or reset "
                            "it (it restarts there, so the time guards of the segments after "
                            "it count from this exit, e.g. a pulse timed from a catch)")

    bar: Optional[BarSpec] = Field(None, description="the bar an until: bar segment catches "
                                   "(dx, dy, window [m]); a catch is physical: never on the "
                                   "tick, falling, no value, direction or ticked of its own")

    recorded_when_set: ClassVar[frozenset[str]] = frozenset({"clock", "bar"})

    @model_validator(mode="after")
    def _bar(self) -> "SegmentSpec":
        if self.until == "bar":
            if self.bar is None:
                raise ValueError("until: bar needs bar: {dx, dy, window} [m]")
            stray = sorted({"value", "direction", "coord", "ticked"} & self.model_fields_set)
            if stray:
                raise ValueError(f"until: bar takes its bar from bar: {{dx, dy, window}}; "
                                 f"{', '.join(stray)} do not apply")
        elif self.bar is not None:
            raise ValueError(f"bar applies only to until: bar (got until: {self.until})")
        return self

    def segment(self) -> Segment:
        fail = STATUS_NAMES.index(SEGMENT_FAIL.get(self.until, "horizon"))
        if self.until == "bar":
            return Segment("bar", value=self.bar.dy, direction="falling",
                           magnets=self.magnets, torque=self.torque,
                           latch_energy=self.latch_energy, ticked=False, clock=self.clock,
                           fail_status=fail, bar_dx=self.bar.dx, bar_window=self.bar.window)
        return Segment(self.until, value=self.value, coord=self.coord,
                       direction=self.direction, magnets=self.magnets, torque=self.torque,
                       latch_energy=self.latch_energy, ticked=self.ticked, clock=self.clock,
                       fail_status=fail)


class SectionSpec(StrictModel):
    """The Poincare section closing a sequence gait's cycle, and the start on it."""

    theta1: float = Field(0.0, ge=-3.2, le=3.2, description="link 1 angle of the section "
                          "[rad], in the frame of the end attached there (0: vertical)")
    direction: Direction = Field("either", description="crossing direction that ends the "
                                                       "cycle")
    torque: float = Field(0.0, description="motor torque on the last leg, up to the section "
                                           "[N m]")
    theta2: float = Field(0.0, ge=-3.2, le=3.2, description="link 2 angle at the cycle start "
                          "[rad] (grid and refine vary dtheta1, dtheta2; floquet frees it)")


class SequenceGaitSpec(StrictModel):
    """A gait written as a phase sequence (``monkeystudy.controllers.SequenceGait``): from the
    section hanging from A, the segments in order, then the section ends the cycle. Gait
    error: the section error, wrap(theta2_f - theta2)^2 + (dtheta1_f - dtheta1)^2 +
    (dtheta2_f - dtheta2)^2."""

    #: how the study's steps name and run it
    conventions: ClassVar[Conventions] = SEQUENCE_CONVENTIONS

    kind: Literal["sequence"] = Field(description="the gait: 'sequence' (a phase sequence)")
    segments: list[SegmentSpec] = Field(min_length=1, max_length=64,
                                        description="the cycle's segments, in order")
    section: SectionSpec = Field(default_factory=SectionSpec)
    tick: float = Field(0.0, ge=0, le=1.0, description="controller tick [s]; 0 = exact "
                                                       "event timing")
    torque_frame: Literal[TORQUE_FRAMES] = Field(  # type: ignore[valid-type]
        "attached_end", description="the frame the segments' and the section's torques [N m] "
                                    "are written in: attached_end (on theta2 of the frame of "
                                    "the end attached at the time: the sign flips with the "
                                    "frame at a swap) or motor (the physical motor torque, "
                                    "its sign fixed to the links for the whole cycle: a "
                                    "torque after a swap within the cycle is negated when the "
                                    "gait is built)")
    rise: float = Field(0.0, ge=-10.0, le=10.0, description="the route's planned height "
                        "rises by this per cycle [m] (< 0: it descends): in cycle k from "
                        "the start (k = 0, 1, ...) every free_end_y guard's world height "
                        "is its value + k * rise, a staircase fixed in the world (a catch "
                        "late in one step is corrected in the next); the full map's height, "
                        "a fall (max_drop) and a survival run's height drift are measured "
                        "from it")

    recorded_when_set: ClassVar[frozenset[str]] = frozenset({"torque_frame", "rise"})

    @field_validator("rise")
    @classmethod
    def _rise_moves_a_world_height(cls, v: float, info: ValidationInfo) -> float:
        segments = info.data.get("segments") or []
        if v != 0.0 and not any(s.until == "free_end_y" for s in segments):
            raise ValueError("a rise moves the world heights of the free_end_y guards; this "
                             "gait has none (a free_end_height catch repeats its height "
                             "above the attached end by itself)")
        return v

    @model_validator(mode="after")
    def _closes(self) -> "SequenceGaitSpec":
        self.gait()  # a cycle that reaches its section in flight or pinned is refused here
        return self

    @property
    def motor_torque(self) -> float:
        """NaN: a sequence gait's segments carry their own torques."""
        return math.nan

    def gait(self) -> SequenceGait:
        """The gait the kernel runs: its torques in the kernel's frame (converted from the
        motor frame when ``torque_frame`` is ``motor``,
        :func:`~monkeystudy.controllers.torques_from_motor_frame`)."""
        sec = self.section
        gait = SequenceGait([s.segment() for s in self.segments], section_theta1=sec.theta1,
                            section_direction=sec.direction, section_torque=sec.torque,
                            theta2=sec.theta2, tick=self.tick, rise=self.rise)
        return torques_from_motor_frame(gait) if self.torque_frame == "motor" else gait


#: the study's ``gait``: the horizontal gait or a sequence gait
StudyGait = Annotated[Union[Gait, SequenceGaitSpec], Field(discriminator="kind")]


class IntegratorSettings(StrictModel):
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

    def to_integrator(self) -> Integrator:
        """The :class:`~monkeystudy.Integrator` of these settings."""
        return Integrator(method=self.method, rtol=self.rtol, atol=self.atol,
                          max_time=self.max_time, controller=self.controller)


#: how a multi-cycle step runs the gait (``monkeystudy.analysis.replay``)
Replay = Annotated[Optional[Literal["gait", "open_loop"]], Field(
    description="how the gait is run: open_loop (its recorded segment times, the clock "
                "restarting at each section crossing; the horizontal gait's only replay and "
                "its default) or gait (a sequence gait's own controller, guards and all; a "
                "sequence gait's default)")]


class OpenLoopSettings(StrictModel):
    tick: Optional[float] = Field(None, ge=0, le=1.0,
                                  description="controller tick [s] (default: the gait's)")
    clock: Literal["reset_at_vertical", "run_on"] = Field(
        "reset_at_vertical", description="restart the clock at each vertical crossing, or "
                                         "let it run on with period = the gait's t_end")

