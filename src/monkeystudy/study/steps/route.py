"""The ``route`` step: a route across the study's wall planned from an atlas of gaits, and
walked many times under noise, replanning after each catch from where the robot senses it is.

From an ``atlas`` step's gaits and switches (with their mirror images), the route is planned
from the wall's start (:func:`~monkeystudy.analysis.route.plan_route`: A* over a lattice of
catches on steel, each step costing its time or energy plus its risk) and walked ``walks``
times (:func:`~monkeystudy.analysis.walk.walk_route`) under the atlas's noise and tick, with
the step's sensor model (:mod:`monkeystudy.analysis.sensing`). Each walk's draws depend only
on ``(seed, run, step)``: the walks are blocks on the pool, saved as shards, the same for any
number of workers and after a resume.
"""
from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any, Literal, Optional

import numpy as np
from pydantic import AfterValidator, Field
from typing_extensions import Annotated

from ...analysis.route import NoRoute, mirrored_name, plan_route
from ...analysis.sensing import sensor_from_dict
from ...analysis.walk import walk_route, walk_trajectory
from ...wall import Wall
from .. import datasets as D
from ..blocks import Block, Task
from ..counts import task_units
from ..models import Name, StrictModel
from ..spec import GaitSpec
from .base import Figure, StepContext, StepKind

#: walks per block on the pool
WALKS_PER_BLOCK = 50

#: how a walk ended (``failure``): arrived, then the walk's own ends, then a cycle's statuses
OUTCOMES = ("", "off_steel", "no_route", "missed_goal", "max_steps")


def _sensor(value: dict | None) -> dict | None:
    if value is not None:
        sensor_from_dict(value)      # a ValueError names the field
    return value


SensorBlock = Annotated[Optional[dict[str, Any]], AfterValidator(_sensor)]


class RouteStep(StrictModel):
    """A route across the study's wall from an atlas step's gaits, walked under noise with
    replanning after every catch: the fraction that arrives, the time and energy, where
    failures happen."""

    name: Name
    kind: Literal["route"]
    from_: Name = Field(alias="from")  # described by the kind (accepts)
    walks: int = Field(ge=1, le=10_000_000, description="noisy walks of the route")
    seed: int = Field(0, ge=0, le=2**63 - 1, description="the noise's seed: with the run "
                      "and the step it keys every draw")
    max_steps: int = Field(100, ge=1, le=100_000, description="steps after which a walk "
                           "stops (max_steps)")
    height_step: float = Field(gt=0, le=10.0, description="the planned catch heights are "
                               "the start's plus whole multiples of this [m] (every gait's "
                               "rise is one): the staircase each step is planned on")
    cost: Literal["time", "energy"] = Field("time", description="what a step costs: its "
                                            "duration or the motor's work")
    risk_weight: float = Field(0.0, ge=0, description="cost per unit of -log(1 - p_fail) "
                               "[s or J]: 0 ignores the risk")
    risk_from: Literal["estimate", "bound"] = Field("bound", description="the failure "
                                                    "probability the risk reads")
    resolution: float = Field(0.001, gt=0, le=1.0, description="the catch lattice's "
                              "spacing [m]")
    max_switch_p_fail: float = Field(0.05, ge=0, lt=1, description="a direct switch between "
                                     "gaits is allowed when its measured failure "
                                     "probability is at most this")
    mirror: bool = Field(True, description="add each gait's mirror image (walked the other "
                         "way)")
    sensor: SensorBlock = Field(None, description="how the robot senses the attached "
                                "magnet (docs/route.md, 'What the robot senses'): kind "
                                "exact, odometry, range_finder or markers and its errors "
                                "(default: exact)")


# --- tasks (run on the workers) ------------------------------------------------------------------
def walk_arrays(n: int, max_steps: int) -> dict[str, np.ndarray]:
    """Empty per-walk arrays of ``n`` walks of up to ``max_steps`` steps (NaN, -1 or empty
    where a walk did not get)."""
    return {"arrived": np.zeros(n, np.int8), "failure": np.empty(n, object),
            "steps": np.zeros(n, np.int32), "time": np.zeros(n), "energy": np.zeros(n),
            "catch": np.full((n, max_steps, 2), np.nan),
            "sensed": np.full((n, max_steps, 2), np.nan),
            "gait": np.full((n, max_steps), -1, np.int32), "failed_at": np.full((n, 2), np.nan)}


