"""Task functions of the analysis steps (shoot, floquet, tick_sweep, basin, continuation,
work_precision, stress): plain values in, plain numpy arrays out.

Like :mod:`monkeystudy.study.drivers`, everything here runs on a worker, lives in an importable
module, takes a :class:`~monkeystudy.study.drivers.GaitSpec` and plain values, and never
touches files, xarray or the study models. The computations themselves are those of
:mod:`monkeystudy.analysis`, :mod:`monkeystudy.precision` and :mod:`monkeystudy.stress`; this
module only chooses their arguments the way docs/datasets.md ("Analysis steps") describes, and
flattens their results.

Gaits passed between steps are dicts ``{dtheta1, dtheta2 [rad s-1], t_switch, t_motor, t_end
[s], error [1], method (0 gauss_newton, 1 grazing)}`` read from a shoot dataset. The motor
torque of a replay is 0 when ``t_motor`` is 0 (a collisionless, motorless gait), else the
study's torque (:func:`replay_torque`).
"""
from __future__ import annotations

import dataclasses
import math
from typing import Any

import numpy as np

from ..kernel import layout as L
from .drivers import GaitSpec, _unpack, spec_sequence

#: shoot ``method`` flag values (dataset variable ``method``)
METHOD_GAUSS_NEWTON, METHOD_GRAZING = 0, 1
METHOD_NAMES = ("gauss_newton", "grazing")

#: multipliers within this distance of 1 are neutral (excluded from ``stable``)
NEUTRAL_TOL = 1e-6

#: the window of sqrt(error) [1] in which the growth per cycle is fitted (linear regime, above
#: round-off)
GROWTH_WINDOW = (1e-10, 1e-4)


def replay_torque(spec: GaitSpec, gait: dict) -> float:
    """Motor torque [N m] of an open-loop replay of ``gait``: 0 if it has no motor phase."""
    return 0.0 if float(gait["t_motor"]) == 0.0 else float(spec["torque"])


def sequence_torque(gait) -> float:
    """A sequence gait's reference motor torque [N m] (0 when it never runs its motor)."""
    from ..continuation import motor_torque
    try:
        return motor_torque(gait)
    except ValueError:
        return 0.0


def _norm_or_nan(v) -> float:
    v = np.asarray(v, float)
    return float(np.linalg.norm(v)) if np.all(np.isfinite(v)) else math.nan


# --- shoot -----------------------------------------------------------------------------------
def _open_loop_cycle_times(z, t_switch, t_motor, torque, robot, integ) -> tuple[float, int]:
    """``(t_end [s], status)`` of one open-loop cycle from section state ``z``."""
    from ..analysis import section_state
    from ..controllers import OpenLoop
    from ..simulate import run_controller

    res = run_controller(OpenLoop(t_switch, t_motor, torque, clock="reset_at_vertical"),
                         section_state(z), robot=robot, integrator=integ, cycles=1,
                         log_capacity=16)
    return float(res.segment_times[2]), int(res.status)


