"""The ``tick_sweep`` step: was it the controller grid? The gait replayed for many cycles once
per controller tick, error per cycle, cycles until it leaves the gait, growth per cycle against
the leading Floquet multiplier.

From a shoot step's exact gait (replayed open-loop with its recorded times on each tick) or a
floquet step's fixed point, as its own controller (guards acted on at the ticks) or open-loop
(``replay``; the study's gait names its default).
"""
from __future__ import annotations

import dataclasses
import math
from functools import partial
from pathlib import Path
from typing import Annotated, Any, Literal, Optional

import numpy as np
from pydantic import Field, field_validator

from ...analysis.multipliers import floquet
from ...analysis.replay import cycle_times, open_loop_gait, sequence_cycles, sweep_ticks
from ...analysis.sections import cycle_return_map
from ...controllers import SequenceGait
from ...simulation import STATUS_NAMES
from .. import datasets as D
from ..blocks import Task
from ..models import Name, Replay, StrictModel, unique
from ..spec import GaitSpec
from .base import Figure, StepContext, StepKind, max_drop_of, no_earlier
from .gait_source import gait_line, motor_torque_of, read_floquet_multipliers, run_problems


class TickSweepStep(StrictModel):
    """The controller-tick question: the exact gait replayed open-loop with its times
    rounded to a controller tick, one run per tick, error per cycle. A sequence gait runs from
    its floquet step's fixed point, as its own controller (its guards acted on at the ticks)
    or open-loop (``replay``)."""

    name: Name
    kind: Literal["tick_sweep"]
    from_: Name = Field(alias="from")  # described by the kind (accepts)
    replay: Replay = None
    ticks: list[Annotated[float, Field(ge=0, le=1.0)]] = Field(
        [1e-3, 1e-4, 1e-5, 0.0], min_length=1, description="controller ticks [s]; 0 = exact "
                                                            "timing")
    cycles: int = Field(80, ge=1, le=100_000, description="cycles per run")
    error_bound: float = Field(1e-2, gt=0, description="a run has left the gait at the "
                                                       "first cycle whose error exceeds "
                                                       "this [1]")
    floquet: Optional[Name] = Field(None, description="an earlier floquet step (open_loop) "
                                    "of the same shoot step: its leading multiplier instead "
                                    "of a finite-difference one")
    solution: Optional[int] = Field(None, ge=0, description="which solution of the shoot "
                                    "step (default: the lowest error)")
    max_drop: Optional[float] = Field(None, gt=0, description="stop ('fell') when the "
                                      "attached end sinks this far [m] (default: link 1's "
                                      "length)")

    @field_validator("ticks")
    @classmethod
    def _distinct(cls, v: list) -> list:
        return unique(v, "ticks")


# --- tasks (run on the workers) ------------------------------------------------------------------
def tick_sweep_task(spec: GaitSpec, gait: SequenceGait, z_star, *, times, ticks,
                    cycles: int, error_bound: float, max_drop: float, replay: str,
                    leading_multiplier: bool, fd_step: float = 1e-5) -> dict[str, Any]:
    """``gait`` run from its fixed point ``z_star = (theta2 [rad], dtheta1, dtheta2 [rad
    s-1])`` once per controller tick [s], as its own controller or replayed open-loop with
    the segment exit ``times`` [s] (None: the cycle's own at ``z_star``;
    :func:`monkeystudy.analysis.replay.sequence_cycles`).

    Per tick: the error per cycle against the start and the attached end's height per cycle
    as the gait records them (NaN padded to ``cycles``), ``cycles_to_bound``,
    ``cycles_completed`` (section crossings reached), the run's status and the fitted growth
    of sqrt(error) per cycle. ``leading_multiplier``: |lambda_max| of the replayed
    exact-timing map by finite differences, with all three (``multipliers``); NaN otherwise.
    Also the replayed segment times (``t_segment`` [s]) and the motor torque [N m].
    """
    robot, integ = spec.robot, spec.integrator
    z_star = np.asarray(z_star, float)
    if times is None:
        times = cycle_times(gait, z_star, robot=robot, integrator=integ)

    def run_one(tick):
        r = sequence_cycles(gait, z_star, cycles=cycles, robot=robot, integrator=integ,
                            replay=replay, times=times, tick=float(tick), max_drop=max_drop)
        return r.error, r.pivot_height, r.status

    out = sweep_ticks(ticks, cycles, error_bound, run_one)
    lead, lam = math.nan, np.full(3, np.nan + 0j)
    if leading_multiplier:
        g = open_loop_gait(gait, times) if replay == "open_loop" else gait
        fl = floquet(partial(cycle_return_map, gait=dataclasses.replace(g, tick=0.0),
                             robot=robot, integrator=integ), z_star, step=fd_step)
        lam = np.asarray(fl.multipliers, complex)
        lead = float(np.abs(lam[0]))
    return dict(out, leading_multiplier=lead, multipliers=lam, torque=motor_torque_of(gait),
                t_segment=np.asarray(times, float))


