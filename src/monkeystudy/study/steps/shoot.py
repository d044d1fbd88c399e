"""The ``shoot`` step: exact fixed points of the study's gait by Newton shooting, from given
starts or from a refine step's result (:mod:`monkeystudy.analysis.shooting`).

Later steps (floquet, tick_sweep, basin, continuation, survival, design) take their gait from a
shoot step's dataset (:func:`~monkeystudy.study.steps.gait_source.shoot_start`): the
lowest-error usable solution (or ``solution: i``).
"""
from __future__ import annotations

import dataclasses
import json
import math
from pathlib import Path
from typing import Any, Literal, Optional

import numpy as np
from pydantic import Field, model_validator

from ...analysis.shooting import shoot_cycle, shoot_grazing
from ...controllers import motorless, open_loop_gait
from ...simulation import STATUS_NAMES, Status, evaluate_cycle_gaits, status_name
from .. import datasets as D
from ..blocks import Task
from ..errors import RunFailed
from ..models import Name, Point, StrictModel
from ..spec import GaitSpec
from .base import Dependency, Figure, StepContext, StepKind
from .gait_source import (
    METHOD_GAUSS_NEWTON, METHOD_GRAZING, METHOD_NAMES, read_start, shoot_start,
)


#: shoot ``method`` flags
SHOOT_METHOD_ATTRS = {
    "long_name": "how the fixed point was found", "units": "1",
    "flag_values": np.array([0, 1], dtype=np.int8),
    "flag_meanings": "gauss_newton grazing",
}


class ShootStep(StrictModel):
    """Exact fixed points of the horizontal gait (Newton shooting, ``monkeystudy.analysis``).

    ``grazing``: Newton on (dtheta1, dtheta2, t) for end B at end A's height at rest (the
    collisionless swap on the grazing border; an exact, motorless fixed point for mirror-image
    links), from the swap time of the gait at the start (exact events). ``gauss_newton``:
    Gauss-Newton on the gait's repeatability residual. One task per start; solutions closer
    than ``dedup_tol`` are merged (the lower error kept).
    """

    name: Name
    kind: Literal["shoot"]
    starts: Optional[list[Point]] = Field(None, min_length=1,
                                          description="start points (dtheta1, dtheta2) "
                                                      "[rad s-1]")
    from_: Optional[Name] = Field(None, alias="from")  # described by the kind (accepts)
    method: Literal["grazing", "gauss_newton", "both"] = Field(
        "both", description="grazing (collisionless swap), gauss_newton (gait residual) or "
                            "both from every start")
    dedup_tol: float = Field(1e-6, gt=0, description="solutions closer than this in "
                                                     "(dtheta1, dtheta2) are one [rad s-1]")
    tol: float = Field(1e-14, gt=0, lt=1.0, description="Newton stops when the residual "
                                                        "norm or the step falls below this "
                                                        "[1]")
    max_iter: int = Field(40, ge=1, le=1000, description="Newton iteration limit")

    @model_validator(mode="after")
    def _starts_or_from(self) -> "ShootStep":
        if (self.starts is None) == (self.from_ is None):
            raise ValueError("give either starts: [[dtheta1, dtheta2], ...] or from: <refine "
                             "step>, not both" if self.starts is not None else
                             "give starts: [[dtheta1, dtheta2], ...] or from: <refine step>")
        return self


# --- tasks (run on the workers) ------------------------------------------------------------------
def _norm_or_nan(v) -> float:
    v = np.asarray(v, float)
    return float(np.linalg.norm(v)) if np.all(np.isfinite(v)) else math.nan


