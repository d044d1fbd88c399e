"""The ``refine`` step: Nelder-Mead on the gait error from one start, or from the k best minima
of a grid's error map, every iterate recorded (the study's fminsearch)."""
from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Annotated, Any, Literal, Optional, Union

import numpy as np
from pydantic import Discriminator, Field, Tag

from ...analysis.gait_kind import gait_kind_text, vertical_passes_before_swap
from ...analysis.search import DEFAULT_PENALTY, FMINSEARCH_TOL, refine_gait
from ...simulation import STATUS_NAMES, Status, evaluate_cycle_gaits, swap_motor_times
from .. import datasets as D
from ..blocks import Task
from ..models import Name, Point, StrictModel
from ..spec import GaitSpec
from .base import Dependency, Figure, StepContext, StepKind
from .gait_source import read_start, refine_start


class BestOfGrid(StrictModel):
    """Start from the ``best`` lowest-error minima of an earlier grid step."""

    from_: Name = Field(alias="from")  # described by the kind (accepts)
    best: int = Field(1, ge=1, le=1000, description="number of grid minima to refine "
                                                    "(one refinement each, dim 'start')")


def _start_tag(v: Any) -> str | None:
    if isinstance(v, list):
        return "point"
    if isinstance(v, (dict, BestOfGrid)):
        return "grid"
    return None


StartSpec = Annotated[
    Union[Annotated[Point, Tag("point")], Annotated[BestOfGrid, Tag("grid")]],
    Discriminator(_start_tag, custom_error_type="start_type",
                  custom_error_message="must be a point [dtheta1, dtheta2] or "
                                       "{from: <grid step>, best: k}"),
]


class RefineStep(StrictModel):
    """Nelder-Mead on the gait error (scipy.optimize.minimize), every iterate recorded."""

    name: Name
    kind: Literal["refine"]
    method: Literal["nelder-mead"] = Field("nelder-mead", description="the minimizer")
    start: StartSpec = Field(description="[dtheta1, dtheta2] [rad s-1], or {from: <grid "
                                         "step>, best: k}")
    xatol: float = Field(FMINSEARCH_TOL, gt=0, description="absolute tolerance on the point "
                                                           "[rad s-1] (fminsearch TolX)")
    fatol: float = Field(FMINSEARCH_TOL, gt=0, description="absolute tolerance on the error "
                                                           "[1] (fminsearch TolFun)")
    maxiter: Optional[int] = Field(None, ge=1, description="iteration limit (default 400)")
    maxfev: Optional[int] = Field(None, ge=1, description="evaluation limit (default 400)")
    penalty: float = Field(DEFAULT_PENALTY, gt=0,
                           description="objective value where the gait fails [1]")

    @property
    def n_starts(self) -> int:
        """How many refinements the step runs (one per start)."""
        return self.start.best if isinstance(self.start, BestOfGrid) else 1


# --- tasks (run on the workers) ------------------------------------------------------------------
def refine_task(spec: GaitSpec, start: tuple[float, float], *, xatol: float, fatol: float,
                maxiter: int | None = None, maxfev: int | None = None,
                penalty: float = DEFAULT_PENALTY) -> dict[str, Any]:
    """:func:`~monkeystudy.analysis.search.refine_gait` on the spec's gait from ``start``
    (dtheta1, dtheta2) [rad s-1]: one cycle of the spec's gait (starts it says cannot reach
    its first guard skipped)."""
    keys = (("error", "status", "t_switch", "t_motor", "t_end") if spec.swap_motor_times else
            ("error", "status", "t_end", "t_segment", "x_advance", "y_advance"))

    def gait(x: tuple[float, float]) -> dict[str, Any]:
        r = evaluate_cycle_gaits(np.array([x]), spec.sequence, robot=spec.robot,
                                 integrator=spec.integrator)
        if spec.swap_motor_times:
            r.update(swap_motor_times(r["t_segment"]))
        return {k: (int(r[k][0]) if k == "status" else
                    r[k][0].copy() if k == "t_segment" else float(r[k][0])) for k in keys}

    r = refine_gait(gait, start, xatol=xatol, fatol=fatol, maxiter=maxiter, maxfev=maxfev,
                    penalty=penalty)
    # what kind of gait the result is: a late swap, after several swings, is another gait
    r["vertical_passes"] = -1 if not spec.swap_motor_times or r["status"] != Status.OK else \
        vertical_passes_before_swap(float(r["x"][0]), float(r["x"][1]), robot=spec.robot,
                                    gait=spec.sequence, integrator=spec.integrator)
    return r


