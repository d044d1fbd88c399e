"""Run studies: plan the blocks, fan them out, save shards, consolidate datasets, resume.

One code path for every executor with the ``concurrent.futures`` interface: a local
``ProcessPoolExecutor`` (all cores by default) or a Dask cluster's
``distributed.Client(address).get_executor()``. Work is split into blocks with deterministic
ids (a grid step: consecutive runs of ``block_size`` points in C order; a refine step: one task
per start; a stability step: one task). Every finished grid block becomes a shard on disk,
written atomically::

    <out>/.<step>.parts/<step key>/b000012.npz

Each step has a content key (:func:`step_keys`: the robot, gait, integrator, the step's
settings, its dependencies' keys and the code), so stale shards are never reused; a rerun skips
the shards that exist and the final datasets do not depend on which blocks were computed when,
nor where, nor by how many workers. A dataset whose ``step_sha256`` and ``code_sha256`` match
is up to date and is not recomputed: editing one step of a study reruns that step and the steps
that depend on it, not the others.

Steps run in dependency order (a refine after the grid it starts from, a stability run after
its refine); independent steps share the pool.
"""
from __future__ import annotations

import gc
import math
import os
import shutil
import signal
import threading
import traceback
import uuid
from collections import deque
from concurrent.futures import (
    FIRST_COMPLETED, CancelledError, Executor, Future, ProcessPoolExecutor, wait,
)
from concurrent.futures.process import BrokenProcessPool
from contextlib import ExitStack, contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Iterator, Sequence

import numpy as np

from .. import __version__
from ..controllers import Integrator
from ..robot import SEED2009_TORQUE, Friction, Link, Robot
from ..simulate import RobotLike, as_robot
from . import analysis_steps as AS
from . import analysis_tasks
from . import datasets as D
from . import drivers
from . import provenance as P
from .loader import LoadedStudy
from .progress import Reporter
from .schema import (
    ANALYSIS_STEPS, BasinStep, BestOfGrid, ContinuationStep, FloquetStep, GridStep, RefineStep,
    StabilityStep, Study,
)


class RunFailed(RuntimeError):
    """A task raised or a result could not be written (exit code 1)."""


class RunInterrupted(RuntimeError):
    """The run stopped early (Ctrl-C, SIGTERM, a dead worker); finished blocks are saved and a
    rerun resumes (exit code 3)."""


# --- resolving a study ----------------------------------------------------------------------------
def study_robot(study: Study) -> Robot:
    """The :class:`~monkeystudy.Robot` a study names (preset or explicit parameters)."""
    r = study.robot
    if isinstance(r, str):
        return Robot.preset(r)
    links = [Link(lk.mass, lk.length, lk.com, lk.inertia) for lk in r.links]
    return Robot(links[0], links[1], gravity=r.gravity,
                 pivot_friction=Friction(r.friction.pivot.viscous, r.friction.pivot.coulomb),
                 joint_friction=Friction(r.friction.joint.viscous, r.friction.joint.coulomb),
                 name=r.name)


def study_integrator(study: Study) -> Integrator:
    i = study.integrator
    return Integrator(method=i.method, rtol=i.rtol, atol=i.atol, max_time=i.max_time,
                      controller=i.controller)


def study_spec(study: Study) -> drivers.GaitSpec:
    g = study.gait
    if g.kind == "sequence":
        return drivers.make_spec(study_robot(study), math.nan, g.tick,
                                 study_integrator(study), sequence=g.gait())
    return drivers.make_spec(study_robot(study), g.motor_torque, g.tick,
                             study_integrator(study))


def step_deps(step) -> tuple[str, ...]:
    if isinstance(step, RefineStep) and isinstance(step.start, BestOfGrid):
        return (step.start.from_,)
    if isinstance(step, StabilityStep):
        return (step.from_,)
    if isinstance(step, ANALYSIS_STEPS):
        return AS.step_deps(step)
    return ()


# --- blocks and shards ------------------------------------------------------------------------------
@dataclass(frozen=True)
class Block:
    """``block_size`` consecutive points (flat C-order indices ``lo..hi``) of a grid step."""

    index: int
    lo: int
    hi: int

    @property
    def id(self) -> str:
        return f"b{self.index:06d}"

    @property
    def size(self) -> int:
        return self.hi - self.lo


def make_blocks(n_points: int, block_size: int) -> list[Block]:
    return [Block(i, lo, min(lo + block_size, n_points))
            for i, lo in enumerate(range(0, n_points, block_size))]


def grid_points(step: GridStep, lo: int = 0, hi: int | None = None) -> np.ndarray:
    """Points ``[n, 2]`` (dtheta1, dtheta2) at flat indices ``lo..hi`` of a grid step."""
    hi = step.n_points if hi is None else hi
    if step.points is not None:
        return np.array(step.points[lo:hi], dtype=np.float64).reshape(-1, 2)
    return _axes_points(step.dtheta1.values(), step.dtheta2.values(), lo, hi)


