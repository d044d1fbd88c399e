"""Progress counts: what workers send as they go reaches the reporter, a task never counts
more than its units, and the plain reporter names a step's phases."""
from __future__ import annotations

import io
import queue
import re
import time

from monkeystudy.study import counts as C
from monkeystudy.study import progress as P
from monkeystudy.study.runner import TaskCounts

from studyhelpers import RecordingReporter


def test_a_task_counts_its_units_once_whatever_its_worker_sent():
    rep = RecordingReporter()
    counts = TaskCounts(rep)
    key = counts.add("survival", 10)
    counts.sent(key, 4)
    counts.sent(key, 20)           # more than it has left: the rest only
    assert rep.counted("survival") == 10
    counts.done(key)               # nothing left to count
    counts.sent(key, 3)            # a count that comes after its result: ignored
    assert rep.counted("survival") == 10
    other = counts.add("survival", 5)
    counts.sent(other, 2)
    counts.done(other)             # its result: the 3 units its worker did not send
    assert rep.counted("survival") == 15
    dropped = counts.add("design", 7)
    counts.drop(dropped)           # its step failed: it counts no more
    counts.sent(dropped, 7)
    assert rep.counted("design") == 0


def test_worker_counts_reach_the_reporter_before_the_result():
    """The counts are read on a thread of their own: they move while the driver is busy
    (here: never handles the result)."""
    rep = RecordingReporter()
    counts = TaskCounts(rep)
    channel = queue.Queue()
    key = counts.add("survival", 100)
    listener = counts.listen(channel)
    try:
        channel.put((key, 30))
        channel.put((key, 12))
        deadline = time.monotonic() + 60
        while rep.counted("survival") < 42 and time.monotonic() < deadline:
            time.sleep(0.01)
        assert rep.counted("survival") == 42
    finally:
        counts.stop(listener)
    assert not listener.is_alive()


def test_a_counted_task_sends_its_units_under_its_key(monkeypatch):
    monkeypatch.setattr(C, "SEND_PERIOD", 0.0)
    channel = queue.Queue()

    def five_runs():
        for _ in range(5):
            C.task_units(1)
        return "done"

    C.open_task_channel(channel)
    try:
        assert C.run_counted(("run", 3), five_runs, (), {}) == "done"
        C.task_units(1)        # outside a task: counted for nobody
    finally:
        C.open_task_channel(None)
    sent = []
    while not channel.empty():
        sent.append(channel.get())
    assert {k for k, _ in sent} == {("run", 3)} and sum(n for _, n in sent) == 5
    assert C.run_counted(("run", 4), five_runs, (), {}) == "done"   # no channel: just runs
    assert channel.empty()


def test_the_plain_reporter_says_each_phase_and_counts_within_it():
    out = io.StringIO()
    rep = P.PlainReporter(out, every=0.0)
    rep.start("design", 80, 0, "designs")
    rep.phase("design", "grid", 80, "designs", "refine, screen, checks")
    rep.advance("design", 80)
    rep.phase("design", "screen", 800, "runs", "checks")
    rep.advance("design", 400)
    lines = out.getvalue().splitlines()
    assert lines[1] == "[monkeystudy] design: grid: 80 designs (then refine, screen, checks)"
    assert lines[2].startswith("[monkeystudy] design: grid: 80/80 designs (100%)")
    assert lines[3] == "[monkeystudy] design: screen: 800 runs (then checks)"
    assert lines[4].startswith("[monkeystudy] design: screen: 400/800 runs (50%)")
    assert "then checks" in lines[4]       # the eta says the step goes on after it


def test_a_bar_of_a_narrow_terminal_keeps_its_count_and_eta_whole(monkeypatch):
    """At 80 columns a phase's bar with its words ("design: blocks", "then refine,
    screen, checks") lost its count and bar to "…". On a terminal of 80 columns (and 60)
    each bar's line fits, and its count with its unit and its eta are whole: the name and the
    phases to come are what is cut."""
    from rich.console import Console

    for columns in (80, 60):
        monkeypatch.setenv("COLUMNS", str(columns))
        rep = P.RichReporter(io.StringIO())
        rep.start("design", 8, 0, "blocks")
        rep.phase("design", "blocks", 8, "blocks", "refine, screen, checks")
        rep.advance("design", 3)
        name = "a_step_name_as_long_as_a_study_file_allows_it_to_be" * 2
        rep.start(name, 12345, 0, "runs")
        rep.phase(name, "screen", 12345, "refinements", "checks")
        rep.advance(name, 123)
        out = io.StringIO()
        Console(file=out, width=rep.console.width, color_system=None).print(
            rep.progress.make_tasks_table(rep.progress.tasks))
        rep.close()
        lines = out.getvalue().splitlines()
        assert rep.console.width == columns and len(lines) == 2, lines
        for line, count in zip(lines, ("3/8 blocks", "123/12345 refinements")):
            assert len(line) <= columns, line
            assert re.search(re.escape(count.split()[0]) + r"\s+" + count.split()[1], line), line
            assert re.search(r"\d+:\d\d:\d\d eta (-:--:--|\d+:\d\d:\d\d)", line), line