def outcome_text(converged: int, message: str, iterations: int) -> str:
    """``converged after 30 iterations`` or why Nelder-Mead stopped without converging.

    ``iterations`` counts the simplex updates recorded: the dataset's iterates less the start
    (iterate 0), as its convergence figure numbers them."""
    after = (f" after {iterations} iteration{'s' if iterations != 1 else ''}"
             if iterations >= 0 else "")
    if converged:
        return f"converged{after}"
    why = ("the iteration limit" if "iterations" in message else
           "the evaluation limit" if "evaluations" in message else message.rstrip("."))
    return f"NOT converged: stopped at {why}{after}"


# --- the dataset ---------------------------------------------------------------------------------
#: the variables of a refine dataset (docs/datasets.md), those of one start; a ``{from: grid,
#: best: k}`` start puts dim ``start`` before each one's dims
VARIABLES = {
    "start": D.index_coordinate("start", "start index (grid minima, lowest error first)",
                                optional=True),
    "iteration": D.index_coordinate("iteration", "Nelder-Mead iteration (0: the start)"),
    "dtheta1": D.Variable.of((), np.float64, D.DTHETA1,
                             long_name="refined " + D.DTHETA1["long_name"]),
    "dtheta2": D.Variable.of((), np.float64, D.DTHETA2,
                             long_name="refined " + D.DTHETA2["long_name"]),
    "segment": D.index_coordinate("segment", D.SEGMENT_NOTE, optional=True),
    "t_segment": D.Variable.of(("segment",), np.float64, D.GAIT_ATTRS["t_segment"],
                               optional=True),
    "error": D.Variable((), np.float64, D.ERROR_UNITS, "{gait_error}; NaN unless ok",
                        {"comment": D.ERROR_COMMENT}),
    "t_switch": D.Variable.of((), np.float64, D.GAIT_ATTRS["t_switch"], optional=True),
    "t_motor": D.Variable.of((), np.float64, D.GAIT_ATTRS["t_motor"], optional=True),
    "t_end": D.Variable((), np.float64, "s", "time of {gait_end}"),
    "x_advance": D.Variable.of((), np.float64, D.GAIT_ATTRS["x_advance"], optional=True),
    "y_advance": D.Variable.of((), np.float64, D.GAIT_ATTRS["y_advance"], optional=True),
    "status": D.Variable.of((), np.int8, D.STATUS_ATTRS),
    "start_dtheta1": D.Variable.of((), np.float64, D.DTHETA1,
                                   long_name="start of the refinement, dtheta1"),
    "start_dtheta2": D.Variable.of((), np.float64, D.DTHETA2,
                                   long_name="start of the refinement, dtheta2"),
    "vertical_passes": D.Variable(
        (), np.int32, "1", "times link 1 passed the vertical before the swap of the refined "
        "gait (0: the swap comes on the first swing; -1: no swap, or a sequence gait)"),
    "converged": D.Variable((), np.int8, "1",
                            "Nelder-Mead met xatol and fatol (1) or hit a limit (0)"),
    "nit": D.Variable((), np.int32, "1", "Nelder-Mead iterations as scipy counts them (the "
                      "initial simplex is one)"),
    "n_iterations": D.Variable((), np.int32, "1", "recorded iterates (start included)"),
    "iterate_dtheta1": D.Variable(("iteration",), np.float64, D.RATE,
                                  "best vertex per iteration, dtheta1"),
    "iterate_dtheta2": D.Variable(("iteration",), np.float64, D.RATE,
                                  "best vertex per iteration, dtheta2"),
    "iterate_error": D.Variable(("iteration",), np.float64, D.ERROR_UNITS,
                                "gait error of the best vertex per iteration (NaN: gait "
                                "failed)", {"comment": D.ERROR_COMMENT}),
    "iterate_nfev": D.Variable(("iteration",), np.int32, "1",
                               "objective evaluations so far (-1: padding)"),
}


