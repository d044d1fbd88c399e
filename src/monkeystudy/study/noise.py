"""The noise a study states for runs of a gait (``noise:`` of a survival step, ``screen.noise``
of a design step): each source off (0) by default, one value or one per noise level, turned
into :class:`~monkeystudy.analysis.survival.Noise` per level. The sources, where a study states
each, their descriptions and bounds are those :data:`~monkeystudy.analysis.survival.SOURCES`
declares: :class:`NoiseSpec`'s fields are made from them."""
from __future__ import annotations

import math
from typing import Annotated, ClassVar, Literal, Union

from pydantic import BeforeValidator, Field, create_model, model_validator

from ..analysis.survival import SOURCES, Noise
from .models import StrictModel


def noise_value(v):
    """A noise value: a number >= 0, or a non-empty list of them (one per level)."""
    def number(x, where=""):
        if isinstance(x, bool) or not isinstance(x, (int, float)):
            raise ValueError(f"must be a number >= 0 or a list of them, got {x!r}{where}")
        if not (math.isfinite(x) and x >= 0):
            raise ValueError(f"must be finite and >= 0, got {x!r}{where}")
        return float(x)
    if isinstance(v, list):
        if not v:
            raise ValueError("an empty list (give a value, or one per noise level)")
        return [number(x, f" (entry {i})") for i, x in enumerate(v)]
    return number(v)


#: a noise value: one level, or one per level (all lists of a step have the same length)
Level = Annotated[Union[float, list[float]], BeforeValidator(noise_value)]


def level_field(description: str, bound: float | None = None):
    return Field(0.0, description=description + " (one value, or a list: one per noise "
                 "level)" + (f"; at most {bound}" if bound is not None else ""))


#: the models of the groups of sources (a source's ``key`` of two parts: group, name), by the
#: group's key: (model name, what the group is)
GROUPS = {
    "sensor": ("SensorNoise", "Sensor noise on what the controller's state guards read, one "
                              "draw per guarded action (a Gaussian's standard deviation, a "
                              "uniform's half-width)."),
    "parameters": ("ParameterNoise", "Robot parameters drawn once per run, relative to the "
                                     "study's robot."),
    "initial_state": ("InitialNoise", "Perturbation of the start on the section, once per run."),
    "friction": ("FrictionNoise", "Friction drawn once per run, absolute, about the study's "
                                  "robot's (a draw below zero is zero)."),
}


def _source_field(source) -> tuple:
    return (Level, level_field(source.described, source.bound))


def _fields() -> dict[str, tuple]:
    """The fields of :class:`NoiseSpec` from the sources, each group a model of its own, in
    the order the sources come."""
    out: dict[str, tuple] = {}
    for group in dict.fromkeys(s.key[0] for s in SOURCES if len(s.key) == 2):
        name, doc = GROUPS[group]
        model = create_model(name, __base__=StrictModel, __doc__=doc,
                             **{s.key[1]: _source_field(s) for s in SOURCES
                                if s.key[0] == group})
        out[group] = (model, Field(default_factory=model))
    return {s.key[0]: (out[s.key[0]] if len(s.key) == 2 else _source_field(s))
            for s in SOURCES}


class NoiseLevels(StrictModel):
    """What a study's noise does with its sources (:class:`NoiseSpec` adds them as fields):
    check them, count its levels, give each level's
    :class:`~monkeystudy.analysis.survival.Noise`."""

    distribution: Literal["gaussian", "uniform"] = Field(
        "gaussian", description="shape of every draw: gaussian (the value is the standard "
                                "deviation) or uniform (the value is the half-width)")

    recorded_when_set: ClassVar[frozenset[str]] = frozenset({"latency", "friction",
                                                             "bar_spacing"})

    def value(self, path: tuple) -> Level:
        node = self
        for key in path:
            node = getattr(node, key)
        return node

    @model_validator(mode="after")
    def _levels(self) -> "NoiseLevels":
        lengths = {}
        for s in SOURCES:
            v = self.value(s.key)
            if isinstance(v, list):
                lengths[".".join(s.key)] = len(v)
            if s.bound is not None and max(v if isinstance(v, list) else [v]) > s.bound:
                raise ValueError(f"noise.{'.'.join(s.key)} must be <= {s.bound}")
        if len(set(lengths.values())) > 1:
            listed = ", ".join(f"noise.{k} has {n}" for k, n in lengths.items())
            raise ValueError(f"every list of noise levels must have the same length: {listed}")
        return self

    @property
    def n_levels(self) -> int:
        for s in SOURCES:
            v = self.value(s.key)
            if isinstance(v, list):
                return len(v)
        return 1

    def level(self, i: int) -> Noise:
        """The :class:`~monkeystudy.analysis.survival.Noise` of level ``i``."""
        kw = {}
        for s in SOURCES:
            v = self.value(s.key)
            kw[s.name] = float(v[i] if isinstance(v, list) else v)
        return Noise(distribution=self.distribution, **kw)

    def swept(self) -> list[str]:
        """The sources given as lists (the ones the levels sweep), by Noise field name."""
        return [s.name for s in SOURCES if isinstance(self.value(s.key), list)]


#: the noise sources of runs of a gait, as a study file states them
NoiseSpec = create_model("NoiseSpec", __base__=NoiseLevels,
                         __doc__="The noise sources of runs of a gait, each off (0) by default.",
                         **_fields())


__all__ = ["GROUPS", "Level", "NoiseLevels", "NoiseSpec", "SOURCES", "level_field",
           "noise_value"]
