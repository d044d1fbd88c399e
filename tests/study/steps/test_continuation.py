"""The continuation step: a family of gaits followed in a robot parameter.

The end-to-end cases read the analysis smoke study's datasets (``analysis_smoke``,
tests/study/steps/conftest.py)."""
from __future__ import annotations

import json

import numpy as np

from studyhelpers import assert_written_as_declared, open_dataset


def test_continuation_follows_the_family(analysis_smoke):
    ds = open_dataset(analysis_smoke[0], "family.nc")
    sh = open_dataset(analysis_smoke[0], "shoot.nc")
    g = int(sh.attrs["best_solution"])
    assert ds.sizes["point"] == 4 and ds.attrs["parameter"] == "com"
    assert ds["parameter_value"].values[0] == 0.543754     # seed2009's link 1 CG
    assert ds["dtheta1"].values[0] == sh["dtheta1"].values[g]
    assert np.all(ds["residual"].values < 1e-12)
    assert np.all(np.diff(ds["parameter_value"].values) > 0)
    assert json.loads(ds.attrs["folds"]) == [] and json.loads(ds.attrs["period_doublings"]) == []


def test_continuation_datasets_are_written_as_declared(analysis_smoke):
    assert_written_as_declared(analysis_smoke[0] / "family.nc", "continuation")


#: studies/two_step.yaml on a small grid, continued in pivot friction
TWO_STEP_FRICTION = """\
schema_version: 1
name: two_step_friction
robot: seed2009
gait:
  kind: sequence
  section: {theta1: 0.0, direction: either, theta2: 0.0}
  segments:
    - {until: free_end_height, value: 0.0, direction: rising, latch_energy: true}
    - {until: energy_restored, value: 0.0, magnets: swap, torque: 0.6354}
    - {until: coord, coord: theta1, value: 0.0, direction: either}
    - {until: free_end_height, value: 0.0, direction: rising, latch_energy: true}
    - {until: energy_restored, value: 0.0, magnets: swap, torque: 0.6354}
integrator: {method: dop853, rtol: 1.0e-12, atol: 1.0e-13, max_time: 3.0}
steps:
  - {name: map, kind: grid,
     dtheta1: {start: 0.70, stop: 0.78, num: 5}, dtheta2: {start: 11.1, stop: 11.2, num: 5}}
  - {name: best, kind: refine, start: {from: map, best: 1}, xatol: 1.0e-10, fatol: 1.0e-20,
     maxfev: 600}
  - {name: floquet, kind: floquet, from: best}
  - {name: friction, kind: continuation, from: floquet, parameter: pivot_viscous, ds: 0.01,
     steps: 5}
"""


def test_a_latched_energy_has_no_friction_branch_and_the_dataset_says_why(tmp_path):
    from monkeystudy.study import load_study, run_study
    from monkeystudy.study.steps import REGISTRY

    from studyhelpers import write_study

    study = load_study(write_study(tmp_path, TWO_STEP_FRICTION, "two_step.yaml"))
    run_study(study, tmp_path / "out", workers=1)
    ds = open_dataset(tmp_path / "out", "friction.nc")
    assert ds.attrs["stop_reason"] == "no_branch"
    assert ds.sizes["point"] == 1 and ds["parameter_value"].values.tolist() == [0.0]
    detail = ds.attrs["stop_detail"]
    assert "pivot_viscous moves the return map off the start's family" in detail
    assert "section's energy by -" in detail
    assert any(detail in line for line in REGISTRY["continuation"].describe(ds))
    assert_written_as_declared(tmp_path / "out" / "friction.nc", "continuation")