def _axes_points(a1: np.ndarray, a2: np.ndarray, lo: int, hi: int) -> np.ndarray:
    idx = np.arange(lo, hi)
    i, j = np.divmod(idx, a2.size)
    return np.stack([a1[i], a2[j]], axis=1)


def parts_root(out: Path, step_name: str) -> Path:
    return out / f".{step_name}.parts"


def shard_dir(out: Path, step_name: str, key: str) -> Path:
    return parts_root(out, step_name) / key[:16]


def shard_path(folder: Path, block: Block) -> Path:
    return folder / f"{block.id}.npz"


def saved_blocks(folder: Path, blocks: Sequence[Block]) -> set[int]:
    """Indices of the blocks whose shard exists in ``folder``."""
    if not folder.is_dir():
        return set()
    names = {p.name for p in folder.iterdir()}
    return {b.index for b in blocks if f"{b.id}.npz" in names}


def write_shard(folder: Path, block: Block, arrays: dict[str, np.ndarray]) -> Path:
    """Save a block's arrays atomically (temp file in the same folder, fsync, os.replace)."""
    folder.mkdir(parents=True, exist_ok=True)
    final = shard_path(folder, block)
    tmp = folder / f".{block.id}.{uuid.uuid4().hex[:8]}.tmp"
    try:
        with open(tmp, "wb") as fh:
            np.savez(fh, lo=np.int64(block.lo), hi=np.int64(block.hi), **arrays)
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, final)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    return final


def read_shard(folder: Path, block: Block,
               names=tuple(drivers.GRID_VARIABLES)) -> dict[str, np.ndarray]:
    with np.load(shard_path(folder, block)) as z:
        if int(z["lo"]) != block.lo or int(z["hi"]) != block.hi:
            raise RunFailed(f"shard {shard_path(folder, block)} does not hold block "
                            f"{block.lo}..{block.hi}")
        return {k: z[k] for k in names}


def clean_parts(out: Path, step_name: str, keep_key: str | None) -> None:
    """Remove stale shard folders (other run keys) and leftover temporary files."""
    root = parts_root(out, step_name)
    if not root.is_dir():
        return
    for p in root.iterdir():
        if keep_key is not None and p.name == keep_key[:16] and p.is_dir():
            for t in p.glob(".*.tmp"):
                t.unlink(missing_ok=True)
        elif p.is_dir():
            shutil.rmtree(p, ignore_errors=True)
        else:
            p.unlink(missing_ok=True)
    if keep_key is None:
        shutil.rmtree(root, ignore_errors=True)


# --- the plan ------------------------------------------------------------------------------------------
@dataclass
class StepPlan:
    step: Any
    path: Path
    deps: tuple[str, ...]
    up_to_date: bool
    blocks: list[Block] = field(default_factory=list)
    saved: set[int] = field(default_factory=set)
    gait_kind: str = "horizontal"
    key: str = ""            # step_keys(): what the dataset depends on, hashed

    @property
    def name(self) -> str:
        return self.step.name

    @property
    def kind(self) -> str:
        return self.step.kind

    @property
    def n_tasks(self) -> int:
        if isinstance(self.step, GridStep):
            return len(self.blocks)
        if isinstance(self.step, RefineStep) and isinstance(self.step.start, BestOfGrid):
            return self.step.start.best
        if isinstance(self.step, BasinStep):
            return len(self.blocks)
        if isinstance(self.step, ANALYSIS_STEPS):
            return AS.n_tasks(self.step, self.gait_kind)
        return 1

    def todo_blocks(self) -> list[Block]:
        return [b for b in self.blocks if b.index not in self.saved]


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
            head = f"  {s.name} [{s.kind}] -> {s.path.name}"
            if s.up_to_date:
                lines.append(f"{head}: up to date")
                continue
            if isinstance(s.step, GridStep):
                todo = s.todo_blocks()
                lines.append(f"{head}: {len(todo)} of {len(s.blocks)} blocks to do "
                             f"({s.step.n_points} points, {s.step.points_per_block} per block, "
                             f"{len(s.saved)} saved)")
                if todo:
                    lines.append(f"    blocks: {_ranges([b.index for b in todo])}")
            elif isinstance(s.step, BasinStep):
                todo = s.todo_blocks()
                dep = f" after {', '.join(s.deps)}" if s.deps else ""
                lines.append(f"{head}: {len(todo)} of {len(s.blocks)} blocks to do "
                             f"({s.step.n_points} starts, {len(s.saved)} saved){dep}")
                if todo and len(s.blocks) > 1:
                    lines.append(f"    blocks: {_ranges([b.index for b in todo])}")
            else:
                n = s.n_tasks
                dep = f" after {', '.join(s.deps)}" if s.deps else ""
                lines.append(f"{head}: {n} task{'s' if n > 1 else ''}{dep}")
        return "\n".join(lines)


