"""Per-brachiation measures (monkeystudy.analysis.brachiation): the integrals on synthetic
series with known answers, the catch velocity against a finite difference of the kernel's
free end, the logs' brachiations, and the nominal trajectories open loop."""
from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from monkeystudy.analysis.brachiation import (
    ACROMONK_TRAJECTORIES, GAP_THRESHOLD, IDENTIFIED, NOMINAL_TRAJECTORIES, at_elbow,
    capture_radius, closed_chain, comparison, free_end_velocity, gait_brachiations,
    log_brachiations, measures, nominal_trajectory, open_loop, positive_work,
    positive_work_held, read_trajectory, torque_square_integral,
)
from monkeystudy.analysis.measured_replay import ModelSwing, acromonk_robot, free_end, replay
from monkeystudy.measured import (CATCH, RELEASE, SHIPPED_LOGS, SWING, log_paths, read_log,
                                  swings)

from toolmodules import load_tool


@pytest.fixture(scope="module")
def robot():
    return acromonk_robot()


def series(t, torque, rate, *, flipped=0, theta=(0.3, 1.0)):
    t = np.asarray(t, float)
    n = t.size
    return ModelSwing(time=t, theta1=np.full(n, theta[0]), theta2=np.full(n, theta[1]),
                      theta1_rate=np.zeros(n), theta2_rate=np.asarray(rate, float) * np.ones(n),
                      torque=np.asarray(torque, float) * np.ones(n), flipped=flipped,
                      name="synthetic")


IRREGULAR = np.cumsum(np.r_[0.0, np.random.default_rng(42).uniform(0.002, 0.02, 200)])


# --- the integrals --------------------------------------------------------------------------
def test_constant_torque_and_rate_give_exact_work_and_torque_square(robot):
    """tau = 1.5 N m, rate 2 rad/s on irregular samples over T: work 3 T, ∫tau² 2.25 T."""
    T = IRREGULAR[-1] - IRREGULAR[0]
    m = measures(robot, series(IRREGULAR, 1.5, 2.0))
    assert m.positive_work == pytest.approx(3.0 * T, rel=1e-13)
    assert m.torque_square == pytest.approx(2.25 * T, rel=1e-13)
    assert m.peak_torque == 1.5 and m.duration == pytest.approx(T, rel=1e-15)
    # the motor brakes throughout: no positive work, the same loss proxy, the same peak
    m = measures(robot, series(IRREGULAR, -1.5, 2.0))
    assert m.positive_work == 0.0
    assert m.torque_square == pytest.approx(2.25 * T, rel=1e-13)
    assert m.peak_torque == 1.5


def test_a_sign_change_counts_only_the_positive_part():
    """Power p(t) = t - 1 on [0, 3] (tau = p, rate 1): positive work ∫_1^3 (t - 1) dt = 2 J,
    whatever the samples, also with the sign change inside an interval (0.5 .. 1.7 s);
    clipping the samples before the trapezoid would count 0.42 J there instead of 0.245."""
    for t in (np.array([0.0, 0.5, 1.7, 3.0]), np.linspace(0.0, 3.0, 7), IRREGULAR * 3.0 /
              IRREGULAR[-1]):
        assert positive_work(t, t - 1.0, np.ones_like(t)) == pytest.approx(2.0, rel=1e-12)
    t = np.array([0.5, 1.7])
    assert positive_work(t, t - 1.0, np.ones(2)) == pytest.approx(0.7 ** 2 / 2.4 * 1.2,
                                                                   rel=1e-14)


def test_irregular_sampling_is_integrated_as_it_comes_and_a_gap_is_flagged(robot):
    """∫tau² of tau linear in t is the trapezoid of tau² on the samples (stated, not hidden:
    the exact ∫ t² dt over [0, 1] is 1/3, the two-interval trapezoid over 0, 0.8, 1 gives
    0.8 * 0.32 + 0.2 * 0.82 = 0.42); an interval above the threshold flags the brachiation."""
    t = np.array([0.0, 0.8, 1.0])
    assert torque_square_integral(t, t) == pytest.approx(0.42, rel=1e-14)
    gapped = np.r_[IRREGULAR, IRREGULAR[-1] + 0.2, IRREGULAR[-1] + 0.21]
    m = measures(robot, series(gapped, 1.0, 1.0))
    assert m.largest_gap == pytest.approx(0.2, rel=1e-12) and m.gapped
    m = measures(robot, series(IRREGULAR, 1.0, 1.0))
    assert m.largest_gap < GAP_THRESHOLD and not m.gapped


