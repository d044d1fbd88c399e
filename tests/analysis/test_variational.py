"""Generic variational Jacobian of sequence-gait return maps (monkeystudy.analysis.variational).

Every case compares the variational Jacobian with fourth-order central differences of the
return map itself (:func:`~monkeystudy.analysis.jacobian_fd`, step 1e-5), in the relative
Frobenius norm ``|J - J_fd| / |J_fd|``; the differences are limited by the finite differences
(``~1e-13 / 1e-5`` of round-off in the map), so they are asserted below 1e-8. The horizontal
gait's two controllers by name (:func:`~monkeystudy.analysis.variational_jacobian`) are the
same Jacobian of :func:`~monkeystudy.controllers.horizontal_gait` and of its open-loop replay.
The measured values at the time of writing are noted beside each assertion.
"""

import re

import numpy as np
import pytest

from monkeystudy import Status
from monkeystudy.analysis import (
    TIGHT, cycle_full_map, cycle_return_map, cycle_section_state, jacobian_fd,
    shoot_grazing, variational_jacobian,
)
from monkeystudy.controllers import SequenceGait, Segment, horizontal_gait
from monkeystudy.kernel import layout as L
from monkeystudy.robot import Friction, Link, Robot
from monkeystudy.analysis.variational import sequence_variational_jacobian
from monkeystudy.simulation import run_controller

TORQUE = 0.6354
#: near the state-based controller's attracting gait (tests/analysis/test_analysis.py)
Z_SEARCH = np.array([0.02475681, -1.08686037, 16.0167845])
SEARCH = SequenceGait([
    Segment("free_end_height", direction="rising", latch_energy=True),
    Segment("energy_restored", direction="rising", magnets="swap", torque=TORQUE),
], section_theta1=0.0, section_direction="either")
#: links that are not mirror images: the frame's parameter row changes at every flip
ASYMMETRIC = Robot(Link(1.2, 0.6, 0.5, 0.02), Link(0.8, 0.55, 0.08, 0.015), name="asym")
FD_RTOL = 1e-8


def rel(a, b):
    return float(np.linalg.norm(a - b) / np.linalg.norm(b))


def fd(gait, z, robot="seed2009", step=1e-5):
    return jacobian_fd(lambda q: cycle_return_map(q, gait, robot=robot), z, step)


def kernel_log(gait, z, robot="seed2009"):
    res = run_controller(gait.controller(), cycle_section_state(gait, z), robot=robot,
                         integrator=TIGHT, cycles=1)
    assert res.status == Status.OK
    return res