def shoot_task(spec: GaitSpec, start: tuple[float, float], *, method: str = "both",
               tol: float = 1e-14, max_iter: int = 40) -> dict[str, Any]:
    """Shoot for exact gaits from one ``start`` (dtheta1, dtheta2) [rad s-1].

    Returns ``{"start", "candidates": [...], "failures": [...]}``; a candidate is a dict
    ``dtheta1, dtheta2, t_switch, t_motor, t_end, error, residual_norm, converged, method,
    status, history, message``. ``grazing``: :func:`~monkeystudy.analysis.shoot_grazing` from
    the swap time of the gait at the start (exact events); its error is that of the open-loop
    return map with no motor, ``|P(z) - z|^2``, ``t_motor = 0``. ``gauss_newton``:
    :func:`~monkeystudy.analysis.shoot_horizontal` (its error, times and history as found).
    """
    from ..analysis import open_loop_return_map, shoot_grazing, shoot_horizontal
    from ..simulate import evaluate_horizontal_gait

    robot, integ = _unpack(spec)
    torque = float(spec["torque"])
    d1, d2 = float(start[0]), float(start[1])
    cands: list[dict] = []
    failures: list[str] = []
    if method in ("grazing", "both"):
        g = evaluate_horizontal_gait(d1, d2, robot=robot, torque=torque, tick=0.0,
                                     integrator=integ)
        if g.status != L.ST_OK or not math.isfinite(g.t_switch):
            failures.append(f"grazing: no gait at the start (status "
                            f"{L.STATUS_NAMES[int(g.status)]}), no swap time to start from")
        else:
            gr = shoot_grazing((d1, d2), g.t_switch, robot=robot, integrator=integ, tol=tol,
                               max_iter=max_iter)
            z = np.array([0.0, gr.dtheta1, gr.dtheta2])
            if not np.all(np.isfinite(z)) or not math.isfinite(gr.t_switch):
                failures.append("grazing: Newton diverged (non-finite iterate)")
            else:
                zn, st = open_loop_return_map(z, t_switch=gr.t_switch, t_motor=0.0, torque=0.0,
                                              robot=robot, integrator=integ)
                t_end, _ = _open_loop_cycle_times(z, gr.t_switch, 0.0, 0.0, robot, integ)
                ok = int(st) == L.ST_OK
                cands.append({
                    "dtheta1": gr.dtheta1, "dtheta2": gr.dtheta2, "t_switch": gr.t_switch,
                    "t_motor": 0.0, "t_end": t_end if ok else math.nan,
                    "error": float(np.sum((zn - z) ** 2)) if ok else math.nan,
                    "residual_norm": _norm_or_nan(gr.residual),
                    "converged": int(bool(gr.converged)), "method": METHOD_GRAZING,
                    "status": int(st), "history": np.asarray(gr.history, float),
                    "message": (f"grazing from t_guess {g.t_switch:.6g} s: "
                                + ("converged" if gr.converged else "not converged")
                                + f" after {len(gr.history) - 1} iterations"),
                })
    if method in ("gauss_newton", "both"):
        sh = shoot_horizontal((d1, d2), robot=robot, torque=torque, integrator=integ, tol=tol,
                              max_iter=max_iter)
        if not (math.isfinite(sh.dtheta1) and math.isfinite(sh.dtheta2)) or not sh.history:
            failures.append(f"gauss_newton: {sh.message} (status {sh.status.name.lower()})")
        else:
            cands.append({
                "dtheta1": sh.dtheta1, "dtheta2": sh.dtheta2, "t_switch": sh.t_switch,
                "t_motor": sh.t_motor, "t_end": sh.t_end, "error": sh.error,
                "residual_norm": _norm_or_nan(sh.residual),
                "converged": int(bool(sh.converged)), "method": METHOD_GAUSS_NEWTON,
                "status": int(sh.status), "history": np.asarray(sh.history, float),
                "message": f"gauss_newton: {sh.message} after {sh.iterations} iterations",
            })
    return {"start": (d1, d2), "candidates": cands, "failures": failures}


def dedup_solutions(results: list[dict], tol: float) -> tuple[list[dict], list[str]]:
    """Merge the candidates of :func:`shoot_task` results (one per start, in start order).

    Candidates closer than ``tol`` [rad s-1] (Euclidean, in (dtheta1, dtheta2)) are one
    solution: the lower error is kept (NaN counts as worst), with ``start_index`` the first
    start that found it and ``starts`` every start that did; the kept solution's ``message``
    notes each merged candidate (its swap time and error: the same rates may be reached with
    another swap time, e.g. on a later swing). Returns ``(solutions, failure messages)``; the
    order is that of discovery (start by start, grazing before gauss_newton).
    """
    sols: list[dict] = []
    failures: list[str] = []

    def key(c):
        return c["error"] if math.isfinite(c["error"]) else math.inf

    for i, r in enumerate(results):
        failures += [f"start {i} {list(r['start'])}: {m}" for m in r["failures"]]
        for c in r["candidates"]:
            hit = None
            for s in sols:
                if math.hypot(s["dtheta1"] - c["dtheta1"], s["dtheta2"] - c["dtheta2"]) < tol:
                    hit = s
                    break
            c = dict(c, found_by=i, merged=[])
            if hit is None:
                sols.append(dict(c, start_index=i, starts=[i]))
                continue
            if i not in hit["starts"]:
                hit["starts"].append(i)
            worse = hit if key(c) < key(hit) else c
            notes = hit["merged"] + [
                f"merged: start {worse['found_by']} {METHOD_NAMES[worse['method']]}, t_switch "
                f"{worse['t_switch']:.6g} s, error {worse['error']:.3g}"]
            if worse is hit:
                keep = {k: hit[k] for k in ("start_index", "starts")}
                hit.clear()
                hit.update(c, **keep)
            hit["merged"] = notes
    for sol in sols:
        sol["message"] = "; ".join([sol["message"]] + sol.pop("merged"))
        del sol["found_by"]
    return sols, failures


