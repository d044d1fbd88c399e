"""Torques in the motor frame (controllers.torques_from_motor_frame, a study's
``torque_frame: motor``): the kernel applies a torque on theta2 of the frame of the end attached
at the time, and theta2 changes sign at a swap; a torque written in the motor frame is the
physical motor torque, converted to the kernel's frame when the gait is built."""
import json

import numpy as np
import pytest

from monkeystudy import Segment, SequenceGait, simulate
from monkeystudy.analysis import cycle_section_state
from monkeystudy.controllers import motor_frame_signs, torques_from_motor_frame
from monkeystudy.study.models import SequenceGaitSpec

#: design B of the issue-30 design search, its torques in the motor frame [N m]: +0.3213 from
#: the vertical to the catch (B rising through the start's world height), -0.4025 for 0.2893 s
#: after the catch (the clock restarting there)
DESIGN_B = {
    "kind": "sequence", "torque_frame": "motor",
    "section": {"theta1": 0.0, "direction": "either", "theta2": 0.43159965929540284},
    "segments": [
        {"until": "time", "value": 7.519090701371105e-08},
        {"until": "free_end_y", "value": 0.0, "direction": "rising",
         "torque": 0.3213454663367762, "clock": "reset"},
        {"until": "time", "value": 0.28929574705023964, "magnets": "swap",
         "torque": -0.40251722486466324},
    ]}
Z_B = np.array([0.43159965929540284, 4.844445533376672, -1.6124995598690839])


def kernel_frame(spec: dict, torques: list[float], section_torque: float = 0.0) -> dict:
    """``spec`` in the kernel's frame with the segment torques given by hand."""
    segs = [dict(seg, torque=t) for seg, t in zip(spec["segments"], torques)]
    out = dict(spec, segments=segs, section=dict(spec.get("section", {}),
                                                 torque=section_torque))
    del out["torque_frame"]
    return out


def program_bytes(gait: SequenceGait) -> bytes:
    prog, obs = gait.program()
    return prog.tobytes() + obs.tobytes()


def test_design_b_in_the_motor_frame_is_the_hand_converted_gait_bit_for_bit():
    motor = SequenceGaitSpec.model_validate(DESIGN_B).gait()
    # before the swap the kernel's frame is A's, the motor frame's: the same torque; after
    # it the frame is B's, theta2 = -theta2 of A's frame: the torque negated
    by_hand = SequenceGaitSpec.model_validate(kernel_frame(
        DESIGN_B, [0.0, 0.3213454663367762, 0.40251722486466324])).gait()
    assert program_bytes(motor) == program_bytes(by_hand)
    assert tuple(motor.segments) == tuple(by_hand.segments)


def test_flight_and_catch_with_the_other_end_is_converted_by_the_frame_of_each_row():
    """A release flies in the frame of the end it left (A); the catch with B changes the frame:
    only the rows after it are negated (and the section row, in B's frame too)."""
    spec = {"kind": "sequence", "torque_frame": "motor",
            "section": {"theta1": 0.0, "direction": "either", "theta2": 0.3, "torque": 0.2},
            "segments": [
                {"until": "coord", "coord": "theta1", "value": 0.6, "latch_energy": True,
                 "torque": 0.1},
                {"until": "free_end_y", "value": 0.0, "magnets": "none", "torque": 0.3},
                {"until": "energy_restored", "value": 0.0, "magnets": "B", "torque": 0.6354},
            ]}
    gait = SequenceGaitSpec.model_validate(spec).gait()
    assert gait.frame_ends() == ["A", "A", "B", "B"]
    by_hand = SequenceGaitSpec.model_validate(kernel_frame(spec, [0.1, 0.3, -0.6354],
                                                           -0.2)).gait()
    assert program_bytes(gait) == program_bytes(by_hand)


def test_a_two_swap_cycle_returns_to_the_motor_frame_and_the_conversion_is_an_involution():
    gait = SequenceGait([
        Segment("free_end_height", direction="rising", torque=0.1),
        Segment("time", value=0.5, magnets="swap", torque=0.2),
        Segment("free_end_height", direction="rising", torque=-0.3),
        Segment("time", value=1.0, magnets="swap", torque=0.4),
    ], section_torque=0.5)
    np.testing.assert_array_equal(motor_frame_signs(gait), [1, -1, -1, 1, 1])
    kernel = torques_from_motor_frame(gait)
    assert [s.torque for s in kernel.segments] == [0.1, -0.2, 0.3, 0.4]
    assert kernel.section_torque == 0.5
    back = torques_from_motor_frame(kernel)
    assert tuple(back.segments) == tuple(gait.segments)
    assert back.section_torque == gait.section_torque
    # a zero torque stays +0.0 (the program's bits do not depend on the frame it came from)
    zero = torques_from_motor_frame(SequenceGait([Segment("time", value=0.1),
                                                  Segment("time", value=0.2, magnets="swap")]))
    assert all(np.signbit(s.torque) == 0 for s in zero.segments)


