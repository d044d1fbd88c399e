"""The noise a study states for runs of a gait (``noise:`` of a survival step, ``screen.noise``
of a design step): each source off (0) by default, one value or one per noise level, turned
into :class:`~monkeystudy.analysis.survival.Noise` per level."""
from __future__ import annotations

import math
from typing import Annotated, ClassVar, Literal, Union

from pydantic import BeforeValidator, Field, model_validator

from ..analysis.survival import Noise
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



#: every noise source: (path in the step's ``noise``, Noise field, units, what it is)
SOURCES = (
    (("timing",), "timing", "s", "actuation timing jitter"),
    (("sensor", "angle"), "angle", "rad", "sensor noise on angle guards"),
    (("sensor", "rate"), "rate", "rad s-1", "sensor noise on rate guards"),
    (("sensor", "height"), "height", "m", "sensor noise on height guards"),
    (("sensor", "energy"), "energy", "J", "sensor noise on energy guards"),
    (("torque",), "torque", "1", "relative torque error of each motor pulse"),
    (("parameters", "mass"), "mass", "1", "relative uncertainty of each link's mass"),
    (("parameters", "com"), "com", "1", "relative uncertainty of each link's CG position"),
    (("parameters", "inertia"), "inertia", "1", "relative uncertainty of each link's inertia"),
    (("initial_state", "theta2"), "theta2", "rad", "perturbation of the start's theta2"),
    (("initial_state", "dtheta1"), "dtheta1", "rad s-1",
     "perturbation of the start's dtheta1"),
    (("initial_state", "dtheta2"), "dtheta2", "rad s-1",
     "perturbation of the start's dtheta2"),
    (("latency",), "latency", "s", "actuation latency, drawn once per run uniformly on [0, "
     "value): the upper end of its range"),
)

#: sources whose value is not a draw's scale of the step's distribution
UNIFORM_PER_RUN = ("latency",)


def level_field(description: str, bound: float | None = None):
    return Field(0.0, description=description + " (one value, or a list: one per noise "
                 "level)" + (f"; at most {bound}" if bound is not None else ""))


class SensorNoise(StrictModel):
    """Sensor noise on what the controller's state guards read, one draw per guarded
    action (a Gaussian's standard deviation, a uniform's half-width)."""

    angle: Level = level_field("angles (coordinate guards on theta1, theta2) [rad]")
    rate: Level = level_field("angular rates (guards on dtheta1, dtheta2) [rad s-1]")
    height: Level = level_field("heights (free-end height guards, x or y guards) [m]")
    energy: Level = level_field("energies (energy and energy-restored guards) [J]")


class ParameterNoise(StrictModel):
    """Robot parameters drawn once per run, relative to the study's robot."""

    mass: Level = level_field("relative uncertainty of each link's mass [1]", 0.5)
    com: Level = level_field("relative uncertainty of each link's CG position [1] (the CG "
                              "is kept on the link)", 0.5)
    inertia: Level = level_field("relative uncertainty of each link's inertia [1]", 0.5)


class InitialNoise(StrictModel):
    """Perturbation of the start on the section, once per run."""

    theta2: Level = level_field("theta2 [rad]")
    dtheta1: Level = level_field("dtheta1 [rad s-1]")
    dtheta2: Level = level_field("dtheta2 [rad s-1]")


class NoiseSpec(StrictModel):
    """The noise sources of runs of a gait, each off (0) by default."""

    distribution: Literal["gaussian", "uniform"] = Field(
        "gaussian", description="shape of every draw: gaussian (the value is the standard "
                                "deviation) or uniform (the value is the half-width)")
    timing: Level = level_field("actuation timing jitter per magnet or motor action [s]: a "
                                 "scheduled action moves early or late, an action triggered "
                                 "by a sensed state waits the draw's magnitude", 1.0)
    sensor: SensorNoise = Field(default_factory=SensorNoise)
    torque: Level = level_field("relative torque error of each motor pulse [1]", 1.0)
    parameters: ParameterNoise = Field(default_factory=ParameterNoise)
    initial_state: InitialNoise = Field(default_factory=InitialNoise)
    latency: Level = level_field("actuation latency [s]: each run draws one value uniformly "
                                  "on [0, latency) (uniform whatever the distribution: a "
                                  "build's actuator delay), added to the delay of every magnet "
                                  "and motor action of the run, before the jitter", 1.0)

    recorded_when_set: ClassVar[frozenset[str]] = frozenset({"latency"})

    def value(self, path: tuple) -> Level:
        node = self
        for key in path:
            node = getattr(node, key)
        return node

    @model_validator(mode="after")
    def _levels(self) -> "NoiseSpec":
        lengths = {}
        for path, _, _, _ in SOURCES:
            v = self.value(path)
            if isinstance(v, list):
                lengths[".".join(path)] = len(v)
        for path, _, _, _ in SOURCES:
            bound = {"timing": 1.0, "torque": 1.0, "mass": 0.5, "com": 0.5,
                     "inertia": 0.5, "latency": 1.0}.get(path[-1])
            v = self.value(path)
            if bound is not None and max(v if isinstance(v, list) else [v]) > bound:
                raise ValueError(f"noise.{'.'.join(path)} must be <= {bound}")
        if len(set(lengths.values())) > 1:
            listed = ", ".join(f"noise.{k} has {n}" for k, n in lengths.items())
            raise ValueError(f"every list of noise levels must have the same length: {listed}")
        return self

    @property
    def n_levels(self) -> int:
        for path, _, _, _ in SOURCES:
            v = self.value(path)
            if isinstance(v, list):
                return len(v)
        return 1

    def level(self, i: int) -> Noise:
        """The :class:`~monkeystudy.analysis.survival.Noise` of level ``i``."""
        kw = {}
        for path, name, _, _ in SOURCES:
            v = self.value(path)
            kw[name] = float(v[i] if isinstance(v, list) else v)
        return Noise(distribution=self.distribution, **kw)

    def swept(self) -> list[str]:
        """The sources given as lists (the ones the levels sweep), by Noise field name."""
        return [name for path, name, _, _ in SOURCES if isinstance(self.value(path), list)]


__all__ = ["InitialNoise", "Level", "NoiseSpec", "ParameterNoise", "SOURCES", "SensorNoise",
           "UNIFORM_PER_RUN", "level_field", "noise_value"]
