"""Nelder-Mead refinement of a gait's start, every iterate recorded (the study's fminsearch).

The 2009 study refined its error-map minima with MATLAB's ``fminsearch``; here it is
:func:`scipy.optimize.minimize` with ``method="Nelder-Mead"``, fminsearch's tolerances and its
initial simplex (+5 % per coordinate). The objective is any gait evaluation
``gait(x) -> {"error", "status", ...}`` at ``x = (dtheta1, dtheta2)`` [rad s-1]; where the gait
fails (status not ok) the objective is a finite ``penalty``, so the simplex retreats instead
of stopping on NaN.
"""
from __future__ import annotations

import math
from typing import Any, Callable

import numpy as np

from ..kernel import layout as L

#: MATLAB ``fminsearch``'s TolX and TolFun, the study's defaults
FMINSEARCH_TOL = 1e-4

#: objective value of an iterate whose gait fails (status not ok) [1]
DEFAULT_PENALTY = 1.0e6


def refine_gait(gait: Callable[[tuple[float, float]], dict[str, Any]],
                start: tuple[float, float], *, xatol: float = FMINSEARCH_TOL,
                fatol: float = FMINSEARCH_TOL, maxiter: int | None = None,
                maxfev: int | None = None, penalty: float = DEFAULT_PENALTY) -> dict[str, Any]:
    """Nelder-Mead (scipy, fminsearch's initial simplex) on the gait error from ``start``.

    Parameters
    ----------
    gait : callable
        ``gait((dtheta1, dtheta2)) -> dict`` with at least ``error`` [1] and ``status``; each
        distinct point is evaluated once (later calls are served from a cache).
    start : (float, float)
        ``(dtheta1, dtheta2)`` [rad s-1].
    xatol, fatol : float
        Absolute tolerances on the point [rad s-1] and on the error [1].
    maxiter, maxfev : int, optional
        Iteration and evaluation limits (scipy's defaults: 200 per variable).
    penalty : float
        Objective value where the gait fails [1].

    Returns
    -------
    dict
        The keys of ``gait`` at the result, and ``x``, ``error`` (NaN unless ok),
        ``iterate_x [k, 2]``, ``iterate_error [k]`` (NaN where the gait failed),
        ``iterate_nfev [k]`` (objective evaluations up to that iterate, counted as scipy
        counts them), ``nit``, ``nfev``, ``converged`` (1: met both tolerances), ``message``,
        ``start``. Iteration 0 is the start; iteration k >= 1 is the best vertex after the
        k-th simplex update (scipy's ``nit`` also counts the initial simplex, so it equals the
        number of recorded iterates unless the evaluation limit cut an update short).
    """
    # scipy.optimize loads in ~0.3 s: only a task that refines pays it
    from scipy.optimize import minimize

    cache: dict[tuple[float, float], dict[str, Any]] = {}
    calls = 0

    def evaluated(x) -> dict[str, Any]:
        key = (float(x[0]), float(x[1]))
        if key not in cache:
            cache[key] = gait(key)
        return cache[key]

    def objective(x) -> float:
        nonlocal calls
        calls += 1
        g = evaluated(x)
        if g["status"] != L.ST_OK or not math.isfinite(g["error"]):
            return float(penalty)
        return g["error"]

    x0 = np.array(start, dtype=np.float64)
    g0 = evaluated(x0)
    it_x = [x0.copy()]
    it_e = [g0["error"] if g0["status"] == L.ST_OK else math.nan]
    it_n = [1]

    def callback(intermediate_result):
        x = np.asarray(intermediate_result.x, dtype=np.float64)
        g = evaluated(x)
        it_x.append(x.copy())
        it_e.append(g["error"] if g["status"] == L.ST_OK else math.nan)
        it_n.append(calls)

    options: dict[str, Any] = {"xatol": float(xatol), "fatol": float(fatol)}
    if maxiter is not None:
        options["maxiter"] = int(maxiter)
    if maxfev is not None:
        options["maxfev"] = int(maxfev)
    res = minimize(objective, x0, method="Nelder-Mead", options=options, callback=callback)
    x = np.asarray(res.x, dtype=np.float64)
    g = evaluated(x)
    return {
        **g, "x": x, "error": g["error"] if g["status"] == L.ST_OK else math.nan,
        "iterate_x": np.array(it_x), "iterate_error": np.array(it_e),
        "iterate_nfev": np.array(it_n, dtype=np.int32), "nit": int(res.nit),
        "nfev": int(res.nfev), "converged": int(bool(res.success)), "message": str(res.message),
        "start": x0,
    }