# --- floquet ---------------------------------------------------------------------------------
def _sorted_eigs(J: np.ndarray) -> np.ndarray:
    lam = np.linalg.eigvals(J)
    return lam[np.argsort(-np.abs(lam), kind="stable")]


def floquet_task(spec: GaitSpec, controller: str, *, gait: dict | None = None,
                 search_start=None, fd_step: float = 1e-5) -> dict[str, Any]:
    """Multipliers of one controller's return map on theta1 = 0 at its fixed point.

    ``open_loop``: the fixed point ``z = (0, dtheta1, dtheta2)`` of ``gait`` with its times;
    ``search``: the state-based controller's fixed point, Newton from ``search_start``
    (:func:`~monkeystudy.analysis.solve_fixed_point` with the variational Jacobian). The
    Jacobian by variational equations and by central differences, both sets of multipliers
    (sorted by decreasing modulus), ``map_defect = |P(z) - z|``, ``agreement = max|J - J_fd| /
    max|J|``, ``stable`` (from the variational multipliers, neutral ones excluded).
    """
    from functools import partial

    from ..analysis import (
        floquet, open_loop_return_map, search_return_map, section_state, solve_fixed_point,
        variational_jacobian,
    )
    from ..controllers import HorizontalSearch
    from ..simulate import run_controller

    robot, integ = _unpack(spec)
    out: dict[str, Any] = {"controller": controller, "newton_converged": 1,
                           "newton_history": np.empty(0)}
    if controller == "open_loop":
        torque = replay_torque(spec, gait)
        t_switch, t_motor = float(gait["t_switch"]), float(gait["t_motor"])
        z = np.array([0.0, gait["dtheta1"], gait["dtheta2"]], float)
        fmap = partial(open_loop_return_map, t_switch=t_switch, t_motor=t_motor, torque=torque,
                       robot=robot, integrator=integ)
        Jv = variational_jacobian("open_loop", z, t_switch=t_switch, t_motor=t_motor,
                                  torque=torque, robot=robot, integrator=integ)
    elif controller == "search":
        torque = float(spec["torque"])
        fmap = partial(search_return_map, torque=torque, robot=robot, integrator=integ)

        def jac(q):
            return variational_jacobian("search", q, torque=torque, robot=robot,
                                        integrator=integ)

        fp = solve_fixed_point(fmap, np.asarray(search_start, float), jacobian=jac)
        z = fp.z
        out["newton_converged"] = int(bool(fp.converged))
        out["newton_history"] = np.asarray(fp.history, float)
        Jv = jac(z)
        res = run_controller(HorizontalSearch(torque), section_state(z), robot=robot,
                             integrator=integ, log_capacity=16)
        t_sw, t_off = (float(t) for t in res.segment_times[:2])
        t_switch, t_motor = t_sw, t_off - t_sw
    elif controller == "sequence":
        return _sequence_floquet(spec, gait, fd_step, out)
    else:
        raise ValueError(f"controller must be 'open_loop', 'search' or 'sequence', got "
                         f"{controller!r}")
    fl = floquet(fmap, z, step=fd_step, neutral_tol=NEUTRAL_TOL)
    lam = _sorted_eigs(Jv)
    neutral = np.abs(lam - 1.0) < NEUTRAL_TOL
    out.update({
        "fixed_point": np.asarray(z, float), "map_defect": float(fl.map_defect),
        "jacobian": Jv, "jacobian_fd": fl.jacobian, "multipliers": lam,
        "multipliers_fd": fl.multipliers,
        "stable": int(bool(np.all(np.abs(lam[~neutral]) < 1.0))),
        "neutral": int(neutral.sum()),
        "agreement": float(np.abs(Jv - fl.jacobian).max() / np.abs(Jv).max()),
        "t_switch": t_switch, "t_motor": t_motor, "torque": torque,
    })
    return out