def shoot_task(spec: GaitSpec, start: tuple[float, float], *, method: str = "both",
               tol: float = 1e-14, max_iter: int = 40) -> dict[str, Any]:
    """Shoot for exact gaits of the study's gait from one ``start`` (dtheta1, dtheta2)
    [rad s-1], with exact event timing.

    Returns ``{"start", "candidates": [...], "failures": [...]}``; a candidate is a dict
    ``dtheta1, dtheta2, t_switch, t_motor, t_end, error, residual_norm, converged, method,
    status, history, message``. ``grazing``: :func:`~monkeystudy.analysis.shooting.shoot_grazing`
    from the swap time of the gait's cycle at the start; its error is the gait's error of the
    motorless open-loop replay (:func:`~monkeystudy.simulation.evaluate_cycle_gaits`),
    ``t_motor = 0``, ``t_end`` that replay's section crossing. ``gauss_newton``: :func:`~monkeystudy.analysis.shooting.
    shoot_cycle` (its error, times and history as found).
    """
    robot, integ = spec.robot, spec.integrator
    gait = dataclasses.replace(spec.sequence, tick=0.0)
    d1, d2 = float(start[0]), float(start[1])
    cands: list[dict] = []
    failures: list[str] = []
    if method in ("grazing", "both"):
        one = evaluate_cycle_gaits([[d1, d2]], gait, robot=robot, integrator=integ)
        status, t_guess = int(one["status"][0]), float(one["t_segment"][0, 0])
        if status != Status.OK or not math.isfinite(t_guess):
            failures.append(f"grazing: no gait at the start (status "
                            f"{status_name(status)}), no swap time to start from")
        else:
            gr = shoot_grazing((d1, d2), t_guess, robot=robot, integrator=integ, tol=tol,
                               max_iter=max_iter)
            z = np.array([gait.theta2, gr.dtheta1, gr.dtheta2])
            if not np.all(np.isfinite(z)) or not math.isfinite(gr.t_switch):
                failures.append("grazing: Newton diverged (non-finite iterate)")
            else:
                # the gait's error of its motorless open-loop replay (as the grid's, the
                # refine's and gauss_newton's: defined on any robot)
                replay = open_loop_gait(motorless(gait), [gr.t_switch, gr.t_switch])
                cyc = evaluate_cycle_gaits([[z[1], z[2]]], replay, robot=robot,
                                           integrator=integ)
                st = int(cyc["status"][0])
                ok = st == Status.OK
                cands.append({
                    "dtheta1": gr.dtheta1, "dtheta2": gr.dtheta2, "t_switch": gr.t_switch,
                    "t_motor": 0.0, "t_end": float(cyc["t_segment"][0, -1]) if ok else math.nan,
                    "error": float(cyc["error"][0]) if ok else math.nan,
                    "residual_norm": _norm_or_nan(gr.residual),
                    "converged": int(bool(gr.converged)), "method": METHOD_GRAZING,
                    "status": int(st), "history": np.asarray(gr.history, float),
                    "message": (f"grazing from t_guess {t_guess:.6g} s: "
                                + ("converged" if gr.converged else "not converged")
                                + f" after {len(gr.history) - 1} iterations"),
                })
    if method in ("gauss_newton", "both"):
        sh = shoot_cycle((d1, d2), gait, robot=robot, integrator=integ, tol=tol,
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


def solutions_summary(sols: list[dict], failures: list[str]) -> str:
    """``2 converged solutions (grazing, gauss_newton), 1 search that did not converge
    (gauss_newton, error 36)``: what the searches found, converged or not."""
    conv = [s for s in sols if s["converged"]]
    rest = [s for s in sols if not s["converged"]]
    out = f"{len(conv)} converged solution{'s' if len(conv) != 1 else ''}"
    if conv:
        out += f" ({', '.join(METHOD_NAMES[s['method']] for s in conv)})"
    if rest:
        out += (f", {len(rest)} search{'es' if len(rest) > 1 else ''} that did not converge ("
                + "; ".join(f"{METHOD_NAMES[s['method']]}, error {s['error']:.3g}"
                            for s in rest) + ")")
    if failures:
        out += f", {len(failures)} without a result"
    return out


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
                f"the same rates were also reached from start {worse['found_by']} by "
                f"{METHOD_NAMES[worse['method']]} with the swap at {worse['t_switch']:.6g} s "
                f"and gait error {worse['error']:.3g}; the lower error is kept"]
            if worse is hit:
                keep = {k: hit[k] for k in ("start_index", "starts")}
                hit.clear()
                hit.update(c, **keep)
            hit["merged"] = notes
    for sol in sols:
        sol["message"] = "; ".join([sol["message"]] + sol.pop("merged"))
        del sol["found_by"]
    return sols, failures


# --- the dataset ---------------------------------------------------------------------------------
#: the variables of a shoot dataset (docs/datasets.md)
VARIABLES = {
    "solution": D.index_coordinate("solution", "solution index (discovery order)"),
    "iteration": D.index_coordinate("iteration", "Newton iteration (0: the start)"),
    "dtheta1": D.Variable.of(("solution",), np.float64, D.DTHETA1,
                             long_name="fixed point, " + D.DTHETA1["long_name"]),
    "dtheta2": D.Variable.of(("solution",), np.float64, D.DTHETA2,
                             long_name="fixed point, " + D.DTHETA2["long_name"]),
    **{key: D.Variable.of(("solution",), np.float64, D.GAIT_ATTRS[key])
       for key in ("t_switch", "t_motor", "t_end")},
    "error": D.Variable(("solution",), np.float64, D.ERROR_UNITS,
                        "gait error of the solution (docs/model.md): grazing: |P(z) - z|^2 of "
                        "the motorless open-loop map; gauss_newton: the study's gait error",
                        {"comment": D.ERROR_COMMENT}),
    "residual_norm": D.Variable(("solution",), np.float64, "1",
                                "norm of the Newton residual at the solution (grazing: B's "
                                "height and velocity; gauss_newton: the gait residual)"),
    "converged": D.Variable(("solution",), np.int8, "1",
                            "Newton met its tolerance (1) or stopped (0)"),
    "method": D.Variable.of(("solution",), np.int8, SHOOT_METHOD_ATTRS),
    "status": D.Variable.of(("solution",), np.int8, D.STATUS_ATTRS,
                            long_name="outcome of the solution's gait cycle"),
    "start_index": D.Variable(("solution",), np.int32, "1",
                              "first start that found the solution"),
    "history": D.Variable(("solution", "iteration"), np.float64, "1",
                          "residual norm per Newton iteration (NaN: padding)"),
}


