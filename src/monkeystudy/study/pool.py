"""Where tasks run: one code path for every executor with the ``concurrent.futures`` interface.

A local ``ProcessPoolExecutor`` (all cores by default; workers forked from the driver once it
has loaded the kernels, so they inherit them) or a Dask cluster's
``distributed.Client(address).get_executor()``. A :class:`Pool` pairs the executor with its
number of task slots and a way to stop it at once.
"""
from __future__ import annotations

import gc
import multiprocessing as mp
import os
import signal
import threading
import time
from concurrent.futures import Executor, Future, ProcessPoolExecutor
from contextlib import contextmanager
from typing import Callable, Iterator

from .errors import RunFailed
from .counts import open_task_channel


class DeferredSignals:
    """Signals whose Python handlers run at safe points instead of wherever they land.

    A handler that raises (Ctrl-C's ``KeyboardInterrupt``, the CLI's SIGTERM, the server's
    stop and client-gone signals) can interrupt the executor's own code between taking one of
    its internal locks and the ``with`` block that would release it (CPython bpo-29988): the
    lock stays taken, and the interpreter then hangs at exit joining the executor's thread.
    Inside this context the signals are only recorded; :meth:`check` runs the handlers they
    displaced, in arrival order, at a point where no such lock is held. Off the main thread
    (where no handler can be set) it does nothing.
    """

    SIGNALS = tuple(getattr(signal, name) for name in ("SIGINT", "SIGTERM", "SIGUSR1")
                    if hasattr(signal, name))

    def __init__(self):
        self.pending: list[tuple[int, object]] = []
        self.previous: dict[int, object] = {}

    def __enter__(self) -> "DeferredSignals":
        if threading.current_thread() is threading.main_thread():
            for sig in self.SIGNALS:
                handler = signal.getsignal(sig)
                if callable(handler):          # a Python handler, which may raise
                    self.previous[sig] = signal.signal(sig, self._record)
        return self

    def _record(self, signum, frame) -> None:
        self.pending.append((signum, frame))

    def check(self) -> None:
        """Run the displaced handlers of the signals that arrived (they may raise)."""
        while self.pending:
            signum, frame = self.pending.pop(0)
            self.previous[signum](signum, frame)

    def discard(self) -> None:
        """Forget the signals that arrived (the work they would have stopped is done)."""
        self.pending.clear()

    def __exit__(self, *exc) -> None:
        for sig, handler in self.previous.items():
            signal.signal(sig, handler)
        if exc[0] is None:
            self.check()          # a signal that came during the last step still counts
        self.previous.clear()


