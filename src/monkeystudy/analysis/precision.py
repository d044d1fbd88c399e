"""Work-precision measurements: run time against error for every integrator.

For each method and relative tolerance, the horizontal gait is evaluated at a set of points;
the wall time per gait (best of ``repeat`` runs, so that a noisy machine inflates nothing) and
the error of the results (the gait error value and the three event times) are recorded against
a reference computed at a much tighter tolerance by a *different* method (the kernel's RK45 at
rtol 1e-13, itself checked against scipy's DOP853). scipy ``solve_ivp`` (RK45, DOP853, LSODA,
with events, hand-written scalar right-hand side) runs the same gaits on a subset of points,
timed in the same process, so ratios between the two are measured side by side. Only warmed
calls are timed: each integrator and each scipy method runs once untimed first (a kernel's
first call loads it, compiling it or reading it from the cache; scipy's first call imports its
solvers), whatever ``repeat`` is.
"""
from __future__ import annotations

import math
import time

import numpy as np

from ..controllers import METHODS, HorizontalSearch, Integrator, kernel_method, settings_vector
from ..kernel.gait import (
    N_RESULT, R_ERROR, R_NFEV, R_STATUS, R_T_END, R_T_MOTOR, R_T_SWITCH, horizontal_gait_batch,
)
from ..kernel.layout import PHASE_SWING
from ..reference.scipy_gait import ScipyGait
from ..robot import SEED2009_TORQUE
from ..simulation import RobotLike, as_robot

def best_of(fn, repeat: int = 5) -> float:
    """Smallest wall time of ``repeat`` calls [s] (the least disturbed one)."""
    best = math.inf
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
    return best


def warmed_best_of(fn, repeat: int = 5) -> float:
    """Smallest wall time of ``repeat`` calls [s] after one untimed call: the first call of a
    kernel loads it (a compile, or a read from the cache), which is not the kernel's time."""
    fn()
    return best_of(fn, repeat)


class NoGaitToMeasure(ValueError):
    """None of the points has a gait whose error can be measured (a work-precision
    measurement would be errors of NaN)."""


def kernel_gaits(par, prog, settings, pts, floor) -> np.ndarray:
    """The kernel's batch gait results ``[n, N_RESULT]`` at ``pts`` (no Python per gait)."""
    out = np.empty((pts.shape[0], N_RESULT))
    horizontal_gait_batch(kernel_method(settings, prog, PHASE_SWING), par, prog, settings, pts,
                          floor, True, out)
    return out


#: the study's tolerance ladder
RTOLS = (1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10, 1e-11, 1e-12, 1e-13)
#: reference: a different method at a much tighter tolerance
REFERENCE = ("rk45", 1e-13)
#: with ``first_swing_only``, kept gaits end before this time [s]
FIRST_SWING_END = 1.2


def _plural(n: int, noun: str) -> str:
    """``1 point``, ``2 points``."""
    return f"{n} {noun}{'' if n == 1 else 's'}"


def _errors(out, ref):
    """Max |difference| over points of the gait error and of the event times."""
    ok = (out[:, R_STATUS] == 0) & (ref[:, R_STATUS] == 0)
    if not np.any(ok):
        return math.nan, math.nan
    de = np.abs(out[ok, R_ERROR] - ref[ok, R_ERROR]).max()
    cols = [R_T_SWITCH, R_T_MOTOR, R_T_END]
    dt = np.abs(out[ok][:, cols] - ref[ok][:, cols]).max()
    return float(de), float(dt)


