"""Sequence gaits (controllers.SequenceGait, simulation.evaluate_cycle_gaits): the study's gait
written as a sequence, the guard values that make climbing gaits, the static frame walk."""
import dataclasses
import math

import numpy as np
import pytest

from monkeystudy import Robot, Segment, SequenceGait, evaluate_cycle_gaits, evaluate_gaits
from monkeystudy.analysis import cycle_return_map, search_return_map
from monkeystudy.controllers import Integrator
from monkeystudy.kernel import layout as L
from monkeystudy.simulation import energies

TIGHT = Integrator(rtol=1e-12, atol=1e-13)
HORIZONTAL = SequenceGait([
    Segment("free_end_height", direction="rising", latch_energy=True,
            fail_status=L.ST_NO_SWITCH),
    Segment("energy_restored", direction="rising", magnets="swap", torque=0.6354,
            fail_status=L.ST_ENERGY_NOT_RESTORED),
])
POINTS = np.array([[0.902, 10.935], [1.0, 11.0], [0.5, 12.5], [2.0, 9.5], [0.1, 9.0]])


def test_horizontal_gait_as_a_sequence_is_the_horizontal_gait():
    a = evaluate_cycle_gaits(POINTS, HORIZONTAL)
    b = evaluate_gaits(POINTS, skip_unreachable=False)
    np.testing.assert_array_equal(a["status"], b["status"])
    ok = b["status"] == L.ST_OK
    assert ok.sum() >= 2 and (~ok).sum() >= 1
    np.testing.assert_allclose(a["error"][ok], b["error"][ok], rtol=1e-12, atol=0)
    assert np.all(np.isnan(a["error"][~ok]))
    # the same steps: the swap, the motor stop and the end are the same events
    np.testing.assert_array_equal(a["t_segment"][ok, 0], b["t_switch"][ok])
    np.testing.assert_array_equal(a["t_segment"][ok, 2], b["t_end"][ok])
    np.testing.assert_array_equal(a["t_end"][ok], b["t_end"][ok])
    np.testing.assert_array_equal(a["nfev"], b["nfev"])
    assert np.all(a["flipped"][ok] == 1)


def test_sequence_return_map_is_the_search_controllers():
    z = np.array([0.02475681, -1.08686037, 16.0167845])
    zs, ss = search_return_map(z, integrator=TIGHT)
    zq, sq = cycle_return_map(z, HORIZONTAL, integrator=TIGHT)
    assert ss == sq == 0
    np.testing.assert_allclose(zq, zs, rtol=0, atol=1e-12)


def test_climbing_guards_catch_at_the_height_and_add_the_climb_energy():
    dh = 0.05
    robot = Robot.preset("seed2009")
    m = robot.link1.mass + robot.link2.mass
    climb = SequenceGait([
        Segment("free_end_height", value=dh, direction="rising", latch_energy=True),
        Segment("energy_restored", value=m * robot.gravity * dh, magnets="swap",
                torque=0.6354),
    ], theta2=1.0)
    z = np.array([1.0, 4.46689255, 0.07213651])
    r = evaluate_cycle_gaits([[z[1], z[2]]], climb, integrator=TIGHT)
    assert r["status"][0] == L.ST_OK
    # the new magnet is dh above the old one: the free end was caught exactly there
    assert abs(r["y_advance"][0] - dh) < 1e-12
    # energy at the section: the start's plus the climb's potential energy (world frame)
    par = robot.params()
    s0 = np.array([0.0, 0.0, 0.0, z[0], 0.0, 0.0, z[1], z[2]])
    k0, v0 = energies(par, s0[None], np.array([0]))
    s1 = r["final_state"][0]
    k1, v1 = energies(par, s1[None], np.array([r["flipped"][0]]))
    assert abs((k1 + v1)[0] - (k0 + v0)[0] - m * robot.gravity * dh) < 1e-9


def test_section_error_wraps_theta2_by_whole_turns():
    base = evaluate_cycle_gaits(POINTS[:2], HORIZONTAL, integrator=TIGHT)
    turned = evaluate_cycle_gaits(POINTS[:2], SequenceGait(HORIZONTAL.segments,
                                                           theta2=2 * math.pi),
                                  integrator=TIGHT)
    # theta2 = 2 pi is the same configuration; the section error does not see the turn (the
    # runs differ only by the integrator's error: |theta2| enters the tolerance scale)
    assert abs(turned["final_state"][0, L.TH2] - base["final_state"][0, L.TH2]) > 6.0
    np.testing.assert_allclose(turned["error"], base["error"], rtol=1e-7)