def write_refine(path: Path, attrs: dict, results: list[dict], multi: bool) -> None:
    """Write a refine dataset from :func:`refine_task` results.

    ``multi`` (a ``{from: grid, best: k}`` start): every variable gains a leading dim ``start``
    and the iterations are padded with NaN (``iterate_nfev`` with -1); ``n_iterations(start)``
    says how many are real.
    """
    n_it = max(len(r["iterate_error"]) for r in results)
    sequence = "t_segment" in results[0]
    fields = D.gait_fields(sequence)
    with D.atomic_netcdf(path) as nc:
        nc.createDimension("iteration", n_it)
        sdim: tuple = ()
        if multi:
            D.write_coordinate(nc, VARIABLES, "start", np.arange(len(results)))
            sdim = ("start",)
        D.write_declared(nc, VARIABLES, "iteration", np.arange(n_it))

        def write(name, data):
            D.write_declared(nc, VARIABLES, name, data, dims=sdim + VARIABLES[name].dims,
                             **fields)

        def col(key, dtype=np.float64, index=None):
            vals = [r[key] if index is None else r[key][index] for r in results]
            arr = np.array(vals, dtype=dtype)
            return arr if multi else arr[0]

        write("dtheta1", col("x", index=0))
        write("dtheta2", col("x", index=1))
        if sequence:
            D.write_coordinate(nc, VARIABLES, "segment", np.arange(len(results[0]["t_segment"])))
            write("t_segment", col("t_segment"))
        keys = (("error", "t_end", "x_advance", "y_advance") if sequence
                else ("error", "t_switch", "t_motor", "t_end"))
        for key in keys:
            write(key, col(key))
        write("status", col("status", np.int8))
        write("start_dtheta1", col("start", index=0))
        write("start_dtheta2", col("start", index=1))
        write("vertical_passes", col("vertical_passes", np.int32))
        write("converged", col("converged", np.int8))
        write("nit", col("nit", np.int32))
        write("n_iterations", np.array([len(r["iterate_error"]) for r in results], np.int32)
              if multi else len(results[0]["iterate_error"]))

        def padded(key, index=None, fill=np.nan, dtype=np.float64):
            arr = np.full((len(results), n_it), fill, dtype=dtype)
            for i, r in enumerate(results):
                v = r[key] if index is None else r[key][:, index]
                arr[i, :len(v)] = v
            return arr if multi else arr[0]

        write("iterate_dtheta1", padded("iterate_x", 0))
        write("iterate_dtheta2", padded("iterate_x", 1))
        write("iterate_error", padded("iterate_error"))
        write("iterate_nfev", padded("iterate_nfev", fill=-1, dtype=np.int32))
        conv = [r["converged"] for r in results]
        msgs = [r["message"] for r in results]
        D.set_global_attrs(nc, dict(
            attrs, converged=int(all(conv)),
            message=json.dumps(msgs) if multi else msgs[0],
            nfev=json.dumps([r["nfev"] for r in results]) if multi else results[0]["nfev"],
        ))


