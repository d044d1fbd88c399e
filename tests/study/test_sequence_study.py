"""A sequence-gait study end to end: grid (t_segment, x/y advance, blocks cutting rows),
refine from the grid, floquet from the refine; identical for 1 and 2 workers."""
from __future__ import annotations

import json

import numpy as np
import pytest
import xarray as xr

from monkeystudy.analysis import cycle_return_map, jacobian_fd
from monkeystudy.controllers import Integrator
from monkeystudy.simulate import evaluate_cycle_gaits
from monkeystudy.study import load_study, run_study
from monkeystudy.study.runner import study_spec
from monkeystudy.study.drivers import spec_sequence

from studyhelpers import assert_same_datasets, write_study

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
    seq = spec_sequence(study_spec(loaded.study))
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
    seq = spec_sequence(study_spec(load_study(folder / "flight.yaml").study))
    zn, st = cycle_return_map(z, seq, integrator=Integrator(rtol=1e-12, atol=1e-13))
    assert st == 0 and np.abs(zn - z).max() < 1e-9


def test_two_workers_give_the_same_datasets(flight_run, tmp_path):
    study, folder = flight_run
    run_study(load_study(study), tmp_path / "two", workers=2)
    assert_same_datasets(folder / "one", tmp_path / "two",
                         names=["map.nc", "best.nc", "floquet.nc"])
