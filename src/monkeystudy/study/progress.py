"""Progress of a run: a rich progress bar with ETA on a terminal, plain log lines otherwise.

Both show a long wait (a first run compiling its kernels) as it happens:
:meth:`Reporter.waiting` says what is being waited for at once, then its elapsed time (a line
updated in place every second on a terminal; a line every ``every`` seconds otherwise), and
how long it took. The thread that keeps the time is joined when the wait ends, and the
terminal's progress display starts only with the first step: the run's process has no other
thread when it forks its workers (:func:`monkeystudy.study.pool.mp_context`).

A step counts its work in its own unit (blocks, runs, designs). A task on a worker says how
much of it is done as it goes, and a step's work in the driver goes in named phases, each with
its own count: :mod:`.counts` holds that side (what the steps call), this module the display.
A phase's line also gives the eta of its whole step: the phase's own eta plus the seconds a
step expects each phase still to come to take (:meth:`Reporter.estimate`), with the phases it
has no estimate of named after it (``step eta 40 s + screen``).
"""
from __future__ import annotations

import re
import sys
import threading
import time
from contextlib import contextmanager
from typing import Callable, Iterator, TextIO


def count(n: int, noun: str, plural: str | None = None) -> str:
    """``1 run``, ``2 runs``, ``0 runs``: a number with its noun in the right number (the
    plural ``plural``, else the noun with an s). Every count the package words goes through
    it, or through :func:`singular_counts` for lines the step kinds word for any count."""
    n = int(n)
    return f"{n} {noun if n == 1 else (plural or noun + 's')}"


def all_of(n: int, noun: str, plural: str | None = None) -> str:
    """``all 5 cycles``, ``both cycles``, ``the 1 cycle``: every one of ``n`` things."""
    n = int(n)
    if n == 1:
        return f"the 1 {noun}"
    return f"both {plural or noun + 's'}" if n == 2 else f"all {count(n, noun, plural)}"


def singular(plural: str) -> str:
    """The singular of a plural noun as the package writes them (``blocks``, ``branches``,
    ``vertical crossings``; ``minima``)."""
    if plural.endswith("minima"):
        return plural[:-1] + "um"
    if plural.endswith(("ches", "shes", "sses", "xes")):
        return plural[:-2]
    return plural[:-1] if plural.endswith("s") and plural != "s" else plural


#: the plural nouns the step kinds count in their lines
COUNTED = ("runs", "cycles", "points", "starts", "iterations", "iterates", "designs", "levels",
           "noise levels", "solutions", "blocks", "samples", "candidates", "gaits", "steps",
           "vertical crossings", "refinements", "tasks", "branches", "swings", "logs",
           "failures", "datasets")
_NOUNS = "|".join(sorted((re.escape(n) for n in COUNTED), key=len, reverse=True))
#: a count of one followed by a plural noun (``1 cycles``): the step kinds word their lines
#: for any count
_ONE_PLURAL = re.compile(rf"(?<![\d.×/])1 ({_NOUNS})\b")
#: a count with a noun whose plural is left open (``2 level(s)``, ``1 noise level(s)``)
_EITHER = re.compile(r"(?<![\d.×/])(\d+) ((?:[a-z]+ )?[a-z]+)\(s\)")


def singular_counts(line: str) -> str:
    """``line`` with every count in the right number: a count of one in the singular (``1
    of 1 cycles`` -> ``1 of 1 cycle``), a plural left open settled (``1 level(s)`` -> ``1
    level``, ``2 level(s)`` -> ``2 levels``), as the run's log, ``monkeystudy inspect``, the
    dry run's plan and the study's page show a step's lines."""
    line = _EITHER.sub(lambda m: count(int(m.group(1)), m.group(2)), line)
    return _ONE_PLURAL.sub(lambda m: "1 " + singular(m.group(1)), line)


class Waited:
    """What :meth:`Reporter.waiting` yields: the wait's length [s], once it is over."""

    def __init__(self):
        self.t0 = time.monotonic()
        self.elapsed = 0.0

    def stop(self) -> float:
        self.elapsed = time.monotonic() - self.t0
        return self.elapsed


