"""Equations of motion against a symbolic Euler-Lagrange derivation (docs/model.md sections 1-2).

The reference (``tests/reference/symbolic.py``) types in only the *positions* of docs/model.md
section 1 and derives ``M``, ``C qdot`` and ``G`` with sympy, for flight (4-DOF) and swing
(2-DOF) separately. Here the kernel's matrices, vector fields, energies, holding torques and
kinematics are compared with the lambdified derivation at random states of random (generally
asymmetric) robots, to a relative 1e-12.
"""
from dataclasses import replace

import numpy as np
import pytest
import sympy as sp

from monkeystudy import Friction, Link, Robot
from monkeystudy.kernel import dynamics as dyn
from monkeystudy.kernel.layout import (
    P_A, P_AS, P_B_JOINT, P_B_PIVOT, P_C_JOINT, P_C_PIVOT, P_H, P_HS, P_K11, P_K22, P_M2R2,
    P_M2S2, P_MTOT,
    PHASE_FLIGHT, PHASE_SWING,
)
from reference.model import RefRobot
from reference.symbolic import derivation

from .helpers import ASYMMETRIC, ROBOTS, random_robot, random_state8

pytestmark = pytest.mark.nojit

N_SAMPLES = 50
RTOL = 1e-12


@pytest.fixture(scope="module")
def sym():
    return derivation()  # slow: derived once per module (and cached per process)


def _cases(seed, friction=False):
    """``N_SAMPLES`` (robot, kernel row, reference robot, 8-state) tuples; the first three
    robots are the named ones, the rest random."""
    rng = np.random.default_rng(seed)
    named = list(ROBOTS.values())
    for i in range(N_SAMPLES):
        robot = named[i] if i < len(named) else random_robot(rng, friction=friction)
        if friction and i < len(named):
            robot = robot.with_friction(Friction(rng.uniform(0, 0.8), rng.uniform(0, 0.8)),
                                        Friction(rng.uniform(0, 0.8), rng.uniform(0, 0.8)))
        yield robot, robot.params()[0], RefRobot.from_robot(robot), random_state8(rng)


def _close(got, want, scale, what):
    err = np.max(np.abs(np.asarray(got) - np.asarray(want)))
    assert err <= RTOL * scale, f"{what}: |diff| {err:.3e} > {RTOL:g} x {scale:.3e}"
    return err / scale


# ----------------------------------------------------------------------------------------------
# the documented closed forms (docs/model.md section 2) are the Euler-Lagrange equations
# ----------------------------------------------------------------------------------------------
def test_model_md_closed_forms_equal_derivation(sym):
    """docs/model.md section 2, typed in, minus the derivation simplifies to zero (both systems)."""
    x, y, th1, th2 = sym.symbols.q
    dx, dy, w1, w2 = sym.symbols.qd
    m1, m2, L1, L2, r1, r2, I1, I2, g, sg1, sg2, Ir, N, housing1 = sym.symbols.prm
    s1, c1, s2, c2 = sp.sin(th1), sp.cos(th1), sp.sin(th2), sp.cos(th2)
    s12, c12 = sp.sin(th1 + th2), sp.cos(th1 + th2)
    a = m1 * r1 + m2 * L1
    h = m2 * r2 * L1
    a_s, hs = m1 * sg1, m2 * sg2 * L1
    hc2 = h * c2 - hs * s2          # link 2's CG moment along link 1 (cos-like)
    hs2 = h * s2 + hs * c2          # and its derivative's magnitude (sin-like)
    Ms = sp.Matrix([[I1 + I2 + m1 * (r1**2 + sg1**2) + m2 * L1**2 + m2 * (r2**2 + sg2**2)
                     + 2 * hc2, I2 + m2 * (r2**2 + sg2**2) + hc2],
                    [I2 + m2 * (r2**2 + sg2**2) + hc2, I2 + m2 * (r2**2 + sg2**2)]])
    # the rotor's constant block: Ir [[1, k], [k, k^2]], k = N (housing on link 1) or 1 - N
    k = housing1 * N + (1 - housing1) * (1 - N)
    Ms = Ms + Ir * sp.Matrix([[1, k], [k, k**2]])
    Cs = sp.Matrix([-hs2 * (2 * w1 * w2 + w2**2), hs2 * w1**2])
    Gs = sp.Matrix([g * (a * s1 + a_s * c1 + m2 * r2 * s12 + m2 * sg2 * c12),
                    g * (m2 * r2 * s12 + m2 * sg2 * c12)])
    Mf = sp.zeros(4, 4)
    Mf[0, 0] = Mf[1, 1] = m1 + m2
    Mf[0, 2] = Mf[2, 0] = a * c1 - a_s * s1 + m2 * r2 * c12 - m2 * sg2 * s12
    Mf[0, 3] = Mf[3, 0] = m2 * r2 * c12 - m2 * sg2 * s12
    Mf[1, 2] = Mf[2, 1] = a * s1 + a_s * c1 + m2 * r2 * s12 + m2 * sg2 * c12
    Mf[1, 3] = Mf[3, 1] = m2 * r2 * s12 + m2 * sg2 * c12
    Mf[2:, 2:] = Ms
    Cf = sp.Matrix([-((a * s1 + a_s * c1) * w1**2 + m2 * (r2 * s12 + sg2 * c12) * (w1 + w2)**2),
                    (a * c1 - a_s * s1) * w1**2 + m2 * (r2 * c12 - sg2 * s12) * (w1 + w2)**2,
                    Cs[0], Cs[1]])
    Gf = sp.Matrix([0, g * (m1 + m2), Gs[0], Gs[1]])

    # canonical form: polynomial in sin/cos of theta1, theta2, reduced modulo s^2 + c^2 = 1
    S1, C1, S2, C2 = sp.symbols("S1 C1 S2 C2")

    def zero(expr):
        e = sp.expand(sp.expand_trig(expr)).subs(
            {sp.sin(th1): S1, sp.cos(th1): C1, sp.sin(th2): S2, sp.cos(th2): C2})
        rem = sp.reduced(sp.expand(e), [S1**2 + C1**2 - 1, S2**2 + C2**2 - 1],
                         S1, S2, C1, C2)[1]
        return rem == 0

    for doc, der in ((Ms, sym.M_swing), (Cs, sym.Cq_swing), (Gs, sym.G_swing),
                     (Mf, sym.M_flight), (Cf, sym.Cq_flight), (Gf, sym.G_flight)):
        diff = doc - der
        assert all(zero(e) for e in diff), diff