def worker_init(driver: int, progress=None) -> None:
    """Pool worker start: Ctrl-C is the driver's business; SIGTERM (the driver's
    :meth:`Pool.abort`) ends the worker at once; exit when the driver is gone (after a kill
    -9 nobody else would stop an idle worker). ``progress``: the queue its tasks' counts go
    to (:func:`~monkeystudy.study.counts.task_units`)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    if progress is not None:
        open_task_channel(progress)
    # a forked worker inherits the driver's Python handlers: the CLI's SIGTERM-as-interrupt
    # would only end the worker's current task with KeyboardInterrupt, and the worker would
    # go on with the tasks already queued to it while the driver waits for it
    for name in ("SIGTERM", "SIGUSR1"):
        if hasattr(signal, name):
            signal.signal(getattr(signal, name), signal.SIG_DFL)
    gc.enable()  # the driver may fork with collection off during its start-up

    def watch():
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
    """An executor, its number of task slots, and how to stop it at once; ``progress``: the
    queue its workers send their tasks' counts to (:func:`~monkeystudy.study.progress.
    run_counted`), None when they send none (a Dask cluster)."""

    def __init__(self, executor: Executor, slots: int, kind: str, closer: Callable[[], None],
                 fork: Callable[[], tuple[Executor, object]] | None = None, progress=None):
        self.executor = executor
        self.slots = max(1, int(slots))
        self.kind = kind
        self.progress = progress
        self._closer = closer
        self._fork = fork

    def renew(self) -> None:
        """Replace the (idle) local workers by new ones forked from this process now, so that
        they inherit the kernels it loaded since; other pools are left as they are."""
        if self._fork is not None:
            self.executor.shutdown(wait=True)
            self.executor, self.progress = self._fork()

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
            manager = getattr(ex, "_executor_manager_thread", None)
            ex.shutdown(wait=False, cancel_futures=True)
            for p in procs:
                if p.is_alive():
                    p.terminate()
            for p in procs:
                p.join(timeout=5)
            # the executor's manager thread now sees its workers gone, fails their futures
            # and closes the queues' pipes. Wait for it: a pool forked while it runs would
            # inherit a pipe's read end (which keeps its writer blocked for ever), and the
            # interpreter joins that thread at exit, so a stuck one hangs the process there.
            if manager is not None and manager.is_alive():
                manager.join(timeout=30)
        else:
            ex.shutdown(wait=False)
        self._closer()

    def close(self) -> None:
        """Shut down after a finished run. A Ctrl-C meanwhile stops nothing (everything is
        done): it is not left to interrupt the executor's shutdown half way."""
        with DeferredSignals() as signals:
            self.executor.shutdown(wait=True)
            self._closer()
            signals.discard()


#: environment variable choosing the local pool's start method (fork, forkserver, spawn)
START_METHOD_ENV = "MONKEYSTUDY_START_METHOD"


def mp_context():
    """The local pool's start method: ``fork`` when this process is single-threaded (the
    workers inherit the imported modules and loaded kernels: no start-up of their own), else
    the ``forkserver`` (forking a multi-threaded process can copy a lock some other thread
    holds, e.g. after an in-process Dask cluster), else ``spawn``; or ``$MONKEYSTUDY_START_
    METHOD``. A command-line run forks: its progress display starts after the pool, and the
    thread showing a compile's elapsed time ends with the compile."""
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
        ctx.set_forkserver_preload(["monkeystudy.study.preload"])
    return ctx


def default_workers() -> int:
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        return os.cpu_count() or 1


def local_pool_kind(workers: int | None = None) -> str:
    """How :func:`local_pool` describes itself: ``2 local processes``."""
    n = default_workers() if workers is None else int(workers)
    return f"{n} local process{'es' if n != 1 else ''}"


def local_pool(workers: int | None = None,
               warm_up: Callable[[], None] | None = None) -> Pool:
    """A started local process pool of ``workers`` (default all cores), forked (or started by
    the forkserver) after ``warm_up`` has loaded the kernels in this process, so that no
    worker compiles or waits for a compile. The caller closes it (``monkeystudy serve`` keeps
    one across runs)."""
    n = default_workers() if workers is None else int(workers)
    if n < 1:
        raise ValueError(f"workers must be >= 1, got {n}")
    if warm_up is not None:
        warm_up()
    ctx = mp_context()
    if not gc.isenabled():
        # start-up mode (the CLI): the modules and kernels loaded so far live as long as
        # the process, so keep them out of every later collection, here and in the forked
        # workers (whose pages then stay shared: the collector never writes to them)
        gc.freeze()

    def fork() -> tuple[Executor, object]:
        # each set of workers its own channel: one a terminated worker may have left locked
        # goes with its pool
        progress = ctx.Queue()
        ex = ProcessPoolExecutor(max_workers=n, mp_context=ctx, initializer=worker_init,
                                 initargs=(os.getpid(), progress))
        try:
            # start the workers now, while the driver plans its first tasks
            with DeferredSignals():
                for _ in range(n):
                    ex.submit(os.getpid)
        except BaseException:   # a Ctrl-C that came while they started: stop them
            Pool(ex, n, "", lambda: None).abort()
            raise
        return ex, progress

    executor, progress = fork()
    return Pool(executor, n, local_pool_kind(n), lambda: None, fork, progress)


@contextmanager
def open_pool(workers: int | None = None, scheduler: str | None = None,
              warm_up: Callable[[], None] | None = None) -> Iterator[Pool]:
    """A local process pool (``workers``, default all cores) or, with ``scheduler``
    (``tcp://host:port``), the executor of a Dask distributed cluster.

    ``warm_up`` loads the kernels in this process, before a local pool's workers start (forked
    workers inherit them; the forkserver's preload loads them from the cache it leaves)."""
    if scheduler:
        try:
            # distributed is optional and slow to import: only a --scheduler run needs it
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
    ok = False
    try:
        if warm_up is not None:
            warm_up()
        gc.enable()  # start-up is over (the CLI turns collection off while it imports)
        yield pool
        ok = True
    finally:
        if ok:
            pool.close()
        else:
            pool.abort()
