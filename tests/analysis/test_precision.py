"""Work-precision measurements (monkeystudy.analysis.precision): what is timed, and what is
refused.

The timing protocol is checked on a simulated clock: the kernel and scipy are replaced by
stand-ins that advance it by a load time on the first call of each integrator and by a
run time on every later call, so the measured times say exactly which calls were timed.
"""
from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from monkeystudy.analysis import precision as P
from monkeystudy.kernel.gait import N_RESULT, R_ERROR, R_NFEV, R_STATUS, R_T_END, R_T_MOTOR, \
    R_T_SWITCH
from monkeystudy.kernel.layout import C_METHOD, C_RTOL

#: simulated seconds: the first call of a kernel integrator (load: compile or cache read), a
#: later call per point, scipy's first call of a method (imports), a later call per gait
KERNEL_LOAD, KERNEL_RUN, SCIPY_LOAD, SCIPY_RUN = 1000.0, 1.0, 5000.0, 50.0


class SimulatedClock:
    def __init__(self):
        self.now = 0.0
        self.loaded: set = set()

    def perf_counter(self) -> float:
        return self.now

    def kernel_gaits(self, par, prog, settings, pts, floor):
        """Gaits at every point that swap on the first swing; costs the clock a load on the
        integrator's first call."""
        method = float(settings[C_METHOD])
        self.now += KERNEL_RUN * len(pts) + (0.0 if method in self.loaded else KERNEL_LOAD)
        self.loaded.add(method)
        out = np.zeros((len(pts), N_RESULT))
        out[:, R_ERROR] = 1e-3 + settings[C_RTOL]
        out[:, R_STATUS] = 0
        out[:, R_T_SWITCH], out[:, R_T_MOTOR], out[:, R_T_END] = 0.43, 0.02, 0.9
        out[:, R_NFEV] = 100
        return out

    def scipy_gait(self, robot, torque, rhs):
        clock = self

        def gait(d1, d2, rtol, atol, method="DOP853"):
            clock.now += SCIPY_RUN + (0.0 if ("scipy", method) in clock.loaded else SCIPY_LOAD)
            clock.loaded.add(("scipy", method))
            return (1e-3 + rtol, 0.43, 0.02, 0.9, 100)
        return SimpleNamespace(gait=gait)


@pytest.fixture
def clock(monkeypatch):
    c = SimulatedClock()
    monkeypatch.setattr(P, "time", SimpleNamespace(perf_counter=c.perf_counter))
    monkeypatch.setattr(P, "kernel_gaits", c.kernel_gaits)
    monkeypatch.setattr(P, "ScipyGait", c.scipy_gait)
    return c


@pytest.mark.parametrize("repeat", [1, 3])
def test_only_warmed_calls_are_timed(clock, repeat):
    """With one repetition as with several, no time includes loading a kernel or scipy's
    first call: the kernel's dop853 on the scipy points (the ratio's denominator) is timed
    after its own untimed first call even when dop853 is not among the methods."""
    pts = [[0.9, 10.9], [1.0, 11.0], [1.1, 11.2]]
    r = P.work_precision(pts, methods=("rk45",), rtols=(1e-6, 1e-8), repeat=repeat,
                         scipy_methods=("RK45", "LSODA"), scipy_rtols=(1e-6, 1e-8),
                         scipy_points=2)
    assert r["n_points"] == 3
    np.testing.assert_array_equal(r["time"], KERNEL_RUN)
    np.testing.assert_array_equal(r["kernel_time_same_points"], KERNEL_RUN)
    np.testing.assert_array_equal(r["scipy_time"], SCIPY_RUN)


def test_points_without_a_gait_are_refused_in_one_sentence(monkeypatch):
    """No gait at all, or none well-conditioned: NoGaitToMeasure saying why and what to do,
    before anything is timed (a dataset of NaN errors would measure nothing)."""
    def results(status, t_end):
        def kernel_gaits(par, prog, settings, pts, floor):
            out = np.zeros((len(pts), N_RESULT))
            out[:, R_STATUS], out[:, R_T_END] = status, t_end
            return out
        return kernel_gaits

    monkeypatch.setattr(P, "kernel_gaits", results(1, np.nan))
    with pytest.raises(P.NoGaitToMeasure, match=r"^no gait at any of the 2 points .*choose "
                                                r"points near a gait"):
        P.work_precision([[0.0, 0.0], [0.1, 0.2]], first_swing_only=False)
    monkeypatch.setattr(P, "kernel_gaits", results(0, 2.5))
    with pytest.raises(P.NoGaitToMeasure, match=r"^no well-conditioned gait among the 2 "
                                                r"points: 2 gaits, none .*first_swing_only: "
                                                r"false$"):
        P.work_precision([[0.0, 0.0], [0.1, 0.2]])
