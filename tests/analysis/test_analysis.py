"""Gait analysis: exact fixed points, Floquet multipliers, and the controller-tick question."""

import numpy as np
import pytest

from monkeystudy import Status, horizontal_gait
from monkeystudy.analysis import (
    floquet, jacobian_fd, motorless, open_loop_return_map, sequence_cycles, shoot_grazing,
)

#: A start near the study's valley (the Nelder-Mead iterates from (1, 12) drift here)
START, T_GUESS = (1.44, 10.31), 0.433


@pytest.fixture(scope="module")
def grazing():
    return shoot_grazing(START, T_GUESS)


def _replay(grazing, cycles: int, tick: float = 0.0):
    """The grazing gait replayed open loop: swap at its time, no motor phase."""
    return sequence_cycles(motorless(horizontal_gait(0.6354)),
                           [0.0, grazing.dtheta1, grazing.dtheta2], cycles=cycles,
                           replay="open_loop", times=[grazing.t_switch, grazing.t_switch],
                           tick=tick)


def test_grazing_newton_converges_quadratically(grazing):
    h = np.array(grazing.history)
    assert grazing.converged
    assert h[-1] < 1e-13
    # quadratic convergence: log10 of the residual roughly doubles per step while far from
    # round-off (e.g. 8e-4 -> 3e-6 -> 6e-12)
    logs = -np.log10(h[1:4])
    assert logs[2] / logs[1] > 1.7 and logs[1] / logs[0] > 1.5


def test_grazing_gait_is_an_exact_fixed_point(grazing):
    """Mirror-image links: a collisionless swap makes the gait repeat with no motor."""
    z = np.array([0.0, grazing.dtheta1, grazing.dtheta2])
    zn, status = open_loop_return_map(z, t_switch=grazing.t_switch, t_motor=0.0, torque=0.0)
    assert status == Status.OK
    error = float(np.sum((zn - z) ** 2))  # the study's error measure
    assert error < 1e-20


def test_floquet_of_a_linear_map_is_exact():
    A = np.array([[0.5, 0.2, 0.0], [0.1, -1.3, 0.4], [0.0, 0.3, 0.9]])

    def fmap(z):
        return A @ z + 1.0, Status.OK

    z_star = np.linalg.solve(np.eye(3) - A, np.ones(3))
    fl = floquet(fmap, z_star)
    np.testing.assert_allclose(fl.jacobian, A, atol=1e-9)
    ev = np.linalg.eigvals(A)
    np.testing.assert_allclose(np.sort(np.abs(fl.multipliers)), np.sort(np.abs(ev)), rtol=1e-9)
    assert fl.map_defect < 1e-12


@pytest.mark.slow
def test_open_loop_gait_is_unstable_and_simulation_confirms_the_multiplier(grazing):
    """The leading multiplier predicts the per-cycle growth of an exact-timing run."""
    z = np.array([0.0, grazing.dtheta1, grazing.dtheta2])

    def fmap(q):
        return open_loop_return_map(q, t_switch=grazing.t_switch, t_motor=0.0, torque=0.0)

    fl = floquet(fmap, z)
    lead = abs(fl.multipliers[0])
    assert not fl.stable and lead > 1.2
    run = _replay(grazing, 60)
    e = np.sqrt(run.error)
    # error sqrt grows geometrically by |lambda_max| per cycle in the linear regime
    lin = (e > 1e-10) & (e < 1e-4)
    growth = np.exp(np.polyfit(np.nonzero(lin)[0], np.log(e[lin]), 1)[0])
    assert growth == pytest.approx(lead, rel=0.02)


@pytest.mark.slow
def test_the_1ms_tick_only_seeds_the_instability(grazing):
    """Finer ticks delay the fall, exact timing too falls: the grid was not the cause."""
    fails = {}
    for tick in (1e-3, 1e-5, 0.0):
        run = _replay(grazing, 80, tick)
        assert run.status == Status.FELL
        fails[tick] = int(np.argmax(run.error > 1e-2)) + 1
    assert fails[1e-3] < fails[1e-5] < fails[0.0] < 80


