"""Walking a route (analysis.walk): one step after another, each gait chosen by replanning from
the robot's estimate, under each step's noise."""
import math
from dataclasses import replace

import numpy as np
import pytest

from monkeystudy.analysis.route import AtlasGait
from monkeystudy.analysis.sections import cycle_section_state
from monkeystudy.analysis.survival import Noise, survival_runs
from monkeystudy.analysis.walk import (
    MAX_STEPS, MISSED_GOAL, NO_ROUTE, OFF_STEEL, WalkGait, mirrored_gait, walk_route,
    with_catch_height,
)
from monkeystudy.controllers import Integrator
from monkeystudy.kernel import layout as L
from monkeystudy.simulation import run_controller
from monkeystudy.study.models import SequenceGaitSpec
from monkeystudy.wall import Goal, Region, Start, Wall

from sequencegaits import Z_DESCENDING, descending

#: robust_design's designed gait (its design step's best), torques in the motor frame [N m]
LEVEL = {
    "kind": "sequence", "torque_frame": "motor",
    "section": {"theta1": 0.0, "direction": "either", "theta2": 0.5479596132339642},
    "segments": [
        {"until": "time", "value": 7.519090701371105e-08},
        {"until": "free_end_y", "value": 0.0, "direction": "rising",
         "torque": 0.34936766154301463, "clock": "reset"},
        {"until": "time", "value": 0.3595490305742456, "magnets": "swap",
         "torque": -0.44095666216325524},
    ]}
#: its fixed point on the section (theta2 [rad], dtheta1, dtheta2 [rad s-1])
Z_LEVEL = (0.5479596132339642, 5.127230897230126, -2.573886303565416)
#: its step [m], [s]
DX_LEVEL, PERIOD_LEVEL = 1.176533444822156, 0.8851244906318175

INTEGRATOR = Integrator(method="dop853", rtol=1e-12, atol=1e-13, max_time=3.0)
NOISE = Noise(timing=1e-3, latency=1e-3, mass=0.01, com=0.01, inertia=0.01)


def level_gait() -> WalkGait:
    return WalkGait("level", SequenceGaitSpec(**LEVEL).gait(), Z_LEVEL)


def atlas_entry(name="level", dx=DX_LEVEL, dy=0.0) -> AtlasGait:
    return AtlasGait(name, dx, dy, PERIOD_LEVEL, 0.45, 0.0, 0.001)


def plate(holes=(), goal_x=10 * DX_LEVEL) -> Wall:
    """A plate 26 m wide, the goal ten level steps ahead (or behind: ``goal_x`` < 0)."""
    return Wall((Region(((-13.0, -2.0), (13.0, -2.0), (13.0, 2.0), (-13.0, 2.0)), holes),),
                Start((0.0, 0.0), "A"), Goal((goal_x, 0.0), 0.05), 0.0)


class _BiasedSensor:
    """A sensor whose estimate is the truth shifted by a fixed offset [m]."""

    def __init__(self, offset):
        self.offset = np.asarray(offset, float)

    def initial(self, true_start, draws):
        return np.asarray(true_start, float) + self.offset

    def update(self, estimate, true_before, true_after, theta_at_catch, draws, *, lengths,
               attached):
        return np.asarray(true_after, float) + self.offset


def test_a_walk_that_repeats_one_gait_is_that_gaits_survival_run_bit_for_bit():
    # step k of run r draws what cycle k of survival run r draws, and a walk of one gait on
    # a level staircase aims every catch at the start's height, as the gait's own guard does
    gait, runs, steps = level_gait(), np.arange(3), 6
    seq = replace(gait.gait, tick=0.001)
    ref = survival_runs(seq.loop_controller(), cycle_section_state(seq, Z_LEVEL), Z_LEVEL,
                        runs=runs, max_cycles=steps, noise=NOISE, seed=30,
                        integrator=INTEGRATOR, section=seq.section_observers())
    assert (ref.cycles == steps).all()
    for r in runs:
        w = walk_route(plate(), [gait], [atlas_entry()], integrator=INTEGRATOR, tick=0.001,
                       noise=NOISE, seed=30, run=int(r), max_steps=steps,
                       plan={"resolution": 0.001})
        assert w.failure == MAX_STEPS and len(w.catches) == steps
        assert w.catches[-1, 0] == ref.distance[r]
        assert w.catches[-1, 1] == ref.height[r]
        assert w.time == ref.time[r]


