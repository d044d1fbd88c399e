"""What a step kind is: one class that declares everything the runner, the planner, the
dataset layer, ``monkeystudy inspect`` and the report need to know about a kind of step.

A kind names its study-file model, the kinds its ``from:`` accepts (:attr:`StepKind.accepts`)
and what its own datasets hand on (:attr:`StepKind.provides`, :meth:`StepKind.hand_on`), the
checks it makes across steps, its tasks (:meth:`StepKind.start`), how its results become a
dataset (:meth:`StepKind.finish`), the key numbers of that dataset (:meth:`StepKind.describe`)
and its figures. The runner sees a step only through its kind and a :class:`StepContext`; it
never looks at the step's type, and no kind looks at another's: what a step starts from comes
through the source's kind (:meth:`StepContext.handed_on`).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, Callable, ClassVar, Mapping

import numpy as np

from ...controllers import Integrator
from .. import provenance
from ..blocks import Block, Task
from ..counts import StepProgress
from ..spec import GaitSpec

if TYPE_CHECKING:
    from ..datasets import Variable

#: a problem found across steps: (path of the key in the study file, message)
Problem = tuple[tuple, str]


@dataclass(frozen=True)
class Figure:
    """A figure of a step's dataset: file ``figures/<step name>_<suffix>.png`` (and PDF); an
    ``across`` figure is drawn once per study from all datasets of its kind
    (``figures/<kind>_<suffix>``).

    The drawing, with the figure's title and caption, lives in :mod:`monkeystudy.plotting`,
    registered under ``(kind, suffix)``: its text is not among the sources that key the kind's
    datasets.
    """

    suffix: str
    across: bool = False


@dataclass
class Dependency:
    """A step another step depends on: its model, the path of its dataset and its kind (what
    reads what the dataset hands on)."""

    step: Any
    path: Path
    provider: "StepKind | None" = None

    @property
    def kind(self) -> str:
        return self.step.kind


@dataclass
class StepContext:
    """What a step kind sees of a run, from :meth:`StepKind.start` to :meth:`StepKind.finish`.

    ``results`` receives each finished task's value under its tag (block results are saved
    as shards and read back with :meth:`block_arrays`); ``state`` carries the kind's own values
    from start to finish; ``progress`` shows the phases of its work in the driver.
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
    progress: StepProgress = field(default_factory=StepProgress)

    @property
    def name(self) -> str:
        return self.step.name

    @property
    def conventions(self):
        """How the study's gait is named and run (:class:`~monkeystudy.study.models.
        Conventions`)."""
        return self.study.gait.conventions

    def handed_on(self, source: str | None = None, **options):
        """What step ``source`` (default: this step's ``from:``) hands on, read by its kind
        (:meth:`StepKind.hand_on`; for a gait, a :class:`~monkeystudy.study.steps.gait_source.
        GaitStart`) with this step's choices ``options``."""
        dep = self.deps[source if source is not None else source_name(self.step)]
        return dep.provider.hand_on(dep, self, **options)

    def todo_blocks(self) -> list[Block]:
        """The blocks without a saved shard."""
        return [b for b in self.blocks if b.index not in self.saved]

    def block_arrays(self, block: Block) -> dict[str, np.ndarray]:
        """A finished block's arrays (held in memory, or read back from its shard)."""
        return self.read_block(block)

    def task_results(self) -> list[Any]:
        """The results of the step's non-block tasks, in tag order."""
        return [self.results[t] for t in sorted(self.results)]


def source_name(step) -> str | None:
    """The step named in a step's ``from:`` (None: none), wherever its model keeps it."""
    for holder in (step, getattr(step, "start", None)):
        name = getattr(holder, "from_", None)
        if isinstance(name, str):
            return name
    return None


def kinds_text(kinds) -> str:
    """``'a'``, ``'a or b'``, ``'a, b or c'``."""
    kinds = list(kinds)
    return kinds[0] if len(kinds) == 1 else ", ".join(kinds[:-1]) + " or " + kinds[-1]