def _sequence_floquet(spec: GaitSpec, gait: dict, fd_step: float, out: dict) -> dict:
    """Floquet analysis of a sequence gait's cycle from a refined start.

    The refine step searched ``(dtheta1, dtheta2)`` at the section's ``theta2``; its best point
    is close to, not on, a fixed point. Newton on the full return map (``theta2`` free, the
    variational Jacobian) polishes it; the multipliers are taken at the polished point (or at
    the refined one, with its ``map_defect``, if Newton fails: ``newton_converged`` 0).
    """
    from functools import partial

    from ..analysis import cycle_return_map, floquet, solve_fixed_point
    from ..saltation import sequence_variational_jacobian
    from ..simulate import evaluate_cycle_gaits
    from .drivers import spec_sequence

    robot, integ = _unpack(spec)
    seq = spec_sequence(spec)
    fmap = partial(cycle_return_map, gait=seq, robot=robot, integrator=integ)

    def jac(q):
        return sequence_variational_jacobian(seq, q, robot=robot, integrator=integ)

    z = np.array([seq.theta2, gait["dtheta1"], gait["dtheta2"]], float)
    try:
        fp = solve_fixed_point(fmap, z, jacobian=jac)
        out["newton_converged"] = int(bool(fp.converged))
        out["newton_history"] = np.asarray(fp.history, float)
        if fp.converged:
            z = fp.z
    except RuntimeError:
        out["newton_converged"] = 0
    Jv = jac(z)
    fl = floquet(fmap, z, step=fd_step, neutral_tol=NEUTRAL_TOL)
    lam = _sorted_eigs(Jv)
    neutral = np.abs(lam - 1.0) < NEUTRAL_TOL
    at = dataclasses.replace(seq, theta2=float(z[0]))
    r = evaluate_cycle_gaits(np.array([[z[1], z[2]]]), at, robot=robot, integrator=integ)
    out.update({
        "fixed_point": z, "map_defect": float(fl.map_defect), "jacobian": Jv,
        "jacobian_fd": fl.jacobian, "multipliers": lam, "multipliers_fd": fl.multipliers,
        "stable": int(bool(np.all(np.abs(lam[~neutral]) < 1.0))),
        "neutral": int(neutral.sum()),
        "agreement": float(np.abs(Jv - fl.jacobian).max() / np.abs(Jv).max()),
        "t_switch": math.nan, "t_motor": math.nan, "torque": math.nan,
        "t_segment": r["t_segment"][0], "x_advance": float(r["x_advance"][0]),
        "y_advance": float(r["y_advance"][0]), "error": float(r["error"][0]),
    })
    return out


# --- tick sweep ------------------------------------------------------------------------------
def growth_per_cycle(error: np.ndarray, window=GROWTH_WINDOW) -> float:
    """``exp`` of the slope of ``log(sqrt(error))`` against the cycle number, fitted over the
    cycles with ``window[0] < sqrt(error) < window[1]``; NaN if fewer than 3 such cycles."""
    e = np.sqrt(np.asarray(error, float))
    with np.errstate(invalid="ignore"):
        lin = np.isfinite(e) & (e > window[0]) & (e < window[1])
    if int(lin.sum()) < 3:
        return math.nan
    c = np.flatnonzero(lin) + 1.0
    return float(np.exp(np.polyfit(c, np.log(e[lin]), 1)[0]))