class Reporter:
    """Silent reporter (the interface): steps with a number of units each."""

    def log(self, message: str) -> None:
        pass

    def start(self, name: str, total: int, done: int = 0, unit: str = "blocks") -> None:
        pass

    def advance(self, name: str, n: int = 1) -> None:
        pass

    def phase(self, name: str, label: str, total: int, unit: str, then: str = "",
              done: int = 0) -> None:
        """Step ``name`` goes on with its phase ``label``: ``total`` units, ``done`` of them
        done; ``then`` names the phases still to come after it ("" for the step's last)."""
        pass

    def estimate(self, name: str, label: str, seconds: float) -> None:
        """Phase ``label`` of step ``name``, still to come, is expected to take ``seconds``
        [s]: the step's eta counts it (a phase to come without an estimate is named
        instead)."""
        pass

    def finish(self, name: str, message: str = "") -> None:
        pass

    def fail(self, name: str, message: str) -> None:
        """Step ``name`` ended without a dataset: ``message`` says how and why (``failed:
        ...``, ``not run: ...``; one line)."""
        pass

    @contextmanager
    def waiting(self, message: str, live: str = "waiting",
                done: str = "done") -> Iterator[Waited]:
        """Around a long wait: ``message`` at once, then ``live`` with the time elapsed while
        it lasts, and ``done`` with the time it took once it is over (not if it was
        interrupted)."""
        self.log(message)
        waited = Waited()
        try:
            yield waited
        finally:
            waited.stop()
        self.log(f"{done} in {_seconds(waited.elapsed)}")

    def close(self) -> None:
        pass


def units(n: int, unit: str) -> str:
    """``unit`` (a plural: ``blocks``, ``branches``) for a count of ``n``: ``1 block``."""
    return count(n, singular(unit), unit)


def _seconds(t: float) -> str:
    return f"{t:.0f} s" if t >= 10 else f"{t:.1f} s"


def phases_to_come(then: str) -> list[str]:
    """The labels of the phases to come, from a phase's ``then`` (``"screen, checks"``)."""
    return [x.strip() for x in then.split(",") if x.strip()]


def step_eta(phase_left: float | None, then: str, estimates: dict[str, float]) -> tuple:
    """The eta of a whole step [s] as far as it can be estimated: ``phase_left`` (the current
    phase's eta; None: not known yet) plus the estimate of every phase to come that has one
    (``estimates``), and the labels of those that have none. ``(None, [])`` when no phase
    comes after the current one; ``(None, labels)`` while the phase's eta is not known."""
    later = phases_to_come(then)
    if not later:
        return None, []
    unknown = [x for x in later if x not in estimates]
    if phase_left is None:
        return None, unknown
    return phase_left + sum(estimates[x] for x in later if x in estimates), unknown


class _Ticker:
    """A daemon thread that calls ``tick(elapsed)`` every ``period`` seconds until stopped
    (and joined)."""

    def __init__(self, tick: Callable[[float], None], period: float):
        self._tick, self._period = tick, period
        self._stop = threading.Event()
        self._t0 = time.monotonic()
        self._thread = threading.Thread(target=self._run, name="monkeystudy-elapsed",
                                        daemon=True)
        self._thread.start()

    def _run(self) -> None:
        while not self._stop.wait(self._period):
            self._tick(time.monotonic() - self._t0)

    def stop(self) -> None:
        """Stop the thread and join it."""
        self._stop.set()
        self._thread.join()


@contextmanager
def ticking(echo: Callable[[str], None], what: str, every: float = 1.0) -> Iterator[None]:
    """Around a wait of a command that speaks in lines: ``echo(f"{what} ({t})")`` every
    ``every`` seconds while it lasts, from a thread joined when it ends (before any fork)."""
    ticker = _Ticker(lambda el: echo(f"{what} ({_seconds(el)})"), every)
    try:
        yield
    finally:
        ticker.stop()