# ----------------------------------------------------------------------------------------------
# kernel vs derivation
# ----------------------------------------------------------------------------------------------
def test_flight_matrices(sym):
    worst = 0.0
    for robot, p, ref, s in _cases(1):
        M, Cq, G = dyn.flight_matrices(p, s)
        Mr, Cr, Gr = ref.flight_matrices(s)
        worst = max(worst, _close(M, Mr, np.max(np.abs(Mr)), f"M {robot}"))
        worst = max(worst, _close(Cq, Cr, np.max(np.abs(Cr)), f"C qdot {robot}"))
        worst = max(worst, _close(G, Gr, np.max(np.abs(Gr)), f"G {robot}"))
        assert np.array_equal(M, M.T)
        # the lower-right block is the swing system (docs/model.md section 2)
        Ms, Cs, Gs = ref.swing_matrices(s[2:4], s[6:8])
        _close(M[2:, 2:], Ms, np.max(np.abs(Ms)), "swing block of M")
        _close(Cq[2:], Cs, np.max(np.abs(Cs)), "swing block of C qdot")
        _close(G[2:], Gs, np.max(np.abs(Gs)), "swing block of G")


def _accel_scale(M, F, Cq, G):
    """Magnitude of the acceleration built from its pieces (no cancellation credited)."""
    return np.max(np.abs(np.linalg.inv(M)) @ (np.abs(F) + np.abs(Cq) + np.abs(G)))


@pytest.mark.parametrize("fmode", [(1.0, 1.0), (-1.0, 1.0), (1.0, -1.0), (-1.0, -1.0)])
def test_swing_vector_field(sym, fmode):
    """``rhs_swing`` = ``M^-1 (F - C qdot - G)``, F: motor on theta2, viscous + Coulomb
    friction at the pivot (theta1) and the joint (theta2)."""
    rng = np.random.default_rng(2)
    fm = np.array(fmode)
    for robot, p, ref, s in _cases(3, friction=True):
        tau = rng.uniform(-3, 3)
        y = s[[2, 3, 6, 7]]
        dy = np.empty(4)
        dyn.rhs_swing(p, tau, fm, y, dy)
        M, Cq, G = ref.swing_matrices(y[:2], y[2:])
        F = ref.swing_forces(y[2:], tau, fmode)
        want = np.linalg.solve(M, F - Cq - G)
        assert np.array_equal(dy[:2], y[2:])
        _close(dy[2:], want, _accel_scale(M, F, Cq, G), f"swing accel {robot}")