def cycles_to_bound(error: np.ndarray, bound: float) -> int:
    """First cycle (1-based) whose error exceeds ``bound``; else the number of cycles run."""
    e = np.asarray(error, float)
    bad = np.flatnonzero(~(e <= bound))
    return int(bad[0]) + 1 if bad.size else int(e.size)


def _sweep(ticks, cycles: int, error_bound: float, run_one) -> dict[str, np.ndarray]:
    """One run per tick: ``run_one(tick) -> (error per cycle, pivot height per cycle,
    status)``; the per-tick arrays of a tick_sweep dataset (NaN padded to ``cycles``)."""
    n = len(ticks)
    out = {"error": np.full((n, cycles), np.nan), "pivot_height": np.full((n, cycles), np.nan),
           "cycles_to_bound": np.zeros(n, np.int32), "cycles_completed": np.zeros(n, np.int32),
           "status": np.zeros(n, np.int8), "growth_per_cycle": np.full(n, np.nan)}
    for i, tick in enumerate(ticks):
        error, pivot, status = run_one(tick)
        e = np.asarray(error, float)[:cycles]
        p = np.asarray(pivot, float)[:cycles]
        out["error"][i, :e.size] = e
        out["pivot_height"][i, :p.size] = p
        out["cycles_to_bound"][i] = cycles_to_bound(e, error_bound)
        out["cycles_completed"][i] = e.size
        out["status"][i] = int(status)
        out["growth_per_cycle"][i] = growth_per_cycle(e)
    return out


def tick_sweep_task(spec: GaitSpec, gait: dict, *, ticks, cycles: int, error_bound: float,
                    max_drop: float, leading_multiplier: bool = True,
                    fd_step: float = 1e-5) -> dict[str, Any]:
    """The gait replayed open-loop from its fixed point once per controller tick [s].

    Per tick: the error per cycle (against the gait's start, MODEL.md section 4) and the pivot
    height per swap (NaN padded to ``cycles``), ``cycles_to_bound``, ``cycles_completed``
    (vertical crossings reached), the run's status and the fitted growth of sqrt(error) per
    cycle. ``leading_multiplier``: also |lambda_max| of the exact-timing open-loop map by
    finite differences (:func:`~monkeystudy.analysis.floquet`); NaN otherwise.
    """
    from functools import partial

    from ..analysis import floquet, open_loop_cycles, open_loop_return_map

    robot, integ = _unpack(spec)
    torque = replay_torque(spec, gait)
    d1, d2 = float(gait["dtheta1"]), float(gait["dtheta2"])
    t_switch, t_motor = float(gait["t_switch"]), float(gait["t_motor"])

    def run_one(tick):
        run = open_loop_cycles(d1, d2, t_switch=t_switch, t_motor=t_motor, cycles=cycles,
                               torque=torque, robot=robot, integrator=integ,
                               tick=float(tick), max_drop=max_drop)
        return run.error, run.pivot_height, run.status

    out = _sweep(ticks, cycles, error_bound, run_one)
    lead = math.nan
    if leading_multiplier:
        fmap = partial(open_loop_return_map, t_switch=t_switch, t_motor=t_motor, torque=torque,
                       robot=robot, integrator=integ)
        fl = floquet(fmap, np.array([0.0, d1, d2]), step=fd_step)
        lead = float(np.abs(fl.multipliers[0]))
    return dict(out, leading_multiplier=lead, torque=torque)


