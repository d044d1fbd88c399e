"""What a run of a study has to do: which steps are up to date, which blocks are saved.

Each step has a content key (:func:`step_keys`: the robot, gait, integrator, the step's
settings, its dependencies' keys and the code), so stale shards are never reused and a dataset
whose ``step_sha256`` and ``code_sha256`` match is up to date: editing one step of a study
reruns that step and the steps that depend on it, not the others. Planning reads only; it
creates nothing (``monkeystudy run --dry-run`` prints the plan).
"""
from __future__ import annotations

import hashlib
import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from . import datasets as D
from . import provenance as P
from .blocks import Block, saved_blocks, shard_dir
from .loader import LoadedStudy
from .progress import count, singular_counts
from .schema import Study
from .spec import gait_json, integrator_fields
from .steps import StepKind, kind_of


@dataclass
class StepPlan:
    """One step of the plan: its kind, dataset path, dependencies, key and blocks."""

    step: Any
    kind: StepKind
    path: Path
    deps: tuple[str, ...]
    up_to_date: bool
    key: str                   # step_keys(): what the dataset depends on, hashed
    gait: Any = None           # the study's gait (its model)
    blocks: list[Block] = field(default_factory=list)
    saved: set[int] = field(default_factory=set)

    @property
    def name(self) -> str:
        return self.step.name

    @property
    def n_tasks(self) -> int:
        return len(self.blocks) if self.blocks else self.kind.n_tasks(self.step, self.gait)

    def todo_blocks(self) -> list[Block]:
        return [b for b in self.blocks if b.index not in self.saved]

    def describe(self) -> list[str]:
        """The plan's lines for this step (``--dry-run``)."""
        head = f"  {self.name} [{self.step.kind}] -> {self.path.name}"
        if self.up_to_date:
            return [f"{head}: up to date"]
        dep = f" after {', '.join(self.deps)}" if self.deps else ""
        if not self.blocks:
            return [f"{head}: {count(self.n_tasks, 'task')}{dep}"]
        todo = self.todo_blocks()
        lines = [f"{head}: {len(todo)} of {count(len(self.blocks), 'block')} to do "
                 f"({singular_counts(self.kind.block_summary(self.step))}, "
                 f"{len(self.saved)} saved){dep}"]
        if todo:
            lines.append(f"    blocks: {block_ranges([b.index for b in todo])}")
        return lines


@dataclass
class Plan:
    """What a run of a study has to do (``--dry-run`` prints it)."""

    loaded: LoadedStudy
    out: Path
    key: str
    steps: list[StepPlan]

    @property
    def up_to_date(self) -> bool:
        return all(s.up_to_date for s in self.steps)

    def describe(self) -> str:
        st = self.loaded.study
        lines = [f"study {st.name!r} ({self.loaded.path}) -> {self.out}",
                 f"run key {self.key[:16]} (study sha256 {self.loaded.sha256[:12]}, code "
                 f"{P.code_sha256()[:12]})"]
        for s in self.steps:
            lines += s.describe()
        return "\n".join(lines)


def block_ranges(indices: list[int]) -> str:
    """``b000000..b000003, b000007``: block ids with consecutive runs collapsed."""
    parts, start, prev = [], None, None
    for i in indices + [None]:
        if start is None:
            start = prev = i
        elif i is not None and i == prev + 1:
            prev = i
        else:
            parts.append(f"b{start:06d}" if start == prev else f"b{start:06d}..b{prev:06d}")
            start = prev = i
    return ", ".join(parts)


def default_out(study: Study) -> Path:
    return Path("outputs") / study.name


def step_keys(study: Study) -> dict[str, str]:
    """Each step's content key: sha256 of everything its dataset depends on - the robot, the
    gait, the integrator, the step's own settings, its dependencies' keys and the code its
    kind runs. Editing one step (or adding one), or the code of another kind, leaves the
    others' keys, datasets and shards valid; editing the robot, gait or integrator changes
    every key. A step that reads files outside the study (:meth:`~monkeystudy.study.steps.
    base.StepKind.input_files`: a hardware log) is keyed on their contents too, and one whose
    kind reads other blocks of the study file (its ``study_blocks``, e.g. a route step's
    ``wall``) on those blocks."""
    common = {"schema_version": study.schema_version, "robot": study.to_robot().to_dict(),
              "gait": gait_json(study),
              "integrator": integrator_fields(study.integrator.to_integrator())}
    keys: dict[str, str] = {}
    for s in study.steps:
        kind = kind_of(s)
        payload = dict(common, step=s.model_dump(mode="json", by_alias=True),
                       code=kind.code_sha256, deps=[keys[d] for d in kind.deps(s)])
        for block in kind.study_blocks:
            value = getattr(study, block)
            payload[block] = None if value is None else value.model_dump(mode="json")
        files = kind.input_files(s)
        if files:       # absent otherwise: the keys of steps that read no file are unchanged
            payload["input_files"] = [P.file_sha256(f) for f in files]
        keys[s.name] = hashlib.sha256(json.dumps(payload, sort_keys=True).encode()).hexdigest()
    return keys


def dataset_current(path: Path, step_sha256: str, code_sha256: str) -> bool:
    """The dataset exists and was made from the same step key (:func:`step_keys`) by the same
    code of its kind."""
    attrs = D.read_attrs(path)
    return bool(attrs) and attrs.get("step_sha256") == step_sha256 and \
        attrs.get("code_sha256") == code_sha256


def plan_study(loaded: LoadedStudy, out: str | Path | None = None) -> Plan:
    """Resolve a study against its output folder: which steps and blocks are left to do.
    Reads only; creates nothing."""
    study = loaded.study
    out = Path(out) if out is not None else default_out(study)
    key = P.run_key(loaded.sha256)
    keys = step_keys(study)
    steps: list[StepPlan] = []
    stale: set[str] = set()
    for s in study.steps:
        kind = kind_of(s)
        path = out / f"{s.name}.nc"
        deps = kind.deps(s)
        current = dataset_current(path, keys[s.name], kind.code_sha256) and \
            not (set(deps) & stale)
        if not current:
            stale.add(s.name)
        sp = StepPlan(s, kind, path, deps, current, keys[s.name], gait=study.gait,
                      blocks=kind.blocks(s))
        if sp.blocks and not current:
            sp.saved = saved_blocks(shard_dir(out, s.name, sp.key), sp.blocks)
        steps.append(sp)
    return Plan(loaded, out, key, steps)
