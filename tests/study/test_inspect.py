"""What ``monkeystudy inspect`` and the run's log say of a study's datasets."""
from __future__ import annotations

import re

from monkeystudy.study import load_study, run_study
from monkeystudy.study.inspect import summarize, summarize_folder
from monkeystudy.study.progress import singular_counts

from studyhelpers import write_study

#: one point, one iteration, one cycle: every count a step reports is 1
ONES = """\
schema_version: 1
name: ones
robot: seed2009
gait: {kind: horizontal, motor_torque: 0.6354, tick: 0.005}
integrator: {rtol: 1.0e-8, atol: 1.0e-10}
steps:
  - {name: point, kind: grid, points: [[0.945, 10.9]]}
  - {name: best, kind: refine, start: [0.945, 10.9], maxiter: 2}
  - {name: one, kind: stability, from: best, cycles: 1}
"""

#: a count of one with a plural noun
ONE_PLURAL = re.compile(r"(?<![\d.])1 (points|cycles|vertical crossings|iterations|runs)\b")


def test_counts_of_one_are_singular_in_the_log_and_in_inspect(tmp_path):
    out = tmp_path / "out"
    summary = run_study(load_study(write_study(tmp_path, ONES, "ones.yaml")), out, workers=1)
    assert summary.notes["one"].startswith("1 cycle, status ok"), summary.notes["one"]
    assert summary.notes["point"].startswith("1 point,"), summary.notes["point"]
    text = summarize_folder(out) + "\n" + summarize(out / "one.nc")
    assert "1 of 1 cycle completed, 1 vertical crossing" in text, text
    for line in list(summary.notes.values()) + text.splitlines():
        assert not ONE_PLURAL.search(line), line


def test_singular_counts():
    assert singular_counts("1 of 1 cycles completed, 1 vertical crossings") == \
        "1 of 1 cycle completed, 1 vertical crossing"
    assert singular_counts("11 points, 0.1 runs, 2 of 21 cycles") == \
        "11 points, 0.1 runs, 2 of 21 cycles"