# ------------------------------------------------------------------------------------------
# the compiled helpers against the simulator's own functions
# ------------------------------------------------------------------------------------------
def test_kernel_helpers_agree_with_the_simulator():
    from monkeystudy.kernel.dynamics import pack, rhs, total_energy8
    from monkeystudy.kernel.events import guard
    from monkeystudy.kernel.hybrid import apply_magnets
    from monkeystudy.kernel.variational import (
        energy8_gradient, entry_reset, field8, field8_jacobian, guard8, guard8_gradient,
    )

    from monkeystudy.kernel.dynamics import holding_torque
    from monkeystudy.kernel.variational import holding_torque8, holding_torque8_gradient

    par = ASYMMETRIC.with_friction(Friction(0.02, 0.3), Friction(0.01, 0.2)).params()
    rng = np.random.default_rng(1)
    for phase in (L.PHASE_SWING, L.PHASE_FLIGHT):
        for fm in ([1.0, 1.0], [-1.0, 0.0], [0.0, -1.0], [0.0, 0.0], [1.0, -1.0]):
            fm = np.array(fm)
            s = rng.normal(size=8) * [1, 1, 1, 1, 2, 2, 5, 5]
            if phase == L.PHASE_SWING:
                s[L.DX] = s[L.DY] = 0.0
            p, tau = par[rng.integers(2)], rng.normal()
            y = np.empty(8)
            n = pack(phase, s, y)
            dy = np.empty(8)
            rhs(phase, p, tau, fm, y[:n], dy[:n])
            f = np.empty(8)
            field8(phase, p, tau, fm, s, f)
            packed = np.empty(8)
            pack(phase, f, packed)
            np.testing.assert_array_equal(packed[:n], dy[:n])
            # field Jacobian against central differences
            A = np.empty((8, 8))
            field8_jacobian(phase, p, tau, fm, s, A)
            Af = np.empty((8, 8))
            for j in range(8):
                e = np.zeros(8)
                e[j] = 1e-6
                fp, fmn = np.empty(8), np.empty(8)
                field8(phase, p, tau, fm, s + e, fp)
                field8(phase, p, tau, fm, s - e, fmn)
                Af[:, j] = (fp - fmn) / 2e-6
            assert np.abs(A - Af).max() <= 1e-6 * (1 + np.abs(A).max())
            # guards as the simulator evaluates them, and their gradients
            for kind, index in ((L.G_FREE_END_HEIGHT, 0), (L.G_ENERGY_RESTORED, 0),
                                (L.G_ENERGY, 0), (L.G_FREE_END_Y, 0), (L.G_COORD, 2),
                                (L.G_COORD, 7)):
                g_sim = guard(kind, index, 0.3, phase, p, tau, fm, y, s[:2].copy(), -1.5)
                assert guard8(kind, index, 0.3, p, s, -1.5) == pytest.approx(g_sim, abs=1e-14)
                grad = np.empty(8)
                guard8_gradient(kind, index, 0.3, p, s, -1.5, grad)
                for j in range(8):
                    e = np.zeros(8)
                    e[j] = 1e-6
                    gfd = (guard8(kind, index, 0.3, p, s + e, -1.5)
                           - guard8(kind, index, 0.3, p, s - e, -1.5)) / 2e-6
                    assert grad[j] == pytest.approx(gfd, rel=1e-7, abs=1e-7)
            # the holding torque (the break-away guard) and its gradient
            for k in (0, 1):
                hold = holding_torque8(phase, p, tau, fm, s, k)
                assert hold == holding_torque(phase, p, tau, fm, y[:n].copy(), k)
                grad = np.empty(8)
                holding_torque8_gradient(phase, p, tau, fm, s, k, grad)
                for j in range(8):
                    e = np.zeros(8)
                    e[j] = 1e-6
                    hfd = (holding_torque8(phase, p, tau, fm, s + e, k)
                           - holding_torque8(phase, p, tau, fm, s - e, k)) / 2e-6
                    assert grad[j] == pytest.approx(hfd, rel=1e-7, abs=1e-7)
            gE = np.empty(8)
            energy8_gradient(p, s, gE)
            e = np.zeros(8)
            e[L.DTH2] = 1e-6
            assert gE[L.DTH2] == pytest.approx(
                (total_energy8(p, s + e) - total_energy8(p, s - e)) / 2e-6, rel=1e-7)
    # entry actions: exactly the simulator's, from every phase
    out, DR = np.empty(8), np.empty((8, 8))
    for phase in (L.PHASE_SWING, L.PHASE_FLIGHT, L.PHASE_FIXED):
        for flipped in (0, 1):
            for mags in ((-1, -1, False), (-1, -1, True), (1, 0, False), (0, 1, False),
                         (1, 1, False), (0, 0, False)):
                s = rng.normal(size=8)
                ref = s.copy()
                ph_ref, fl_ref = apply_magnets(par, ref, phase, flipped, *mags)
                ph, fl = entry_reset(par, s, phase, flipped, *mags, out, DR)
                assert (ph, fl) == (ph_ref, fl_ref)
                np.testing.assert_array_equal(out, ref)
                for j in range(8):
                    e = np.zeros(8)
                    e[j] = 1e-7
                    a, b = s + e, s - e
                    apply_magnets(par, a, phase, flipped, *mags)
                    apply_magnets(par, b, phase, flipped, *mags)
                    np.testing.assert_allclose(DR[:, j], (a - b) / 2e-7, rtol=1e-6,
                                               atol=1e-7)


