"""The joint motor's limits (``Robot.motor``): read from a URDF's motor joint, stated in a
study, kept in a dataset's robot attribute, and held against a study's gait and a design
search's torques."""
from __future__ import annotations

import math
from pathlib import Path

import pytest

from monkeystudy import Link, Motor, Robot
from monkeystudy.analysis.design import SEGMENT_TORQUE_BOUND, SegmentDesignSpace
from monkeystudy.analysis.measured_replay import acromonk_robot
from monkeystudy.study.loader import StudyError, parse_study
from monkeystudy.study.models import SequenceGaitSpec

ROOT = Path(__file__).resolve().parents[1]
LINKS = (Link(1.04, 0.315, 0.234, 0.0017), Link(0.63, 0.315, 0.124, 0.0041))


def test_a_urdf_robot_takes_its_motor_joints_limits():
    """acromonk.urdf's joint_1: <limit effort="16" velocity="43">."""
    assert acromonk_robot().motor == Motor(16.0, 43.0)
    assert Robot(*LINKS).motor == Motor(math.inf, math.inf)


@pytest.mark.parametrize("motor,message", [
    (Motor(0.0), "motor.torque_limit must be > 0"),
    (Motor(1.0, -2.0), "motor.speed_limit must be > 0"),
    (Motor(float("nan")), "motor.torque_limit must be > 0"),
])
def test_a_bad_motor_is_refused_by_name(motor, message):
    with pytest.raises(ValueError, match=message):
        Robot(*LINKS, motor=motor)


def test_the_motor_survives_a_datasets_robot_attribute_and_is_absent_when_unlimited():
    limited = Robot(*LINKS, motor=Motor(3.0))
    d = limited.to_dict()
    assert d["motor"] == {"torque_limit": 3.0, "speed_limit": None}    # JSON has no inf
    assert Robot.from_dict(d) == limited
    assert "motor" not in Robot(*LINKS).to_dict()
    assert Robot.from_dict(acromonk_robot().to_dict()) == acromonk_robot()


URDF_STUDY = f"""\
schema_version: 1
name: limited
robot:
  urdf: {ROOT / 'data/acromonk/model/acromonk.urdf'}
  links: [hook_1, link_2]
  joints: [virtul_joint_hook_1, joint_1]
  far_grip: hook_2
  motor: {{motor}}
gait: {{kind: horizontal, motor_torque: {{torque}}, tick: 0.001}}
steps:
  - {{name: gait1, kind: refine, start: [1.0, 11.0], maxiter: 2}}
"""


def urdf_study(motor: str, torque: float = 1.0) -> str:
    return URDF_STUDY.replace("{motor}", motor).replace("{torque}", repr(torque))


def test_a_study_states_the_motors_limits_over_the_urdfs():
    """A field left out keeps the URDF's."""
    study = parse_study(urdf_study("{torque_limit: 3.0}"), "limited.yaml").study
    assert study.to_robot().motor == Motor(3.0, 43.0)
    study = parse_study(urdf_study("{}"), "limited.yaml").study
    assert study.to_robot().motor == Motor(16.0, 43.0)


def test_a_gait_torque_above_the_motors_limit_is_a_located_error():
    with pytest.raises(StudyError) as err:
        parse_study(urdf_study("{torque_limit: 3.0}", torque=-3.5), "limited.yaml")
    text = str(err.value)
    assert "limited.yaml:9" in text and "gait.motor_torque" in text
    assert "3.5 N m is more than the robot's motor gives (its torque_limit 3.0 N m)" in text
    parse_study(urdf_study("{torque_limit: 3.0}", torque=-3.0), "limited.yaml")  # at the limit
    with pytest.raises(StudyError, match="robot.motor.torque_limit"):
        parse_study(urdf_study("{torque_limit: 0}"), "limited.yaml")


#: a two-swap brachiation of AcroMonk (the hook caught where the free end falls through
#: the holding end's height; motor frame [N m], s): a fixed point of its return map
#: (tests/analysis/test_design.py), unstable (rho 8.18)
BRACHIATION = {
    "kind": "sequence", "torque_frame": "motor",
    "section": {"theta1": 0.0, "direction": "either", "theta2": 0.15718415},
    "segments": [
        {"until": "free_end_y", "value": 0.0, "direction": "falling",
         "torque": -0.36501134, "clock": "reset"},
        {"until": "time", "value": 0.39134575, "magnets": "swap", "torque": 2.58882863},
        {"until": "coord", "coord": "theta1", "value": 0.0, "direction": "either"},
        {"until": "free_end_y", "value": 0.0, "direction": "falling",
         "torque": -2.81165613, "clock": "reset"},
        {"until": "time", "value": 0.08122807, "magnets": "swap", "torque": 1.63025727}]}


def test_a_segment_design_bounds_its_torques_by_the_robots_motor():
    """The motor's torque_limit bounds the design's torques; a motor that states none leaves
    the design search's own bound, 2 N m."""
    gait = SequenceGaitSpec.model_validate(BRACHIATION).gait()
    values = SegmentDesignSpace(gait, acromonk_robot(), motor_frame=True).values()
    for motor, bound in ((Motor(3.0), 3.0), (Motor(16.0, 43.0), 16.0),
                         (Motor(), SEGMENT_TORQUE_BOUND)):
        space = SegmentDesignSpace(gait, acromonk_robot().with_motor(motor), motor_frame=True)
        assert space.parameter("segment2_torque").upper == bound
    limited = SegmentDesignSpace(gait, acromonk_robot().with_motor(Motor(2.5)), motor_frame=True)
    assert "segment2_torque = 2.58882863 N m outside [-2.5, 2.5]" in limited.buildable(values)
    assert SegmentDesignSpace(gait, acromonk_robot().with_motor(Motor(3.0)),
                              motor_frame=True).buildable(values) == ""


#: BRACHIATION on a ladder: each catch a bar 0.34 m back (window 0.03 m) instead of the start's
#: world height, the torques re-found for it (AcroMonk, no pivot Coulomb friction, the rotor of
#: tests/analysis/test_design.acromonk_for_design)
BAR_BRACHIATION = {
    "kind": "sequence", "torque_frame": "motor",
    "section": {"theta1": 0.0, "direction": "either", "theta2": -0.0739151096},
    "segments": [
        {"until": "bar", "bar": {"dx": -0.34, "dy": 0.0, "window": 0.03}, "torque": 0.779877,
         "clock": "reset"},
        {"until": "time", "value": 0.115121, "magnets": "swap", "torque": -2.47776},
        {"until": "coord", "coord": "theta1", "value": 0.0, "direction": "either"},
        {"until": "bar", "bar": {"dx": -0.34, "dy": 0.0, "window": 0.03}, "torque": -1.607085,
         "clock": "reset"},
        {"until": "time", "value": 0.95018, "magnets": "swap", "torque": 0.797934}]}
#: its fixed point (theta2 [rad], dtheta1, dtheta2 [rad s-1]), found by the refine and floquet
#: steps (stable: section-map multipliers 0.4236, -0.2956, 1.4e-6)
Z_BAR_BRACHIATION = (-0.0739151096, -3.9857510475, -2.2169045367)