def route_block(spec: GaitSpec, atlas, wall: dict, runs: np.ndarray, *, seed: int,
                max_steps: int, height_step: float, plan: dict,
                sensor: dict | None) -> dict[str, np.ndarray]:
    """Walks number ``runs`` of the route (:func:`~monkeystudy.analysis.walk.walk_route`):
    per walk its outcome, steps, time, energy, catches and estimates."""
    wall_ = Wall.from_dict(wall)
    model = sensor_from_dict(sensor) if sensor is not None else None
    names = [g.name for g in atlas.gaits]
    out = walk_arrays(len(runs), max_steps)
    for i, run in enumerate(runs):
        w = walk_route(wall_, atlas.walk_gaits, atlas.gaits, atlas.transitions,
                       robot=spec.robot, integrator=spec.integrator, tick=atlas.tick,
                       noise=atlas.noise, seed=seed, run=int(run), sensor=model,
                       max_steps=max_steps, height_step=height_step, plan=plan)
        k = len(w.catches)
        out["arrived"][i] = w.arrived
        out["failure"][i] = w.failure
        out["steps"][i] = len(w.gaits)
        out["time"][i], out["energy"][i] = w.time, w.energy
        out["catch"][i, :k], out["sensed"][i, :k] = w.catches, w.sensed
        out["gait"][i, :len(w.gaits)] = [names.index(g) for g in w.gaits]
        out["failed_at"][i] = w.failed_at
        task_units(1)
    out["failure"] = out["failure"].astype(str)
    return out


def noiseless_walk(spec: GaitSpec, atlas, wall: Wall, step: RouteStep) -> dict | None:
    """The route walked once without noise on the atlas's tick, sampled every
    :data:`SAMPLE_DT`: world positions of the ends and the joint, the attached end, the phase
    and the motor torque (None when it records nothing)."""
    w = walk_route(wall, atlas.walk_gaits, atlas.gaits, atlas.transitions, robot=spec.robot,
                   integrator=spec.integrator, tick=atlas.tick, max_steps=step.max_steps,
                   height_step=step.height_step, plan=RouteKind.plan_options(step),
                   sample_dt=SAMPLE_DT)
    return walk_trajectory(w)


# --- the dataset ---------------------------------------------------------------------------------
RUN, RUN_STEP, GAIT, PLAN = ("run",), ("run", "step"), ("gait",), ("plan_step",)

