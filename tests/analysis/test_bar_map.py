"""The full map of a gait that catches bars (docs/model.md section 7, "The full map on a
ladder"), and its catches' offset margins and speeds (monkeystudy.analysis.cycle_catches)."""
import numpy as np
import pytest

from monkeystudy.analysis import (
    TIGHT, bar_catch_rows, cycle_catches, cycle_full_map, cycle_return_map, jacobian_fd,
    sorted_eigs,
)
from monkeystudy.analysis.measured_replay import acromonk_robot
from monkeystudy.analysis.variational import sequence_variational_jacobian
from monkeystudy.controllers import Integrator
from monkeystudy.kernel import layout as L
from monkeystudy.robot import Friction, Rotor
from monkeystudy.simulation import run_controller
from monkeystudy.analysis.sections import cycle_section_state
from monkeystudy.study.models import SequenceGaitSpec

from test_motor import BAR_BRACHIATION, Z_BAR_BRACHIATION

INTEG = Integrator(method="dop853", rtol=1e-12, atol=1e-13, max_time=6.0)
Z = np.array(Z_BAR_BRACHIATION)


def bar_robot():
    return acromonk_robot(Friction(0.0, 0.0), Friction(0.04144, 0.0)).with_rotor(
        Rotor(2.453e-4, 6.0, 1))


def bar_gait():
    return SequenceGaitSpec.model_validate(BAR_BRACHIATION).gait()


def test_the_bar_gait_is_a_fixed_point():
    zn, st = cycle_return_map(Z, bar_gait(), robot=bar_robot(), integrator=INTEG)
    assert st == 0
    assert np.linalg.norm(zn - Z) < 1e-8


def test_a_bar_catch_resets_the_height_so_the_full_maps_height_row_is_zero():
    """A catch puts the new attached end on its bar, wherever the state was: after a cycle
    that ends on a bar it caught, the height is the bar's. The full map's height row is zero
    (multiplier 0), not the translation e_y (multiplier 1), by finite differences and by
    variational equations alike, and the other multipliers are the section map's."""
    gait, robot = bar_gait(), bar_robot()
    w = np.concatenate([[0.0], Z])
    J_fd = jacobian_fd(lambda q: cycle_full_map(q, gait, robot=robot, integrator=INTEG), w)
    J_var = sequence_variational_jacobian(gait, w, robot=robot, integrator=INTEG, height=True)
    J_sec = sequence_variational_jacobian(gait, Z, robot=robot, integrator=INTEG)
    assert np.all(J_var[0] == 0.0)
    np.testing.assert_allclose(J_fd[0], 0.0, atol=1e-9)
    np.testing.assert_allclose(J_var, J_fd, atol=1e-6 * np.abs(J_var).max())
    np.testing.assert_allclose(J_var[1:, 1:], J_sec, atol=1e-9)
    lam_full, lam_sec = sorted_eigs(J_var), sorted_eigs(J_sec)
    assert abs(lam_full[-1]) < 1e-12
    np.testing.assert_allclose(lam_full[:3], lam_sec, atol=1e-9)
    np.testing.assert_allclose(np.abs(sorted_eigs(J_fd))[:3], np.abs(lam_sec), atol=1e-6)
    assert max(abs(lam_full)) == pytest.approx(0.423634, abs=1e-6)


def test_a_start_off_its_bar_catches_the_world_fixed_bar():
    """The full map's ladder is fixed in the world: from a start 2 mm above its bar the first
    catch still lands on the bar at height 0 (not 2 mm up), and the cycle ends on the last
    bar's height, 0."""
    w, st = cycle_full_map(np.concatenate([[0.002], Z]), bar_gait(), robot=bar_robot(),
                           integrator=INTEG)
    assert st == 0
    assert w[0] == 0.0


def test_catch_margins_and_speeds_are_the_runs_own_catch_states():
    """Each catch's offset margin and speed against a direct run: the log row of the catch
    holds the grip point (the free end, before the snap) and the sample at the exit the state
    just before the impact; the bar is dx from the end the robot hung from, which after the
    first catch is the first bar."""
    gait, robot = bar_gait(), bar_robot()
    c = cycle_catches(Z, gait, robot=robot, integrator=INTEG)
    assert list(c.segment) == bar_catch_rows(gait) == [0, 3]
    res = run_controller(gait.controller(), cycle_section_state(gait, Z), robot=robot,
                         integrator=INTEG, cycles=1, sample_dt=1e-5)
    log = res.log[res.log[:, L.L_KIND] == L.LOG_SEGMENT]
    bars = [(-0.34, 0.0), (-0.68, 0.0)]            # world x, y of the bars caught
    for k, (row, bar) in enumerate(zip((0, 3), bars)):
        grip = log[row, L.L_STATE + L.X]             # the catch row: before the snap
        assert c.margin[k] == pytest.approx(0.03 - abs(grip - bar[0]), abs=1e-12)
        assert 0.0 < c.margin[k] < 0.03
        # the free end's velocity from its positions at the last two samples of the swing
        # that ends at the catch (the run samples the state before the impact at its exit)
        t_catch = log[row, L.L_T]
        before = np.flatnonzero((res.sample_t <= t_catch) & (res.sample_segment == row))[-2:]
        assert res.sample_t[before[-1]] == t_catch
        pts = [res.sample_state[i] for i in before]
        p = res.params[int(res.sample_flipped[before[-1]])]
        ends = [np.array([s[L.X] + p[L.P_L1] * np.sin(s[L.TH1]) + p[L.P_L2] * np.sin(
                          s[L.TH1] + s[L.TH2]),
                          s[L.Y] - p[L.P_L1] * np.cos(s[L.TH1]) - p[L.P_L2] * np.cos(
                          s[L.TH1] + s[L.TH2])]) for s in pts]
        v = (ends[1] - ends[0]) / (res.sample_t[before[1]] - res.sample_t[before[0]])
        assert c.speed[k] == pytest.approx(np.hypot(*v), rel=1e-4)
    np.testing.assert_allclose(c.margin, [0.01889087, 0.00538868], atol=1e-7)
