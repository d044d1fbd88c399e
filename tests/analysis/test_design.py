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


# --- designs of a sequence gait's segments ---------------------------------------------------------
import numpy as np  # noqa: E402

from monkeystudy.analysis.design import (  # noqa: E402
    SegmentDesignSpace, evaluate_design, with_variational,
)
from monkeystudy.analysis.multipliers import sorted_eigs  # noqa: E402
from monkeystudy.controllers import Integrator  # noqa: E402
from monkeystudy.robot import Robot  # noqa: E402
from monkeystudy.study.models import SequenceGaitSpec  # noqa: E402

from test_motor_frame import DESIGN_B, Z_B, program_bytes  # noqa: E402

TIGHT = Integrator(method="dop853", rtol=1e-12, atol=1e-13, max_time=3.0)


def design_b_space(**kw) -> SegmentDesignSpace:
    gait = SequenceGaitSpec.model_validate(DESIGN_B).gait()      # kernel frame
    return SegmentDesignSpace(gait, Robot.preset("seed2009"), motor_frame=True,
                              integrator=TIGHT, **kw)


def test_a_segment_design_states_its_torques_as_the_study_wrote_them():
    """Motor frame: the values are the study's torques (+0.3213 before the catch, -0.4025
    after the swap, which the kernel applies negated), and they rebuild the same program."""
    space = design_b_space()
    v = space.values()
    written = [s["torque"] if "torque" in s else 0.0 for s in DESIGN_B["segments"]]
    assert [v[f"segment{k}_torque"] for k in (1, 2, 3)] == written
    assert [v[f"segment{k}_value"] for k in (1, 2, 3)] == [s["value"] for s in
                                                          DESIGN_B["segments"]]
    assert program_bytes(space.gait_for(v)) == program_bytes(space.base_gait)
    kernel = space.gait_for(dict(v, segment3_torque=-0.5)).segments[2].torque
    assert kernel == 0.5                 # after the swap: the opposite sign in the kernel
    assert space.parameter("segment2_value").unit == "m"     # a free_end_y guard
    assert space.parameter("segment3_value").unit == "s"
    with pytest.raises(ValueError, match="k from 1 to 3"):
        space.parameter("segment4_torque")
    with pytest.raises(ValueError, match="unknown design parameter"):
        space.parameter("t_switch")
    assert "outside" in space.buildable(dict(v, segment3_torque=-2.5))


def test_design_b_as_a_segment_design_holds_its_height_and_contracts():
    """Design B solved by the compiled Newton (no balance) lands on the fixed point the
    study's refine and floquet steps find; the full map's multipliers by variational
    equations and finite differences agree to 1e-6, the section map's multipliers are among
    them, and the height's is ~0 (the catch at the start's height sets the next height)."""
    space = design_b_space()
    res = with_variational(space, evaluate_design(space, {}, Z_B + [0.01, 0.02, -0.02]))
    assert res.ok, res.message
    np.testing.assert_allclose(res.z, Z_B, atol=1e-9)
    assert abs(res.rise) < 1e-12                # the next hold is at the start's height
    assert res.jacobian.shape == res.jacobian_fd.shape == (4, 4)
    assert abs(res.spectral_radius - res.spectral_radius_fd) < 1e-6
    assert res.spectral_radius == pytest.approx(0.3041373, abs=1e-6)
    # every catch is at the start's world height: the next height depends on nothing (its
    # row is zero), so the full map's multipliers are the section map's and 0
    np.testing.assert_allclose(res.jacobian[0], 0.0, atol=1e-9)
    assert abs(res.multipliers[-1]) < 1e-9
    reduced = sorted_eigs(res.jacobian[1:, 1:])
    np.testing.assert_allclose(np.sort_complex(res.multipliers[:3]), np.sort_complex(reduced),
                               atol=1e-9)
    section_only = design_b_space(height_in_map=False)
    r3 = evaluate_design(section_only, {}, Z_B)
    assert r3.jacobian_fd.shape == (3, 3)
    assert r3.spectral_radius_fd == pytest.approx(res.spectral_radius_fd, abs=1e-6)


