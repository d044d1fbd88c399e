"""The study page's set-up (:mod:`monkeystudy.plotting.page`): the gait and integrator only
when a step of the study ran them, what a step that runs no gait ran instead, and the robot's
joint motor's rotor. The datasets are their global attributes alone (the page reads nothing
else of them for its set-up)."""
from __future__ import annotations

import json
from dataclasses import replace

import pytest
import xarray as xr

from monkeystudy.plotting.page import render_page
from monkeystudy.plotting.report import DRAWINGS
from monkeystudy.robot import Robot, Rotor

GAIT = {"kind": "horizontal", "motor_torque": 0.6354, "tick": 0.001}
INTEGRATOR = {"method": "dop853", "rtol": 1e-10, "atol": 1e-12, "max_time": 3.0,
              "controller": "scipy"}
REPLAY_ONLY = """\
schema_version: 1
name: s
steps:
  - {name: replay, kind: hardware_replay, train: [a.csv.gz], held_out: [b.csv.gz]}
"""
MIXED = """\
schema_version: 1
name: s
gait: {kind: horizontal, motor_torque: 0.6354, tick: 0.001}
steps:
  - {name: map, kind: grid, dtheta1: {start: 0.5, stop: 1.5, num: 3},
     dtheta2: {start: 10.0, stop: 12.0, num: 3}}
  - {name: replay, kind: hardware_replay, train: [a.csv.gz], held_out: [b.csv.gz]}
"""
#: hardware_replay's attr replay_integrator (docs/datasets.md: <method> rtol <rtol> atol <atol>)
REPLAY_INTEGRATOR = "dop853 rtol 1e-08 atol 1e-10"


def dataset(kind: str, name: str, study_text: str, *, gait: dict | None = GAIT,
            robot: Robot | None = None, **extra) -> xr.Dataset:
    attrs = {"study_name": "s", "step_name": name, "step_kind": kind,
             "study_text": study_text, "history": "2026-01-01T00:00:00Z monkeystudy run",
             "robot": json.dumps((robot or Robot.preset("seed2009")).to_dict()),
             "integrator": json.dumps(INTEGRATOR), **extra}
    if gait is not None:
        attrs["gait"] = json.dumps(gait)
    return xr.Dataset(attrs=attrs)


def page(datasets: dict) -> str:
    return render_page("s", datasets, {}, drawings=DRAWINGS)


@pytest.mark.parametrize("gait", [GAIT, None], ids=["stated", "none"])
def test_a_study_whose_steps_run_no_gait_says_what_they_ran_instead(gait):
    # a dataset of a study that still named a gait its step never ran, and one of a study
    # without: neither page states a gait or an integrator the step did not run
    html = page({"replay": dataset("hardware_replay", "replay", REPLAY_ONLY, gait=gait,
                                   replay_integrator=REPLAY_INTEGRATOR)})
    assert "Gait:" not in html and "Integrator:" not in html
    assert "No step of this study runs the study&#x27;s gait" in html
    assert ("measured elbow torque through the robot with each model&#x27;s friction "
            "(identified, published damping, none), integrated with DOP853, rtol 1e-08, "
            "atol 1e-10.") in html


def test_a_study_with_a_gait_step_states_its_gait_and_which_steps_do_not_run_it():
    html = page({"map": dataset("grid", "map", MIXED),
                 "replay": dataset("hardware_replay", "replay", MIXED,
                                   replay_integrator=REPLAY_INTEGRATOR)})
    assert ("Gait: horizontal, motor torque 0.6354 N m, controller tick 1 ms. Integrator: "
            "DOP853, rtol 1e-10, atol 1e-12") in html
    assert ('These steps do not run the gait above: '
            '<a href="#step-replay">replay</a> [hardware_replay] replays') in html
    # a study whose every step runs the gait: the gait sentence alone
    grid_only = MIXED.split("  - {name: replay")[0]
    html = page({"map": dataset("grid", "map", grid_only)})
    assert "Gait: horizontal" in html
    assert "do not run" not in html and "No step of this study" not in html


@pytest.mark.parametrize("housing, link", [(1, "link 1 (end A)"), (2, "link 2 (end B)")])
def test_the_robot_table_shows_the_joint_motors_rotor(housing, link):
    rotor = Rotor(inertia=3.2e-5, gear_ratio=6.0, housing=housing)
    robot = replace(Robot.preset("seed2009"), rotor=rotor)
    html = page({"map": dataset("grid", "map", MIXED.split("  - {name: replay")[0],
                                robot=robot)})
    assert (f"joint motor&#x27;s rotor: inertia 3.2e-05 kg m² about its axis, gear ratio 6 "
            f"(rotor turns per turn of the joint), reflected to the joint N² I<sub>r</sub> = "
            f"{rotor.reflected_inertia:.10g} kg m²; its housing on {link}") in html
    assert f"{rotor.reflected_inertia:.10g}" == "0.001152"


def test_a_robot_without_a_rotor_shows_none():
    html = page({"map": dataset("grid", "map", MIXED.split("  - {name: replay")[0])})
    assert "rotor" not in html


def test_a_rotor_without_inertia_is_said_as_its_geometry_alone():
    # a study that identifies the rotor's inertia states only its gear and housing
    robot = replace(Robot.preset("seed2009"), rotor=Rotor(gear_ratio=6.0, housing=1))
    html = page({"map": dataset("grid", "map", MIXED.split("  - {name: replay")[0],
                                robot=robot)})
    assert ("joint motor&#x27;s rotor: gear ratio 6 (rotor turns per turn of the joint), its "
            "housing on link 1 (end A); its inertia not given (0 kg m²)") in html
    assert "reflected" not in html