def sequence_tick_sweep_task(spec: GaitSpec, z_star, *, ticks, cycles: int,
                             error_bound: float, max_drop: float, replay: str,
                             leading_multiplier: bool, fd_step: float = 1e-5) -> dict[str, Any]:
    """:func:`tick_sweep_task` for the spec's sequence gait from its fixed point ``z_star =
    (theta2 [rad], dtheta1, dtheta2 [rad s-1])``, run as its own controller or open-loop
    (``replay``; :func:`monkeystudy.replay.sequence_cycles`). ``pivot_height`` is the attached
    end's height at each section crossing. ``leading_multiplier``: |lambda_max| of the
    replayed exact-timing map by finite differences (NaN otherwise); also returns all three
    (``multipliers``) and the replayed segment times (``t_segment`` [s])."""
    from functools import partial

    from ..analysis import cycle_return_map, floquet
    from ..replay import cycle_times, open_loop_gait, sequence_cycles

    robot, integ = _unpack(spec)
    gait = spec_sequence(spec)
    z_star = np.asarray(z_star, float)
    times = cycle_times(gait, z_star, robot=robot, integrator=integ)

    def run_one(tick):
        r = sequence_cycles(gait, z_star, cycles=cycles, robot=robot, integrator=integ,
                            replay=replay, times=times, tick=float(tick), max_drop=max_drop)
        return r.error, r.pivot_height, r.status

    out = _sweep(ticks, cycles, error_bound, run_one)
    lead, lam = math.nan, np.full(3, np.nan + 0j)
    if leading_multiplier:
        g = open_loop_gait(gait, times) if replay == "open_loop" else gait
        fl = floquet(partial(cycle_return_map, gait=dataclasses.replace(g, tick=0.0),
                             robot=robot, integrator=integ), z_star, step=fd_step)
        lam = np.asarray(fl.multipliers, complex)
        lead = float(np.abs(lam[0]))
    return dict(out, leading_multiplier=lead, multipliers=lam, torque=sequence_torque(gait),
                t_segment=times)


def sequence_basin_block(spec: GaitSpec, z_star, offsets1: np.ndarray, offsets2: np.ndarray,
                         *, max_cycles: int, error_bound: float, tick: float,
                         replay: str) -> dict[str, np.ndarray]:
    """:func:`basin_block` for the spec's sequence gait around its fixed point ``z_star``
    (:func:`monkeystudy.replay.sequence_basin`)."""
    from ..replay import sequence_basin

    robot, integ = _unpack(spec)
    B = sequence_basin(spec_sequence(spec), np.asarray(z_star, float),
                       np.asarray(offsets1, float), np.asarray(offsets2, float),
                       max_cycles=int(max_cycles), error_bound=float(error_bound), robot=robot,
                       integrator=integ, replay=replay, tick=float(tick))
    return {"cycles": np.ascontiguousarray(B, np.int32).ravel()}


# --- basin -----------------------------------------------------------------------------------
def basin_block(spec: GaitSpec, gait: dict, offsets1: np.ndarray, offsets2: np.ndarray, *,
                max_cycles: int, error_bound: float, tick: float) -> dict[str, np.ndarray]:
    """Cycles survived from starts ``gait + (a, b)`` for ``a`` in ``offsets1`` (rows of the
    basin), ``b`` in ``offsets2`` [rad s-1] (:func:`~monkeystudy.analysis.basin`); returns
    ``{"cycles": int32 array [len(offsets1) * len(offsets2)]}`` in C order."""
    from ..analysis import basin

    robot, integ = _unpack(spec)
    B = basin(float(gait["dtheta1"]), float(gait["dtheta2"]), t_switch=float(gait["t_switch"]),
              t_motor=float(gait["t_motor"]), torque=replay_torque(spec, gait),
              offsets1=np.asarray(offsets1, float), offsets2=np.asarray(offsets2, float),
              max_cycles=int(max_cycles), error_bound=float(error_bound), robot=robot,
              integrator=integ, tick=float(tick))
    return {"cycles": np.ascontiguousarray(B, np.int32).ravel()}


# --- continuation ----------------------------------------------------------------------------
def parameter_value(robot_dict: dict, parameter: str) -> float:
    """The robot's current value of a continuation parameter (link 1's com [m], link 1's
    inertia [kg m2], gravity [m s-2])."""
    if parameter == "com":
        return float(robot_dict["link1"]["com"])
    if parameter == "inertia":
        return float(robot_dict["link1"]["inertia"])
    if parameter == "gravity":
        return float(robot_dict["gravity"])
    raise ValueError(f"parameter must be 'com', 'inertia' or 'gravity', got {parameter!r}")


