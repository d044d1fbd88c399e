"""Continuation of sequence gaits (monkeystudy.analysis.continuation): parameter plumbing, bifurcation
bookkeeping, and branches checked against physics they must obey."""
import dataclasses
import math
import re
from functools import partial

import numpy as np
import pytest

from monkeystudy.analysis import cycle_return_map, jacobian_fd, solve_fixed_point
from monkeystudy.analysis.continuation import (
    crossings, continue_cycle, fold_indices, motor_torque, parameter_of, with_parameter,
)
from monkeystudy.controllers import Segment, SequenceGait
from monkeystudy.robot import Robot
from monkeystudy.analysis.variational import sequence_variational_jacobian
from monkeystudy.simulation import evaluate_cycle_gaits

from sequencegaits import INTEG, TORQUE, Z_DESCENDING, descending, two_step, two_swing


def residual(gait, z, robot) -> float:
    zn, st = cycle_return_map(z, gait, robot=robot, integrator=INTEG)
    assert st == 0
    return float(np.abs(zn - z).max())


# --- parameters ------------------------------------------------------------------------------
def test_mass_ratio_keeps_total_mass_and_shape():
    base = Robot.preset("seed2009")
    r, g = with_parameter(base, two_step(), "mass_ratio", 0.5)
    assert r.link1.mass + r.link2.mass == pytest.approx(2.0, rel=1e-15)
    assert r.link2.mass / r.link1.mass == pytest.approx(0.5, rel=1e-15)
    # same shape: inertia per unit mass and CG positions unchanged
    assert r.link1.inertia / r.link1.mass == pytest.approx(base.link1.inertia / 1.0)
    assert r.link2.inertia / r.link2.mass == pytest.approx(base.link2.inertia / 1.0)
    assert (r.link1.com, r.link2.com) == (base.link1.com, base.link2.com)
    assert parameter_of(r, g, "mass_ratio") == pytest.approx(0.5)
    same, _ = with_parameter(base, two_step(), "mass_ratio", 1.0)
    np.testing.assert_array_equal(same.params(), base.params())
    with pytest.raises(ValueError, match="mass_ratio must be > 0"):
        with_parameter(base, two_step(), "mass_ratio", 0.0)


def test_torque_scales_every_motor_segment():
    g = dataclasses.replace(two_step(), section_torque=-0.2)
    _, g2 = with_parameter("seed2009", g, "torque", 2 * TORQUE)
    assert [s.torque for s in g2.segments] == [0.0, 2 * TORQUE, 0.0, 0.0, 2 * TORQUE]
    assert g2.section_torque == pytest.approx(-0.4)
    assert motor_torque(g2) == 2 * TORQUE
    motorless = SequenceGait([Segment("free_end_height", 0.0, magnets="keep")])
    with pytest.raises(ValueError, match="no motor segment"):
        motor_torque(motorless)


def test_friction_and_mirror_parameters():
    r, _ = with_parameter("seed2009", two_step(), "joint_viscous", 0.01)
    assert r.joint_friction.viscous == 0.01 and r.pivot_friction.viscous == 0.0
    r, _ = with_parameter("seed2009", two_step(), "pivot_viscous", 0.02)
    assert r.pivot_friction.viscous == 0.02
    r, _ = with_parameter("seed2009", two_step(), "com", 0.5)
    assert r.link1.com == 0.5 and r.link2.com == pytest.approx(0.61 - 0.5)
    with pytest.raises(ValueError, match="parameter must be one of"):
        with_parameter("seed2009", two_step(), "length", 1.0)


# --- bifurcation bookkeeping -----------------------------------------------------------------
def test_crossings_classify_multipliers_leaving_the_circle():
    neutral = 1.0
    pd, p1, ns = crossings(np.array([neutral, -0.9, 0.3]), np.array([neutral, -1.1, 0.3]))
    assert (pd, p1, ns) == (True, False, False)
    pd, p1, ns = crossings(np.array([neutral, 0.9, 0.3]), np.array([neutral, 1.2, 0.3]))
    assert (pd, p1, ns) == (False, True, False)
    pd, p1, ns = crossings(np.array([neutral, 0.9 + 0.3j, 0.9 - 0.3j]),
                            np.array([neutral, 1.0 + 0.3j, 1.0 - 0.3j]))
    assert (pd, p1, ns) == (False, False, True)
    # a stable complex pair that meets the real axis and leaves through +1
    pd, p1, ns = crossings(np.array([neutral, 0.98 + 0.1j, 0.98 - 0.1j]),
                            np.array([neutral, 1.2, 0.7]))
    assert (pd, p1, ns) == (False, True, False)
    # the neutral multiplier is never a crossing, nor moving inside the circle
    assert crossings(np.array([1.0, 0.5, 0.2]), np.array([1.0, 0.6, -0.3])) == \
        (False, False, False)


