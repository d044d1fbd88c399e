"""A study's ``robot:`` naming a URDF file (study/models.py UrdfRobotParams): the reduced robot,
its path relative to the study file, and file:line: key errors before any work."""
from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from monkeystudy import Friction, Robot
from monkeystudy.study.loader import StudyError, load_study, parse_study

URDF = Path(__file__).resolve().parents[2] / "data" / "acromonk" / "model" / "acromonk.urdf"
NAMES = dict(links=("hook_1", "link_2"), joints=("virtul_joint_hook_1", "joint_1"),
             far_grip="hook_2")

STUDY = """\
schema_version: 1
name: acromonk_urdf
robot:
  urdf: {urdf}
  links: [{link1}, link_2]
  joints: [virtul_joint_hook_1, {motor}]
  far_grip: {far_grip}
  friction: {{pivot: {{viscous: 0.044}}, joint: {{viscous: 0.06}}}}
gait: {{kind: horizontal, motor_torque: 0.6354, tick: 0.001}}
steps:
  - {{name: gait1, kind: refine, start: [1.0, 11.0], maxiter: 2}}
"""


def write_study(tmp_path, urdf="model/acromonk.urdf", link1="hook_1", motor="joint_1",
                far_grip="hook_2"):
    """A study in ``tmp_path/studies`` naming a copy of the AcroMonk URDF in
    ``tmp_path/studies/model``."""
    folder = tmp_path / "studies"
    (folder / "model").mkdir(parents=True, exist_ok=True)
    shutil.copy(URDF, folder / "model" / "acromonk.urdf")
    path = folder / "acromonk.yaml"
    path.write_text(STUDY.format(urdf=urdf, link1=link1, motor=motor, far_grip=far_grip))
    return path


def test_a_study_robot_from_its_urdf_relative_to_the_study_file(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)        # not the study's folder: the path is the study's
    loaded = load_study(write_study(tmp_path))
    want = Robot.from_urdf(URDF, **NAMES, pivot_friction=Friction(0.044),
                           joint_friction=Friction(0.06))
    assert loaded.study.to_robot() == want
    assert want.link1.com_across != 0.0 and want.name == "acromonk"


def issues(path) -> list[str]:
    with pytest.raises(StudyError) as err:
        load_study(path)
    return str(err.value).splitlines()


def test_a_missing_urdf_file_is_a_located_error(tmp_path):
    path = write_study(tmp_path, urdf="model/none.urdf")
    assert issues(path) == [f"{path}:4: robot.urdf: no such URDF file: "
                            f"{path.parent / 'model' / 'none.urdf'}"]


def test_wrong_names_are_located_errors(tmp_path):
    path = write_study(tmp_path, link1="hook_x", motor="elbow", far_grip="hook_3")
    got = issues(path)
    assert [line.split(": ")[0:2] for line in got] == [
        [f"{path}:5", "robot.links[0]"], [f"{path}:6", "robot.joints[1]"],
        [f"{path}:7", "robot.far_grip"]]
    assert "no link 'hook_x' in the URDF (links: Base, " in got[0]
    assert "no joint 'elbow' in the URDF (joints: base_weld, " in got[1]
    assert "no link 'hook_3' in the URDF" in got[2]


def test_a_chain_that_is_not_grip_link_motor_link_is_a_located_error(tmp_path):
    path = write_study(tmp_path, link1="link_2")   # links [link_2, link_2]
    got = issues(path)
    assert len(got) == 1 and got[0].startswith(f"{path}:3: robot: the grip joint "
                                               "'virtul_joint_hook_1' moves 'hook_1', not "
                                               "link 1 'link_2'")


def test_a_study_without_a_file_reads_the_urdf_from_the_working_directory(tmp_path,
                                                                          monkeypatch):
    path = write_study(tmp_path)
    monkeypatch.chdir(path.parent)
    study = parse_study(path.read_text()).study
    assert study.to_robot().name == "acromonk"
