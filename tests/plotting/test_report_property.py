"""Any valid study runs and reports: hypothesis draws studies (tests/plotting/studystrategies.py),
each is run with the study runner and reported (tests/plotting/reportcheck.py).

What must hold for every study: the loader accepts it; the run completes, or refuses a step
whose source found nothing to build on (``reportcheck.RUN_REFUSALS``); the report returns
normally, every figure it plans is drawn or skipped with a reason given in the log and on the
page, the page's images exist, no figure text says "nan" or "1 runs", and a second report
redraws nothing.

The default run draws a fixed set of examples (``derandomize``); the slow test draws others,
as many as ``MONKEYSTUDY_PROPERTY_EXAMPLES`` says (default 25). Every failure found is kept as
a named case in tests/regressions/test_report_studies.py.
"""
from __future__ import annotations

import os

import pytest
from hypothesis import HealthCheck, given, settings

from reportcheck import run_and_report
from studystrategies import studies, study_text

#: examples of the slow test (set MONKEYSTUDY_PROPERTY_EXAMPLES=500 for a long search)
SLOW_EXAMPLES = int(os.environ.get("MONKEYSTUDY_PROPERTY_EXAMPLES", "25"))

COMMON = dict(deadline=None, database=None, derandomize=True,
              suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])


def check(study: dict, root) -> None:
    """Run and report the study (``run_and_report`` asserts every property of the result);
    either the run refused with one of the run's stated reasons, or every planned figure was
    drawn or skipped with its reason."""
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