# ------------------------------------------------------------------------------------------
# the study's controllers: the horizontal gait by name, and finite differences
# ------------------------------------------------------------------------------------------
def test_search_controller_matches_fd():
    J = variational_jacobian("search", Z_SEARCH)
    # by name, the horizontal gait's own controller: the Jacobian of its preset
    assert J.tobytes() == sequence_variational_jacobian(horizontal_gait(TORQUE),
                                                        Z_SEARCH).tobytes()
    assert rel(J, fd(SEARCH, Z_SEARCH)) < FD_RTOL                      # measured 1.3e-9
    # the finite differences, not the variational Jacobian, limit the agreement: a larger
    # step (less round-off in the difference) agrees better
    assert rel(J, fd(SEARCH, Z_SEARCH, step=1e-4)) < 1e-9              # measured 1.0e-10


def search_times(z):
    t = kernel_log(SEARCH, z).segment_times
    return t[0], t[1] - t[0]


def test_open_loop_replay_matches_fd():
    t_sw, t_mot = search_times(Z_SEARCH)
    gait = SequenceGait([Segment("time", value=t_sw),
                         Segment("time", value=t_sw + t_mot, magnets="swap", torque=TORQUE)])
    J = variational_jacobian("open_loop", Z_SEARCH, t_switch=t_sw, t_motor=t_mot,
                             torque=TORQUE)
    assert rel(J, fd(gait, Z_SEARCH)) < FD_RTOL                        # measured 1.2e-10
    # a time guard is not a state guard: the map differs from the search gait's
    assert rel(J, sequence_variational_jacobian(SEARCH, Z_SEARCH)) > 0.1


# beyond the study: flight and catch, climbing, friction, asymmetric links, a fixed phase
# ------------------------------------------------------------------------------------------
#: release at theta1 = 0.6 rising, fly until end B reaches the world height of the first
#: pivot, catch with B (flip + plastic impact), motor until the cycle-start energy is back
FLIGHT = SequenceGait([
    Segment("coord", coord="theta1", value=0.6, direction="rising", latch_energy=True),
    Segment("free_end_y", value=0.0, direction="rising", magnets="none"),
    Segment("energy_restored", magnets="B", torque=2.0),
])


def test_flight_gait_matches_fd():
    z = np.array([0.0, 3.0, 8.0])
    res = kernel_log(FLIGHT, z)
    phases = res.log[:, L.L_PHASE]
    assert L.PHASE_FLIGHT in phases and res.state[L.H_FLIPPED] == 1   # it flew, caught B
    J = sequence_variational_jacobian(FLIGHT, z)
    assert rel(J, fd(FLIGHT, z)) < FD_RTOL                             # measured 2.0e-10


def test_climbing_gait_matches_fd():
    robot = Robot.preset("seed2009")
    dh = 0.1
    m_g = (robot.link1.mass + robot.link2.mass) * robot.gravity
    gait = SequenceGait([
        Segment("free_end_height", value=dh, direction="rising", latch_energy=True),
        Segment("energy_restored", value=m_g * dh, magnets="swap", torque=1.5),
    ])
    z = np.array([0.0, 5.5, 5.0])
    res = kernel_log(gait, z)
    assert res.state[L.Y] == pytest.approx(dh, abs=1e-9)               # it climbed
    J = sequence_variational_jacobian(gait, z)
    assert rel(J, fd(gait, z)) < FD_RTOL                               # measured 4.3e-11


def test_energy_latched_at_a_state_event_with_the_motor_on():
    """The reference energy is latched on entering a segment at a state-triggered time while
    the motor works (dE/dt != 0 there): the reference moves with the start through the state
    and through the latch time."""
    gait = SequenceGait([
        Segment("coord", coord="theta1", value=0.3, direction="either", torque=-0.5),
        Segment("free_end_height", direction="rising", latch_energy=True, torque=-0.5),
        Segment("energy_restored", magnets="swap", torque=TORQUE),
    ])
    z = np.array([0.0, -2.5, 19.0])
    J = sequence_variational_jacobian(gait, z)
    assert rel(J, fd(gait, z)) < FD_RTOL                               # measured 4.6e-10


