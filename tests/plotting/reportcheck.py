"""The whole path for one study text: load, run, report, and what must hold of the result.

:func:`run_and_report` is what the property test (test_report_property.py) and the kept
regression cases (tests/regressions/test_report_studies.py) call: the study runs with the
project's runner into a fresh folder, the report draws every figure it plans (PNG only, short
animations), and what must hold of the result is checked:

* the run completes, or the steps it refuses found nothing to build on
  (:data:`RUN_REFUSALS`) and it ends with ``StepsFailed`` naming each; every step that does
  not depend on a failed step ran (its dataset is there), and every step not run depends on
  one;
* the datasets (tests/plotting/datasetcheck.py): no unexplained NaN, a replay of a converged
  fixed point stays near it, a floquet step's handed-on point is converged or the next
  step's refusal says it is not;
* the report (:func:`check_report`) returns normally (no failed figure), or, when the run
  refused steps, says the study is incomplete naming exactly the steps that failed or were
  not run; every planned figure is drawn or skipped with a stated reason, no two figures are
  drawn to one file, every step that failed is on the page with its reason, every file the
  page references exists, and a second report redraws nothing.
"""
from __future__ import annotations

import html
import re
import time
from dataclasses import dataclass, field
from pathlib import Path

import yaml
from matplotlib.text import Text

from monkeystudy.plotting.drawing import NothingToDraw
from monkeystudy.plotting.page import PAGE
from monkeystudy.plotting.report import (
    DRAWINGS, MANIFEST, StudyIncomplete, load_dataset, plan, report_study, split_groups,
    study_datasets,
)
from monkeystudy.study import RunFailed, parse_study, run_study
from monkeystudy.study.progress import Reporter
from monkeystudy.study.runner import StepsFailed

from plotting.datasetcheck import dataset_problems

#: What the runner refuses at run time: a step whose source step found nothing to build on
#: (a refine of a grid without a gait, a replay of a refine that found no gait, ...). These
#: are the run's decisions, not the report's; the report must still draw what was written.
RUN_REFUSALS = (
    r"\d+ starts? requested, but (its one point has no gait|none of its \d+ points"
    r"|only \d+ of its)",
    r"found no (gait|cycle) to run",
    r"produced no (usable start|usable gait|solution|converged solution|converged grazing gait"
    r"|gait)",
    r"no start produced a solution",
    r"no design of the grid has a gait",
    r"did not converge to a fixed point",
    r"has no \w+ fixed point",
    r"could not analyse its \w+ return map",
    r"no gait at any of the \d+ points?",
    r"no well-conditioned gait among the \d+ points",
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


class LogLines(Reporter):
    """The run's log as the study runner reports it: each written step's line."""

    def __init__(self):
        self.notes: dict[str, str] = {}

    def finish(self, name: str, message: str = "") -> None:
        self.notes[name] = message


def run_and_report(text: str, folder: Path, *, workers: int | None = None) -> Outcome:
    """Run the study ``text`` into ``folder`` and report it; check the result (every
    problem found is named in one AssertionError)."""
    loaded = parse_study(text, "<drawn study>")
    study = yaml.safe_load(text)
    out = Outcome(folder)
    problems: list[str] = []
    failed: dict[str, str] = {}
    log = LogLines()
    t0 = time.perf_counter()
    try:
        run_study(loaded, folder, workers=1, reporter=log)
    except RunFailed as exc:
        msg = str(exc)
        out.refused = msg
        if isinstance(exc, StepsFailed):
            failed = dict(exc.summary.failed)
            out.incomplete = {**exc.summary.failed, **exc.summary.not_run}
            problems += [f"the run failed: {step}: {why}" for step, why in failed.items()
                         if not any(re.search(p, why) for p in RUN_REFUSALS)]
        else:     # one failure ended the run (its message names the step first)
            problems.append(f"the run failed: {msg}")
            step, _, why = msg.partition(": ")
            if step in {s["name"] for s in study["steps"]}:
                failed = {step: why}
    out.run_seconds = time.perf_counter() - t0
    problems += steps_ran_problems(study, folder, failed, out.incomplete)
    problems += dataset_problems(folder, study, log.notes, failed)
    try:
        if not folder.is_dir() or not study_datasets(folder):
            assert out.refused, "the run wrote no dataset and said nothing"
        t1 = time.perf_counter()
        try:
            report_study(folder, progress=out.lines.append, workers=workers, **FAST)
            assert not out.refused, \
                "the report of a study that refused steps says it is complete"
        except StudyIncomplete as exc:
            assert set(exc.failed) == set(out.incomplete) and not exc.missing, str(exc)
        out.report_seconds = time.perf_counter() - t1
        check_report(folder, out)
    except AssertionError as exc:
        problems.append(str(exc))
    assert not problems, "\n".join(problems)
    return out


def depends_on(study: dict) -> dict[str, set[str]]:
    """Every step's sources, direct and indirect, by name: ``from``, a refine's
    ``start.from``, a tick_sweep's ``floquet``."""
    direct = {}
    for step in study["steps"]:
        start = step.get("start")
        names = {step.get("from"), step.get("floquet"),
                 start.get("from") if isinstance(start, dict) else None}
        direct[step["name"]] = {n for n in names if n}
    deps: dict[str, set[str]] = {}
    for name in direct:            # steps come after their sources (the loader checks)
        deps[name] = set(direct[name])
        for d in direct[name]:
            deps[name] |= deps.get(d, set())
    return deps


def steps_ran_problems(study: dict, folder: Path, failed: dict[str, str],
                       incomplete: dict[str, str]) -> list[str]:
    """A failed step stops only itself and the steps built on it: every other step wrote
    its dataset, and every step not run depends on a failed one."""
    out = []
    for name, sources in depends_on(study).items():
        if name in failed:
            continue
        if sources & set(failed):
            if name not in incomplete:
                out.append(f"{name}: built on failed {sorted(sources & set(failed))}, but "
                           "not said to be not run")
        elif not (folder / f"{name}.nc").is_file():
            out.append(f"{name}: depends on no failed step and did not run"
                       + (f": {incomplete[name]}" if name in incomplete else ""))
    return out


def check_report(folder: Path, out: Outcome) -> None:
    """Every planned figure drawn or skipped with a reason (log and page), every image the
    page references on disk, and a second report finds everything up to date."""
    import json

    figs = folder / "figures"
    manifest = (json.loads((figs / MANIFEST).read_text())["figures"]
                if (figs / MANIFEST).exists() else {})     # nothing planned, nothing drawn
    page = (figs / PAGE).read_text()
    jobs = plan(folder, fps=FAST["fps"], max_frames=FAST["max_frames"])
    names = [job.name for job in jobs]
    twice = sorted({n for n in names if names.count(n) > 1})
    assert not twice, f"figures drawn twice to one file: {', '.join(twice)}"
    files = [f for entry in manifest.values() for f in entry.get("outputs", [])]
    assert len(files) == len(set(files)), "two figures of the manifest share a file"
    for job in jobs:
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
    text = html.unescape(page)
    for step, why in out.incomplete.items():
        assert f'<h3 id="step-{step}">' in page, f"{step}: failed, not on the page"
        assert why in text, f"{step}: its reason is not on the page: {why}"
        assert any(line.startswith(f"step {step}: ") for line in out.lines), \
            f"{step}: failed, not in the log"
    again: list[str] = []
    try:
        written = report_study(folder, progress=again.append, **FAST)
    except StudyIncomplete as exc:
        written = exc.written
    assert written == [], f"a second report redrew {[p.name for p in written]}: {again}"
