"""The study file schema (version 1): a study names a robot, a gait with its controller settings,
an integrator and a list of steps; a study whose steps run no gait (:attr:`~monkeystudy.study.
steps.base.StepKind.runs_gait`: hardware_replay) has no gait.

The models are strict, frozen pydantic v2 models (:mod:`monkeystudy.study.models`); each step
kind brings its own (:mod:`monkeystudy.study.steps`). Everything is checked here, before any
work: unknown keys, wrong types, non-finite or non-physical values, empty grids, and references
between steps (:func:`cross_check`, which asks each step's kind).
:mod:`monkeystudy.study.loader` turns the errors into ``file:line: key: message`` lines.
"""
from __future__ import annotations

from typing import Annotated, Any, Literal, Optional, Union

from pydantic import ConfigDict, Field, TypeAdapter, ValidationError

from ..robot import Robot
from .models import (
    SCHEMA_VERSION, IntegratorSettings, Name, RobotSpec, StrictModel, StudyGait, to_robot,
)
from .figures import figure_name_clash
from .steps import REGISTRY
from .steps.base import kinds_text, no_earlier, source_name
from .wall_spec import WallSpec, wall_problems

#: a step of any registered kind (pydantic picks the model by ``kind``)
Step = Annotated[Union[tuple(k.model for k in REGISTRY.values())],  # type: ignore[misc]
                 Field(discriminator="kind")]


class Study(StrictModel):
    """A MonkeyBot study (schema version 1)."""

    model_config = ConfigDict(title="MonkeyBot study", json_schema_extra={
        "$schema": "https://json-schema.org/draft/2020-12/schema",
    })

    schema_version: Literal[1] = Field(description="version of this schema (1)")
    name: Name = Field(description="study name (output folder outputs/<name>)")
    description: str = Field("", description="free text")
    robot: RobotSpec = Field(description="a preset name, explicit parameters or a URDF file")
    gait: Optional[StudyGait] = Field(
        None, description="the gait the steps run, with its controller settings (required "
                          "unless no step runs one: " + ", ".join(
                              k.name for k in REGISTRY.values() if not k.runs_gait) + ")")
    integrator: IntegratorSettings = Field(default_factory=IntegratorSettings)
    steps: list[Step] = Field(min_length=1, description="steps, run in dependency order")
    wall: Optional[WallSpec] = Field(None, description="the wall the robot climbs: steel "
                                     "regions with holes, the start and the goal (the route "
                                     "planner's input, docs/route.md; no step reads it)")

    def step(self, name: str):
        for s in self.steps:
            if s.name == name:
                return s
        raise KeyError(name)

    def to_robot(self) -> Robot:
        """The study's :class:`~monkeystudy.Robot` (a preset, its explicit parameters or its
        URDF's reduction)."""
        return to_robot(self.robot)


#: a problem across fields or steps: (path of the key in the study file, message)
Problem = tuple[tuple, str]

#: validates one step of any kind
STEP = TypeAdapter(Step)
#: validates a ``wall:`` block
WALL = TypeAdapter(WallSpec)


def cross_check(study: Study) -> list[Problem]:
    """Checks across fields and steps: ``[(path, message), ...]`` (empty when all is well).

    Step names must be unique, and so must the names of the figures they make
    (:func:`figure_name_clash`); a step whose kind does not support the study's gait is
    refused, and so is a study without a gait whose steps run one (:attr:`~monkeystudy.study.
    steps.base.StepKind.runs_gait`); every other check is the step kind's own
    (:meth:`~monkeystudy.study.steps.base.StepKind.check`), given the earlier steps by name;
    the ``wall:`` block's start is on steel (:func:`wall_problems`).
    """
    return motor_problems(study) + wall_problems(study.wall) + \
        _check_steps(study, list(enumerate(study.steps)), {})


def motor_problems(study: Study) -> list[Problem]:
    """Each torque of the study's gait [N m] larger than its robot's motor gives
    (``robot.motor.torque_limit``; a robot whose motor states no limit has none)."""
    gait = study.gait
    if gait is None:
        return []
    limit = study.to_robot().motor.torque_limit
    torques = ([(("gait", "motor_torque"), gait.motor_torque)] if gait.kind == "horizontal"
               else [(("gait", "segments", k, "torque"), seg.torque)
                     for k, seg in enumerate(gait.segments)]
               + [(("gait", "section", "torque"), gait.section.torque)])
    return [(path, f"{abs(tau)!r} N m is more than the robot's motor gives (its torque_limit "
                   f"{limit!r} N m)") for path, tau in torques if abs(tau) > limit]


