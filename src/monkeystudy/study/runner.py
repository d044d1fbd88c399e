"""Run studies: start each step when its dependencies are done, fan its tasks out, keep the
results, write the dataset, resume.

One loop serves every step kind (:mod:`monkeystudy.study.steps`): a kind turns its step into
tasks (:meth:`~monkeystudy.study.steps.base.StepKind.start`) and its results into a dataset
(:meth:`~monkeystudy.study.steps.base.StepKind.finish`); the runner only moves values between
them. Tasks tagged with a block are saved as shards the moment they finish (a rerun skips
them); the datasets do not depend on which blocks were computed when, nor where, nor by how
many workers. Steps run in dependency order; independent steps share the pool. A step that
fails stops only itself and the steps built on it, leaving failure markers
(:mod:`monkeystudy.study.failures`); the run ends naming every failure. Tasks run on a local
process pool or a Dask cluster (:mod:`monkeystudy.study.pool`).
"""
from __future__ import annotations

import math
import queue
import threading
import time
import traceback
import uuid
from collections import deque
from concurrent.futures import FIRST_COMPLETED, CancelledError, Executor, Future, wait
from concurrent.futures.process import BrokenProcessPool
from contextlib import ExitStack, contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Iterator

import numpy as np

from .. import __version__, compiling
from ..compiling import KERNEL_CACHE_DIR
from ..controllers import Integrator, horizontal_gait
from ..robot import SEED2009_TORQUE
from ..simulation import (
    RobotLike, Status, as_robot, initial_state, loaded_kernels, run_controller,
)
from . import datasets as D
from . import provenance as P
from .blocks import Block, Task, clean_parts, make_blocks, read_shard, saved_blocks, shard_dir, \
    write_shard
from .errors import RunFailed, RunInterrupted
from .failures import FAILED, NOT_RUN, StepFailure, clear_failures, write_failure
from .loader import LoadedStudy
from .models import UrdfRobotParams
from .plan import Plan, StepPlan, plan_study
from .pool import DeferredSignals, Pool, local_pool_kind, open_pool
from .counts import StepProgress, TaskPhase, run_counted
from .progress import Reporter, all_of, count, singular_counts
from .spec import GaitSpec, gait_json, gait_spec, integrator_fields
from .steps import Dependency, StepContext, kind_of
from .steps.grid import HORIZONTAL_VARIABLES, axes_points, grid_block


@dataclass
class RunSummary:
    """What a run did: the datasets it wrote and found up to date, the blocks it computed and
    reused, each written step's one-line summary (``notes``), and the steps that wrote no
    dataset: ``failed`` and ``not_run`` (a step they depend on failed), each with the reason
    (their markers: :mod:`~monkeystudy.study.failures`)."""

    out: Path
    written: list[Path]
    up_to_date: list[Path]
    blocks_computed: int
    blocks_reused: int
    notes: dict[str, str] = field(default_factory=dict)
    failed: dict[str, str] = field(default_factory=dict)
    not_run: dict[str, str] = field(default_factory=dict)


class StepsFailed(RunFailed):
    """Some steps of a run failed (exit code 1); every step whose dependencies succeeded ran.
    ``summary`` (a :class:`RunSummary`) says what was written, what failed and why, and what
    was not run."""

    def __init__(self, summary: RunSummary):
        self.summary = summary
        super().__init__(failures_text(summary))


def failures_text(summary: RunSummary) -> str:
    """The steps of a run that wrote no dataset, one line each: ``<step>: <reason>``, and
    ``<step>: not run: ...``; a count first when there is more than one."""
    lines = [f"{name}: {why}" for name, why in summary.failed.items()] + \
        [f"{name}: not run: {why}" for name, why in summary.not_run.items()]
    if len(lines) == 1:
        return lines[0]
    head = (f"{count(len(summary.failed), 'step')} failed"
            + (f", {len(summary.not_run)} not run" if summary.not_run else "") + ":")
    return "\n  ".join([head] + lines)


def urdf_attrs(loaded: LoadedStudy) -> dict:
    """A robot read from a URDF: ``robot_urdf``, the file as the study names it (relative to
    the study file's folder), and ``robot_urdf_sha256``, the hash of its bytes; empty for
    any other robot."""
    robot = loaded.study.robot
    if not isinstance(robot, UrdfRobotParams):
        return {}
    base = loaded.path.parent if loaded.path is not None else Path(".")
    return {"robot_urdf": robot.urdf,
            "robot_urdf_sha256": P.file_sha256(base / Path(robot.urdf).expanduser())}


