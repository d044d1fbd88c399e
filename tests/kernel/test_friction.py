"""Friction at the pivot and the joint (docs/model.md section 2, "Generalized forces").

Viscous friction dissipates exactly ``b1 w1^2 + b2 w2^2`` (swing; only the joint in flight).
Coulomb friction is a stick-slip hybrid system: a slipping DOF stops (an event) and sticks if
the torque needed to hold it is within the Coulomb limit, else slips back; a stuck DOF breaks
away when that torque reaches the limit. The kernel's event sequence, modes and states are
compared with an independent chained-``solve_ivp`` implementation of those rules
(``reference.model.swing_with_friction``), and energy never increases.
"""
import numpy as np
import pytest
from scipy.integrate import solve_ivp

from monkeystudy import Friction, Integrator, PhaseSequence, Segment, initial_state, run_controller
from monkeystudy.kernel import dynamics as dyn
from monkeystudy.kernel.layout import (
    H_FMODE0, H_FMODE1, L_ID, L_KIND, L_STATE, L_T, LOG_FRICTION, PHASE_FLIGHT, PHASE_SWING,
    ST_END_TIME,
)
from reference import model as ref_model
from reference.model import RefRobot

from .helpers import ROBOTS

pytestmark = pytest.mark.nojit

SWING = PhaseSequence([Segment("none")], observers=())
FLIGHT = PhaseSequence([Segment("none", magnets="none")], observers=())
INTEG = Integrator("dop853", 1e-13, 1e-13, max_time=10.0)
T_END = 3.0


def _run(robot, prog=SWING, t_end=T_END, sample_dt=0.005, **start):
    d1, d2 = start.pop("dtheta1", 0.0), start.pop("dtheta2", 0.0)
    res = run_controller(prog, initial_state(d1, d2, **start), robot=robot, integrator=INTEG,
                         t_end=t_end, sample_dt=sample_dt)
    assert res.status == ST_END_TIME
    return res


def _energies(res):
    return np.array([dyn.total_energy8(res.params[int(f)], s)
                     for s, f in zip(res.sample_state, res.sample_mode[:, 1])])


def _assert_never_increases(e):
    scale = np.max(np.abs(e)) + 1.0
    assert np.all(np.diff(e) <= 1e-12 * scale), np.max(np.diff(e))


def _friction_rows(res):
    return res.log[res.log[:, L_KIND] == LOG_FRICTION]


# ----------------------------------------------------------------------------------------------
# viscous
# ----------------------------------------------------------------------------------------------
@pytest.mark.parametrize("b_pivot,b_joint", [(0.2, 0.0), (0.0, 0.05), (0.3, 0.1)])
def test_viscous_dissipation_is_exact(b_pivot, b_joint):
    """E(t) - E(0) = -int (b1 w1^2 + b2 w2^2) dt, the integral carried as an extra state of
    the reference ODE; the trajectory agrees with the reference; E strictly decreases."""
    robot = ROBOTS["asymmetric"].with_friction(Friction(b_pivot), Friction(b_joint))
    ref = RefRobot.from_robot(robot)
    res = _run(robot, dtheta1=3.0, dtheta2=-5.0, theta1=0.4)
    f = ref.swing_rhs(0.0)

    def aug(t, z):
        return np.concatenate([f(t, z[:4]), [b_pivot * z[2] ** 2 + b_joint * z[3] ** 2]])
    sol = solve_ivp(aug, (0.0, T_END), [0.4, 0.0, 3.0, -5.0, 0.0], method="DOP853",
                    rtol=1e-13, atol=1e-13, t_eval=res.sample_t, dense_output=True)
    z = sol.y.T
    np.testing.assert_allclose(res.sample_state[:, [2, 3, 6, 7]], z[:, :4], rtol=0, atol=1e-9)
    e = _energies(res)
    np.testing.assert_allclose(e - e[0], -z[:, 4], rtol=0, atol=1e-10 * (1 + abs(e[0])))
    assert np.all(np.diff(e) < 0.0)
    assert e[0] - e[-1] > 0.1   # a real loss, not round-off


def test_viscous_joint_in_flight_and_no_pivot_friction_in_flight():
    """In flight nothing is pinned: pivot friction (however large) does nothing; joint viscous
    friction dissipates b2 w2^2 (trajectory as the reference flight ODE)."""
    base = ROBOTS["seed2009"]
    res = _run(base.with_friction(Friction(5.0, 5.0), Friction()), prog=FLIGHT, t_end=1.0,
               dtheta1=3.0, dtheta2=-5.0, theta1=0.4)
    assert np.all(res.sample_mode[:, 0] == PHASE_FLIGHT)
    e = _energies(res)
    assert np.max(np.abs(e - e[0])) <= 1e-10 * (1 + np.max(np.abs(e)))
    assert not np.any(res.log[:, L_KIND] == LOG_FRICTION)
    robot = base.with_friction(Friction(), Friction(0.08))
    res = _run(robot, prog=FLIGHT, t_end=1.0, dtheta1=3.0, dtheta2=-5.0, theta1=0.4)
    ref = RefRobot.from_robot(robot)
    sol = solve_ivp(ref.flight_rhs(0.0), (0.0, 1.0), res.sample_state[0], method="DOP853",
                    rtol=1e-13, atol=1e-13, t_eval=res.sample_t)
    np.testing.assert_allclose(res.sample_state, sol.y.T, rtol=0, atol=1e-9)
    e = _energies(res)
    assert np.all(np.diff(e) < 0.0)