#: the variables of a route dataset (docs/datasets.md)
VARIABLES = {
    "gait": D.label_coordinate("gait", "the gait's name (mirror images named '<gait> "
                               "(mirrored)')"),
    "gait_dx": D.Variable(GAIT, np.float64, "m", "the attached magnet's advance along the "
                          "wall over one step (signed: world x)"),
    "gait_dy": D.Variable(GAIT, np.float64, "m", "its rise over the step"),
    "gait_duration": D.Variable(GAIT, np.float64, "s", "the step's duration"),
    "gait_energy": D.Variable(GAIT, np.float64, "J", "the motor's net work over the step"),
    "gait_p_fail": D.Variable(GAIT, np.float64, "1", "failure probability per step"),
    "gait_p_fail_upper": D.Variable(GAIT, np.float64, "1", "its one-sided 97.5 % "
                                    "Clopper-Pearson upper bound"),
    "gait_spectral_radius": D.Variable(GAIT, np.float64, "1", "the full return map's "
                                       "spectral radius (NaN for a switch step)"),
    "gait_mfpt": D.Variable(GAIT, np.float64, "1", "mean first-passage time to failure "
                            "[steps] (a lower bound when gait_mfpt_censored)"),
    "gait_mfpt_low": D.Variable(GAIT, np.float64, "1", "its 95 % interval's low end [steps]"),
    "gait_mfpt_high": D.Variable(GAIT, np.float64, "1", "its 95 % interval's high end "
                                 "[steps]"),
    "gait_mfpt_censored": D.Variable(GAIT, np.int8, "1", "1: gait_mfpt is a lower bound"),
    "gait_survival_runs": D.Variable(GAIT, np.int32, "1", "survival runs measured"),
    "gait_survival_failed": D.Variable(GAIT, np.int32, "1", "of them, runs that failed"),
    "plan_step": D.index_coordinate("plan_step", "the planned route's step, from 1"),
    "plan_gait": D.Variable(PLAN, str, "1", "the gait of the planned step"),
    "plan_catch_x": D.Variable(PLAN, np.float64, "m", "the attached magnet after the planned "
                               "step: x"),
    "plan_catch_y": D.Variable(PLAN, np.float64, "m", "the attached magnet after the planned "
                               "step: y"),
    "run": D.index_coordinate("run", "walk number (keys its noise)"),
    "step": D.index_coordinate("step", "step of a walk, from 1"),
    "arrived": D.Variable(RUN, np.int8, "1", "whether the walk arrived: its last catch lies "
                          "in the goal (a boolean)",
                          {"flag_values": np.array([0, 1], np.int8),
                           "flag_meanings": "failed arrived"}),
    "failure": D.Variable(RUN, str, "1", "how the walk ended: empty when it arrived, else "
                          "off_steel, no_route, missed_goal, max_steps or the failing "
                          "cycle's status (fell, no_switch, ...)"),
    "steps_walked": D.Variable(RUN, np.int32, "1", "steps taken (a failed one included)"),
    "walk_time": D.Variable(RUN, np.float64, "s", "time from the start to the last "
                            "completed step's end"),
    "walk_energy": D.Variable(RUN, np.float64, "J", "the motor's net work over the "
                              "completed steps"),
    "catch_x": D.Variable(RUN_STEP, np.float64, "m", "the attached magnet after each "
                          "completed step, true: x (NaN after the walk ended)"),
    "catch_y": D.Variable(RUN_STEP, np.float64, "m", "the same: y"),
    "sensed_x": D.Variable(RUN_STEP, np.float64, "m", "the robot's estimate of it: x"),
    "sensed_y": D.Variable(RUN_STEP, np.float64, "m", "the robot's estimate of it: y"),
    "step_gait": D.Variable(RUN_STEP, np.int32, "1", "index into gait of each step's gait "
                            "(-1 after the walk ended)"),
    "failure_x": D.Variable(RUN, np.float64, "m", "where a failed walk failed: x (NaN when "
                            "it arrived)"),
    "failure_y": D.Variable(RUN, np.float64, "m", "where a failed walk failed: y"),
    # the planned route walked once without noise, sampled (for the animation)
    "xy": D.label_coordinate("xy", "world axis", optional=True),
    "time": D.Variable(("sample",), np.float64, "s", "time of the noiseless walk",
                       optional=True),
    **{key: D.Variable(("sample", "xy"), np.float64, "m", f"world position of {what}",
                       optional=True)
       for key, what in (("A", "end A"), ("joint", "the joint"), ("B", "end B"))},
    "attached_end": D.Variable(("sample",), np.int8, "1", "end the frame hangs from (0: A, "
                               "1: B)", optional=True),
    "phase": D.Variable.of(("sample",), np.int8, D.PHASE_ATTRS, optional=True),
    "motor_torque": D.Variable(("sample",), np.float64, "N m", "motor torque on theta2 of the "
                               "frame of the end attached", optional=True),
}

#: the noiseless walk's sample interval [s]
SAMPLE_DT = 0.01

#: the atlas variables a route dataset copies for the gaits it planned with
COPIED = ("gait_spectral_radius", "gait_mfpt", "gait_mfpt_low", "gait_mfpt_high",
          "gait_mfpt_censored", "gait_survival_runs", "gait_survival_failed")