class PlainReporter(Reporter):
    """One line per event; progress at most every ``every`` seconds per step."""

    def __init__(self, stream: TextIO | None = None, every: float = 5.0,
                 clock: Callable[[], float] = time.monotonic):
        self.stream = stream or sys.stderr
        self.every = every
        self.clock = clock              # [s]: time.monotonic, or a test's
        self._steps: dict[str, list] = {}
        self._estimates: dict[str, dict[str, float]] = {}
        # a run's worker counts arrive on a thread of their own (:func:`run_counted`)
        self._lock = threading.RLock()

    def _line(self, text: str) -> None:
        with self._lock:
            print(f"[monkeystudy] {text}", file=self.stream, flush=True)

    def log(self, message: str) -> None:
        self._line(message)

    @contextmanager
    def waiting(self, message, live="waiting", done="done"):
        self._line(message)
        waited = Waited()
        ticker = None
        ok = False
        try:
            ticker = _Ticker(lambda el: self._line(f"{live}: {_seconds(el)}"), self.every)
            yield waited
            ok = True
        finally:
            if ticker is not None:
                ticker.stop()
            waited.stop()
            if not ok:
                self._line(f"{live}: stopped after {_seconds(waited.elapsed)}")
        self._line(f"{done} in {_seconds(waited.elapsed)}")

    def start(self, name, total, done=0, unit="blocks"):
        now = self.clock()
        with self._lock:
            self._estimates[name] = {}
            # total, done, done at the phase's start, unit, step start, last line, phase
            # label, phase start, phases to come
            self._steps[name] = [total, done, done, unit, now, now, "", now, ""]
            resumed = f" ({done} already saved)" if done else ""
            self._line(f"{name}: {units(total, unit)}{resumed}")

    def phase(self, name, label, total, unit, then="", done=0):
        now = self.clock()
        with self._lock:
            st = self._steps.get(name)
            t0 = st[4] if st else now
            self._steps[name] = [total, done, done, unit, t0, now, label, now, then]
            self._line(f"{name}: {label}: {units(total, unit)}"
                       + (f" (then {then})" if then else ""))

    def advance(self, name, n=1):
        with self._lock:
            st = self._steps.get(name)
            if st is None:
                return
            st[1] += n
            total, done, done0, unit, _, last, label, p0, then = st
            now = self.clock()
            if done < total and now - last < self.every:
                return
            st[5] = now
            el = now - p0
            rate = (done - done0) / el if el > 0 else 0.0
            left = (total - done) / rate if rate > 0 and done < total else None
            eta = (f", eta {left:.0f} s" + (f" then {then}" if then else "")
                   if left is not None else "")
            whole, unknown = step_eta(left, then, self._estimates.get(name, {}))
            if whole is not None:
                eta += f"; step eta {whole:.0f} s" + (f" + {', '.join(unknown)}"
                                                       if unknown else "")
            what = f"{name}: {label}" if label else name
            self._line(f"{what}: {done}/{total} {unit} ({100.0 * done / max(total, 1):.0f}%), "
                       f"{el:.1f} s{eta}")

    def estimate(self, name, label, seconds):
        with self._lock:
            self._estimates.setdefault(name, {})[label] = float(seconds)

    def finish(self, name, message=""):
        with self._lock:
            st = self._steps.get(name)
            el = f" in {self.clock() - st[4]:.1f} s" if st else ""
            self._line(f"{name}: done{el}" + (f" - {message}" if message else ""))

    def fail(self, name, message):
        self._line(f"{name}: {message}")


def _words(field: str, style: str):
    """A progress column of a task's words (``description`` or a field) on one line, cut
    with "…" when the terminal is too narrow: the table shrinks it before the count."""
    # rich loads with the display, only on a terminal (as in RichReporter)
    from rich.progress import ProgressColumn
    from rich.text import Text

    class Words(ProgressColumn):
        def render(self, task):
            text = task.description if field == "description" else task.fields.get(field, "")
            return Text(str(text), style=style, no_wrap=True, overflow="ellipsis")
    return Words()


def _step_eta_column():
    """A progress column of a phase's step eta (:func:`step_eta`: the phase's eta from its
    rate plus the estimates of the phases to come): ``step eta 0:00:40``, never cut; empty
    for a step without phases to come. The phases to come without an estimate are named in
    the words after the bar (:func:`_then_words`)."""
    # rich loads with the display, only on a terminal (as in RichReporter)
    from rich.progress import ProgressColumn
    from rich.table import Column
    from rich.text import Text

    class StepEta(ProgressColumn):
        def render(self, task):
            then = task.fields.get("later", "")
            if not phases_to_come(then):
                return Text("")
            left = None if task.finished else task.time_remaining
            whole, _ = step_eta(left, then, task.fields.get("estimates", {}))
            return Text("step eta " + ("-:--:--" if whole is None else _hms(whole)),
                        style="cyan")
    return StepEta(table_column=Column(no_wrap=True))


def _then_words(then: str, estimates: dict[str, float]) -> str:
    """The words after a phase's bar: the phases to come that its step eta leaves out (no
    estimate), ``+ screen, checks``; else the phases to come, ``then checks``."""
    unknown = step_eta(0.0, then, estimates)[1]
    if unknown:
        return "+ " + ", ".join(unknown)
    return f"then {then}" if then else ""


def _hms(t: float) -> str:
    """``0:01:05``: a time [s] as rich's time columns show it (whole seconds)."""
    t = max(int(t), 0)
    return f"{t // 3600}:{t // 60 % 60:02d}:{t % 60:02d}"


