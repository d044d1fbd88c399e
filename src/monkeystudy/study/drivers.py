"""Task functions of the study steps: plain numbers and numpy arrays in, plain arrays out.

Every function here runs on a worker (a local process or a Dask worker), so it lives in an
importable module, takes picklable plain values (:class:`GaitSpec` is a dict of floats and
strings) and never touches files, xarray or the study models. The kernels run serially inside
a task; parallelism is the runner's business (one task per block of grid points, one task per
refinement, one per stability run).

* :func:`grid_block` - the horizontal gait (MODEL.md section 4) at a block of points.
* :func:`refine_task` - Nelder-Mead on the gait error from one start, every iterate recorded.
* :func:`stability_task` - a refined gait replayed open-loop for N cycles, per-cycle numbers
  from the run's event log, and a sampled trajectory.
"""
from __future__ import annotations

import dataclasses
import math
from typing import Any, Optional, TypedDict

import numpy as np

from ..controllers import Integrator, OpenLoop, Segment, SequenceGait
from ..kernel import layout as L
from ..robot import Friction, Link, Robot
from ..simulate import (
    energies, evaluate_cycle_gaits, evaluate_gaits, gait_error, initial_state, physical_points,
    run_controller,
)

#: Variables of a grid block, with their dtype in blocks, shards and datasets.
GRID_VARIABLES = {
    "error": np.float64, "status": np.int8, "t_switch": np.float64, "t_motor": np.float64,
    "t_end": np.float64, "steps": np.int32, "nfev": np.int32, "rejected": np.int32,
}

#: Variables of a sequence gait's grid block (``t_segment`` has a trailing dim ``segment``).
SEQUENCE_GRID_VARIABLES = {
    "error": np.float64, "status": np.int8, "t_end": np.float64, "t_segment": np.float64,
    "x_advance": np.float64, "y_advance": np.float64, "steps": np.int32, "nfev": np.int32,
    "rejected": np.int32,
}


class GaitSpec(TypedDict):
    """What every task needs to evaluate a gait (plain values, picklable)."""

    robot: dict          # Robot.to_dict()
    torque: float        # motor torque [N m]
    tick: float          # controller tick [s]
    integrator: dict     # Integrator fields
    sequence: Optional[dict]  # a SequenceGait's fields (segments as dicts), or None: the
                              # horizontal gait


def integrator_fields(integrator: Integrator) -> dict:
    """The integrator settings a study can set, as a gait spec and a dataset carry them (one
    list: a field missing here would silently fall back to its default on the workers)."""
    return {"method": integrator.method, "rtol": integrator.rtol, "atol": integrator.atol,
            "max_time": integrator.max_time, "controller": integrator.controller}


def make_spec(robot: Robot, torque: float, tick: float, integrator: Integrator,
              sequence: SequenceGait | None = None) -> GaitSpec:
    return GaitSpec(robot=robot.to_dict(), torque=float(torque), tick=float(tick),
                    integrator=integrator_fields(integrator),
                    sequence=None if sequence is None else dataclasses.asdict(sequence))


def spec_sequence(spec: GaitSpec) -> SequenceGait | None:
    """The spec's sequence gait, or None for the horizontal gait."""
    d = spec.get("sequence")
    if d is None:
        return None
    d = dict(d)
    d["segments"] = [Segment(**seg) for seg in d["segments"]]
    return SequenceGait(**d)


def grid_variables(spec: GaitSpec) -> dict[str, Any]:
    """The variables (name -> dtype) of the spec's grid blocks."""
    return GRID_VARIABLES if spec.get("sequence") is None else SEQUENCE_GRID_VARIABLES


def n_cycle_segments(spec: GaitSpec) -> int:
    """Segments of a sequence gait's cycle, the section included (0: horizontal gait)."""
    seq = spec.get("sequence")
    return 0 if seq is None else len(seq["segments"]) + 1


def robot_from_dict(d: dict) -> Robot:
    return Robot(Link(**d["link1"]), Link(**d["link2"]), gravity=d["gravity"],
                 pivot_friction=Friction(**d["pivot_friction"]),
                 joint_friction=Friction(**d["joint_friction"]), name=d["name"])