def test_the_mirrored_gait_walks_the_mirror_image_of_the_gaits_walk():
    gait = level_gait()
    back = gait.mirrored()
    assert back.name == "level (mirrored)"
    twice = mirrored_gait(mirrored_gait(gait.gait))
    for a, b in zip(twice.program(), gait.gait.program()):     # an involution
        np.testing.assert_array_equal(a, b)
    prog, mirror = gait.gait.program()[0], back.gait.program()[0]
    np.testing.assert_array_equal(mirror[:, L.S_TORQUE], -prog[:, L.S_TORQUE])
    # the section: link 1 crossing the vertical either way is its own mirror image
    assert prog[-1, L.S_GVALUE] == mirror[-1, L.S_GVALUE] == 0.0
    kw = dict(integrator=INTEGRATOR, max_steps=5, plan={"resolution": 0.001})
    fwd = walk_route(plate(), [gait], [atlas_entry()], **kw)
    rev = walk_route(plate(goal_x=-10 * DX_LEVEL), [back],
                     [atlas_entry(back.name, -DX_LEVEL)], **kw)
    assert fwd.catches[-1, 0] == pytest.approx(5 * DX_LEVEL, abs=1e-6)
    np.testing.assert_allclose(rev.catches[:, 0], -fwd.catches[:, 0], rtol=0, atol=1e-11)
    np.testing.assert_allclose(rev.catches[:, 1], fwd.catches[:, 1], rtol=0, atol=1e-11)
    assert rev.energy == pytest.approx(fwd.energy, rel=1e-9)


def test_a_catch_where_the_steel_has_a_hole_fails_the_walk_there():
    # the third catch lands at x = 3.53 m: a window there has no steel
    window = ((3.4, -0.5), (3.7, -0.5), (3.7, 0.5), (3.4, 0.5))
    wall = replace(plate(holes=(window,)), goal=Goal((10 * DX_LEVEL, 0.0), 0.5))
    # the planner knows the window, so it plans no route through it: the walk is refused
    w = walk_route(wall, [level_gait()], [atlas_entry()], integrator=INTEGRATOR,
                   max_steps=8, plan={"resolution": 0.001})
    assert w.failure == NO_ROUTE and len(w.catches) == 0
    # a robot that believes itself 0.3 m behind plans its third catch at 3.23 m, clear of
    # the window, and lands at 3.53 m, in it: the magnet cannot hold
    w = walk_route(wall, [level_gait()], [atlas_entry()], integrator=INTEGRATOR,
                   max_steps=8, sensor=_BiasedSensor((-0.3, 0.0)),
                   plan={"resolution": 0.001})
    assert w.failure == OFF_STEEL and not w.arrived
    assert len(w.catches) == 2
    assert w.failed_at[0] == pytest.approx(3 * DX_LEVEL, abs=1e-6)
    assert abs(w.failed_at[1]) < 1e-9
    # its time and energy are those of the two steps that held, not of the one that fell
    held = walk_route(wall, [level_gait()], [atlas_entry()], integrator=INTEGRATOR,
                      max_steps=2, sensor=_BiasedSensor((-0.3, 0.0)),
                      plan={"resolution": 0.001})
    assert held.failure == MAX_STEPS and len(held.catches) == 2
    assert w.time == held.time == pytest.approx(2 * PERIOD_LEVEL, rel=1e-9)
    assert w.energy == held.energy


def test_a_walk_arrives_when_its_catch_lies_in_the_goal():
    wall = Wall((Region(((-1.0, -1.0), (6.0, -1.0), (6.0, 1.0), (-1.0, 1.0))),),
                Start((0.0, 0.0)), Goal((4 * DX_LEVEL, 0.0), 0.02))
    w = walk_route(wall, [level_gait()], [atlas_entry()], integrator=INTEGRATOR,
                   max_steps=10, plan={"resolution": 0.001})
    assert w.arrived and w.failure == "" and len(w.catches) == 4
    assert math.isnan(w.failed_at[0])
    assert w.gaits == ("level",) * 4


def test_the_walks_energy_is_the_motors_work_integrated_over_the_steps():
    # the motor's power is its torque times theta2's rate; integrate it over a finely
    # sampled run of the same steps, independently of the impacts' energy bookkeeping
    gait = level_gait()
    w = walk_route(plate(), [gait], [atlas_entry()], integrator=INTEGRATOR, max_steps=3,
                   plan={"resolution": 0.001})
    prog, obs = gait.program(0.0)
    hyb = cycle_section_state(gait.gait, Z_LEVEL)
    res = run_controller(replace(gait.gait, rise=0.0).loop_controller(
        gait.gait.section_observers()), hyb, integrator=INTEGRATOR, cycles=3,
        sample_dt=1e-4)
    t, y = res.sample_t, res.sample_state
    power = res.sample_torque * y[:, L.DTH2]
    work = float(np.sum(0.5 * (power[1:] + power[:-1]) * np.diff(t)))
    assert res.state[L.H_T] == pytest.approx(w.time, rel=1e-12)
    assert w.energy > 0.1
    # the trapezoid's error at 0.1 ms samples is about 1e-8 of it (second order in the step)
    assert w.energy == pytest.approx(work, rel=5e-8)


