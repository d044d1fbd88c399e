"""Study files: every mistake rejected before any work, located as ``file:line: key``."""
from __future__ import annotations

import json
from pathlib import Path

import pytest

from monkeystudy.study import StudyError, load_study, parse_study
from monkeystudy.study.schema import json_schema
from monkeystudy.study.steps.grid import GridStep
from monkeystudy.study.steps.refine import BestOfGrid, RefineStep
from monkeystudy.study.steps.stability import StabilityStep

HERE = Path(__file__).parent
ROOT = HERE.parents[1]
BAD = sorted((HERE / "bad_studies").glob("*.yaml"))


def expected(path: Path) -> str:
    first = path.read_text().splitlines()[0]
    assert first.startswith("# expect: "), path
    return first[len("# expect: "):]


def test_corpus_is_large_enough():
    assert len(BAD) >= 12


@pytest.mark.parametrize("path", BAD, ids=[p.stem for p in BAD])
def test_bad_study_is_rejected_with_file_line_key(path):
    with pytest.raises(StudyError) as info:
        load_study(path)
    lines = str(info.value).splitlines()
    want = f"{path}:{expected(path)}"
    assert any(line.startswith(want) for line in lines), (want, lines)
    for issue in info.value.issues:
        assert issue.file == str(path)


def test_every_problem_is_reported_sorted_by_line():
    text = """\
schema_version: 1
name: two
robot: {links: [{mass: -1.0, length: 0.61, com: 0.3, inertia: 0.01},
                {mass: 1.0, length: 0.61, com: 0.3, inertia: 0.01}]}
gait: {kind: horizontal, motor_torque: 0.6354, tikc: 0.001}
steps:
  - {name: g, kind: refine, start: [0.9, 10.9], xatol: 0}
"""
    with pytest.raises(StudyError) as info:
        parse_study(text, "x.yaml")
    msg = str(info.value).splitlines()
    assert msg == [
        "x.yaml:3: robot.links[0].mass: must be > 0, got -1.0",
        "x.yaml:5: gait.tikc: unknown key; did you mean 'tick'? (allowed: kind, motor_torque, "
        "tick)",
        "x.yaml:7: steps[0].xatol: must be > 0, got 0",
    ]


def test_yaml12_numbers_and_words():
    """``1e-3`` is a number (YAML 1.2), ``no`` is not a boolean: the YAML 1.1 traps."""
    text = """\
schema_version: 1
name: y12
robot: seed2009
gait: {kind: horizontal, motor_torque: 6354e-4, tick: 1e-3}
integrator: {rtol: 1e-8, atol: 1E-10}
steps:
  - {name: no, kind: refine, start: [9e-1, 1.09e+1]}
"""
    st = parse_study(text).study
    assert st.gait.tick == 0.001 and st.gait.motor_torque == 0.6354
    assert st.integrator.rtol == 1e-8 and st.integrator.atol == 1e-10
    assert st.steps[0].name == "no"
    assert st.steps[0].start == [0.9, 10.9]


def test_models_are_frozen_and_defaults_documented():
    st = load_study(ROOT / "studies" / "horizontal.yaml").study
    with pytest.raises(Exception):
        st.name = "other"  # frozen
    refine = st.step("gait1")
    assert isinstance(refine, RefineStep)
    assert refine.xatol == refine.fatol == 1e-4          # fminsearch defaults
    assert st.integrator.method == "dop853"


def test_shipped_studies_are_valid():
    h = load_study(ROOT / "studies" / "horizontal.yaml").study
    grid = h.step("error_map")
    assert isinstance(grid, GridStep)
    assert (grid.dtheta1.num, grid.dtheta2.num) == (121, 201)
    assert (grid.dtheta1.start, grid.dtheta1.stop) == (0.0, 3.0)
    assert (grid.dtheta2.start, grid.dtheta2.stop) == (9.0, 14.0)
    assert h.step("gait1").start == [1.0, 12.0]
    assert h.step("gait2").start == [0.5, 11.75]
    for name, src in (("gait1_cycles", "gait1"), ("gait2_cycles", "gait2")):
        s = h.step(name)
        assert isinstance(s, StabilityStep) and s.from_ == src and s.cycles == 30
    smoke = load_study(ROOT / "studies" / "smoke.yaml").study
    kinds = {s.kind for s in smoke.steps}
    assert kinds == {"grid", "refine", "stability"}
    assert any(isinstance(s, RefineStep) and isinstance(s.start, BestOfGrid)
               for s in smoke.steps)


def test_missing_file_is_an_issue(tmp_path):
    with pytest.raises(StudyError, match="no such file"):
        load_study(tmp_path / "nope.yaml")


def test_shipped_json_schema_is_up_to_date():
    shipped = ROOT / "src" / "monkeystudy" / "schema" / "study.schema.json"
    assert json.loads(shipped.read_text()) == json_schema(), \
        "regenerate: monkeystudy schema > src/monkeystudy/schema/study.schema.json"


