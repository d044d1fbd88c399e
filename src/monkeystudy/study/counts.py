"""The counting side of a run's progress: what a step kind calls to say how much of its work
is done, apart from how it is shown (:mod:`.progress`), so that the display's code is not among
the sources a dataset is keyed on (docs/architecture.md). A task on a worker counts its units
(:func:`task_units`, sent over the pool's progress channel: :func:`run_counted`), and a long
task its own phases (:func:`task_phase`); a step's work in the driver goes in named phases,
each with its own count (:class:`StepProgress`).
"""
from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Callable


class StepProgress:
    """How a step's work in the driver (a kind's :meth:`~monkeystudy.study.steps.base.
    StepKind.finish`) shows its phases: :meth:`phase` starts one with its own count on the
    step's line and returns the function that advances it; :meth:`estimate` says how long a
    phase still to come is expected to take (the step's eta counts it). Without a reporter,
    silent. ``clock`` [s] times the work an estimate is made from (a test gives its own)."""

    def __init__(self, reporter=None, name: str = "",
                 clock: Callable[[], float] = time.monotonic):
        self.reporter = reporter        # a progress.Reporter, or None: silent
        self.name = name
        self.clock = clock

    def phase(self, label: str, total: int, unit: str,
              then: str = "") -> Callable[[int], None]:
        """Phase ``label`` of ``total`` ``unit`` (a plural) begins; ``then`` names the phases
        that follow it. Returns ``advance(n=1)``."""
        reporter = self.reporter
        if reporter is None:
            return lambda n=1: None
        reporter.phase(self.name, label, int(total), unit, then)

        def advance(n: int = 1) -> None:
            reporter.advance(self.name, n)
        return advance

    def estimate(self, label: str, seconds: float) -> None:
        """Phase ``label``, still to come, is expected to take ``seconds`` [s]."""
        if self.reporter is not None:
            self.reporter.estimate(self.name, label, float(seconds))


# --- counts from the workers ---------------------------------------------------------------------
#: the least time between two counts a worker sends [s]: the display moves, the pipe stays quiet
SEND_PERIOD = 0.2


@dataclass(frozen=True)
class TaskPhase:
    """A task's phase, as its worker says it over the channel: ``label``, ``total`` units
    of ``unit`` (a plural)."""

    label: str
    total: int
    unit: str


class TaskChannel:
    """A worker's end of its pool's progress channel (a queue the driver reads): the task it
    runs (its key, set by :func:`run_counted`) and the units it did since its last message."""

    def __init__(self, queue):
        self.queue = queue
        self.key = None
        self.pending = 0
        self.last = 0.0

    def add(self, n: int) -> None:
        if self.key is None:
            return
        self.pending += n
        now = time.monotonic()
        if now - self.last >= SEND_PERIOD:
            self.queue.put((self.key, self.pending))
            self.pending, self.last = 0, now

    def phase(self, phase: TaskPhase) -> None:
        if self.key is None:
            return
        if self.pending:            # the units of the phase before: counted in it
            self.queue.put((self.key, self.pending))
        self.queue.put((self.key, phase))
        self.pending, self.last = 0, time.monotonic()


#: this process's end of the channel: set once in a pool worker (the pool's initializer,
#: :func:`open_task_channel`); None in the driver, in tests and on a Dask worker, where
#: :func:`task_units` does nothing
_CHANNEL: TaskChannel | None = None


def open_task_channel(queue) -> None:
    """In a pool worker at its start: send the counts of its tasks to ``queue`` (None:
    send nothing)."""
    global _CHANNEL
    _CHANNEL = TaskChannel(queue) if queue is not None else None


def task_units(n: int = 1) -> None:
    """The running task did ``n`` more units of its work (runs, designs): said to the driver
    (at most every :data:`SEND_PERIOD`) when the task runs on a pool with a progress channel,
    else nothing."""
    if _CHANNEL is not None:
        _CHANNEL.add(n)


def task_phase(label: str, total: int, unit: str) -> None:
    """The running task goes on with its phase ``label`` of ``total`` ``unit`` (a plural),
    which its :func:`task_units` count from here on (its earlier phase, if any, is over).
    Said to the driver at once, which shows it as a count of its own under the task's step,
    when the task runs on a pool with a progress channel; else nothing."""
    if _CHANNEL is not None:
        _CHANNEL.phase(TaskPhase(label, int(total), unit))


def run_counted(key, fn: Callable, args: tuple, kwargs: dict):
    """``fn(*args, **kwargs)`` on a worker, its :func:`task_units` sent under ``key`` (the
    driver's name for the task). The driver counts whatever was not sent when the result
    comes."""
    channel = _CHANNEL
    if channel is None:
        return fn(*args, **kwargs)
    channel.key, channel.pending, channel.last = key, 0, time.monotonic()
    try:
        return fn(*args, **kwargs)
    finally:
        if channel.pending:      # the count is whole at once, even if the driver is busy
            channel.queue.put((key, channel.pending))
        channel.key, channel.pending = None, 0