def test_static_frame_walk():
    assert HORIZONTAL.end_attached() == "B"
    two = SequenceGait([*HORIZONTAL.segments, Segment("free_end_height", magnets="keep"),
                        Segment("energy_restored", magnets="swap", torque=0.6)])
    assert two.end_attached() == "A"
    flight = SequenceGait([Segment("coord", value=0.6), Segment("free_end_y", magnets="none"),
                           Segment("energy_restored", magnets="B", torque=0.6)])
    assert flight.end_attached() == "B"
    assert [sorted(e) for e in flight.attached_ends()] == [["A"], [], ["B"], ["B"]]
    with pytest.raises(ValueError, match="no magnet on"):
        SequenceGait([Segment("coord", value=0.6), Segment("free_end_y", magnets="none")])
    with pytest.raises(ValueError, match="both magnets"):
        SequenceGait([Segment("time", value=0.1, magnets="both")])
    with pytest.raises(ValueError, match="at least one segment"):
        SequenceGait([])


def test_a_cycle_ending_on_b_that_names_its_ends_loops_with_its_mirror_image():
    """A run of many cycles of a gait whose cycle ends hanging from B and acts on a named end
    (a catch with B) loops over the cycle and its mirror image (the next cycle, hanging from
    B, catches with A); every other gait loops over its one cycle, row for row."""
    flight = SequenceGait([Segment("coord", value=0.6), Segment("free_end_y", magnets="none"),
                           Segment("energy_restored", magnets="B", torque=0.6)])
    assert flight.alternates
    rows = flight.loop_segments()
    assert rows[:3] == flight.all_segments()[:3]
    assert [s.magnets for s in rows] == ["keep", "none", "B", "keep", "keep", "none", "A",
                                         "keep"]
    assert rows[4:] == [dataclasses.replace(s, magnets={"B": "A"}.get(s.magnets, s.magnets))
                        for s in flight.all_segments()]
    assert flight.cycle_end_rows() == [3, 7] and flight.loop_magnet_rows() == [0, 1, 4, 5]
    prog, obs = flight.loop_controller(flight.section_observers()).program()
    assert prog[:, L.S_NEXT].tolist() == [1, 2, 3, 4, 5, 6, 7, 0]
    assert prog[:, L.S_CYCLE].tolist() == [0, 0, 0, 1, 0, 0, 0, 1]
    assert prog[6, L.S_MAG_A] == 1 and prog[6, L.S_MAG_B] == 0
    assert obs[:, L.O_SEGMENT].tolist() == [3, 7]
    two = SequenceGait([*HORIZONTAL.segments, Segment("free_end_height"),
                        Segment("energy_restored", magnets="swap", torque=0.6)])
    on_a = SequenceGait([Segment("coord", value=0.6), Segment("free_end_y", magnets="none"),
                         Segment("energy_restored", magnets="A", torque=0.6)])
    for gait in (HORIZONTAL, two, on_a):
        assert not gait.alternates
        assert gait.loop_segments() == gait.all_segments()
        assert gait.section_observers() == (gait.section_observer(),)
        np.testing.assert_array_equal(gait.loop_controller().program()[0],
                                      gait.controller().program()[0])


def test_non_mirror_robot_cycle_ending_on_b_is_refused():
    from monkeystudy import Link

    lop = Robot(Link(1.0, 0.61, 0.5, 0.018), Link(1.0, 0.61, 0.2, 0.018))
    with pytest.raises(ValueError, match="mirror-image links"):
        cycle_return_map([0.0, 1.0, 11.0], HORIZONTAL, robot=lop)


# --- the horizontal gait as a preset (controllers.horizontal_gait) -----------------------------
TAU = 0.6354
#: the smoke study's grid (tick 1 ms): points below the swap energy floor, points whose link 2
#: ends more than pi from its start (where a wrapped error would differ), and gaits
SMOKE_GRID = np.stack(np.meshgrid(np.linspace(0.0, 2.0, 9), np.linspace(9.5, 12.5, 11),
                                  indexing="ij"), -1).reshape(-1, 2)


def _table_diff(a: np.ndarray, b: np.ndarray) -> list:
    """``(row, column)`` of the entries where two program tables differ."""
    return [tuple(int(i) for i in rc) for rc in np.argwhere(a != b)]