def test_a_heavier_pre_catch_torque_moves_the_fixed_point_and_changes_rho():
    """A free parameter changes the gait: another torque before the catch, another fixed
    point and spectral radius, the height still held."""
    space = design_b_space()
    base = evaluate_design(space, {}, Z_B)
    other = evaluate_design(space, {"segment2_torque": 0.35, "segment3_torque": -0.42}, Z_B)
    assert other.ok and abs(other.rise) < 1e-12
    assert np.max(np.abs(other.z - base.z)) > 1e-2
    assert abs(other.spectral_radius_fd - base.spectral_radius_fd) > 1e-2


def test_without_noise_every_run_of_a_design_completes_and_the_draws_repeat():
    """design_survival: noiseless runs of design B all complete; with noise, the same seed
    gives the same runs (noise keyed by seed and run)."""
    from monkeystudy.analysis.design import design_survival
    from monkeystudy.analysis.survival import Noise

    space = design_b_space()
    res = evaluate_design(space, {}, Z_B)
    calm = design_survival(space, res, runs=3, max_cycles=6, noise=Noise(), seed=1, tick=0.0)
    assert list(calm.cycles) == [6, 6, 6] and np.all(calm.failure == 0)
    noisy = [design_survival(space, res, runs=4, max_cycles=6, tick=1e-3, seed=7,
                             noise=Noise(timing=1e-3, mass=0.01)) for _ in range(2)]
    np.testing.assert_array_equal(noisy[0].cycles, noisy[1].cycles)
    np.testing.assert_array_equal(noisy[0].height, noisy[1].height)


# --- a design must be a gait of its starting gait's kind ---------------------------------------
from dataclasses import replace  # noqa: E402

from monkeystudy.analysis.design import (  # noqa: E402
    cycle_shape, design_step_problem, step_problems,
)

#: design B with a pulse of -2 N m after the catch: 0.1 s of it is a step; 0.364 s of it spins
#: link 2 through link 1 (the catch then finds B where A hangs), with its fixed point (theta2
#: [rad], dtheta1, dtheta2 [rad s-1]) from the design step's grid
SWING = ({"segment3_torque": -2.0, "segment3_value": 0.1}, [0.542, 5.714, -9.470])
SPIN = ({"segment3_torque": -2.0, "segment3_value": 0.36363636363636365},
        [-0.432, -2.480, 40.148])


def test_a_design_that_spins_link_2_is_refused_and_one_that_swings_is_not():
    space = design_b_space()
    robot = Robot.preset("seed2009")
    start = replace(SequenceGaitSpec.model_validate(DESIGN_B).gait(), theta2=float(Z_B[0]))
    reference = cycle_shape(start, Z_B, robot=robot, integrator=TIGHT)
    # design B's step: one swap, link 1 back at the vertical once, theta2 within 0.67 rad
    assert (reference.status, reference.swaps, reference.crossings) == (0, 1, 1)
    assert reference.max_abs_theta2 < 0.7 and reference.max_kinetic_energy < 10.0
    assert step_problems(reference, reference, robot) == []
    swing = evaluate_design(space, *SWING)
    spin = evaluate_design(space, *SPIN)
    assert swing.ok and spin.ok
    # the spinning one contracts more: a search by the spectral radius alone would pick it
    assert spin.spectral_radius_fd < 1.0 < swing.spectral_radius_fd
    assert abs(spin.advance) < 1e-9 < 1.0 < swing.advance
    assert design_step_problem(space, swing, reference) == ""
    why = design_step_problem(space, spin, reference)
    assert "link 1 passes the section 4 times per cycle, the starting gait 1" in why
    assert "link 2 turns through link 1" in why


# --- a robot without mirror-image links: a two-swap cycle --------------------------------------
from monkeystudy.analysis.measured_replay import acromonk_robot  # noqa: E402
from monkeystudy.robot import Friction, Rotor  # noqa: E402

