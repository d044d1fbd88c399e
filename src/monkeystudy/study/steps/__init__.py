"""The step kinds of a study, one module each, registered here in schema order.

Each kind (a :class:`~monkeystudy.study.steps.base.StepKind`) declares its study-file model,
dependencies, cross-step checks, tasks, dataset, key numbers and figures; the schema, the
planner, the runner, ``monkeystudy inspect`` and the report iterate over :data:`REGISTRY`.
What adding a kind takes is listed in docs/architecture.md ("Step kinds"), and
``tests/test_architecture.py`` checks each of its parts.
"""
from __future__ import annotations

from .atlas import AtlasKind
from .base import Dependency, Figure, StepContext, StepKind
from .basin import BasinKind
from .continuation import ContinuationKind
from .design import DesignKind
from .floquet import FloquetKind
from .grid import GridKind
from .hardware_replay import HardwareReplayKind
from .refine import RefineKind
from .route import RouteKind
from .shoot import ShootKind
from .stability import StabilityKind
from .stress import StressKind
from .survival import SurvivalKind
from .tick_sweep import TickSweepKind
from .work_precision import WorkPrecisionKind

#: every step kind by its ``kind:`` name, in the order the schema lists them
REGISTRY: dict[str, StepKind] = {k.name: k for k in (
    GridKind(), RefineKind(), StabilityKind(), ShootKind(), FloquetKind(), TickSweepKind(),
    BasinKind(), ContinuationKind(), WorkPrecisionKind(), StressKind(), SurvivalKind(),
    DesignKind(), HardwareReplayKind(), AtlasKind(), RouteKind(),
)}


def kind_of(step) -> StepKind:
    """The kind of a step model (its ``kind`` field)."""
    return REGISTRY[step.kind]


__all__ = ["Dependency", "Figure", "REGISTRY", "StepContext", "StepKind", "kind_of"]