def test_fold_indices():
    assert fold_indices([0.0, 1.0, 2.0, 1.5, 1.0, 1.2]) == [2, 4]
    assert fold_indices([3.0, 2.0, 1.0]) == []


# --- branches ---------------------------------------------------------------------------------
def test_gravity_torque_scaling_maps_one_branch_onto_another(two_step_point):
    """Dimensional analysis: with gravity and every torque multiplied by s, a trajectory runs
    sqrt(s) times faster on the same path (no time or energy guards here). So the torque
    branch at 4 g is the torque branch at g with torque x 4 and rates x 2: the continuation,
    run from the scaled start, must recover the known branch point by point."""
    z = two_step_point
    g0 = Robot.preset("seed2009")
    b1 = continue_cycle(two_step(), z, "torque", robot=g0, integrator=INTEG, ds=0.02,
                        steps=8)
    assert b1.stop_reason == "steps" and np.all(np.diff(b1.value) > 0)
    g4 = dataclasses.replace(g0, gravity=4 * g0.gravity)
    z4 = np.array([z[0], 2 * z[1], 2 * z[2]])
    assert residual(two_step(4 * TORQUE), z4, g4) < 1e-10      # the scaled start is exact
    b4 = continue_cycle(two_step(4 * TORQUE), z4, "torque", robot=g4, integrator=INTEG,
                        ds=0.05, steps=8)
    assert b4.stop_reason == "steps"
    inside = b4.value / 4 <= b1.value[-1]
    assert inside.sum() >= 5
    from scipy.interpolate import CubicSpline
    for y1, y4 in ((b1.dtheta1, b4.dtheta1), (b1.dtheta2, b4.dtheta2)):
        known = CubicSpline(b1.value, y1)(b4.value[inside] / 4)
        np.testing.assert_allclose(y4[inside] / 2, known, rtol=0, atol=2e-6)
    # the multipliers are dimensionless: the same along both branches
    lam1 = np.sort(np.abs(b1.multipliers[0]))
    lam4 = np.sort(np.abs(b4.multipliers[0]))
    np.testing.assert_allclose(lam4, lam1, atol=1e-8)


def test_mass_ratio_branch_points_are_fixed_points_with_right_multipliers(two_step_point):
    b = continue_cycle(two_step(), two_step_point, "mass_ratio", robot="seed2009",
                       integrator=INTEG, ds=-0.05, steps=5)
    assert len(b.value) == 6 and np.all(np.diff(b.value) < 0)
    assert b.value[-1] < 0.85
    base = Robot.preset("seed2009")
    for i in range(len(b.value)):
        rb, g = with_parameter(base, two_step(), "mass_ratio", b.value[i])
        g = dataclasses.replace(g, theta2=b.theta2[i])
        # evaluated afresh by the batch kernel: a fixed point to the integrator's accuracy
        r = evaluate_cycle_gaits(np.array([[b.dtheta1[i], b.dtheta2[i]]]), g, robot=rb,
                                 integrator=INTEG)
        assert r["status"][0] == 0 and r["error"][0] < 1e-20
    # the multipliers against finite differences at the last point, where the ratio is
    # far from the mirror-symmetric 1 and the gait has become unstable
    rb, g = with_parameter(base, two_step(), "mass_ratio", b.value[-1])
    zl = np.array([b.theta2[-1], b.dtheta1[-1], b.dtheta2[-1]])
    Jfd = jacobian_fd(partial(cycle_return_map, gait=g, robot=rb, integrator=INTEG), zl)
    lam_fd = np.linalg.eigvals(Jfd)
    np.testing.assert_allclose(np.sort(np.abs(b.multipliers[-1])), np.sort(np.abs(lam_fd)),
                               atol=1e-6)
    assert b.neutral.tolist() == [1] * len(b.value)   # the free energy level, everywhere
    assert b.theta2_pinned        # held by the phase condition, to the corrector's tolerance
    np.testing.assert_allclose(b.theta2, two_step_point[0], rtol=0, atol=1e-10)
    assert b.stable[0] == 1 and b.stable[-1] == 0
    assert len(b.through_plus_one) == 1               # stability is lost through +1
    i = b.through_plus_one[0]
    assert np.abs(b.multipliers[i - 1]).max() < 1.0 + 1e-6 < np.abs(b.multipliers[i]).max()


