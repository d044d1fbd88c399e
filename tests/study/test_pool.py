"""The local process pool: aborting it stops its workers, whatever handlers they inherited."""
from __future__ import annotations

import os
import signal
import time

import pytest

from monkeystudy.study.pool import START_METHOD_ENV, local_pool


def _sleep(seconds: float) -> int:
    time.sleep(seconds)
    return os.getpid()


@pytest.mark.skipif(not hasattr(signal, "SIGTERM") or os.name != "posix", reason="POSIX signals")
def test_abort_stops_forked_workers_that_inherited_a_sigterm_handler(monkeypatch):
    """The CLI turns SIGTERM into KeyboardInterrupt; forked workers inherit that handler.
    Aborting must still end them at once, not just interrupt their current task and let them
    run the next one already queued to them."""
    monkeypatch.setenv(START_METHOD_ENV, "fork")

    def interrupt(signum, frame):
        raise KeyboardInterrupt

    previous = signal.signal(signal.SIGTERM, interrupt)
    try:
        pool = local_pool(1)
        procs = list(pool.executor._processes.values())
        futures = [pool.submit(_sleep, 120.0) for _ in range(4)]   # one runs, one is queued
        time.sleep(1.0)
        assert not futures[0].done()
        pool.abort()
        assert not any(p.is_alive() for p in procs)
    finally:
        signal.signal(signal.SIGTERM, previous)
        for p in procs:
            if p.is_alive():
                p.kill()


def test_a_signal_deferred_until_the_end_of_the_block_still_takes_effect():
    from monkeystudy.study.pool import DeferredSignals

    def interrupt(signum, frame):
        raise KeyboardInterrupt

    previous = signal.signal(signal.SIGTERM, interrupt)
    try:
        with pytest.raises(KeyboardInterrupt):
            with DeferredSignals():
                os.kill(os.getpid(), signal.SIGTERM)
                time.sleep(0.1)               # recorded, not raised, inside the block
        assert signal.getsignal(signal.SIGTERM) is interrupt
    finally:
        signal.signal(signal.SIGTERM, previous)


def _live_children() -> list[int]:
    """Child processes of this one that are still running (zombies excluded)."""
    me = os.getpid()
    out = []
    for stat in __import__("pathlib").Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = stat.read_text().rsplit(")", 1)[1].split()
        except OSError:
            continue
        if int(fields[1]) == me and fields[0] != "Z":
            out.append(int(stat.parent.name))
    return out


@pytest.mark.skipif(not os.path.isdir("/proc"), reason="reads /proc")
def test_ctrl_c_while_the_pool_starts_stops_its_workers(monkeypatch):
    """A Ctrl-C that lands while the workers start: the pool is stopped before the interrupt
    goes on (no worker outlives it)."""
    from monkeystudy.study import pool as P

    before = set(_live_children())
    enter = P.DeferredSignals.__enter__

    def enter_and_interrupt(self):
        out = enter(self)
        os.kill(os.getpid(), signal.SIGINT)     # arrives while the workers start
        return out
    monkeypatch.setattr(P.DeferredSignals, "__enter__", enter_and_interrupt)
    with pytest.raises(KeyboardInterrupt):
        local_pool(2)
    t0 = time.monotonic()
    while set(_live_children()) - before and time.monotonic() - t0 < 30:
        time.sleep(0.05)
    assert not set(_live_children()) - before
