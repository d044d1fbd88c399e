"""Named regression studies of the report: every valid study that once broke ``monkeystudy
report`` (or, marked xfail, the run before it), found by hand or by the property test
(tests/plotting/test_report_property.py), kept verbatim with what went wrong.

Each is run with the study runner and reported by ``reportcheck.run_and_report``: the run
refuses only steps with nothing to build on, and runs every step that does not depend on
one; its datasets hold no unexplained NaN, its replays of a converged fixed point stay near
it, a floquet step's point is converged or refused saying so; the report returns normally
or names the failed steps, every planned figure is drawn or skipped with its reason on the
page and in the log, no two to one file, the page's images exist, no figure text says "nan"
or "1 runs".
"""
from __future__ import annotations

import json

import numpy as np
import xarray as xr

from plotting.reportcheck import run_and_report
from test_motor_frame import DESIGN_B

HEAD = """\
schema_version: 1
name: regression
integrator: {{rtol: 1.0e-8, atol: 1.0e-10, max_time: {max_time}}}
"""


def report(tmp_path, text: str, max_time: float = 3.0):
    return run_and_report(HEAD.format(max_time=max_time) + text, tmp_path / "out")



def test_a_2x2_grid_has_no_whole_cell_for_the_surface(tmp_path):
    """Issue 32: a 2 x 2 grid has one cell, and no cell with four corners that have a gait;
    the surface raised ``ValueError: zero-size array to reduction operation minimum`` and
    ``report`` exited 1. Its points with a gait are now dots."""
    out = report(tmp_path, """\
robot: seed2009
gait: {kind: horizontal, motor_torque: 0.6354, tick: 0.001}
steps:
  - {name: m, kind: grid, dtheta1: {start: 0.0, stop: 3.0, num: 2},
     dtheta2: {start: 9.0, stop: 14.0, num: 2}}
  - {name: r, kind: refine, start: {from: m, best: 1}, maxiter: 5}
  - {name: c, kind: stability, from: r, cycles: 3}
""")
    assert "m_surface" in out.drawn and "m_map" in out.drawn


def test_grids_with_one_value_along_an_axis_and_a_single_point(tmp_path):
    """Issue 32: a grid of one dtheta1 (a row) and a grid of one point: the surface failed as
    for the 2 x 2 grid. A row is drawn as a curve with its points, a point as a dot."""
    out = report(tmp_path, """\
robot: seed2009
gait: {kind: horizontal, motor_torque: 0.6354, tick: 0.001}
steps:
  - {name: m, kind: grid, dtheta1: {start: 1.0, stop: 1.0, num: 1},
     dtheta2: {start: 9.0, stop: 14.0, num: 8}}
  - {name: p, kind: grid, points: [[1.0, 11.0]]}
  - {name: r, kind: refine, start: [1.0, 11.0], maxiter: 1}
  - {name: c, kind: stability, from: r, cycles: 1}
""")
    assert {"m_surface", "p_surface", "r_convergence", "c_error"} <= set(out.drawn)


def test_a_grid_without_any_gait(tmp_path):
    """Property test, first examples: a sequence gait's one-point grid with no cycle (and
    the run refusing to refine its minimum). The surface failed as above; now the map shows
    why there is no gait, and the surface and swap-time map say why they are not drawn."""
    out = report(tmp_path, """\
robot: seed2009
gait:
  kind: sequence
  section: {theta1: 0.0, direction: either, theta2: 0.0}
  segments:
    - {until: coord, coord: theta1, value: 0.3, direction: rising, latch_energy: true}
    - {until: free_end_y, value: 0.0, direction: rising, magnets: none}
    - {until: energy_restored, value: 0.0, magnets: B, torque: 0.2394}
  tick: 0.0
steps:
  - {name: map, kind: grid, points: [[0.0, 6.0]]}
  - {name: best, kind: refine, start: {from: map, best: 1}, maxiter: 1}
""")
    assert out.refused and "its one point has no gait" in out.refused
    assert out.drawn == ["map_map"]
    assert "no point of the grid has a gait" in out.skipped["map_surface"]