def test_branch_stops_at_a_border_where_the_event_sequence_changes():
    """The two-swing gait's torque branch ends where the first swing's return to the
    vertical becomes a tangency: just beyond it, link 1 recrosses theta1 = 0 at once."""
    g = two_swing()
    fmap = partial(cycle_return_map, gait=g, robot="seed2009", integrator=INTEG)
    fp = solve_fixed_point(fmap, np.array([0.0, -2.23093117, 19.27909023]), jacobian=lambda q:
                           sequence_variational_jacobian(g, q, robot="seed2009",
                                                         integrator=INTEG))
    assert fp.converged
    b = continue_cycle(g, fp.z, "torque", robot="seed2009", integrator=INTEG, ds=0.3,
                       steps=40)
    assert b.stop_reason == "border"
    assert 0.80 < b.value[-1] < 0.86
    last = dataclasses.replace(g, theta2=b.theta2[-1])

    def seg_times(mu, d1, d2):
        rb, gg = with_parameter("seed2009", last, "torque", mu)
        return evaluate_cycle_gaits(np.array([[d1, d2]]), gg, robot=rb,
                                    integrator=INTEG)["t_segment"][0]

    t_here = seg_times(b.value[-1], b.dtheta1[-1], b.dtheta2[-1])
    # a little further along the branch's direction the second segment ends within a
    # fraction of the first swing instead of a whole swing later
    d = np.array([b.dtheta1[-1] - b.dtheta1[-2], b.dtheta2[-1] - b.dtheta2[-2],
                  b.value[-1] - b.value[-2]])
    d /= np.linalg.norm(d)
    jumped = False
    for h in (0.005, 0.01, 0.02, 0.04):
        u = np.array([b.dtheta1[-1], b.dtheta2[-1], b.value[-1]]) + h * d
        t = seg_times(u[2], u[0], u[1])
        if t[1] - t[0] < 0.5 * (t_here[1] - t_here[0]):
            jumped = True
            break
    assert jumped


def test_refuses_what_it_cannot_continue(two_step_point):
    z = two_step_point
    with pytest.raises(ValueError, match="not a fixed point"):
        continue_cycle(two_step(), z + np.array([0.0, 1e-3, 0.0]), "torque",
                       integrator=INTEG, steps=1)
    with pytest.raises(ValueError, match="parameter must be one of"):
        continue_cycle(two_step(), z, "links", integrator=INTEG)
    with pytest.raises(ValueError, match="non-zero"):
        continue_cycle(two_step(), z, "torque", integrator=INTEG, ds=0.0)
    assert math.isclose(parameter_of("seed2009", two_step(), "gravity"), 9.81)


def test_an_isolated_fixed_point_is_continued_with_theta2_free():
    """Topping the energy up to an absolute level (not a latched one) leaves no neutral
    multiplier: the fixed point is isolated, theta2 moves along the branch. In joint friction,
    which starts at its floor 0 (one-sided differences there)."""
    from monkeystudy.kernel.dynamics import kinetic_energy, potential_energy

    par = Robot.preset("seed2009").params()[0]
    level = (kinetic_energy(par, 0.0, 0.0, 0.0, 0.0, 0.7423135, 11.1626225)
             + potential_energy(par, 0.0, 0.0, 0.0))
    g = SequenceGait([Segment("free_end_height", 0.0, direction="rising"),
                      Segment("energy", float(level), direction="rising", magnets="swap",
                              torque=TORQUE)], theta2=0.0)
    fmap = partial(cycle_return_map, gait=g, robot="seed2009", integrator=INTEG)
    fp = solve_fixed_point(fmap, np.array([0.0, 0.7423135, 11.1626225]), jacobian=lambda q:
                           sequence_variational_jacobian(g, q, robot="seed2009",
                                                         integrator=INTEG))
    assert fp.converged
    b = continue_cycle(g, fp.z, "joint_viscous", robot="seed2009", integrator=INTEG,
                       ds=0.02, steps=2)
    assert not b.theta2_pinned and b.neutral.tolist() == [0, 0, 0]
    assert b.value[0] == 0.0 and np.all(b.value[1:] > 0.0)
    assert abs(b.theta2[-1] - b.theta2[0]) > 1e-3
    for i in range(len(b.value)):
        rb, gi = with_parameter("seed2009", g, "joint_viscous", b.value[i])
        z = np.array([b.theta2[i], b.dtheta1[i], b.dtheta2[i]])
        assert residual(gi, z, rb) < 1e-10


