"""The labelled trajectory of :func:`monkeystudy.simulate`: what its variables are and mean."""
import numpy as np
import pytest

from monkeystudy import OpenLoop, evaluate_horizontal_gait, simulate
from monkeystudy.kernel.layout import PHASE_SWING


@pytest.fixture(scope="module")
def three_cycles():
    g = evaluate_horizontal_gait(0.902, 10.935, tick=0.001)
    return simulate(OpenLoop(g.t_switch, g.t_motor, 0.6354, tick=0.001),
                    dtheta1=0.902, dtheta2=10.935, cycles=3, sample_dt=0.01)


def test_every_variable_and_coordinate_has_units_and_a_long_name(three_cycles):
    ds = three_cycles
    for v in ds.variables:
        assert ds[v].attrs.get("units") and ds[v].attrs.get("long_name"), v


def test_the_state_is_in_the_frame_of_the_attached_end(three_cycles):
    ds = three_cycles
    swing = ds.phase.values == PHASE_SWING
    on_a = swing & (ds.attached_end.values == 0)
    on_b = swing & (ds.attached_end.values == 1)
    assert on_a.any() and on_b.any()
    xy = np.column_stack([ds.x.values, ds.y.values])
    # hanging from a magnet, (x, y) is that magnet, which does not move
    np.testing.assert_allclose(xy[on_a], ds.A.values[on_a], atol=1e-12)
    np.testing.assert_allclose(xy[on_b], ds.B.values[on_b], atol=1e-12)
    assert np.all(ds.x_dot.values[swing] == 0) and np.all(ds.y_dot.values[swing] == 0)
    # each link is its length long in the world
    l1 = np.hypot(*(ds.joint.values - ds.A.values).T)
    l2 = np.hypot(*(ds.B.values - ds.joint.values).T)
    np.testing.assert_allclose(l1, 0.61, rtol=1e-12)
    np.testing.assert_allclose(l2, 0.61, rtol=1e-12)


def test_the_event_log_ends_on_the_last_sample_and_counts_the_swaps(three_cycles):
    ds = three_cycles
    assert ds.attrs["status"] == "ok" and ds.attrs["cycles"] == 3
    swaps = np.flatnonzero(np.diff(ds.attached_end.values) != 0)
    assert len(swaps) == 3
    assert int(ds.event_attached_end.values[-1]) == int(ds.attached_end.values[-1])
    for name in ("x", "y", "theta1", "theta2", "theta1_dot", "theta2_dot"):
        assert float(ds[f"event_{name}"].values[-1]) == float(ds[name].values[-1]), name
    np.testing.assert_allclose(ds.total_energy, ds.kinetic_energy + ds.potential_energy,
                               rtol=0, atol=0)


def test_bad_sample_step_is_refused_before_running():
    with pytest.raises(ValueError, match="sample_dt"):
        simulate(OpenLoop(0.4, 0.02, 0.6354), sample_dt=0.0)
