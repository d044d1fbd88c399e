"""The stability step's task: a refined gait replayed open-loop for many cycles."""
from __future__ import annotations

import math

import numpy as np
import pytest

from monkeystudy import Integrator, Robot
from monkeystudy.kernel.layout import ST_HORIZON, ST_OK, ST_UNREACHABLE
from monkeystudy.simulation import Status
from monkeystudy.study.runner import load_kernels
from monkeystudy.study.spec import GaitSpec
from monkeystudy.study.steps import refine, stability

from studyhelpers import assert_written_as_declared

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