def step_attrs(loaded: LoadedStudy, step, history: str) -> dict:
    """Global attributes of a step's dataset (docs/datasets.md), before the step's own; a
    gait that states its torques' frame (``torque_frame``) or its route's rise per cycle
    (``rise`` [m]) is named with it, a robot read from a URDF names the file and its hash
    (:func:`urdf_attrs`), and a study without a gait has no ``gait`` attribute."""
    study = loaded.study
    frame = ({"torque_frame": study.gait.torque_frame}
             if study.gait is not None and "torque_frame" in study.gait.model_fields_set
             else {})
    if study.gait is not None and "rise" in study.gait.model_fields_set:
        frame["rise"] = float(study.gait.rise)
    gait = {"gait": gait_json(study)} if study.gait is not None else {}
    return {
        "title": f"{study.name}: {step.name}",
        "study_name": study.name, "step_name": step.name, "step_kind": step.kind,
        "study_description": study.description,
        "step": step.model_dump(mode="json", by_alias=True),
        "study_text": loaded.text, "study_sha256": loaded.sha256,
        "robot": study.to_robot().to_dict(), **gait,
        "integrator": integrator_fields(study.integrator.to_integrator()),
        "monkeystudy_version": __version__, "git_revision": P.git_revision(),
        "code_sha256": kind_of(step).code_sha256, "library_versions": P.library_versions(),
        "history": history, "Conventions": D.CONVENTIONS, "source": "monkeystudy",
        **frame, **urdf_attrs(loaded),
    }


def kernel_specs(spec: GaitSpec, steps: list[StepPlan]) -> list[tuple[GaitSpec,
                                                                    list[StepPlan]]]:
    """What a run of ``steps`` compiles before fanning out, each with the steps it serves: the
    study's ``spec`` (its gait and integrator) for the steps that run the gait, and for those
    that do not (:attr:`~monkeystudy.study.steps.base.StepKind.runs_gait`), a spec without a
    gait per integration method of their own integrators
    (:attr:`~monkeystudy.study.steps.base.StepKind.own_integrator`) unless the study's spec
    loads that method's kernels already."""
    out: list[tuple[GaitSpec, list[StepPlan]]] = []
    gait = [s for s in steps if s.kind.runs_gait]
    if gait:
        out.append((spec, gait))
    own: dict[str, list[StepPlan]] = {}
    integrators: dict[str, Integrator] = {}
    for s in steps:
        integ = s.kind.own_integrator
        if s.kind.runs_gait or integ is None:
            continue
        if gait and integ.method == spec.integrator.method:
            gait.append(s)     # its runs compile with the gait's
        else:
            own.setdefault(integ.method, []).append(s)
            integrators.setdefault(integ.method, integ)
    out += [(GaitSpec(spec.robot, integrators[m], math.nan, math.nan, has_gait=False), own[m])
            for m in own]
    return out


def kernels_marker(method: str, *, runs: bool = False, variational: bool = False,
                   gait: bool = True) -> Path | None:
    """A file in the kernel cache (keyed by every kernel source) that :func:`load_kernels`
    leaves once these kernels were compiled for the integration ``method`` (each method is its
    own specialisation; ``gait`` False: without the gait evaluation, :func:`kernel_specs`): its
    absence means a first run, which compiles. None when the cache is not ours (a read-only
    home)."""
    if not KERNEL_CACHE_DIR:
        return None
    return Path(KERNEL_CACHE_DIR) / "-".join(["loaded", method] + ["runs"] * runs
                                             + ["variational"] * variational
                                             + ["without-gait"] * (not gait))


