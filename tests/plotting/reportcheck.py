"""The whole path for one study text: load, run, report, and what must hold of the result.

:func:`run_and_report` is what the property test (test_report_property.py) and the kept
regression cases (test_report_regressions.py) call: the study runs with the project's runner
into a fresh folder, the report draws every figure it plans (PNG only, short animations), and
the checks of :func:`check_report` hold: the report returns normally (no failed figure), or,
when the run refused steps, says the study is incomplete naming exactly the steps that failed
or were not run; every planned figure is drawn or skipped with a stated reason, every step
that failed is on the page with its reason, and every file the page references exists.
"""
from __future__ import annotations

import re
import time
from dataclasses import dataclass, field
from pathlib import Path

from matplotlib.text import Text

from monkeystudy.plotting.drawing import NothingToDraw
from monkeystudy.plotting.page import PAGE
from monkeystudy.plotting.report import (
    DRAWINGS, MANIFEST, StudyIncomplete, load_dataset, plan, report_study, split_groups,
    study_datasets,
)
from monkeystudy.study import RunFailed, parse_study, run_study
from monkeystudy.study.runner import StepsFailed

#: What the runner refuses at run time: a step whose source step found nothing to build on
#: (a refine of a grid without a gait, a replay of a refine that found no gait, ...). These
#: are the run's decisions, not the report's; the report must still draw what was written.
RUN_REFUSALS = (
    r"\d+ starts? requested, but (its one point has no gait|none of its \d+ points"
    r"|only \d+ of its)",
    r"found no (gait|cycle) to run",
    r"produced no (usable start|usable gait|solution|converged solution|gait)",
    r"no start produced a solution",
    r"no design of the grid has a gait",
    r"did not converge to a fixed point",
    r"has no \w+ fixed point",
    r"could not analyse its \w+ return map",
)

#: text no figure may show: a number that is not one, a count in the wrong number
BAD_TEXT = (re.compile(r"\bnan\b", re.IGNORECASE),
            re.compile(r"(?<![\d.×])1 (runs|points|cycles|starts|iterations|iterates|designs|levels"
                       r"|solutions|samples|minima)\b"))

#: fast drawing settings: PNG only, a few animation frames
FAST = dict(formats=("png",), fps=4.0, max_frames=5)


@dataclass
class Outcome:
    """What one study came to."""

    folder: Path
    refused: str | None = None              # the run's refusal (RUN_REFUSALS), if any
    incomplete: dict[str, str] = field(default_factory=dict)   # failed / not run: why
    drawn: list[str] = field(default_factory=list)
    skipped: dict[str, str] = field(default_factory=dict)
    lines: list[str] = field(default_factory=list)
    run_seconds: float = 0.0
    report_seconds: float = 0.0


def run_and_report(text: str, folder: Path, *, workers: int | None = None) -> Outcome:
    """Run the study ``text`` into ``folder`` and report it; check the result."""
    loaded = parse_study(text, "<drawn study>")
    out = Outcome(folder)
    t0 = time.perf_counter()
    try:
        run_study(loaded, folder, workers=1)
    except RunFailed as exc:
        msg = str(exc)
        assert isinstance(exc, StepsFailed), f"the run failed: {msg}"
        for step, why in exc.summary.failed.items():
            assert any(re.search(p, why) for p in RUN_REFUSALS), f"the run failed: {msg}"
        out.refused = msg
        out.incomplete = {**exc.summary.failed, **exc.summary.not_run}
    out.run_seconds = time.perf_counter() - t0
    if not folder.is_dir() or not study_datasets(folder):
        assert out.refused, "the run wrote no dataset and said nothing"
    t1 = time.perf_counter()
    try:
        report_study(folder, progress=out.lines.append, workers=workers, **FAST)
        assert not out.refused, "the report of a study that refused steps says it is complete"
    except StudyIncomplete as exc:
        assert set(exc.failed) == set(out.incomplete) and not exc.missing, str(exc)
    out.report_seconds = time.perf_counter() - t1
    check_report(folder, out)
    return out


def check_report(folder: Path, out: Outcome) -> None:
    """Every planned figure drawn or skipped with a reason (log and page), every image the
    page references on disk, and a second report finds everything up to date."""
    import json

    figs = folder / "figures"
    manifest = (json.loads((figs / MANIFEST).read_text())["figures"]
                if (figs / MANIFEST).exists() else {})     # nothing planned, nothing drawn
    page = (figs / PAGE).read_text()
    for job in plan(folder, fps=FAST["fps"], max_frames=FAST["max_frames"]):
        entry = manifest.get(job.name)
        assert entry is not None, f"{job.name}: planned, neither drawn nor skipped"
        if "skipped" in entry:
            reason = entry["skipped"]
            assert reason.strip(), f"{job.name}: skipped without a reason"
            out.skipped[job.name] = reason
            assert any(f"{job.name}: skipped: {reason}" in line for line in out.lines), \
                f"{job.name}: the log does not say why it was skipped"
            assert f'id="{job.name}" class="skipped"' in page, \
                f"{job.name}: the page does not show the skipped figure"
        else:
            assert entry["outputs"], f"{job.name}: drawn, but no file recorded"
            out.drawn.append(job.name)
    for job in plan(folder, animation=False):
        if job.name in out.drawn:
            data = [load_dataset(p) for p in job.inputs]
            how = DRAWINGS[job.key]
            try:
                fig = how.draw(split_groups(data, job.sizes) if job.sizes else data)
            except NothingToDraw:
                raise AssertionError(f"{job.name}: drawn by the report, not on a redraw")
            for t in fig.findobj(Text):
                for bad in BAD_TEXT:
                    assert not bad.search(t.get_text()), \
                        f"{job.name}: figure text {t.get_text()!r}"
    shown = re.sub(r"<pre>.*?</pre>", "", page, flags=re.S)     # the study file as written
    for bad in BAD_TEXT:
        assert not bad.search(shown), f"the page says {bad.search(shown).group(0)!r}"
    for ref in re.findall(r'(?:src|href)="([^"#][^"]*)"', page):
        assert (figs / ref).resolve().is_file(), f"the page references {ref}, not on disk"
    for step, why in out.incomplete.items():
        assert f'<h3 id="step-{step}">' in page, f"{step}: failed, not on the page"
        assert any(line.startswith(f"step {step}: ") for line in out.lines), \
            f"{step}: failed, not in the log"
    again: list[str] = []
    try:
        written = report_study(folder, progress=again.append, **FAST)
    except StudyIncomplete as exc:
        written = exc.written
    assert written == [], "a second report redrew something"