def test_variational_and_finite_difference_jacobians_agree(grazing):
    """Open-loop map at the exact gait: var-eq (saltation/impact Jacobians) vs central FD."""
    from monkeystudy.analysis import variational_jacobian
    z = np.array([0.0, grazing.dtheta1, grazing.dtheta2])
    Jv = variational_jacobian("open_loop", z, t_switch=grazing.t_switch, t_motor=0.0,
                              torque=0.0)
    Jf = jacobian_fd(lambda q: open_loop_return_map(q, t_switch=grazing.t_switch,
                                                    t_motor=0.0, torque=0.0), z)
    assert np.abs(Jv - Jf).max() / np.abs(Jv).max() < 1e-8


#: the state-based controller's attracting gait (found by the 1000-cycle run, polished by
#: Newton): link 1 passes the vertical backwards while link 2 turns a full revolution
CLOSED_LOOP_START = np.array([0.0248, -1.0869, 16.0168])


@pytest.mark.slow
def test_state_based_controller_gait_multipliers():
    """Energy restoration makes one multiplier exactly 1; the others are inside the circle."""
    from monkeystudy.analysis import search_return_map, solve_fixed_point, variational_jacobian
    fp = solve_fixed_point(search_return_map, CLOSED_LOOP_START,
                           jacobian=lambda q: variational_jacobian("search", q))
    assert fp.converged and fp.defect < 1e-12
    h = np.array(fp.history)
    assert h[2] < h[1] ** 1.5 * 10  # superlinear (quadratic) convergence
    Jv = variational_jacobian("search", fp.z)
    Jf = jacobian_fd(search_return_map, fp.z)
    assert np.abs(Jv - Jf).max() / np.abs(Jv).max() < 1e-7
    lam = np.linalg.eigvals(Jv)
    lam = lam[np.argsort(-np.abs(lam))]
    assert np.min(np.abs(lam - 1.0)) < 1e-7        # the neutral energy direction
    others = lam[np.abs(lam - 1.0) > 1e-6]
    assert len(others) == 2 and np.all(np.abs(others) < 1.0)


def test_continuation_recovers_the_gravity_scaling_branch(grazing):
    """Known branch: g -> k^2 g scales rates by k and times by 1/k; multipliers (dimension-
    less) do not change."""
    from monkeystudy.analysis import continue_grazing
    b = continue_grazing(grazing, "gravity", 9.81, ds=0.5, steps=4)
    assert len(b.value) == 5 and b.value[-1] > 11.0
    k = np.sqrt(b.value / 9.81)
    np.testing.assert_allclose(b.dtheta1, grazing.dtheta1 * k, rtol=1e-11)
    np.testing.assert_allclose(b.dtheta2, grazing.dtheta2 * k, rtol=1e-11)
    np.testing.assert_allclose(b.t_switch, grazing.t_switch / k, rtol=1e-11)
    np.testing.assert_allclose(np.abs(b.multipliers),
                               np.broadcast_to(np.abs(b.multipliers[0]), b.multipliers.shape),
                               atol=1e-9)
    assert b.residual.max() < 1e-12
    assert b.folds == [] and b.period_doublings == []


def test_basin_is_peaked_at_the_exact_gait(grazing):
    from monkeystudy.analysis import sequence_basin
    off = np.array([-1e-3, 0.0, 1e-3])
    B = sequence_basin(motorless(horizontal_gait(0.6354)), [0.0, grazing.dtheta1,
                                                             grazing.dtheta2], off, off,
                       max_cycles=60, replay="open_loop",
                       times=[grazing.t_switch, grazing.t_switch])
    assert B[1, 1] == B.max() and B[1, 1] > 3 * np.delete(B.ravel(), 4).max()
