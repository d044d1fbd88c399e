"""The joint motor's rotor (``Robot.rotor``, docs/model.md section 2, "The motor's rotor"):
its block in the mass matrix as a builder computes it by hand, its validation, its round trip
through a dataset's robot attribute, and a study's ``robot.rotor``."""
from __future__ import annotations

import numpy as np
import pytest

from monkeystudy import Link, Robot, Rotor
from monkeystudy.kernel.dynamics import swing_matrices
from monkeystudy.study.loader import StudyError, parse_study

LINKS = (Link(1.04, 0.315, 0.234, 0.0017, -0.0058), Link(0.63, 0.315, 0.124, 0.0041, 0.0088))


def test_the_rotor_adds_its_block_to_the_swing_mass_matrix_in_both_frames():
    """A rotor of inertia J geared N:1 with its housing on link 1 turns at w1 + N w2: it adds
    J [[1, N], [N, N^2]] hanging from end A, and J [[1, 1-N], [1-N, (1-N)^2]] from end B,
    where its housing's link is link 2."""
    bare = Robot(*LINKS)
    geared = Robot(*LINKS, rotor=Rotor(inertia=2.8e-4, gear_ratio=6.0, housing=1))
    th1, th2, w1, w2 = 0.4, -1.1, 2.0, -3.0
    for row, k in ((0, 6.0), (1, -5.0)):
        m0, b0 = swing_matrices(bare.params()[row], th1, th2, w1, w2)
        m1, b1 = swing_matrices(geared.params()[row], th1, th2, w1, w2)
        np.testing.assert_allclose(m1 - m0, 2.8e-4 * np.array([[1.0, k], [k, k * k]]),
                                   rtol=1e-12, atol=1e-15)
        np.testing.assert_array_equal(b1, b0)      # no Coriolis, no gravity of its own
    assert geared.rotor.reflected_inertia == pytest.approx(36 * 2.8e-4)


def test_a_robot_without_a_rotor_has_the_bits_it_had():
    """Zero inertia: every parameter the kernel reads is the rotorless robot's."""
    bare = Robot(*LINKS)
    none = Robot(*LINKS, rotor=Rotor(inertia=0.0, gear_ratio=6.0, housing=2))
    assert np.array_equal(bare.params()[:, :24], none.params()[:, :24])
    for row in (0, 1):
        for th in ((0.3, 1.2, 4.0, -7.0), (2.9, -0.4, -1.0, 9.0)):
            m0, b0 = swing_matrices(bare.params()[row], *th)
            m1, b1 = swing_matrices(none.params()[row], *th)
            assert np.array_equal(m0, m1) and np.array_equal(b0, b1)


@pytest.mark.parametrize("rotor,message", [
    (Rotor(inertia=-1e-5), "rotor.inertia must be >= 0"),
    (Rotor(inertia=1e-5, housing=3), "rotor.housing must be 1 or 2"),
    (Rotor(inertia=1e-5, gear_ratio=float("nan")), "rotor.gear_ratio must be finite"),
])
def test_a_bad_rotor_is_refused_by_name(rotor, message):
    with pytest.raises(ValueError, match=message):
        Robot(*LINKS, rotor=rotor)


def test_the_rotor_survives_a_datasets_robot_attribute_and_is_absent_when_none():
    geared = Robot(*LINKS, rotor=Rotor(inertia=2.8e-4, gear_ratio=6.0, housing=1))
    assert Robot.from_dict(geared.to_dict()) == geared
    assert "rotor" not in Robot(*LINKS).to_dict()
    # a geometry without inertia is still said (a study that identifies the inertia needs it)
    d = Robot(*LINKS, rotor=Rotor(gear_ratio=6.0)).to_dict()
    assert d["rotor"] == {"inertia": 0.0, "gear_ratio": 6.0, "housing": 1}


STUDY = """\
schema_version: 1
name: geared
robot:
  links:
    - {mass: 1.04, length: 0.315, com: 0.234, inertia: 0.0017}
    - {mass: 0.63, length: 0.315, com: 0.124, inertia: 0.0041}
  rotor: {rotor}
gait: {kind: horizontal, motor_torque: 0.6354, tick: 0.001}
steps:
  - {name: gait1, kind: refine, start: [1.0, 11.0], maxiter: 2}
"""


def test_a_study_robot_with_a_rotor():
    study = parse_study(STUDY.replace("{rotor}", "{inertia: 6.3e-5, gear_ratio: 6, housing: 2}"),
                        "geared.yaml")
    assert study.study.to_robot().rotor == Rotor(6.3e-5, 6.0, 2)


def test_a_bad_rotor_in_a_study_is_a_located_error():
    with pytest.raises(StudyError) as err:
        parse_study(STUDY.replace("{rotor}", "{inertia: 6.3e-5, housing: 3}"), "geared.yaml")
    assert "geared.yaml:7" in str(err.value) and "robot.rotor.housing" in str(err.value)