class RichReporter(Reporter):
    """A rich progress bar per step, with elapsed time and ETA (on a terminal)."""

    def __init__(self, stream: TextIO | None = None,
                 clock: Callable[[], float] = time.monotonic):
        # rich loads in ~0.1 s: only a run on a terminal pays for it
        from rich.console import Console

        self.console = Console(file=stream or sys.stderr)
        self.clock = clock              # [s]: the bars' times; time.monotonic, or a test's
        self.progress = None
        self._tasks: dict[str, int] = {}
        self._estimates: dict[str, dict[str, float]] = {}

    def _display(self):
        """The progress display, started with the first step (its refresh thread with it).

        A step's line is its name and phase, its count and unit, the elapsed time and eta,
        the step's eta (with phases to come), the bar and the phases still to come. The count
        and times are never cut; on a narrow terminal the bar, the name and the phases to
        come shrink (the words cut with "…")."""
        if self.progress is None:
            # loaded with the first step's display, after the compile
            from rich.progress import (
                BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn,
                TimeRemainingColumn,
            )
            from rich.table import Column

            def whole():
                return Column(no_wrap=True)
            self.progress = Progress(
                _words("description", "bold"),
                MofNCompleteColumn(table_column=whole()),
                TextColumn("{task.fields[unit]}", table_column=whole()),
                TimeElapsedColumn(table_column=whole()),
                TextColumn("eta", table_column=whole()),
                TimeRemainingColumn(table_column=whole()),
                _step_eta_column(),
                BarColumn(bar_width=24), _words("then", "dim"),
                console=self.console, transient=False, get_time=self.clock)
            self.progress.start()
        return self.progress

    def log(self, message):
        self.console.print(message, markup=False, highlight=False, soft_wrap=True)

    @contextmanager
    def waiting(self, message, live="waiting", done="done"):
        out = self.console.file
        lock = threading.Lock()

        def show(elapsed: float) -> None:
            text = f"{live}: {_seconds(elapsed)}"
            with lock:
                out.write("\r\x1b[2K" + text[:max(self.console.width - 1, 20)])
                out.flush()

        self.log(message)
        waited = Waited()
        ticker = None
        ok = False
        try:
            show(0.0)
            ticker = _Ticker(show, 1.0)
            yield waited
            ok = True
        finally:
            if ticker is not None:
                ticker.stop()
            waited.stop()
            with lock:
                out.write("\r\x1b[2K")
                out.flush()
            self.log(f"{done} in {_seconds(waited.elapsed)}" if ok else
                     f"{live}: stopped after {_seconds(waited.elapsed)}")

    def start(self, name, total, done=0, unit="blocks"):
        if done:
            self.log(f"{name}: {units(total, unit)} ({done} already saved)")
        self._estimates[name] = {}
        self._tasks[name] = self._display().add_task(name, total=total, completed=done,
                                                     unit=units(total, unit).split(" ", 1)[1],
                                                     then="", later="", estimates={})

    def phase(self, name, label, total, unit, then="", done=0):
        if name not in self._tasks:
            self.start(name, total, done, unit)
        # a new count (its rate and eta start afresh); the step's elapsed time runs on
        t = self._tasks[name]
        began = self.progress.tasks[t].start_time
        self.progress.reset(t, start=True, total=total, completed=done,
                            description=f"{name}: {label}",
                            unit=units(total, unit).split(" ", 1)[1],
                            then=_then_words(then, self._estimates.get(name, {})),
                            later=then, estimates=dict(self._estimates.get(name, {})))
        if began is not None:
            self.progress.tasks[t].start_time = began

    def advance(self, name, n=1):
        if name in self._tasks:
            self.progress.advance(self._tasks[name], n)

    def estimate(self, name, label, seconds):
        est = self._estimates.setdefault(name, {})
        est[label] = float(seconds)
        if name in self._tasks:
            t = self._tasks[name]
            then = self.progress.tasks[t].fields.get("later", "")
            self.progress.update(t, estimates=dict(est), then=_then_words(then, est))

    def finish(self, name, message=""):
        if name in self._tasks:
            t = self._tasks[name]
            self.progress.update(t, completed=self.progress.tasks[t].total, then="", later="")
        if message:
            self.log(f"{name}: {message}")

    def fail(self, name, message):
        if name in self._tasks:
            self.progress.update(self._tasks[name], description=f"{name} (failed)")
        self.log(f"{name}: {message}")

    def close(self):
        if self.progress is not None:
            self.progress.stop()


def make_reporter(stream: TextIO | None = None) -> Reporter:
    """Rich on a terminal, plain lines otherwise."""
    stream = stream or sys.stderr
    try:
        tty = stream.isatty()
    except (AttributeError, ValueError):
        tty = False
    return RichReporter(stream) if tty else PlainReporter(stream)