def _ranges(indices: list[int]) -> str:
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
    gait, the integrator, the step's own settings, its dependencies' keys and the code.
    Editing one step (or adding one) leaves the others' keys, datasets and shards valid;
    editing the robot, gait or integrator changes every key."""
    import hashlib
    import json

    common = {"schema_version": study.schema_version, "robot": study_robot(study).to_dict(),
              "gait": _json_gait(study), "integrator": _json_integrator(study),
              "code": P.code_sha256()}
    keys: dict[str, str] = {}
    for s in study.steps:
        payload = dict(common, step=s.model_dump(mode="json", by_alias=True),
                       deps=[keys[d] for d in step_deps(s)])
        keys[s.name] = hashlib.sha256(json.dumps(payload, sort_keys=True).encode()).hexdigest()
    return keys


def dataset_current(path: Path, step_sha256: str) -> bool:
    """The dataset exists and was made from the same step key (:func:`step_keys`)."""
    attrs = D.read_attrs(path)
    return bool(attrs) and attrs.get("step_sha256") == step_sha256 and \
        attrs.get("code_sha256") == P.code_sha256()


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
        path = out / f"{s.name}.nc"
        deps = step_deps(s)
        current = dataset_current(path, keys[s.name]) and not (set(deps) & stale)
        if not current:
            stale.add(s.name)
        sp = StepPlan(s, path, deps, current, gait_kind=study.gait.kind, key=keys[s.name])
        if isinstance(s, GridStep):
            sp.blocks = make_blocks(s.n_points, s.points_per_block)
            if not current:
                sp.saved = saved_blocks(shard_dir(out, s.name, sp.key), sp.blocks)
        elif isinstance(s, BasinStep):
            sp.blocks = AS.basin_blocks(s)
            if not current:
                sp.saved = saved_blocks(shard_dir(out, s.name, sp.key), sp.blocks)
        steps.append(sp)
    return Plan(loaded, out, key, steps)


# --- executors -----------------------------------------------------------------------------------------
def _worker_init(driver: int) -> None:
    """Pool worker start: Ctrl-C is the driver's business; exit when the driver is gone
    (after a kill -9 nobody else would stop an idle worker)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    gc.enable()  # the driver may fork with collection off during its start-up

    def watch():
        import time
        while True:
            time.sleep(1.0)
            try:
                os.kill(driver, 0)
            except ProcessLookupError:
                os._exit(3)
            except PermissionError:  # pid reused by another user's process: gone too
                os._exit(3)

    threading.Thread(target=watch, name="monkeystudy-parent-watch", daemon=True).start()


class Pool:
    """An executor, its number of task slots, and how to stop it at once."""

    def __init__(self, executor: Executor, slots: int, kind: str, closer: Callable[[], None],
                 fork: Callable[[], Executor] | None = None):
        self.executor = executor
        self.slots = max(1, int(slots))
        self.kind = kind
        self._closer = closer
        self._fork = fork

    def renew(self) -> None:
        """Replace the (idle) local workers by new ones forked from this process now, so that
        they inherit the kernels it loaded since; other pools are left as they are."""
        if self._fork is not None:
            self.executor.shutdown(wait=True)
            self.executor = self._fork()

    def submit(self, fn, *args, **kwargs) -> Future:
        return self.executor.submit(fn, *args, **kwargs)

    @property
    def usable(self) -> bool:
        """False once the pool was aborted, shut down or lost a worker."""
        ex = self.executor
        if isinstance(ex, ProcessPoolExecutor):
            return not (getattr(ex, "_broken", False) or getattr(ex, "_shutdown_thread", False))
        return True

    def abort(self) -> None:
        """Cancel queued tasks and stop the workers now (finished shards stay on disk)."""
        ex = self.executor
        if isinstance(ex, ProcessPoolExecutor):
            procs = list((getattr(ex, "_processes", None) or {}).values())
            ex.shutdown(wait=False, cancel_futures=True)
            for p in procs:
                if p.is_alive():
                    p.terminate()
            for p in procs:
                p.join(timeout=5)
        else:
            ex.shutdown(wait=False)
        self._closer()

    def close(self) -> None:
        self.executor.shutdown(wait=True)
        self._closer()


#: environment variable choosing the local pool's start method (fork, forkserver, spawn)
START_METHOD_ENV = "MONKEYSTUDY_START_METHOD"