def load_kernels(spec: GaitSpec, *, runs: bool = False, variational: bool = False,
                 ahead: bool = False) -> None:
    """Compile (or load from the on-disk cache) the kernels the tasks use, once, in the
    driver, before fanning out: parallel first compiles would race on the cache.

    The gait evaluation, unless ``spec`` has no gait (``has_gait`` False); ``runs``: the
    controller runs of multi-cycle steps (without a gait, of the steps' own controllers: a
    horizontal gait's controller compiles the same loop); ``variational``: the
    variational-equation kernels of floquet and continuation steps. ``ahead`` (a first run,
    nothing cached): a second process compiles the hybrid loop's callees meanwhile
    (:mod:`monkeystudy.compiling`); it is stopped once the gait evaluation is loaded, before
    anything else compiles (the runs link the same compiled loop).
    """
    gait = spec.sequence if spec.has_gait else horizontal_gait(SEED2009_TORQUE)
    ctrl = gait.controller() if runs else None
    helper = compiling.start(spec.integrator.method) if ahead and spec.has_gait else None

    def compile_all():
        try:
            if spec.has_gait:
                grid_block(spec, np.array([[1.0, 11.0]]))
        finally:
            compiling.stop(helper)   # the loop's callees are all here now
        if ctrl is not None:
            run_controller(ctrl, initial_state(1.0, 11.0), robot=spec.robot,
                           integrator=spec.integrator, t_end=0.05, sample_dt=0.01)
        if variational:
            compiling.compile_variational(spec.robot.params())

    try:
        # on a thread of its own, so that a Ctrl-C stops the wait at once (compiling.py)
        compiling.on_own_thread(compile_all)
    finally:
        compiling.stop(helper)      # an interrupted wait leaves no helper compiling on
    marker = kernels_marker(spec.integrator.method, runs=runs, variational=variational,
                            gait=spec.has_gait)
    if marker is not None:
        try:
            marker.touch()
        except OSError:
            pass


# --- the run loop ----------------------------------------------------------------------------
@dataclass
class _Pending:
    """A task in the queue or on the pool, with the step it belongs to."""

    step: StepPlan
    task: Task
    key: tuple = ()


class TaskCounts:
    """The progress count of each task on the pool, from what its worker sends as it goes
    (:func:`~monkeystudy.study.counts.task_units`, read on a thread of its own: the
    count moves while the driver works on a step) and the rest when its result comes: a
    task adds its ``units`` to its step's count, never more.

    A long task may count in phases of its own (:func:`~monkeystudy.study.counts.
    task_phase`, e.g. a fit's residual evaluations): each is a count of its own under its
    step (``<step>: <phase>``, up to the phase's total) beside the step's count of tasks,
    which the task adds its ``units`` to when its result comes."""

    def __init__(self, reporter: Reporter):
        self.rep = reporter
        self.lock = threading.Lock()
        # key -> [step name, units, units counted, its phase's count's name ("": none),
        # the phase's total, the phase's units counted]
        self.open: dict[tuple, list] = {}
        # a resident pool's channel may still hold counts of an earlier run's tasks: keys
        # are this run's own
        self.run = uuid.uuid4().hex
        self.n = 0

    def add(self, step: str, units: int) -> tuple:
        """A task of ``step`` counting ``units`` goes to the pool: its key."""
        with self.lock:
            self.n += 1
            key = (self.run, self.n)
            self.open[key] = [step, int(units), 0, "", 0, 0]
            return key

    def sent(self, key: tuple, n) -> None:
        """The worker of task ``key`` did ``n`` more units (an int), or began a phase (a
        :class:`~monkeystudy.study.counts.TaskPhase`)."""
        with self.lock:
            c = self.open.get(key)
            if c is None:
                return
            if isinstance(n, TaskPhase):
                self._end_phase(c)
                c[3:6] = [f"{c[0]}: {n.label}", n.total, 0]
                self.rep.start(c[3], n.total, 0, n.unit)
                return
            if c[3]:
                n = min(int(n), c[4] - c[5])
                if n > 0:
                    c[5] += n
                    self.rep.advance(c[3], n)
                return
            n = min(int(n), c[1] - c[2])
            if n > 0:
                c[2] += n
                self.rep.advance(c[0], n)

    def _end_phase(self, c: list) -> None:
        """The phase of task ``c`` (if any) is over: its count whole and finished."""
        if c[3]:
            if c[4] > c[5]:
                self.rep.advance(c[3], c[4] - c[5])
            self.rep.finish(c[3])
            c[3] = ""

    def done(self, key: tuple) -> None:
        """Task ``key``'s result came: its units not yet counted are (and its phase is
        over)."""
        with self.lock:
            c = self.open.pop(key, None)
            if c is None:
                return
            self._end_phase(c)
            if c[1] > c[2]:
                self.rep.advance(c[0], c[1] - c[2])

    def drop(self, key: tuple) -> None:
        """Task ``key`` counts no more (its step failed)."""
        with self.lock:
            self.open.pop(key, None)

    def listen(self, channel) -> "threading.Thread | None":
        """Read the pool's progress ``channel`` on a daemon thread until :meth:`stop`."""
        if channel is None:
            return None
        self._stop = threading.Event()

        def read():
            while not self._stop.is_set():
                try:
                    key, n = channel.get(timeout=0.25)
                except queue.Empty:
                    continue
                except (OSError, EOFError, ValueError):   # the pool was stopped
                    return
                self.sent(key, n)
        thread = threading.Thread(target=read, name="monkeystudy-counts", daemon=True)
        thread.start()
        return thread

    def stop(self, thread: "threading.Thread | None") -> None:
        if thread is not None:
            self._stop.set()
            thread.join(timeout=5)