def test_counts_are_worded_in_the_right_number():
    """No "1 cycles", "1 candidates", "for all 1 cycle", "2 level(s)", "drew 1
    figure(s)": one helper words a count (:func:`count`, :func:`all_of`), and the lines the
    step kinds word for any count are settled where they are shown (:func:`singular_counts`)."""
    assert P.count(1, "cycle") == "1 cycle" and P.count(0, "cycle") == "0 cycles"
    assert P.count(2, "minimum", "minima") == "2 minima"
    assert [P.all_of(n, "cycle") for n in (1, 2, 5)] == ["the 1 cycle", "both cycles",
                                                         "all 5 cycles"]
    assert P.units(1, "branches") == "1 branch" and P.units(1, "blocks") == "1 block"
    for line, shown in (
            ("8 runs x 2 level(s); MFPT", "8 runs x 2 levels; MFPT"),
            ("1 noise level(s) x 1 runs of up to 1 cycles", "1 noise level x 1 run of up to "
                                                            "1 cycle"),
            ("refused 1 candidate(s), no gait of", "refused 1 candidate, no gait of"),
            ("chosen by survival: 1 candidates, 1 gaits", "chosen by survival: 1 candidate, "
                                                          "1 gait"),
            ("1 step(s) per cycle", "1 step per cycle"),
            ("1/1 blocks, 0.1 runs, 21 points, 11 cycles", "1/1 blocks, 0.1 runs, 21 points, "
                                                           "11 cycles")):
        assert P.singular_counts(line) == shown


def test_a_run_with_one_step_up_to_date_says_so_in_the_singular(tmp_path):
    """Never "all 1 datasets up to date"."""
    from monkeystudy.study import parse_study, run_study

    text = ("schema_version: 1\nname: one\nrobot: seed2009\n"
            "gait: {kind: horizontal, motor_torque: 0.6354, tick: 0.001}\n"
            "steps:\n  - {name: pts, kind: grid, points: [[0.9, 10.9]]}\n")
    loaded = parse_study(text, "one.yaml", tmp_path / "one.yaml")
    run_study(loaded, tmp_path / "out", workers=1)
    log = io.StringIO()
    run_study(loaded, tmp_path / "out", workers=1, reporter=P.PlainReporter(log))
    assert "one: the 1 dataset up to date in" in log.getvalue(), log.getvalue()


def test_a_phase_line_gives_the_eta_of_its_whole_step_as_far_as_it_is_estimated():
    """A design step's line gave the eta of its phase only. The plain reporter's
    line (an injected clock) gives the step's eta too: the phase's own plus the estimate of
    every phase to come that has one, the others named after it; the last phase's is its
    own."""
    now = [0.0]
    out = io.StringIO()
    rep = P.PlainReporter(out, every=0.0, clock=lambda: now[0])
    rep.start("design", 100, 0, "designs")
    rep.phase("design", "grid", 100, "designs", "refine, screen, checks")
    now[0] = 10.0
    rep.advance("design", 50)                    # 5 designs/s: 10 s left
    rep.estimate("design", "checks", 30.0)
    rep.phase("design", "refine", 200, "designs", "screen, checks")
    now[0] = 14.0
    rep.advance("design", 100)                   # 25 designs/s: 4 s left
    rep.phase("design", "screen", 800, "runs", "checks")
    now[0] = 22.0
    rep.advance("design", 400)                   # 50 runs/s: 8 s left
    rep.phase("design", "checks", 6, "checks")
    now[0] = 25.0
    rep.advance("design", 3)                     # 1 check/s: 3 s left
    lines = out.getvalue().splitlines()
    assert lines[2].endswith("eta 10 s then refine, screen, checks; "
                             "step eta 10 s + refine, screen, checks"), lines[2]
    assert lines[4].endswith("eta 4 s then screen, checks; step eta 34 s + screen"), lines[4]
    assert lines[6].endswith("eta 8 s then checks; step eta 38 s"), lines[6]
    assert lines[8].endswith("3/6 checks (50%), 3.0 s, eta 3 s"), lines[8]