def _mp_context():
    """The local pool's start method: ``fork`` when this process is single-threaded (the
    workers inherit the imported modules and loaded kernels: no start-up of their own), else
    the ``forkserver`` (forking a multi-threaded process can copy a lock some other thread
    holds, e.g. after an in-process Dask cluster), else ``spawn``; or ``$MONKEYSTUDY_START_
    METHOD``."""
    import multiprocessing as mp
    methods = mp.get_all_start_methods()
    method = os.environ.get(START_METHOD_ENV)
    if not method:
        if "fork" in methods and threading.active_count() == 1:
            method = "fork"
        else:
            method = "forkserver" if "forkserver" in methods else "spawn"
    if method not in methods:
        raise RunFailed(f"{START_METHOD_ENV}={method!r}: this platform offers "
                        f"{', '.join(methods)}")
    ctx = mp.get_context(method)
    if method == "forkserver":
        ctx.set_forkserver_preload(["monkeystudy.study._preload"])
    return ctx


def default_workers() -> int:
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        return os.cpu_count() or 1


def local_pool(workers: int | None = None,
               warm_up: Callable[[], None] | None = None) -> Pool:
    """A started local process pool of ``workers`` (default all cores); see :func:`open_pool`
    for ``warm_up``. The caller closes it (``monkeystudy serve`` keeps one across runs)."""
    n = default_workers() if workers is None else int(workers)
    if n < 1:
        raise ValueError(f"workers must be >= 1, got {n}")
    ctx = _mp_context()
    if ctx.get_start_method() == "fork" and warm_up is not None:
        warm_up()
        warm_up = None
    if not gc.isenabled():
        # start-up mode (the CLI): the modules and kernels loaded so far live as long as
        # the process, so keep them out of every later collection, here and in the forked
        # workers (whose pages then stay shared: the collector never writes to them)
        gc.freeze()

    def fork() -> Executor:
        ex = ProcessPoolExecutor(max_workers=n, mp_context=ctx,
                                 initializer=_worker_init, initargs=(os.getpid(),))
        # start the workers now: they load the kernels (forkserver preload) while the
        # driver does its own warm-up and planning, instead of after it
        for _ in range(n):
            ex.submit(os.getpid)
        return ex

    ex = fork()
    if warm_up is not None:
        warm_up()
    return Pool(ex, n, f"{n} local process{'es' if n > 1 else ''}", lambda: None, fork)


@contextmanager
def open_pool(workers: int | None = None, scheduler: str | None = None,
              warm_up: Callable[[], None] | None = None) -> Iterator[Pool]:
    """A local process pool (``workers``, default all cores) or, with ``scheduler``
    (``tcp://host:port``), the executor of a Dask distributed cluster.

    ``warm_up`` loads the kernels in this process. With the forkserver (the default) it runs
    while the workers start (they load their own from the preload); with ``fork`` it runs
    first, and the forked workers inherit the loaded kernels."""
    if scheduler:
        try:
            from distributed import Client
        except ImportError as exc:
            raise RunFailed("--scheduler needs dask.distributed: "
                            "pip install 'monkeystudy[dask]'") from exc
        try:
            client = Client(scheduler, timeout="20s", set_as_default=False)
        except (OSError, TimeoutError) as exc:
            raise RunFailed(f"cannot connect to the Dask scheduler {scheduler}: {exc}") \
                from exc
        slots = sum(client.nthreads().values()) or 1
        pool = Pool(client.get_executor(pure=False), slots, f"dask {scheduler}", client.close)
    else:
        pool = local_pool(workers, warm_up)
        warm_up = None
    if warm_up is not None:
        warm_up()
    gc.enable()  # start-up is over (the CLI turns collection off while it imports)
    ok = False
    try:
        yield pool
        ok = True
    finally:
        if ok:
            pool.close()
        else:
            pool.abort()


# --- running a study ---------------------------------------------------------------------------------
@dataclass
class RunSummary:
    out: Path
    written: list[Path]
    up_to_date: list[Path]
    blocks_computed: int
    blocks_reused: int
    notes: dict[str, str] = field(default_factory=dict)


def _json_gait(study: Study) -> dict:
    if study.gait.kind == "sequence":
        return study.gait.model_dump(mode="json")
    return {"kind": study.gait.kind, "motor_torque": study.gait.motor_torque,
            "tick": study.gait.tick}


def _json_integrator(study: Study) -> dict:
    return drivers.integrator_fields(study_integrator(study))


