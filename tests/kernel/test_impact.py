"""Plastic impacts and the flip (docs/model.md section 3).

Identities at random states of random robots: the projection is a projection that pins the
attached end, never creates kinetic energy (and loses exactly Carnot's ``1/2 dq^T M dq``),
conserves angular momentum about the new pivot; ``attach_xy_end`` is the explicit ``P``; the
flip is an involution that changes the description, not the physics (energies, positions,
velocities of every point). Then the same resets as the hybrid loop applies them (swap,
attach from flight, both magnets, release).
"""
import math

import numpy as np
import pytest

from monkeystudy import Integrator, PhaseSequence, Segment, initial_state, run_controller
from monkeystudy.kernel import dynamics as dyn
from monkeystudy.kernel.layout import (
    H_FLIPPED, H_PHASE, L_E_AFTER, L_E_BEFORE, L_FLIPPED, L_PHASE, L_STATE, L_T,
    PHASE_FIXED, PHASE_FLIGHT, PHASE_SWING,
)
from reference.model import RefRobot
from reference.symbolic import derivation

from .helpers import ROBOTS, random_robot, random_state8

pytestmark = pytest.mark.nojit

N_SAMPLES = 60
TOL = 1e-13


def _cases(seed):
    rng = np.random.default_rng(seed)
    named = list(ROBOTS.values())
    for i in range(N_SAMPLES):
        robot = named[i] if i < len(named) else random_robot(rng)
        yield robot, robot.params()[0], random_state8(rng)


def _ang_momentum(p_row_robot, s8, point):
    ref = RefRobot.from_robot(p_row_robot) if not isinstance(p_row_robot, RefRobot) \
        else p_row_robot
    return float(derivation().f_ang_momentum(s8[:4], s8[4:], ref.prm, point))


def _free_end_velocity(p, s):
    L1, L2 = p[2], p[3]
    th1, th2, w1, w2 = s[2], s[3], s[6], s[7]
    return np.array([s[4] + L1 * math.cos(th1) * w1 + L2 * math.cos(th1 + th2) * (w1 + w2),
                     s[5] + L1 * math.sin(th1) * w1 + L2 * math.sin(th1 + th2) * (w1 + w2)])


# ----------------------------------------------------------------------------------------------
# the projection
# ----------------------------------------------------------------------------------------------
def test_projection_identities():
    worst = {}
    for robot, p, s in _cases(21):
        P = dyn.impact_projection(p, s)
        scale = max(1.0, np.max(np.abs(P)))
        worst["P2-P"] = max(worst.get("P2-P", 0), np.max(np.abs(P @ P - P)) / scale)
        assert np.max(np.abs(P @ P - P)) <= TOL * scale
        qd = s[4:]
        qp = P @ qd
        vscale = np.max(np.abs(qd)) * scale
        assert np.max(np.abs(qp[:2])) <= TOL * vscale          # J qdot+ = 0
        # P is the projection the independent model builds from the sympy mass matrix
        Pref = RefRobot.from_robot(robot).projection(s)
        assert np.max(np.abs(P - Pref)) <= 1e-12 * scale
        # closed form used by the hybrid loop
        s2 = s.copy()
        dyn.attach_xy_end(p, s2)
        assert np.array_equal(s2[:4], s[:4])
        assert s2[4] == 0.0 and s2[5] == 0.0
        assert np.max(np.abs(s2[4:] - qp)) <= TOL * vscale, (s2[4:], qp)


def test_impact_energy_and_momentum():
    """K never increases; the loss is Carnot's ``1/2 (qd- - qd+)^T M (qd- - qd+)``; the impulse
    acts only on the (x, y) rows, so the theta rows of ``M qdot`` and the angular momentum
    about the attached point are conserved."""
    for robot, p, s in _cases(22):
        M, _, _ = dyn.flight_matrices(p, s)
        s2 = s.copy()
        dyn.attach_xy_end(p, s2)
        k_before = 0.5 * s[4:] @ M @ s[4:]
        k_after = dyn.kinetic_energy(p, s2[2], s2[3], s2[4], s2[5], s2[6], s2[7])
        assert k_after <= k_before * (1.0 + TOL)
        dq = s[4:] - s2[4:]
        assert abs((k_before - k_after) - 0.5 * dq @ M @ dq) <= 1e-12 * k_before
        assert np.max(np.abs((M @ s2[4:])[2:] - (M @ s[4:])[2:])) <= \
            TOL * np.max(np.abs(M) @ np.abs(s[4:]))
        h_before = _ang_momentum(robot, s, (s[0], s[1]))
        h_after = _ang_momentum(robot, s2, (s[0], s[1]))
        hscale = np.max(np.abs(M) @ np.abs(s[4:])) * (1.0 + abs(s[0]) + abs(s[1]))
        assert abs(h_after - h_before) <= 1e-12 * hscale