def test_a_phase_bar_gives_the_eta_of_its_whole_step_as_far_as_it_is_estimated():
    """The rich bar of a phase (an injected clock) shows the step's eta beside the phase's
    (the phase's eta plus the estimates of the phases to come), and after the bar the
    phases to come it leaves out, or the phases to come when it leaves out none."""
    from rich.console import Console

    now = [0.0]
    rep = P.RichReporter(io.StringIO(), clock=lambda: now[0])

    def line() -> str:
        out = io.StringIO()
        Console(file=out, width=160, color_system=None).print(
            rep.progress.make_tasks_table(rep.progress.tasks))
        return out.getvalue().strip()

    rep.start("design", 100, 0, "designs")
    rep.phase("design", "refine", 200, "designs", "screen, checks")
    rep.estimate("design", "checks", 30.0)
    for t in (2.0, 4.0):                         # 25 designs/s: 100 left, 4 s
        now[0] = t
        rep.advance("design", 50)
    shown = line()
    assert "eta 0:00:04 step eta 0:00:34" in shown and shown.endswith("+ screen"), shown
    rep.phase("design", "screen", 800, "runs", "checks")
    for t in (6.0, 10.0):                        # 100 runs/s: 400 left, 4 s
        now[0] = t
        rep.advance("design", 400 if t == 10.0 else 0)
    shown = line()
    assert "eta 0:00:04 step eta 0:00:34" in shown and shown.endswith("then checks"), shown
    rep.phase("design", "checks", 6, "checks")
    assert "step eta" not in line()
    rep.close()


def test_a_tasks_phases_are_counts_of_their_own_beside_its_steps_tasks():
    """A hardware_replay step's line sat at 18/19 tasks for the minutes of its
    identification. A task's phases (:func:`~monkeystudy.study.counts.task_phase`) are
    counts of their own under its step (``<step>: <phase>``), each up to its total and
    finished when the next begins or the task's result comes; the step counts the task's
    units when its result comes, whatever its phases counted."""
    rep = RecordingReporter()
    counts = TaskCounts(rep)
    fit = counts.add("replay", 1)
    other = counts.add("replay", 1)
    counts.sent(fit, C.TaskPhase("identify", 7, "residual evaluations"))
    counts.sent(fit, 1)
    counts.sent(fit, 2)
    counts.done(other)                       # another task of the step: the step's count
    counts.sent(fit, C.TaskPhase("replays", 2, "logs"))
    counts.sent(fit, 5)                      # more than the phase has: its total only
    counts.done(fit)
    assert rep.events == [
        ("start", "replay: identify", 7, 0, "residual evaluations"),
        ("advance", "replay: identify", 1), ("advance", "replay: identify", 2),
        ("advance", "replay", 1),
        ("advance", "replay: identify", 4),  # the fit converged: its count made whole
        ("finish", "replay: identify"),
        ("start", "replay: replays", 2, 0, "logs"),
        ("advance", "replay: replays", 2),
        ("finish", "replay: replays"),
        ("advance", "replay", 1)]


def test_a_task_phase_goes_over_the_channel_after_the_units_before_it(monkeypatch):
    """A worker's units of one phase reach the driver before the next phase begins (a
    count sent late would count in the wrong phase)."""
    monkeypatch.setattr(C, "SEND_PERIOD", 60.0)       # units held back until flushed
    channel = queue.Queue()

    def two_phases():
        C.task_phase("identify", 3, "residual evaluations")
        C.task_units(3)
        C.task_phase("replays", 2, "logs")
        C.task_units(2)

    C.open_task_channel(channel)
    try:
        C.run_counted(("run", 1), two_phases, (), {})
    finally:
        C.open_task_channel(None)
    sent = []
    while not channel.empty():
        sent.append(channel.get()[1])
    assert sent == [C.TaskPhase("identify", 3, "residual evaluations"), 3,
                    C.TaskPhase("replays", 2, "logs"), 2]
