"""The continuation step: a family of gaits followed in a robot parameter.

The end-to-end cases read the analysis smoke study's datasets (``analysis_smoke``,
tests/study/steps/conftest.py)."""
from __future__ import annotations

import json

import numpy as np

from studyhelpers import assert_written_as_declared, open_dataset


def test_continuation_follows_the_family(analysis_smoke):
    ds = open_dataset(analysis_smoke[0], "family.nc")
    sh = open_dataset(analysis_smoke[0], "shoot.nc")
    g = int(sh.attrs["best_solution"])
    assert ds.sizes["point"] == 4 and ds.attrs["parameter"] == "com"
    assert ds["parameter_value"].values[0] == 0.543754     # seed2009's link 1 CG
    assert ds["dtheta1"].values[0] == sh["dtheta1"].values[g]
    assert np.all(ds["residual"].values < 1e-12)
    assert np.all(np.diff(ds["parameter_value"].values) > 0)
    assert json.loads(ds.attrs["folds"]) == [] and json.loads(ds.attrs["period_doublings"]) == []


def test_continuation_datasets_are_written_as_declared(analysis_smoke):
    assert_written_as_declared(analysis_smoke[0] / "family.nc", "continuation")
