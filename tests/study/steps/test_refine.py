"""The refine step's task: Nelder-Mead from one start, every iterate recorded."""
from __future__ import annotations

import math

import numpy as np
import pytest

from monkeystudy import Integrator, Robot
from monkeystudy.kernel.layout import ST_OK
from monkeystudy.study.runner import load_kernels
from monkeystudy.study.spec import GaitSpec
from monkeystudy.study.steps import refine

from studyhelpers import assert_written_as_declared, refine_starts_dims

TORQUE = 0.6354
INTEG = Integrator(rtol=1e-8, atol=1e-10)


@pytest.fixture(scope="module")
def spec():
    s = GaitSpec(Robot.preset("seed2009"), INTEG, TORQUE, 0.001)
    load_kernels(s, runs=True)
    return s


def test_refine_records_iterates_and_converges(spec):
    r = refine.refine_task(spec, (1.0, 12.0), xatol=1e-4, fatol=1e-4)
    it = r["iterate_x"]
    assert it.shape == (len(r["iterate_error"]), 2)
    np.testing.assert_array_equal(it[0], [1.0, 12.0])          # iteration 0: the start
    np.testing.assert_array_equal(it[-1], r["x"])
    assert r["converged"] == 1 and r["status"] == ST_OK
    assert r["error"] == pytest.approx(r["iterate_error"][-1])
    finite = r["iterate_error"][np.isfinite(r["iterate_error"])]
    assert np.all(np.diff(finite) <= 0)                   # the best vertex never gets worse
    assert np.all(np.diff(r["iterate_nfev"]) > 0)
    assert r["iterate_nfev"][-1] <= r["nfev"]
    assert len(r["iterate_error"]) == r["nit"]
    assert r["error"] < 1e-3                              # the study's gait, near (0.90, 10.93)
    assert abs(r["x"][0] - 0.9) < 0.05 and abs(r["x"][1] - 10.93) < 0.05


def test_refine_penalty_keeps_the_objective_finite(spec):
    """From a start where the gait fails the simplex gets the penalty, not NaN."""
    r = refine.refine_task(spec, (0.05, 6.0), xatol=1e-4, fatol=1e-4, maxiter=20,
                            penalty=1e6)
    assert r["status"] != ST_OK and math.isnan(r["error"])
    assert np.isnan(r["iterate_error"]).all()
    assert r["nit"] <= 20


def test_refine_limits(spec):
    r = refine.refine_task(spec, (1.0, 12.0), xatol=1e-4, fatol=1e-4, maxfev=15)
    assert r["nfev"] <= 16 and r["converged"] == 0


def test_refine_datasets_are_written_as_declared(tiny_reference, analysis_smoke):
    assert_written_as_declared(tiny_reference[1] / "best.nc", "refine",
                               dims_of=refine_starts_dims)
    assert_written_as_declared(analysis_smoke[0] / "nm.nc", "refine")


def test_a_grid_with_fewer_gaits_than_best_is_refused_saying_how_many(tmp_path):
    """A refine asking for more starts than the grid has gaits stops with how many it has
    and what to change; a count of one is "1 point", not "1 points"."""
    from monkeystudy.study import RunFailed, parse_study, run_study

    text = """\
schema_version: 1
name: few
robot: seed2009
gait: {kind: horizontal, motor_torque: 0.6354, tick: 0.001}
integrator: {rtol: 1.0e-8, atol: 1.0e-10}
steps:
  - {name: map, kind: grid, points: [[0.0, 6.0], [0.9, 10.9], [0.1, 6.5]]}
  - {name: best, kind: refine, start: {from: map, best: 2}, maxiter: 2}
"""
    with pytest.raises(RunFailed) as exc:
        run_study(parse_study(text, "few.yaml", tmp_path / "few.yaml"), tmp_path / "out",
                  workers=1)
    assert str(exc.value) == (
        "best: start: {from: map, best: 2}: grid 'map': 2 starts requested, but only 1 of its "
        "3 points has a gait (an error value): ask for at most 1, or widen or move the grid")


def test_a_search_that_finds_no_gait_says_so_not_best_error_nan(tmp_path):
    """A refinement whose every point failed said "best error nan" in the run's log
    and "error nan" in ``monkeystudy inspect``. It says that it found no gait, so there is no
    error, with the status its search ended on."""
    import io

    from monkeystudy.study import parse_study, run_study
    from monkeystudy.study.inspect import summarize
    from monkeystudy.study.progress import PlainReporter

    text = """\
schema_version: 1
name: nogait
robot: seed2009
gait: {kind: horizontal, motor_torque: 0.6354, tick: 0.001}
integrator: {rtol: 1.0e-8, atol: 1.0e-10}
steps:
  - {name: lost, kind: refine, start: [0.05, 6.0], maxiter: 3}
"""
    log = io.StringIO()
    run_study(parse_study(text, "nogait.yaml", tmp_path / "nogait.yaml"), tmp_path / "out",
              workers=1, reporter=PlainReporter(log))
    done = [line for line in log.getvalue().splitlines()
            if line.startswith("[monkeystudy] lost: done")]
    assert len(done) == 1, log.getvalue()
    assert "nan" not in done[0] and "no gait found, so no error" in done[0], done[0]
    shown = summarize(tmp_path / "out" / "lost.nc")
    assert "nan" not in shown and "no error (no gait found)" in shown, shown
