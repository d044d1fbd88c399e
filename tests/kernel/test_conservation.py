"""Conservation laws over long unforced runs (docs/model.md section 3, "Identities").

Torque 0 and no friction: total energy (world frame) is conserved in swing and in flight; in
flight the total linear momentum changes only by ``-(m1 + m2) g t`` along y and the angular
momentum about the CG is conserved. Runs are 100 s at ``rtol = atol = 1e-12`` (DOP853); the
invariants are computed from the sampled states with the independent formulas of
``tests/reference`` (and the kernel's energy, which must agree).
"""

import numpy as np
import pytest

from monkeystudy import (
    Integrator, PhaseSequence, Segment, initial_state, run_controller, simulate,
)
from monkeystudy.kernel import dynamics as dyn
from monkeystudy.kernel.layout import PHASE_FLIGHT, PHASE_SWING, ST_END_TIME
from reference.model import RefRobot
from reference.symbolic import derivation

from .helpers import ROBOTS

T_END = 100.0
INTEG = Integrator("dop853", rtol=1e-12, atol=1e-12, max_time=2 * T_END)
DRIFT = 1e-9

SWING = PhaseSequence([Segment("none")], observers=())
FLIGHT = PhaseSequence([Segment("none", magnets="none")], observers=())

# (robot, start): a low swing, a whirling one (link 2 goes over the top), an asymmetric one
SWING_CASES = [
    ("seed2009", dict(dtheta1=1.0, dtheta2=-2.0, theta1=0.3)),
    ("uniform_rod", dict(dtheta1=4.0, dtheta2=12.0)),
    ("asymmetric", dict(dtheta1=-3.0, dtheta2=9.0, theta1=1.0, theta2=-0.5)),
    ("geared", dict(dtheta1=2.0, dtheta2=-6.0, theta1=0.4, theta2=0.3)),
]


@pytest.mark.parametrize("name,start", SWING_CASES, ids=[c[0] for c in SWING_CASES])
def test_swing_energy_conserved(name, start):
    robot = ROBOTS[name]
    ref = RefRobot.from_robot(robot)
    d1, d2 = start.pop("dtheta1"), start.pop("dtheta2")
    ds = simulate(SWING, robot=robot, state=initial_state(d1, d2, **start), t_end=T_END,
                  sample_dt=0.05, integrator=INTEG)
    assert ds.attrs["status"] == "end_time"
    assert np.all(ds.phase.values == PHASE_SWING)
    assert ds.time.values[-1] == T_END
    e = ds.total_energy.values
    k = ds.kinetic_energy.values
    scale = abs(e[0]) + k.max()
    drift = np.max(np.abs(e - e[0])) / scale
    assert drift < DRIFT, f"relative energy drift {drift:.2e}"
    # the kernel's energies are the docs/model.md ones (independent formula on a subset)
    s8 = np.column_stack([ds[v].values for v in ("x", "y", "theta1", "theta2", "x_dot", "y_dot",
                                                  "theta1_dot", "theta2_dot")])
    for i in range(0, len(s8), 97):
        assert e[i] == pytest.approx(ref.energy8(s8[i]), rel=1e-12, abs=1e-12 * scale)
    # the motion is not trivial: both links move, the swing visits a range of angles
    assert np.ptp(ds.theta1.values) > 0.5 and np.ptp(ds.theta2.values) > 0.5


