"""The tick_sweep step: the gait replayed per controller tick, cycles to the error bound,
the growth per cycle against the leading multiplier.

The end-to-end cases read the analysis smoke study's datasets (``analysis_smoke``,
tests/study/steps/conftest.py)."""
from __future__ import annotations

import numpy as np
import pytest

from monkeystudy.analysis.replay import cycles_to_bound, growth_per_cycle

from studyhelpers import assert_written_as_declared, open_dataset


def test_tick_sweep_exact_timing_lasts_longest(analysis_smoke):
    ds = open_dataset(analysis_smoke[0], "ticks.nc")
    fl = open_dataset(analysis_smoke[0], "floquet.nc")
    c = dict(zip(ds["tick"].values, ds["cycles_to_bound"].values))
    assert c[0.0] > c[0.001]                               # the tick only seeds the fall
    assert ds.sizes["cycle"] == 60 and list(ds["cycle"].values[:2]) == [1, 2]
    lead = float(ds.attrs["leading_multiplier"])
    lam = fl["multipliers_real"].values[0, 0] + 1j * fl["multipliers_imag"].values[0, 0]
    assert lead == pytest.approx(abs(lam), rel=1e-6)      # FD here, var-eq in floquet
    exact = int(np.flatnonzero(ds["tick"].values == 0.0)[0])
    assert float(ds["growth_per_cycle"][exact]) == pytest.approx(lead, rel=0.02)
    e = ds["error"].values[exact]
    k = int(ds["cycles_to_bound"][exact])
    assert e[k - 1] > 1e-2 and np.all(e[:k - 1] <= 1e-2)
    assert np.all(np.isnan(e[int(ds["cycles_completed"][exact]):]))


def test_tick_sweep_takes_the_multiplier_of_a_floquet_step(analysis_smoke):
    ds = open_dataset(analysis_smoke[0], "ticks_var.nc")
    fl = open_dataset(analysis_smoke[0], "floquet.nc")
    lam = fl["multipliers_real"].values[0, 0] + 1j * fl["multipliers_imag"].values[0, 0]
    assert float(ds.attrs["leading_multiplier"]) == abs(lam)
    assert "floquet step floquet" in ds.attrs["leading_multiplier_source"]


def test_growth_and_cycles_to_bound():
    e = (1e-9 * 1.5 ** np.arange(40)) ** 2
    assert growth_per_cycle(e) == pytest.approx(1.5, rel=1e-9)
    assert np.isnan(growth_per_cycle(np.array([1e-3, 1e-2])))
    assert cycles_to_bound(np.array([1e-5, 1e-3, 2e-2, 1.0]), 1e-2) == 3
    assert cycles_to_bound(np.array([1e-5, 1e-3]), 1e-2) == 2


def test_tick_sweep_datasets_are_written_as_declared(analysis_smoke):
    for name in ('ticks.nc', 'ticks_var.nc'):
        assert_written_as_declared(analysis_smoke[0] / name, "tick_sweep")