def test_a_coarse_grid_of_another_robot_with_a_strong_motor(tmp_path):
    """Issue 32: a coarse 4 x 4 grid of another robot with a strong motor has gaits at a few
    points and no whole cell among them: the surface failed as above."""
    out = report(tmp_path, """\
robot:
  name: heavy
  gravity: 9.81
  links:
    - {mass: 2.0, length: 0.8, com: 0.6, inertia: 0.08}
    - {mass: 2.0, length: 0.8, com: 0.2, inertia: 0.08}
gait: {kind: horizontal, motor_torque: 3.0, tick: 0.001}
steps:
  - {name: m, kind: grid, dtheta1: {start: 0.0, stop: 3.0, num: 4},
     dtheta2: {start: 6.0, stop: 12.0, num: 4}}
""")
    assert "m_map" in out.drawn
    assert "m_surface" in out.drawn or "m_surface" in out.skipped


def test_a_refined_minimum_without_a_gait_is_named_without_nan(tmp_path):
    """Property test: a refine whose search found no gait was keyed on the error map as
    "e = nan at (1.364, 10.070) (no gait)"; its replay's figures were drawn empty, titled
    "swap at nan s, motor nan s", and its filmstrip left out without a word (no samples)."""
    out = report(tmp_path, """\
robot: uniform_rod
gait: {kind: horizontal, motor_torque: 0.6354, tick: 0.005}
steps:
  - {name: map, kind: grid, dtheta1: {start: 0.0, stop: 0.05, num: 6},
     dtheta2: {start: 13.39, stop: 13.39, num: 1}}
  - {name: map2, kind: grid, points: [[0.0, 10.8], [1.704, 8.217], [1.551, 13.87]]}
  - {name: best, kind: refine, start: [1.364, 10.07], maxiter: 7}
  - {name: cycles, kind: stability, from: best, cycles: 3, sample_dt: 0.05, max_drop: 0.369,
     controller: {clock: run_on}}
""")
    for name in ("cycles_error", "cycles_kinetic_energy", "cycles_height"):
        assert "no swap time" in out.skipped[name], name
    assert "no motion" in out.skipped["cycles_filmstrip"]
    assert "cycles_animation" in out.skipped


def test_a_basin_of_one_start_counts_in_the_singular(tmp_path):
    """Property test: a 1 x 1 basin with one cycle per run was titled "1×1 starts ...;
    1 = never failed in 1 cycles"."""
    out = report(tmp_path, """\
robot: seed2009
gait: {kind: horizontal, motor_torque: 0.6354, tick: 0.0}
steps:
  - {name: exact, kind: shoot, starts: [[1.0, 12.0]], method: grazing}
  - name: basin
    kind: basin
    from: exact
    offsets: {d_dtheta1: {start: 0.0, stop: 0.0, num: 1},
              d_dtheta2: {start: 0.0, stop: 0.0, num: 1}}
    max_cycles: 1
""")
    assert "basin_cycles_map" in out.drawn


# --- what once broke the run (found by the property test) --------------------------------------
def test_floquet_search_on_another_robot(tmp_path):
    """The search controller's Newton starts from the 2009 robot's fixed point; on another
    robot, with phases of at most 1 s, there is no cycle from it: the floquet dataset says
    so (``failure``), the figure is skipped with that reason."""
    out = report(tmp_path, """\
robot: uniform_rod
gait: {kind: horizontal, motor_torque: 0.6354, tick: 0.0}
steps:
  - {name: multipliers, kind: floquet, controllers: [search]}
""", max_time=1.0)
    failure = floquet_failures(out.folder)["search"]
    assert "no cycle" in failure, failure
    assert "no return map was analysed: search: " in out.skipped["multipliers_multipliers"]


def test_sequence_floquet_whose_event_order_differs(tmp_path):
    """The variational run at the refined start meets the events in another order than the
    run: the floquet dataset records it (``failure``) instead of the run failing."""
    out = report(tmp_path, """\
robot:
  name: drawn
  gravity: 7.0
  links:
    - {mass: 0.5907, length: 1.27, com: 0.1669, inertia: 0.06424}
    - {mass: 0.5907, length: 1.27, com: 1.1031, inertia: 0.06424}
gait:
  kind: sequence
  section: {theta1: 0.0, direction: either, theta2: 0.0}
  segments:
    - {until: coord, coord: theta1, value: 0.0, direction: falling, latch_energy: true}
    - {until: coord, coord: theta1, value: 0.0, direction: rising}
    - {until: free_end_height, value: 0.0, direction: rising}
    - {until: energy_restored, value: 0.0, magnets: swap, torque: 0.9298}
  tick: 0.0
steps:
  - {name: map, kind: grid, dtheta1: {start: 0.163, stop: 1.775, num: 7},
     dtheta2: {start: 3.513, stop: 5.125, num: 7}}
  - {name: best, kind: refine, start: {from: map, best: 1}, maxiter: 10}
  - {name: multipliers, kind: floquet, from: best}
""")
    failure = floquet_failures(out.folder)["sequence"]
    assert "event sequences differ" in failure, failure
    assert out.skipped["multipliers_multipliers"].endswith(failure)


