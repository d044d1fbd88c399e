"""A sequence-gait study end to end: grid (t_segment, x/y advance, blocks cutting rows),
refine from the grid, floquet from the refine; identical for 1 and 2 workers."""
from __future__ import annotations

import json

import numpy as np
import pytest
import xarray as xr

from monkeystudy.analysis import cycle_return_map
from monkeystudy.controllers import Integrator
from monkeystudy.simulation import evaluate_cycle_gaits
from monkeystudy.study import load_study, run_study
from monkeystudy.study.spec import gait_spec

from studyhelpers import (assert_same_datasets, assert_written_as_declared, refine_starts_dims,
                          write_study)

#: the flight gait of studies/flight_gait.yaml on a small grid around its fixed point
FLIGHT = """\
schema_version: 1
name: flight_tiny
robot: seed2009
gait:
  kind: sequence
  section: {theta1: 0.0, direction: either, theta2: 0.3}
  segments:
    - {until: coord, coord: theta1, value: 0.6, direction: rising, latch_energy: true}
    - {until: free_end_y, value: 0.0, direction: rising, magnets: none}
    - {until: energy_restored, magnets: B, torque: 0.6354}
integrator: {method: dop853, rtol: 1.0e-12, atol: 1.0e-13, max_time: 3.0}
steps:
  - {name: map, kind: grid, block_size: 7,
     dtheta1: {start: 1.8, stop: 2.0, num: 5}, dtheta2: {start: 9.8, stop: 10.1, num: 6}}
  - {name: best, kind: refine, start: {from: map, best: 1}, xatol: 1.0e-10, fatol: 1.0e-20,
     maxfev: 400}
  - {name: floquet, kind: floquet, from: best}
  - {name: cycles, kind: stability, from: floquet, cycles: 8}
  - {name: survive, kind: survival, from: floquet, runs: 2, max_cycles: 6, seed: 1,
     error_bound: 1.0e-6, noise: {timing: 1.0e-12}}
"""


@pytest.fixture(scope="module")
def flight_run(tmp_path_factory):
    folder = tmp_path_factory.mktemp("flight")
    study = write_study(folder, FLIGHT, "flight.yaml")
    run_study(load_study(study), folder / "one", workers=1)
    return study, folder


def test_grid_holds_the_cycle_of_every_point(flight_run):
    study, folder = flight_run
    loaded = load_study(study)
    seq = gait_spec(loaded.study).sequence
    with xr.open_dataset(folder / "one" / "map.nc") as ds:
        ds.load()
    assert ds["t_segment"].dims == ("dtheta1", "dtheta2", "segment")
    assert ds.sizes["segment"] == 4
    assert json.loads(ds.attrs["gait"])["kind"] == "sequence"
    g1, g2 = np.meshgrid(ds["dtheta1"].values, ds["dtheta2"].values, indexing="ij")
    direct = evaluate_cycle_gaits(np.stack([g1.ravel(), g2.ravel()], 1), seq,
                                  integrator=Integrator(rtol=1e-12, atol=1e-13))
    # blocks of 7 points cut the rows of 6: the flat-to-2-D writing must put each where it is
    np.testing.assert_array_equal(ds["status"].values.ravel(), direct["status"])
    np.testing.assert_array_equal(ds["error"].values.ravel(), direct["error"])
    np.testing.assert_array_equal(ds["t_segment"].values.reshape(-1, 4), direct["t_segment"])
    np.testing.assert_array_equal(ds["x_advance"].values.ravel(), direct["x_advance"])
    ok = direct["status"] == 0
    assert ok.sum() >= 10
    # the catch is by B at A's height: no climb, and the robot moves on
    assert np.all(np.abs(direct["y_advance"][ok]) < 1e-12)
    assert np.all(direct["x_advance"][ok] > 0.3)


def test_refine_finds_an_exact_cycle(flight_run):
    _, folder = flight_run
    with xr.open_dataset(folder / "one" / "best.nc") as r:
        r.load()
    assert r["status"].values.ravel()[0] == 0
    # Nelder-Mead on (dtheta1, dtheta2) at theta2 = 0 reaches round-off: a fixed point exists
    assert float(r["error"].values.ravel()[0]) < 1e-18
    assert r["t_segment"].sizes["segment"] == 4
    assert "t_switch" not in r


def test_floquet_of_the_cycle(flight_run):
    _, folder = flight_run
    with xr.open_dataset(folder / "one" / "floquet.nc") as f:
        f.load()
    assert list(f["controller"].values) == ["sequence"]
    assert int(f["newton_converged"].values[0]) == 1
    assert float(f["map_defect"].values[0]) < 1e-10
    # the energy latch makes one multiplier exactly neutral
    assert int(f["neutral"].values[0]) == 1
    J, Jfd = f["jacobian"].values[0], f["jacobian_fd"].values[0]
    assert np.abs(J - Jfd).max() / np.abs(J).max() < 1e-6
    # the fixed point is a fixed point of the map the study defines
    z = f["fixed_point"].values[0]
    seq = gait_spec(load_study(folder / "flight.yaml").study).sequence
    zn, st = cycle_return_map(z, seq, integrator=Integrator(rtol=1e-12, atol=1e-13))
    assert st == 0 and np.abs(zn - z).max() < 1e-9