def test_unset_frame_is_the_kernel_frame_and_is_not_recorded():
    """A study without ``torque_frame`` (every study written before it) builds the gait it
    always did and records the gait as it always did (its step keys and datasets stay)."""
    plain = {k: v for k, v in DESIGN_B.items() if k != "torque_frame"}
    spec = SequenceGaitSpec.model_validate(plain)
    assert spec.torque_frame == "attached_end"
    assert "torque_frame" not in spec.model_dump(mode="json")
    assert "clock" not in spec.model_dump(mode="json")["segments"][0]
    assert [s.torque for s in spec.gait().segments] == [0.0, 0.3213454663367762,
                                                        -0.40251722486466324]
    stated = SequenceGaitSpec.model_validate(dict(plain, torque_frame="attached_end"))
    assert stated.model_dump(mode="json")["torque_frame"] == "attached_end"
    assert program_bytes(stated.gait()) == program_bytes(spec.gait())
    motor = SequenceGaitSpec.model_validate(DESIGN_B).model_dump(mode="json")
    assert motor["torque_frame"] == "motor"
    assert motor["segments"][1]["clock"] == "reset"


def physical_joint_torques(gait: SequenceGait, z) -> dict[int, float]:
    """The motor torque [N m] acting in each segment of one cycle, measured from the
    trajectory alone: the work-energy balance over a stretch of the segment (no impact in
    it, no friction), E(t2) - E(t1) = tau (phi(t2) - phi(t1)), with phi the angle of link 2
    relative to link 1 computed from the world positions of A, the joint and B
    (counter-clockwise positive: theta2 of end A's frame, whatever the frame the kernel is
    in)."""
    ds = simulate(gait.controller(), state=cycle_section_state(gait, z), cycles=1,
                  sample_dt=1e-3, integrator=gait_integrator())
    A, J, B = (np.asarray(ds[k].values) for k in ("A", "joint", "B"))
    link1, link2 = J - A, B - J
    phi = np.unwrap(np.arctan2(link2[:, 1], link2[:, 0]) - np.arctan2(link1[:, 1],
                                                                        link1[:, 0]))
    energy = np.asarray(ds["total_energy"].values)
    seg = np.asarray(ds["segment"].values)
    out = {}
    for k in np.unique(seg):
        idx = np.flatnonzero(seg == k)
        if idx.size < 12:
            continue
        i1, i2 = idx[3], idx[-4]          # inside the segment: away from its events
        out[int(k)] = (energy[i2] - energy[i1]) / (phi[i2] - phi[i1])
    return out


def gait_integrator():
    from monkeystudy.controllers import Integrator
    return Integrator(rtol=1e-12, atol=1e-13)


def test_the_physical_motor_torque_is_the_motor_frame_torque_on_both_sides_of_the_swap():
    """Design B's motor torque, measured from its trajectory by the work it does on the
    joint angle of the links (world positions), is +0.3213 N m before the catch and
    -0.4025 N m after it: the values written in the motor frame, on both sides of the swap,
    although the kernel applies +0.4025 after it (in B's frame)."""
    gait = SequenceGaitSpec.model_validate(DESIGN_B).gait()
    tau = physical_joint_torques(gait, Z_B)
    assert set(tau) >= {1, 2, 3}
    assert tau[1] == pytest.approx(0.3213454663367762, rel=1e-8)
    assert tau[2] == pytest.approx(-0.40251722486466324, rel=1e-8)
    assert abs(tau[3]) < 1e-8                      # the motor is off to the section
    assert gait.segments[2].torque > 0.0           # the kernel's frame: B's, sign reversed


def test_one_motor_frame_torque_held_across_the_swap_keeps_its_sign_on_the_links():
    """The same torque written in both segments around a swap: in the motor frame it keeps
    its sign relative to the links (the work balance measures +0.3 N m on both sides); in
    the kernel's frame (attached_end) the same numbers reverse it at the swap."""
    spec = {"kind": "sequence", "section": {"theta1": 0.0, "theta2": 0.43159965929540284},
            "segments": [{"until": "time", "value": 0.3, "torque": 0.3},
                         {"until": "time", "value": 0.55, "magnets": "swap", "torque": 0.3}]}
    motor = physical_joint_torques(
        SequenceGaitSpec.model_validate(dict(spec, torque_frame="motor")).gait(), Z_B)
    kernel = physical_joint_torques(SequenceGaitSpec.model_validate(spec).gait(), Z_B)
    assert motor[0] == pytest.approx(0.3, rel=1e-8)
    assert motor[1] == pytest.approx(0.3, rel=1e-8)
    assert kernel[0] == pytest.approx(0.3, rel=1e-8)
    assert kernel[1] == pytest.approx(-0.3, rel=1e-8)


def design_b_study(name: str) -> str:
    """A small study of design B: refine, floquet and a 2 x 2 segment design with a short
    refine, verification and screen (study file text, named ``name``)."""
    return (f"schema_version: 1\nname: {name}\nrobot: seed2009\n"
            f"gait: {json.dumps(DESIGN_B)}\n" + DESIGN_B_STEPS)


#: the integrator and steps of :func:`design_b_study`
DESIGN_B_STEPS = """\
integrator: {method: dop853, rtol: 1.0e-12, atol: 1.0e-13, max_time: 3.0}
steps:
  - {name: refine, kind: refine, start: [4.844445533376672, -1.6124995598690839],
     maxiter: 300}
  - {name: floquet, kind: floquet, from: refine}
  - name: design
    kind: design
    from: floquet
    parameters:
      segment2_torque: {start: 0.30, stop: 0.34, num: 2}
      segment3_torque: {start: -0.42, stop: -0.38, num: 2}
    refine: {starts: 1, max_evaluations: 12}
    verify: {cycles: 20, decay_cycles: 8, basin_num: 3, basin_cycles: 5}
    screen: {candidates: 3, runs: 6, max_cycles: 8, seed: 3,
             noise: {timing: 1.0e-3, parameters: {mass: 0.01}}}
"""