# --- the catch velocity ------------------------------------------------------------------
@pytest.mark.parametrize("flipped", [0, 1])
def test_the_free_end_velocity_is_the_derivative_of_the_kernels_free_end(robot, flipped):
    """On a simulated swing (the BF plan open loop on the identified model, in either
    parameter row) the free end's velocity from the simulated angles and rates agrees with
    a central difference of the kernel's free-end positions at the 1 ms samples, to the
    difference's own error (O(h²) of the free end's third derivative: seen ~1e-5 m/s)."""
    plan = replace(nominal_trajectory("BF"), flipped=flipped)
    ol = open_loop(IDENTIFIED.robot(robot), plan)
    rep = replay(IDENTIFIED.robot(robot), plan, 0, plan.duration)
    pos, vel = free_end_velocity(robot, rep.simulated[:, 0], rep.simulated[:, 1],
                                 rep.simulated_rates[:, 0], rep.simulated_rates[:, 1], flipped)
    np.testing.assert_allclose(pos, ol.free_end, atol=1e-15)
    h = np.diff(rep.time)
    assert np.allclose(h, 1e-3, rtol=1e-2)
    fd = (pos[2:] - pos[:-2]) / (rep.time[2:] - rep.time[:-2])[:, None]
    speed = np.abs(vel[1:-1]).max()
    assert speed > 0.5
    assert np.abs(fd - vel[1:-1]).max() < 1e-3 * speed


def test_the_catch_is_the_last_sample_and_its_direction_is_measured_from_onward(robot):
    """At the last sample of a series the catch speed is |v| and its angle below the
    horizontal counts from the direction away from the held end (0: onward, pi/2: down)."""
    plan = nominal_trajectory("BF")
    m = measures(robot, plan)
    pos, vel = free_end_velocity(robot, plan.theta1[-1:], plan.theta2[-1:],
                                 plan.theta1_rate[-1:], plan.theta2_rate[-1:], 0)
    assert m.catch_speed == pytest.approx(float(np.hypot(*vel[0])), rel=1e-15)
    assert pos[0, 0] > 0
    assert m.catch_angle == pytest.approx(math.atan2(-vel[0, 1], vel[0, 0]), rel=1e-15)
    fb = nominal_trajectory("FB")                 # travels the other way: x < 0
    m = measures(robot, fb)
    pos, vel = free_end_velocity(robot, fb.theta1[-1:], fb.theta2[-1:], fb.theta1_rate[-1:],
                                 fb.theta2_rate[-1:], 0)
    assert pos[0, 0] < 0
    assert m.catch_angle == pytest.approx(math.atan2(-vel[0, 1], -vel[0, 0]), rel=1e-15)


# --- the logs ---------------------------------------------------------------------------------
def test_a_flagged_brachiation_runs_from_the_release_to_the_first_catch_row():
    log = read_log(SHIPPED_LOGS / "BF_pd_5x.csv.gz")
    found = log_brachiations(log)
    bare = log_brachiations(log, with_release=False)
    assert len(found) == len(bare) == 5
    for b, nb, sw in zip(found, bare, swings(log)):
        start = sw.start - (len(b) - len(nb))
        assert log.phase[start] == RELEASE and log.phase[start - 1] != RELEASE
        assert np.all(log.phase[start:sw.start] == RELEASE)
        assert np.all(log.phase[sw.start:sw.stop] == SWING) and log.phase[sw.stop] == CATCH
        assert len(nb) == sw.stop - sw.start + 1       # the catch row included
        assert b.time[-1] == pytest.approx(log.time[sw.stop] - log.time[start], abs=1e-12)
    # the frame's sign flips with the holding hook; the power does not
    assert [b.flipped for b in found] == [0, 1, 0, 1, 0]


def test_a_log_that_ends_with_its_trajectory_ends_its_brachiation_at_its_last_row():
    log = read_log(SHIPPED_LOGS / "FB_pd_1x_.csv.gz")
    (b,) = log_brachiations(log)
    (sw,) = swings(log)
    assert sw.stop == len(log) and len(b) == len(log) - sw.start


# --- the nominal trajectories open loop ------------------------------------------------------
def initial_acceleration(robot, plan):
    """The open loop's acceleration at its start [rad s-2] from its angles at the plan's
    next two samples (h1, h2 about 1 and 2 ms): d(h) = a h²/2 + j h³/6 + O(h⁴), solved for
    a and j, leaves an O(h²) error in a."""
    q0 = np.array([plan.theta1[0], plan.theta2[0]])
    w0 = np.array([plan.theta1_rate[0], plan.theta2_rate[0]])
    hs = plan.time[1:3] - plan.time[0]
    d = np.array([open_loop(robot, plan, horizon=h).final_state[:2] - q0 - w0 * h
                  for h in hs])
    A = np.array([[h * h / 2, h ** 3 / 6] for h in hs])
    return np.linalg.solve(A, d)[0]


