"""Many cycles of a sequence gait (monkeystudy.analysis.replay): its own controller and the open-loop
replay, checked against the return map, its linearisation and the controller tick."""
import dataclasses
import math
from functools import partial

import numpy as np
import pytest

from monkeystudy.analysis import cycle_return_map, floquet
from monkeystudy.controllers import Integrator, Segment, horizontal_gait, motorless
from monkeystudy.kernel import layout as L
from monkeystudy.analysis.replay import (
    cycle_times, growth_per_cycle, open_loop_gait, section_error, sequence_basin,
    sequence_cycles,
)
from monkeystudy.simulation import evaluate_cycle_gaits

from sequencegaits import INTEG, flight, two_step

TIGHT = Integrator(method="dop853", rtol=1e-13, atol=1e-13)


def test_open_loop_gait_retraces_the_recorded_cycle(two_step_point):
    """At the fixed point the open-loop replay is the same trajectory: same segment exits,
    same section state, same advance."""
    g = two_step()
    times = cycle_times(g, two_step_point, integrator=INTEG)
    ol = open_loop_gait(g, times)
    assert all(s.until == "time" for s in ol.segments)
    assert [s.magnets for s in ol.segments] == [s.magnets for s in g.segments]
    assert [s.torque for s in ol.segments] == [s.torque for s in g.segments]
    z_gait, _ = cycle_return_map(two_step_point, g, integrator=INTEG)
    z_ol, st = cycle_return_map(two_step_point, ol, integrator=INTEG)
    assert st == 0
    np.testing.assert_allclose(z_ol, z_gait, rtol=0, atol=1e-9)
    th2 = two_step_point[0]   # the cycle's start, as cycle_times used it
    r_g = evaluate_cycle_gaits([two_step_point[1:]], dataclasses.replace(g, theta2=th2),
                               integrator=INTEG)
    r_o = evaluate_cycle_gaits([two_step_point[1:]], dataclasses.replace(ol, theta2=th2),
                               integrator=INTEG)
    np.testing.assert_allclose(r_o["t_segment"], r_g["t_segment"], rtol=0, atol=1e-12)
    assert r_o["x_advance"][0] == pytest.approx(r_g["x_advance"][0], abs=1e-10)


def test_own_controller_holds_the_two_step_point(two_step_point):
    """The two-step gait is stable (multipliers 1, 0.85, 0.62): from its fixed point the
    error stays at round-off and every cycle advances by the same step."""
    r = sequence_cycles(two_step(), two_step_point, cycles=50, integrator=INTEG)
    assert r.status == L.ST_OK and len(r.error) == 50
    assert np.all(r.error < 1e-16)
    one = evaluate_cycle_gaits([two_step_point[1:]],
                               dataclasses.replace(two_step(), theta2=two_step_point[0]),
                               integrator=INTEG)
    np.testing.assert_allclose(r.x_advance, one["x_advance"][0], rtol=0, atol=1e-9)
    np.testing.assert_allclose(r.pivot_height, 0.0, atol=1e-9)
    # the section crossings are one period apart
    np.testing.assert_allclose(np.diff(r.t_cross), one["t_end"][0], rtol=0, atol=1e-9)
    # the first magnet action of each cycle is its first swap
    np.testing.assert_allclose(r.t_swap[0], one["t_segment"][0, 0], rtol=0, atol=1e-12)


def test_open_loop_error_grows_at_the_floquet_rate(two_step_point):
    """A small perturbation of the open-loop replay grows by the leading multiplier of its
    return map (finite differences of one cycle) each cycle: the per-cycle runs and the
    linearisation are independent paths through the simulator."""
    g = two_step()
    times = cycle_times(g, two_step_point, integrator=TIGHT)
    ol = open_loop_gait(g, times)
    fl = floquet(partial(cycle_return_map, gait=ol, integrator=TIGHT), two_step_point)
    lam = abs(fl.multipliers[0])
    assert lam > 2.0   # the open-loop replay of this stable gait is unstable
    w, v = np.linalg.eig(fl.jacobian)
    lead = np.real(v[:, np.argmax(np.abs(w))])
    delta = 1e-7
    r = sequence_cycles(g, two_step_point + delta * lead / np.linalg.norm(lead), cycles=5,
                        integrator=TIGHT, replay="open_loop", times=times,
                        reference=two_step_point)
    d = np.sqrt(r.error)               # |deviation| after each cycle
    # along the leading eigenvector the deviation is multiplied by lambda every cycle. Two
    # errors bound the check: the fixed point's own defect (~5e-11, relative ~5e-4 of a 1e-7
    # deviation, and shrinking as it grows) and the map's curvature once the deviation nears
    # 1e-4 (measured: ratios within 2.3e-5 of lambda for delta = 1e-7, cycles 1-5)
    np.testing.assert_allclose(d[1:] / d[:-1], lam, rtol=5e-5)
    np.testing.assert_allclose(d[0], delta * lam, rtol=5e-4)


