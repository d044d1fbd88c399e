"""tools/rise_family.py: the one-swing family's search by continuation in the rise, its
gait blocks, and the bisection of the steepest climb."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import yaml

from monkeystudy.analysis import cycle_full_map
from monkeystudy.analysis.multipliers import jacobian_fd, solve_fixed_point
from monkeystudy.analysis.sections import cycle_return_map
from monkeystudy.study import parse_study
from monkeystudy.study.models import SequenceGaitSpec

from toolmodules import load_tool

ROOT = Path(__file__).resolve().parents[2]


rf = load_tool("rise_family")


def study_gait(path: Path):
    """A design study's gait, its fixed point (Newton from its refine step's start) and its
    full map's spectral radius (finite differences, as the atlas step measures it)."""
    study = parse_study(path.read_text()).study
    gait = study.gait.gait()
    robot, integ = study.to_robot(), rf.INTEGRATOR
    start = np.array([study.gait.section.theta2, *study.steps[0].start])
    fixed = solve_fixed_point(lambda z: cycle_return_map(z, gait, robot=robot,
                                                         integrator=integ), start)
    z = np.asarray(fixed.z, float)
    J = jacobian_fd(lambda v: cycle_full_map(v, gait, robot=robot, integrator=integ),
                    np.concatenate([[0.0], z]), 1e-5)
    return study, z, float(np.max(np.abs(np.linalg.eigvals(J))))


@pytest.fixture(scope="module")
def level():
    """The search at rise 0 on a 2 x 2 x 2 grid with robust_design's torques and pulse as one
    of its cells, its 2 least-rho stable gaits screened by 20 runs of 50 steps."""
    t1, t2, d = rf.LEVEL_GAIT
    grid = rf.Grid((0.2118, t1), (t2, -0.2118), (d, 0.4))
    return grid, rf.search([0.0], grid, rf.Screen(candidates=2, runs=20, steps=50))


@pytest.fixture(scope="module")
def descent():
    """The search on a 4 x 4 x 2 grid, continued from the level gait down to a rise of
    -0.1 m in steps of 0.01 m, its 2 least-rho stable gaits screened by 20 runs of 50 steps."""
    grid = rf.Grid((-0.2118, 0.0, 0.2118, 0.4236), (-0.4236, -0.2118, 0.0, 0.2118), (0.2, 0.3))
    return grid, rf.search([-0.1], grid, rf.Screen(candidates=2, runs=20, steps=50),
                           rise_step=0.01)


def test_the_search_at_rise_0_finds_robust_designs_gait(level):
    """The grid's cell of robust_design's torques and pulse holds the study's gait: its
    fixed point and full-map rho, solved here from the study file by the return map, to
    1e-6; it is stable, and the rise's line counts it."""
    grid, found = level
    study, z, rho = study_gait(ROOT / "studies" / "robust_design.yaml")
    segs = study.gait.segments
    cell = (segs[1].torque, segs[2].torque, segs[2].value)
    assert grid.cell(grid.index(cell)) == cell
    g = found.grids[0.0][grid.index(cell)][0]
    assert g.stable and g.cell == cell
    np.testing.assert_allclose(g.z, z, rtol=0, atol=1e-6)
    assert g.rho == pytest.approx(rho, abs=1e-6)
    (res,) = found.rises
    assert res.rise == 0.0 and res.stable >= 1 and res.chosen is not None
    assert res.chosen.gait.stable and 0 <= res.chosen.lasted <= res.chosen.runs == 20


def test_the_continued_search_keeps_one_swing_steps_of_the_rise(descent):
    """At -0.1 m every stable gait is a one-swing step, each cell's gaits are distinct
    (theta2 within a turn), and the chosen gait is one of the screened candidates."""
    grid, found = descent
    solved = found.grids[-0.1]
    assert solved
    for gs in solved.values():
        assert all(abs(g.z[0]) <= np.pi for g in gs)
        assert all(rf.distinct(g.z, [h for h in gs if h is not g], rf.SAME_GAIT) for g in gs)
        assert [rf.order_key(g) for g in gs] == sorted(rf.order_key(g) for g in gs)
    (res,) = found.rises
    assert res.chosen.gait in rf.candidates(solved, 2)
    assert res.stable == sum(gs[0].stable for gs in solved.values())


def test_the_level_gait_is_robust_designs():
    """The continuation's origin is robust_design's gait, solved from its refine's start."""
    study, z, rho = study_gait(ROOT / "studies" / "robust_design.yaml")
    segs = study.gait.segments
    assert rf.LEVEL_GAIT == (segs[1].torque, segs[2].torque, segs[2].value)
    g = rf.level_gait(rf.family_space(0.0))
    np.testing.assert_allclose(g.z, z, rtol=0, atol=1e-6)
    assert g.rho == pytest.approx(rho, abs=1e-6)


def test_the_written_gait_block_is_the_gait_the_search_solved(descent):
    """The YAML the script writes is an atlas step's gaits list; each gait's fixed point from
    its start, by the atlas's own return map, is the search's."""
    grid, found = descent
    g = found.rises[0].chosen.gait
    entry = rf.atlas_entry(-0.1, g)
    assert entry["name"] == "rise_-0.10"
    (read,) = yaml.safe_load("gaits:\n" + rf.entries_yaml([entry]))["gaits"]
    assert read == entry
    gait = SequenceGaitSpec(**read["gait"]).gait()
    study = parse_study((ROOT / "studies" / "descending_design.yaml").read_text()).study
    fixed = solve_fixed_point(lambda z: cycle_return_map(z, gait, robot=study.to_robot(),
                                                         integrator=rf.INTEGRATOR),
                              np.asarray(read["start"]))
    np.testing.assert_allclose(fixed.z, g.z, rtol=0, atol=1e-9)


def test_the_steepest_rise_is_bisected_to_the_resolution():
    """From 0.02 m up in 0.01 m steps to the first rise that fails, then bisected to
    0.005 m; each trial continues from the steepest rise below it that held."""
    calls = []

    def holds(r, state):
        calls.append((r, state))
        return r if r <= 0.0437 else None

    assert rf.steepest(holds, 0.02, 0.02, 0.01, 0.005) == (0.04, 0.045)
    assert calls == [(0.03, 0.02), (0.04, 0.03), (0.05, 0.04), (0.045, 0.04)]


def test_the_continuation_visits_every_listed_rise_in_small_steps():
    up, down = rf.rise_path([-0.25, 0.0, 0.02, 0.05], 0.01)
    assert up == [0.01, 0.02, 0.03, 0.04, 0.05]
    assert down[0] == -0.01 and down[-1] == -0.25 and len(down) == 25
    assert np.all(np.abs(np.diff([0.0, *down])) <= 0.01 + 1e-12)