def work_precision(points, *, robot: RobotLike = "seed2009", torque: float = SEED2009_TORQUE,
                   methods=tuple(METHODS), rtols=RTOLS, atol_ratio: float = 1e-2,
                   repeat: int = 3, scipy_methods=("RK45", "DOP853", "LSODA"),
                   scipy_rtols=(1e-6, 1e-8, 1e-10), scipy_points: int = 4,
                   first_swing_only: bool = True) -> dict:
    """Measure time per gait [s] and errors for each (method, rtol); plain arrays out.

    ``methods`` are kernel pairs (``METHODS``), each optionally with ``+pi`` for the PI
    step-size controller (``"dop853+pi"``); without it, scipy's controller.

    Returns ``{"methods", "rtols", "time", "nfev", "error_value", "error_times",
    "status_mismatch", "scipy_methods", "scipy_rtols", "scipy_time", "scipy_error_value",
    "scipy_error_times", "kernel_time_same_points"}``. Errors are NaN where no point had a
    gait in both runs.

    Raises :class:`NoGaitToMeasure` when no point has a gait (with ``first_swing_only``: a
    well-conditioned one), before anything is timed.
    """
    robot = as_robot(robot)
    par = robot.params()
    floor = robot.swap_energy_floor()
    pts = np.ascontiguousarray(points, dtype=float).reshape(-1, 2)
    prog, _ = HorizontalSearch(torque).program()

    def settings(method, rtol):
        # "dop853+pi": the pair with the PI step-size controller (Integrator.controller)
        pair, _, controller = method.partition("+")
        return settings_vector(Integrator(method=pair, rtol=rtol, atol=rtol * atol_ratio,
                                          max_steps=5_000_000,
                                          controller=controller or "scipy"))

    ref = kernel_gaits(par, prog, settings(*REFERENCE), pts, floor)
    n_gaits = int(np.sum(ref[:, R_STATUS] == 0))
    if n_gaits == 0:
        raise NoGaitToMeasure(f"no gait at any of the {_plural(len(pts), 'point')} (reference "
                              f"{REFERENCE[0]} rtol {REFERENCE[1]:g}): there is no error to "
                              "measure; choose points near a gait (a grid step's map shows "
                              "where)")
    if first_swing_only:
        # a swap on a later swing follows a chaotic double-pendulum phase: its results are
        # ill-conditioned (errors amplified ~1e3 and more), which measures the problem, not
        # the integrator; keep gaits that swap on the first swing and end before 1.2 s
        keep = (ref[:, R_STATUS] == 0) & (ref[:, R_T_END] < FIRST_SWING_END)
        if not np.any(keep):
            raise NoGaitToMeasure(
                f"no well-conditioned gait among the {_plural(len(pts), 'point')}: "
                f"{_plural(n_gaits, 'gait')}, none swapping on the first swing and ending "
                f"before {FIRST_SWING_END:g} s (first_swing_only: true); choose points near "
                "such a gait, or set first_swing_only: false")
        pts, ref = pts[keep], ref[keep]
    n_m, n_r = len(methods), len(rtols)
    t = np.full((n_m, n_r), np.nan)
    nfev = np.full((n_m, n_r), np.nan)
    e_val = np.full((n_m, n_r), np.nan)
    e_t = np.full((n_m, n_r), np.nan)
    mismatch = np.zeros((n_m, n_r), np.int32)
    for i, m in enumerate(methods):
        for j, rtol in enumerate(rtols):
            st = settings(m, rtol)
            out = kernel_gaits(par, prog, st, pts, floor)       # untimed: loads the kernel
            t[i, j] = best_of(lambda: kernel_gaits(par, prog, st, pts, floor), repeat) / len(pts)
            nfev[i, j] = out[:, R_NFEV].mean()
            e_val[i, j], e_t[i, j] = _errors(out, ref)
            mismatch[i, j] = int(np.sum(out[:, R_STATUS] != ref[:, R_STATUS]))

    sub = pts[:scipy_points]
    ref_sub = ref[:scipy_points]
    sg = ScipyGait(robot, torque, "scalar")
    for m in scipy_methods:
        # untimed: the first solve_ivp call of a process imports and sets up scipy's solvers
        sg.gait(sub[0, 0], sub[0, 1], scipy_rtols[0], scipy_rtols[0] * atol_ratio, method=m)
    s_t = np.full((len(scipy_methods), len(scipy_rtols)), np.nan)
    s_ev = np.full_like(s_t, np.nan)
    s_et = np.full_like(s_t, np.nan)
    k_t = np.full(len(scipy_rtols), np.nan)
    for j, rtol in enumerate(scipy_rtols):
        st = settings("dop853", rtol)
        # warmed: dop853 may not be among ``methods`` (its kernel not loaded yet)
        k_t[j] = warmed_best_of(lambda: kernel_gaits(par, prog, st, sub, floor),
                                repeat) / len(sub)
        for i, m in enumerate(scipy_methods):
            t0 = time.perf_counter()
            res = [sg.gait(a, b, rtol, rtol * atol_ratio, method=m) for a, b in sub]
            s_t[i, j] = (time.perf_counter() - t0) / len(sub)
            arr = np.full((len(sub), ref.shape[1]), np.nan)
            for k, r in enumerate(res):
                arr[k, R_ERROR], arr[k, R_T_SWITCH], arr[k, R_T_MOTOR], arr[k, R_T_END] = r[:4]
                arr[k, R_STATUS] = 0 if math.isfinite(r[0]) else 1
            s_ev[i, j], s_et[i, j] = _errors(arr, ref_sub)
    return {"methods": list(methods), "rtols": np.asarray(rtols, float), "time": t,
            "nfev": nfev, "error_value": e_val, "error_times": e_t,
            "status_mismatch": mismatch, "scipy_methods": list(scipy_methods),
            "scipy_rtols": np.asarray(scipy_rtols, float), "scipy_time": s_t,
            "scipy_error_value": s_ev, "scipy_error_times": s_et,
            "kernel_time_same_points": k_t, "n_points": len(pts),
            "reference": f"{REFERENCE[0]} rtol {REFERENCE[1]:g}"}
