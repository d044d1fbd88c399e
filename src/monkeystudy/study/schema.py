"""The study file schema (version 1): a study names a robot, a gait with its controller settings,
an integrator and a list of steps.

The models are strict, frozen pydantic v2 models (:mod:`monkeystudy.study.models`); each step
kind brings its own (:mod:`monkeystudy.study.steps`). Everything is checked here, before any
work: unknown keys, wrong types, non-finite or non-physical values, empty grids, and references
between steps (:func:`cross_check`, which asks each step's kind).
:mod:`monkeystudy.study.loader` turns the errors into ``file:line: key: message`` lines.
"""
from __future__ import annotations

from typing import Annotated, Any, Literal, Union

from pydantic import ConfigDict, Field

from ..robot import Robot
from .models import (
    SCHEMA_VERSION, IntegratorSettings, Name, RobotSpec, StrictModel, StudyGait, to_robot,
)
from .figures import figure_name_clash
from .steps import REGISTRY

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
    robot: RobotSpec = Field(description="a preset name or explicit parameters")
    gait: StudyGait
    integrator: IntegratorSettings = Field(default_factory=IntegratorSettings)
    steps: list[Step] = Field(min_length=1, description="steps, run in dependency order")

    def step(self, name: str):
        for s in self.steps:
            if s.name == name:
                return s
        raise KeyError(name)

    def to_robot(self) -> Robot:
        """The study's :class:`~monkeystudy.Robot` (a preset or its explicit parameters)."""
        return to_robot(self.robot)


def cross_check(study: Study) -> list[tuple[tuple, str]]:
    """Checks across fields and steps: ``[(path, message), ...]`` (empty when all is well).

    Step names must be unique, and so must the names of the figures they make
    (:func:`figure_name_clash`); a step whose kind does not support the study's gait is
    refused; every other check is the step kind's own (:meth:`~monkeystudy.study.steps.base.
    StepKind.check`), given the earlier steps by name.
    """
    gait = study.gait.kind
    supported = ", ".join(k.name for k in REGISTRY.values() if gait in k.gait_kinds)
    problems: list[tuple[tuple, str]] = []
    seen: dict[str, Any] = {}
    figures: dict[str, tuple[str, str, str]] = {}
    for i, s in enumerate(study.steps):
        if s.name in seen:
            problems.append((("steps", i, "name"), f"duplicate step name {s.name!r}"))
        else:
            clash = figure_name_clash(s, figures)
            if clash:
                problems.append((("steps", i, "name"), clash))
        kind = REGISTRY[s.kind]
        if gait not in kind.gait_kinds:
            problems.append((("steps", i, "kind"), f"a {s.kind} step needs a "
                             f"{' or '.join(kind.gait_kinds)} gait (a {gait} gait supports "
                             f"{supported})"))
        else:
            problems.extend(kind.check(study, i, s, seen))
        seen.setdefault(s.name, s)
    return problems


def json_schema() -> dict:
    """The JSON Schema of study files (``monkeystudy schema``)."""
    return Study.model_json_schema(by_alias=True)


__all__ = ["SCHEMA_VERSION", "Step", "Study", "cross_check", "json_schema"]