# --- friction and a latched energy -------------------------------------------------------------
@pytest.mark.parametrize("parameter", ["joint_viscous", "pivot_viscous"])
def test_friction_has_no_branch_through_a_latched_energys_family(two_step_point, parameter):
    """The two-step gait restores the energy it latched: its fixed points are a family (one
    multiplier 1). Friction breaks that family (next test): the start is the only fixed point
    near friction 0, and the continuation says so at once, either way."""
    b = continue_cycle(two_step(), two_step_point, parameter, integrator=INTEG, ds=0.01,
                       steps=5)
    assert b.theta2_pinned
    assert b.stop_reason == "no_branch", (b.stop_reason, b.value)
    assert b.value.tolist() == [0.0] and b.residual[0] < 1e-10
    assert "section's energy by -" in b.stop_detail and parameter in b.stop_detail
    down = continue_cycle(two_step(), two_step_point, parameter, integrator=INTEG, ds=-0.01,
                          steps=5)
    assert down.stop_reason == "bounds" and down.value.tolist() == [0.0]


def test_a_latched_energy_loses_what_friction_takes_after_the_motor(two_step_point):
    """Why friction leaves the two-step gait no fixed point: its motor restores the energy
    latched at the cycle's start (row 0) and again at the second swing's (row 3); the
    friction work while the motor is off after each restore (rows 2 and 5: from the first
    restore to the second latch, from the second restore to the section) is never restored.
    The section's energy falls by exactly that work, linearly in the friction, and a fixed
    point would return to its energy. An independent Newton solve (theta2 free) at that
    friction finds none, and the continuation's energy rate is the same loss."""
    from monkeystudy.analysis import cycle_map_error, cycle_section_state
    from monkeystudy.simulation import simulate

    start = two_step_point
    losses = []
    for mu in (1e-5, 2e-5):
        rb, g = with_parameter("seed2009", two_step(), "joint_viscous", mu)
        run = simulate(g.controller(), robot=rb, state=cycle_section_state(g, start),
                       cycles=1, sample_dt=1e-5, integrator=INTEG)
        assert run.attrs["status"] == "ok"
        t, w2, row = run["time"].values, run["theta2_dot"].values, run["segment"].values
        energy = run["total_energy"].values
        power = mu * w2 ** 2                    # the joint's viscous torque -mu dtheta2
        same = (row[1:] == row[:-1]) & np.isin(row[1:], (2, 5))
        work_after_restores = float(np.sum((0.5 * (power[1:] + power[:-1]) * np.diff(t))[same]))
        loss = float(energy[0] - energy[-1])
        assert loss == pytest.approx(work_after_restores, rel=1e-3)
        losses.append(loss)
    assert losses[1] == pytest.approx(2 * losses[0], rel=1e-2)
    # no fixed point at mu = 2e-5: Newton stalls far above the map's error
    fmap = partial(cycle_return_map, gait=g, robot=rb, integrator=INTEG)
    fp = solve_fixed_point(fmap, start, map_error=cycle_map_error(start, g, robot=rb,
                                                                   integrator=INTEG),
                           jacobian=lambda q: sequence_variational_jacobian(
                               g, q, robot=rb, integrator=INTEG))
    assert not fp.converged and fp.defect > 1e-6, fp.message
    # the continuation's rate [J per N m s] is this loss per unit of friction
    b = continue_cycle(two_step(), start, "joint_viscous", integrator=INTEG, ds=0.01, steps=1)
    rate = float(re.search(r"energy by (\S+) J per N m s", b.stop_detail).group(1))
    assert rate == pytest.approx(-losses[0] / 1e-5, rel=2e-2)


# --- a link's own parameters: the cycle of two steps ---------------------------------------------
def uneven_robot() -> Robot:
    """seed2009 with links that differ: link 1's CG 2 % farther from A, link 2 3 % lighter."""
    r = Robot.preset("seed2009")
    return dataclasses.replace(r, link1=dataclasses.replace(r.link1, com=r.link1.com * 1.02),
                               link2=dataclasses.replace(r.link2, mass=r.link2.mass * 0.97))


