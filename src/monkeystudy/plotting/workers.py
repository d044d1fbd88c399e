"""Figure jobs on worker processes: the workers draw, the calling process keeps the books.

:func:`run_jobs` runs ``run_one(k, send)`` for every job ``k`` on up to ``workers`` forked
processes (each takes the next job when it is done with one, so long jobs queued first keep
both cores busy) and hands every event to ``handle(k, event, value)`` *in the calling
process*: ``"start"``, ``"message"`` (what the job passed to ``send``), ``"done"`` (its return
value) or ``"failed"`` (the traceback's text). The caller alone writes shared files (the
report's manifest), so a worker never races another for them.

Workers are forked, so they share the caller's loaded modules and the job list without
pickling either; only the events cross the process boundary. They ignore Ctrl-C (the whole
terminal's process group receives it): the caller stops them with SIGTERM, which each turns
into ``SystemExit`` so that the file being written is removed by its ``finally`` clause, kills
one still running after :data:`STOP_GRACE` (the report then removes the temporary file it
left), and re-raises the ``KeyboardInterrupt``. A worker that dies fails the job it held; the other
jobs go on. Where ``fork`` is not available, or with one worker or one job, the jobs run one
after the other in the calling process, with the same events.
"""
from __future__ import annotations

import multiprocessing as mp
import os
import queue
import signal
import time
import traceback
from typing import Any, Callable, Sequence

#: ``run_one(k, send)``: draw job ``k``; ``send(value)`` reports progress as it goes
RunOne = Callable[[int, Callable[[Any], None]], Any]
#: ``handle(k, event, value)``, called in the calling process
Handle = Callable[[int, str, Any], None]
#: ``idle()``: called in the calling process at least every :data:`POLL` while jobs run on
#: the workers
Idle = Callable[[], None]

#: how often the calling process looks for a worker that died [s]
POLL = 0.2
#: how long a worker stopped with SIGTERM may take to clean up before it is killed [s]
STOP_GRACE = 5.0


def available_cores() -> int:
    """The cores this process may run on."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:        # not on Linux
        return os.cpu_count() or 1


def run_jobs(order: Sequence[int], run_one: RunOne, handle: Handle, workers: int,
             idle: Idle | None = None) -> None:
    """Run the jobs ``order`` (indices, in the order they are started) and hand their events
    to ``handle``; see the module docstring. ``idle()`` is called between events, at least
    every :data:`POLL` while workers draw (not when the jobs run in this process). Returns
    when every job is done or failed."""
    order = list(order)
    if not order:
        return
    n = min(int(workers), len(order))
    if n <= 1 or "fork" not in mp.get_all_start_methods():
        for k in order:
            _run_here(k, run_one, handle)
        return
    _run_forked(order, run_one, handle, n, idle)


def _run_here(k: int, run_one: RunOne, handle: Handle) -> None:
    handle(k, "start", None)
    try:
        value = run_one(k, lambda v: handle(k, "message", v))
    except Exception:  # one broken job must not stop the others
        handle(k, "failed", traceback.format_exc())
        return
    handle(k, "done", value)


def _terminate(signum, frame):
    raise SystemExit(128 + signum)


def _worker(run_one: RunOne, tasks, results) -> None:
    """A worker's loop: take the next job, run it, say what came of it."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, _terminate)
    pid = os.getpid()
    while True:
        k = tasks.get()
        if k is None:
            break
        results.put((pid, k, "start", None))
        try:
            value = run_one(k, lambda v, k=k: results.put((pid, k, "message", v)))
        except Exception:
            results.put((pid, k, "failed", traceback.format_exc()))
        else:
            results.put((pid, k, "done", value))
    results.close()
    results.join_thread()          # every event delivered before the process ends


def _run_forked(order: list[int], run_one: RunOne, handle: Handle, n: int,
                idle: Idle | None = None) -> None:
    ctx = mp.get_context("fork")
    tasks, results = ctx.SimpleQueue(), ctx.Queue()
    for k in order:
        tasks.put(k)
    for _ in range(n):
        tasks.put(None)
    procs = [ctx.Process(target=_worker, args=(run_one, tasks, results), daemon=True)
             for _ in range(n)]
    for p in procs:
        p.start()
    running: dict[int, int] = {}           # worker pid -> the job it holds
    remaining = set(order)
    try:
        while remaining:
            try:
                pid, k, event, value = results.get(timeout=POLL)
            except queue.Empty:
                _dead_workers(procs, running, remaining, handle)
            else:
                if event == "start":
                    running[pid] = k
                elif event in ("done", "failed"):
                    running.pop(pid, None)
                    remaining.discard(k)
                handle(k, event, value)
            if idle is not None and remaining:
                idle()
    except BaseException:
        # Ctrl-C (or a failure in ``handle``): stop the workers; each removes the file it
        # was writing on its way out
        stop(procs)
        raise
    for p in procs:
        p.join()


def stop(procs) -> None:
    """Stop the workers: SIGTERM (each removes the file it was writing), then, for one still
    running after :data:`STOP_GRACE`, SIGKILL (the caller removes what it left)."""
    for p in procs:
        if p.is_alive():
            p.terminate()
    deadline = time.monotonic() + STOP_GRACE
    for p in procs:
        p.join(max(0.0, deadline - time.monotonic()))
    for p in procs:
        if p.is_alive():
            p.kill()
            p.join()


def _dead_workers(procs, running: dict[int, int], remaining: set[int],
                  handle: Handle) -> None:
    """Fail the job of every worker that died holding one; with no worker left, fail the
    jobs nobody will take."""
    for p in procs:
        if not p.is_alive() and p.pid in running:
            k = running.pop(p.pid)
            remaining.discard(k)
            handle(k, "failed", f"the drawing process died (exit code {p.exitcode})")
    if remaining and not any(p.is_alive() for p in procs) and not running:
        for k in sorted(remaining):
            handle(k, "failed", "no drawing process was left to draw it")
        remaining.clear()