def write_route(path: Path, attrs: dict, atlas, atlas_rows: dict, route, arrays: dict,
                max_steps: int, trajectory: dict | None = None) -> None:
    """Write a route dataset (``trajectory``: the noiseless walk's samples, or None)."""
    names = [g.name for g in atlas.gaits]
    with D.atomic_netcdf(path) as nc:

        def write(name, data):
            D.write_declared(nc, VARIABLES, name, data)

        D.write_coordinate(nc, VARIABLES, "gait", names)
        for key in ("dx", "dy", "duration", "energy", "p_fail", "p_fail_upper"):
            write(f"gait_{key}", [getattr(g, key) for g in atlas.gaits])
        for key in COPIED:
            write(key, [atlas_rows[key][n] for n in names])
        steps = route.steps if route is not None else ()
        D.write_coordinate(nc, VARIABLES, "plan_step", np.arange(1, len(steps) + 1))
        write("plan_gait", [s.gait for s in steps])
        write("plan_catch_x", [s.catch[0] for s in steps])
        write("plan_catch_y", [s.catch[1] for s in steps])
        n = len(arrays["arrived"])
        D.write_coordinate(nc, VARIABLES, "run", np.arange(n))
        D.write_coordinate(nc, VARIABLES, "step", np.arange(1, max_steps + 1))
        write("arrived", arrays["arrived"])
        write("failure", arrays["failure"])
        write("steps_walked", arrays["steps"])
        write("walk_time", arrays["time"])
        write("walk_energy", arrays["energy"])
        write("catch_x", arrays["catch"][..., 0])
        write("catch_y", arrays["catch"][..., 1])
        write("sensed_x", arrays["sensed"][..., 0])
        write("sensed_y", arrays["sensed"][..., 1])
        write("step_gait", arrays["gait"])
        write("failure_x", arrays["failed_at"][:, 0])
        write("failure_y", arrays["failed_at"][:, 1])
        if trajectory is not None:
            nc.createDimension("xy", 2)
            write("xy", np.array(["x", "y"], object))
            nc.createDimension("sample", len(trajectory["time"]))
            D.write_declared(nc, VARIABLES, "time", trajectory["time"])
            for key in ("A", "joint", "B"):
                D.write_declared(nc, VARIABLES, key, trajectory[key], coordinates="time")
            for key in ("attached_end", "phase", "motor_torque"):
                D.write_declared(nc, VARIABLES, key, trajectory[key], coordinates="time")
        D.set_global_attrs(nc, attrs)