@pytest.mark.parametrize("catch", ["swap", "B"])
def test_the_two_step_cycle_is_two_cycles_of_the_gait(catch):
    """On links that differ, one cycle of the two-step cycle ends where two looped cycles of
    the gait end (the kernel's own loop: mirror image, section row, staircase), hanging from
    A two rises down; a gait whose cycle ends on A is its own. A catch written as "B on"
    (not "swap") is "A on" in the second step, as in the looped run."""
    from monkeystudy.analysis import cycle_section_state
    from monkeystudy.analysis.continuation import two_step_cycle
    from monkeystudy.simulation import run_controller

    g = descending()
    segs = list(g.segments)
    segs[2] = dataclasses.replace(segs[2], magnets=catch)
    g = dataclasses.replace(g, segments=tuple(segs))
    g2 = two_step_cycle(g)
    assert g2.segments[-1].magnets == {"swap": "swap", "B": "A"}[catch]
    assert g.end_attached() == "B" and g2.end_attached() == "A"
    assert g2.rise == 2 * g.rise and len(g2.segments) == 2 * len(g.segments) + 1
    assert [s.value for s in g2.segments if s.until == "free_end_y"] == [-0.1, -0.2]
    robot = uneven_robot()
    start = cycle_section_state(g, Z_DESCENDING)
    looped = run_controller(g.loop_controller(), start, robot=robot, integrator=INTEG,
                            cycles=2)
    doubled = run_controller(g2.controller(), start, robot=robot, integrator=INTEG, cycles=1)
    assert looped.status == 0 and doubled.status == 0
    assert np.abs(doubled.state[:8] - looped.state[:8]).max() < 1e-9
    assert abs(doubled.state[1] - (-0.2)) < 1e-9      # hanging from A two steps down
    assert two_step_cycle(g2) is g2


def test_the_two_step_cycles_multipliers_are_the_squares_of_one_steps():
    """On mirror-image links the two-step cycle has the gait's fixed point, and its
    multipliers (variational equations) are the squares of one step's."""
    from monkeystudy.analysis.continuation import two_step_cycle

    g = descending()
    g2 = two_step_cycle(g)
    assert residual(g2, Z_DESCENDING, "seed2009") < 1e-10
    lam1 = np.linalg.eigvals(sequence_variational_jacobian(g, Z_DESCENDING, robot="seed2009",
                                                           integrator=INTEG))
    lam2 = np.linalg.eigvals(sequence_variational_jacobian(g2, Z_DESCENDING, robot="seed2009",
                                                           integrator=INTEG))
    assert np.sort_complex(lam2) == pytest.approx(np.sort_complex(lam1 ** 2), abs=1e-7)


def test_a_links_own_parameter_continues_the_two_step_cycle():
    """Continuation in link 1's CG: each branch point is a fixed point of the two-step cycle
    on a robot built with that CG (link 2 as it was), and the start's multipliers are one
    step's squared."""
    from monkeystudy.analysis.continuation import two_step_cycle

    g = descending()
    base = Robot.preset("seed2009")
    assert parameter_of(base, g, "link1_com") == base.link1.com
    b = continue_cycle(g, Z_DESCENDING, "link1_com", robot=base, integrator=INTEG, ds=0.05,
                       steps=3)
    assert len(b.value) == 4 and np.all(np.diff(b.value) > 0) and b.value[-1] > base.link1.com
    g2 = two_step_cycle(g)
    for i in range(len(b.value)):
        built = dataclasses.replace(base, link1=dataclasses.replace(base.link1,
                                                                    com=b.value[i]))
        z = np.array([b.theta2[i], b.dtheta1[i], b.dtheta2[i]])
        assert residual(g2, z, built) < 1e-9
        rb, _ = with_parameter(base, g, "link1_com", b.value[i])
        assert rb.link1.com == b.value[i] and rb.link2 == base.link2
    lam1 = np.linalg.eigvals(sequence_variational_jacobian(g, Z_DESCENDING, robot=base,
                                                           integrator=INTEG))
    assert np.sort_complex(b.multipliers[0]) == pytest.approx(np.sort_complex(lam1 ** 2),
                                                              abs=1e-7)