def write_shoot(path: Path, attrs: dict, solutions: list[dict]) -> None:
    """Write a shoot dataset from the deduplicated solutions of
    :func:`dedup_solutions` (discovery order)."""
    n = len(solutions)
    n_it = max(1, max(len(s["history"]) for s in solutions))
    with D.atomic_netcdf(path) as nc:
        D.write_coordinate(nc, VARIABLES, "solution", np.arange(n))
        D.write_coordinate(nc, VARIABLES, "iteration", np.arange(n_it))

        def col(key, dtype=np.float64):
            return np.array([s[key] for s in solutions], dtype=dtype)

        for key in ("dtheta1", "dtheta2", "t_switch", "t_motor", "t_end", "error",
                    "residual_norm"):
            D.write_declared(nc, VARIABLES, key, col(key))
        for key in ("converged", "method", "status"):
            D.write_declared(nc, VARIABLES, key, col(key, np.int8))
        D.write_declared(nc, VARIABLES, "start_index", col("start_index", np.int32))
        hist = np.full((n, n_it), np.nan)
        for i, s in enumerate(solutions):
            hist[i, :len(s["history"])] = s["history"]
        D.write_declared(nc, VARIABLES, "history", hist)
        D.set_global_attrs(nc, dict(attrs, message=[s["message"] for s in solutions],
                               solution_starts=[s["starts"] for s in solutions]))


# --- the kind ------------------------------------------------------------------------------------
class ShootKind(StepKind):
    name = "shoot"
    model = ShootStep
    variables = VARIABLES
    accepts = ("refine",)
    takes = "its refined rates start the shooting (instead of starts)"
    provides = "its lowest-error usable solution (or solution: i)"
    unit = "starts"
    figures = (
        Figure("newton"),
    )

    def n_tasks(self, step: ShootStep, gait) -> int:
        return len(step.starts) if step.starts is not None else 1

    def hand_on(self, dep: Dependency, ctx: StepContext, **options):
        return read_start(shoot_start, dep, ctx, options)

    def start(self, ctx: StepContext) -> list[Task]:
        st = ctx.step
        if st.from_ is not None:
            g = ctx.handed_on()
            if not (math.isfinite(g.z[-2]) and math.isfinite(g.z[-1])):
                raise RunFailed(f"{ctx.name}: refine step {st.from_!r} produced no usable start")
            starts = [(g.z[-2], g.z[-1])]
        else:
            starts = [(float(p[0]), float(p[1])) for p in st.starts]
        ctx.state["starts"] = starts
        kw = {"method": st.method, "tol": st.tol, "max_iter": st.max_iter}
        return [Task(i, shoot_task, (ctx.spec, x0), kw) for i, x0 in enumerate(starts)]

    def finish(self, ctx: StepContext, attrs: dict) -> str:
        st = ctx.step
        sols, failures = dedup_solutions(ctx.task_results(), st.dedup_tol)
        if not sols:
            raise RunFailed(f"{ctx.name}: no start produced a solution: " + "; ".join(failures))
        errs = [x["error"] if math.isfinite(x["error"]) else math.inf for x in sols]
        best = int(np.argmin(errs))
        attrs.update(method=st.method, dedup_tol=st.dedup_tol, tol=st.tol,
                     max_iter=st.max_iter, starts=[list(x) for x in ctx.state["starts"]],
                     refine_step=st.from_ or "", failures=failures, best_solution=best)
        write_shoot(ctx.path, attrs, sols)
        b = sols[best]
        return solutions_summary(sols, failures) + (
            f"; best: error {b['error']:.3g} at ({b['dtheta1']:.10g}, {b['dtheta2']:.10g}) "
            f"rad s-1, {METHOD_NAMES[b['method']]}"
            f"{'' if b['converged'] else ' (NOT converged)'}, t_switch {b['t_switch']:.6g} s")

    def describe(self, ds) -> list[str]:
        a = ds.attrs
        out = []
        msgs = json.loads(a.get("message", "[]"))
        for i in range(ds.sizes["solution"]):
            out.append(f"solution {i}{' (best)' if i == int(a.get('best_solution', -1)) else ''}: "
                       f"({float(ds['dtheta1'][i]):.10g}, {float(ds['dtheta2'][i]):.10g}) rad s-1, "
                       f"error {float(ds['error'][i]):.3g}, "
                       f"{METHOD_NAMES[int(ds['method'][i])]}, "
                       f"{'converged' if int(ds['converged'][i]) else 'not converged'}, "
                       f"t_switch {float(ds['t_switch'][i]):.6g} s, t_motor "
                       f"{float(ds['t_motor'][i]):.6g} s, status "
                       f"{STATUS_NAMES[int(ds['status'][i])]}")
            if i < len(msgs):
                out.append(f"  {msgs[i]}")
        fails = json.loads(a.get("failures", "[]"))
        if fails:
            out.append("failed attempts: " + "; ".join(fails))
        out.append(f"starts: {a.get('starts')}")
        return out