def test_an_estimate_too_high_makes_every_catch_fire_that_much_low():
    gait = level_gait()
    w = walk_route(plate(), [gait], [atlas_entry()], integrator=INTEGRATOR, max_steps=3,
                   sensor=_BiasedSensor((0.0, 0.004)), plan={"resolution": 0.001})
    np.testing.assert_allclose(w.catches[:, 1], -0.004, rtol=0, atol=1e-9)
    np.testing.assert_allclose(w.sensed[:, 1], 0.0, rtol=0, atol=1e-9)


def test_a_robot_that_believes_it_arrived_where_it_did_not_missed_the_goal():
    wall = Wall((Region(((-1.0, -1.0), (6.0, -1.0), (6.0, 1.0), (-1.0, 1.0))),),
                Start((0.0, 0.0)), Goal((3 * DX_LEVEL, 0.0), 0.2))
    # it believes itself 1 m ahead: after two steps (2.35 m) it believes it is at 3.35 m,
    # within 0.2 m of the goal
    w = walk_route(wall, [level_gait()], [atlas_entry()], integrator=INTEGRATOR,
                   max_steps=10, sensor=_BiasedSensor((1.0, 0.0)),
                   plan={"resolution": 0.001})
    assert w.failure == MISSED_GOAL and not w.arrived
    assert len(w.catches) == 2
    assert w.failed_at[0] == pytest.approx(2 * DX_LEVEL, abs=1e-6)


class _LowAfterCatch(_BiasedSensor):
    """Knows the start exactly; after each catch its estimate is ``offset`` off the truth."""

    def initial(self, true_start, draws):
        return np.asarray(true_start, float)


def test_a_walk_ends_where_it_plans_from_the_staircases_row_in_the_goal():
    """The robot plans from its estimate on the staircase's nearest row; when that point lies
    in the goal's disc it believes it has arrived, even where the estimate itself (0.04 m
    below the row) lies outside: it neither plans an empty route nor steps past the goal."""
    wall = Wall((Region(((-1.0, -1.0), (6.0, -1.0), (6.0, 1.0), (-1.0, 1.0))),),
                Start((0.0, 0.0)), Goal((DX_LEVEL, 0.0), 0.03))
    w = walk_route(wall, [level_gait()], [atlas_entry()], integrator=INTEGRATOR,
                   max_steps=10, sensor=_LowAfterCatch((0.0, -0.04)), height_step=0.1,
                   plan={"resolution": 0.001})
    assert w.gaits == ("level",) and len(w.catches) == 1
    assert w.sensed[0, 1] == pytest.approx(w.catches[0, 1] - 0.04, abs=1e-12)
    assert wall.goal.distance(w.sensed[0])[0] > 0.0       # the estimate: outside the disc
    assert w.arrived and w.failure == ""


def test_a_walk_that_starts_in_the_goal_takes_no_step():
    wall = Wall((Region(((-1.0, -1.0), (6.0, -1.0), (6.0, 1.0), (-1.0, 1.0))),),
                Start((0.0, 0.0)), Goal((0.1, 0.0), 0.2))
    w = walk_route(wall, [level_gait()], [atlas_entry()], integrator=INTEGRATOR,
                   max_steps=10, plan={"resolution": 0.001})
    assert w.arrived and w.gaits == () and len(w.catches) == 0


def test_catch_heights_are_set_only_on_world_height_guards():
    prog, _ = level_gait().program(0.001)
    out = with_catch_height(prog, 0.25)
    changed = np.flatnonzero((out != prog).any(axis=1))
    assert changed.tolist() == [1] and out[1, L.S_GVALUE] == 0.25
    assert (prog[:, L.S_RISE] == 0.0).all()


def test_a_walk_gait_needs_a_world_height_catch_and_a_swap():
    seq = SequenceGaitSpec(**LEVEL).gait()
    no_catch = replace(seq, segments=[replace(s, until="free_end_height")
                                      if s.until == "free_end_y" else s
                                      for s in seq.segments])
    with pytest.raises(ValueError, match="free_end_y"):
        WalkGait("x", no_catch, Z_LEVEL)
    with pytest.raises(ValueError, match="3 finite"):
        WalkGait("x", seq, (0.1, 0.2))
    with pytest.raises(ValueError, match="height_step"):
        walk_route(plate(), [level_gait()], [atlas_entry()], height_step=0.0)
    with pytest.raises(ValueError, match="no gait to walk"):
        walk_route(plate(), [level_gait()], [atlas_entry("other")])


