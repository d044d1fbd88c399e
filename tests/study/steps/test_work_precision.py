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
