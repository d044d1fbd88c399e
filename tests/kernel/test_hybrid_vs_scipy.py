"""The hybrid gait against an independent scipy implementation (docs/model.md section 4).

The reference (``tests/reference/model.py``) derives the equations of motion with sympy, applies
the impact with the explicit projection matrix and runs the horizontal gait as chained
``solve_ivp(method="DOP853", rtol=atol=1e-13)`` calls with terminal, directed events:
B rises to A's height (+1), the energy is restored (+1), theta1 crosses 0 (either). The kernel
runs at the same tolerances. Event times, the gait error and the final state must agree to
1e-9 on a spread of points, robots and signed torques, including grazing swaps where B only
just reaches A's height (which scipy's own event detection steps over: the reference recovers
those crossings at the guard's maximum, see ``_first_crossing``), and with the 1 ms controller
tick. Each located event must satisfy its guard to 1e-12.
"""
import math

import numpy as np
import pytest

from monkeystudy import (
    HorizontalSearch, Integrator, evaluate_gaits, evaluate_horizontal_gait, initial_state,
    run_controller,
)
from monkeystudy.kernel import dynamics as dyn
from monkeystudy.kernel.layout import (
    L_E_AFTER, L_E_BEFORE, L_ID, L_KIND, L_STATE, L_T, LOG_SEGMENT, ST_NO_SWITCH, ST_OK,
    ST_UNREACHABLE,
)
from reference import model as ref_model

from .helpers import ROBOTS, grazing_point, random_robot, reference_robot

KERNEL = Integrator("dop853", rtol=1e-13, atol=1e-13)
TOL = 1e-9          # event times [s], final state, and gait error (relative to max(1, e))
GUARD_TOL = 1e-12


_ref = reference_robot


def _same_status(kernel_status, ref_status):
    if ref_status == ref_model.NO_SWITCH:   # the kernel may prove it without integrating
        return kernel_status in (ST_NO_SWITCH, ST_UNREACHABLE)
    return kernel_status == ref_status


def _compare(name, tau, d1, d2, tick=0.0, ref_kw=None):
    g = ref_model.horizontal_gait(_ref(name), d1, d2, tau, tick=tick, **(ref_kw or {}))
    k = evaluate_horizontal_gait(d1, d2, robot=ROBOTS[name], torque=tau, tick=tick,
                                 integrator=KERNEL)
    assert _same_status(int(k.status), g.status), (k.status, g.status)
    if g.status == ref_model.NO_SWITCH:
        return g, k
    assert abs(k.t_switch - g.t_switch) <= TOL, (k.t_switch, g.t_switch)
    if g.status == ref_model.ENERGY_NOT_RESTORED:
        return g, k
    assert abs(k.t_motor - g.t_motor) <= TOL, (k.t_motor, g.t_motor)
    if g.status == ref_model.NO_RETURN:
        return g, k
    assert abs(k.t_end - g.t_end) <= TOL, (k.t_end, g.t_end)
    assert abs(k.error - g.error) <= TOL * max(1.0, abs(g.error)), (k.error, g.error)
    fs = g.final_state
    np.testing.assert_allclose(k.final_state[[0, 1, 3, 6, 7]], fs[[0, 1, 3, 6, 7]], rtol=0,
                               atol=TOL * max(1.0, np.max(np.abs(fs))))
    assert abs(k.final_state[2]) <= GUARD_TOL and abs(fs[2]) <= GUARD_TOL
    return g, k