def test_json_schema_states_units_and_forbids_unknown_keys():
    s = json_schema()
    link = s["$defs"]["LinkParams"]
    assert link["additionalProperties"] is False
    assert "[kg]" in link["properties"]["mass"]["description"]
    assert "[rad s-1]" in s["$defs"]["Axis"]["properties"]["start"]["description"]
    assert s["properties"]["schema_version"]["const"] == 1


def test_a_problem_in_a_key_merged_from_an_anchor_names_the_step_that_merges_it():
    """A step written as ``{<<: *other, name: ...}`` takes its keys from the anchor: a problem
    in one of them is reported on the merging step's line (ruamel keeps no line for a merged
    key), not lost in a KeyError."""
    from monkeystudy.study.loader import parse_study

    text = (ROOT / "studies" / "open_loop_design_smoke.yaml").read_text()
    bad = text.replace("t_motor: {start: 0.14", "t_motor: {start: -0.14", 1)
    assert bad != text
    with pytest.raises(StudyError) as err:
        parse_study(bad, "bad.yaml")
    merged = [i for i in err.value.issues if i.key.startswith("steps[2]")]
    assert merged, str(err.value)
    line = next(n for n, row in enumerate(bad.splitlines(), 1) if "name: schedule_clock" in row)
    assert all(i.line == line for i in merged), str(err.value)


def test_steps_whose_figures_would_share_a_file_name_are_refused_whichever_comes_first():
    """A figure is named ``<step>_<figure>``: a grid step ``b_cycles`` (figure ``map``) and a
    basin step ``b`` (figure ``cycles_map``) would both write ``b_cycles_map``; the later
    step's name is the problem, located. Names that only share a beginning are fine."""
    head = """\
schema_version: 1
name: clash
robot: seed2009
gait: {kind: horizontal, motor_torque: 0.6354, tick: 0.0}
steps:
  - {name: s, kind: shoot, starts: [[1.44, 10.31]]}
"""
    grid = ("  - {name: b_cycles, kind: grid, dtheta1: {start: 1.3, stop: 1.6, num: 3},\n"
            "     dtheta2: {start: 10.0, stop: 10.5, num: 3}}\n")
    basin = ("  - {name: b, kind: basin, from: s, offsets: {d_dtheta1: {start: -1.0e-3, stop: "
             "1.0e-3, num: 3},\n     d_dtheta2: {start: -1.0e-3, stop: 1.0e-3, num: 3}}}\n")
    with pytest.raises(StudyError) as err:
        parse_study(head + grid + basin, "x.yaml")
    assert str(err.value) == (
        "x.yaml:9: steps[2].name: figure file b_cycles_map would be both the grid figure map "
        "of step 'b_cycles' and the basin figure cycles_map of step 'b' (a figure is named "
        "<step>_<figure>): rename one of the two steps")
    parse_study(head + grid.replace("b_cycles", "b_cycle") + basin, "x.yaml")


def test_problems_across_steps_are_reported_with_the_field_errors():
    """One pass reports every problem: a ``from:`` naming a later step, and one naming a step
    of the wrong kind, with the field errors of other keys; a step built on a step that is
    not valid is not judged against it (no "no earlier step" for a step that is there)."""
    text = """\
schema_version: 1
name: all_at_once
robot: seed2009
gait: {kind: horizontal, motor_torque: 0.6354, tick: 0.001}
steps:
  - {name: c, kind: stability, from: g, cycles: 3}
  - {name: g, kind: refine, start: [0.9, 10.9], xatol: 0}
  - {name: m, kind: grid, dtheta1: {start: 0.5, stop: 1.5, num: 0},
     dtheta2: {start: 10.0, stop: 12.0, num: 3}}
  - {name: r, kind: refine, start: {from: m, best: 2}}
  - {name: r2, kind: refine, start: {from: c, best: 2}}
  - {name: g, kind: refine, start: [1.0, 11.0]}
"""
    want = [
        "x.yaml:6: steps[0].from: no earlier step named 'g'",
        "x.yaml:7: steps[1].xatol: must be > 0, got 0",
        "x.yaml:8: steps[2].dtheta1.num: must be >= 1, got 0",
        "x.yaml:11: steps[4].start.from: 'c' is a stability step, expected a grid step",
        "x.yaml:12: steps[5].name: duplicate step name 'g'",
    ]
    with pytest.raises(StudyError) as info:
        parse_study(text, "x.yaml")
    assert str(info.value).splitlines() == want
    # with the gait not valid, the steps' names and from: are still checked
    with pytest.raises(StudyError) as info:
        parse_study(text.replace("tick: 0.001", "tikc: 0.001"), "x.yaml")
    assert str(info.value).splitlines() == [
        "x.yaml:4: gait.tikc: unknown key; did you mean 'tick'? (allowed: kind, motor_torque, "
        "tick)"] + want