class StoppingProgress(StepProgress):
    """A step's progress in the driver (:class:`~monkeystudy.study.counts.StepProgress`)
    whose every phase start and every unit counted is also a point where the run may stop:
    ``stop_point`` is called there (the run's :meth:`~monkeystudy.study.pool.DeferredSignals.
    check`, which raises the interruption a deferred Ctrl-C or SIGTERM asks for). The work of
    a kind's :meth:`~monkeystudy.study.steps.base.StepKind.finish` is in memory until it writes
    its dataset, after its last count, so stopping at a count loses no written file; a long
    phase (a design's refine, screen, checks) then stops within a unit of its work instead of
    when the step ends."""

    def __init__(self, reporter, name: str, stop_point: Callable[[], None]):
        super().__init__(reporter, name)
        self.stop_point = stop_point

    def phase(self, label: str, total: int, unit: str,
              then: str = "") -> Callable[[int], None]:
        self.stop_point()
        advance = super().phase(label, total, unit, then)
        stop_point = self.stop_point

        def advance_or_stop(n: int = 1) -> None:
            advance(n)
            stop_point()
        return advance_or_stop


class StudyRun:
    """One run of a plan on a pool: starts steps when their dependencies are done, keeps the
    results of their tasks, and finishes each step when its last task is in; a step that
    fails is set aside with the steps built on it (:meth:`_fail`)."""

    def __init__(self, plan: Plan, pool: Pool, reporter: Reporter, history: str,
                 pause_after_blocks: int | None = None):
        self.plan = plan
        self.pause_after_blocks = pause_after_blocks
        self.pool = pool
        self.rep = reporter
        self.counts = TaskCounts(reporter)
        self.history = history
        self.spec = gait_spec(plan.loaded.study)
        self.by_name = {s.name: s for s in plan.steps}
        self.done = {s.name for s in plan.steps if s.up_to_date}
        self.waiting = [s for s in plan.steps if not s.up_to_date]
        self.queue: deque[_Pending] = deque()
        self.inflight: dict[Future, _Pending] = {}
        self.contexts: dict[str, StepContext] = {}
        self.remaining: dict[str, int] = {}
        self.written: list[Path] = []
        self.computed = 0
        self.reused = 0
        self.notes: dict[str, str] = {}
        # finished blocks kept in memory for the consolidation (which reads the others back
        # from their shards); at most one write buffer of points, so memory stays flat
        self.held: dict[tuple[str, int], dict[str, np.ndarray]] = {}
        self.held_points = 0
        # the steps that wrote no dataset, with the reason (their markers say it too)
        self.failed: dict[str, str] = {}
        self.not_run: dict[str, str] = {}
        # Ctrl-C and SIGTERM while the run is on: acted on between waits and at each count of
        # a step's work in the driver (StoppingProgress)
        self.signals = DeferredSignals()

    # starting and finishing steps ---------------------------------------------------------
    def _start_ready(self) -> None:
        for s in list(self.waiting):
            if all(d in self.done for d in s.deps):
                self.waiting.remove(s)
                self._start(s)

    def _context(self, s: StepPlan) -> StepContext:
        out = self.plan.out
        deps = {d: Dependency(self.by_name[d].step, self.by_name[d].path, self.by_name[d].kind)
                for d in s.deps}
        return StepContext(step=s.step, study=self.plan.loaded.study, spec=self.spec,
                           path=s.path, out=out, key=s.key, deps=deps, blocks=s.blocks,
                           read_block=lambda b, s=s: self._block_arrays(s, b),
                           progress=StoppingProgress(self.rep, s.name, self.signals.check))

    def _start(self, s: StepPlan) -> None:
        try:
            self._start_tasks(s)
        except Exception as exc:      # a refusal, a write, a fault: the step's alone
            self._fail(s, exc)

    def _start_tasks(self, s: StepPlan) -> None:
        ctx = self._context(s)
        if s.blocks:
            clean_parts(self.plan.out, s.name, s.key)
            s.saved = saved_blocks(shard_dir(self.plan.out, s.name, s.key), s.blocks)
            ctx.saved = s.saved
        tasks = s.kind.start(ctx)
        self.contexts[s.name] = ctx
        if s.blocks:
            self.reused += len(s.saved)

            def units(b: Block) -> int:
                return b.size if s.kind.block_units else 1
            for t in tasks:
                if isinstance(t.tag, Block):
                    t.units = units(t.tag)
            total = sum(units(b) for b in s.blocks)
            done = sum(units(b) for b in s.blocks if b.index in s.saved)
        else:
            total, done = sum(t.units for t in tasks), 0
        self.rep.start(s.name, total, done, s.kind.unit)
        phases = s.kind.phases(s.step)
        if phases:      # the tasks are its first phase: the line says what follows
            self.rep.phase(s.name, phases[0], total, s.kind.unit, ", ".join(phases[1:]), done)
        self.remaining[s.name] = len(tasks)
        for t in tasks:
            self.queue.append(_Pending(s, t))
        if not tasks:
            self._finish(s)

    def _finish(self, s: StepPlan) -> None:
        self.remaining.pop(s.name, None)
        attrs = step_attrs(self.plan.loaded, s.step, self.history)
        attrs["step_sha256"] = s.key
        msg = singular_counts(s.kind.finish(self.contexts.pop(s.name), attrs))
        if s.blocks:
            clean_parts(self.plan.out, s.name, None)
        self.written.append(s.path)
        self.done.add(s.name)
        self.notes[s.name] = msg
        self.rep.finish(s.name, msg)

    def _fail(self, s: StepPlan, exc: BaseException, task: Task | None = None) -> None:
        """Step ``s`` failed with ``exc`` (raised by ``task``, or by the driver's part of the
        step): drop its queued tasks and what it holds, record why (its marker), and the
        same for every waiting step that depends on it, directly or not. Its tasks still on
        the pool finish; their blocks are saved (:meth:`_keep_block`)."""
        if s.name in self.failed:
            return
        reason = failure_reason(s.name, exc, task)
        self.failed[s.name] = reason
        if not isinstance(exc, RunFailed):   # a fault: its traceback, for whoever fixes it
            self.rep.log("".join(traceback.format_exception(exc)).rstrip())
        self.queue = deque(p for p in self.queue if p.step is not s)
        self.contexts.pop(s.name, None)
        self.remaining.pop(s.name, None)
        for b in s.blocks:
            if self.held.pop((s.name, b.index), None) is not None:
                self.held_points -= b.size
        self._record(s, FAILED, reason)
        self.rep.fail(s.name, f"failed: {reason}")
        blocked = {s.name}
        while True:
            stuck = [w for w in self.waiting if set(w.deps) & blocked]
            if not stuck:
                break
            for w in stuck:
                self.waiting.remove(w)
                dep = next(d for d in w.deps if d in blocked)
                why = (f"step {dep!r}, which it depends on, "
                       + ("failed" if dep in self.failed else "was not run"))
                self.not_run[w.name] = why
                blocked.add(w.name)
                self._record(w, NOT_RUN, why)
                self.rep.fail(w.name, f"not run: {why}")

    def _record(self, s: StepPlan, state: str, reason: str) -> None:
        """Leave the step's failure marker (a run that cannot write it still reports the
        failure at its end)."""
        study = self.plan.loaded
        try:
            write_failure(self.plan.out, StepFailure(s.name, s.step.kind, state, reason,
                                                     study.study.name, study.text))
        except OSError as exc:
            self.rep.log(f"{s.name}: could not record the failure: {exc}")

    def _block_arrays(self, s: StepPlan, b: Block) -> dict[str, np.ndarray]:
        value = self.held.pop((s.name, b.index), None)
        if value is not None:
            self.held_points -= b.size
            return value
        return read_shard(shard_dir(self.plan.out, s.name, s.key), b)

    # tasks ----------------------------------------------------------------------------------
    def _submit(self, p: _Pending) -> None:
        t = p.task
        p.key = self.counts.add(p.step.name, t.units)
        try:
            self.inflight[self.pool.submit(run_counted, p.key, t.fn, t.args, t.kwargs)] = p
        except BaseException:
            self.counts.drop(p.key)
            raise

    def _handle(self, p: _Pending, value: Any) -> None:
        s, tag = p.step, p.task.tag
        if isinstance(tag, Block):
            write_shard(shard_dir(self.plan.out, s.name, s.key), tag, value)
            s.saved.add(tag.index)
            self.computed += 1
            if self.held_points + tag.size <= D.WRITE_BUFFER_POINTS:
                self.held[(s.name, tag.index)] = value
                self.held_points += tag.size
        else:
            self.contexts[s.name].results[tag] = value
        self.counts.done(p.key)
        self.remaining[s.name] -= 1
        if self.remaining[s.name] == 0:
            self._finish(s)

    def _keep_block(self, p: _Pending, value: Any) -> None:
        """Save a finished block after the run failed (finished work is never lost)."""
        try:
            write_shard(shard_dir(self.plan.out, p.step.name, p.step.key), p.task.tag, value)
        except Exception:
            pass

    def _fill(self) -> BaseException | None:
        """Submit queued tasks up to twice the pool's slots (an exclusive task alone);
        returns the error of a pool that broke since the last wait."""
        self._start_ready()
        while self.queue and len(self.inflight) < 2 * self.pool.slots and not self.paused:
            if any(x.task.exclusive for x in self.inflight.values()) or \
                    (self.queue[0].task.exclusive and self.inflight):
                break   # an exclusive task runs alone: wait for the pool to drain
            p = self.queue.popleft()
            try:
                self._submit(p)
            except BrokenProcessPool as exc:  # a worker died since the last wait
                return exc
        return None

    @property
    def paused(self) -> bool:
        """The test hook ``pause_after_blocks`` holds the run (:func:`run_study`)."""
        return self.pause_after_blocks is not None and \
            self.computed >= self.pause_after_blocks

    def _pause(self, signals: DeferredSignals) -> None:
        """Hold the run until a signal's handler raises or the pool loses a worker (the
        test hook)."""
        self.rep.log(f"paused after {count(self.computed, 'computed block')} "
                     "($MONKEYSTUDY_PAUSE_AFTER_BLOCKS), waiting for a signal")
        while self.pool.usable:
            signals.check()
            time.sleep(0.05)

    def run(self) -> None:
        """Submit, wait and handle until every step is done. Signals (Ctrl-C, SIGTERM) take
        effect between waits (:class:`~monkeystudy.study.pool.DeferredSignals`), at most half
        a second after they arrive, and, while a step works in the driver, at its next count
        (:class:`StoppingProgress`)."""
        listener = self.counts.listen(self.pool.progress)
        try:
            with self.signals as signals:
                self._loop(signals)
        finally:
            self.counts.stop(listener)

    def _loop(self, signals: DeferredSignals) -> None:
        """Run until nothing is queued, on the pool or waiting. A step that fails stops
        itself and the steps built on it; every other step runs on."""
        broken: BaseException | None = None
        while True:
            signals.check()
            if broken is None:
                broken = self._fill()
            if not self.inflight and broken is None:
                if self.paused and (self.queue or self.waiting):
                    self._pause(signals)
                    broken = BrokenProcessPool("a worker died while the run was paused")
                    continue
                break
            finished, _ = wait(list(self.inflight), timeout=0.5, return_when=FIRST_COMPLETED) \
                if self.inflight else (set(), set())
            finished = list(finished)
            for i, f in enumerate(finished):
                p = self.inflight.pop(f)
                exc = task_error(f)
                if exc is not None or p.step.name in self.failed:
                    self.counts.drop(p.key)
                if exc is None:
                    if p.step.name in self.failed:
                        if isinstance(p.task.tag, Block):   # keep finished work
                            self._keep_block(p, f.result())
                        continue
                    try:
                        self._handle(p, f.result())
                    except Exception as e:  # writing its shard or its dataset failed
                        self._fail(p.step, e)
                    except KeyboardInterrupt:
                        # stopped in a step's work in the driver (StoppingProgress): the
                        # blocks the same wait brought are finished work too
                        for g in finished[i + 1:]:
                            q = self.inflight.pop(g)
                            if isinstance(q.task.tag, Block) and task_error(g) is None:
                                self._keep_block(q, g.result())
                        raise
                elif is_lost_worker(exc):
                    broken = broken or exc
                else:
                    self._fail(p.step, exc, p.task)
            if broken is not None:
                self.pool.abort()
                failed = (f"; {count(len(self.failed), 'step')} failed before "
                          f"({', '.join(self.failed)})" if self.failed else "")
                raise RunInterrupted(f"a worker died ({type(broken).__name__}: {broken}); "
                                     "finished blocks are saved: rerun the same command to "
                                     f"resume{failed}")
        if self.waiting:
            raise RunFailed("steps never became ready: "
                            + ", ".join(s.name for s in self.waiting))


