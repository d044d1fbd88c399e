"""A study's ``wall:`` block: read into a :class:`~monkeystudy.wall.Wall`, every mistake
reported as ``file:line: key: message`` before any work."""
from __future__ import annotations

import numpy as np
import pytest

from monkeystudy.study import StudyError, parse_study
from monkeystudy.wall import Goal, Region, Start, Wall

HEAD = """\
schema_version: 1
name: climb
robot: seed2009
gait: {kind: horizontal, motor_torque: 0.6354}
steps:
  - {name: g, kind: refine, start: [0.9, 10.9]}
"""

WALL = """\
wall:
  margin: 0.03
  regions:
    - outline: [[0, 0], [6, 0], [6, 3], [0, 3]]
      holes:
        - [[2, 1], [3, 1], [3, 2], [2, 2]]
    - outline: [[7, 0], [9, 0], [8, 2]]
  start: {position: [0.5, 1.5], attached: B}
  goal: {position: [5.5, 1.5], radius: 0.2}
"""


def issues(text: str) -> list[str]:
    with pytest.raises(StudyError) as info:
        parse_study(text, "w.yaml")
    return str(info.value).splitlines()


def test_the_block_is_the_wall_it_describes():
    study = parse_study(HEAD + WALL, "w.yaml").study
    wall = study.wall.to_wall()
    assert wall == Wall([Region([(0, 0), (6, 0), (6, 3), (0, 3)],
                                [[(2, 1), (3, 1), (3, 2), (2, 2)]]),
                         Region([(7, 0), (9, 0), (8, 2)])],
                        Start((0.5, 1.5), "B"), Goal((5.5, 1.5), 0.2), 0.03)
    np.testing.assert_array_equal(wall.on_steel([(2.5, 1.5), (8.0, 1.0)]), [False, True])
    assert parse_study(HEAD, "w.yaml").study.wall is None


@pytest.mark.parametrize("old, new, want", [
    ("[[7, 0], [9, 0], [8, 2]]", "[[7, 0], [9, 0], [8, 0]]",
     "w.yaml:13: wall.regions[1].outline: edges 0 and 1 fold back onto each other"),
    ("[[2, 1], [3, 1], [3, 2], [2, 2]]", "[[2, 1], [3, 1], [2, 2], [3, 2]]",
     "w.yaml:12: wall.regions[0].holes[0]: the polygon crosses itself: edge 1 (vertices 1-2) "
     "meets edge 3 (vertices 3-0)"),
    ("[[7, 0], [9, 0], [8, 2]]", "[[7, 0], [9, 0]]",
     "w.yaml:13: wall.regions[1].outline: must have at least 3 items, got 2"),
    ("position: [0.5, 1.5]", "position: [2.5, 1.5]",
     "w.yaml:14: wall.start.position: start (2.5, 1.5) is not on steel: the attached magnet "
     "must hold on a region"),
    ("attached: B", "attached: C", "w.yaml:14: wall.start.attached: must be 'A' or 'B'"),
    ("radius: 0.2", "radius: -0.2", "w.yaml:15: wall.goal.radius: must be > 0, got -0.2"),
    ("margin: 0.03", "margni: 0.03", "w.yaml:8: wall.margni: unknown key; did you mean "
     "'margin'?"),
    ("[[2, 1], [3, 1], [3, 2], [2, 2]]", "[[2, 1], [3, 1], [3, .inf], [2, 2]]",
     "w.yaml:12: wall.regions[0].holes[0][2][1]: must be finite"),
])
def test_a_mistake_in_the_block_names_its_line_and_key(old, new, want):
    assert old in WALL
    got = issues(HEAD + WALL.replace(old, new))
    assert any(line.startswith(want) for line in got), got


def test_a_start_off_steel_is_reported_with_the_studys_other_problems():
    """The start is checked across the block even when another part of the study is not
    valid, so one pass reports both."""
    text = (HEAD.replace("seed2009", "seed2010")
            + WALL.replace("position: [0.5, 1.5]", "position: [8.5, 1.9]"))
    got = issues(text)
    assert got[0].startswith("w.yaml:3: robot: must be")
    assert got[1].startswith("w.yaml:14: wall.start.position: start (8.5, 1.9) is not on "
                             "steel")