class StepKind:
    """One kind of study step. Subclasses set the class attributes and override the methods
    their kind needs; :mod:`monkeystudy.study.steps` registers one instance of each."""

    #: the ``kind:`` of the step in a study file
    name: ClassVar[str] = ""
    #: its pydantic model (:mod:`monkeystudy.study.models` building blocks)
    model: ClassVar[type] = object
    #: the kinds of step its ``from:`` may name (none: it has no ``from:``)
    accepts: ClassVar[tuple[str, ...]] = ()
    #: where its ``from:`` is in a study file (keys below the step) and the model holding it
    from_key: ClassVar[tuple[str, ...]] = ("from",)
    from_model: ClassVar[type | None] = None
    #: what it takes from that step (the schema's description of ``from:``)
    takes: ClassVar[str] = "the gait it hands on"
    #: what its datasets hand on to a later step's ``from:`` (:meth:`hand_on`; "" none)
    provides: ClassVar[str] = ""
    #: the gaits it supports (``horizontal``, ``sequence``)
    gait_kinds: ClassVar[tuple[str, ...]] = ("horizontal",)
    #: its tasks run the study's gait with the study's integrator; False: they run neither
    #: (a study whose steps all are so needs no ``gait:``), but :attr:`own_integrator`
    runs_gait: ClassVar[bool] = True
    #: the integrator its tasks run with when they do not run the study's (:attr:`runs_gait`
    #: False): the runner loads its kernels before fanning out
    own_integrator: ClassVar[Integrator | None] = None
    #: the blocks of the study file besides the robot, gait and integrator its datasets
    #: depend on (e.g. ``wall``): its step key covers them (:func:`~monkeystudy.study.plan.
    #: step_keys`), so a changed block is run again
    study_blocks: ClassVar[tuple[str, ...]] = ()
    #: what its progress counts (tasks, or ``blocks`` for a resumable kind)
    unit: ClassVar[str] = "tasks"
    #: its progress counts the points of its blocks (runs, designs: :attr:`unit`), which
    #: its tasks report as they go (:func:`~monkeystudy.study.counts.task_units`), not
    #: the blocks
    block_units: ClassVar[bool] = False
    #: its figures, in drawing order
    figures: ClassVar[tuple[Figure, ...]] = ()
    #: why it has no figure (when ``figures`` is empty)
    no_figures: ClassVar[str] = ""
    #: its dataset is bit-reproducible (same numbers for any workers, resumed or not)
    reproducible: ClassVar[bool] = True
    #: its dataset's variables, coordinates included, by name (:class:`~monkeystudy.study.
    #: datasets.Variable`; docs/datasets.md documents them): what its writer writes
    variables: ClassVar[Mapping[str, "Variable"]] = {}

    def __init_subclass__(cls, **kwargs):
        # the declaration is the schema's description of from:
        super().__init_subclass__(**kwargs)
        holder = cls.from_model or cls.model
        fields = getattr(holder, "model_fields", {})
        if cls.accepts and "from_" in fields:
            fields["from_"].description = (f"an earlier {kinds_text(cls.accepts)} step: "
                                           f"{cls.takes}")
            holder.model_rebuild(force=True)
            if holder is not cls.model:
                cls.model.model_rebuild(force=True)

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

    def input_files(self, step) -> tuple[str, ...]:
        """Files outside the study a step reads (paths): their contents are part of its key
        (:func:`~monkeystudy.study.plan.step_keys`), so a dataset is current only while they
        are unchanged. Default: none."""
        return ()

    def check(self, study, index: int, step, seen: dict[str, Any]) -> list[Problem]:
        """Problems across steps (``seen``: the earlier steps by name): its ``from:`` names an
        earlier step of a kind it :attr:`accepts`, then the kind's own
        (:meth:`check_step`, given that step or None)."""
        name = source_name(step)
        ref = None
        problems: list[Problem] = []
        if name is not None and self.accepts:
            ref = seen.get(name)
            if ref is None or ref.kind not in self.accepts:
                problems.append((("steps", index) + self.from_key,
                                 no_earlier(name, kinds_text(self.accepts), ref)))
                ref = None
        return problems + self.check_step(study, index, step, ref, seen)

    def check_step(self, study, index: int, step, ref, seen: dict[str, Any]) -> list[Problem]:
        """The kind's own problems; ``ref`` is the step its ``from:`` names when that is of a
        kind it accepts (else None), ``seen`` the earlier steps by name. None by default."""
        return []

    def blocks(self, step) -> list[Block]:
        """The resumable blocks of a step (none: its tasks are not saved one by one)."""
        return []

    def block_summary(self, step) -> str:
        """What a resumable step's blocks hold, for the plan's line."""
        return f"{sum(b.size for b in self.blocks(step))} points"

    def phases(self, step) -> tuple[str, ...]:
        """The phases of its work, in order, when it has several: its tasks on the pool, then
        its work in :meth:`finish`, each shown with its own count (:attr:`StepContext.
        progress`); none: its tasks are all of it."""
        return ()

    def n_tasks(self, step, gait) -> int:
        """How many tasks the step queues (``--dry-run`` shows it) for the study's ``gait``
        (its model)."""
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

    def hand_on(self, dep: Dependency, ctx: StepContext, **options):
        """What a step of this kind hands on to ``ctx``'s step (:attr:`provides`), read from
        its dataset ``dep`` with that step's choices ``options``."""
        raise NotImplementedError(f"a {self.name} step hands nothing on")

    # --- reading ----------------------------------------------------------------------------
    def describe(self, ds) -> list[str]:
        """Key numbers of one of its datasets (an ``xarray.Dataset``), one line each."""
        return []

    def own_setup(self, ds) -> str:
        """What a step of a kind that does not run the study's gait (:attr:`runs_gait` False)
        ran instead, in words, from one of its datasets (an ``xarray.Dataset``): the page's
        set-up says it. Empty by default."""
        return ""


def no_earlier(name: str, kind: str, found) -> str:
    """The message for a ``from:`` that names no earlier step of the expected kind."""
    if found is None:
        return f"no earlier step named {name!r}"
    return f"{name!r} is a {found.kind} step, expected a {kind} step"


def max_drop_of(step, spec: GaitSpec) -> float:
    """A step's ``max_drop`` [m], by default link 1's length."""
    value = getattr(step, "max_drop", None)
    return float(value) if value is not None else float(spec.robot.link1.length)