def task_error(f: Future) -> BaseException | None:
    """The exception a finished task raised, its cancellation's (e.g. a Dask cluster
    cancelled it), or None."""
    try:
        return f.exception()
    except CancelledError as e:
        return e


def failure_reason(step: str, exc: BaseException, task: Task | None = None) -> str:
    """Why step ``step`` failed, in one line: a refusal (:class:`RunFailed`: the step found
    nothing to work on) as it says it (without the step's name it may start with); any other
    exception (a fault) by its type, with the task that raised it."""
    if isinstance(exc, RunFailed):
        text = str(exc).removeprefix(f"{step}: ")
    else:
        text = f"{type(exc).__name__}: {exc}"
        if task is not None:
            text = f"task {task.tag.id if isinstance(task.tag, Block) else task.tag} " \
                   f"failed: {text}"
    return " ".join(text.split())


def is_lost_worker(exc: BaseException) -> bool:
    """The task's worker is gone (a dead local process, a lost Dask worker)."""
    if isinstance(exc, BrokenProcessPool):
        return True
    return type(exc).__name__ in ("KilledWorker", "CommClosedError", "FutureCancelledError",
                                  "CancelledError")


def run_study(loaded: LoadedStudy, out: str | Path | None = None, *,
              workers: int | None = None, scheduler: str | None = None,
              reporter: Reporter | None = None, command: str | None = None,
              pool: Pool | None = None, pause_after_blocks: int | None = None) -> RunSummary:
    """Run a study: every step not up to date, resuming from saved shards.

    ``pool``: a resident pool to run on instead of opening one (``monkeystudy serve``); it
    stays open after a finished run and is aborted (its workers stopped) after any other end,
    so that no task of this run outlives it: check :attr:`Pool.usable` before reusing it.

    ``pause_after_blocks`` (for testing interruptions; the command line reads
    ``$MONKEYSTUDY_PAUSE_AFTER_BLOCKS``): once this many blocks were computed, submit nothing
    more, say so and wait for a signal.

    A step that fails (a task raised, it found nothing to work on, its dataset could not be
    written) stops itself and the steps built on it, each leaving a failure marker with the
    reason (:mod:`~monkeystudy.study.failures`); every other step runs to its end.

    Raises :class:`StepsFailed` (a :class:`RunFailed`: some steps failed, the others ran;
    exit 1), :class:`RunFailed` (the run could not start, exit 1) or :class:`RunInterrupted`
    (Ctrl-C, SIGTERM or a dead worker, exit 3; rerun to resume).
    """
    if pool is not None and (workers is not None or scheduler):
        raise ValueError("workers and scheduler choose a pool: not with pool=")
    reporter = reporter or Reporter()
    plan = plan_study(loaded, out)
    current = [s.path for s in plan.steps if s.up_to_date]
    if plan.out.is_dir():
        clear_failures(plan.out)      # the markers say what the last run left undone
    if plan.up_to_date:
        reporter.log(f"{loaded.study.name}: {all_of(len(plan.steps), 'dataset')} up to date "
                     f"in {plan.out}")
        return RunSummary(plan.out, [], current, 0, 0)
    plan.out.mkdir(parents=True, exist_ok=True)
    history = P.history_line(command if command is not None else
                             f"python: monkeystudy.study.run_study({str(loaded.path)!r})")
    todo = [s for s in plan.steps if not s.up_to_date]
    spec = gait_spec(loaded.study)
    where = (pool.kind if pool is not None else f"dask {scheduler}" if scheduler else
             local_pool_kind(workers))
    reporter.log(f"{loaded.study.name}: {count(len(todo), 'step')} to run "
                 f"({', '.join(s.name for s in todo)}) on {where} -> {plan.out}")
    run = None
    try:
        def warm_up():
            for ks, steps in kernel_specs(spec, todo):
                warm_up_kernels(ks, steps)

        def warm_up_kernels(ks: GaitSpec, steps: list[StepPlan]):
            needs = {"runs": any(s.kind.needs_runs(s.step) for s in steps),
                     "variational": any(s.kind.needs_variational(s.step) for s in steps)}
            method = ks.integrator.method
            marker = kernels_marker(method, **needs, gait=ks.has_gait)
            # nothing loaded yet for this method: compile the loop's callees on the idle core
            first = marker is not None and not any(marker.parent.glob(f"loaded-{method}*"))

            def load():
                load_kernels(ks, **needs, ahead=first)
            if pool is not None or marker is None or marker.exists():
                load()     # cached: loads in about a second, silently
                return
            what = marker.name.removeprefix("loaded-")
            with reporter.waiting(f"compiling the kernels this study uses ({method}), as the "
                                  f"first run with this code does: "
                                  f"{compiling.compile_estimate(what)}; cached for later runs",
                                  live="compiling", done="compiled the kernels") as timer:
                load()
            if first:
                compiling.record_compile_time(what, timer.elapsed)

        with (open_pool(workers, scheduler, warm_up) if pool is None
              else resident_pool(pool, warm_up)) as used:
            run = StudyRun(plan, used, reporter, history, pause_after_blocks)
            run.run()
    except KeyboardInterrupt:
        raise RunInterrupted(interrupted_message(plan, run)) from None
    summary = RunSummary(plan.out, run.written, current, run.computed, run.reused, run.notes,
                         dict(run.failed), dict(run.not_run))
    if run.failed:
        raise StepsFailed(summary)
    return summary


