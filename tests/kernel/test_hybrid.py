"""The hybrid loop's action delays (program column ``S_DELAY``): a time guard's instant moves
by the delay, a state guard's action waits for it, zero changes nothing."""
import numpy as np
import pytest

from monkeystudy.controllers import Integrator, PhaseSequence, Segment
from monkeystudy.kernel import layout as L
from monkeystudy.simulation import initial_state, run_controller

INTEG = Integrator(rtol=1e-12, atol=1e-12)


def _run(segments, tick=0.0):
    ctrl = PhaseSequence(segments, observers=(), tick=tick)
    return run_controller(ctrl, initial_state(1.0, 2.0, theta1=0.3), integrator=INTEG,
                          sample_dt=0.01)


@pytest.mark.parametrize("delay", [0.0, 0.0123, -0.0123])
@pytest.mark.parametrize("tick", [0.0, 0.001])
def test_a_time_guard_exits_at_its_instant_moved_by_the_delay(delay, tick):
    res = _run([Segment("time", value=0.2005, delay=delay),
                Segment("time", value=0.5, torque=0.3, next=-1)], tick=tick)
    assert res.status == 0
    instant = 0.2005 if tick == 0 else 0.201          # the first tick at or after it
    assert res.segment_times[0] == pytest.approx(instant + delay, abs=1e-15)
    # the motor comes on at that exit, not before
    t, torque = res.sample_t, res.sample_mode[:, L.M_TORQUE]
    assert np.all(torque[t < instant + delay - 1e-12] == 0.0)
    assert np.all(torque[t > instant + delay + 1e-12] == 0.3)


def test_a_state_guard_acts_the_delay_after_it_fires():
    guard = dict(until="coord", coord="theta1", value=0.0, direction="falling")
    on_time = _run([Segment(**guard), Segment("time", value=2.0, next=-1)])
    late = _run([Segment(**guard, delay=0.05), Segment("time", value=2.0, next=-1)])
    fired = on_time.segment_times[0]
    assert 0.0 < fired < 1.0
    assert late.segment_times[0] == pytest.approx(fired + 0.05, abs=1e-15)
    # in the meantime the segment went on: link 1 kept falling past the vertical
    state = late.log[late.log[:, L.L_ID] == 0][0, L.L_STATE:L.L_STATE + 8]
    assert state[L.TH1] < -0.01


def test_a_zero_delay_changes_no_bit():
    segs = [Segment("coord", coord="theta1", value=0.0, direction="falling"),
            Segment("time", value=0.9, torque=0.2, next=-1)]
    a = _run(segs)
    b = _run([Segment("coord", coord="theta1", value=0.0, direction="falling", delay=0.0),
              segs[1]])
    assert a.sample_state.tobytes() == b.sample_state.tobytes()
    assert a.segment_times.tobytes() == b.segment_times.tobytes()


def test_a_state_guard_refuses_a_negative_delay():
    with pytest.raises(ValueError, match="latency"):
        PhaseSequence([Segment("coord", delay=-0.01, next=-1)]).program()