def _unpack(spec: GaitSpec) -> tuple[Robot, Integrator]:
    return robot_from_dict(spec["robot"]), Integrator(**spec["integrator"])


# --- grid -------------------------------------------------------------------------------------
def grid_block(spec: GaitSpec, points: np.ndarray, skip_unreachable: bool = True
               ) -> dict[str, np.ndarray]:
    """Evaluate the gait at ``points[n, 2]`` (dtheta1, dtheta2) [rad s-1].

    Returns the arrays of :func:`grid_variables` (``error`` NaN unless status is ok): the
    horizontal gait's, or one cycle of the spec's sequence gait.
    """
    robot, integ = _unpack(spec)
    seq = spec_sequence(spec)
    if seq is None:
        r = evaluate_gaits(points, robot=robot, torque=spec["torque"], tick=spec["tick"],
                           integrator=integ, skip_unreachable=skip_unreachable)
    else:
        # no energy bound here: a sequence's motor may act before its swap
        r = evaluate_cycle_gaits(points, seq, robot=robot, integrator=integ)
    return {name: np.asarray(r[name]).astype(dt, copy=False)
            for name, dt in grid_variables(spec).items()}


# --- refine -----------------------------------------------------------------------------------
def refine_task(spec: GaitSpec, start: tuple[float, float], *, xatol: float, fatol: float,
                maxiter: int | None = None, maxfev: int | None = None,
                penalty: float = 1.0e6) -> dict[str, Any]:
    """Nelder-Mead (scipy, fminsearch's initial simplex) on the gait error from ``start``.

    The objective is the gait error where the gait is ok and ``penalty`` elsewhere (a large
    finite value: the simplex retreats from failed gaits instead of stopping on NaN). Iteration
    0 is the start; iteration k >= 1 is the best vertex after the k-th simplex update (scipy's
    ``nit`` also counts the initial simplex, so it equals the number of recorded iterates
    unless the evaluation limit cut an update short).
    ``iterate_nfev`` counts objective evaluations up to that iterate (repeated points are
    evaluated once, but counted as scipy counts them).
    """
    from scipy.optimize import minimize

    robot, integ = _unpack(spec)
    seq = spec_sequence(spec)
    cache: dict[tuple[float, float], dict[str, Any]] = {}
    calls = 0

    def gait(x) -> dict[str, Any]:
        key = (float(x[0]), float(x[1]))
        if key not in cache:
            if seq is None:
                r = evaluate_gaits(np.array([key]), robot=robot, torque=spec["torque"],
                                   tick=spec["tick"], integrator=integ, skip_unreachable=True)
                keys = ("error", "status", "t_switch", "t_motor", "t_end")
            else:
                r = evaluate_cycle_gaits(np.array([key]), seq, robot=robot, integrator=integ)
                keys = ("error", "status", "t_end", "t_segment", "x_advance", "y_advance")
            cache[key] = {k: (int(r[k][0]) if k == "status" else
                              r[k][0].copy() if k == "t_segment" else float(r[k][0]))
                          for k in keys}
        return cache[key]

    def objective(x) -> float:
        nonlocal calls
        calls += 1
        g = gait(x)
        if g["status"] != L.ST_OK or not math.isfinite(g["error"]):
            return float(penalty)
        return g["error"]

    x0 = np.array(start, dtype=np.float64)
    g0 = gait(x0)
    it_x = [x0.copy()]
    it_e = [g0["error"] if g0["status"] == L.ST_OK else math.nan]
    it_n = [1]

    def callback(intermediate_result):
        x = np.asarray(intermediate_result.x, dtype=np.float64)
        g = gait(x)
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
    g = gait(x)
    return {
        **g, "x": x, "error": g["error"] if g["status"] == L.ST_OK else math.nan,
        "iterate_x": np.array(it_x), "iterate_error": np.array(it_e),
        "iterate_nfev": np.array(it_n, dtype=np.int32), "nit": int(res.nit),
        "nfev": int(res.nfev), "converged": int(bool(res.success)), "message": str(res.message),
        "start": x0,
    }