@pytest.mark.parametrize("pivot", [0.0, 0.02])
def test_viscous_friction_is_in_the_vector_field(pivot):
    robot = Robot.preset("seed2009").with_friction(Friction(viscous=pivot),
                                                   Friction(viscous=0.01))
    J = sequence_variational_jacobian(SEARCH, Z_SEARCH, robot=robot)
    assert rel(J, fd(SEARCH, Z_SEARCH, robot)) < FD_RTOL               # measured 7.0e-10
    # friction changes the map enough that leaving it out could not pass the test above
    assert rel(J, sequence_variational_jacobian(SEARCH, Z_SEARCH)) > 0.1


def test_asymmetric_links_two_swaps_clock_reset_section_off_vertical():
    """Ends on A (no mirror symmetry needed), so the flipped parameter row is exercised;
    the second swap resets the clock, and a time guard counts from that state event."""
    gait = SequenceGait([
        Segment("free_end_height", direction="rising", latch_energy=True),
        Segment("energy_restored", magnets="swap", torque=TORQUE),
        Segment("free_end_height", direction="rising", latch_energy=True),
        Segment("energy_restored", magnets="swap", torque=TORQUE, clock="reset"),
        Segment("time", value=0.05, torque=-TORQUE),
    ], section_theta1=0.2, section_direction="rising")
    z = np.array([0.1, 5.0, 8.0])
    J = sequence_variational_jacobian(gait, z, robot=ASYMMETRIC)
    assert rel(J, fd(gait, z, ASYMMETRIC)) < FD_RTOL                   # measured 6.0e-10


def test_fixed_phase_and_falling_section():
    """Swing, fly, hold with both magnets (a stop: velocities vanish), hang from B on a
    timer with the motor, swap back to A, restore the energy; section theta1 = -0.3 falling."""
    gait = SequenceGait([
        Segment("coord", coord="theta1", value=0.5, direction="rising", latch_energy=True),
        Segment("free_end_y", value=-0.3, direction="rising", magnets="none", clock="reset"),
        Segment("time", value=0.1, magnets="both"),
        Segment("time", value=0.3, magnets="B", torque=TORQUE),
        Segment("free_end_height", direction="rising"),
        Segment("energy_restored", magnets="swap", torque=TORQUE),
    ], section_theta1=-0.3, section_direction="falling")
    z = np.array([0.0, -5.0, 16.0])
    res = kernel_log(gait, z, ASYMMETRIC)
    assert L.PHASE_FIXED in res.log[:, L.L_PHASE]
    J = sequence_variational_jacobian(gait, z, robot=ASYMMETRIC)
    assert rel(J, fd(gait, z, ASYMMETRIC)) < FD_RTOL                   # measured 2.5e-10


# ------------------------------------------------------------------------------------------
# segments that end on entry
# ------------------------------------------------------------------------------------------
def test_zero_length_flight_composes_to_the_swap():
    """Release both ends (a flight that ends at once: the energy guard, 1 kJ below the
    reference, is met on entry), then catch with B: the same map as the swap."""
    gait = SequenceGait([
        Segment("free_end_height", direction="rising", latch_energy=True),
        Segment("energy_restored", value=-1e3, magnets="none"),
        Segment("energy_restored", magnets="B", torque=TORQUE),
    ])
    res = kernel_log(gait, Z_SEARCH)
    assert res.log[0, L.L_T] == res.log[1, L.L_T]                      # zero length
    np.testing.assert_array_equal(cycle_return_map(Z_SEARCH, gait)[0],
                                  cycle_return_map(Z_SEARCH, SEARCH)[0])
    J = sequence_variational_jacobian(gait, Z_SEARCH)
    assert rel(J, sequence_variational_jacobian(SEARCH, Z_SEARCH)) < 1e-12   # 7e-15


def test_time_already_past_composes():
    gait = SequenceGait([
        Segment("free_end_height", direction="rising", latch_energy=True),
        Segment("time", value=0.0, magnets="swap", torque=TORQUE),    # clock 0: past at once
        Segment("energy_restored", torque=TORQUE),
    ])
    J = sequence_variational_jacobian(gait, Z_SEARCH)
    assert rel(J, sequence_variational_jacobian(SEARCH, Z_SEARCH)) < 1e-12