def test_projection_of_an_attached_state_changes_nothing():
    """An end already at rest is not hit: ``P`` leaves ``J qdot = 0`` velocities alone."""
    for robot, p, s in _cases(23):
        s[4:6] = 0.0
        s2 = s.copy()
        dyn.attach_xy_end(p, s2)
        assert np.max(np.abs(s2[6:] - s[6:])) <= TOL * np.max(np.abs(s[6:]))


# ----------------------------------------------------------------------------------------------
# the flip
# ----------------------------------------------------------------------------------------------
def _angle_diff(a, b):
    return abs(math.remainder(a - b, 2.0 * math.pi))


def test_flip_twice_is_identity():
    for robot, p, s in _cases(24):
        fp = dyn.flipped_params(p)
        np.testing.assert_allclose(dyn.flipped_params(fp), p, rtol=4e-16, atol=4e-16)
        s2 = s.copy()
        dyn.flip_state(p, s2)
        assert -math.pi <= s2[2] < math.pi
        dyn.flip_state(fp, s2)
        L = p[2] + p[3]
        assert np.max(np.abs(s2[:2] - s[:2])) <= TOL * (L + np.max(np.abs(s[:2])))
        assert _angle_diff(s2[2], s[2]) <= TOL * 10 and _angle_diff(s2[3], s[3]) <= TOL * 10
        vscale = np.max(np.abs(s[4:])) * (1 + L)
        assert np.max(np.abs(s2[4:] - s[4:])) <= TOL * vscale


def test_flip_preserves_physics():
    """Same energies (world frame), same positions of both ends, the joint and both CGs (roles
    swapped), same velocity of the former (x, y) end (now the free end); and the docs/model.md
    formulas of the independent model."""
    for robot, p, s in _cases(25):
        fp = dyn.flipped_params(p)
        s2 = s.copy()
        dyn.flip_state(p, s2)
        k1 = dyn.kinetic_energy(p, s[2], s[3], s[4], s[5], s[6], s[7])
        k2 = dyn.kinetic_energy(fp, s2[2], s2[3], s2[4], s2[5], s2[6], s2[7])
        v1 = dyn.potential_energy(p, s[1], s[2], s[3])
        v2 = dyn.potential_energy(fp, s2[1], s2[2], s2[3])
        assert abs(k2 - k1) <= TOL * k1 * 10
        vscale = p[8] * (p[0] + p[1]) * (abs(s[1]) + p[2] + p[3])
        assert abs(v2 - v1) <= TOL * vscale
        a = np.empty((5, 2))
        b = np.empty((5, 2))
        dyn.points8(p, s, a)
        dyn.points8(fp, s2, b)
        assert np.max(np.abs(b[::-1] - a)) <= TOL * np.max(np.abs(a))
        ve = _free_end_velocity(fp, s2)
        assert np.max(np.abs(ve - s[4:6])) <= TOL * np.max(np.abs(s2[4:]) * (1 + p[2] + p[3]))
        want = RefRobot.from_robot(robot).flip8(s)
        assert np.max(np.abs(s2[[0, 1, 4, 5, 6, 7]] - want[[0, 1, 4, 5, 6, 7]])) <= \
            TOL * np.max(np.abs(want))
        assert _angle_diff(s2[2], want[2]) <= 1e-14 and _angle_diff(s2[3], want[3]) <= 1e-14


def test_flip_keeps_theta2_continuous():
    """``theta2' = -theta2`` exactly (docs/model.md section 3), with no 2 pi jump: at a swap with the
    links folded (theta2 = +-pi, B at A: for equal links always "at A's height") a wrap into
    [-pi, pi) would pick the branch by round-off, and the gait error ``theta2_f^2 + ...``
    with it (it jumped between ~0.01 and ~40 along d2 at d1 = -1, seed2009). theta1' is
    wrapped into [-pi, pi), as the vertical guard needs."""
    rng = np.random.default_rng(26)
    p = ROBOTS["seed2009"].params()[0]
    near_pi = [math.pi, -math.pi, math.nextafter(math.pi, 4.0), math.nextafter(-math.pi, -4.0),
               math.pi - 1e-12, -math.pi + 1e-12, 3.5, -3.5, 7.0, -9.0]
    for th2 in near_pi:
        s = random_state8(rng)
        s[3] = th2
        s2 = s.copy()
        dyn.flip_state(p, s2)
        assert s2[3] == -th2
        assert -math.pi <= s2[2] < math.pi
        assert _angle_diff(s2[2], math.pi + s[2] + s[3]) <= 1e-14


# ----------------------------------------------------------------------------------------------
# resets as the hybrid loop applies them
# ----------------------------------------------------------------------------------------------
INTEG = Integrator("dop853", rtol=1e-12, atol=1e-12)


def _transition(res, t):
    """Samples just before and after the transition at time ``t`` (both are written)."""
    idx = np.flatnonzero(res.sample_t == t)
    assert len(idx) >= 2, (t, res.sample_t)
    return idx[0], idx[-1]