# --- the kind ------------------------------------------------------------------------------------
class RefineKind(StepKind):
    name = "refine"
    model = RefineStep
    variables = VARIABLES
    gait_kinds = ("horizontal", "sequence")
    accepts = ("grid",)
    from_key = ("start", "from")
    from_model = BestOfGrid
    takes = "its best minima start the refinements"
    provides = "its refined gait (the lowest error, or start_index)"
    unit = "refinements"
    figures = (
        Figure("convergence"),
    )

    def deps(self, step: RefineStep) -> tuple[str, ...]:
        return (step.start.from_,) if isinstance(step.start, BestOfGrid) else ()

    def check_step(self, study, index, step: RefineStep, ref, seen) -> list:
        if ref is not None and step.start.best > ref.n_points:
            return [(("steps", index, "start", "best"),
                     f"must be <= the {ref.n_points} points of {ref.name!r}")]
        return []

    def n_tasks(self, step: RefineStep, gait) -> int:
        return step.n_starts

    def hand_on(self, dep: Dependency, ctx: StepContext, **options):
        return read_start(refine_start, dep, ctx, options)

    def needs_runs(self, step) -> bool:
        return False

    def start(self, ctx: StepContext) -> list[Task]:
        st = ctx.step
        if isinstance(st.start, BestOfGrid):
            starts = ctx.handed_on(best=st.start.best)
        else:
            starts = np.array([st.start], dtype=np.float64)
        kw = {"xatol": st.xatol, "fatol": st.fatol, "maxiter": st.maxiter,
              "maxfev": st.maxfev, "penalty": st.penalty}
        return [Task(i, refine_task, (ctx.spec, (float(x0[0]), float(x0[1]))), kw)
                for i, x0 in enumerate(starts)]

    def finish(self, ctx: StepContext, attrs: dict) -> str:
        st = ctx.step
        results = ctx.task_results()
        multi = isinstance(st.start, BestOfGrid)
        attrs.update(method=st.method, xatol=st.xatol, fatol=st.fatol,
                     maxiter=st.maxiter if st.maxiter is not None else -1,
                     maxfev=st.maxfev if st.maxfev is not None else -1,
                     penalty=st.penalty,
                     start=st.start.model_dump(mode="json", by_alias=True)
                     if multi else list(st.start))
        write_refine(ctx.path, attrs, results, multi)
        best = min(range(len(results)), key=lambda i: results[i]["error"]
                   if math.isfinite(results[i]["error"]) else math.inf)
        b = results[best]
        kind = (f", {gait_kind_text(b['vertical_passes'])}" if ctx.spec.swap_motor_times
                else "")
        at = f"({b['x'][0]:.6g}, {b['x'][1]:.6g})"
        outcome = outcome_text(b['converged'], b['message'], len(b['iterate_error']) - 1)
        if math.isfinite(b["error"]):
            msg = f"best error {b['error']:.3g} at {at}{kind}, {outcome}"
        else:       # every vertex failed, so the penalty was all the search could compare
            msg = (f"no gait found, so no error: the search ended at {at} with status "
                   f"{STATUS_NAMES[int(b['status'])]}, every point it tried without a gait; "
                   f"{outcome}")
        if len(results) > 1:
            n_conv = sum(r["converged"] for r in results)
            msg += f" (start {best}); {n_conv} of {len(results)} starts converged"
        return msg

    def describe(self, ds) -> list[str]:
        def col(name, default=np.nan):
            return np.atleast_1d(ds[name].values) if name in ds else \
                np.full(ds["dtheta1"].size, default)

        d1, d2, err, st = col("dtheta1"), col("dtheta2"), col("error"), col("status", 0)
        conv, passes = col("converged", 0), col("vertical_passes", -2)
        # recorded iterates per start, the start (iterate 0) included
        iterates = col("n_iterations", ds.sizes.get("iteration", 0))
        ts, tm, s1, s2 = col("t_switch"), col("t_motor"), col("start_dtheta1"), \
            col("start_dtheta2")
        msgs = [m for m in (ds.attrs.get("message", ""),)]
        try:
            msgs = json.loads(msgs[0]) if d1.size > 1 else msgs
        except ValueError:
            pass
        lines = []
        for k in range(d1.size):
            kind = f", {gait_kind_text(int(passes[k]))}" if passes[k] > -2 and \
                "t_switch" in ds else ""
            times = (f"; swap at {ts[k]:.6g} s, motor {tm[k]:.6g} s" if np.isfinite(ts[k])
                     else "")
            error = (f"error {err[k]:.4g}" if np.isfinite(err[k]) else
                     "no error (no gait found)")
            lines.append(f"start {k}: ({s1[k]:.6g}, {s2[k]:.6g}) -> ({d1[k]:.6g}, {d2[k]:.6g}) "
                         f"rad s-1, {error}, {STATUS_NAMES[int(st[k])]}{kind}; "
                         f"{outcome_text(int(conv[k]), str(msgs[min(k, len(msgs) - 1)]), int(iterates[k]) - 1)}"
                         f"{times}")
        return lines