# --- the dataset ---------------------------------------------------------------------------------
#: the variables of a tick_sweep dataset (docs/datasets.md); the long_names' fields say
#: where a cycle is recorded (the section or the vertical after the swap)
VARIABLES = {
    "tick": D.Variable(("tick",), np.float64, "s", "controller tick (0: exact event timing)"),
    "cycle": D.index_coordinate("cycle", "cycle number"),
    "error": D.Variable(("tick", "cycle"), np.float64, D.ERROR_UNITS,
                        "error against the gait start at the {crossing} ending the cycle "
                        "(docs/model.md; NaN: not reached)", {"comment": D.ERROR_COMMENT}),
    "pivot_height": D.Variable(("tick", "cycle"), np.float64, "m",
                               "world height of the attached end {pivot_when}"),
    "cycles_to_bound": D.Variable(("tick",), np.int32, "1",
                                  "first cycle whose error exceeds error_bound (else the "
                                  "cycles reached)"),
    "cycles_completed": D.Variable(("tick",), np.int32, "1",
                                   "cycles that reached their {crossing}"),
    "status": D.Variable.of(("tick",), np.int8, D.STATUS_ATTRS,
                            long_name="why the run stopped (ok: all cycles ran)"),
    "growth_per_cycle": D.Variable(("tick",), np.float64, "1",
                                   "fitted geometric growth of sqrt(error) per cycle where "
                                   "1e-10 < sqrt(error) < 1e-4 (NaN: fewer than 3 such "
                                   "cycles)"),
}


def write_tick_sweep(path: Path, attrs: dict, ticks, result: dict, records: str) -> None:
    """Write a tick_sweep dataset from a :func:`tick_sweep_task` result, the cycles recorded
    at the section or from the swap (``records``, :class:`~monkeystudy.controllers.
    SequenceGait`)."""
    err = np.asarray(result["error"], float)
    section = records == "section"
    at = "section crossing" if section else "vertical crossing"
    fields = {"crossing": at,
              "pivot_when": "at the section crossing ending the cycle" if section
              else "after the cycle's swap"}
    with D.atomic_netcdf(path) as nc:
        D.write_coordinate(nc, VARIABLES, "tick", np.asarray(ticks, float))
        D.write_coordinate(nc, VARIABLES, "cycle", np.arange(1, err.shape[1] + 1))
        D.write_declared(nc, VARIABLES, "error", err, **fields)
        for key in ("pivot_height", "cycles_to_bound", "cycles_completed", "status",
                    "growth_per_cycle"):
            D.write_declared(nc, VARIABLES, key, result[key], **fields)
        D.set_global_attrs(nc, attrs)