@pytest.mark.parametrize("fmode", [(1.0, 1.0), (1.0, -1.0), (-1.0, 1.0)])
def test_flight_vector_field(sym, fmode):
    """``rhs_flight`` = ``M^-1 (F - C qdot - G)`` with F = joint torque and joint friction only
    (nothing is pinned in flight: pivot friction and ``fmode[0]`` must not act)."""
    rng = np.random.default_rng(4)
    fm = np.array(fmode)
    for robot, p, ref, s in _cases(5, friction=True):
        tau = rng.uniform(-3, 3)
        dy = np.empty(8)
        dyn.rhs_flight(p, tau, fm, s, dy)
        M, Cq, G = ref.flight_matrices(s)
        F = ref.flight_forces(s[6:], tau, fmode)
        want = np.linalg.solve(M, F - Cq - G)
        assert np.array_equal(dy[:4], s[4:])
        _close(dy[4:], want, _accel_scale(M, F, Cq, G), f"flight accel {robot}")


def test_locked_dofs_and_holding_torque(sym):
    """A stuck DOF (``fmode[k] == 0``) has zero acceleration, the other obeys its own row, and
    ``holding_torque`` is the friction torque row k needs (the DOF's Coulomb term removed)."""
    rng = np.random.default_rng(6)
    for robot, p, ref, s in _cases(7, friction=True):
        tau = rng.uniform(-3, 3)
        y = s[[2, 3, 6, 7]]
        for fmode in ((0.0, 1.0), (1.0, 0.0), (0.0, 0.0), (0.0, -1.0), (-1.0, 0.0)):
            fm = np.array(fmode)
            dy = np.empty(4)
            dyn.rhs_swing(p, tau, fm, y, dy)
            want = ref.swing_accel(y, tau, fmode)
            M, Cq, G = ref.swing_matrices(y[:2], y[2:])
            F = ref.swing_forces(y[2:], tau, fmode)
            scale = _accel_scale(M, F, Cq, G)
            _close(dy[2:], want, scale, f"locked swing accel {fmode}")
            for k in range(2):
                if fmode[k] != 0.0:
                    continue
                hold = dyn.holding_torque(PHASE_SWING, p, tau, fm, y, k)
                hold_ref = ref.swing_holding_torque(y, tau, fmode, k)
                _close(hold, hold_ref, np.max(np.abs(M) @ (scale + np.abs(F) + np.abs(Cq)
                                                           + np.abs(G))), "holding torque")
        # flight: only the joint can stick
        for fmode in ((1.0, 0.0), (-1.0, 0.0)):
            fm = np.array(fmode)
            dy = np.empty(8)
            dyn.rhs_flight(p, tau, fm, s, dy)
            want = ref.flight_accel(s, tau, fmode)
            M, Cq, G = ref.flight_matrices(s)
            F = ref.flight_forces(s[6:], tau, (1.0, 0.0))
            scale = _accel_scale(M, F, Cq, G)
            _close(dy[4:], want, scale, "locked flight accel")
            assert dy[7] == 0.0
            hold = dyn.holding_torque(PHASE_FLIGHT, p, tau, fm, s, 1)
            hold_ref = M[3] @ want - (F - Cq - G)[3]
            _close(hold, hold_ref, np.max(np.abs(M) @ (scale + np.abs(F) + np.abs(Cq)
                                                       + np.abs(G))), "flight holding torque")


def test_energy_and_kinematics(sym):
    for robot, p, ref, s in _cases(8):
        K = dyn.kinetic_energy(p, s[2], s[3], s[4], s[5], s[6], s[7])
        V = dyn.potential_energy(p, s[1], s[2], s[3])
        Kr, Vr = ref.kinetic8(s), ref.potential8(s)
        _close(K, Kr, abs(Kr), "kinetic energy")
        Vscale = robot.gravity * (robot.link1.mass + robot.link2.mass) * (
            abs(s[1]) + robot.link1.length + robot.link2.length)
        _close(V, Vr, Vscale, "potential energy")
        _close(dyn.total_energy8(p, s), Kr + Vr, abs(Kr) + Vscale, "total energy")
        # swinging (dx = dy = 0): the flight coupling terms must vanish, not be skipped wrongly
        s0 = s.copy()
        s0[4:6] = 0.0
        _close(dyn.kinetic_energy(p, s0[2], s0[3], 0.0, 0.0, s0[6], s0[7]), ref.kinetic8(s0),
               ref.kinetic8(s0), "swing kinetic energy")
        pts = np.empty((5, 2))
        dyn.points8(p, s, pts)
        want = ref.points8(s)
        _close(pts, want, np.max(np.abs(want)), "points")
        fe = dyn.free_end_offset(p, s[2], s[3])
        _close(np.array(fe), want[4] - want[0], robot.link1.length + robot.link2.length,
               "free end offset")


