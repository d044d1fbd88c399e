"""The floquet step: multipliers by variational equations beside finite differences.

The end-to-end cases read the analysis smoke study's datasets (``analysis_smoke``,
tests/study/steps/conftest.py)."""
from __future__ import annotations

import numpy as np
import pytest

from studyhelpers import assert_written_as_declared, open_dataset


def test_floquet_multipliers_and_agreement(analysis_smoke):
    ds = open_dataset(analysis_smoke[0], "floquet.nc")
    assert list(ds["controller"].values) == ["open_loop", "search"]
    lam = ds["multipliers_real"].values + 1j * ds["multipliers_imag"].values
    lam_fd = ds["multipliers_fd_real"].values + 1j * ds["multipliers_fd_imag"].values
    assert np.all(ds["agreement"].values < 1e-7)            # var-eq vs finite differences
    np.testing.assert_allclose(np.abs(lam), np.abs(lam_fd), rtol=1e-6)
    assert np.all(ds["map_defect"].values < 1e-11)
    ol, se = 0, 1
    # the open-loop exact gait is unstable, its leading multiplier ~1.75
    assert ds["stable"].values[ol] == 0 and abs(lam[ol, 0]) == pytest.approx(1.748, abs=2e-3)
    np.testing.assert_array_equal(ds["fixed_point"].values[ol, 0], 0.0)
    assert ds["t_motor"].values[ol] == 0.0
    # the state-based controller: one neutral multiplier (energy), the others inside
    assert ds["stable"].values[se] == 1 and ds["neutral"].values[se] == 1
    assert np.min(np.abs(lam[se] - 1.0)) < 1e-7
    assert np.all(np.abs(lam[se][np.abs(lam[se] - 1.0) > 1e-6]) < 1.0)
    assert ds["t_motor"].values[se] > 0.0


def test_floquet_datasets_are_written_as_declared(analysis_smoke):
    assert_written_as_declared(analysis_smoke[0] / "floquet.nc", "floquet")