# --- stability --------------------------------------------------------------------------------
def _run_record(res) -> dict[str, Any]:
    """A multi-cycle run's status, counts and sampled trajectory (world positions [m] of A,
    the joint and B; phase; motor torque [N m]) for a stability dataset."""
    pts = physical_points(res.params, res.sample_state, res.sample_mode[:, L.M_FLIPPED])
    return {
        "status": int(res.status), "cycles_completed": int(res.counts[L.K_CYCLES]),
        "time": res.sample_t.copy(), "A": pts["A"], "joint": pts["joint"], "B": pts["B"],
        "phase": res.sample_mode[:, L.M_PHASE].astype(np.int8),
        "motor_torque": res.sample_mode[:, L.M_TORQUE].copy(),
        "steps": int(res.counts[L.K_STEPS]), "nfev": int(res.counts[L.K_NFEV]),
    }


def stability_task(spec: GaitSpec, gait: dict[str, float], *, cycles: int, tick: float,
                   clock: str, sample_dt: float, max_drop: float) -> dict[str, Any]:
    """Replay a refined gait open-loop (swap at ``t_switch``, motor for ``t_motor`` [s]).

    ``gait`` holds the refined ``dtheta1``, ``dtheta2`` [rad s-1], ``t_switch``, ``t_motor``,
    ``t_end`` [s] and ``status``. With ``clock='run_on'`` the period is ``t_end``. Per cycle
    c = 1..N (from the run's log): the swap (segment 0 exit) starting it, the first vertical
    crossing (observer) after that swap, and there the error against the initial rates
    (MODEL.md section 4, with the frame's theta2, dtheta1, dtheta2) and the kinetic energy;
    ``pivot_height`` and the world position of the attached end after the swap.
    A gait that is not ok is not run: ``status`` is its status and every cycle is NaN.
    """
    robot, integ = _unpack(spec)
    nan = np.full(cycles, np.nan)
    out: dict[str, Any] = {
        "status": int(gait["status"]), "cycles_completed": 0,
        "error": nan.copy(), "kinetic_energy": nan.copy(), "pivot_height": nan.copy(),
        "x_advance": nan.copy(), "t_cross": nan.copy(), "t_swap": nan.copy(),
        "time": np.empty(0), "A": np.empty((0, 2)), "joint": np.empty((0, 2)),
        "B": np.empty((0, 2)), "phase": np.empty(0, np.int8), "motor_torque": np.empty(0),
        "steps": 0, "nfev": 0,
    }
    times = (gait["t_switch"], gait["t_motor"], gait["t_end"])
    if gait["status"] != L.ST_OK or not all(math.isfinite(t) for t in times):
        return out
    d1, d2 = float(gait["dtheta1"]), float(gait["dtheta2"])
    ctrl = OpenLoop(gait["t_switch"], gait["t_motor"], spec["torque"], tick=tick, clock=clock,
                    period=gait["t_end"] if clock == "run_on" else math.nan)
    res = run_controller(ctrl, initial_state(d1, d2), robot=robot, integrator=integ,
                         cycles=cycles, sample_dt=sample_dt, max_drop=max_drop)
    log = res.log
    swaps = log[(log[:, L.L_KIND] == L.LOG_SEGMENT) & (log[:, L.L_ID] == 0)]
    cross = log[log[:, L.L_KIND] == L.LOG_OBSERVER]
    x_prev = 0.0                                  # the gait starts hanging from A at x = 0
    for c in range(min(cycles, swaps.shape[0])):
        s = swaps[c, L.L_STATE:L.L_STATE + 8]
        out["t_swap"][c] = swaps[c, L.L_T]
        out["pivot_height"][c] = s[L.Y]
        out["x_advance"][c] = s[L.X] - x_prev
        x_prev = s[L.X]
        t0 = swaps[c, L.L_T]
        t1 = swaps[c + 1, L.L_T] if c + 1 < swaps.shape[0] else math.inf
        k = np.flatnonzero((cross[:, L.L_T] > t0) & (cross[:, L.L_T] < t1))
        if k.size == 0:
            continue
        row = cross[k[0]]
        f = row[L.L_STATE:L.L_STATE + 8]
        out["t_cross"][c] = row[L.L_T]
        out["error"][c] = gait_error(f, d1, d2)
        ke, _ = energies(res.params, f[None, :], np.array([row[L.L_FLIPPED]]))
        out["kinetic_energy"][c] = ke[0]
    out.update(_run_record(res))
    return out