# --- the kind ------------------------------------------------------------------------------------
class TickSweepKind(StepKind):
    name = "tick_sweep"
    model = TickSweepStep
    variables = VARIABLES
    gait_kinds = ("horizontal", "sequence")
    accepts = ("shoot", "floquet")
    unit = "runs"
    figures = (
        Figure("error_growth"),
    )

    def deps(self, step: TickSweepStep) -> tuple[str, ...]:
        return (step.from_,) + ((step.floquet,) if step.floquet is not None else ())

    def check_step(self, study, index, step: TickSweepStep, ref, seen) -> list:
        out = run_problems(study, index, step, ref)
        if step.floquet is None:
            return out
        if ref is not None and ref.kind == "floquet":
            return out + [(("steps", index, "floquet"), "a tick_sweep from a floquet step takes "
                           "its fixed point and multipliers from that step")]
        other = seen.get(step.floquet)
        if other is None or other.kind != "floquet":
            out.append((("steps", index, "floquet"), no_earlier(step.floquet, "floquet",
                                                                other)))
        elif "open_loop" not in other.controllers:
            out.append((("steps", index, "floquet"),
                        f"{other.name!r} has no open_loop controller"))
        elif other.from_ != step.from_:
            out.append((("steps", index, "floquet"),
                        f"{other.name!r} analyses shoot step {other.from_!r}, this step "
                        f"{step.from_!r}: they must be the same"))
        return out

    def start(self, ctx: StepContext) -> list[Task]:
        st = ctx.step
        max_drop = max_drop_of(st, ctx.spec)
        g = ctx.handed_on(solution=st.solution, replay=st.replay)
        ctx.state.update(gait=g, max_drop=max_drop)
        # the leading multiplier: a floquet step's (variational equations), else finite
        # differences of the replayed exact-timing map (by the task)
        if st.floquet is not None:
            lam = read_floquet_multipliers(ctx.deps[st.floquet].path, "open_loop")
            ctx.state["leading"] = (float(np.abs(lam[0])), f"floquet step {st.floquet} "
                                    "(variational equations)")
        elif g.replay == "gait":
            lam = read_floquet_multipliers(ctx.deps[st.from_].path, g.source["controller"])
            ctx.state["leading"] = (float(np.abs(lam[0])), f"floquet step {st.from_} "
                                    "(variational equations of the gait's own controller)")
        kw = {"ticks": list(st.ticks), "cycles": st.cycles, "error_bound": st.error_bound,
              "max_drop": max_drop, "replay": g.replay, "times": g.times,
              "leading_multiplier": "leading" not in ctx.state}
        return [Task(0, tick_sweep_task, (ctx.spec, g.gait, g.z), kw)]

    def finish(self, ctx: StepContext, attrs: dict) -> str:
        st = ctx.step
        r = ctx.results[0]
        g = ctx.state["gait"]
        fd = "leading" not in ctx.state
        lead, source = ctx.state.get("leading", (
            r["leading_multiplier"], "finite differences of the exact-timing open-loop map"))
        attrs.update(g.attrs("run", t_segment=r["t_segment"],
                             open_loop_multipliers=r["multipliers"] if fd else None))
        attrs.update(leading_multiplier=lead, leading_multiplier_source=source,
                     error_bound=st.error_bound, cycles=st.cycles, motor_torque=r["torque"],
                     max_drop=ctx.state["max_drop"])
        write_tick_sweep(ctx.path, attrs, st.ticks, r, g.gait.records)
        rows = ", ".join(f"{t:g} s: {int(c)}" for t, c in zip(st.ticks, r["cycles_to_bound"]))
        return f"cycles to bound {rows}; leading multiplier {lead:.4g}"

    def describe(self, ds) -> list[str]:
        a = ds.attrs
        out = [gait_line(a),
               f"leading multiplier {float(a.get('leading_multiplier', np.nan)):.6g} "
               f"({a.get('leading_multiplier_source', '')}); error bound "
               f"{a.get('error_bound')}"]
        for i, t in enumerate(ds["tick"].values):
            growth = float(ds["growth_per_cycle"][i])
            out.append(f"tick {t:g} s: {int(ds['cycles_to_bound'][i])} cycles to bound, "
                       f"{int(ds['cycles_completed'][i])} completed, status "
                       f"{STATUS_NAMES[int(ds['status'][i])]}, " +
                       (f"growth per cycle {growth:.4g}" if math.isfinite(growth) else
                        "growth per cycle not fitted (fewer than 3 cycles with 1e-10 < "
                        "sqrt(error) < 1e-4)"))
        return out