@pytest.mark.parametrize("name", NOMINAL_TRAJECTORIES)
def test_the_open_loop_on_the_plans_own_model_starts_with_the_plans_acceleration(robot, name):
    """A plan's first row is a collocation knot, where the plan's acceleration is the URDF
    model's at its state and torque (tests/test_urdf.py: to 1e-9). The open loop on that
    model (acromonk_robot, frictionless, no rotor) starts with it: the acceleration from its
    angles at about 1 and 2 ms agrees to 1e-2 relative (seen: 5e-4 - 5e-3; the estimate's
    O(h²) error and the held torque's half-sample steps over those two samples), while the
    identified model (rotor, friction) differs by 10-66 %."""
    plan = nominal_trajectory(name)
    cols = read_trajectory(ACROMONK_TRAJECTORIES / name / f"{name}_traj.csv.gz")
    want = np.array([cols["shoulder_acc"][0], cols["elbow_acc"][0]])
    got = initial_acceleration(robot, plan)
    assert np.abs(got - want).max() < 1e-2 * np.abs(want).max()
    other = initial_acceleration(IDENTIFIED.robot(robot), plan)
    assert np.abs(other - want).max() > 5e-2 * np.abs(want).max()


def test_the_open_loop_compares_the_free_end_with_the_plans(robot):
    """The whole BF plan on its own model: the free end at the plan's final time within a
    few centimetres of the plan's (the spline is the model's solution only at its knots and
    midpoints), and the plan's own closest approach to the bar 0.34 m ahead is the distance
    of its final free end (0.361 m, 2 mm up)."""
    plan = nominal_trajectory("BF")
    ol = open_loop(robot, plan)
    _, _, end = free_end(robot, plan.theta1[-1], plan.theta2[-1], 0)
    assert ol.target == (0.34, 0.0)
    assert ol.planned_closest <= math.hypot(end[0, 0] - 0.34, end[0, 1]) + 1e-15
    assert ol.final_miss == pytest.approx(float(np.hypot(*(ol.free_end[-1] - end[0]))),
                                          rel=1e-12)
    assert ol.time[-1] == pytest.approx(plan.time[-1], abs=1e-12)


def test_the_closed_chain_puts_the_free_end_on_the_next_bar(robot):
    """Both hooks on bars 0.34 m apart: the kernel's free end at (0.34, 0) from the held end,
    and the URDF angles are the model's through the URDF's angle map (theta1 = q1 - 0.0636)."""
    th1, th2, q1, q2 = closed_chain(robot)
    _, _, end = free_end(robot, th1, th2, 0)
    np.testing.assert_allclose(end[0], [0.34, 0.0], atol=1e-14)
    assert q2 == th2 and q1 - th1 == pytest.approx(math.atan2(0.02, 0.31401), abs=1e-5)


def test_the_capture_radius_needs_a_flagged_log(robot):
    with pytest.raises(ValueError, match="no flagged log"):
        capture_radius(robot, [read_log(SHIPPED_LOGS / "ZF_pd_1x.csv.gz")])


# --- a held torque (a simulated gait) ---------------------------------------------------------
@pytest.mark.parametrize("tau, rise", [(1.2, 3.0), (-1.2, 2.0)])
def test_a_held_torque_does_the_work_of_the_angle_it_turns(tau, rise):
    """theta2 = sin(w t) over 1.25 periods: it rises 0 -> 1, falls to -1, rises to 1 (a total
    rise of 3, a fall of 2). A constant torque's positive work is |tau| times the rise (tau >
    0) or the fall (tau < 0), the turning points inside the sampling intervals."""
    w = 2.0 * math.pi / 0.8
    t = np.sort(np.r_[0.0, 1.0, np.random.default_rng(7).uniform(0.0, 1.0, 400)])
    work = positive_work_held(t, np.full(t.size, tau), np.sin(w * t), w * np.cos(w * t))
    assert work == pytest.approx(abs(tau) * rise, rel=1e-9)


def test_a_held_torque_changes_at_a_repeated_sample():
    """tau 1 N m for 1 s, then -2 N m for 1 s (the change at a repeated sample, as a
    simulation writes a segment's exit), theta2 = t: work 1 J, int tau2 1 + 4 = 5 N2 m2 s."""
    t = np.r_[np.linspace(0.0, 1.0, 11), np.linspace(1.0, 2.0, 11)]
    tau = np.r_[np.full(11, 1.0), np.full(11, -2.0)]
    assert positive_work_held(t, tau, t, np.ones(t.size)) == pytest.approx(1.0, rel=1e-14)
    assert torque_square_integral(t, tau) == pytest.approx(5.0, rel=1e-14)
    with pytest.raises(ValueError, match="not held"):
        positive_work_held(t[[0, 10, 12]], tau[[0, 10, 12]], t[[0, 10, 12]], np.ones(3))


