"""The Butcher tableaux are scipy's, bit for bit (``kernel/tableaux.py`` vs
``scipy.integrate._ivp.rk`` and ``dop853_coefficients``): the step-for-step comparisons with
``solve_ivp`` in ``test_integrate.py`` rely on it."""
import numpy as np
import pytest
from scipy.integrate._ivp import dop853_coefficients as dc
from scipy.integrate._ivp import rk

from monkeystudy.kernel import tableaux as tb

pytestmark = pytest.mark.nojit


def _same(ours, theirs):
    ours = np.asarray(ours)
    theirs = np.asarray(theirs)
    assert ours.dtype == np.float64
    assert ours.shape == theirs.shape
    # bit for bit (tobytes also distinguishes -0.0 from 0.0)
    assert ours.tobytes() == theirs.astype(np.float64).tobytes()


@pytest.mark.parametrize("name", ["A", "B", "C", "E", "P"])
def test_rk45(name):
    _same(getattr(tb, f"RK45_{name}"), getattr(rk.RK45, name))


def test_rk45_sizes_and_orders():
    assert tb.RK45_N_STAGES == rk.RK45.n_stages
    assert tb.RK45_ORDER == rk.RK45.order
    assert tb.RK45_ERROR_ORDER == rk.RK45.error_estimator_order


@pytest.mark.parametrize("name", ["A", "B", "C", "E3", "E5", "D"])
def test_dop853(name):
    _same(getattr(tb, f"DOP853_{name}"), getattr(dc, name))


def test_dop853_solver_views():
    """scipy's solver slices the full table: our full table gives the same slices."""
    n = tb.DOP853_N_STAGES
    _same(tb.DOP853_A[:n, :n], rk.DOP853.A)
    _same(tb.DOP853_A[n + 1:], rk.DOP853.A_EXTRA)
    _same(tb.DOP853_C[:n], rk.DOP853.C)
    _same(tb.DOP853_C[n + 1:], rk.DOP853.C_EXTRA)
    _same(tb.DOP853_B, rk.DOP853.B)
    _same(tb.DOP853_E3, rk.DOP853.E3)
    _same(tb.DOP853_E5, rk.DOP853.E5)
    assert tb.DOP853_N_STAGES == dc.N_STAGES == rk.DOP853.n_stages
    assert tb.DOP853_N_STAGES_EXTENDED == dc.N_STAGES_EXTENDED
    assert tb.DOP853_INTERPOLATOR_POWER == dc.INTERPOLATOR_POWER
    assert tb.DOP853_ORDER == rk.DOP853.order
    assert tb.DOP853_ERROR_ORDER == rk.DOP853.error_estimator_order


def test_consistency_conditions():
    """Row sums of A are the nodes; weights sum to one (a sanity check of the tables' roles)."""
    for A, B, C in ((tb.RK45_A, tb.RK45_B, tb.RK45_C),
                    (tb.DOP853_A[:tb.DOP853_N_STAGES, :tb.DOP853_N_STAGES], tb.DOP853_B,
                     tb.DOP853_C[:tb.DOP853_N_STAGES])):
        np.testing.assert_allclose(A.sum(axis=1), C, atol=1e-14)
        assert B.sum() == pytest.approx(1.0, abs=1e-14)