def sequence_stability_task(spec: GaitSpec, z0, *, cycles: int, tick: float | None,
                            sample_dt: float, max_drop: float, replay: str) -> dict[str, Any]:
    """Run the spec's sequence gait for ``cycles`` cycles from section state ``z0 = (theta2
    [rad], dtheta1, dtheta2 [rad s-1])`` (:func:`monkeystudy.replay.sequence_cycles`: its own
    controller or its open-loop replay, ``tick`` [s] or the gait's).

    Returns the keys of :func:`stability_task`, measured at each section crossing (``t_cross``)
    with ``t_swap`` the cycle's first magnet action [s], plus ``t_segment`` (the replayed
    segment times of an open-loop replay, else the recorded cycle's) [s]. A start whose cycle
    does not close is not run: ``status`` is its status and every cycle is NaN.
    """
    from ..replay import sequence_cycles

    robot, integ = _unpack(spec)
    gait = spec_sequence(spec)
    nan = np.full(cycles, np.nan)
    out: dict[str, Any] = {
        "status": L.ST_OK, "cycles_completed": 0,
        "error": nan.copy(), "kinetic_energy": nan.copy(), "pivot_height": nan.copy(),
        "x_advance": nan.copy(), "t_cross": nan.copy(), "t_swap": nan.copy(),
        "time": np.empty(0), "A": np.empty((0, 2)), "joint": np.empty((0, 2)),
        "B": np.empty((0, 2)), "phase": np.empty(0, np.int8), "motor_torque": np.empty(0),
        "steps": 0, "nfev": 0, "t_segment": np.full(len(gait.all_segments()), np.nan),
    }
    z0 = np.asarray(z0, float)
    one = evaluate_cycle_gaits([[z0[1], z0[2]]], dataclasses.replace(gait, theta2=z0[0]),
                               robot=robot, integrator=integ)
    if int(one["status"][0]) != L.ST_OK:
        out["status"] = int(one["status"][0])
        return out
    times = one["t_segment"][0].copy()
    out["t_segment"] = times
    r = sequence_cycles(gait, z0, cycles=cycles, robot=robot, integrator=integ,
                        replay=replay, times=times, tick=tick, max_drop=max_drop,
                        sample_dt=sample_dt)
    n = min(cycles, len(r.error))
    for key in ("error", "kinetic_energy", "pivot_height", "x_advance", "t_cross", "t_swap"):
        out[key][:n] = getattr(r, key)[:n]
    res = r.run
    out.update(_run_record(res))
    return out


# --- warm-up ------------------------------------------------------------------------------------
def warm_up(spec: GaitSpec, stability: bool = False) -> None:
    """Compile (or load from the on-disk cache) the kernels the tasks use, once, in the
    driver, before fanning out: parallel first compiles would race on the cache."""
    grid_block(spec, np.array([[1.0, 11.0]]))
    seq = spec_sequence(spec)
    if stability and seq is not None:
        robot, integ = _unpack(spec)
        run_controller(seq.controller(), initial_state(1.0, 11.0), robot=robot,
                       integrator=integ, t_end=0.05)
    elif stability:
        robot, integ = _unpack(spec)
        run_controller(OpenLoop(0.01, 0.01, spec["torque"], tick=spec["tick"]),
                       initial_state(1.0, 11.0), robot=robot, integrator=integ, t_end=0.05,
                       sample_dt=0.01)


__all__ = ["GRID_VARIABLES", "GaitSpec", "SEQUENCE_GRID_VARIABLES", "grid_block",
           "grid_variables", "integrator_fields", "make_spec", "n_cycle_segments", "refine_task",
           "robot_from_dict", "spec_sequence", "stability_task", "warm_up"]