def test_kinetic_energy_is_half_qdot_M_qdot():
    rng = np.random.default_rng(9)
    for _ in range(N_SAMPLES):
        p = random_robot(rng).params()[0]
        s = random_state8(rng)
        M, _, _ = dyn.flight_matrices(p, s)
        K = dyn.kinetic_energy(p, s[2], s[3], s[4], s[5], s[6], s[7])
        want = 0.5 * s[4:] @ M @ s[4:]
        assert abs(K - want) <= RTOL * abs(want)
        assert np.all(np.linalg.eigvalsh(M) > 0.0)


# ----------------------------------------------------------------------------------------------
# parameters
# ----------------------------------------------------------------------------------------------
def test_derived_parameters():
    rng = np.random.default_rng(10)
    for robot in [*ROBOTS.values(), *(random_robot(rng, True) for _ in range(10))]:
        p = robot.params()[0]
        l1, l2 = robot.link1, robot.link2
        assert p[P_A] == pytest.approx(l1.mass * l1.com + l2.mass * l1.length, rel=1e-15)
        assert p[P_H] == pytest.approx(l2.mass * l2.com * l1.length, rel=1e-15)
        assert p[P_M2R2] == pytest.approx(l2.mass * l2.com, rel=1e-15)
        assert p[P_K11] == pytest.approx(
            l1.inertia + l2.inertia + l1.mass * (l1.com**2 + l1.com_across**2)
            + l2.mass * l1.length**2 + l2.mass * (l2.com**2 + l2.com_across**2), rel=1e-15)
        assert p[P_K22] == pytest.approx(
            l2.inertia + l2.mass * (l2.com**2 + l2.com_across**2), rel=1e-15)
        assert p[P_AS] == pytest.approx(l1.mass * l1.com_across, rel=1e-15)
        assert p[P_HS] == pytest.approx(l2.mass * l2.com_across * l1.length, rel=1e-15)
        assert p[P_M2S2] == pytest.approx(l2.mass * l2.com_across, rel=1e-15)
        assert p[P_MTOT] == pytest.approx(l1.mass + l2.mass, rel=1e-15)
        assert (p[P_B_PIVOT], p[P_C_PIVOT], p[P_B_JOINT], p[P_C_JOINT]) == (
            robot.pivot_friction.viscous, robot.pivot_friction.coulomb,
            robot.joint_friction.viscous, robot.joint_friction.coulomb)


def test_flipped_params_are_the_robot_seen_from_b():
    """docs/model.md section 3: links swap, CGs re-measured from the new proximal ends; friction
    stays with the pivot and the joint; the CGs' offsets across the links change sign; the
    motor's housing stays on its link, which is link 2 seen from B. Row 1 of
    ``Robot.params()`` is that robot."""
    rng = np.random.default_rng(11)
    for robot in [*ROBOTS.values(), *(random_robot(rng, True) for _ in range(10))]:
        l1, l2 = robot.link1, robot.link2
        # each link's direction reverses: its CG's offset across it changes sign
        seen_from_b = Robot(Link(l2.mass, l2.length, l2.length - l2.com, l2.inertia,
                                 -l2.com_across),
                            Link(l1.mass, l1.length, l1.length - l1.com, l1.inertia,
                                 -l1.com_across),
                            gravity=robot.gravity, pivot_friction=robot.pivot_friction,
                            joint_friction=robot.joint_friction,
                            rotor=replace(robot.rotor, housing=3 - robot.rotor.housing))
        par = robot.params()
        np.testing.assert_allclose(dyn.flipped_params(par[0]), seen_from_b.params()[0],
                                   rtol=1e-15, atol=1e-15)
        np.testing.assert_array_equal(par[1], dyn.flipped_params(par[0]))


def test_asymmetric_robot_is_asymmetric():
    """Guard against a vacuous fixture: the flip really changes the asymmetric robot."""
    par = ASYMMETRIC.params()
    assert not np.allclose(par[0], par[1])