def step_attrs(loaded: LoadedStudy, step, history: str) -> dict:
    """Global attributes of a step's dataset (docs/datasets.md), before the step's own."""
    study = loaded.study
    return {
        "title": f"{study.name}: {step.name}",
        "study_name": study.name, "step_name": step.name, "step_kind": step.kind,
        "study_description": study.description,
        "step": step.model_dump(mode="json", by_alias=True),
        "study_text": loaded.text, "study_sha256": loaded.sha256,
        "robot": study_robot(study).to_dict(), "gait": _json_gait(study),
        "integrator": _json_integrator(study),
        "monkeystudy_version": __version__, "git_revision": P.git_revision(),
        "code_sha256": P.code_sha256(), "library_versions": P.library_versions(),
        "history": history, "Conventions": D.CONVENTIONS, "source": "monkeystudy",
    }


@dataclass
class _Task:
    step: StepPlan
    tag: Any                # Block for grids, start index for refine, None for stability
    fn: Callable
    args: tuple
    kwargs: dict
    exclusive: bool = False  # runs alone on the pool (wall-time measurements)


class _Run:
    def __init__(self, plan: Plan, pool: Pool, reporter: Reporter, history: str):
        self.plan = plan
        self.pool = pool
        self.rep = reporter
        self.history = history
        self.spec = study_spec(plan.loaded.study)
        self.robot = study_robot(plan.loaded.study)
        self.by_name = {s.name: s for s in plan.steps}
        self.done = {s.name for s in plan.steps if s.up_to_date}
        self.waiting = [s for s in plan.steps if not s.up_to_date]
        self.queue: deque[_Task] = deque()
        self.inflight: dict[Future, _Task] = {}
        self.results: dict[str, dict] = {}
        self.remaining: dict[str, int] = {}
        self.written: list[Path] = []
        self.computed = 0
        self.reused = 0
        self.notes: dict[str, str] = {}
        # finished blocks kept in memory for the consolidation (which reads the others back
        # from their shards); at most one write buffer of points, so memory stays flat
        self.held: dict[tuple[str, int], dict[str, np.ndarray]] = {}
        self.held_points = 0

    # starting steps -----------------------------------------------------------------------
    def _start_ready(self) -> None:
        for s in list(self.waiting):
            if all(d in self.done for d in s.deps):
                self.waiting.remove(s)
                self._start(s)

    def _start(self, s: StepPlan) -> None:
        out = self.plan.out
        if isinstance(s.step, GridStep):
            clean_parts(out, s.name, s.key)
            folder = shard_dir(out, s.name, s.key)
            s.saved = saved_blocks(folder, s.blocks)
            todo = s.todo_blocks()
            self.reused += len(s.saved)
            self.rep.start(s.name, len(s.blocks), len(s.saved), "blocks")
            self.remaining[s.name] = len(todo)
            for b in todo:
                self.queue.append(_Task(s, b, drivers.grid_block,
                                        (self.spec, None, s.step.skip_unreachable), {}))
            if not todo:
                self._finish(s)
        elif isinstance(s.step, RefineStep):
            st = s.step
            if isinstance(st.start, BestOfGrid):
                err, d1, d2 = D.read_grid_error(self.by_name[st.start.from_].path)
                try:
                    starts = D.best_grid_points(err, d1, d2, st.start.best)
                except ValueError as exc:
                    raise RunFailed(f"{s.name}: {exc}") from None
            else:
                starts = np.array([st.start], dtype=np.float64)
            kw = {"xatol": st.xatol, "fatol": st.fatol, "maxiter": st.maxiter,
                  "maxfev": st.maxfev, "penalty": st.penalty}
            self.rep.start(s.name, len(starts), 0, "refinements")
            self.remaining[s.name] = len(starts)
            self.results[s.name] = {}
            for i, x0 in enumerate(starts):
                self.queue.append(_Task(s, i, drivers.refine_task,
                                        (self.spec, (float(x0[0]), float(x0[1]))), kw))
        elif isinstance(s.step, ANALYSIS_STEPS):
            AS.start(self, s)
        else:
            st = s.step
            tick = st.controller.tick if st.controller.tick is not None else \
                self.plan.loaded.study.gait.tick
            max_drop = st.max_drop if st.max_drop is not None else self.robot.link1.length
            self.rep.start(s.name, 1, 0, "runs")
            self.remaining[s.name] = 1
            if self.plan.loaded.study.gait.kind == "sequence":
                gait = AS.sequence_start(self, s)
                kw = {"cycles": st.cycles, "tick": tick, "sample_dt": st.sample_dt,
                      "max_drop": max_drop, "replay": st.replay or "gait"}
                self.results[s.name] = {"gait": gait, "options": kw}
                self.queue.append(_Task(s, None, drivers.sequence_stability_task,
                                        (self.spec, gait["z"]), kw))
                return
            gait, idx = D.read_refined(self.by_name[st.from_].path, st.start_index)
            gait["start_index"] = idx
            kw = {"cycles": st.cycles, "tick": tick, "clock": st.controller.clock,
                  "sample_dt": st.sample_dt, "max_drop": max_drop}
            self.results[s.name] = {"gait": gait, "options": kw}
            self.queue.append(_Task(s, None, drivers.stability_task, (self.spec, gait), kw))

    # tasks ----------------------------------------------------------------------------------
    def _submit(self, t: _Task) -> None:
        args = t.args
        if isinstance(t.tag, Block) and isinstance(t.step.step, GridStep):
            args = (args[0], grid_points(t.step.step, t.tag.lo, t.tag.hi), args[2])
        self.inflight[self.pool.submit(t.fn, *args, **t.kwargs)] = t

    def _handle(self, t: _Task, value: Any) -> None:
        s = t.step
        if isinstance(t.tag, Block):
            write_shard(shard_dir(self.plan.out, s.name, s.key), t.tag, value)
            s.saved.add(t.tag.index)
            self.computed += 1
            if isinstance(s.step, GridStep) and \
                    self.held_points + t.tag.size <= D.WRITE_BUFFER_POINTS:
                self.held[(s.name, t.tag.index)] = value
                self.held_points += t.tag.size
        elif isinstance(s.step, RefineStep):
            self.results[s.name][t.tag] = value
        elif isinstance(s.step, ANALYSIS_STEPS):
            AS.handle(self, t, value)
        else:
            self.results[s.name]["result"] = value
        self.rep.advance(s.name)
        self.remaining[s.name] -= 1
        if self.remaining[s.name] == 0:
            self._finish(s)

    def _finish(self, s: StepPlan) -> None:
        attrs = step_attrs(self.plan.loaded, s.step, self.history)
        attrs["step_sha256"] = s.key
        st = s.step
        if isinstance(st, GridStep):
            folder = shard_dir(self.plan.out, s.name, s.key)
            variables = drivers.grid_variables(self.spec)
            blocks = ((b.lo, self._held(s, b) or read_shard(folder, b, tuple(variables)))
                      for b in s.blocks)
            attrs["block_size"] = st.points_per_block
            where = ({"points": grid_points(st)} if st.points is not None else
                     {"axes": (st.dtheta1.values(), st.dtheta2.values())})
            info = D.write_grid(s.path, attrs, blocks=blocks, variables=variables,
                                n_segments=drivers.n_cycle_segments(self.spec), **where)
            clean_parts(self.plan.out, s.name, None)
            msg = f"{info['n_points']} points, skipped_fraction {info['skipped_fraction']:.3f}"
        elif isinstance(st, RefineStep):
            res = self.results.pop(s.name)
            results = [res[i] for i in range(len(res))]
            multi = isinstance(st.start, BestOfGrid)
            attrs.update(method=st.method, xatol=st.xatol, fatol=st.fatol,
                         maxiter=st.maxiter if st.maxiter is not None else -1,
                         maxfev=st.maxfev if st.maxfev is not None else -1,
                         penalty=st.penalty,
                         start=st.start.model_dump(mode="json", by_alias=True)
                         if multi else list(st.start))
            D.write_refine(s.path, attrs, results, multi)
            best = min(results, key=lambda r: r["error"] if math.isfinite(r["error"])
                       else math.inf)
            msg = (f"error {best['error']:.3g} at ({best['x'][0]:.6g}, {best['x'][1]:.6g}), "
                   f"{sum(r['nit'] for r in results)} iterations")
        elif isinstance(st, ANALYSIS_STEPS):
            msg = AS.finish(self, s, attrs)
        else:
            res = self.results.pop(s.name)
            gait, kw, r = res["gait"], res["options"], res["result"]
            if "replay" in kw:   # a sequence gait
                attrs.update(AS.sequence_attrs(gait, kw["replay"]),
                             controller={"tick": kw["tick"], "clock": "reset_at_section"},
                             sample_dt=kw["sample_dt"], max_drop=kw["max_drop"],
                             cycles=kw["cycles"], t_segment=list(r["t_segment"]))
                gait = {"dtheta1": gait["z"][1], "dtheta2": gait["z"][2]}
            else:
                attrs.update(controller={"tick": kw["tick"], "clock": kw["clock"]},
                             sample_dt=kw["sample_dt"], max_drop=kw["max_drop"],
                             cycles=kw["cycles"], refine_step=st.from_,
                             refine_start=gait["start_index"], replay="open_loop")
            D.write_stability(s.path, attrs, r, gait)
            from ..kernel.layout import STATUS_NAMES
            msg = f"{r['cycles_completed']} cycles, status {STATUS_NAMES[r['status']]}"
        self.written.append(s.path)
        self.done.add(s.name)
        self.notes[s.name] = msg
        self.rep.finish(s.name, msg)

    def _held(self, s: StepPlan, b: Block) -> dict[str, np.ndarray] | None:
        value = self.held.pop((s.name, b.index), None)
        if value is not None:
            self.held_points -= b.size
        return value

    # the loop -------------------------------------------------------------------------------
    def run(self) -> None:
        failure: BaseException | None = None
        broken: BaseException | None = None
        limit = 2 * self.pool.slots
        while True:
            if failure is None and broken is None:
                self._start_ready()
                while self.queue and len(self.inflight) < limit:
                    if any(x.exclusive for x in self.inflight.values()) or \
                            (self.queue[0].exclusive and self.inflight):
                        break   # an exclusive task runs alone: wait for the pool to drain
                    t = self.queue.popleft()
                    try:
                        self._submit(t)
                    except BrokenProcessPool as exc:  # a worker died since the last wait
                        broken = exc
                        break
            if not self.inflight and broken is None:
                break
            finished, _ = wait(list(self.inflight), timeout=0.5, return_when=FIRST_COMPLETED) \
                if self.inflight else (set(), set())
            for f in finished:
                t = self.inflight.pop(f)
                try:
                    exc = f.exception()
                except CancelledError as e:  # e.g. a Dask cluster cancelled it
                    exc = e
                if exc is None:
                    if failure is None:
                        try:
                            self._handle(t, f.result())
                        except Exception as e:  # writing failed
                            failure = e
                    elif isinstance(t.tag, Block):  # keep finished work
                        self._handle_quiet(t, f.result())
                elif _is_lost_worker(exc):
                    broken = broken or exc
                elif failure is None:
                    failure = RunFailed(f"{t.step.name}: task "
                                        f"{t.tag.id if isinstance(t.tag, Block) else t.tag} "
                                        f"failed: {type(exc).__name__}: {exc}\n"
                                        + "".join(traceback.format_exception(exc)))
            if broken is not None:
                self.pool.abort()
                raise RunInterrupted(f"a worker died ({type(broken).__name__}: {broken}); "
                                     f"finished blocks are saved, rerun to resume")
        if failure is not None:
            if isinstance(failure, RunFailed):
                raise failure
            raise RunFailed(f"{type(failure).__name__}: {failure}") from failure
        if self.waiting:
            raise RunFailed("steps never became ready: "
                            + ", ".join(s.name for s in self.waiting))

    def _handle_quiet(self, t: _Task, value: Any) -> None:
        try:
            write_shard(shard_dir(self.plan.out, t.step.name, t.step.key), t.tag, value)
        except Exception:
            pass


