"""The shoot step: exact gaits by Newton shooting (grazing and gauss_newton), the merge of
solutions found from several starts, a start from a refine step.

The end-to-end cases read the analysis smoke study's datasets (``analysis_smoke``,
tests/study/steps/conftest.py)."""
from __future__ import annotations

import json

import numpy as np
import pytest

from monkeystudy.study.steps.shoot import METHOD_GAUSS_NEWTON, METHOD_GRAZING, dedup_solutions

from studyhelpers import assert_written_as_declared, open_dataset


def test_shoot_finds_the_exact_grazing_gait_once(analysis_smoke):
    ds = open_dataset(analysis_smoke[0], "shoot.nc")
    method = ds["method"].values
    grazing = np.flatnonzero(method == METHOD_GRAZING)
    # both starts land on the same collisionless gait: merged into one solution
    assert grazing.size == 1
    g = int(grazing[0])
    assert json.loads(ds.attrs["solution_starts"])[g] == [0, 1]
    assert ds["error"].values[g] < 1e-20                   # exact by construction
    assert ds["converged"].values[g] == 1 and ds["status"].values[g] == 0
    assert ds["t_motor"].values[g] == 0.0
    assert ds["t_end"].values[g] == pytest.approx(2 * ds["t_switch"].values[g], rel=1e-9)
    assert ds["dtheta1"].values[g] == pytest.approx(1.49524375, abs=1e-6)
    assert ds["dtheta2"].values[g] == pytest.approx(10.2468454, abs=1e-6)
    assert int(ds.attrs["best_solution"]) == g
    h = ds["history"].values[g]
    assert h[np.isfinite(h)][-1] < 1e-13
    # gauss_newton stalls on the grazing border (the error is not smooth there)
    assert np.all(ds["error"].values[method == METHOD_GAUSS_NEWTON] > 1e-8)
    assert len(json.loads(ds.attrs["message"])) == ds.sizes["solution"]


def test_shoot_from_a_refine_step(analysis_smoke):
    nm = open_dataset(analysis_smoke[0], "nm.nc")
    ds = open_dataset(analysis_smoke[0], "shoot_nm.nc")
    sh = open_dataset(analysis_smoke[0], "shoot.nc")
    assert json.loads(ds.attrs["starts"]) == [[float(nm["dtheta1"]), float(nm["dtheta2"])]]
    assert ds.attrs["refine_step"] == "nm" and ds.sizes["solution"] == 1
    g = int(sh.attrs["best_solution"])
    assert ds["error"].values[0] < 1e-20
    assert ds["dtheta1"].values[0] == pytest.approx(sh["dtheta1"].values[g], abs=1e-9)


def test_dedup_keeps_the_lower_error_and_every_start():
    def cand(d1, err, method=1):
        return {"dtheta1": d1, "dtheta2": 10.0, "error": err, "method": method,
                "t_switch": 0.4, "message": f"found {err:g}"}
    results = [{"start": (1.0, 12.0), "candidates": [cand(1.5, 400.0), cand(1.2, 1e-3, 0)],
                "failures": []},
               {"start": (1.4, 10.3), "candidates": [cand(1.5 + 1e-8, 1e-27)],
                "failures": ["gauss_newton: no gait"]}]
    sols, fails = dedup_solutions(results, 1e-6)
    assert [s["dtheta1"] for s in sols] == [1.5 + 1e-8, 1.2]
    assert sols[0]["error"] == 1e-27 and sols[0]["starts"] == [0, 1]
    assert sols[0]["start_index"] == 0
    assert sols[0]["message"] == ("found 1e-27; the same rates were also reached from start 0 "
                                  "by grazing with the swap at 0.4 s and gait error 400; the "
                                  "lower error is kept")
    assert sols[1]["message"] == "found 0.001"
    assert fails == ["start 1 [1.4, 10.3]: gauss_newton: no gait"]


def test_shoot_datasets_are_written_as_declared(analysis_smoke):
    for name in ('shoot.nc', 'shoot_nm.nc'):
        assert_written_as_declared(analysis_smoke[0] / name, "shoot")


def test_a_collisionless_swap_on_a_later_swing_is_not_handed_on_as_a_gait(tmp_path):
    """From (1.44, 10.31) alone the grazing solve converges to B at rest at A's height 1.30 s
    after the start, after the cycle's return to the vertical: its equations are met, its
    gait error is 429. A later step refuses it, saying so, instead of running a non-gait."""
    from monkeystudy.study import load_study, run_study
    from monkeystudy.study.errors import RunFailed

    path = tmp_path / "one_start.yaml"
    path.write_text("""\
schema_version: 1
name: one_start
robot: seed2009
gait: {kind: horizontal, motor_torque: 0.6354, tick: 0.0}
integrator: {rtol: 1.0e-10, atol: 1.0e-12}
steps:
  - {name: shoot, kind: shoot, starts: [[1.44, 10.31]], method: grazing}
  - {name: ticks, kind: tick_sweep, from: shoot, ticks: [0.001], cycles: 5}
""")
    with pytest.raises(RunFailed, match=r"produced no usable gait \(found: grazing error "
                                        r"429 status 0; a gait's error is at most 0.01\)"):
        run_study(load_study(path), tmp_path / "out", workers=1)
    ds = open_dataset(tmp_path / "out", "shoot.nc")
    assert ds["converged"].values[0] == 1 and ds["error"].values[0] > 100
    assert ds["t_switch"].values[0] == pytest.approx(1.30034, abs=1e-4)
