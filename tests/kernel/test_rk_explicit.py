"""The generated straight-line steps (``kernel/rk_explicit.py``) and what the hot loop takes
from them.

* The file is what ``tools/gen_rk_kernels.py`` generates from the tableaux (regenerate after
  changing either).
* The sines and cosines a step leaves for the guards (``trig``) are bit for bit those of the
  new point's angles, so a guard evaluated from them (``guard_trig``, and the hot loop's
  ``guard_and_rate_step``) equals :func:`guard` there exactly (the event logic compares signs of
  guards evaluated both ways).
* DOP853's controller power ``en ** (-1/8)``, taken from the squared norm by
  :func:`.roots.inv_root16`, is within two ulps of scipy's ``pow`` of the norm.
"""
import importlib.util
import math
from pathlib import Path

import numpy as np
import pytest

from monkeystudy.kernel import dynamics as dyn
from monkeystudy.kernel.dynamics import trig_of
from monkeystudy.kernel.events import (
    guard, guard_and_rate_step, guard_rate, guard_rate_trig, guard_trig,
)
from monkeystudy.kernel.integrate import error_power_sq, rk_step
from monkeystudy.kernel.layout import (
    G_COORD, G_ENERGY, G_ENERGY_RESTORED, G_FREE_END_HEIGHT, G_FREE_END_Y, METHOD_DOP853,
    METHOD_RK45, N_TRIG, PHASE_FLIGHT, PHASE_SWING,
)

from .helpers import ROBOTS

pytestmark = pytest.mark.nojit

ROOT = Path(__file__).resolve().parents[2]
FM = np.array([1.0, 1.0])


def test_generated_file_is_up_to_date():
    spec = importlib.util.spec_from_file_location("gen_rk_kernels",
                                                  ROOT / "tools" / "gen_rk_kernels.py")
    gen = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(gen)
    have = (ROOT / "src" / "monkeystudy" / "kernel" / "rk_explicit.py").read_text()
    assert have == gen.generate(), "run: python tools/gen_rk_kernels.py"


def _states(rng, phase, k=40):
    n = 4 if phase == PHASE_SWING else 8
    if phase == PHASE_SWING:
        lo = [-4.0, -4.0, -12.0, -12.0]
    else:
        lo = [-1.0, -1.0, -4.0, -4.0, -3.0, -3.0, -12.0, -12.0]
    lo = np.array(lo)
    return [rng.uniform(lo, -lo) for _ in range(k)], n


@pytest.mark.parametrize("method", [METHOD_DOP853, METHOD_RK45], ids=["dop853", "rk45"])
@pytest.mark.parametrize("phase", [PHASE_SWING, PHASE_FLIGHT], ids=["swing", "flight"])
def test_step_trig_is_the_new_points_and_guards_agree_bit_for_bit(method, phase):
    rng = np.random.default_rng(5)
    p = ROBOTS["asymmetric"].params()[0]
    pivot = np.array([0.3, -0.2])
    kinds = [(G_FREE_END_HEIGHT, 0, 0.05), (G_FREE_END_Y, 0, -0.4), (G_ENERGY, 0, 1.5),
             (G_ENERGY_RESTORED, 0, 0.2), (G_COORD, 2, 0.1)]
    states, n = _states(rng, phase)
    for y0 in states:
        y = np.zeros(8)
        y[:n] = y0
        f = np.zeros(8)
        dyn.rhs(phase, p, 0.3, FM, y, f)
        K = np.zeros((16, 8))
        trig = np.full(8, np.nan)
        y_new = np.zeros(8)
        f_new = np.zeros(8)
        rk_step(method, phase, p, 0.3, FM, y, f, 1e-3, n, K, trig, y_new, f_new)
        want = np.zeros(N_TRIG)
        trig_of(phase, y_new, want)
        assert np.array_equal(trig[:N_TRIG], want)
        for kind, index, value in kinds:
            g = guard(kind, index, value, phase, p, 0.3, FM, y_new, pivot, -2.0)
            gt = guard_trig(kind, index, value, phase, p, 0.3, FM, y_new, pivot, -2.0, trig)
            assert g == gt, (kind, g, gt)
            work = np.zeros(8)
            r = guard_rate(kind, index, phase, p, 0.3, FM, y_new, pivot, work)
            rt = guard_rate_trig(kind, index, phase, p, 0.3, FM, y_new, pivot, work, trig)
            assert r == rt, (kind, r, rt)
            gs, rs = guard_and_rate_step(kind, index, value, phase, p, 0.3, FM, y_new, pivot,
                                         -2.0, trig)
            assert (gs, rs) == (g, r), (kind, gs, rs, g, r)


def test_energy_guard_is_total_energy8_exactly():
    """The energy guard (from a step's trig) and the latched reference (``total_energy8``) use
    the same arithmetic: a collisionless swap restores the energy to the last bit."""
    rng = np.random.default_rng(9)
    p = ROBOTS["seed2009"].params()[0]
    for phase in (PHASE_SWING, PHASE_FLIGHT):
        states, n = _states(rng, phase, 20)
        for y0 in states:
            y = np.zeros(8)
            y[:n] = y0
            pivot = np.array([0.1, 0.4])
            s8 = np.zeros(8)
            if phase == PHASE_SWING:
                s8[[0, 1, 2, 3, 6, 7]] = [pivot[0], pivot[1], y[0], y[1], y[2], y[3]]
            else:
                s8[:] = y
            trig = np.zeros(N_TRIG)
            trig_of(phase, y, trig)
            g = guard_trig(G_ENERGY, 0, 0.0, phase, p, 0.0, FM, y, pivot, 0.0, trig)
            assert g == dyn.total_energy8(p, s8)


def test_dop853_error_power_is_scipys_pow_to_two_ulps():
    """The controller's factor from ``en_sq`` against scipy's ``en ** (-1/8)`` of the norm
    itself (``en`` is the rounded square root of ``en_sq`` here, as the norm scipy computes is
    rounded): inv_root16's ~1 ulp plus pow's 0.5 plus the norm's rounding, scaled by 1/8."""
    rng = np.random.default_rng(3)
    values = np.concatenate([10.0 ** rng.uniform(-300, 300, 2000), rng.uniform(0.0, 1.0, 2000),
                             [1e-310, 1.0, 0.5, 2.0, np.nextafter(1.0, 0.0)]])
    for en_sq in values:
        got = error_power_sq(METHOD_DOP853, en_sq)
        want = math.sqrt(en_sq) ** (-1.0 / 8.0)
        assert abs(got - want) <= 2 * math.ulp(want), (en_sq, got, want)
    assert error_power_sq(METHOD_DOP853, 0.0) == math.inf
    assert error_power_sq(METHOD_RK45, 0.09) == 0.09 ** (-1.0 / 10.0)