def continuation_task(spec: GaitSpec, gait: dict, *, parameter: str, ds: float, steps: int,
                      bounds=(-math.inf, math.inf)) -> dict[str, Any]:
    """Continue the collisionless gait family from a grazing solution in ``parameter``
    (:func:`~monkeystudy.analysis.continue_grazing`), starting at the robot's own value."""
    from ..analysis import GrazingResult, continue_grazing

    robot, integ = _unpack(spec)
    value0 = parameter_value(spec["robot"], parameter)
    start = GrazingResult(float(gait["dtheta1"]), float(gait["dtheta2"]),
                          float(gait["t_switch"]), np.zeros(3), True, [])
    b = continue_grazing(start, parameter, value0, robot=robot, ds=float(ds), steps=int(steps),
                         bounds=tuple(bounds), integrator=integ)
    return {"parameter": b.parameter, "value0": value0, "value": np.asarray(b.value, float),
            "dtheta1": np.asarray(b.dtheta1, float), "dtheta2": np.asarray(b.dtheta2, float),
            "t_switch": np.asarray(b.t_switch, float), "residual": np.asarray(b.residual, float),
            "multipliers": np.asarray(b.multipliers, complex), "folds": list(b.folds),
            "period_doublings": list(b.period_doublings)}


def sequence_continuation_task(spec: GaitSpec, fixed_point, *, parameter: str, ds: float,
                               steps: int, ds_max: float | None = None,
                               bounds=(-math.inf, math.inf)) -> dict[str, Any]:
    """Continue a sequence gait's fixed point ``(theta2, dtheta1, dtheta2)`` in ``parameter``
    (:func:`~monkeystudy.continuation.continue_cycle`), starting at the study's own value;
    with each branch point's segment end times and advance per cycle."""
    from ..continuation import continue_cycle, with_parameter
    from ..simulate import evaluate_cycle_gaits
    from .drivers import n_cycle_segments, spec_sequence

    robot, integ = _unpack(spec)
    seq = spec_sequence(spec)
    z0 = np.asarray(fixed_point, float)
    b = continue_cycle(seq, z0, parameter, robot=robot, ds=float(ds), steps=int(steps),
                       ds_max=ds_max, bounds=tuple(bounds), integrator=integ)
    n = len(b.value)
    t_seg = np.full((n, n_cycle_segments(spec)), np.nan)
    adv = np.full((n, 2), np.nan)
    for i in range(n):
        rb, g = with_parameter(robot, seq, parameter, b.value[i])
        g = dataclasses.replace(g, theta2=float(b.theta2[i]))
        r = evaluate_cycle_gaits(np.array([[b.dtheta1[i], b.dtheta2[i]]]), g, robot=rb,
                                 integrator=integ)
        t_seg[i] = r["t_segment"][0]
        adv[i] = r["x_advance"][0], r["y_advance"][0]
    return {"parameter": parameter, "value0": float(b.value[0]), "value": b.value,
            "theta2": b.theta2, "theta2_pinned": int(b.theta2_pinned),
            "dtheta1": b.dtheta1, "dtheta2": b.dtheta2,
            "residual": b.residual, "iterations": b.iterations, "arclength": b.arclength,
            "multipliers": b.multipliers, "neutral": b.neutral, "stable": b.stable,
            "t_segment": t_seg, "x_advance": adv[:, 0], "y_advance": adv[:, 1],
            "folds": list(b.folds), "period_doublings": list(b.period_doublings),
            "through_plus_one": list(b.through_plus_one),
            "neimark_sacker": list(b.neimark_sacker),
            "stop_reason": b.stop_reason}