def cross_check_parts(data: Any, context: dict | None = None) -> list[Problem]:
    """The checks of :func:`cross_check` that a study whose fields are not all valid still
    allows (``data``: the study file as plain Python), so that one pass reports them with
    the field errors: every valid step is checked against the others, but a step that
    depends on an earlier step that is not valid (its kind's checks would need that step)
    is not; with the robot, gait or integrator not valid, only the steps' names and their
    ``from:`` (it names an earlier step of a kind it accepts) are checked; a valid ``wall:``
    block is checked whatever else is not valid (:func:`wall_problems`). ``context`` is the
    validation context (:func:`monkeystudy.study.loader.parse_study`'s: the study file's
    folder, which a robot's URDF path is relative to).
    """
    walls = _wall_parts(data)
    steps = data.get("steps") if isinstance(data, dict) else None
    if not isinstance(steps, list):
        return walls
    valid: list[tuple[int, Any]] = []
    invalid: dict[str, int] = {}      # the names of steps that are not valid, first index
    for i, raw in enumerate(steps):
        try:
            valid.append((i, STEP.validate_python(raw)))
        except ValidationError:
            name = raw.get("name") if isinstance(raw, dict) else None
            if isinstance(name, str):
                invalid.setdefault(name, i)
    if not valid:
        return walls
    try:
        study = Study.model_validate(dict(data, steps=[steps[i] for i, _ in valid]),
                                     context=context)
    except ValidationError:
        study = None
    return (motor_problems(study) if study is not None else []) + walls + \
        _check_steps(study, valid, invalid)


def _wall_parts(data: Any) -> list[Problem]:
    """:func:`wall_problems` of the study's ``wall:`` block when the block itself is valid."""
    raw = data.get("wall") if isinstance(data, dict) else None
    if raw is None:
        return []
    try:
        return wall_problems(WALL.validate_python(raw))
    except ValidationError:
        return []        # the block's own errors are the field errors


def _check_steps(study: Study | None, steps: list[tuple[int, Any]],
                 invalid: dict[str, int]) -> list[Problem]:
    """:func:`cross_check` of ``steps`` (valid steps at their index in the file) in a study
    whose steps named in ``invalid`` (at their index) are not valid; ``study`` None: its
    robot, gait or integrator are not valid either."""
    gait = study.gait.kind if study is not None and study.gait is not None else None
    supported = ", ".join(k.name for k in REGISTRY.values() if gait in k.gait_kinds)
    problems: list[Problem] = []
    need_gait: list[str] = []    # the steps that run a gait the study does not have
    seen: dict[str, Any] = {}
    figures: dict[str, tuple[str, str, str]] = {}
    for i, s in steps:
        if s.name in seen or invalid.get(s.name, i) < i:
            problems.append((("steps", i, "name"), f"duplicate step name {s.name!r}"))
        else:
            clash = figure_name_clash(s, figures)
            if clash:
                problems.append((("steps", i, "name"), clash))
        kind = REGISTRY[s.kind]
        # a step built on an earlier step that is not valid cannot be judged against it
        judged = not any(invalid.get(d, i) < i for d in kind.deps(s))
        if study is None:
            if judged:
                problems.extend(_from_problems(kind, i, s, seen))
        elif study.gait is None and kind.runs_gait:
            need_gait.append(f"{s.name!r} ({s.kind})")   # its checks would read the gait
        elif study.gait is None:
            if judged:
                problems.extend(kind.check(study, i, s, seen))
        elif gait not in kind.gait_kinds:
            problems.append((("steps", i, "kind"), f"a {s.kind} step needs a "
                             f"{' or '.join(kind.gait_kinds)} gait (a {gait} gait supports "
                             f"{supported})"))
        elif judged:
            problems.extend(kind.check(study, i, s, seen))
        seen.setdefault(s.name, s)
    if need_gait:
        many = len(need_gait) > 1
        gaitless = kinds_text([k.name for k in REGISTRY.values() if not k.runs_gait])
        names = " and ".join([", ".join(need_gait[:-1]), need_gait[-1]] if many else need_gait)
        problems.append((("gait",), f"required key missing: step{'s' if many else ''} {names} "
                         f"run{'' if many else 's'} the study's gait (only {gaitless} steps "
                         f"run none)"))
    return problems


def _from_problems(kind, index: int, step, seen: dict[str, Any]) -> list[Problem]:
    """The first check of :meth:`~monkeystudy.study.steps.base.StepKind.check` alone (what
    a study without a valid gait allows): its ``from:`` names an earlier step of a kind it
    accepts."""
    name = source_name(step)
    if name is None or not kind.accepts:
        return []
    ref = seen.get(name)
    if ref is not None and ref.kind in kind.accepts:
        return []
    return [(("steps", index) + kind.from_key, no_earlier(name, kinds_text(kind.accepts), ref))]


def json_schema() -> dict:
    """The JSON Schema of study files (``monkeystudy schema``)."""
    return Study.model_json_schema(by_alias=True)


__all__ = ["SCHEMA_VERSION", "Problem", "Step", "Study", "cross_check", "cross_check_parts",
           "json_schema", "motor_problems"]