# --- the kind ------------------------------------------------------------------------------------
class RouteKind(StepKind):
    name = "route"
    model = RouteStep
    variables = VARIABLES
    gait_kinds = ("horizontal", "sequence")
    accepts = ("atlas",)
    takes = "the atlas of gaits and switches it plans with"
    runs_gait = False
    study_blocks = ("wall",)       # a new wall is walked again
    unit = "walks"
    block_units = True
    figures = (Figure("wall"), Figure("walks"), Figure("atlas"), Figure("outcomes"),
               Figure("animation"))

    def check_step(self, study, index, step: RouteStep, ref, seen) -> list:
        if getattr(study, "wall", None) is None:
            return [(("steps", index, "kind"), "a route step walks the study's wall: give a "
                     "wall: block (docs/route.md)")]
        return []

    def blocks(self, step: RouteStep) -> list[Block]:
        return [Block(i, lo, min(lo + WALKS_PER_BLOCK, step.walks))
                for i, lo in enumerate(range(0, step.walks, WALKS_PER_BLOCK))]

    def block_summary(self, step: RouteStep) -> str:
        return f"{step.walks} walks of up to {step.max_steps} steps"

    def n_tasks(self, step: RouteStep, gait) -> int:
        return len(self.blocks(step))

    @staticmethod
    def plan_options(step: RouteStep) -> dict:
        return {"cost": step.cost, "risk_weight": step.risk_weight,
                "risk_from": step.risk_from, "resolution": step.resolution}

    def start(self, ctx: StepContext) -> list[Task]:
        st = ctx.step
        atlas = ctx.handed_on(max_switch_p_fail=st.max_switch_p_fail, mirror=st.mirror)
        wall = ctx.study.wall.to_wall().to_dict()
        ctx.state.update(atlas=atlas, wall=wall)
        kw = {"seed": st.seed, "max_steps": st.max_steps, "height_step": st.height_step,
              "plan": self.plan_options(st), "sensor": st.sensor}
        return [Task(b, route_block, (ctx.spec, atlas, wall,
                                      np.arange(b.lo, b.hi, dtype=np.int64)), kw)
                for b in ctx.todo_blocks()]

    def finish(self, ctx: StepContext, attrs: dict) -> str:
        import xarray as xr   # the driver reads datasets; the workers never load xarray
        st = ctx.step
        atlas, wall = ctx.state["atlas"], ctx.state["wall"]
        n = st.walks
        arrays = walk_arrays(n, st.max_steps)
        for b in ctx.blocks:
            got = ctx.block_arrays(b)
            for k in arrays:
                arrays[k][b.lo:b.hi] = got[k]
        arrays["failure"] = arrays["failure"].astype(str)
        wall_ = Wall.from_dict(wall)
        try:
            route = plan_route(wall_, atlas.gaits, atlas.transitions, mirror=False,
                               **self.plan_options(st))
        except NoRoute:
            route = None
        dep = ctx.deps[st.from_]
        with xr.open_dataset(dep.path) as ads:
            base = [str(g) for g in ads["gait"].values]
            rows = {key: {g: float(ads[key].values[k]) for k, g in enumerate(base)}
                    for key in COPIED}
        for key in COPIED:   # a mirror image has its gait's numbers
            for g in atlas.gaits:
                if g.name not in rows[key]:
                    rows[key][g.name] = rows[key][mirrored_name(g.name)]
        arrived = int(arrays["arrived"].sum())
        attrs.update(wall=json.dumps(wall), sensor=json.dumps(st.sensor or {"kind": "exact"}),
                     cost=st.cost, risk_weight=st.risk_weight, risk_from=st.risk_from,
                     resolution=st.resolution, height_step=st.height_step, walks=n,
                     seed=st.seed, max_steps=st.max_steps, arrived_runs=arrived,
                     arrived_fraction=arrived / n, tick=atlas.tick,
                     noise=json.dumps(atlas.noise.to_dict()),
                     excluded_gaits=json.dumps(list(atlas.excluded)),
                     planned_steps=len(route.steps) if route else 0,
                     planned_p_arrive=route.p_arrive if route else math.nan,
                     planned_p_arrive_low=route.p_arrive_low if route else math.nan,
                     planned_p_arrive_survival=route.p_arrive_survival if route else math.nan,
                     planned_time=route.expected_time if route else math.nan,
                     planned_energy=route.expected_energy if route else math.nan,
                     n_blocks=len(ctx.blocks))
        write_route(ctx.path, attrs, atlas, rows, route, arrays, st.max_steps,
                    noiseless_walk(ctx.spec, atlas, wall_, st) if route else None)
        plan = (f"planned {len(route.steps)} steps, p_arrive {route.p_arrive:.4g} "
                f"(survival curves: {route.p_arrive_survival:.4g})"
                if route else "no route from the start")
        return f"{plan}; {arrived} of {n} walks arrived"

    def own_setup(self, ds) -> str:
        """What it walked and how, from its dataset."""
        return (f"walks its atlas's gaits across the study's wall, {ds.attrs.get('walks')} "
                f"times under the atlas's noise and tick, with the study's robot and "
                f"integrator, as the atlas step")

    def describe(self, ds) -> list[str]:
        a = ds.attrs
        fails = np.asarray(ds["failure"].values).astype(str)
        causes = ", ".join(f"{c} {int((fails == c).sum())}" for c in sorted(set(fails))
                           if c)
        plan = [str(g) for g in ds["plan_gait"].values]
        lines = [f"planned: {a.get('planned_steps')} steps ({', '.join(plan) or 'none'}), "
                 f"time {float(a['planned_time']):.4g} s, energy "
                 f"{float(a['planned_energy']):.4g} J, p_arrive "
                 f"{float(a['planned_p_arrive']):.4g} (>= "
                 f"{float(a['planned_p_arrive_low']):.4g}); from the gaits' survival curves "
                 f"{float(a.get('planned_p_arrive_survival', math.nan)):.4g}",
                 f"walked: {a.get('arrived_runs')} of {a.get('walks')} arrived "
                 f"({100 * float(a['arrived_fraction']):.4g} %); failed: {causes or 'none'}"]
        ok = np.asarray(ds["arrived"].values, bool)
        if ok.any():
            t = np.asarray(ds["walk_time"].values)[ok]
            e = np.asarray(ds["walk_energy"].values)[ok]
            lines.append(f"arrived walks: time median {np.median(t):.4g} s "
                         f"[{t.min():.4g}, {t.max():.4g}], energy median {np.median(e):.4g} J "
                         f"[{e.min():.4g}, {e.max():.4g}]")
        return lines