def _is_lost_worker(exc: BaseException) -> bool:
    if isinstance(exc, BrokenProcessPool):
        return True
    return type(exc).__name__ in ("KilledWorker", "CommClosedError", "FutureCancelledError",
                                  "CancelledError")


def run_study(loaded: LoadedStudy, out: str | Path | None = None, *,
              workers: int | None = None, scheduler: str | None = None,
              reporter: Reporter | None = None, command: str | None = None,
              pool: Pool | None = None) -> RunSummary:
    """Run a study: every step not up to date, resuming from saved shards.

    ``pool``: a resident pool to run on instead of opening one (``monkeystudy serve``); it
    stays open after a finished run and is aborted (its workers stopped) after any other end,
    so that no task of this run outlives it: check :attr:`Pool.usable` before reusing it.

    Raises :class:`RunFailed` (a task raised, exit 1) or :class:`RunInterrupted` (Ctrl-C,
    SIGTERM or a dead worker, exit 3; rerun to resume).
    """
    if pool is not None and (workers is not None or scheduler):
        raise ValueError("workers and scheduler choose a pool: not with pool=")
    reporter = reporter or Reporter()
    plan = plan_study(loaded, out)
    current = [s.path for s in plan.steps if s.up_to_date]
    if plan.up_to_date:
        reporter.log(f"{loaded.study.name}: all {len(plan.steps)} datasets up to date in "
                     f"{plan.out}")
        return RunSummary(plan.out, [], current, 0, 0)
    plan.out.mkdir(parents=True, exist_ok=True)
    history = P.history_line(command if command is not None else
                             f"python: monkeystudy.study.run_study({str(loaded.path)!r})")
    todo = [s for s in plan.steps if not s.up_to_date]
    spec = study_spec(loaded.study)
    run = None
    try:
        def warm_up():
            if pool is None:   # a resident pool's process has them (see _resident)
                reporter.log("loading the compiled kernels (the first run after a change "
                             "compiles them: a few minutes)")
            drivers.warm_up(spec, stability=any(
                isinstance(s.step, (StabilityStep,) + ANALYSIS_STEPS) for s in todo))
            if any(isinstance(s.step, (FloquetStep, ContinuationStep)) for s in todo):
                analysis_tasks.warm_up(spec)

        with (open_pool(workers, scheduler, warm_up) if pool is None
              else _resident(pool, warm_up)) as used:
            reporter.log(f"{loaded.study.name}: {len(todo)} step(s) to run on {used.kind} "
                         f"-> {plan.out}")
            run = _Run(plan, used, reporter, history)
            run.run()
    except KeyboardInterrupt:
        saved = sum(len(s.saved) for s in plan.steps
                    if isinstance(s.step, (GridStep, BasinStep)))
        raise RunInterrupted(f"interrupted; {saved} finished blocks are saved, rerun to "
                             "resume") from None
    return RunSummary(plan.out, run.written, current, run.computed, run.reused, run.notes)