# ----------------------------------------------------------------------------------------------
# Coulomb
# ----------------------------------------------------------------------------------------------
def test_huge_pivot_coulomb_holds_from_rest():
    """Released at rest at an angle with a pivot that can hold any torque: theta1 never moves,
    the joint swings freely (energy conserved), nothing slips."""
    robot = ROBOTS["seed2009"].with_friction(Friction(0.0, 1000.0), Friction())
    res = _run(robot, dtheta2=4.0, theta1=0.6, theta2=-0.3)
    assert np.all(res.sample_state[:, 2] == 0.6)
    assert np.all(res.sample_state[:, 6] == 0.0)
    assert np.ptp(res.sample_state[:, 3]) > 1.0
    assert len(_friction_rows(res)) == 0
    assert res.state[H_FMODE0] == 0.0
    e = _energies(res)
    assert np.max(np.abs(e - e[0])) <= 1e-10 * (1 + abs(e[0]))
    # the holding torque stayed within the limit all along
    p = res.params[0]
    fm = np.array([0.0, 1.0])
    holds = [dyn.holding_torque(PHASE_SWING, p, 0.0, fm, s[[2, 3, 6, 7]], 0)
             for s in res.sample_state]
    assert max(abs(h) for h in holds) < 1000.0


def test_sliding_pivot_stops_and_sticks():
    """A pivot thrown with speed decelerates, stops (logged, speed exactly 0) and sticks: from
    then on theta1 is constant and its speed zero."""
    robot = ROBOTS["seed2009"].with_friction(Friction(0.0, 30.0), Friction())
    res = _run(robot, dtheta1=2.0, dtheta2=1.0)
    rows = _friction_rows(res)
    assert len(rows) == 1 and rows[0, L_ID] == 0
    t_stick = rows[0, L_T]
    assert 0.0 < t_stick < 0.5
    assert rows[0, L_STATE + 6] == 0.0
    after = res.sample_t > t_stick
    assert np.all(res.sample_state[after, 6] == 0.0)
    assert np.all(res.sample_state[after, 2] == rows[0, L_STATE + 2])
    before = res.sample_t < t_stick
    assert np.all(np.diff(res.sample_state[before, 6]) < 0.0)   # decelerating
    assert res.state[H_FMODE0] == 0.0
    _assert_never_increases(_energies(res))


STICK_SLIP = [  # (pivot friction, joint friction, start)
    (Friction(0.0, 2.0), Friction(), dict(dtheta1=2.0)),
    (Friction(0.1, 1.0), Friction(), dict(dtheta1=3.0, dtheta2=-4.0)),
    (Friction(), Friction(0.0, 0.3), dict(dtheta1=1.0, dtheta2=5.0)),
    (Friction(0.05, 0.8), Friction(0.02, 0.2), dict(dtheta1=2.5, dtheta2=-6.0, theta1=0.2)),
]


@pytest.mark.parametrize("robot_name", ["seed2009", "asymmetric"])
@pytest.mark.parametrize("pivot,joint,start", STICK_SLIP)
def test_stick_slip_matches_reference(robot_name, pivot, joint, start):
    robot = ROBOTS[robot_name].with_friction(pivot, joint)
    res = _run(robot, **dict(start))
    ref = RefRobot.from_robot(robot)
    y0 = [start.get("theta1", 0.0), start.get("theta2", 0.0), start.get("dtheta1", 0.0),
          start.get("dtheta2", 0.0)]
    run = ref_model.swing_with_friction(ref, y0, 0.0, T_END)
    rows = _friction_rows(res)
    assert len(run.events) > 0
    assert len(rows) == len(run.events)
    for row, (t, k, kind, mode) in zip(rows, run.events):
        assert row[L_ID] == k
        assert abs(row[L_T] - t) <= 1e-9
        assert row[L_STATE + 6 + k] == 0.0          # zero speed exactly at the event
    assert (res.state[H_FMODE0], res.state[H_FMODE1]) == run.fmode
    # a DOF that sticks stays put (angle constant, speed exactly 0) until its next event
    for i, (t, k, kind, mode) in enumerate(run.events):
        if mode != 0.0:
            continue
        t_next = next((e[0] for e in run.events[i + 1:] if e[1] == k), np.inf)
        window = (res.sample_t > t + 1e-9) & (res.sample_t < t_next - 1e-9)
        assert np.all(res.sample_state[window, 6 + k] == 0.0)
        assert np.all(res.sample_state[window, 2 + k] == rows[i, L_STATE + 2 + k])
    np.testing.assert_allclose(res.state[[2, 3, 6, 7]], run.y, rtol=0, atol=1e-9)
    # samples against the reference's piecewise solution
    for t, s in zip(res.sample_t[::20], res.sample_state[::20]):
        np.testing.assert_allclose(s[[2, 3, 6, 7]], ref_model.friction_state_at(run, t),
                                   rtol=0, atol=1e-9)
    _assert_never_increases(_energies(res))


def test_joint_coulomb_in_flight_dissipates():
    robot = ROBOTS["asymmetric"].with_friction(Friction(), Friction(0.01, 0.4))
    res = _run(robot, prog=FLIGHT, t_end=1.5, dtheta1=2.0, dtheta2=6.0, theta1=0.3)
    rows = _friction_rows(res)
    assert len(rows) > 0
    assert np.all(rows[:, L_ID] == 1)
    assert np.all(rows[:, L_STATE + 7] == 0.0)
    _assert_never_increases(_energies(res))
