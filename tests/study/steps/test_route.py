"""The route step: a route across the study's wall from an atlas, walked under noise with
replanning after every catch; walks in resumable blocks, the same for any number of workers."""
from __future__ import annotations

import json
import shutil

import numpy as np
import pytest

from monkeystudy.study import load_study, parse_study, plan_study, run_study
from monkeystudy.study.blocks import shard_dir
from monkeystudy.study.loader import StudyError

from steps.routestudy import DX_LEVEL, ROUTE_STUDY
from studyhelpers import (assert_same_datasets, assert_written_as_declared, open_dataset,
                          write_study)


def test_the_route_plans_four_level_steps_and_most_walks_arrive(route_study):
    ds = open_dataset(route_study[1], "route.nc")
    assert list(ds["plan_gait"].values) == ["level"] * 4
    # lattice points: the n-th within n * resolution / 2 of n exact steps
    err = np.abs(ds["plan_catch_x"].values - DX_LEVEL * np.arange(1, 5))
    assert (err <= 0.0005 * np.arange(1, 5) + 1e-12).all()
    a = ds.attrs
    assert int(a["walks"]) == 60 and int(a["planned_steps"]) == 4
    arrived = ds["arrived"].values.astype(bool)
    assert int(a["arrived_runs"]) == arrived.sum() and arrived.sum() >= 50
    failure = ds["failure"].values.astype(str)
    assert (failure[arrived] == "").all() and (failure[~arrived] != "").all()
    # an arrived walk took the planned four steps and its last catch lies in the goal
    steps = ds["steps_walked"].values[arrived]
    assert (steps == 4).all()
    last_x = ds["catch_x"].values[arrived, 3]
    assert (np.abs(last_x - 4 * DX_LEVEL) <= 0.05).all()
    assert np.isnan(ds["catch_x"].values[arrived, 4:]).all()
    # the walls's steel and goal travel with the dataset
    assert json.loads(a["wall"])["goal"]["radius"] == 0.05
    # exact sensing: the estimate is the truth
    np.testing.assert_array_equal(ds["sensed_x"].values, ds["catch_x"].values)
    t = ds["walk_time"].values[arrived]
    assert (np.abs(t - 4 * 0.8851244906318175) < 0.05).all()


def test_walks_are_the_same_for_any_number_of_workers_and_after_a_resume(route_study,
                                                                         tmp_path):
    study, ref = route_study
    out = tmp_path / "out"
    shutil.copytree(ref, out)
    (out / "route.nc").unlink()
    loaded = load_study(study)
    sp = next(s for s in plan_study(loaded, out).steps if s.name == "route")
    assert len(sp.blocks) == 2
    summary = run_study(loaded, out, workers=1)
    assert [p.name for p in summary.written] == ["route.nc"]
    assert_same_datasets(ref, out, ["route.nc"])
    assert not list(out.glob(".route.parts")) and not shard_dir(out, "route", sp.key).exists()


def test_route_datasets_are_written_as_declared(route_study):
    assert_written_as_declared(route_study[1] / "route.nc", "route")


def test_a_route_step_needs_the_studys_wall():
    text = ROUTE_STUDY[:ROUTE_STUDY.index("wall:")]
    with pytest.raises(StudyError, match="a route step walks the study's wall"):
        parse_study(text)


def test_a_route_step_plans_from_an_atlas_step():
    text = ROUTE_STUDY.replace("    from: atlas\n", "    from: nowhere\n")
    with pytest.raises(StudyError, match="no earlier step named 'nowhere'"):
        parse_study(text)


def test_an_unknown_sensor_is_refused_at_its_key(tmp_path):
    text = ROUTE_STUDY.replace("    risk_weight: 10.0\n",
                               "    risk_weight: 10.0\n    sensor: {kind: sonar}\n")
    with pytest.raises(StudyError, match="sensor"):
        load_study(write_study(tmp_path, text, "s.yaml"))


def test_a_new_wall_walks_again_and_the_atlas_stays(route_study, tmp_path):
    """The route's datasets depend on the study's wall: against the first run's folder, the
    study with its goal moved plans the route again and keeps the atlas (which reads no
    wall)."""
    study, ref = route_study
    out = tmp_path / "out"
    shutil.copytree(ref, out)
    text = study.read_text()
    assert text.count("radius: 0.05}") == 1
    moved = study.with_name("route_moved.yaml")
    moved.write_text(text.replace("radius: 0.05}", "radius: 0.2}"))
    assert {s.name: s.up_to_date for s in plan_study(load_study(study), out).steps} == \
        {"atlas": True, "route": True}
    assert {s.name: s.up_to_date for s in plan_study(load_study(moved), out).steps} == \
        {"atlas": True, "route": False}