def test_tick_delays_each_guard_to_the_next_tick(two_step_point):
    """With a tick, the gait's first swap happens at the first tick after B reaches A's
    height (the clock starts at the section, at t = 0)."""
    g = two_step()
    exact = cycle_times(g, two_step_point, integrator=INTEG)[0]
    for h in (1e-3, 1e-4):
        r = sequence_cycles(g, two_step_point, cycles=1, integrator=INTEG, tick=h)
        assert r.t_swap[0] == pytest.approx(math.ceil(exact / h) * h, abs=1e-12)
        assert r.t_swap[0] > exact
    ol = sequence_cycles(g, two_step_point, cycles=1, integrator=INTEG, tick=1e-3,
                         replay="open_loop")
    assert ol.t_swap[0] == pytest.approx(math.ceil(exact / 1e-3) * 1e-3, abs=1e-12)


def test_basin_centre_survives_and_far_starts_do_not(two_step_point):
    B = sequence_basin(two_step(), two_step_point, [0.0, 0.3], [0.0], max_cycles=10,
                       error_bound=1e-2, integrator=INTEG)
    assert B.shape == (2, 1)
    assert B[0, 0] == 10
    assert B[1, 0] < 10


def test_section_error_wraps_theta2():
    s = np.zeros((2, 8))
    s[0, L.TH2] = 2 * math.pi + 0.1
    s[1, L.DTH1], s[1, L.DTH2] = 1.0, 2.0
    e = section_error(s, (0.0, 1.0, 2.0))
    assert e[0] == pytest.approx(0.01 + 1.0 + 4.0)
    assert e[1] == 0.0


def test_refusals(two_step_point):
    g = two_step()
    t = cycle_times(g, two_step_point, integrator=INTEG)
    with pytest.raises(ValueError, match="must not decrease"):
        open_loop_gait(g, t[::-1])
    with pytest.raises(ValueError, match="finite segment exit times"):
        open_loop_gait(g, t[:2])
    moved = dataclasses.replace(g, segments=(dataclasses.replace(g.segments[0],
                                                                 clock="reset"),
                                             *g.segments[1:]))
    with pytest.raises(ValueError, match="moves the controller clock"):
        open_loop_gait(moved, t)
    with pytest.raises(ValueError, match="replay must be"):
        sequence_cycles(g, two_step_point, cycles=1, replay="closed")
    swap_first = dataclasses.replace(g, segments=(Segment("coord", 0.0, magnets="swap"),
                                                  *g.segments))
    with pytest.raises(ValueError, match="first segment acts on the magnets"):
        sequence_cycles(swap_first, two_step_point, cycles=1)
    with pytest.raises(ValueError, match="does not close"):
        cycle_times(g, np.array([0.0, 0.0, 0.1]), integrator=INTEG)


#: the horizontal gait's exact, collisionless fixed point (README, "What the studies found"):
#: (theta2, dtheta1 [rad s-1], dtheta2 [rad s-1]), swapped at T_SWAP [s] without a motor
EXACT_GAIT = (0.0, 1.4952437542556796, 10.246845402521146)
T_SWAP = 0.43344770344868


