"""A catch on a bar (guard ``G_BAR``, docs/model.md section 6): the free end comes down through
the bar's height; within the window it catches (the plastic impact at the grip point, then the
snap onto the bar), outside it passes the bar and the swing goes on."""
import numpy as np
import pytest

from monkeystudy import Robot
from monkeystudy.controllers import Integrator, Observer, PhaseSequence, Segment
from monkeystudy.kernel import layout as L
from monkeystudy.kernel.dynamics import total_energy8
from monkeystudy.simulation import initial_state, run_controller

INTEG = Integrator(rtol=1e-12, atol=1e-12)
#: hanging from A at the origin, released at rest: the free end falls through A's height at
#: x = +1.040 m, swings back and falls through it again at x = -0.5835 m (seed2009)
START = dict(x=0.0, y=0.0, theta1=2.0, theta2=0.3)
FALLING = dict(until="free_end_height", value=0.0, direction="falling", ticked=False)
AFTER = Segment("time", value=0.3, magnets="swap", next=-1)


def _run(segments, sample_dt=0.0):
    return run_controller(PhaseSequence(segments, tick=0.001),
                          initial_state(START["x"], START["y"], theta1=START["theta1"],
                                        theta2=START["theta2"]),
                          integrator=INTEG, sample_dt=sample_dt)


def _exits(res):
    """The log's segment exits (the run also logs friction mode changes)."""
    return res.log[res.log[:, L.L_KIND] == L.LOG_SEGMENT]


def _catch(bar_dx, window, dy=0.0):
    return Segment("bar", value=dy, direction="falling", bar_dx=bar_dx, bar_window=window)


def test_a_crossing_inside_the_window_is_the_swap_at_the_grip_point_then_the_snap():
    """Inside the window the catch is the free-end-height swap bit for bit (same instant,
    same impact, same energy loss); then the new attached end is exactly on the bar, a
    translation by the catch offset that changes no angle, rate or energy."""
    swap = _run([Segment(**FALLING), AFTER], sample_dt=0.01)
    bar = _run([_catch(1.05, 0.02), AFTER], sample_dt=0.01)
    assert swap.status == bar.status == L.ST_OK
    assert bar.segment_times.tobytes() == swap.segment_times.tobytes()
    assert bar.log[0].tobytes() == swap.log[0].tobytes()   # the state before the snap, logged
    x_grip = bar.log[0, L.L_STATE + L.X]
    assert x_grip == pytest.approx(1.0400, abs=1e-3)
    # the snap: the sample at the next segment's entry has its pivot on the bar
    k = np.flatnonzero(bar.sample_t == bar.segment_times[0])[-1]
    snapped = bar.sample_state[k]
    assert snapped[L.X] == 1.05 and snapped[L.Y] == 0.0
    before = bar.log[0, L.L_STATE:L.L_STATE + 8]
    assert np.array_equal(snapped[L.TH1:], before[L.TH1:])
    par = Robot.preset("seed2009").params()
    # the crossing puts the grip point at the bar's height to round-off: no energy moves
    assert total_energy8(par[1], snapped) == pytest.approx(bar.log[0, L.L_E_AFTER],
                                                           abs=1e-12)
    assert bar.log[0, L.L_E_AFTER] < bar.log[0, L.L_E_BEFORE]   # the plastic impact's loss
    # the run goes on from the bar: the final pivot is the bar
    assert bar.state[L.X] == 1.05 and bar.state[L.Y] == 0.0


def test_a_crossing_outside_the_window_passes_the_bar_and_a_later_one_inside_catches():
    """The first crossing (x = 1.04 m) misses a bar at -0.58 m: the hook passes it and the
    robot swings on, hanging from A, to the second crossing (x = -0.5835 m), which catches."""
    twice = _run([Segment(**FALLING), Segment(**FALLING), AFTER])
    x_second = _exits(twice)[1, L.L_STATE + L.X]
    assert x_second == pytest.approx(-0.5835, abs=1e-3)
    bar = _run([_catch(x_second + 0.005, 0.01), AFTER])
    assert bar.status == L.ST_OK
    assert bar.segment_times[0] == pytest.approx(twice.segment_times[1], abs=1e-9)
    assert _exits(bar)[0, L.L_STATE + L.X] == pytest.approx(x_second, abs=1e-9)
    assert bar.state[L.X] == x_second + 0.005


def test_a_swing_that_never_meets_the_bar_runs_to_its_horizon():
    res = _run([_catch(0.3, 0.02), AFTER])
    assert res.status == L.ST_HORIZON
    assert np.isnan(res.segment_times[0])
    assert int(res.state[L.H_FLIPPED]) == 0 and res.state[L.X] == 0.0   # still on its bar


def test_a_higher_bar_is_caught_at_its_height():
    """A bar 5 cm above A's: the catch is at the free end's height 0.05 m, where the new
    pivot is snapped."""
    res = _run([_catch(1.0, 0.1, dy=0.05), AFTER])
    assert res.status == L.ST_OK
    s = _exits(res)[0, L.L_STATE:L.L_STATE + 8]
    assert s[L.Y] == pytest.approx(0.05, abs=1e-12)
    assert abs(s[L.X] - 1.0) <= 0.1
    assert res.state[L.X] == 1.0 and res.state[L.Y] == 0.05


def test_a_bar_row_is_never_ticked_and_is_checked():
    prog, _ = PhaseSequence([_catch(1.0, 0.02), AFTER], tick=0.001).program()
    assert prog[0, L.S_TICKED] == 0.0 and prog[0, L.S_GUARD] == L.G_BAR
    assert prog[0, L.S_BAR_DX] == 1.0 and prog[0, L.S_BAR_WINDOW] == 0.02
    with pytest.raises(ValueError, match="bar_window > 0"):
        PhaseSequence([_catch(1.0, 0.0)]).program()
    with pytest.raises(ValueError, match="falling"):
        PhaseSequence([Segment("bar", direction="rising", bar_dx=1.0,
                               bar_window=0.02)]).program()
    with pytest.raises(ValueError, match="no delay"):
        PhaseSequence([Segment("bar", direction="falling", bar_dx=1.0, bar_window=0.02,
                               delay=0.01)]).program()
    with pytest.raises(ValueError, match="observer"):
        Observer(until="bar").row()