def floquet_failures(folder) -> dict[str, str]:
    """The ``failure`` of each controller of a study's floquet dataset."""
    with xr.open_dataset(folder / "multipliers.nc") as ds:
        return {str(c): str(f) for c, f in zip(ds["controller"].values, ds["failure"].values)}


def test_sequence_floquet_with_a_tick(tmp_path):
    """A gait with a controller tick: the floquet step differentiates its exact-timing return
    map (as for the horizontal gait)."""
    out = report(tmp_path, """\
robot: seed2009
gait:
  kind: sequence
  section: {theta1: 0.0, direction: either, theta2: 0.0}
  segments:
    - {until: coord, coord: theta1, value: 0.0, direction: falling, latch_energy: true}
    - {until: coord, coord: theta1, value: 0.0, direction: rising}
    - {until: free_end_height, value: 0.0, direction: rising}
    - {until: energy_restored, value: 0.0, magnets: swap, torque: 0.43}
  tick: 0.001
steps:
  - {name: map, kind: grid, dtheta1: {start: 0.0, stop: 0.9533, num: 7},
     dtheta2: {start: 12.17, stop: 15.7, num: 4}}
  - {name: best, kind: refine, start: {from: map, best: 1}, maxiter: 3}
  - {name: multipliers, kind: floquet, from: best}
""")
    assert floquet_failures(out.folder) == {"sequence": ""}
    assert "multipliers_multipliers" in out.drawn


def test_a_motor_frame_gait_with_its_height_in_the_map_and_survival_height(tmp_path):
    """A gait written in the motor frame, caught at the start's world height, its floquet
    step with the height in the map, a stability run on the tick and a survival step with
    latency and a height tolerance: every figure draws, the new ones (the full map's row,
    the height change of each run) among them."""
    out = report(tmp_path, """\
robot: seed2009
""" + f"gait: {json.dumps(DESIGN_B)}\n" + """\
steps:
  - {name: r, kind: refine, start: [4.844445533376672, -1.6124995598690839], maxiter: 50}
  - {name: f, kind: floquet, from: r, height_in_map: true}
  - {name: c, kind: stability, from: f, cycles: 3, controller: {tick: 0.001}}
  - {name: s, kind: survival, from: f, runs: 4, max_cycles: 10, height_tolerance: 0.01,
     controller: {tick: 0.001}, noise: {timing: 1.0e-3, latency: 1.0e-3}}
""")
    assert {"f_multipliers", "c_filmstrip", "c_height", "s_height_drift",
            "s_mfpt"} <= set(out.drawn)


def test_grazing_shoot_on_links_that_are_not_mirror_images(tmp_path):
    """Found by the property test: the shoot step's grazing solution measured its error with
    the one-cycle return map, which refuses links that are not mirror images (ValueError, the
    run failed). Its error is now the gait's error of its motorless replay, as the grid's."""
    out = report(tmp_path, """\
robot:
  name: drawn
  gravity: 3.0
  links:
    - {mass: 1.0, length: 0.5, com: 0.25, inertia: 0.0625}
    - {mass: 1.0, length: 1.0, com: 0.5, inertia: 0.25}
gait: {kind: horizontal, motor_torque: -1.0, tick: 0.0}
steps:
  - {name: map, kind: grid, points: [[0.0, 4.0]]}
  - {name: exact, kind: shoot, starts: [[0.0, 4.886]], method: grazing, max_iter: 1}
""", max_time=1.0)
    assert out.refused is None
    with xr.open_dataset(out.folder / "exact.nc") as ds:
        assert ds.sizes["solution"] == 1