def test_clock_reset_at_a_zero_length_exit_matches_fd():
    """The clock restarts at the exit of a segment that ends on entry, at the (state-
    triggered) swap: the motor's end then moves with the swap time."""
    gait = SequenceGait([
        Segment("free_end_height", direction="rising", latch_energy=True),
        Segment("energy_restored", value=-1e3, magnets="swap", torque=TORQUE, clock="reset"),
        Segment("time", value=0.2, torque=TORQUE),
    ])
    res = kernel_log(gait, Z_SEARCH)
    assert res.log[0, L.L_T] == res.log[1, L.L_T]
    J = sequence_variational_jacobian(gait, Z_SEARCH)
    assert rel(J, fd(gait, Z_SEARCH)) < FD_RTOL                        # measured 2.6e-9


@pytest.fixture(scope="module")
def grazing():
    return shoot_grazing((1.44, 10.31), 0.433)


def test_collisionless_swap_on_a_timer(grazing):
    """The grazing gait: swap at the time B reaches A's height at rest, zero motor time
    (the motor segment's time is already reached on entry)."""
    z = np.array([0.0, grazing.dtheta1, grazing.dtheta2])
    gait = SequenceGait([Segment("time", value=grazing.t_switch),
                         Segment("time", value=grazing.t_switch, magnets="swap")])
    J = sequence_variational_jacobian(gait, z)
    assert rel(J, fd(gait, z)) < FD_RTOL                               # measured 1.9e-10
    # the horizontal gait's motorless replay by name: the same events
    Jh = variational_jacobian("open_loop", z, t_switch=grazing.t_switch, t_motor=0.0,
                              torque=0.0)
    assert rel(Jh, fd(gait, z)) < FD_RTOL


def test_collisionless_swap_then_energy_level_guard_is_a_kink(grazing):
    """After a collisionless swap the energy is restored *exactly*, so the motor segment ends
    on entry; but the robot is at rest there, and any nearby start loses energy O(dz^2) at
    the swap, which the motor (starting from zero power) restores in a time O(|dz|): the
    map has a kink (one-sided slopes differ), and no Jacobian is returned."""
    z = np.array([0.0, grazing.dtheta1, grazing.dtheta2])
    gait = SequenceGait([Segment("time", value=grazing.t_switch, latch_energy=True),
                         Segment("energy_restored", magnets="swap", torque=TORQUE)])
    f0 = cycle_return_map(z, gait)[0]
    e = np.array([1e-4, 0.0, 0.0])
    up = (cycle_return_map(z + e, gait)[0] - f0) / 1e-4
    down = (f0 - cycle_return_map(z - e, gait)[0]) / 1e-4
    assert rel(up, down) > 0.5                                         # a kink indeed
    with pytest.raises(ValueError, match="kink"):
        sequence_variational_jacobian(gait, z)


# ------------------------------------------------------------------------------------------
# refusals, and speed
# ------------------------------------------------------------------------------------------
def test_refuses_ticks_and_failed_cycles():
    ticked = SequenceGait(SEARCH.segments, tick=1e-3)
    with pytest.raises(ValueError, match="tick"):
        sequence_variational_jacobian(ticked, Z_SEARCH)
    with pytest.raises(ValueError, match="mirror"):
        sequence_variational_jacobian(SEARCH, Z_SEARCH, robot=ASYMMETRIC)  # ends on B
    with pytest.raises(RuntimeError, match="no cycle"):
        sequence_variational_jacobian(SEARCH, [0.0, 0.1, 0.1])         # never swaps



