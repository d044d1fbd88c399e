"""What a step kind is: one class that declares everything the runner, the planner, the
dataset layer, ``monkeystudy inspect`` and the report need to know about a kind of step.

A kind names its study-file model, the steps it depends on, the checks it makes across steps,
its tasks (:meth:`StepKind.start`), how its results become a dataset (:meth:`StepKind.finish`),
the key numbers of that dataset (:meth:`StepKind.describe`) and its figures. The runner sees a
step only through its kind and a :class:`StepContext`; it never looks at the step's type.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, ClassVar

import numpy as np

from .. import provenance
from ..blocks import Block, Task
from ..spec import GaitSpec

#: a problem found across steps: (path of the key in the study file, message)
Problem = tuple[tuple, str]


@dataclass(frozen=True)
class Figure:
    """A figure of a step's dataset: file ``figures/<step name>_<suffix>.png`` (and PDF); an
    ``across`` figure is drawn once per study from all datasets of its kind
    (``figures/<kind>_<suffix>``).

    ``title`` says what it shows (progress lines, the file's metadata); ``caption`` what to
    look at (the study's HTML page). The drawing itself lives in :mod:`monkeystudy.plotting`,
    registered under ``(kind, suffix)``.
    """

    suffix: str
    title: str
    caption: str
    across: bool = False


@dataclass
class Dependency:
    """A step another step depends on: its model and the path of its dataset."""

    step: Any
    path: Path

    @property
    def kind(self) -> str:
        return self.step.kind


@dataclass
class StepContext:
    """What a step kind sees of a run, from :meth:`StepKind.start` to :meth:`StepKind.finish`.

    ``results`` receives each finished task's value under its tag (block results are saved
    as shards and read back with :meth:`block_arrays`); ``state`` carries the kind's own values
    from start to finish.
    """

    step: Any
    study: Any
    spec: GaitSpec
    path: Path
    out: Path
    key: str
    deps: dict[str, Dependency]
    blocks: list[Block] = field(default_factory=list)
    saved: set[int] = field(default_factory=set)
    results: dict[Any, Any] = field(default_factory=dict)
    state: dict[str, Any] = field(default_factory=dict)
    read_block: Callable[[Block], dict[str, np.ndarray]] | None = None

    @property
    def name(self) -> str:
        return self.step.name

    @property
    def gait_kind(self) -> str:
        return self.study.gait.kind

    def todo_blocks(self) -> list[Block]:
        """The blocks without a saved shard."""
        return [b for b in self.blocks if b.index not in self.saved]

    def block_arrays(self, block: Block) -> dict[str, np.ndarray]:
        """A finished block's arrays (held in memory, or read back from its shard)."""
        return self.read_block(block)

    def task_results(self) -> list[Any]:
        """The results of the step's non-block tasks, in tag order."""
        return [self.results[t] for t in sorted(self.results)]


class StepKind:
    """One kind of study step. Subclasses set the class attributes and override the methods
    their kind needs; :mod:`monkeystudy.study.steps` registers one instance of each."""

    #: the ``kind:`` of the step in a study file
    name: ClassVar[str] = ""
    #: its pydantic model (:mod:`monkeystudy.study.models` building blocks)
    model: ClassVar[type] = object
    #: the gaits it supports (``horizontal``, ``sequence``)
    gait_kinds: ClassVar[tuple[str, ...]] = ("horizontal",)
    #: what its progress counts (tasks, or ``blocks`` for a resumable kind)
    unit: ClassVar[str] = "tasks"
    #: its figures, in drawing order
    figures: ClassVar[tuple[Figure, ...]] = ()
    #: why it has no figure (when ``figures`` is empty)
    no_figures: ClassVar[str] = ""
    #: its dataset is bit-reproducible (same numbers for any workers, resumed or not)
    reproducible: ClassVar[bool] = True

    @property
    def code_sha256(self) -> str:
        """Hash of the code this kind runs (its module's import closure,
        :func:`~monkeystudy.study.provenance.code_sha256`): its datasets' key."""
        return provenance.code_sha256(type(self).__module__)

    @property
    def summary(self) -> str:
        """One line: the first line of the model's docstring."""
        return (self.model.__doc__ or "").strip().splitlines()[0]

    # --- planning ---------------------------------------------------------------------------
    def deps(self, step) -> tuple[str, ...]:
        """Names of the steps this one needs first (default: its ``from:``)."""
        name = getattr(step, "from_", None)
        return (name,) if name is not None else ()

    def check(self, study, index: int, step, seen: dict[str, Any]) -> list[Problem]:
        """Problems across steps (``seen``: the earlier steps by name); none by default."""
        return []

    def blocks(self, step) -> list[Block]:
        """The resumable blocks of a step (none: its tasks are not saved one by one)."""
        return []

    def block_summary(self, step) -> str:
        """What a resumable step's blocks hold, for the plan's line."""
        return f"{sum(b.size for b in self.blocks(step))} points"

    def n_tasks(self, step, gait_kind: str) -> int:
        """How many tasks the step queues (``--dry-run`` shows it)."""
        return 1

    def needs_runs(self, step) -> bool:
        """Whether its tasks run controllers for many cycles (the runner loads those
        kernels before fanning out)."""
        return True

    def needs_variational(self, step) -> bool:
        """Whether its tasks use the variational kernels (loaded before fanning out)."""
        return False

    # --- running ----------------------------------------------------------------------------
    def start(self, ctx: StepContext) -> list[Task]:
        """The tasks of the step (its dependencies' datasets exist); only the blocks without
        a shard (``ctx.todo_blocks()``) for a resumable kind."""
        raise NotImplementedError

    def finish(self, ctx: StepContext, attrs: dict) -> str:
        """Write the step's dataset to ``ctx.path`` (``attrs``: the study's global attributes)
        and return the one-line summary shown when it is done."""
        raise NotImplementedError

    # --- reading ----------------------------------------------------------------------------
    def describe(self, ds) -> list[str]:
        """Key numbers of one of its datasets (an ``xarray.Dataset``), one line each."""
        return []


def no_earlier(name: str, kind: str, found) -> str:
    """The message for a ``from:`` that names no earlier step of the expected kind."""
    if found is None:
        return f"no earlier step named {name!r}"
    return f"{name!r} is a {found.kind} step, expected a {kind} step"


def max_drop_of(step, spec: GaitSpec) -> float:
    """A step's ``max_drop`` [m], by default link 1's length."""
    value = getattr(step, "max_drop", None)
    return float(value) if value is not None else float(spec.robot.link1.length)
