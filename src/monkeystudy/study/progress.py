"""Progress of a run: a rich progress bar with ETA on a terminal, plain log lines otherwise."""
from __future__ import annotations

import sys
import time
from typing import TextIO


class Reporter:
    """Silent reporter (the interface): steps with a number of units each."""

    def log(self, message: str) -> None:
        pass

    def start(self, name: str, total: int, done: int = 0, unit: str = "blocks") -> None:
        pass

    def advance(self, name: str, n: int = 1) -> None:
        pass

    def finish(self, name: str, message: str = "") -> None:
        pass

    def close(self) -> None:
        pass


class PlainReporter(Reporter):
    """One line per event; progress at most every ``every`` seconds per step."""

    def __init__(self, stream: TextIO | None = None, every: float = 5.0):
        self.stream = stream or sys.stderr
        self.every = every
        self._steps: dict[str, list] = {}

    def _line(self, text: str) -> None:
        print(f"[monkeystudy] {text}", file=self.stream, flush=True)

    def log(self, message: str) -> None:
        self._line(message)

    def start(self, name, total, done=0, unit="blocks"):
        now = time.monotonic()
        self._steps[name] = [total, done, done, unit, now, now]
        resumed = f" ({done} already saved)" if done else ""
        self._line(f"{name}: {total} {unit}{resumed}")

    def advance(self, name, n=1):
        st = self._steps.get(name)
        if st is None:
            return
        st[1] += n
        total, done, done0, unit, t0, last = st
        now = time.monotonic()
        if done < total and now - last < self.every:
            return
        st[5] = now
        el = now - t0
        rate = (done - done0) / el if el > 0 else 0.0
        eta = f", eta {(total - done) / rate:.0f} s" if rate > 0 and done < total else ""
        self._line(f"{name}: {done}/{total} {unit} ({100.0 * done / max(total, 1):.0f}%), "
                   f"{el:.1f} s{eta}")

    def finish(self, name, message=""):
        st = self._steps.get(name)
        el = f" in {time.monotonic() - st[4]:.1f} s" if st else ""
        self._line(f"{name}: done{el}" + (f" - {message}" if message else ""))


class RichReporter(Reporter):
    """A rich progress bar per step, with elapsed time and ETA (on a terminal)."""

    def __init__(self, stream: TextIO | None = None):
        # rich loads in ~0.1 s: only a run on a terminal pays for it
        from rich.console import Console
        from rich.progress import (
            BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn,
            TimeRemainingColumn,
        )

        self.console = Console(file=stream or sys.stderr)
        self.progress = Progress(TextColumn("[bold]{task.description}"), BarColumn(),
                                 MofNCompleteColumn(), TextColumn("{task.fields[unit]}"),
                                 TimeElapsedColumn(), TextColumn("eta"), TimeRemainingColumn(),
                                 console=self.console, transient=False)
        self.progress.start()
        self._tasks: dict[str, int] = {}

    def log(self, message):
        self.progress.console.print(message, markup=False, highlight=False)

    def start(self, name, total, done=0, unit="blocks"):
        self._tasks[name] = self.progress.add_task(name, total=total, completed=done,
                                                   unit=unit)

    def advance(self, name, n=1):
        if name in self._tasks:
            self.progress.advance(self._tasks[name], n)

    def finish(self, name, message=""):
        if name in self._tasks:
            t = self._tasks[name]
            self.progress.update(t, completed=self.progress.tasks[t].total)
        if message:
            self.log(f"{name}: {message}")

    def close(self):
        self.progress.stop()


def make_reporter(stream: TextIO | None = None) -> Reporter:
    """Rich on a terminal, plain lines otherwise."""
    stream = stream or sys.stderr
    try:
        tty = stream.isatty()
    except (AttributeError, ValueError):
        tty = False
    return RichReporter(stream) if tty else PlainReporter(stream)
