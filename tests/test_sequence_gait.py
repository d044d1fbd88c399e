"""Sequence gaits (controllers.SequenceGait, simulate.evaluate_cycle_gaits): the study's gait
written as a sequence, the guard values that make climbing gaits, the static frame walk."""
import math

import numpy as np
import pytest

from monkeystudy import Robot, Segment, SequenceGait, evaluate_cycle_gaits, evaluate_gaits
from monkeystudy.analysis import cycle_return_map, search_return_map
from monkeystudy.controllers import Integrator
from monkeystudy.kernel import layout as L
from monkeystudy.simulate import energies

TIGHT = Integrator(rtol=1e-12, atol=1e-13)
HORIZONTAL = SequenceGait([
    Segment("free_end_height", direction="rising", latch_energy=True,
            fail_status=L.ST_NO_SWITCH),
    Segment("energy_restored", direction="rising", magnets="swap", torque=0.6354,
            fail_status=L.ST_ENERGY_NOT_RESTORED),
])
POINTS = np.array([[0.902, 10.935], [1.0, 11.0], [0.5, 12.5], [2.0, 9.5], [0.1, 9.0]])


def test_horizontal_gait_as_a_sequence_is_the_horizontal_gait():
    a = evaluate_cycle_gaits(POINTS, HORIZONTAL)
    b = evaluate_gaits(POINTS, skip_unreachable=False)
    np.testing.assert_array_equal(a["status"], b["status"])
    ok = b["status"] == L.ST_OK
    assert ok.sum() >= 2 and (~ok).sum() >= 1
    np.testing.assert_allclose(a["error"][ok], b["error"][ok], rtol=1e-12, atol=0)
    assert np.all(np.isnan(a["error"][~ok]))
    # the same steps: the swap, the motor stop and the end are the same events
    np.testing.assert_array_equal(a["t_segment"][ok, 0], b["t_switch"][ok])
    np.testing.assert_array_equal(a["t_segment"][ok, 2], b["t_end"][ok])
    np.testing.assert_array_equal(a["t_end"][ok], b["t_end"][ok])
    np.testing.assert_array_equal(a["nfev"], b["nfev"])
    assert np.all(a["flipped"][ok] == 1)


def test_sequence_return_map_is_the_search_controllers():
    z = np.array([0.02475681, -1.08686037, 16.0167845])
    zs, ss = search_return_map(z, integrator=TIGHT)
    zq, sq = cycle_return_map(z, HORIZONTAL, integrator=TIGHT)
    assert ss == sq == 0
    np.testing.assert_allclose(zq, zs, rtol=0, atol=1e-12)


def test_climbing_guards_catch_at_the_height_and_add_the_climb_energy():
    dh = 0.05
    robot = Robot.preset("seed2009")
    m = robot.link1.mass + robot.link2.mass
    climb = SequenceGait([
        Segment("free_end_height", value=dh, direction="rising", latch_energy=True),
        Segment("energy_restored", value=m * robot.gravity * dh, magnets="swap",
                torque=0.6354),
    ], theta2=1.0)
    z = np.array([1.0, 4.46689255, 0.07213651])
    r = evaluate_cycle_gaits([[z[1], z[2]]], climb, integrator=TIGHT)
    assert r["status"][0] == L.ST_OK
    # the new magnet is dh above the old one: the free end was caught exactly there
    assert abs(r["y_advance"][0] - dh) < 1e-12
    # energy at the section: the start's plus the climb's potential energy (world frame)
    par = robot.params()
    s0 = np.array([0.0, 0.0, 0.0, z[0], 0.0, 0.0, z[1], z[2]])
    k0, v0 = energies(par, s0[None], np.array([0]))
    s1 = r["final_state"][0]
    k1, v1 = energies(par, s1[None], np.array([r["flipped"][0]]))
    assert abs((k1 + v1)[0] - (k0 + v0)[0] - m * robot.gravity * dh) < 1e-9


def test_section_error_wraps_theta2_by_whole_turns():
    base = evaluate_cycle_gaits(POINTS[:2], HORIZONTAL, integrator=TIGHT)
    turned = evaluate_cycle_gaits(POINTS[:2], SequenceGait(HORIZONTAL.segments,
                                                           theta2=2 * math.pi),
                                  integrator=TIGHT)
    # theta2 = 2 pi is the same configuration; the section error does not see the turn (the
    # runs differ only by the integrator's error: |theta2| enters the tolerance scale)
    assert abs(turned["final_state"][0, L.TH2] - base["final_state"][0, L.TH2]) > 6.0
    np.testing.assert_allclose(turned["error"], base["error"], rtol=1e-7)


def test_static_frame_walk():
    assert HORIZONTAL.end_attached() == "B"
    two = SequenceGait([*HORIZONTAL.segments, Segment("free_end_height", magnets="keep"),
                        Segment("energy_restored", magnets="swap", torque=0.6)])
    assert two.end_attached() == "A"
    flight = SequenceGait([Segment("coord", value=0.6), Segment("free_end_y", magnets="none"),
                           Segment("energy_restored", magnets="B", torque=0.6)])
    assert flight.end_attached() == "B"
    assert [sorted(e) for e in flight.attached_ends()] == [["A"], [], ["B"], ["B"]]
    with pytest.raises(ValueError, match="no magnet on"):
        SequenceGait([Segment("coord", value=0.6), Segment("free_end_y", magnets="none")])
    with pytest.raises(ValueError, match="both magnets"):
        SequenceGait([Segment("time", value=0.1, magnets="both")])
    with pytest.raises(ValueError, match="at least one segment"):
        SequenceGait([])


def test_non_mirror_robot_cycle_ending_on_b_is_refused():
    from monkeystudy import Link

    lop = Robot(Link(1.0, 0.61, 0.5, 0.018), Link(1.0, 0.61, 0.2, 0.018))
    with pytest.raises(ValueError, match="mirror-image links"):
        cycle_return_map([0.0, 1.0, 11.0], HORIZONTAL, robot=lop)