# (robot, torque [N m], dtheta1, dtheta2): successful gaits, both torque signs, the study's
# point ...
OK_POINTS = [
    ("seed2009", 0.6354, 0.902, 10.935),       # the study's point (docs/model.md section 4)
    ("seed2009", 0.6354, -1.0, 15.0),
    ("seed2009", 0.6354, 4.5, 1.0),
    ("seed2009", -0.6354, 1.0, -15.0),
    ("seed2009", -0.6354, -4.5, -1.0),
    ("seed2009", 2.0, 5.0, -3.0),
    ("seed2009", -2.0, 1.0, -16.0),
    ("uniform_rod", 2.0, 3.5, 4.0),
    ("uniform_rod", 2.0, 6.0, -6.0),
    ("uniform_rod", -2.0, -3.5, -4.0),
    ("uniform_rod", 0.6354, -4.0, -2.0),
    ("asymmetric", 2.0, 5.0, -2.0),
    ("asymmetric", 2.0, 4.5, 3.0),
    ("asymmetric", -2.0, -5.0, 2.0),
    ("asymmetric", 0.6354, -4.5, -2.0),
    ("asymmetric", 0.6354, 4.5, 4.0),
]
# ... and points whose gait fails for each documented reason
FAIL_POINTS = [
    ("seed2009", 0.6354, 2.0, 0.0),            # no switch (energy above the floor)
    ("asymmetric", 0.6354, 4.0, 0.0),          # no switch
    ("uniform_rod", 0.6354, -5.0, -4.0),       # energy never restored
    ("asymmetric", 0.6354, -5.0, 4.0),         # energy never restored
    ("uniform_rod", 2.0, 6.0, 4.0),            # link 1 never back to theta1 = 0
]
POINTS = OK_POINTS + FAIL_POINTS


@pytest.mark.slow
@pytest.mark.parametrize("name,tau,d1,d2", POINTS)
def test_gait_matches_reference(name, tau, d1, d2):
    _compare(name, tau, d1, d2)


@pytest.mark.nojit
def test_study_point():
    """docs/model.md section 4's numbers for seed2009 at (0.902, 10.935), tau = 0.6354."""
    g, k = _compare("seed2009", 0.6354, 0.902, 10.935)
    assert k.status == ST_OK
    assert k.t_switch == pytest.approx(0.42766, abs=5e-6)
    assert k.t_motor == pytest.approx(0.02531, abs=5e-6)
    assert k.error == pytest.approx(1.4376e-4, rel=1e-4)


@pytest.mark.nojit
@pytest.mark.parametrize("d1,d2", [(-1.0, 15.0), (-4.0, 13.0)])
def test_folded_swap_matches_reference(d1, d2):
    """Named fixture: link 2 passes the folded position (theta2 = pi, B *at* A) rising, which
    for equal links is a swap. The post-swap theta2 = -pi exactly: the kernel used to wrap
    it into [-pi, pi), so its branch (and the gait error, by ~(2 pi)^2) was round-off's."""
    g, k = _compare("seed2009", 0.6354, d1, d2)
    assert k.status == ST_OK
    res = run_controller(HorizontalSearch(0.6354), initial_state(d1, d2), robot="seed2009",
                         integrator=KERNEL)
    assert abs(abs(res.log[0, L_STATE + 3]) - math.pi) < 1e-9   # folded at the swap


@pytest.mark.nojit
def test_gait_error_has_no_branch_jumps():
    """Along a line of starts that swap folded, the error varies smoothly (no 2 pi jumps)."""
    d2 = np.linspace(14.5, 15.5, 41)
    r = evaluate_gaits(np.c_[np.full_like(d2, -1.0), d2], robot="seed2009", torque=0.6354)
    assert np.all(r["status"] == ST_OK)
    assert np.max(np.abs(np.diff(r["error"]))) < 0.05, r["error"]


# ----------------------------------------------------------------------------------------------
# grazing swaps: B rises to delta above A at its highest
# ----------------------------------------------------------------------------------------------
GRAZING = [  # (robot, direction of (dtheta1, dtheta2), delta [m], torque)
    ("seed2009", (0.0, 1.0), 1e-4, 0.6354),
    ("seed2009", (0.0, 1.0), 1e-6, -1.5),
    ("seed2009", (0.3, 1.0), 1e-6, 0.6354),
    ("uniform_rod", (1.0, -1.0), 1e-6, 0.6354),
    ("asymmetric", (0.3, 1.0), 1e-6, 0.6354),
    ("asymmetric", (1.0, -1.0), 1e-5, -1.5),
]


@pytest.mark.slow
@pytest.mark.parametrize("name,u,delta,tau", GRAZING)
def test_grazing_gait_matches_reference(name, u, delta, tau):
    d1, d2 = grazing_point(name, u, delta)
    t_max, h_max = ref_model.first_height_maximum(_ref(name), d1, d2)
    assert h_max == pytest.approx(delta, rel=1e-6)
    g, k = _compare(name, tau, d1, d2)
    assert g.t_switch < t_max   # the rising crossing, before the summit
    # just below the border, B never reaches A on that swing: the swap comes later, or never
    d1m, d2m = grazing_point(name, u, -delta)
    g, k = _compare(name, tau, d1m, d2m)
    assert not (g.t_switch <= t_max * 1.5)