# --- found by the property test with every step kind, clock and name (studystrategies.py) ------
def report_text(tmp_path, text: str):
    """Run and report a study kept as the property test drew it (the whole text)."""
    return run_and_report(text, tmp_path / "out")


FAILED_REFINE_THEN_A_GRID = """\
{
 "schema_version": 1,
 "name": "drawn",
 "robot": "uniform_rod",
 "gait": {"kind": "horizontal", "motor_torque": -0.1197, "tick": 0.0},
 "integrator": {"rtol": 1e-08, "atol": 1e-10, "max_time": 3.0},
 "steps": [
  {
   "name": "a",
   "kind": "grid",
   "points": [[0.0, 0.0]]
  },
  {
   "name": "aa",
   "kind": "refine",
   "start": {
    "from": "a",
    "best": 1
   },
   "maxiter": 1
  },
  {
   "name": "aaa",
   "kind": "grid",
   "points": [[0.0, 7.0]]
  }
 ]
}

"""


def test_a_failed_step_leaves_the_independent_later_step_to_run(tmp_path):
    """The refine of a grid without a gait fails; the grid after it depends on nothing. The
    run stopped at the failure, leaving that grid unrun, and the report returned normally
    with a page that did not name the failed step. The grid runs, the run ends naming the
    failure (StepsFailed), and the report says the study is incomplete and lists it."""
    out = report_text(tmp_path, FAILED_REFINE_THEN_A_GRID)
    assert set(out.incomplete) == {"aa"}
    assert "its one point has no gait" in out.incomplete["aa"]
    assert (out.folder / "aaa.nc").is_file()


CLIMBING_POLISHED_AT_THE_DEFAULT_TOLERANCES = """\
{
 "schema_version": 1,
 "name": "drawn",
 "robot": "seed2009",
 "gait": {"kind": "sequence", "section": {"theta1": 0.0, "direction": "either", "theta2": 1.0}, "segments": [{"until": "free_end_height", "value": 0.05, "direction": "rising", "latch_energy": true}, {"until": "energy_restored", "value": 0.981, "magnets": "swap", "torque": 0.6354}], "tick": 0.0},
 "steps": [
  {
   "name": "a",
   "kind": "grid",
   "points": [[4.3, 0.1]]
  },
  {
   "name": "aa",
   "kind": "refine",
   "start": {
    "from": "a",
    "best": 1
   }
  },
  {
   "name": "aaa",
   "kind": "floquet",
   "from": "aa"
  },
  {
   "name": "aaaa",
   "kind": "stability",
   "from": "aaa",
   "cycles": 1,
   "sample_dt": 0.005
  }
 ]
}

"""


def test_a_fixed_point_at_its_maps_error_level_is_polished_and_run(tmp_path):
    """The climbing gait at the default tolerances (rtol 1e-10): Newton's residual stops near
    1e-11, inside the map's error level (3e-9), short of a fixed residual target; the floquet
    step analysed the refined start instead, said nothing of it, and the stability step
    refused its point ("Newton not converged"). The polish stops at the map's error level,
    converged, and the stability run repeats the fixed point."""
    out = report_text(tmp_path, CLIMBING_POLISHED_AT_THE_DEFAULT_TOLERANCES)
    assert out.refused is None
    with xr.open_dataset(out.folder / "aaa.nc") as f:
        assert int(f["newton_converged"].values[0]) == 1
        assert float(f["map_defect"].values[0]) <= float(f["map_error"].values[0])
    with xr.open_dataset(out.folder / "aaaa.nc") as c:
        assert float(c["error"].values[0]) < 1e-16


