"""The stability step's task: a refined gait replayed open-loop for many cycles."""
from __future__ import annotations

import json
import math

import numpy as np
import pytest

import xarray as xr

from monkeystudy import Integrator, Robot
from monkeystudy.controllers import horizontal_gait, motorless, open_loop_gait
from monkeystudy.kernel.layout import ST_HORIZON, ST_OK, ST_UNREACHABLE
from monkeystudy.simulation import Status, evaluate_cycle_gaits
from monkeystudy.study import load_study, run_study
from monkeystudy.study.runner import load_kernels
from monkeystudy.study.spec import GaitSpec
from monkeystudy.study.steps import refine, stability

from studyhelpers import assert_written_as_declared, write_study

TORQUE = 0.6354
INTEG = Integrator(rtol=1e-8, atol=1e-10)


@pytest.fixture(scope="module")
def spec():
    s = GaitSpec(Robot.preset("seed2009"), INTEG, TORQUE, 0.001)
    load_kernels(s, runs=True)
    return s


def test_stability_first_cycle_repeats_the_refined_gait(spec):
    r = refine.refine_task(spec, (1.0, 12.0), xatol=1e-4, fatol=1e-4)
    s = stability.stability_task(spec, spec.sequence, [0.0, r["x"][0], r["x"][1]],
                                 times=[r["t_switch"], r["t_switch"] + r["t_motor"]],
                                 cycles=5, tick=0.001, sample_dt=0.005, max_drop=0.61,
                                 replay="open_loop")
    assert s["status"] == ST_OK and s["cycles_completed"] == 5
    # the open-loop replay of the recorded times is the search controller's first cycle
    assert s["error"][0] == pytest.approx(r["error"], rel=1e-6, abs=1e-12)
    assert np.all(np.diff(s["t_swap"]) > 0) and np.all(s["t_cross"] > s["t_swap"])
    assert np.all(np.abs(s["pivot_height"]) < 0.05)
    assert np.all(np.abs(s["x_advance"] - 0.51) < 0.05)   # about L1 s1 + L2 s12 per step
    assert np.all(s["kinetic_energy"] > 0)
    n = len(s["time"])
    assert n > 0 and s["A"].shape == s["B"].shape == s["joint"].shape == (n, 2)
    assert np.all(np.diff(s["time"]) >= 0)
    assert set(np.unique(s["phase"])) <= {0, 1, 2}


def test_stability_of_a_failed_gait_is_not_run(spec):
    # below the swap energy floor: the gait's one cycle says unreachable, nothing runs
    s = stability.stability_task(spec, spec.sequence, [0.0, 0.1, 5.0],
                                 times=[math.nan, math.nan], cycles=3, tick=0.001,
                                 sample_dt=0.005, max_drop=0.61, replay="open_loop")
    assert s["status"] == ST_UNREACHABLE and np.isnan(s["error"]).all()
    assert len(s["time"]) == 0


def test_stability_dataset_is_written_as_declared(tiny_reference):
    assert_written_as_declared(tiny_reference[1] / "cycles.nc", "stability")


def test_the_runs_line_says_why_it_stopped_and_which_cycles_reached_no_crossing():
    """A run that stops early says where and why in the run's log, not only its status name;
    a cycle recorded from its swap that reached no vertical crossing before the next swap
    (error NaN in a run that ran all its cycles) is named."""
    stopped = {"status": ST_HORIZON, "cycles_completed": 2,
               "error": np.array([5.1e-27, 144.8, np.nan, np.nan])}
    text = stability.run_summary(stopped, 4, "section")
    assert text.startswith("STOPPED after 2 of 4 cycles: status horizon")
    assert Status.HORIZON.message in text and "crossing" not in text
    gap = {"status": ST_OK, "cycles_completed": 3, "error": np.array([1e-4, np.nan, 8e-4])}
    assert stability.run_summary(gap, 3, "swap") == (
        "3 cycles, status ok; 1 cycle(s) (2) reached no vertical crossing before the next "
        "swap (error NaN)")
    ok = {"status": ST_OK, "cycles_completed": 3, "error": np.array([1e-4, 2e-4, 8e-4])}
    assert stability.run_summary(ok, 3, "swap") == "3 cycles, status ok"
    np.testing.assert_array_equal(stability.uncrossed_cycles([1e-4, np.nan, 1e-3, np.nan],
                                                              ST_HORIZON), [2])


#: the exact gait (its grazing fixed point, no motor) replayed from its floquet step's fixed
#: point with the restarting clock and with the clock running on, on a 1 ms tick
RUN_ON_FROM_FLOQUET = """\
schema_version: 1
name: run_on_from_floquet
robot: seed2009
gait: {kind: horizontal, motor_torque: 0.6354, tick: 0.0}
integrator: {method: dop853, rtol: 1.0e-13, atol: 1.0e-13}
steps:
  - {name: shoot, kind: shoot, starts: [[1.0, 12.0], [1.44, 10.31]]}
  - {name: floquet, kind: floquet, from: shoot, controllers: [open_loop]}
  - {name: reset, kind: stability, from: floquet, cycles: 5, controller: {tick: 0.001}}
  - {name: run_on, kind: stability, from: floquet, cycles: 5,
     controller: {tick: 0.001, clock: run_on}}
"""


def test_a_floquet_fixed_point_replayed_with_a_running_clock_runs_it_on(tmp_path):
    """``clock: run_on`` from a floquet step runs the clock on with the fixed point's period
    (its open-loop cycle's vertical crossing): the swaps come at the first tick after
    ``(k - 1) * period + t_switch``, where the restarting clock swaps ``t_switch`` after the
    tick that follows each vertical crossing; every cycle reaches its crossing."""
    study = write_study(tmp_path, RUN_ON_FROM_FLOQUET, "run_on.yaml")
    run_study(load_study(study), tmp_path / "out", workers=1)
    with xr.open_dataset(tmp_path / "out" / "floquet.nc") as f, \
            xr.open_dataset(tmp_path / "out" / "reset.nc") as reset, \
            xr.open_dataset(tmp_path / "out" / "run_on.nc") as run_on:
        f.load()
        reset.load()
        run_on.load()
    z = f["fixed_point"].values[0]
    t_switch = float(f["t_switch"].values[0])
    assert float(f["t_motor"].values[0]) == 0.0
    cycle = open_loop_gait(motorless(horizontal_gait(0.6354)), (t_switch, t_switch))
    period = float(evaluate_cycle_gaits([z[1:]], cycle, robot="seed2009",
                                        integrator=Integrator(rtol=1e-13, atol=1e-13))
                   ["t_end"][0])
    assert json.loads(run_on.attrs["controller"]) == {"tick": 0.001, "clock": "run_on"}
    on_tick = np.ceil((np.arange(5) * period + t_switch) / 0.001 - 1e-9) * 0.001
    np.testing.assert_allclose(run_on["t_swap"].values, on_tick, rtol=0, atol=1e-12)
    after_cross = np.ceil(reset["t_cross"].values[:-1] / 0.001) * 0.001
    np.testing.assert_allclose(reset["t_swap"].values[1:],
                               np.ceil((after_cross + t_switch) / 0.001 - 1e-9) * 0.001,
                               rtol=0, atol=1e-12)
    for ds in (reset, run_on):
        assert int(ds["status"]) == ST_OK and np.all(np.isfinite(ds["error"].values))