@pytest.mark.parametrize("name", list(ROBOTS))
def test_swap_from_swing(name):
    """Swap = embed (dx = dy = 0), flip, project (docs/model.md section 3); the new pivot is B's
    world position; energy does not increase; the log row shows the post-impact state."""
    robot = ROBOTS[name]
    ref = RefRobot.from_robot(robot)
    prog = PhaseSequence([Segment("time", value=0.23, ticked=False),
                          Segment("time", value=0.5, magnets="swap", ticked=False)],
                         observers=())
    res = run_controller(prog, initial_state(2.0, 7.0, theta1=0.3), robot=robot,
                         integrator=INTEG, sample_dt=0.01)
    i, j = _transition(res, 0.23)
    before = res.sample_state[i]
    after = res.sample_state[j]
    assert res.sample_mode[i, 0] == PHASE_SWING and res.sample_mode[i, 1] == 0
    assert res.sample_mode[j, 0] == PHASE_SWING and res.sample_mode[j, 1] == 1
    want = ref.flipped().attach(ref.flip8(before))
    np.testing.assert_allclose(after, want, rtol=0, atol=1e-13 * (1 + np.max(np.abs(want))))
    row = res.log[0]
    assert row[L_T] == 0.23 and row[L_FLIPPED] == 1 and row[L_PHASE] == PHASE_SWING
    np.testing.assert_array_equal(row[L_STATE:L_STATE + 8], after)
    assert row[L_E_AFTER] <= row[L_E_BEFORE]
    assert row[L_E_BEFORE] == pytest.approx(ref.energy8(before), rel=1e-13, abs=1e-13)
    assert row[L_E_AFTER] == pytest.approx(ref.flipped().energy8(after), rel=1e-13, abs=1e-13)


def test_attach_b_from_flight_and_release_and_fixed():
    """Swing -> release A (flight with the swing velocities) -> attach B (flip + project) ->
    both magnets (all motion stops while time passes) -> only B (swing from rest) -> flight."""
    robot = ROBOTS["asymmetric"]
    ref = RefRobot.from_robot(robot)
    prog = PhaseSequence([
        Segment("time", value=0.10, ticked=False),                   # swing about A
        Segment("time", value=0.25, magnets="none", ticked=False),   # release A: flight
        Segment("time", value=0.40, magnets="B", ticked=False),      # B attaches: impact
        Segment("time", value=0.55, magnets="both", ticked=False),   # fixed
        Segment("time", value=0.70, magnets="B", ticked=False),      # A released: swing, rest
        Segment("none", magnets="none", ticked=False),               # flight again
    ], observers=())
    res = run_controller(prog, initial_state(3.0, -4.0, theta1=0.4, theta2=0.9), robot=robot,
                         integrator=INTEG, t_end=0.9, sample_dt=0.01)
    ph = res.sample_mode[:, 0]
    fl = res.sample_mode[:, 1]
    # 0.10: release A from swing: flight starts with the swing velocities (dx = dy = 0 at A)
    i, j = _transition(res, 0.10)
    assert ph[i] == PHASE_SWING and ph[j] == PHASE_FLIGHT and fl[j] == 0
    np.testing.assert_array_equal(res.sample_state[i], res.sample_state[j])
    # 0.25: attach B from flight
    i, j = _transition(res, 0.25)
    assert ph[i] == PHASE_FLIGHT and ph[j] == PHASE_SWING and fl[j] == 1
    want = ref.flipped().attach(ref.flip8(res.sample_state[i]))
    np.testing.assert_allclose(res.sample_state[j], want, rtol=0,
                               atol=1e-13 * (1 + np.max(np.abs(want))))
    # 0.40: both magnets: fixed, at rest, nothing moves while time passes
    i, j = _transition(res, 0.40)
    assert ph[j] == PHASE_FIXED
    fixed = np.flatnonzero(ph == PHASE_FIXED)
    assert np.all(res.sample_state[fixed, 4:] == 0.0)
    assert np.all(res.sample_state[fixed, :4] == res.sample_state[i, :4])
    assert res.sample_t[fixed].min() == 0.40 and res.sample_t[fixed].max() == 0.55
    # 0.55: release A from fixed: swing about B, from rest
    i, j = _transition(res, 0.55)
    assert ph[j] == PHASE_SWING and fl[j] == 1
    assert np.all(res.sample_state[j, 4:] == 0.0)
    # 0.70: release B: flight from the swing state
    i, j = _transition(res, 0.70)
    assert ph[j] == PHASE_FLIGHT and fl[j] == 1
    np.testing.assert_array_equal(res.sample_state[i], res.sample_state[j])
    # the world energy is carried through every reset
    e = np.array([ref.energy8(s) if f == 0 else ref.flipped().energy8(s)
                  for s, f in zip(res.sample_state, fl)])
    e_kernel = np.array([dyn.total_energy8(res.params[int(f)], s)
                         for s, f in zip(res.sample_state, fl)])
    np.testing.assert_allclose(e_kernel, e, rtol=1e-12, atol=1e-12)
    assert np.all(np.diff(e) <= 1e-9 * np.max(np.abs(e)))
    assert res.state[H_PHASE] == PHASE_FLIGHT and res.state[H_FLIPPED] == 1