def test_event_times_that_differ_are_named_as_numbers():
    """Links that are not mirror images, a two-swap gait at a start that is not a gait (a
    refine's stall): the re-integrated energy-restored exit misses the kernel's by 1.8e-8 s.
    The message names both times as plain numbers (not ``np.float64(...)``), as the floquet
    dataset's ``failure`` and the run's log show it."""
    robot = Robot(Link(1.0, 0.61, 0.543754, 0.02713056), Link(1.1, 0.61, 0.066246, 0.0298436),
                  name="uneven")
    swap = [Segment("free_end_height", direction="rising", latch_energy=True),
            Segment("energy_restored", magnets="swap", torque=TORQUE)]
    gait = SequenceGait(swap + [Segment("coord", coord="theta1", value=0.0,
                                        direction="either")] + swap,
                        section_theta1=0.0, section_direction="either")
    with pytest.raises(RuntimeError, match="event sequences differ") as info:
        sequence_variational_jacobian(gait, np.array([0.0, 0.785307251752252,
                                                      8.992968636533302]), robot=robot)
    message = str(info.value)
    assert "np." not in message and "float64" not in message, message
    assert re.match(r"segment 1 exits at 0\.6234394\d+ s here, 0\.6234394\d+ s in the kernel",
                    message), message


def test_a_catch_on_a_bar_matches_fd():
    """AcroMonk's two-swap brachiation (tests/analysis/test_design.py) with each catch a bar
    (``until: bar``: 3.4 cm and 60 cm ahead of the hook it hangs from, in -x): the
    variational Jacobian through the window and the snap agrees with finite differences, and
    with the free-end guard's gait (the snap moves no angle or rate)."""
    from monkeystudy.study.models import SequenceGaitSpec
    from test_design import BRACHIATION, Z_BRACHIATION, acromonk_for_design
    robot = acromonk_for_design()
    segs = [dict(s) for s in BRACHIATION["segments"]]
    for k, dx in ((0, -0.03), (3, -0.60)):
        for key in ("value", "direction"):
            segs[k].pop(key)
        segs[k].update(until="bar", bar={"dx": dx, "dy": 0.0, "window": 0.02})
    gait = SequenceGaitSpec.model_validate(dict(BRACHIATION, segments=segs)).gait()
    res = kernel_log(gait, Z_BRACHIATION, robot)
    exits = res.log[res.log[:, L.L_KIND] == L.LOG_SEGMENT]
    assert exits[3, L.L_STATE + L.X] == pytest.approx(-0.03 - 0.600, abs=0.02)
    assert res.state[L.X] == -0.03 - 0.60       # the snaps: each pivot is its bar
    J = sequence_variational_jacobian(gait, Z_BRACHIATION, robot=robot)
    assert rel(J, fd(gait, Z_BRACHIATION, robot)) < 1e-6
    free_end = SequenceGaitSpec.model_validate(BRACHIATION).gait()
    assert rel(J, sequence_variational_jacobian(free_end, Z_BRACHIATION, robot=robot)) < 1e-9


# ------------------------------------------------------------------------------------------
# Coulomb friction: slip reversals, sticks and break-aways crossed with saltation matrices
# ------------------------------------------------------------------------------------------
#: one swing of the hanging robot with the motor off for 0.3 s, to the vertical
SWING = SequenceGait([Segment("time", value=0.3)], section_theta1=0.0,
                     section_direction="either")


def coulomb(pivot=0.0, joint=0.0):
    return Robot.preset("seed2009").with_friction(Friction(coulomb=pivot),
                                                  Friction(coulomb=joint))


def coulomb_events(gait, z, robot):
    """``(dof, what, t)`` of each Coulomb event of one cycle in the kernel's log: ``dof`` 0
    pivot, 1 joint; ``what`` "reverse" (slips back), "stick" or "break" (break-away), told by
    whether the DOF's speed is exactly zero at the first sample after the event."""
    res = run_controller(gait.controller(), cycle_section_state(gait, z), robot=robot,
                         integrator=TIGHT, cycles=1, sample_dt=1e-4)
    assert res.status == Status.OK
    stuck, out = [False, False], []
    for row in res.log[res.log[:, L.L_KIND] == L.LOG_FRICTION]:
        k, t = int(row[L.L_ID]), float(row[L.L_T])
        i = np.searchsorted(res.sample_t, t, side="right")
        now = bool(res.sample_state[i, L.DTH1 + k] == 0.0)
        out.append((k, "break" if stuck[k] else "stick" if now else "reverse", t))
        stuck[k] = now
    return out