def interrupted_message(plan: Plan, run: "StudyRun | None") -> str:
    """What an interrupted run leaves: the datasets it wrote and the blocks it saved."""
    todo = [s for s in plan.steps if not s.up_to_date]
    written = len(run.written) if run is not None else 0
    saved = sum(len(s.saved) for s in todo if s.blocks and s.name not in
                (run.done if run is not None else ()))
    failed = (f" ({count(len(run.failed), 'step')} failed before: "
              f"{', '.join(run.failed)})" if run is not None and run.failed else "")
    if written == 0 and saved == 0:
        return ("interrupted before any step finished: nothing to keep yet (compiled kernels "
                f"are cached){failed}; rerun the same command to start again")
    parts = []
    if written:
        parts.append(f"{written} of {count(len(todo), 'dataset')} written")
    if saved:
        parts.append(f"{count(saved, 'finished block')} saved")
    return f"interrupted; {' and '.join(parts)}{failed}: rerun the same command to resume"


@contextmanager
def resident_pool(pool: Pool, warm_up: Callable[[], None]) -> Iterator[Pool]:
    """Run on a pool that outlives the run; abort it unless the run finishes."""
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


# --- programmatic grids (benchmarks) -----------------------------------------------------------
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
    spec = GaitSpec(as_robot(robot), integrator, float(torque), float(tick))
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
            return axes_points(a1, a2, lo, hi)
    n = int(np.prod(shape))
    out = {k: np.empty(n, dt) for k, dt in HORIZONTAL_VARIABLES.items()}
    blocks = make_blocks(n, int(block_size))

    def put(b: Block, r: dict) -> None:
        for k in out:
            out[k][b.lo:b.hi] = r[k]

    if executor is None and workers == 0:
        for b in blocks:
            put(b, grid_block(spec, points(b.lo, b.hi), skip_unreachable))
    else:
        load_kernels(spec)
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
                    pending[ex.submit(grid_block, spec, points(b.lo, b.hi),
                                      skip_unreachable)] = b
                if not pending:
                    break
                finished, _ = wait(list(pending), return_when=FIRST_COMPLETED)
                for f in finished:
                    put(pending.pop(f), f.result())
    res: dict[str, Any] = {k: v.reshape(shape) for k, v in out.items()}
    res["skipped_fraction"] = float(np.mean(out["status"] == Status.UNREACHABLE)) if n else 0.0
    return res


__all__ = ["RunFailed", "RunInterrupted", "RunSummary", "StepsFailed", "StudyRun",
           "load_kernels", "run_grid", "run_study", "step_attrs"]