from test_motor import BRACHIATION  # noqa: E402

#: its fixed point, found by the refine and floquet steps (unstable: rho 8.18)
Z_BRACHIATION = np.array([0.15718415, -7.3971987, 1.7245056])


def test_a_bars_rise_is_not_a_design_parameter():
    """A catch on a bar takes its value from the ladder: a design may vary the catch's
    torque, not where the bar is."""
    segs = [dict(s) for s in BRACHIATION["segments"]]
    for key in ("value", "direction"):
        segs[0].pop(key)
    segs[0].update(until="bar", bar={"dx": -0.03, "dy": 0.0, "window": 0.02})
    gait = SequenceGaitSpec.model_validate(dict(BRACHIATION, segments=segs)).gait()
    space = SegmentDesignSpace(gait, acromonk_for_design(), motor_frame=True, integrator=TIGHT)
    assert space.parameter("segment1_torque").unit == "N m"
    with pytest.raises(ValueError, match="catches a bar"):
        space.parameter("segment1_value")


def acromonk_for_design() -> Robot:
    return acromonk_robot(Friction(0.0, 0.0), Friction(0.04144, 0.0)).with_rotor(
        Rotor(2.453e-4, 6.0, 1))


def test_a_two_swap_cycle_designs_a_robot_without_mirror_image_links():
    """A cycle that ends hanging from A again compares like with like for any robot: the
    segment design solves AcroMonk's two-swap brachiation (links 1.04 and 0.63 kg) and its
    full map's multipliers by variational equations and by finite differences agree; a
    one-swap cycle on the same robot is refused (it would compare B's frame with A's)."""
    robot = acromonk_for_design()
    assert not robot.is_mirror_image
    gait = SequenceGaitSpec.model_validate(BRACHIATION).gait()
    space = SegmentDesignSpace(gait, robot, motor_frame=True, integrator=TIGHT,
                               torque_limit=3.0)      # N m: the lab's trajectory optimisation
    res = with_variational(space, evaluate_design(space, {}, Z_BRACHIATION + [0.0, 0.01, -0.01]))
    assert res.ok, res.message
    np.testing.assert_allclose(res.z, Z_BRACHIATION, atol=1e-6)
    assert abs(res.spectral_radius - res.spectral_radius_fd) < 1e-6
    assert res.spectral_radius == pytest.approx(8.18385, abs=1e-4)
    assert abs(res.advance) == pytest.approx(0.633954, abs=1e-5)     # two bars of the cycle
    one_swap = dict(BRACHIATION, segments=BRACHIATION["segments"][:2])
    with pytest.raises(ValueError, match="mirror-image links"):
        SegmentDesignSpace(SequenceGaitSpec.model_validate(one_swap).gait(), robot,
                           motor_frame=True, integrator=TIGHT)


# --- a gait that catches bars ------------------------------------------------------------------
from test_motor import BAR_BRACHIATION, Z_BAR_BRACHIATION  # noqa: E402

from monkeystudy.analysis.design import OUT_OF_BOUNDS, STATUS_NAMES  # noqa: E402
from monkeystudy.kernel.design import DS_NO_CYCLE  # noqa: E402

BAR_INTEG = Integrator(method="dop853", rtol=1e-12, atol=1e-13, max_time=6.0)
#: a 2 x 2 grid of the catches' torques around the bar gait's [N m, motor frame]
BAR_GRID = [(a, b) for a in (0.77, 0.78) for b in (-1.62, -1.60)]


def bar_space(window2: float = 0.03, **kw) -> SegmentDesignSpace:
    segs = [dict(s) for s in BAR_BRACHIATION["segments"]]
    segs[3] = dict(segs[3], bar=dict(segs[3]["bar"], window=window2))
    gait = SequenceGaitSpec.model_validate(dict(BAR_BRACHIATION, segments=segs)).gait()
    return SegmentDesignSpace(gait, acromonk_for_design(), motor_frame=True,
                              integrator=BAR_INTEG, **kw)


