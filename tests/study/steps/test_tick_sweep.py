"""The tick_sweep step: the gait replayed per controller tick, cycles to the error bound,
the growth per cycle against the leading multiplier.

The end-to-end cases read the analysis smoke study's datasets (``analysis_smoke``,
tests/study/steps/conftest.py)."""
from __future__ import annotations

import numpy as np
import pytest

from monkeystudy.analysis.replay import cycles_to_bound, growth_per_cycle

from studyhelpers import assert_written_as_declared, open_dataset


def test_tick_sweep_exact_timing_lasts_longest(analysis_smoke):
    ds = open_dataset(analysis_smoke[0], "ticks.nc")
    fl = open_dataset(analysis_smoke[0], "floquet.nc")
    c = dict(zip(ds["tick"].values, ds["cycles_to_bound"].values))
    assert c[0.0] > c[0.001]                               # the tick only seeds the fall
    assert ds.sizes["cycle"] == 60 and list(ds["cycle"].values[:2]) == [1, 2]
    lead = float(ds.attrs["leading_multiplier"])
    lam = fl["multipliers_real"].values[0, 0] + 1j * fl["multipliers_imag"].values[0, 0]
    assert lead == pytest.approx(abs(lam), rel=1e-6)      # FD here, var-eq in floquet
    exact = int(np.flatnonzero(ds["tick"].values == 0.0)[0])
    assert float(ds["growth_per_cycle"][exact]) == pytest.approx(lead, rel=0.02)
    e = ds["error"].values[exact]
    k = int(ds["cycles_to_bound"][exact])
    assert e[k - 1] > 1e-2 and np.all(e[:k - 1] <= 1e-2)
    assert np.all(np.isnan(e[int(ds["cycles_completed"][exact]):]))


def test_tick_sweep_takes_the_multiplier_of_a_floquet_step(analysis_smoke):
    ds = open_dataset(analysis_smoke[0], "ticks_var.nc")
    fl = open_dataset(analysis_smoke[0], "floquet.nc")
    lam = fl["multipliers_real"].values[0, 0] + 1j * fl["multipliers_imag"].values[0, 0]
    assert float(ds.attrs["leading_multiplier"]) == abs(lam)
    assert "floquet step floquet" in ds.attrs["leading_multiplier_source"]


def test_growth_and_cycles_to_bound():
    e = (1e-9 * 1.5 ** np.arange(40)) ** 2
    assert growth_per_cycle(e) == pytest.approx(1.5, rel=1e-9)
    assert np.isnan(growth_per_cycle(np.array([1e-3, 1e-2])))
    assert cycles_to_bound(np.array([1e-5, 1e-3, 2e-2, 1.0]), 1e-2) == 3
    assert cycles_to_bound(np.array([1e-5, 1e-3]), 1e-2) == 2


def test_tick_sweep_datasets_are_written_as_declared(analysis_smoke):
    for name in ('ticks.nc', 'ticks_var.nc'):
        assert_written_as_declared(analysis_smoke[0] / name, "tick_sweep")


#: the flight gait of studies/flight_gait.yaml on a 1 ms tick: its floquet step's fixed point
#: (of the exact-timing map) replayed open loop on exact timing, as a tick sweep and as a
#: stability run, and by its own controller
FLIGHT_ON_A_TICK = """\
schema_version: 1
name: flight_on_a_tick
robot: seed2009
gait:
  kind: sequence
  section: {theta1: 0.0, direction: either, theta2: 0.3}
  segments:
    - {until: coord, coord: theta1, value: 0.6, direction: rising, latch_energy: true}
    - {until: free_end_y, value: 0.0, direction: rising, magnets: none}
    - {until: energy_restored, value: 0.0, magnets: B, torque: 0.6354}
  tick: 0.001
integrator: {rtol: 1.0e-10}
steps:
  - {name: map, kind: grid, dtheta1: {start: 1.896, stop: 2.033, num: 2},
     dtheta2: {start: 10.0, stop: 10.15, num: 4}}
  - {name: best, kind: refine, start: {from: map, best: 1}}
  - {name: floquet, kind: floquet, from: best}
  - {name: open_loop, kind: tick_sweep, from: floquet, ticks: [0.0, 0.001], cycles: 3,
     replay: open_loop}
  - {name: own, kind: tick_sweep, from: floquet, ticks: [0.0], cycles: 3, replay: gait}
  - {name: cycles, kind: stability, from: floquet, cycles: 3, replay: open_loop,
     controller: {tick: 0.0}}
"""


def test_an_open_loop_replay_of_a_fixed_point_keeps_its_exact_timing_cycle(tmp_path):
    """The floquet step's fixed point is the exact-timing map's: an open-loop replay keeps
    the segment exits of its exact-timing cycle (not of the cycle on the gait's tick, which
    ends up to a tick later), so on exact timing it repeats the fixed point to its map's
    defect, as the gait's own controller does; on the tick it departs."""
    import json

    import xarray as xr

    from monkeystudy.study import parse_study, run_study

    run_study(parse_study(FLIGHT_ON_A_TICK, "flight.yaml"), tmp_path / "out", workers=1)
    with xr.open_dataset(tmp_path / "out" / "floquet.nc") as f, \
            xr.open_dataset(tmp_path / "out" / "open_loop.nc") as ol, \
            xr.open_dataset(tmp_path / "out" / "own.nc") as own, \
            xr.open_dataset(tmp_path / "out" / "cycles.nc") as c:
        exits = f["t_segment"].values[0]
        np.testing.assert_allclose(json.loads(ol.attrs["t_segment"]), exits, rtol=0,
                                   atol=1e-9)
        np.testing.assert_allclose(json.loads(c.attrs["t_segment"]), exits, rtol=0,
                                   atol=1e-9)
        # three cycles of a map with |lambda| 4 from a point it moves 1e-11
        assert np.all(ol["error"].values[0] < 1e-16), ol["error"].values[0]
        assert np.all(own["error"].values[0] < 1e-16), own["error"].values[0]
        assert np.all(c["error"].values < 1e-16), c["error"].values
        assert ol["error"].values[1, 0] > 1e-8            # on the 1 ms tick it departs