def test_horizontal_preset_program_is_the_search_controllers_and_open_loops():
    from monkeystudy import HorizontalSearch, OpenLoop
    from monkeystudy.analysis.replay import open_loop_gait
    from monkeystudy.controllers import CYCLE_VERTICAL, PhaseSequence, horizontal_gait

    pre = horizontal_gait(TAU, 0.001)
    prog, obs = pre.program()
    # one cycle: the search controller's rows; its end stops (next -1), the preset's loops
    # back and restarts the clock, which changes nothing once max_cycles = 1 ends the run
    search, _ = HorizontalSearch(TAU, tick=0.001).program()
    assert _table_diff(search, prog) == [(2, L.S_NEXT), (2, L.S_CLOCK)]
    looped, _ = HorizontalSearch(TAU, tick=0.001, loop=True).program()
    assert _table_diff(looped, prog) == [(2, L.S_CLOCK)]   # no time guard reads the clock
    assert obs.shape[0] == 0 and prog[2, L.S_TICKED] == 0.0   # the section is exact
    # its open-loop replay is OpenLoop's program, the section sensed on the tick included;
    # only the energy latch of row 0 is kept (nothing reads it without an energy guard)
    for clock, period in (("reset_at_vertical", math.nan), ("run_on", 0.77)):
        rep = open_loop_gait(horizontal_gait(TAU, 0.001, period=period), [0.43, 0.43 + 0.024])
        ol_prog, ol_obs = OpenLoop(0.43, 0.024, TAU, tick=0.001, clock=clock,
                                   period=period).program()
        rep_prog, rep_obs = PhaseSequence(rep.all_segments(), (rep.section_observer(),),
                                          rep.tick).program()
        assert _table_diff(ol_prog, rep_prog) == [(0, L.S_SET_EREF)]
        np.testing.assert_array_equal(rep_obs, ol_obs)
        np.testing.assert_array_equal(rep_obs[0], CYCLE_VERTICAL.row())


def _search_controller_batch(points: np.ndarray, tick: float) -> dict:
    """The kernel's own evaluation of the horizontal gait (the search controller's program,
    the unreachable pre-check and the 2009 error in one compiled batch)."""
    from monkeystudy import HorizontalSearch
    from monkeystudy.controllers import kernel_method, settings_vector
    from monkeystudy.kernel import gait as K

    robot = Robot.preset("seed2009")
    prog, _ = HorizontalSearch(TAU, tick=tick).program()
    settings = settings_vector(Integrator(), tick=tick)
    out = np.empty((points.shape[0], K.N_RESULT))
    K.horizontal_gait_batch(kernel_method(settings, prog, L.PHASE_SWING), robot.params(), prog,
                            settings, np.ascontiguousarray(points), robot.swap_energy_floor(),
                            True, out)
    return {"error": out[:, K.R_ERROR], "status": out[:, K.R_STATUS].astype(np.int8),
            "t_switch": out[:, K.R_T_SWITCH], "t_motor": out[:, K.R_T_MOTOR],
            "t_end": out[:, K.R_T_END], "steps": out[:, K.R_STEPS].astype(np.int64),
            "nfev": out[:, K.R_NFEV].astype(np.int64),
            "rejected": out[:, K.R_REJECTED].astype(np.int64),
            "final_state": out[:, K.R_FINAL:K.R_FINAL + 8]}


def test_horizontal_preset_evaluation_is_the_search_controllers():
    """One cycle of the preset is the kernel's horizontal-gait evaluation, bit for bit: the
    same run, the 2009 error (theta2 not wrapped), the unreachable starts skipped; and
    evaluate_gaits names its times as that evaluation does."""
    from monkeystudy.controllers import horizontal_gait

    h = _search_controller_batch(SMOKE_GRID, 0.001)
    s = evaluate_cycle_gaits(SMOKE_GRID, horizontal_gait(TAU, 0.001))
    ok = h["status"] == L.ST_OK
    assert np.sum(h["status"] == L.ST_UNREACHABLE) >= 5
    assert np.sum(ok & (np.abs(s["final_state"][:, L.TH2]) >= math.pi)) >= 1
    for key in ("error", "status", "steps", "nfev", "rejected", "final_state"):
        assert h[key].tobytes() == s[key].tobytes(), key
    t = s["t_segment"]
    assert h["t_switch"].tobytes() == t[:, 0].tobytes()
    assert h["t_motor"].tobytes() == (t[:, 1] - t[:, 0]).tobytes()
    assert h["t_end"].tobytes() == t[:, 2].tobytes()
    g = evaluate_gaits(SMOKE_GRID, torque=TAU, tick=0.001)
    for key in h:
        assert h[key].tobytes() == np.asarray(g[key]).tobytes(), key
    # without the pre-check the starts below the floor are integrated: they never swap
    every = evaluate_cycle_gaits(SMOKE_GRID, horizontal_gait(TAU, 0.001),
                                 skip_unreachable=False)
    low = h["status"] == L.ST_UNREACHABLE
    assert np.all(every["status"][low] == L.ST_NO_SWITCH) and np.all(every["steps"][low] > 0)


def test_preset_properties_are_checked():
    from monkeystudy.controllers import horizontal_gait

    pre = horizontal_gait(TAU)
    assert not pre.wrap_theta2 and pre.unreachable_below_floor and pre.records == "swap"
    assert pre.starts_by_free_swing() and pre.magnet_rows() == [0]
    with pytest.raises(ValueError, match="swings freely"):
        SequenceGait([Segment("time", value=0.4), Segment("time", value=0.5, magnets="swap")],
                     unreachable_below_floor=True)
    two = SequenceGait([*HORIZONTAL.segments, Segment("free_end_height"),
                        Segment("energy_restored", magnets="swap", torque=0.6)])
    with pytest.raises(ValueError, match="exactly one magnet action"):
        SequenceGait(two.segments, records="swap")


