"""Any valid study runs and reports: hypothesis draws studies (tests/plotting/studystrategies.py),
each is run with the study runner and reported (tests/plotting/reportcheck.py).

What must hold for every study: the loader accepts it, or refuses two steps whose figures
would share a file name (file:line: steps[i].name, naming both), and the rest runs; the run
completes, or refuses a step whose source found nothing to build on
(``reportcheck.RUN_REFUSALS``) and still runs every step that does not depend on it; its
datasets hold no unexplained NaN, its replays of a converged fixed point stay near it, and
a floquet step's handed-on point is converged or refused saying it is not
(tests/plotting/datasetcheck.py); the report returns normally, or says which steps failed,
every figure it plans is drawn or skipped with a reason given in the log and on the page, no
two to one file, the page's images exist, no figure text says "nan" or "1 runs", and a second
report redraws nothing. And a study with several problems has them all reported in one pass.

The default run draws a fixed set of examples (``derandomize``); the slow test draws others,
as many as ``MONKEYSTUDY_PROPERTY_EXAMPLES`` says (default 25). Every failure found is kept as
a named case in tests/regressions/test_report_studies.py.
"""
from __future__ import annotations

import os
import re

import pytest
from hypothesis import HealthCheck, given, settings

from monkeystudy.study import parse_study
from monkeystudy.study.loader import StudyError

from reportcheck import run_and_report
from studystrategies import (
    invalid_studies, key_text, rename, studies, study_lines, study_text,
)

#: examples of the slow test (set MONKEYSTUDY_PROPERTY_EXAMPLES=500 for a long search)
SLOW_EXAMPLES = int(os.environ.get("MONKEYSTUDY_PROPERTY_EXAMPLES", "25"))

COMMON = dict(deadline=None, database=None, derandomize=True,
              suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])

SHOWN = "<drawn study>"

#: the loader's refusal of two steps whose figures would share a file name
CLASH = re.compile(re.escape(SHOWN) + r":(\d+): steps\[(\d+)\]\.name: figure file (\S+) "
                   r"would be both the \w+ figure (\w+) of step '([^']+)' and the \w+ figure "
                   r"(\w+) of step '([^']+)'")


def line_of(where: dict, path: tuple) -> int:
    """The line of a key (of its longest path :func:`study_lines` records)."""
    while path not in where:
        path = path[:-1]
    return where[path]


def without_clashes(study: dict) -> dict:
    """The study as the loader accepts it: when two of its steps would draw figures of one
    file name, the loader must refuse the later one at its name's line, naming the figure
    and both steps; that step renamed, the study is valid."""
    text = study_text(study)
    try:
        parse_study(text, SHOWN)
        return study
    except StudyError as exc:
        lines, where = study_lines(study)
        steps = study["steps"]
        renamed = {}
        for problem in str(exc).splitlines():
            m = CLASH.match(problem)
            assert m, f"a valid study refused: {problem}\n{text}"
            line, i, file, fig1, step1, fig2, step2 = m.groups()
            name = steps[int(i)]["name"]
            assert int(line) == line_of(where, ("steps", int(i), "name")), problem
            assert name in (step1, step2) and {step1, step2} <= {s["name"] for s in steps}
            assert file == f"{step1}_{fig1}" == f"{step2}_{fig2}", problem
            renamed[name] = f"renamed{i}"
    fixed = rename(study, renamed)
    parse_study(study_text(fixed), SHOWN)
    return fixed


def check(study: dict, root) -> None:
    """Run and report the study (``run_and_report`` asserts every property of the result);
    either the run refused with one of the run's stated reasons, or every planned figure was
    drawn or skipped with its reason."""
    study = without_clashes(study)
    out = run_and_report(study_text(study), root.mktemp("study") / "out")
    assert out.refused or out.drawn or out.skipped, "nothing was run, drawn or skipped"


@settings(max_examples=12, **COMMON)
@given(study=studies())
def test_any_valid_study_runs_and_reports(study, tmp_path_factory):
    check(study, tmp_path_factory)


@pytest.mark.slow
@settings(max_examples=SLOW_EXAMPLES, **COMMON)
@given(study=studies())
def test_many_valid_studies_run_and_report(study, tmp_path_factory):
    check(study, tmp_path_factory)


@settings(max_examples=60, **COMMON)
@given(drawn=invalid_studies())
def test_every_problem_of_a_study_is_reported_in_one_pass(drawn):
    """A study with a field error (a setting out of range, an unknown key or a gait
    setting), a ``from:`` naming a later step and perhaps a duplicate name: the loader
    reports each, as ``file:line: key: message``, in one pass."""
    study, expected = drawn
    lines, where = study_lines(study)
    with pytest.raises(StudyError) as exc:
        parse_study(study_text(study), SHOWN)
    reported = str(exc.value).splitlines()
    for problem in reported:
        assert re.match(re.escape(SHOWN) + r":\d+: [\w.\[\]-]+: \S", problem), problem
    for path in expected:
        head = f"{SHOWN}:{line_of(where, path)}: {key_text(path)}: "
        assert any(p.startswith(head) for p in reported), \
            f"{head}... not reported:\n" + "\n".join(reported)
