"""The compiled sine and cosine (:mod:`monkeystudy.kernel.trig`) against 120-bit values.

The error is measured in units in the last place of the correctly rounded result, over the
angles a gait sees, wide angles, and arguments next to multiples of pi/2 (where the reduction
cancels and the third piece of pi/2 decides the result).
"""
import math

import mpmath
import numpy as np
import pytest
from numba import njit

from monkeystudy.kernel import trig
from monkeystudy.kernel.dynamics import angle_trig, swing_accel_trig
from monkeystudy.kernel.dynamics import trig_of
from monkeystudy.kernel.layout import PHASE_SWING, T_C1, T_C12, T_C2, T_S1, T_S12, T_S2

#: fdlibm's kernels are within 1 ulp; the reduction here drops fdlibm's tail (one double for
#: the reduced argument), which costs up to ~0.3 ulp more (measured 1.26 at worst)
MAX_ULP = 1.5


def _ulp_errors(x, values, fn):
    mpmath.mp.prec = 120
    out = np.empty(x.size)
    for i, (xi, vi) in enumerate(zip(x, values)):
        ref = fn(mpmath.mpf(float(xi)))
        out[i] = float(abs(mpmath.mpf(float(vi)) - ref)) / np.spacing(abs(float(ref)))
    return out


def _arguments():
    rng = np.random.default_rng(7)
    near = (np.arange(-64, 65) * (np.pi / 2))[:, None] * np.ones(5)
    near[:, 1] = np.nextafter(near[:, 0], np.inf)
    near[:, 2] = np.nextafter(near[:, 0], -np.inf)
    near[:, 3] += 1e-9
    near[:, 4] -= 1e-13
    return np.concatenate([
        rng.uniform(-np.pi, np.pi, 3000),      # the angles of a swing
        rng.uniform(-200.0, 200.0, 2000),      # long runs wind theta up
        rng.uniform(-1e5, 1e5, 500),           # up to the reduction bound
        near.ravel(),
        [0.0, -0.0, 1e-300, -1e-20, 5e-9, np.pi / 4, -np.pi / 4, 0.78539816, 0.7853982],
    ])


def test_sin_and_cos_within_one_and_a_half_ulp():
    x = _arguments()
    s = np.empty_like(x)
    c = np.empty_like(x)
    trig.sincos_array(x, s, c)
    es = _ulp_errors(x, s, mpmath.sin)
    ec = _ulp_errors(x, c, mpmath.cos)
    assert es.max() <= MAX_ULP, (x[es.argmax()], es.max())
    assert ec.max() <= MAX_ULP, (x[ec.argmax()], ec.max())
    # and mostly correctly rounded, like the C library (which this replaces)
    assert np.mean(es <= 0.5) > 0.8 and np.mean(ec <= 0.5) > 0.8


def test_third_piece_of_pi_over_two_is_needed_next_to_multiples_of_pi_over_two():
    """With pi/2 in two pieces, sin(58 pi/2 rounded) is off by ~450 ulp: the test of the
    reduction is the arguments next to multiples of pi/2 (here with the third piece)."""
    x = np.array([-58 * (np.pi / 2), 64 * (np.pi / 2), np.nextafter(40 * (np.pi / 2), 0.0)])
    s = np.empty_like(x)
    c = np.empty_like(x)
    trig.sincos_array(x, s, c)
    assert _ulp_errors(x, s, mpmath.sin).max() <= MAX_ULP
    assert _ulp_errors(x, c, mpmath.cos).max() <= MAX_ULP
    # the dropped term is ~k * 1.5e-33, far below 1 ulp of sin(x) except where sin(x) ~ 1e-16
    assert abs(trig.PIO2_3) * 58 > 0.5 * np.spacing(abs(s[0]))


def test_signs_zero_and_exact_values():
    x = np.array([0.0, -0.0, 5e-324, -1e-20])
    s = np.empty_like(x)
    c = np.empty_like(x)
    trig.sincos_array(x, s, c)
    assert np.array_equal(s, x) and np.all(c == 1.0)
    assert math.copysign(1.0, s[1]) == -1.0  # sin(-0) = -0


@pytest.mark.parametrize("x", [1e5, -3e7, 1e300, np.inf, -np.inf, np.nan])
def test_beyond_the_bound_the_c_library(x):
    s = np.empty(1)
    c = np.empty(1)
    trig.sincos_array(np.array([x]), s, c)
    with np.errstate(invalid="ignore"):
        ref_s, ref_c = np.sin(x), np.cos(x)
    assert np.array_equal(s, [ref_s], equal_nan=True)
    assert np.array_equal(c, [ref_c], equal_nan=True)


def test_complex_arguments_pass_through_numpy():
    """The complex-step derivatives of :mod:`.variational` need the complex sine and cosine."""
    @njit
    def f(z):
        return trig.sincos(z)

    z = 0.7 + 1e-30j
    s, c = f(z)
    assert s == np.sin(z) and c == np.cos(z)
    assert s.imag == pytest.approx(1e-30 * np.cos(0.7), rel=1e-15)


def test_same_bits_in_a_contracting_step_and_in_the_guards():
    """The step's last stage (compiled with ``fastmath={'contract'}``) and the guards'
    :func:`.dynamics.trig_of` (strict) see the same sines and cosines, bit for bit: every
    product that feeds an addition is an explicit fused multiply-add."""
    from monkeystudy import Robot
    from monkeystudy.kernel.rk_explicit import FM

    par = Robot.preset("seed2009").params()[0]  # the row of the unflipped robot
    fmode = np.ones(2)

    @njit(fastmath=FM)
    def contracting(par, fmode, th1, th2):
        return swing_accel_trig(par, 0.3, fmode, th1, th2, 0.4, -2.0)[2:]

    @njit
    def strict(th1, th2):
        return angle_trig(th1, th2)

    rng = np.random.default_rng(3)
    trig_buf = np.empty(8)
    for th1, th2 in rng.uniform(-20.0, 20.0, (2000, 2)):
        a = contracting(par, fmode, th1, th2)
        b = strict(th1, th2)
        trig_of(PHASE_SWING, np.array([th1, th2, 0.0, 0.0]), trig_buf)
        c = tuple(trig_buf[[T_S1, T_C1, T_S2, T_C2, T_S12, T_C12]])
        assert a == b == c


def test_pieces_of_pi_over_two_and_two_over_pi():
    """Each piece of pi/2 is the double nearest what the previous ones leave (300-bit pi)."""
    mpmath.mp.prec = 300
    rest = mpmath.pi / 2
    for piece in (trig.PIO2_1, trig.PIO2_2, trig.PIO2_3):
        assert piece == float(rest)
        rest -= mpmath.mpf(piece)
    assert abs(rest) < 1e-49
    assert trig.INV_PIO2 == float(2 / mpmath.pi)