@contextmanager
def _resident(pool: Pool, warm_up: Callable[[], None]) -> Iterator[Pool]:
    """Run on a pool that outlives the run; abort it unless the run finishes."""
    from ..simulate import loaded_kernels
    before = loaded_kernels()
    warm_up()
    if loaded_kernels() != before:
        pool.renew()   # this run needs kernels the workers were forked without
    ok = False
    try:
        yield pool
        ok = True
    finally:
        if not ok:
            pool.abort()


# --- programmatic grids (benchmarks) -----------------------------------------------------------------
def run_grid(dtheta1, dtheta2=None, *, robot: RobotLike = "seed2009",
             torque: float = SEED2009_TORQUE, tick: float = 0.0,
             integrator: Integrator = Integrator(), skip_unreachable: bool = True,
             block_size: int = 512, workers: int | None = None,
             executor: Executor | None = None) -> dict[str, Any]:
    """Evaluate the horizontal gait on a grid, in memory, with the study runner's blocks.

    Parameters
    ----------
    dtheta1, dtheta2 : array_like
        Axis values [rad s-1] (results shaped ``(len(dtheta1), len(dtheta2))``), or
        ``dtheta1`` alone as points ``[n, 2]`` (results shaped ``(n,)``).
    robot, torque, tick, integrator, skip_unreachable
        As :func:`monkeystudy.evaluate_gaits` (torque [N m], tick [s]).
    block_size : int
        Points per task.
    workers : int, optional
        Local processes (default: all cores); ``0`` evaluates in this process, no pool.
    executor : concurrent.futures.Executor, optional
        Use this executor instead (e.g. ``distributed.Client(addr).get_executor()``).

    Returns
    -------
    dict
        ``error``, ``status``, ``t_switch``, ``t_motor``, ``t_end``, ``steps``, ``nfev``,
        ``rejected`` arrays, and ``skipped_fraction``.
    """
    robot = as_robot(robot)
    spec = drivers.make_spec(robot, torque, tick, integrator)
    if dtheta2 is None:
        pts = np.asarray(dtheta1, np.float64).reshape(-1, 2)
        shape = (pts.shape[0],)

        def points(lo, hi):
            return pts[lo:hi]
    else:
        a1 = np.asarray(dtheta1, np.float64).ravel()
        a2 = np.asarray(dtheta2, np.float64).ravel()
        shape = (a1.size, a2.size)

        def points(lo, hi):
            return _axes_points(a1, a2, lo, hi)
    n = int(np.prod(shape))
    out = {k: np.empty(n, dt) for k, dt in drivers.GRID_VARIABLES.items()}
    blocks = make_blocks(n, int(block_size))

    def put(b: Block, r: dict) -> None:
        for k in out:
            out[k][b.lo:b.hi] = r[k]

    if executor is None and workers == 0:
        for b in blocks:
            put(b, drivers.grid_block(spec, points(b.lo, b.hi), skip_unreachable))
    else:
        drivers.warm_up(spec)
        with ExitStack() as stack:
            if executor is None:
                pool = stack.enter_context(open_pool(workers))
                ex, slots = pool.executor, pool.slots
            else:
                ex, slots = executor, 8
            pending: dict[Future, Block] = {}
            it = iter(blocks)
            while True:
                while len(pending) < 2 * slots:
                    b = next(it, None)
                    if b is None:
                        break
                    pending[ex.submit(drivers.grid_block, spec, points(b.lo, b.hi),
                                      skip_unreachable)] = b
                if not pending:
                    break
                finished, _ = wait(list(pending), return_when=FIRST_COMPLETED)
                for f in finished:
                    put(pending.pop(f), f.result())
    res: dict[str, Any] = {k: v.reshape(shape) for k, v in out.items()}
    res["skipped_fraction"] = float(np.mean(out["status"] == 5)) if n else 0.0
    return res


__all__ = ["Plan", "RunFailed", "RunInterrupted", "RunSummary", "open_pool", "plan_study",
           "run_grid", "run_study"]