def test_dead_reckoning_from_the_catch_angles_follows_the_walk_it_senses():
    # odometry without error adds the step vectors of the angles at each catch: the walker
    # passes the kernel's angles and the end it hung from, so its estimate is the truth
    from monkeystudy.analysis.sensing import Odometry
    w = walk_route(plate(), [level_gait()], [atlas_entry()], integrator=INTEGRATOR,
                   max_steps=4, sensor=Odometry(), plan={"resolution": 0.001})
    assert len(w.catches) == 4
    np.testing.assert_allclose(w.sensed, w.catches, rtol=0, atol=1e-9)
    # with encoder noise the estimate wanders from the truth, and the catches follow it
    noisy = walk_route(plate(), [level_gait()], [atlas_entry()], integrator=INTEGRATOR,
                       max_steps=4, sensor=Odometry(angle_noise=2e-3), seed=3,
                       plan={"resolution": 0.001})
    err = noisy.sensed - noisy.catches
    assert 1e-5 < np.abs(err).max() < 0.01
    # a catch fires where the estimate says the planned height is
    np.testing.assert_allclose(noisy.catches[1:, 1] + err[:-1, 1], 0.0, atol=1e-9)


def test_a_sampled_walk_records_the_trajectory_it_walked():
    from monkeystudy.simulation import physical_points
    gait = level_gait()
    w = walk_route(plate(), [gait], [atlas_entry()], integrator=INTEGRATOR, max_steps=3,
                   plan={"resolution": 0.001}, sample_dt=0.01)
    t, y, mode = w.samples
    assert len(t) == len(y) == len(mode) > 3 * PERIOD_LEVEL / 0.01 - 3
    # time runs on (an event is sampled on both sides of it, at one time)
    assert np.all(np.diff(t) >= 0) and t[-1] <= w.time + 1e-12
    # sampling never changes the steps: the walk is the unsampled one
    bare = walk_route(plate(), [gait], [atlas_entry()], integrator=INTEGRATOR, max_steps=3,
                      plan={"resolution": 0.001})
    np.testing.assert_array_equal(w.catches, bare.catches)
    pts = physical_points(w.params, y, mode[:, L.M_FLIPPED])
    # the attached end holds still between catches: at each sample it is at the start or a
    # catch
    held = np.where(mode[:, L.M_FLIPPED] > 0.5, 1, 0)
    ends = np.where(held[:, None] == 0, pts["A"], pts["B"])
    stops = np.vstack([[0.0, 0.0], w.catches])
    assert np.min(np.linalg.norm(ends[:, None, :] - stops[None], axis=2), axis=1).max() < 1e-9


def test_a_designed_switch_step_takes_one_gaits_cycle_into_the_others():
    from monkeystudy.analysis.sections import cycle_return_map
    from monkeystudy.analysis.walk import design_switch, switch_runs
    level = level_gait()
    down = WalkGait("descend", descending(), Z_DESCENDING)
    d = design_switch(level, down, rise=-0.1, torque_limit=0.6354, integrator=INTEGRATOR)
    assert d.residual < 1e-9
    assert max(abs(d.catch_torque), abs(d.after_torque)) <= 0.6354
    # independently: the step's own return map from the level gait's fixed point
    z, status = cycle_return_map(Z_LEVEL, d.gait, integrator=INTEGRATOR)
    assert status == 0
    np.testing.assert_allclose(z, Z_DESCENDING, atol=1e-9)
    assert SequenceGaitSpec(**d.spec).gait().program()[0].tobytes() == \
        d.gait.program()[0].tobytes()
    # a direct switch fails at once; through the switch step the descent goes on
    plan = [(level, 0.0, DX_LEVEL)] * 2 + [(down, -0.1, 0.8633)] * 3
    direct = switch_runs(plan, [0], integrator=INTEGRATOR, height_tolerance=0.02)
    assert direct.failed[0] and direct.failed_step[0] == 2
    # through the switch step (whose catch lands behind: the free magnet swings back to it)
    # the descent goes on, with exact timing
    via = WalkGait("switch", d.gait, Z_LEVEL)
    plan = plan[:2] + [(via, -0.1, -0.908)] + plan[2:]
    held = switch_runs(plan, [0], integrator=INTEGRATOR, height_tolerance=1e-9)
    assert not held.failed.any()