# --- work precision --------------------------------------------------------------------------
def work_precision_task(spec: GaitSpec, points: np.ndarray, **options) -> dict[str, Any]:
    """:func:`monkeystudy.precision.work_precision` on the study's robot and torque
    (``options``: methods, rtols, atol_ratio, repeat, scipy_methods, scipy_rtols,
    scipy_points, first_swing_only). Wall times: not reproducible bit for bit."""
    from ..bench import ScipyGait
    from ..precision import work_precision

    robot, _ = _unpack(spec)
    pts = np.asarray(points, float).reshape(-1, 2)
    # the first solve_ivp call of a process imports and sets up scipy's solvers: pay for it
    # here, not in the first timed cell
    sg = ScipyGait(robot, float(spec["torque"]), "scalar")
    for m in options.get("scipy_methods", ("RK45", "DOP853", "LSODA")):
        sg.gait(pts[0, 0], pts[0, 1], 1e-6, 1e-8, method=m)
    return work_precision(pts, robot=robot, torque=float(spec["torque"]), **options)


# --- stress ----------------------------------------------------------------------------------
def stress_drift_task(spec: GaitSpec, phase: str, rtol: float, *, periods: float,
                      checkpoints: int, atol_ratio: float) -> dict[str, Any]:
    """Energy drift of one unforced, frictionless run (:func:`monkeystudy.stress.
    energy_drift`) of the study's robot with the study's integrator method."""
    from ..stress import energy_drift

    robot, integ = _unpack(spec)
    return energy_drift(robot, phase, rtol=float(rtol), periods=float(periods),
                        checkpoints=int(checkpoints), atol_ratio=float(atol_ratio),
                        method=integ.method)


def stress_long_run_task(spec: GaitSpec, kind: str, *, start, cycles: int, tick: float,
                         max_drop: float, max_steps: int) -> dict[str, Any]:
    """One long run (:func:`monkeystudy.stress.long_run`) with the study's robot, torque and
    integrator (step budget ``max_steps``); ``tick`` [s], 0 = exact."""
    from dataclasses import replace

    from ..stress import long_run

    robot, integ = _unpack(spec)
    return long_run(kind, start=tuple(float(x) for x in start), cycles=int(cycles),
                    torque=float(spec["torque"]), tick=float(tick), robot=robot,
                    integrator=replace(integ, max_steps=int(max_steps)),
                    max_drop=float(max_drop))


def stress_extreme_task(spec: GaitSpec, cases, *, points, max_steps: int) -> list[dict]:
    """The extreme cases (:func:`monkeystudy.stress.extreme_case`) in order, with the study's
    robot, torque, controller tick and integrator (step budget ``max_steps``)."""
    from dataclasses import replace

    from ..stress import extreme_case

    robot, integ = _unpack(spec)
    integ = replace(integ, max_steps=int(max_steps))
    return [dict(extreme_case(c, robot=robot, torque=float(spec["torque"]),
                              tick=float(spec["tick"]), integrator=integ,
                              points=np.asarray(points, float)), case=c) for c in cases]


# --- warm-up ---------------------------------------------------------------------------------
def warm_up(spec: GaitSpec) -> None:
    """Compile (or load) the variational kernels once in the driver, before fanning out."""
    from ..kernel.variational import (
        swap_jacobian, swap_state, swing_energy_gradient, swing_field, swing_variational_rhs,
    )

    robot, _ = _unpack(spec)
    par = robot.params()
    y = np.array([0.1, 0.2, 1.0, 10.0])
    Y = np.concatenate([y, np.eye(4).ravel()])
    dY = np.empty(20)
    swing_variational_rhs(par[0], 0.0, np.ones(2), Y, dY)
    J = np.empty((4, 4))
    swap_jacobian(par[0], par[1], y, J)
    swap_state(par[0], par[1], y)
    f = np.empty(4)
    swing_field(par[0], 0.0, np.ones(2), y, f)
    g = np.empty(4)
    swing_energy_gradient(par[0], 0.0, y, g)


__all__ = ["METHOD_GAUSS_NEWTON", "METHOD_GRAZING", "METHOD_NAMES", "basin_block",
           "continuation_task", "cycles_to_bound", "dedup_solutions", "floquet_task",
           "growth_per_cycle", "parameter_value", "replay_torque", "sequence_continuation_task",
           "shoot_task", "stress_drift_task", "stress_extreme_task", "stress_long_run_task",
           "tick_sweep_task", "warm_up", "work_precision_task"]
