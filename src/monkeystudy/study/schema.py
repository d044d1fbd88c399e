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


class IntegratorSettings(_Model):
    """Integrator settings (scipy ``solve_ivp`` semantics for rtol/atol)."""

    method: Literal["dop853", "rk45"] = Field("dop853", description="Runge-Kutta pair")
    rtol: float = Field(1e-10, ge=100 * np.finfo(float).eps, lt=1.0,
                        description="relative tolerance [1]")
    atol: float = Field(1e-12, gt=0, description="absolute tolerance [rad, rad s-1]")
    max_time: float = Field(3.0, gt=0, le=1.0e4,
                            description="horizon of one controller phase [s]")


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
    block_size: int = Field(512, ge=1, le=1_000_000,
                            description="points per block (unit of work and of resume)")
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
    def n_blocks(self) -> int:
        return -(-self.n_points // self.block_size)


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
    from_: Name = Field(alias="from", description="an earlier refine step")
    cycles: int = Field(ge=1, le=100_000, description="number of cycles")
    controller: OpenLoopSettings = Field(default_factory=OpenLoopSettings)
    start_index: Optional[int] = Field(None, ge=0, description="which start of a multi-start "
                                       "refine step (default: the lowest error)")
    sample_dt: float = Field(0.005, gt=0, le=1.0,
                             description="trajectory sampling interval [s]")
    max_drop: Optional[float] = Field(None, gt=0, description="stop ('fell') when the "
                                      "attached end sinks this far [m] (default: link 1's "
                                      "length)")


Step = Annotated[Union[GridStep, RefineStep, StabilityStep], Field(discriminator="kind")]

STEP_KINDS = {"grid": GridStep, "refine": RefineStep, "stability": StabilityStep}


class Study(_Model):
    """A MonkeyBot study (schema version 1)."""

    model_config = ConfigDict(title="MonkeyBot study", json_schema_extra={
        "$schema": "https://json-schema.org/draft/2020-12/schema",
    })

    schema_version: Literal[1] = Field(description="version of this schema (1)")
    name: Name = Field(description="study name (output folder outputs/<name>)")
    description: str = Field("", description="free text")
    robot: RobotSpec = Field(description="a preset name or explicit parameters")
    gait: Gait
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
        if isinstance(s, StabilityStep):
            ref = seen.get(s.from_)
            if not isinstance(ref, RefineStep):
                problems.append((("steps", i, "from"), _no_earlier(s.from_, "refine", ref)))
            elif s.start_index is not None:
                k = ref.start.best if isinstance(ref.start, BestOfGrid) else 1
                if s.start_index >= k:
                    problems.append((("steps", i, "start_index"),
                                     f"must be < {k} (the starts of {ref.name!r})"))
        seen.setdefault(s.name, s)
    return problems


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
    "Axis", "BestOfGrid", "FMINSEARCH_TOL", "Gait", "GridStep", "IntegratorSettings",
    "LinkParams", "RefineStep", "RobotParams", "SCHEMA_VERSION", "STEP_KINDS", "StabilityStep",
    "Study", "cross_check", "json_schema",
]