FLIGHT_FROM_ITS_FIXED_POINT_FOR_THREE_CYCLES = """\
{
 "schema_version": 1,
 "name": "drawn",
 "robot": "seed2009",
 "gait": {"kind": "sequence", "section": {"theta1": 0.0, "direction": "either", "theta2": 0.3}, "segments": [{"until": "coord", "coord": "theta1", "value": 0.6, "direction": "rising", "latch_energy": true}, {"until": "free_end_y", "value": 0.0, "direction": "rising", "magnets": "none"}, {"until": "energy_restored", "value": 0.0, "magnets": "B", "torque": 0.6354}], "tick": 0.001},
 "integrator": {"rtol": 1e-10},
 "steps": [
  {
   "name": "map",
   "kind": "grid",
   "dtheta1": {
    "start": 1.891,
    "stop": 2.069,
    "num": 5
   },
   "dtheta2": {
    "start": 9.903,
    "stop": 10.18,
    "num": 4
   }
  },
  {
   "name": "best",
   "kind": "refine",
   "start": {
    "from": "map",
    "best": 1
   }
  },
  {
   "name": "multipliers",
   "kind": "floquet",
   "from": "best"
  },
  {
   "name": "stability_f",
   "kind": "stability",
   "from": "multipliers",
   "cycles": 2,
   "sample_dt": 0.02,
   "max_drop": 0.1202
  },
  {
   "name": "tick_sweep_f",
   "kind": "tick_sweep",
   "from": "multipliers",
   "ticks": [0.005, 0.001, 0.0],
   "cycles": 3,
   "replay": "gait"
  },
  {
   "name": "cycles",
   "kind": "stability",
   "from": "best",
   "cycles": 5,
   "sample_dt": 0.05
  }
 ]
}

"""


def test_a_flight_gait_run_from_its_fixed_point_repeats_it_every_cycle(tmp_path):
    """The flight gait catches with B, so its cycle ends hanging from B: every other cycle is
    its mirror image. Run from its fixed point for more than one cycle it was wrong from the
    second (error 145, 12 rad s-1 off). On exact timing every cycle repeats the fixed point to
    round-off (its leading multiplier is 4)."""
    out = report_text(tmp_path, FLIGHT_FROM_ITS_FIXED_POINT_FOR_THREE_CYCLES)
    assert out.refused is None
    with xr.open_dataset(out.folder / "tick_sweep_f.nc") as t:
        exact = t["error"].values[list(t["tick"].values).index(0.0)]
    assert np.all(exact < 1e-18), exact


RUNNING_CLOCK_ON_A_5_MS_TICK = """\
{
 "schema_version": 1,
 "name": "drawn",
 "robot": "seed2009",
 "gait": {"kind": "horizontal", "motor_torque": 0.5202, "tick": 0.005},
 "integrator": {"rtol": 1e-08, "atol": 1e-10, "max_time": 3.0},
 "steps": [
  {
   "name": "map",
   "kind": "grid",
   "dtheta1": {
    "start": 2.93,
    "stop": 2.93,
    "num": 1
   },
   "dtheta2": {
    "start": 13.03,
    "stop": 13.03,
    "num": 1
   }
  },
  {
   "name": "map2",
   "kind": "grid",
   "dtheta1": {
    "start": 0.0,
    "stop": 0.0,
    "num": 1
   },
   "dtheta2": {
    "start": 14.0,
    "stop": 14.0,
    "num": 1
   }
  },
  {
   "name": "best",
   "kind": "refine",
   "start": [0.796, 10.43],
   "maxiter": 8
  },
  {
   "name": "cycles",
   "kind": "stability",
   "from": "best",
   "cycles": 2,
   "sample_dt": 0.005,
   "max_drop": 0.3333,
   "controller": {
    "clock": "run_on"
   }
  },
  {
   "name": "exact",
   "kind": "shoot",
   "starts": [[1.44, 10.31], [0.0, 9.588]],
   "method": "gauss_newton",
   "max_iter": 3
  },
  {
   "name": "noise",
   "kind": "survival",
   "from": "best",
   "runs": 4,
   "max_cycles": 7,
   "seed": 1,
   "noise": {
    "timing": 0.02
   },
   "controller": {
    "tick": 0.001
   }
  }
 ]
}

"""


def test_a_running_clock_records_every_cycles_vertical_crossing(tmp_path):
    """A stability run of a refined gait with its clock running on, on a 5 ms tick: the
    second cycle's vertical crossing came after the clock's period ended, and the cycle was
    recorded with no crossing (error, kinetic energy and crossing time NaN) while the run's
    status was ok. Every cycle that crosses records it."""
    out = report_text(tmp_path, RUNNING_CLOCK_ON_A_5_MS_TICK)
    with xr.open_dataset(out.folder / "cycles.nc") as c:
        assert int(c["status"]) == 0
        for name in ("error", "kinetic_energy", "t_cross"):
            assert np.all(np.isfinite(c[name].values)), name
