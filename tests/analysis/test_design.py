"""A design's pulses as a motor gives them (monkeystudy.analysis.design.motor_frame_pulses).

The kernel applies a pulse on theta2 of the frame of the end attached at the time; theta2
changes sign at the swap, so the part of a pulse after the swap is the opposite physical
torque. The physical check of that convention (the joint torque measured from the energy a
trajectory gains) is in tests/test_motor_frame.py; here the split itself.
"""
import pytest

from monkeystudy.analysis.design import motor_frame_pulses

#: the as_built best design of studies/open_loop_design.yaml (kernel frame)
AS_BUILT = {"t_switch": 0.39327945256326247, "motor_start": -0.27476725865938123,
            "t_motor": 0.32434053532539747, "torque": -0.6299122695486689}


def test_a_pulse_across_the_swap_is_two_pulses_of_opposite_sign():
    (a0, a1, ta), (b0, b1, tb) = motor_frame_pulses(AS_BUILT)
    ts = AS_BUILT["t_switch"]
    assert (a0, a1, ta) == (ts + AS_BUILT["motor_start"], ts, AS_BUILT["torque"])
    assert (b0, tb) == (ts, -AS_BUILT["torque"])
    assert b1 == pytest.approx(ts + AS_BUILT["motor_start"] + AS_BUILT["t_motor"], abs=1e-15)
    assert a1 - a0 == pytest.approx(0.27476725865938123, abs=1e-15)
    assert b1 - b0 == pytest.approx(0.04957327666601624, abs=1e-15)


def test_a_pulse_before_the_swap_keeps_its_sign_and_one_after_it_is_negated():
    before = dict(AS_BUILT, motor_start=-0.3, t_motor=0.2)
    assert motor_frame_pulses(before) == [(AS_BUILT["t_switch"] - 0.3,
                                           AS_BUILT["t_switch"] - 0.3 + 0.2,
                                           AS_BUILT["torque"])]
    two = dict(before, pulse2_start=0.141, pulse2_duration=0.132, pulse2_torque=0.415)
    (_, _, first), (s0, s1, second) = motor_frame_pulses(two)
    assert first == AS_BUILT["torque"] and second == -0.415
    assert s0 == AS_BUILT["t_switch"] + 0.141


def test_no_torque_or_no_time_is_no_pulse():
    assert motor_frame_pulses(dict(AS_BUILT, torque=0.0)) == []
    assert motor_frame_pulses(dict(AS_BUILT, t_motor=0.0)) == []