# ----------------------------------------------------------------------------------------------
# the 1 ms controller tick
# ----------------------------------------------------------------------------------------------
TICK = 1e-3


def _on_grid(t):
    return abs(t / TICK - round(t / TICK)) <= 1e-9


@pytest.mark.nojit
@pytest.mark.parametrize("name,tau,d1,d2", [
    ("seed2009", 0.6354, 0.902, 10.935),
    ("seed2009", -0.6354, -4.5, -1.0),
    ("uniform_rod", 2.0, 3.5, 4.0),
    ("asymmetric", 0.6354, -4.5, -2.0),
])
def test_ticked_gait_matches_reference(name, tau, d1, d2):
    g, k = _compare(name, tau, d1, d2, tick=TICK)
    assert k.status == ST_OK
    ts, tm = k.t_switch, k.t_switch + k.t_motor
    assert _on_grid(ts) and _on_grid(tm), (ts, tm)
    # acted on at the first tick at or after the exact crossing
    exact = evaluate_horizontal_gait(d1, d2, robot=ROBOTS[name], torque=tau, integrator=KERNEL)
    assert exact.t_switch <= ts < exact.t_switch + TICK
    if name == "seed2009" and d1 == 0.902:   # the numbers of docs/model.md section 4 / README
        assert ts == pytest.approx(0.428, abs=1e-12)
        assert k.t_motor == pytest.approx(0.025, abs=1e-12)


# ----------------------------------------------------------------------------------------------
# each located event satisfies its guard
# ----------------------------------------------------------------------------------------------
@pytest.mark.nojit
@pytest.mark.parametrize("name,tau,d1,d2", OK_POINTS[::2])
def test_events_satisfy_guards(name, tau, d1, d2):
    robot = ROBOTS[name]
    par = robot.params()
    res = run_controller(HorizontalSearch(tau), initial_state(d1, d2), robot=robot,
                         integrator=KERNEL)
    assert res.status == ST_OK
    rows = res.log[res.log[:, L_KIND] == LOG_SEGMENT]
    assert list(rows[:, L_ID]) == [0, 1, 2]
    e0 = dyn.total_energy8(par[0], initial_state(d1, d2)[:8])
    # swap: the new pivot (B) is at A's height (A hangs at y = 0), world frame carried over
    swap = rows[0]
    s = swap[L_STATE:L_STATE + 8]
    assert abs(s[1]) <= GUARD_TOL
    assert s[4] == 0.0 and s[5] == 0.0
    assert swap[L_E_AFTER] <= swap[L_E_BEFORE]
    assert swap[L_E_BEFORE] == pytest.approx(e0, abs=1e-9 * (1 + abs(e0)))  # no motor yet
    # motor off: energy back to E0
    off = rows[1]
    assert abs(off[L_E_BEFORE] - e0) <= GUARD_TOL * (1.0 + abs(e0))
    # end: theta1 = 0
    end = rows[2]
    assert abs(end[L_STATE + 2]) <= GUARD_TOL
    assert res.segment_times[0] == swap[L_T] < off[L_T] < end[L_T]


@pytest.mark.nojit
def test_ticked_events_satisfy_their_conditions():
    """On the tick, B is above A at the swap (the pivot rises) and the energy is at or above
    E0 when the motor goes off (a small surplus)."""
    robot = ROBOTS["seed2009"]
    par = robot.params()
    res = run_controller(HorizontalSearch(0.6354, tick=TICK), initial_state(0.902, 10.935),
                         robot=robot, integrator=KERNEL)
    assert res.status == ST_OK
    rows = res.log[res.log[:, L_KIND] == LOG_SEGMENT]
    e0 = dyn.total_energy8(par[0], initial_state(0.902, 10.935)[:8])
    assert rows[0, L_STATE + 1] > 0.0
    assert rows[1, L_E_BEFORE] >= e0
    assert _on_grid(rows[0, L_T]) and _on_grid(rows[1, L_T])
    assert abs(rows[2, L_STATE + 2]) <= GUARD_TOL   # the end is exact, never ticked