def bar_grid(space):
    return [evaluate_design(space, {"segment1_torque": a, "segment4_torque": b},
                            Z_BAR_BRACHIATION) for a, b in BAR_GRID]


def test_a_bar_gaits_design_is_measured_on_its_section_map_with_the_height_reset():
    """A segment design of a bar gait runs (the bars' rises are the ladder's, not parameters
    to bound) and its full map's spectral radius is the section map's: the catches reset the
    height (multiplier 0), they do not leave it neutral (1)."""
    res = with_variational(bar_space(), evaluate_design(bar_space(), {}, Z_BAR_BRACHIATION))
    assert res.ok, res.message
    assert res.spectral_radius_fd == pytest.approx(0.423634, abs=1e-6)
    assert abs(res.spectral_radius - res.spectral_radius_fd) < 1e-6
    assert abs(res.multipliers[-1]) < 1e-12
    np.testing.assert_allclose(res.catch_offset_margin, [0.01889087, 0.00538868], atol=1e-7)
    assert res.max_catch_speed == pytest.approx(6.16405, abs=1e-4)
    assert res.objective("spectral_radius", 0.0, 0.1) == pytest.approx(
        res.spectral_radius_fd + 0.1 * res.max_catch_speed, abs=1e-12)
    assert "segment1_value = 0.05 m" in bar_space().buildable(
        dict(bar_space().values(), segment1_value=0.05))


def test_a_design_whose_catch_falls_outside_a_narrow_window_is_no_cycle():
    """With the second bar's window narrowed to 26 mm two designs of the grid still catch it
    (their hook within 26 mm of the bar) and two do not: the hook passes the bar, their cycle
    ends at its horizon and the design fails as no_cycle, naming the bar."""
    wide, narrow = bar_grid(bar_space()), bar_grid(bar_space(window2=0.026))
    assert all(r.ok for r in wide)
    for w, n in zip(wide, narrow):
        if w.catch_offset_margin[1] > 0.004:      # inside 26 mm too
            assert n.ok
            assert n.catch_offset_margin[1] == pytest.approx(w.catch_offset_margin[1] - 0.004,
                                                             abs=1e-9)
        else:
            assert n.status == DS_NO_CYCLE, n.message
            assert "segment 4's bar" in n.message and "outside its window 0.026 m" in n.message
    assert sum(r.ok for r in narrow) == 2


def test_a_catch_below_min_offset_margin_is_rejected():
    """min_offset_margin rejects the grid's designs whose closest catch comes nearer than
    5 mm to the window's edge (status out_of_bounds, the margin in the message)."""
    plain = bar_grid(bar_space())
    held = bar_grid(bar_space(min_offset_margin=0.005))
    for p, h in zip(plain, held):
        if p.min_offset_margin >= 0.005:
            assert h.ok and h.spectral_radius_fd == p.spectral_radius_fd
        else:
            assert h.status == OUT_OF_BOUNDS and STATUS_NAMES[h.status] == "out_of_bounds"
            assert "below min_offset_margin 0.005 m" in h.message
    assert sum(h.ok for h in held) == 2


def test_a_screen_measures_a_ladder_gaits_advance_the_way_it_travels():
    """The bar gait travels towards -x (two bars of 0.34 m back per cycle): without noise
    every screen run of it completes its cycles, none stalls on a minimum advance measured
    towards +x."""
    from monkeystudy.analysis.design import design_survival
    from monkeystudy.analysis.survival import Noise

    space = bar_space()
    res = evaluate_design(space, {}, Z_BAR_BRACHIATION)
    assert res.ok and res.advance == pytest.approx(-0.68, abs=1e-9)
    calm = design_survival(space, res, runs=2, max_cycles=3, noise=Noise(), seed=1, tick=0.0)
    assert list(calm.cycles) == [3, 3] and np.all(calm.failure == 0)
    assert calm.distance[0] == pytest.approx(-3 * 0.68, abs=1e-9)