def fd_agrees(gait, z, robot, J, height=False):
    """Fourth-order central differences at two steps, at the integrator's tightest
    tolerances (TIGHT): the relative differences from ``J``."""
    f = cycle_full_map if height else cycle_return_map
    return [rel(J, jacobian_fd(lambda q: f(q, gait, robot=robot), z, h)) for h in (1e-5, 1e-4)]


def test_pivot_coulomb_slip_reversals_match_fd():
    """The search controller's cycle with Coulomb friction at the pivot (the identified
    AcroMonk's 0.0787 N m): link 1 turns back twice, each time slipping the other way at
    once (the holding torque beyond the limit): the field jumps by the friction torque's
    change of sign."""
    robot = coulomb(pivot=0.0787)
    assert [e[:2] for e in coulomb_events(SEARCH, Z_SEARCH, robot)] == [(0, "reverse")] * 2
    J = sequence_variational_jacobian(SEARCH, Z_SEARCH, robot=robot)
    assert max(fd_agrees(SEARCH, Z_SEARCH, robot, J)) < FD_RTOL       # 1.5e-9, 4.8e-11


def test_joint_coulomb_stick_and_break_away_match_fd():
    """The joint stops and sticks (holding torque within the limit), breaks away while the
    robot swings (the holding torque reaches 0.2 N m), and sticks again until the section.
    A stick absorbs perturbations of the joint's speed: the map's dtheta2 row is zero."""
    robot = coulomb(joint=0.2)
    z = np.array([0.0, 3.0, -0.5])
    events = coulomb_events(SWING, z, robot)
    assert [e[:2] for e in events] == [(1, "stick"), (1, "break"), (1, "stick")]
    assert events[1][2] < 0.3                  # a break-away event, not a segment's entry
    J = sequence_variational_jacobian(SWING, z, robot=robot)
    assert np.all(J[2] == 0.0)
    assert max(fd_agrees(SWING, z, robot, J)) < FD_RTOL                # 1.2e-10, 2.7e-11


def test_joint_coulomb_slip_reversal_then_stick_in_one_segment_matches_fd():
    """Under a constant torque the joint slips back at its first stop and sticks at its
    second (a large Coulomb limit): the reversal's saltation, then the stick's, which zeroes
    the dtheta2 row."""
    robot = coulomb(joint=0.5)
    gait = SequenceGait([Segment("time", value=0.3, torque=0.5)], section_theta1=0.0,
                        section_direction="either")
    z = np.array([0.0, 3.0, -0.5])
    assert [e[:2] for e in coulomb_events(gait, z, robot)] == [(1, "reverse"), (1, "stick")]
    J = sequence_variational_jacobian(gait, z, robot=robot)
    assert max(fd_agrees(gait, z, robot, J)) < FD_RTOL                 # 2.4e-11, 1.2e-11


@pytest.mark.parametrize("joint", [0.0, 0.02])
def test_acromonk_brachiation_with_coulomb_friction_matches_fd(joint):
    """AcroMonk's two-swap brachiation (tests/analysis/test_design.py) on the identified
    model (pivot Coulomb 0.07865 N m, joint viscous 0.04144 N m s), with and without
    Coulomb friction at the joint: the hook turns back on its bar 11 times a cycle (each
    time slipping on), the joint (with Coulomb friction) twice, and the full map's spectral
    radius by variational equations is the finite differences' to 1e-6."""
    from test_design import BRACHIATION, Z_BRACHIATION
    from monkeystudy.analysis.measured_replay import acromonk_robot
    from monkeystudy.study.models import SequenceGaitSpec
    robot = acromonk_robot(Friction(0.0, 0.07865), Friction(0.04144, joint))
    gait = SequenceGaitSpec.model_validate(BRACHIATION).gait()
    events = [e[:2] for e in coulomb_events(gait, Z_BRACHIATION, robot)]
    assert events.count((0, "reverse")) == 11
    assert events.count((1, "reverse")) == (2 if joint else 0)
    assert len(events) == (13 if joint else 11)
    J = sequence_variational_jacobian(gait, Z_BRACHIATION, robot=robot)
    assert max(fd_agrees(gait, Z_BRACHIATION, robot, J)) < FD_RTOL
    w = np.concatenate([[0.0], Z_BRACHIATION])
    Jh = sequence_variational_jacobian(gait, w, robot=robot, height=True)
    Jh_fd = jacobian_fd(lambda q: cycle_full_map(q, gait, robot=robot), w, 1e-5)
    rho, rho_fd = (float(np.abs(np.linalg.eigvals(M)).max()) for M in (Jh, Jh_fd))
    assert abs(rho - rho_fd) <= 1e-6 * rho_fd                          # 8.77, 1.74


