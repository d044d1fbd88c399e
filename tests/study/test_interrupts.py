"""Ctrl-C as a person presses it: in a pseudo-terminal, at known points of a first run.

Every interruption lands at a point the test has seen the run reach (the live compile line;
the pause that ``$MONKEYSTUDY_PAUSE_AFTER_BLOCKS`` holds after so many computed blocks), never
at a time hoped to fall inside the run, so the tests hold on a fast or a slow machine. A
terminal's Ctrl-C is SIGINT to the foreground process group: the driver, its pool's workers
and the compiling helper alike. A signal in a step's work in the driver (a design's refine,
screen, checks) is sent by the run's own progress count, in the run's process.
"""
from __future__ import annotations

import os
import pty
import re
import select
import signal
import sys
import threading
import time
from pathlib import Path

import pytest

from monkeystudy.service.client import sigterm_as_interrupt
from monkeystudy.study.errors import RunInterrupted
from monkeystudy.study.loader import load_study
from monkeystudy.study.runner import run_study

from studyhelpers import RecordingReporter, assert_same_datasets, write_study
from test_motor_frame import design_b_study

pytestmark = pytest.mark.skipif(os.name != "posix", reason="pseudo-terminals and signals")

STUDY = """\
schema_version: 1
name: interrupted
robot: seed2009
gait: {kind: horizontal, motor_torque: 0.6354, tick: 0.001}
integrator: {rtol: 1.0e-8, atol: 1.0e-10}
steps:
  - {name: map, kind: grid, block_size: 40,
     dtheta1: {start: 0.0, stop: 3.0, num: 30}, dtheta2: {start: 9.0, stop: 14.0, num: 40}}
  - {name: best, kind: refine, start: {from: map, best: 1}, maxiter: 10}
"""
N_BLOCKS = 30

#: a hang guard, not a timing: a cold compile on a loaded 2-core machine can take minutes
HANG = 600.0


class Terminal:
    """``monkeystudy ARGS`` in a pseudo-terminal: its output as it comes, Ctrl-C, exit code."""

    def __init__(self, args: list[str], env: dict[str, str]):
        self.pid, self.fd = pty.fork()
        if self.pid == 0:  # the child: the command, as the terminal's foreground job
            os.execvpe(sys.executable, [sys.executable, "-m", "monkeystudy", *args],
                       {**os.environ, **env})
        self.output = ""
        self.code: int | None = None

    def _read(self, timeout: float) -> bool:
        """Read what is there within ``timeout``; False once the terminal is closed."""
        ready, _, _ = select.select([self.fd], [], [], timeout)
        if not ready:
            return True
        try:
            data = os.read(self.fd, 65536)
        except OSError:   # EIO: the child closed the terminal
            return False
        if not data:
            return False
        self.output += data.decode(errors="replace")
        return True

    def wait_for(self, pattern: str, timeout: float = HANG) -> None:
        t0 = time.monotonic()
        while not re.search(pattern, self.output):
            if not self._read(0.1) or time.monotonic() - t0 > timeout:
                self.close()
                pytest.fail(f"never printed {pattern!r} (exit {self.code}):\n{self.output}")

    def ctrl_c(self) -> None:
        os.killpg(self.pid, signal.SIGINT)

    def close(self, timeout: float = HANG) -> int:
        t0 = time.monotonic()
        while self._read(0.1) and time.monotonic() - t0 < timeout:
            pass
        if self.code is None:
            try:
                _, status = os.waitpid(self.pid, 0 if time.monotonic() - t0 < timeout
                                       else os.WNOHANG)
                self.code = os.waitstatus_to_exitcode(status)
            except ChildProcessError:
                pass
            if self.code is None:
                os.killpg(self.pid, signal.SIGKILL)
                os.waitpid(self.pid, 0)
                self.code = -9
            os.close(self.fd)
        return self.code


def _run(args, env=None) -> Terminal:
    return Terminal(["run", *map(str, args)], env or {})


def _shards(out: Path) -> int:
    return len(list(out.glob(".map.parts/*/b*.npz")))


def _assert_one_clean_line(term: Terminal, needle: str) -> None:
    assert term.code == 3, term.output
    for sign in ("Traceback", "Aborted", "Exception ignored"):
        assert sign not in term.output, term.output
    assert needle in term.output, term.output


@pytest.mark.slow
@pytest.mark.parametrize("seconds", [1, 4])
def test_ctrl_c_while_compiling_exits_3_and_the_rerun_completes(tmp_path, seconds):
    """A first run with an empty kernel cache, interrupted while it compiles (``seconds``
    into it, as its live line shows): exit 3, one line, no traceback (nor one that numba's
    compiler swallows), no helper process left; the same command then compiles on and
    finishes."""
    study = write_study(tmp_path, STUDY, "s.yaml")
    out = tmp_path / "out"
    env = {"NUMBA_CACHE_DIR": str(tmp_path / "cold-cache")}
    term = _run([study, "--out", out, "--workers", "2"], env)
    term.wait_for(rf"compiling: ([{seconds}-9]|[1-9][0-9])")
    term.ctrl_c()
    term.close()
    _assert_one_clean_line(term, "interrupted before any step finished")
    assert "compiling: stopped after" in term.output   # it landed inside the compile
    assert not list(out.glob("*.nc"))
    # the helper got the Ctrl-C too and the run stops it: none goes on compiling (one that
    # is still being reaped may show for a moment on a loaded machine)
    t0 = time.monotonic()
    while _helpers(tmp_path) and time.monotonic() - t0 < 10:
        time.sleep(0.1)
    assert not _helpers(tmp_path), "the compiling helper outlived the run"

    again = _run([study, "--out", out, "--workers", "2"], env)
    assert again.close() == 0, again.output
    assert "compiled the kernels in" in again.output
    assert (out / "map.nc").exists() and (out / "best.nc").exists()