def _flight_invariants(ref, states):
    """Linear momentum and CG (world frame), and the internal motion's angular momentum about
    the CG and kinetic energy. The internal quantities depend on the angles and their rates
    only: they are evaluated on the same configuration translated to the origin with the CG
    at rest, so that the fall (|v| ~ 1e3 m/s, |y| ~ 5e4 m after 100 s) does not cancel away
    their digits."""
    d = derivation()
    lin = np.array([np.asarray(d.f_lin_momentum(s[:4], s[4:], ref.prm), float).ravel()
                    for s in states])
    cg = np.array([np.asarray(d.f_cg(s[:4], s[4:], ref.prm), float).ravel() for s in states])
    mt = ref.m1 + ref.m2
    ang, k_int = [], []
    for s in states:
        z = np.array([0.0, 0.0, s[2], s[3], 0.0, 0.0, s[6], s[7]])
        v_rel = np.asarray(d.f_lin_momentum(z[:4], z[4:], ref.prm), float).ravel() / mt
        z[4:6] = -v_rel                  # the (x, y) end moves so that the CG is at rest
        c = np.asarray(d.f_cg(z[:4], z[4:], ref.prm), float).ravel()
        ang.append(float(d.f_ang_momentum(z[:4], z[4:], ref.prm, c)))
        k_int.append(ref.kinetic8(z))
        if len(ang) == 1:   # scale of the angular momentum: its terms without cancellation
            ang_scale = np.sum(np.abs(np.asarray(
                d.f_ang_momentum_terms(z[:4], z[4:], ref.prm, c), float)))
    return lin, cg, np.array(ang), ang_scale, np.array(k_int)


@pytest.mark.parametrize("name", ["asymmetric", "seed2009", "geared"])
def test_flight_conservation(name):
    robot = ROBOTS[name]
    ref = RefRobot.from_robot(robot)
    par = robot.params()
    res = run_controller(FLIGHT, initial_state(2.5, -7.0, theta1=0.7, theta2=1.2),
                         robot=robot, integrator=INTEG, t_end=T_END, sample_dt=0.25)
    assert res.status == ST_END_TIME
    assert np.all(res.sample_mode[:, 0] == PHASE_FLIGHT)
    t = res.sample_t
    s = res.sample_state
    assert t[-1] == T_END
    mt = ref.m1 + ref.m2
    g = ref.g
    # energy: kernel and reference formulas; relative to the energy exchanged (K grows to
    # ~(m g t)^2 / 2m while V falls by as much)
    e = np.array([dyn.total_energy8(par[0], x) for x in s])
    e_ref = np.array([ref.energy8(x) for x in s])
    k = np.array([ref.kinetic8(x) for x in s])
    scale = abs(e[0]) + k.max()
    np.testing.assert_allclose(e, e_ref, rtol=0, atol=1e-12 * scale)
    assert np.max(np.abs(e - e[0])) / scale < DRIFT
    lin, cg, ang, ang_scale, k_int = _flight_invariants(ref, s)
    # linear momentum: p(t) = p(0) - m g t e_y
    want = lin[0] + np.outer(t - t[0], [0.0, -mt * g])
    pscale = np.abs(lin[0]).max() + mt * g * T_END
    assert np.max(np.abs(lin - want)) / pscale < DRIFT
    # the CG flies on the parabola those momenta imply
    cg_want = cg[0] + np.outer(t, lin[0] / mt) + np.outer(0.5 * t**2, [0.0, -g])
    assert np.max(np.abs(cg - cg_want)) / (0.5 * g * T_END**2) < DRIFT
    # angular momentum about the CG and the internal kinetic energy are conserved
    assert np.max(np.abs(ang - ang[0])) / ang_scale < DRIFT
    assert np.max(np.abs(k_int - k_int[0])) / k_int[0] < DRIFT
    # the robot really tumbles (not a trivial motion)
    assert np.ptp(s[:, 3]) > 1.0


def test_swing_energy_conserved_rk45():
    """The lower-order pair conserves energy too, to its tolerance (shorter run)."""
    robot = ROBOTS["seed2009"]
    integ = Integrator("rk45", rtol=1e-11, atol=1e-11, max_time=30.0)
    ds = simulate(SWING, robot=robot, state=initial_state(1.0, 6.0), t_end=20.0,
                  sample_dt=0.05, integrator=integ)
    e = ds.total_energy.values
    scale = abs(e[0]) + ds.kinetic_energy.values.max()
    assert np.max(np.abs(e - e[0])) / scale < 1e-8