def test_the_cycles_alternate_with_their_mirror_images(flight_run):
    """The flight gait releases A and catches with B: its cycle ends hanging from B, and the
    floquet step's return map compares B's frame with A's, so the next cycle releases B and
    catches with A. From the fixed point every cycle of the stability step repeats the first
    (the same advance, at the start's height, the error at round-off grown by the leading
    multiplier, 3.9: below 1e-12 after 8 cycles), and every survival run under 1e-12 s of
    timing jitter completes all its cycles within the error bound."""
    _, folder = flight_run
    with xr.open_dataset(folder / "one" / "floquet.nc") as f, \
            xr.open_dataset(folder / "one" / "cycles.nc") as c, \
            xr.open_dataset(folder / "one" / "survive.nc") as s:
        f.load()
        c.load()
        s.load()
    assert int(c["status"]) == 0 and c.attrs["cycles_completed"] == 8
    np.testing.assert_allclose(c["x_advance"].values, float(f["x_advance"].values[0]),
                               rtol=0, atol=1e-6)
    np.testing.assert_allclose(c["pivot_height"].values, 0.0, rtol=0, atol=1e-6)
    assert np.all(c["error"].values < 1e-12)
    assert np.all(s["cycles_completed"].values == 6)
    assert np.all(s["failure"].values == 0)


def test_two_workers_give_the_same_datasets(flight_run, tmp_path):
    study, folder = flight_run
    run_study(load_study(study), tmp_path / "two", workers=2)
    assert_same_datasets(folder / "one", tmp_path / "two",
                         names=["map.nc", "best.nc", "floquet.nc"])


#: studies/two_step.yaml on a small grid, with short continuations
TWO_STEP = """\
schema_version: 1
name: two_step_tiny
robot: seed2009
gait:
  kind: sequence
  section: {theta1: 0.0, direction: either, theta2: 0.0}
  segments:
    - {until: free_end_height, value: 0.0, direction: rising, latch_energy: true}
    - {until: energy_restored, value: 0.0, magnets: swap, torque: 0.6354}
    - {until: coord, coord: theta1, value: 0.0, direction: either}
    - {until: free_end_height, value: 0.0, direction: rising, latch_energy: true}
    - {until: energy_restored, value: 0.0, magnets: swap, torque: 0.6354}
integrator: {method: dop853, rtol: 1.0e-12, atol: 1.0e-13, max_time: 3.0}
steps:
  - {name: map, kind: grid,
     dtheta1: {start: 0.70, stop: 0.78, num: 5}, dtheta2: {start: 11.1, stop: 11.2, num: 5}}
  - {name: best, kind: refine, start: {from: map, best: 1}, xatol: 1.0e-10, fatol: 1.0e-20,
     maxfev: 600}
  - {name: floquet, kind: floquet, from: best}
  - {name: lighter, kind: continuation, from: floquet, parameter: mass_ratio, ds: -0.05,
     steps: 3}
  - {name: stronger, kind: continuation, from: floquet, parameter: torque, ds: 0.05,
     steps: 2, bounds: [0.0, 0.7]}
"""


def test_sequence_continuation_end_to_end(tmp_path):
    study = write_study(tmp_path, TWO_STEP, "two_step.yaml")
    run_study(load_study(study), tmp_path / "out", workers=1)
    with xr.open_dataset(tmp_path / "out" / "floquet.nc") as fl:
        z = fl["fixed_point"].values[0]
    with xr.open_dataset(tmp_path / "out" / "lighter.nc") as ds:
        ds.load()
    assert_written_as_declared(tmp_path / "out" / "lighter.nc", "continuation")
    assert ds.attrs["parameter"] == "mass_ratio" and ds.attrs["stop_reason"] == "steps"
    assert ds.sizes["point"] == 4 and ds.sizes["segment"] == 6
    assert ds["parameter_value"].values[0] == 1.0
    assert np.all(np.diff(ds["parameter_value"].values) < 0)
    np.testing.assert_array_equal([ds["dtheta1"].values[0], ds["dtheta2"].values[0]], z[1:])
    assert ds.attrs["theta2_pinned"] == 1
    np.testing.assert_allclose(ds["theta2"].values, z[0], rtol=0, atol=1e-10)
    assert np.all(ds["residual"].values < 1e-10)
    assert ds["stable"].values[0] == 1 and ds["neutral"].values.tolist() == [1] * 4
    assert np.all(ds["x_advance"].values > 0.9)      # it walks: about 0.92 m per two steps
    for name in ("parameter_value", "residual", "t_segment", "multipliers_real"):
        assert ds[name].attrs["units"] and ds[name].attrs["long_name"]
    with xr.open_dataset(tmp_path / "out" / "stronger.nc") as ds2:
        v = ds2["parameter_value"].values
        assert ds2.attrs["stop_reason"] == "bounds" and v[0] == pytest.approx(0.6354)
        assert np.all(v <= 0.7) and v.size >= 2
    from monkeystudy.plotting import plot_continuation
    import matplotlib.pyplot as plt
    fig = plot_continuation(ds)
    gids = {a.get_gid() for ax in fig.axes for a in ax.get_children() if a.get_gid()}
    assert {"dtheta1", "dtheta2", "t_cycle", "modulus_0", "modulus_1", "unit_level",
            "start"} <= gids
    assert "modulus_2" not in gids                   # the neutral multiplier is left out
    plt.close(fig)