@pytest.mark.parametrize("tick", [0.0, 1e-3])
def test_running_clock_records_every_vertical_crossing(tick):
    """The horizontal gait replayed open-loop with a clock that runs on with the gait's
    period: each cycle crosses the vertical near the period's end, before or after it (with
    exact timing the first cycle crosses there to round-off; on a 1 ms tick later cycles
    cross either side as the replay drifts, the last one after the run's last period). Each
    cycle is recorded at the first vertical crossing after its swap, wherever the period
    ends: on the vertical, between its swap and the next, the first cycle's crossing the
    same state as the restarting clock's (one trajectory up to there)."""
    gait = motorless(horizontal_gait(0.6354))
    times = (T_SWAP, T_SWAP)
    period = float(evaluate_cycle_gaits([EXACT_GAIT[1:]], open_loop_gait(gait, times),
                                        integrator=TIGHT)["t_end"][0])
    run_on = dataclasses.replace(gait, period=period)
    r = sequence_cycles(run_on, (0.0, *EXACT_GAIT), cycles=12, integrator=TIGHT,
                        replay="open_loop", times=times, tick=tick)
    assert r.status == L.ST_OK
    assert len(r.error) == 12 and np.all(np.isfinite(r.error))
    assert np.all(np.isfinite(r.t_cross)) and np.all(r.t_cross > r.t_swap)
    assert np.all(r.t_cross[:-1] < r.t_swap[1:])
    np.testing.assert_allclose(r.section_state[:, L.TH1], 0.0, rtol=0, atol=1e-12)
    # the crossings fall on both sides of the period's ends: the case the record must cover
    late = r.t_cross - period * np.arange(1, 13)
    assert late.max() >= 0.0 and (tick == 0.0 or late.min() < 0.0)
    reset = sequence_cycles(gait, EXACT_GAIT, cycles=1, integrator=TIGHT, replay="open_loop",
                            times=times, tick=tick)
    np.testing.assert_allclose(r.section_state[0], reset.section_state[0], rtol=0,
                               atol=1e-10)
    if tick == 0.0:
        assert r.error[0] < 1e-24        # the fixed point, to round-off


@pytest.mark.parametrize("replay", ["gait", "open_loop"])
def test_mirrored_cycles_hold_the_flight_gait(flight_point, replay):
    """studies/flight_gait.yaml releases A, flies and catches with B: its cycle ends hanging
    from B, and its return map compares B's frame with A's (mirror-image links), so the next
    cycle starts hanging from B and is the mirror image, releasing B and catching with A.
    From the fixed point every cycle repeats the first (its advance, at the start's height),
    the first cycle's section state is the one-cycle return map's, and the deviation grows
    by the leading multiplier of the replayed map per cycle (finite differences of one cycle:
    an independent path through the simulator), from round-off, never faster."""
    g = flight()
    times = cycle_times(g, flight_point, integrator=INTEG)
    one_cycle = g if replay == "gait" else open_loop_gait(g, times)
    r = sequence_cycles(g, flight_point, cycles=12, integrator=INTEG, replay=replay,
                        times=times)
    assert r.status == L.ST_OK and len(r.error) == 12
    z1, _ = cycle_return_map(flight_point, one_cycle, integrator=INTEG)
    s1 = r.section_state[0]
    np.testing.assert_allclose([s1[L.TH2], s1[L.DTH1], s1[L.DTH2]], z1, rtol=0, atol=1e-12)
    one = evaluate_cycle_gaits([flight_point[1:]],
                               dataclasses.replace(one_cycle, theta2=flight_point[0]),
                               integrator=INTEG)
    assert one["x_advance"][0] > 0.7
    np.testing.assert_allclose(r.x_advance, one["x_advance"][0], rtol=0, atol=1e-7)
    np.testing.assert_allclose(r.pivot_height, 0.0, rtol=0, atol=1e-7)
    fl = floquet(partial(cycle_return_map, gait=one_cycle, integrator=INTEG), flight_point)
    lam = float(np.max(np.abs(fl.multipliers)))
    assert lam > 2.0
    # the map's own error (rtol 1e-12: the fixed point's defect) enters every cycle, grows by lam
    d = np.sqrt(r.error)
    k = np.arange(1, 13)
    assert np.all(d <= 1e-12 * ((1.05 * lam) ** k - 1.0) / (1.05 * lam - 1.0))
    assert growth_per_cycle(r.error) == pytest.approx(lam, rel=0.02)


def test_a_running_clocks_schedule_is_its_cycles_from_the_same_start():
    """A running clock's section state names theta1 first (its clock phase zero): the
    segment exits of its cycle from there are the restarting clock's from the same state."""
    gait = horizontal_gait(0.6354)
    start = (0.0, 0.902, 10.935)          # the 2009 study's gait (README)
    exits = cycle_times(gait, start, integrator=INTEG)
    run_on = dataclasses.replace(gait, period=0.9)
    np.testing.assert_array_equal(cycle_times(run_on, (0.0, *start), integrator=INTEG)[:2],
                                  exits[:2])