def _runs_equal(a, b, differ: tuple = ()) -> None:
    """Two runs are the same run: final state (but the hybrid entries ``differ``, which the
    programs set differently and nothing reads), event log, samples and counts."""
    assert a.status == b.status
    keep = np.setdiff1d(np.arange(L.N_HYB), differ)
    assert a.state[keep].tobytes() == b.state[keep].tobytes()
    assert a.log.tobytes() == b.log.tobytes()
    assert a.sample_t.tobytes() == b.sample_t.tobytes()
    assert a.sample_state.tobytes() == b.sample_state.tobytes()
    np.testing.assert_array_equal(a.counts, b.counts)


@pytest.mark.parametrize("tick", [0.001, 0.0])
def test_horizontal_preset_runs_are_the_2009_controllers_runs(tick):
    """Many cycles of the preset's controllers are the 2009 controllers' runs, bit for bit:
    its open-loop replay (section on the tick, observed exactly) is OpenLoop's, with the
    clock restarting at the vertical or running on; its own controller observed at the
    section is the looping search controller's."""
    from monkeystudy import HorizontalSearch, OpenLoop, initial_state, run_controller
    from monkeystudy.analysis.replay import open_loop_gait
    from monkeystudy.controllers import PhaseSequence, horizontal_gait

    d1, d2, t_sw, t_m = 0.89938149, 10.93372088, 0.43, 0.024
    start = initial_state(d1, d2)
    kw = dict(integrator=Integrator(), max_drop=0.61, sample_dt=0.005)
    for clock, period in (("reset_at_vertical", math.nan), ("run_on", 0.7713)):
        rep = open_loop_gait(horizontal_gait(TAU, tick, period=period), [t_sw, t_sw + t_m])
        ctrl = PhaseSequence(rep.all_segments(), (rep.section_observer(),), rep.tick)
        a = run_controller(OpenLoop(t_sw, t_m, TAU, tick=tick, clock=clock, period=period),
                           start, cycles=12, **kw)
        b = run_controller(ctrl, start, cycles=12, **kw)
        assert a.counts[L.K_CYCLES] >= 3
        _runs_equal(a, b, differ=(L.H_EREF,))    # the replay keeps row 0's energy latch
    pre = horizontal_gait(TAU, tick)
    z = [0.02475681, -1.08686037, 16.0167845]
    start = initial_state(z[1], z[2], theta2=z[0])
    a = run_controller(HorizontalSearch(TAU, tick=tick, loop=True), start, cycles=8, **kw)
    b = run_controller(PhaseSequence(pre.all_segments(), (pre.section_observer(),), tick),
                       start, cycles=8, **kw)
    assert a.counts[L.K_CYCLES] == 8
    _runs_equal(a, b, differ=(L.H_CLOCK,))   # the preset restarts its clock at the section


def test_per_swap_records_read_the_open_loop_run():
    """``records='swap'``: per swap the attached end just after it; per swap the first
    section crossing after it, with the 2009 error against the start row by row."""
    from monkeystudy import OpenLoop, initial_state, run_controller
    from monkeystudy.analysis.replay import sequence_cycles
    from monkeystudy.controllers import horizontal_gait
    from monkeystudy.simulation import gait_error

    d1, d2, t_sw, t_m = 0.89938149, 10.93372088, 0.43, 0.024
    r = sequence_cycles(horizontal_gait(TAU, 0.001), [0.0, d1, d2], cycles=30,
                        integrator=Integrator(), replay="open_loop", times=[t_sw, t_sw + t_m])
    res = run_controller(OpenLoop(t_sw, t_m, TAU, tick=0.001), initial_state(d1, d2),
                         cycles=30, max_drop=0.61)
    log = res.log
    swaps = log[(log[:, L.L_KIND] == L.LOG_SEGMENT) & (log[:, L.L_ID] == 0)]
    cross = log[log[:, L.L_KIND] == L.LOG_OBSERVER]
    assert r.status == res.status and len(swaps) == len(cross) + 1 >= 5  # the last one fell
    assert r.t_swap.tobytes() == swaps[:, L.L_T].tobytes()
    assert r.pivot_height.tobytes() == swaps[:, L.L_STATE + L.Y].tobytes()
    assert r.t_cross.tobytes() == cross[:, L.L_T].tobytes()
    err = np.array([gait_error(row[L.L_STATE:L.L_STATE + 8], d1, d2) for row in cross])
    assert r.error.tobytes() == err.tobytes()