def test_holding_torque_at_the_limit_at_a_stop_is_refused():
    """The torque of the swing's first segment decides whether the joint's first stop
    slips back (-0.5 N m) or sticks (0): between them, at the torque where the holding
    torque at the stop is the limit, the map has a kink, and the message names the stop."""
    from monkeystudy.kernel.variational import holding_torque8
    robot = coulomb(joint=0.2)
    z = np.array([0.0, 3.0, 0.5])
    p = robot.params()[0]

    def gait(tau):
        return SequenceGait([Segment("time", value=0.3, torque=tau)], section_theta1=0.0,
                            section_direction="either")

    def margin(tau):
        res = kernel_log(gait(tau), z, robot)
        row = res.log[res.log[:, L.L_KIND] == L.LOG_FRICTION][0]
        s = row[L.L_STATE:L.L_STATE + 8].copy()
        return abs(holding_torque8(L.PHASE_SWING, p, tau, np.ones(2), s, 1)) - 0.2

    lo, hi = -0.5, 0.0
    assert margin(lo) > 0 > margin(hi)
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if margin(mid) > 0 else (lo, mid)
    with pytest.raises(ValueError, match=r"the joint is at rest at its stop in segment 0 "
                                         r"\(t = 0\.0\d+ s\) with its holding torque at the "
                                         "Coulomb limit"):
        sequence_variational_jacobian(gait(lo), z, robot=robot)


def test_holding_torque_at_the_limit_at_a_segment_entry_is_refused():
    """Stuck at a segment's exit, the joint enters a segment whose torque puts its holding
    torque exactly at the limit: whether it stays stuck depends on the start."""
    from monkeystudy.kernel.variational import holding_torque8
    robot = coulomb(joint=0.5)
    z = np.array([0.0, 3.0, 0.5])
    first = SequenceGait([Segment("time", value=0.3), Segment("time", value=0.35)],
                         section_theta1=0.0, section_direction="either")
    assert [e[:2] for e in coulomb_events(first, z, robot)] == [(1, "stick")]
    log = kernel_log(first, z, robot).log
    s = log[log[:, L.L_KIND] == L.LOG_SEGMENT][0, L.L_STATE:L.L_STATE + 8].copy()
    p = robot.params()[0]
    tau = holding_torque8(L.PHASE_SWING, p, 0.0, np.ones(2), s, 1) + 0.5
    assert holding_torque8(L.PHASE_SWING, p, tau, np.ones(2), s, 1) == pytest.approx(-0.5,
                                                                                     abs=1e-15)
    gait = SequenceGait([Segment("time", value=0.3), Segment("time", value=0.35, torque=tau)],
                        section_theta1=0.0, section_direction="either")
    with pytest.raises(ValueError, match=r"the joint is at rest at the entry of segment 1 "
                                         r"\(t = 0\.3 s\)"):
        sequence_variational_jacobian(gait, z, robot=robot)
    # a little further from the limit, either way, it is differentiable
    for dtau in (-1e-3, 1e-3):
        g = SequenceGait([Segment("time", value=0.3),
                          Segment("time", value=0.35, torque=tau + dtau)],
                         section_theta1=0.0, section_direction="either")
        J = sequence_variational_jacobian(g, z, robot=robot)
        assert max(fd_agrees(g, z, robot, J)) < FD_RTOL


def test_a_start_at_rest_with_coulomb_friction_is_refused():
    with pytest.raises(ValueError, match="the joint starts at rest with Coulomb friction"):
        sequence_variational_jacobian(SWING, [0.0, 3.0, 0.0], robot=coulomb(joint=0.2))
