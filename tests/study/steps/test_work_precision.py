"""The work_precision step: integrator timings (not bit-reproducible by nature).

The end-to-end cases read the analysis smoke study's datasets (``analysis_smoke``,
tests/study/steps/conftest.py)."""
from __future__ import annotations

import numpy as np

from studyhelpers import assert_written_as_declared, open_dataset


def test_work_precision_dataset_is_marked_not_reproducible(analysis_smoke):
    ds = open_dataset(analysis_smoke[0], "timing.nc")
    assert list(ds["method"].values) == ["dop853"] and list(ds["rtol"].values) == [1e-6, 1e-8]
    assert list(ds["scipy_method"].values) == ["DOP853"]
    assert int(ds.attrs["bit_reproducible"]) == 0 and "timings" in ds.attrs["reproducibility"]
    assert np.all(ds["time_per_gait"].values > 0)
    e = ds["error_value"].values[0]
    assert e[1] < e[0]                                     # tighter tolerance, smaller error
    assert np.all(ds["status_mismatch"].values == 0)


def test_work_precision_datasets_are_written_as_declared(analysis_smoke):
    assert_written_as_declared(analysis_smoke[0] / "timing.nc", "work_precision")


NO_GAIT = """\
schema_version: 1
name: no_gait
robot: seed2009
gait: {kind: horizontal, motor_torque: 0.6354, tick: 0.001}
integrator: {method: dop853, rtol: 1.0e-8, atol: 1.0e-10}
steps:
  - {name: wp, kind: work_precision, points: [[0.0, 0.0], [0.1, 0.2]], methods: [rk45],
     rtols: [1.0e-6], repeat: 1, scipy_methods: [RK45], scipy_rtols: [1.0e-6]}
"""


def test_points_without_a_gait_are_refused_in_one_line(tmp_path):
    """The step's points hold no gait to measure: the run says so in one line naming the step
    (no worker traceback) and exits 1; nothing is written."""
    from click.testing import CliRunner

    from monkeystudy.cli import app

    study = tmp_path / "no_gait.yaml"
    study.write_text(NO_GAIT)
    out = tmp_path / "out"
    res = CliRunner().invoke(app, ["run", str(study), "--out", str(out), "--workers", "1"])
    assert res.exit_code == 1, res.output
    assert "Traceback" not in res.output
    lines = [x for x in res.output.splitlines() if "run failed" in x]
    assert len(lines) == 1 and lines[0].startswith("monkeystudy: run failed: wp: no gait at "
                                                   "any of the 2 points"), res.output
    assert not list(out.glob("*.nc"))