def test_the_logs_at_the_elbow_scale_the_torque_measures_only(robot):
    m = measures(robot, series(IRREGULAR, 1.5, 2.0))
    e = at_elbow(m, 0.8)
    assert (e.positive_work, e.torque_square, e.peak_torque) == pytest.approx(
        (0.8 * m.positive_work, 0.64 * m.torque_square, 0.8 * m.peak_torque), rel=1e-15)
    assert (e.duration, e.catch_speed) == (m.duration, m.catch_speed)


@pytest.fixture(scope="module")
def designed():
    return load_tool("acromonk_brachiation").designed_gait()


def test_the_designed_gaits_brachiations_run_from_catch_to_catch(designed):
    """The two brachiations of studies/acromonk_gait.yaml: together one period; each ends at a
    catch with the hook's speed the section analysis finds; int tau2 is sum tau_k^2 dt_k over
    the segments' exit times; the positive work does not depend on the sampling."""
    from monkeystudy.analysis.sections import cycle_catches
    from monkeystudy.simulation import run_controller
    from monkeystudy.analysis.sections import cycle_section_state
    g = designed
    halves = gait_brachiations(g)
    ms = [measures(g.robot, b, held=True) for b in halves]
    assert [b.name for b in halves] == ["acromonk_gait: B holds", "acromonk_gait: A holds"]
    res = run_controller(g.gait.controller(), cycle_section_state(g.gait, g.section_state),
                         robot=g.robot, integrator=g.integrator, cycles=1, sample_dt=0.0)
    ends = res.segment_times               # the exits of segments 0..5 (5: the section)
    period = ends[-1]
    assert sum(m.duration for m in ms) == pytest.approx(period, rel=1e-12)
    # B holds from the catch ending segment 3 to the one ending segment 0 of the next cycle
    assert ms[0].duration == pytest.approx(ends[3] - ends[0], rel=1e-12)
    cc = cycle_catches(g.section_state, g.gait, robot=g.robot, integrator=g.integrator)
    np.testing.assert_allclose([m.catch_speed for m in ms], cc.speed[::-1], rtol=1e-9)
    taus = [s.torque for s in g.gait.segments] + [g.gait.section_torque]
    durations = np.diff(np.r_[0.0, ends])
    B = [1, 2, 3]                           # the segments from B's catch to A's
    assert ms[0].torque_square == pytest.approx(
        sum(taus[k] ** 2 * durations[k] for k in B), rel=1e-10)
    assert ms[1].torque_square == pytest.approx(
        sum(taus[k] ** 2 * durations[k] for k in (0, 4, 5)), rel=1e-10)
    fine = [measures(g.robot, b, held=True) for b in gait_brachiations(g, sample_dt=2.5e-4)]
    for a, b in zip(ms, fine):
        assert a.positive_work == pytest.approx(b.positive_work, rel=1e-9)
        assert a.positive_work > 0.0


# --- the documented numbers ---------------------------------------------------------------------
DOC = Path(__file__).resolve().parents[2] / "docs" / "acromonk.md"


def test_the_identified_values_are_the_ones_the_docs_quote():
    """IDENTIFIED holds the study's identified model as docs/acromonk.md quotes it from
    ``monkeystudy inspect outputs/acromonk``."""
    text = " ".join(DOC.read_text().split())
    assert (f"pivot Coulomb {IDENTIFIED.pivot.coulomb} N m" in text
            and f"joint viscous {IDENTIFIED.joint.viscous} N m s" in text
            and f"rotor inertia {IDENTIFIED.rotor_inertia:.7f} kg m2" in text
            and f"torque scale {IDENTIFIED.torque_scale} " in text)
    assert IDENTIFIED.pivot.viscous == IDENTIFIED.joint.coulomb == 0.0


def test_the_docs_table_is_what_the_tool_prints():
    """docs/acromonk.md, "Brachiations measured", quotes tools/acromonk_brachiation.py's
    output exactly (the shipped logs, the four plans)."""
    text = DOC.read_text()
    section = text[text.index("## Brachiations measured"):]
    start = section.index("```text\n") + len("```text\n")
    quoted = section[start:section.index("```", start)].rstrip("\n")
    logs = [read_log(p) for p in log_paths(SHIPPED_LOGS)]
    assert quoted == comparison(logs, gait=load_tool("acromonk_brachiation").designed_gait())