def _helpers(tmp_path: Path) -> list[Path]:
    """Compiling helpers running with this test's kernel cache."""
    return [p for p in Path("/proc").glob("[0-9]*/cmdline")
            if b"monkeystudy.compiling" in _read_bytes(p)
            and str(tmp_path).encode() in _read_bytes(p.with_name("environ"))]


def _read_bytes(path: Path) -> bytes:
    try:
        return path.read_bytes()
    except OSError:
        return b""


@pytest.mark.slow
def test_ctrl_c_in_a_block_and_in_a_resumed_run_then_the_rerun_is_bit_identical(tmp_path):
    """Interrupted after 3 computed blocks, then after 5 more of the resumed run: exit 3 with
    one line each time, shards kept; the third run computes only what is missing, and its
    datasets equal an uninterrupted run's bit for bit."""
    study = write_study(tmp_path, STUDY, "s.yaml")
    out = tmp_path / "out"
    saved = 0
    for pause in (3, 5):
        term = _run([study, "--out", out, "--workers", "2"],
                    {"MONKEYSTUDY_PAUSE_AFTER_BLOCKS": str(pause)})
        term.wait_for("waiting for a signal")
        term.ctrl_c()
        term.close()
        _assert_one_clean_line(term, "finished blocks saved: rerun the same command to resume")
        assert _shards(out) >= saved + pause
        saved = _shards(out)
        assert saved < N_BLOCKS and not (out / "map.nc").exists()
        assert term.output.rfind("\x1b[?25h") >= term.output.rfind("\x1b[?25l"), \
            "the terminal's cursor was left hidden"

    last = _run([study, "--out", out, "--workers", "2"])
    assert last.close() == 0, last.output
    assert f"({saved} already saved)" in last.output
    clean = tmp_path / "clean"
    run_study(load_study(study), clean, workers=1)
    assert_same_datasets(clean, out, ["map.nc", "best.nc"])


# --- an interruption while a step works in the driver ---------------------------------------------
DESIGN = design_b_study("design_interrupted")
DESIGN_FILES = ["refine.nc", "floquet.nc", "design.nc"]


class SignalInPhase(RecordingReporter):
    """Sends ``signum`` to the main thread at the first count of the design step's phase
    ``label`` (its work in the driver, after its blocks), then counts the units that phase
    still does."""

    def __init__(self, label: str, signum: int):
        super().__init__()
        self.label, self.signum = label, signum
        self.current = ""
        self.total = 0
        self.sent = False
        self.after = 0

    def phase(self, name, label, total, unit, then="", done=0):
        super().phase(name, label, total, unit, then, done)
        if name == "design":
            self.current = label
            if label == self.label:
                self.total = total

    def advance(self, name, n=1):
        super().advance(name, n)
        if name != "design" or self.current != self.label:
            return
        if self.sent:
            self.after += n
        else:
            self.sent = True
            signal.pthread_kill(threading.main_thread().ident, self.signum)


@pytest.fixture(scope="module")
def design_clean(tmp_path_factory) -> Path:
    """The design study run once without an interruption."""
    folder = tmp_path_factory.mktemp("design_clean")
    run_study(load_study(write_study(folder, DESIGN, "design.yaml")), folder / "out",
              workers=1)
    return folder / "out"


@pytest.mark.slow
@pytest.mark.parametrize("label, signum", [("refine", signal.SIGINT),
                                           ("screen", signal.SIGTERM),
                                           ("checks", signal.SIGINT)])
def test_a_signal_in_a_design_steps_driver_phase_stops_it_at_the_next_count(
        tmp_path, design_clean, label, signum):
    """Ctrl-C (or SIGTERM, as the command line handles it: like Ctrl-C) during the design
    step's refine, screen or checks, which run in the driver after its blocks: the run stops
    at the phase's next count, not when the step ends, with the datasets of the steps before
    written and the design's blocks saved; the rerun computes no block again, and its
    datasets equal an uninterrupted run's bit for bit."""
    study = write_study(tmp_path, DESIGN, "design.yaml")
    out = tmp_path / "out"
    rec = SignalInPhase(label, signum)
    previous = sigterm_as_interrupt() if signum == signal.SIGTERM else None
    try:
        with pytest.raises(RunInterrupted, match="2 of 3 datasets written"):
            run_study(load_study(study), out, workers=1, reporter=rec)
    finally:
        if previous is not None:
            signal.signal(signal.SIGTERM, previous)
    assert rec.sent and rec.total > 2
    assert rec.after <= 1 < rec.total - 1, (label, rec.after, rec.total)
    assert not (out / "design.nc").exists()
    assert (out / "refine.nc").exists() and (out / "floquet.nc").exists()
    saved = len(list(out.glob(".design.parts/*/b*.npz")))
    assert saved > 0

    summary = run_study(load_study(study), out, workers=1)
    assert [p.name for p in summary.written] == ["design.nc"]
    assert (summary.blocks_computed, summary.blocks_reused) == (0, saved)
    assert_same_datasets(design_clean, out, DESIGN_FILES)