# ----------------------------------------------------------------------------------------------
# symmetry and the energy floor
# ----------------------------------------------------------------------------------------------
@pytest.mark.nojit
@pytest.mark.parametrize("name,tau,d1,d2", OK_POINTS[::3] + FAIL_POINTS[1:3])
def test_mirror_symmetry(name, tau, d1, d2):
    """Reflecting the world in the vertical (theta -> -theta, torque -> -torque) gives the
    same gait: same times and error."""
    kw = dict(robot=ROBOTS[name], integrator=Integrator("dop853", 1e-10, 1e-12))
    a = evaluate_horizontal_gait(d1, d2, torque=tau, **kw)
    b = evaluate_horizontal_gait(-d1, -d2, torque=-tau, **kw)
    assert a.status == b.status
    for f in ("t_switch", "t_motor", "t_end", "error"):
        va, vb = getattr(a, f), getattr(b, f)
        assert (math.isnan(va) and math.isnan(vb)) or va == pytest.approx(vb, rel=1e-12,
                                                                          abs=1e-12)
    np.testing.assert_allclose(a.final_state * [-1, 1, -1, -1, -1, 1, -1, -1], b.final_state,
                               rtol=1e-12, atol=1e-12)


def _swap_surface_min_potential(robot, n=200001):
    """Least potential energy with B at A's height, by brute force on the swap surface,
    sampled along th1 and along th1 + th2 (where one's cosine nears +-1 the surface turns
    fast in it, and the other samples it evenly)."""
    l1, l2 = robot.link1, robot.link2
    angle = np.linspace(-np.pi, np.pi, n)
    pairs = []
    for ratio, first in ((l1.length / l2.length, True), (l2.length / l1.length, False)):
        # the other angle's cosine is -ratio times this one's: keep where it exists
        c_other = -ratio * np.cos(angle)
        ok = np.abs(c_other) <= 1.0
        for sgn in (1.0, -1.0):
            other = sgn * np.arccos(c_other[ok])
            pairs.append((angle[ok], other) if first else (other, angle[ok]))
    best = np.inf
    for th1, th12 in pairs:
        # docs/model.md section 1, the CGs' heights with their offsets across the links
        v = -robot.gravity * ((l1.mass * l1.com + l2.mass * l1.length) * np.cos(th1)
                              - l1.mass * l1.com_across * np.sin(th1)
                              + l2.mass * l2.com * np.cos(th12)
                              - l2.mass * l2.com_across * np.sin(th12))
        best = min(best, v.min())
    return best


@pytest.mark.nojit
def test_swap_energy_floor():
    rng = np.random.default_rng(41)
    robots = [*ROBOTS.values(), *(random_robot(rng) for _ in range(20))]
    for robot in robots:
        floor = robot.swap_energy_floor()
        brute = _swap_surface_min_potential(robot)
        assert floor <= brute + 1e-12 * (1 + abs(brute))
        assert brute - floor <= 1e-8 * (1 + abs(floor)), (robot, floor, brute)


@pytest.mark.nojit
@pytest.mark.parametrize("name", list(ROBOTS))
def test_unreachable_points_never_switch(name):
    """A start just below the energy floor: marked unreachable without integrating, and
    integrating it anyway (kernel and reference) never reaches the swap."""
    robot = ROBOTS[name]
    par = robot.params()
    floor = robot.swap_energy_floor()
    u = np.array([0.3, 1.0])
    M, _, _ = dyn.flight_matrices(par[0], np.zeros(8))
    k_unit = 0.5 * u @ M[2:, 2:] @ u
    v0 = dyn.potential_energy(par[0], 0.0, 0.0, 0.0)
    s = math.sqrt((floor - v0) * (1 - 1e-6) / k_unit)
    d1, d2 = s * u
    assert dyn.total_energy8(par[0], initial_state(d1, d2)[:8]) < floor
    r = evaluate_gaits([[d1, d2]], robot=robot, integrator=KERNEL)
    assert r["status"][0] == ST_UNREACHABLE
    r = evaluate_gaits([[d1, d2]], robot=robot, integrator=KERNEL, skip_unreachable=False)
    assert r["status"][0] == ST_NO_SWITCH
    g = ref_model.horizontal_gait(_ref(name), d1, d2, 0.6354)
    assert g.status == ref_model.NO_SWITCH