#: the same gait run for many cycles: its own controller and the open-loop replay
TWO_STEP_REPLAYS = TWO_STEP.split("  - {name: lighter")[0] + """\
  - {name: own, kind: stability, from: floquet, cycles: 12, replay: gait}
  - {name: own_from_refine, kind: stability, from: best, cycles: 3}
  - {name: open, kind: stability, from: floquet, cycles: 12, replay: open_loop}
  - {name: ticks_open, kind: tick_sweep, from: floquet, replay: open_loop, ticks: [1.0e-3, 0.0],
     cycles: 12}
  - {name: ticks_own, kind: tick_sweep, from: floquet, ticks: [1.0e-3, 0.0], cycles: 12}
  - {name: basin, kind: basin, from: floquet, max_cycles: 4, error_bound: 1.0e-2,
     offsets: {d_dtheta1: {start: -0.3, stop: 0.3, num: 3},
               d_dtheta2: {start: -0.3, stop: 0.3, num: 3}}}
"""


def test_sequence_replays_end_to_end(tmp_path):
    study = write_study(tmp_path, TWO_STEP_REPLAYS, "two_step.yaml")
    run_study(load_study(study), tmp_path / "out", workers=2)
    out = tmp_path / "out"
    with xr.open_dataset(out / "floquet.nc") as fl:
        z = fl["fixed_point"].values[0]
        lam_own = np.abs(fl["multipliers_real"].values[0] + 1j * fl["multipliers_imag"].values[0])
    with xr.open_dataset(out / "own.nc") as own, xr.open_dataset(out / "open.nc") as ol:
        own.load()
        ol.load()
    # the own controller holds the stable gait; the open-loop replay of it drifts away
    assert own.attrs["replay"] == "gait" and ol.attrs["replay"] == "open_loop"
    assert own.attrs["floquet_step"] == "floquet" and own.attrs["start_theta2"] == z[0]
    assert int(own["status"]) == 0 and np.all(own["error"].values < 1e-15)
    assert np.all(own["x_advance"].values > 0.9)
    assert "section crossing" in own["error"].attrs["long_name"]
    e = ol["error"].values
    assert e[-1] > 1e6 * e[2] > 0
    np.testing.assert_allclose(json.loads(ol.attrs["t_segment"]),
                               json.loads(own.attrs["t_segment"]), rtol=0, atol=1e-12)
    with xr.open_dataset(out / "own_from_refine.nc") as r:
        assert r.attrs["refine_step"] == "best" and r.attrs["start_theta2"] == 0.0
        assert np.all(r["error"].values < 1e-12)
    with xr.open_dataset(out / "ticks_open.nc") as t_open:
        t_open.load()
    assert t_open.attrs["leading_multiplier"] == pytest.approx(2.529, abs=2e-3)
    assert "finite differences" in t_open.attrs["leading_multiplier_source"]
    assert len(json.loads(t_open.attrs["open_loop_multipliers_real"])) == 3
    to_bound = dict(zip(t_open["tick"].values.tolist(), t_open["cycles_to_bound"].values))
    assert to_bound[1e-3] < to_bound[0.0]
    with xr.open_dataset(out / "ticks_own.nc") as t_own:
        t_own.load()
    assert t_own.attrs["leading_multiplier"] == pytest.approx(lam_own.max(), rel=1e-12)
    assert "floquet step floquet" in t_own.attrs["leading_multiplier_source"]
    assert np.all(t_own["error"].sel(tick=0.0).values < 1e-15)
    assert t_own["error"].sel(tick=1e-3).values[0] > 1e-6     # the tick moves the swap
    with xr.open_dataset(out / "basin.nc") as b:
        b.load()
    assert b.attrs["replay"] == "gait" and b["cycles"].values[1, 1] == 4
    assert b["cycles"].values[0, 0] < 4
    from monkeystudy.plotting import plot_basin, plot_tick_sweep
    from monkeystudy.plotting.cycles import plot_error_comparison
    import matplotlib.pyplot as plt
    for fig, want in ((plot_tick_sweep(t_open), {"error_0", "error_1", "prediction"}),
                      (plot_basin(b), {"cycles", "gait"}),
                      (plot_error_comparison([own, ol]), {"error_own", "error_open"})):
        gids = {a.get_gid() for ax in fig.axes for a in ax.get_children() if a.get_gid()}
        assert want <= gids, gids
        plt.close(fig)


def test_sequence_datasets_are_written_as_declared(flight_run):
    _, folder = flight_run
    assert_written_as_declared(folder / "one" / "map.nc", "grid")
    assert_written_as_declared(folder / "one" / "best.nc", "refine", dims_of=refine_starts_dims)
    assert_written_as_declared(folder / "one" / "floquet.nc", "floquet")
