"""The ``stress`` step: numerical stress scenarios (:mod:`monkeystudy.analysis.stress`) -
energy drift of unforced runs over thousands of periods, long controller runs, extreme
parameters. Deterministic (no timings): the dataset is bit-reproducible."""
from __future__ import annotations

from dataclasses import replace
from pathlib import Path
from typing import Annotated, Any, Literal, Optional

import numpy as np
from pydantic import Field, ValidationInfo, field_validator

from ...analysis.stress import (
    COULOMB_START, COULOMB_T_END, DRIFT_FLOOR, EXTREME_CASES, FLIGHT_START, HUGE_VELOCITIES,
    LONG_RUNS, PERIOD_RTOL, PERIOD_WINDOW, SWING_START, energy_drift, extreme_case, long_run,
)
from ...simulation import STATUS_NAMES
from .. import datasets as D
from ..blocks import Task
from ..models import Name, Point, StrictModel, unique
from ..spec import GaitSpec
from .base import Figure, StepContext, StepKind, max_drop_of


#: defaults of the stress step's scenarios (:mod:`monkeystudy.analysis.stress`)
STRESS_RTOLS = [1e-8, 1e-10, 1e-12]
STRESS_START = [0.902, 10.935]
STRESS_POINTS = [[0.5, 11.0], [2.0, 6.0], [5.0, -3.0], [0.1, 0.1], [0.902, 10.935]]
STRESS_CASES = ["mass_ratio_1_100", "mass_ratio_100_1", "tiny_inertia", "cg_at_the_ends",
                "huge_velocities", "coulomb_sticking"]


class EnergyDriftScenario(StrictModel):
    """Unforced, frictionless runs of the study's robot
    (:func:`monkeystudy.analysis.stress.energy_drift`): relative energy drift at log-spaced
    checkpoints, one run per phase and tolerance."""

    phases: list[Literal["swing", "flight"]] = Field(
        ["swing", "flight"], min_length=1, description="swing: hanging from end A, started "
        "at (dtheta1, dtheta2) = (1, 0) rad s-1; flight: a tumbling free fall")
    rtols: list[Annotated[float, Field(ge=100 * np.finfo(float).eps, lt=1.0)]] = Field(
        STRESS_RTOLS, min_length=1, description="relative tolerances [1] (atol = rtol * "
                                                "atol_ratio)")
    atol_ratio: float = Field(1e-2, gt=0, le=1.0, description="atol = rtol * atol_ratio "
                                                             "[rad, rad s-1, m, m s-1]")
    periods: float = Field(10000.0, ge=10.0, le=1.0e6, description="run length in "
                           "reference periods of the phase (swing: ~1.6 s for seed2009)")
    checkpoints: int = Field(13, ge=4, le=200, description="log-spaced checkpoints from one "
                             "period to the end")

    @field_validator("phases", "rtols")
    @classmethod
    def _distinct(cls, v: list, info: ValidationInfo) -> list:
        return unique(v, info.field_name)


class LongRunScenario(StrictModel):
    """The study's gait replayed for many cycles open loop (ticked and exact) and by the
    looped state-based controller (exact and ticked); every run must end with a status."""

    cycles: int = Field(1000, ge=1, le=100_000, description="cycles per run")
    start: Point = Field(STRESS_START, description="gait start (dtheta1, dtheta2) [rad s-1] "
                         "(hanging from A); the open-loop runs replay the gait evaluated here")
    tick: float = Field(1e-3, gt=0, le=1.0, description="controller tick of the ticked runs "
                                                        "[s]")
    max_drop: Optional[float] = Field(None, gt=0, description="stop ('fell') when the "
                                      "attached end sinks this far [m] (default: link 1's "
                                      "length)")
    max_steps: int = Field(20_000_000, ge=1000, le=1_000_000_000,
                           description="integrator step budget per run")


class ExtremeScenario(StrictModel):
    """Extreme parameters (:data:`monkeystudy.analysis.stress.EXTREME_CASES`): status counts
    per case and whether every result marked ok is finite."""

    cases: list[Literal[tuple(STRESS_CASES)]] = Field(  # type: ignore[valid-type]
        STRESS_CASES, min_length=1, description="cases to run: " + ", ".join(STRESS_CASES))
    points: list[Point] = Field(STRESS_POINTS, min_length=1,
                                description="gait starts (dtheta1, dtheta2) [rad s-1] of "
                                            "the parameter cases")
    max_steps: int = Field(200_000, ge=1000, le=1_000_000_000,
                           description="integrator step budget per gait evaluation")

    @field_validator("cases")
    @classmethod
    def _distinct(cls, v: list) -> list:
        return unique(v, "cases")


class StressStep(StrictModel):
    """Numerical stress tests (:mod:`monkeystudy.analysis.stress`): energy drift of unforced
    runs, long controller runs, extreme parameters. Every scenario runs, with its defaults
    unless given. Deterministic (no timings): the dataset is bit-reproducible."""

    name: Name
    kind: Literal["stress"]
    energy_drift: EnergyDriftScenario = Field(default_factory=EnergyDriftScenario)
    long_runs: LongRunScenario = Field(default_factory=LongRunScenario)
    extreme: ExtremeScenario = Field(default_factory=ExtremeScenario)


def stress_tasks(step: StressStep) -> list[tuple]:
    """The tasks of a stress step, in tag order: ``("drift", phase, rtol)`` per phase and
    tolerance, ``("long", run name, controller kind, ticked)`` per long run, then one
    ``("extreme",)`` task for all the extreme cases."""
    d = step.energy_drift
    return ([("drift", ph, r) for ph in d.phases for r in d.rtols]
            + [("long",) + run for run in LONG_RUNS] + [("extreme",)])


# --- tasks (run on the workers) ------------------------------------------------------------------
def stress_drift_task(spec: GaitSpec, phase: str, rtol: float, *, periods: float,
                      checkpoints: int, atol_ratio: float) -> dict[str, Any]:
    """Energy drift of one unforced, frictionless run (:func:`monkeystudy.analysis.stress.
    energy_drift`) of the study's robot with the study's integrator method."""
    robot, integ = spec.robot, spec.integrator
    return energy_drift(robot, phase, rtol=float(rtol), periods=float(periods),
                        checkpoints=int(checkpoints), atol_ratio=float(atol_ratio),
                        method=integ.method)


def stress_long_run_task(spec: GaitSpec, kind: str, *, start, cycles: int, tick: float,
                         max_drop: float, max_steps: int) -> dict[str, Any]:
    """One long run (:func:`monkeystudy.analysis.stress.long_run`) with the study's robot, torque and
    integrator (step budget ``max_steps``); ``tick`` [s], 0 = exact."""
    robot, integ = spec.robot, spec.integrator
    return long_run(kind, start=tuple(float(x) for x in start), cycles=int(cycles),
                    torque=spec.torque, tick=float(tick), robot=robot,
                    integrator=replace(integ, max_steps=int(max_steps)),
                    max_drop=float(max_drop))


def stress_extreme_task(spec: GaitSpec, cases, *, points, max_steps: int) -> list[dict]:
    """The extreme cases (:func:`monkeystudy.analysis.stress.extreme_case`) in order, with the study's
    robot, torque, controller tick and integrator (step budget ``max_steps``)."""
    robot, integ = spec.robot, spec.integrator
    integ = replace(integ, max_steps=int(max_steps))
    return [dict(extreme_case(c, robot=robot, torque=spec.torque,
                              tick=spec.tick, integrator=integ,
                              points=np.asarray(points, float)), case=c) for c in cases]


# --- the dataset ---------------------------------------------------------------------------------
#: dims of the energy-drift runs
DRIFT_RUNS = ("drift_phase", "drift_rtol")

#: the variables of a stress dataset (docs/datasets.md): energy drift, long runs, extreme cases
VARIABLES = {
    # energy drift
    "drift_phase": D.label_coordinate("drift_phase", "phase of the unforced, frictionless run: "
                                      "swing (hanging from end A) or flight (nothing attached)"),
    "drift_rtol": D.Variable(("drift_rtol",), np.float64, "1",
                             "relative tolerance of the run (atol = rtol * atol_ratio)"),
    "checkpoint": D.index_coordinate("checkpoint", "checkpoint (log-spaced in time)"),
    "period": D.Variable(("drift_phase",), np.float64, "s",
                         "reference period: mean interval between rising crossings of theta1 = "
                         "0 (oscillation), or 2 pi / |mean dtheta1/dt| (link 1 tumbling)"),
    "time": D.Variable(("drift_phase", "checkpoint"), np.float64, "s",
                       "time of the checkpoint (1 to `periods` reference periods, log-spaced)"),
    "energy_drift": D.Variable(DRIFT_RUNS + ("checkpoint",), np.float64, "1",
                               "relative energy drift |E - E0| / (|K| + |V|) at the checkpoint "
                               "(NaN: not reached)"),
    "growth_exponent": D.Variable(DRIFT_RUNS, np.float64, "1",
                                  "log-log slope of the drift against time over the last "
                                  "decade of checkpoints, fitted above drift_floor (NaN: fewer "
                                  "than 3 such checkpoints); 1 = linear growth"),
    "drift_per_period": D.Variable(DRIFT_RUNS, np.float64, "1",
                                   "final energy drift / number of reference periods"),
    "drift_steps": D.Variable(DRIFT_RUNS, np.int64, "1", "accepted integrator steps of the run"),
    "drift_status": D.Variable.of(DRIFT_RUNS, np.int8, D.STATUS_ATTRS,
                                  long_name="how the run ended (end_time: every checkpoint "
                                  "reached)"),
    "initial_energy": D.Variable(("drift_phase",), np.float64, "J",
                                 "total energy E0 at the start (world frame)"),
    # long runs
    "run": D.label_coordinate("run", "long run: controller and timing"),
    "controller": D.Variable(("run",), str, "1", "controller: open_loop (the gait's recorded "
                             "times replayed) or search (state-based, looped)"),
    "tick": D.Variable(("run",), np.float64, "s", "controller tick (0: exact event timing)"),
    "run_status": D.Variable.of(("run",), np.int8, D.STATUS_ATTRS,
                                long_name="why the run stopped (ok: all cycles ran)"),
    "cycles_completed": D.Variable(("run",), np.int32, "1", "cycles completed"),
    "steps": D.Variable(("run",), np.int64, "1", "accepted integrator steps"),
    "nfev": D.Variable(("run",), np.int64, "1", "right-hand-side evaluations"),
    "rejected": D.Variable(("run",), np.int64, "1", "rejected integrator steps"),
    "final_pivot_height": D.Variable(("run",), np.float64, "m",
                                     "world height of the attached end when the run stopped "
                                     "(start: 0)"),
    "t_final": D.Variable(("run",), np.float64, "s", "simulated time when the run stopped"),
    "final_state_finite": D.Variable(("run",), np.int8, "1",
                                     "the final state is finite (1) or not (0)"),
    "t_switch": D.Variable(("run",), np.float64, "s",
                           "swap time replayed by an open-loop run (NaN: state-based)"),
    "t_motor": D.Variable(("run",), np.float64, "s",
                          "motor-on duration replayed by an open-loop run (NaN: state-based)"),
    # extreme cases
    "case": D.label_coordinate("case", "extreme case"),
    "status": D.Variable.of(("status",), np.int8, D.STATUS_ATTRS, long_name="run status"),
    "description": D.Variable(("case",), str, "1", "what the case changes"),
    "status_counts": D.Variable(("case", "status"), np.int32, "1",
                                "runs of the case ending with each status"),
    "n_runs": D.Variable(("case",), np.int32, "1",
                         "runs of the case (gait evaluations or one free run)"),
    "finite_ok": D.Variable(("case",), np.int8, "1",
                            "every run marked ok (free run: end_time) has finite results and "
                            "every other run's error is NaN (1) or not (0)"),
    "max_steps_taken": D.Variable(("case",), np.int64, "1",
                                  "most accepted integrator steps of one run of the case"),
    "energy_change": D.Variable(("case",), np.float64, "J",
                                "final minus initial total energy of the free run (NaN: gait "
                                "evaluations)"),
    "friction_events": D.Variable(("case",), np.int32, "1",
                                  "stick and slip events of the free run (0: gait evaluations)"),
}


def write_stress(path: Path, attrs: dict, phases: list[str], rtols: list[float],
                 drift: list[dict], runs: list[dict], cases: list[dict]) -> None:
    """Write a stress dataset (docs/datasets.md, ``stress``) from the results of
    :func:`stress_drift_task` (phase-major, one per phase
    and tolerance), :func:`stress_long_run_task` (one per
    run, with its ``run`` name, ``controller`` and ``tick``) and
    :func:`stress_extreme_task` (one per case)."""
    n_c = len(drift[0]["time"])
    grid = {(r["phase"], r["rtol"]): r for r in drift}

    def cell(key, dtype=np.float64):
        return np.array([[grid[(ph, rt)][key] for rt in rtols] for ph in phases], dtype=dtype)

    def per_phase(key):
        return np.array([grid[(ph, rtols[0])][key] for ph in phases], dtype=np.float64)

    n_status = len(STATUS_NAMES)
    counts = np.zeros((len(cases), n_status), np.int32)
    for i, c in enumerate(cases):
        counts[i] = np.bincount(np.asarray(c["status"], np.int64), minlength=n_status)
    with D.atomic_netcdf(path) as nc:

        def write(name, data):
            D.write_declared(nc, VARIABLES, name, data)

        # energy drift
        D.write_coordinate(nc, VARIABLES, "drift_phase", phases)
        D.write_coordinate(nc, VARIABLES, "drift_rtol", np.asarray(rtols, float))
        D.write_coordinate(nc, VARIABLES, "checkpoint", np.arange(n_c))
        write("period", per_phase("period"))
        write("time", np.array([grid[(ph, rtols[0])]["time"] for ph in phases], float))
        write("energy_drift",
              np.array([[grid[(ph, rt)]["drift"] for rt in rtols] for ph in phases], float))
        write("growth_exponent", cell("growth_exponent"))
        write("drift_per_period", cell("drift_per_period"))
        write("drift_steps", cell("steps", np.int64))
        write("drift_status", cell("status", np.int8))
        write("initial_energy", per_phase("energy0"))
        # long runs
        D.write_coordinate(nc, VARIABLES, "run", [r["run"] for r in runs])
        write("controller", np.array([r["controller"] for r in runs], object))
        for name, key in (("tick", "tick"), ("run_status", "status"),
                          ("cycles_completed", "cycles_completed"), ("steps", "steps"),
                          ("nfev", "nfev"), ("rejected", "rejected"),
                          ("final_pivot_height", "final_pivot_height"), ("t_final", "t_final"),
                          ("final_state_finite", "finite"), ("t_switch", "t_switch"),
                          ("t_motor", "t_motor")):
            write(name, [r[key] for r in runs])
        # extreme cases
        D.write_coordinate(nc, VARIABLES, "case", [c["case"] for c in cases])
        D.write_coordinate(nc, VARIABLES, "status", np.arange(n_status))
        write("description", np.array([EXTREME_CASES.get(c["case"], "") for c in cases], object))
        write("status_counts", counts)
        write("n_runs", counts.sum(axis=1))
        for name, key in (("finite_ok", "finite_ok"), ("max_steps_taken", "max_steps"),
                          ("energy_change", "energy_change"),
                          ("friction_events", "friction_events")):
            write(name, [c[key] for c in cases])
        D.set_global_attrs(nc, attrs)


def finish_stress(ctx: StepContext, attrs: dict) -> str:
    """Write a stress step's dataset; return its one-line summary."""
    st = ctx.step
    results = ctx.task_results()
    spec = ctx.state["tasks_spec"]
    drift = [r for t, r in zip(spec, results) if t[0] == "drift"]
    runs = [dict(r, run=t[1], controller=t[2], tick=st.long_runs.tick if t[3] else 0.0)
            for t, r in zip(spec, results) if t[0] == "long"]
    cases = results[-1]
    d, lr = st.energy_drift, st.long_runs
    attrs.update(
        swing_start=SWING_START, flight_start=FLIGHT_START, drift_floor=DRIFT_FLOOR,
        period_window=PERIOD_WINDOW, period_rtol=PERIOD_RTOL, periods=d.periods,
        atol_ratio=d.atol_ratio, cycles=lr.cycles, long_run_start=list(lr.start),
        long_run_tick=lr.tick, max_drop=ctx.state["max_drop"], long_run_max_steps=lr.max_steps,
        extreme_points=[list(p) for p in st.extreme.points],
        extreme_max_steps=st.extreme.max_steps,
        huge_velocities=[list(p) for p in HUGE_VELOCITIES],
        coulomb_start=list(COULOMB_START), coulomb_t_end=COULOMB_T_END,
        bit_reproducible=1)
    write_stress(ctx.path, attrs, list(d.phases), list(d.rtols), drift, runs, cases)
    exps = ", ".join(f"{r['phase']} {r['rtol']:.0e}: {r['growth_exponent']:.3g}"
                     for r in drift)
    outs = ", ".join(f"{r['run']} {STATUS_NAMES[r['status']]} {r['cycles_completed']}"
                     for r in runs)
    bad = [c["case"] for c in cases if not c["finite_ok"]]
    return (f"growth exponents {exps}; long runs {outs}; extreme cases "
            + ("all finite where ok" if not bad else "NON-FINITE: " + ", ".join(bad)))


# --- the kind ------------------------------------------------------------------------------------
class StressKind(StepKind):
    name = "stress"
    model = StressStep
    variables = VARIABLES
    unit = "runs"
    figures = (
        Figure("stress"),
    )

    def n_tasks(self, step: StressStep, gait) -> int:
        return len(stress_tasks(step))

    def start(self, ctx: StepContext) -> list[Task]:
        st = ctx.step
        tasks = stress_tasks(st)
        d, lr, ex = st.energy_drift, st.long_runs, st.extreme
        max_drop = max_drop_of(lr, ctx.spec)
        ctx.state.update(tasks_spec=tasks, max_drop=max_drop)
        out = []
        for i, t in enumerate(tasks):
            if t[0] == "drift":
                out.append(Task(i, stress_drift_task, (ctx.spec, t[1], t[2]),
                                {"periods": d.periods, "checkpoints": d.checkpoints,
                                 "atol_ratio": d.atol_ratio}))
            elif t[0] == "long":
                out.append(Task(i, stress_long_run_task, (ctx.spec, t[2]),
                                {"start": list(lr.start), "cycles": lr.cycles,
                                 "tick": lr.tick if t[3] else 0.0, "max_drop": max_drop,
                                 "max_steps": lr.max_steps}))
            else:
                out.append(Task(i, stress_extreme_task, (ctx.spec, list(ex.cases)),
                                {"points": [list(p) for p in ex.points],
                                 "max_steps": ex.max_steps}))
        return out

    def finish(self, ctx: StepContext, attrs: dict) -> str:
        return finish_stress(ctx, attrs)

    def describe(self, ds) -> list[str]:
        a = ds.attrs
        out = []
        for i, ph in enumerate(ds["drift_phase"].values):
            cells = ", ".join(
                f"{r:.0e}: drift {float(ds['energy_drift'][i, j, -1]):.3g}, exponent "
                f"{float(ds['growth_exponent'][i, j]):.3g}, per period "
                f"{float(ds['drift_per_period'][i, j]):.3g}"
                for j, r in enumerate(ds["drift_rtol"].values))
            out.append(f"energy drift, {ph} (period {float(ds['period'][i]):.4g} s, "
                       f"{float(ds['time'][i, -1]):.4g} s): {cells}")
        for k, r in enumerate(ds["run"].values):
            out.append(f"long run {r}: {STATUS_NAMES[int(ds['run_status'][k])]}, "
                       f"{int(ds['cycles_completed'][k])} of {a.get('cycles')} cycles, "
                       f"{int(ds['steps'][k])} steps, final pivot height "
                       f"{float(ds['final_pivot_height'][k]):.4g} m")
        for k, c in enumerate(ds["case"].values):
            counts = ds["status_counts"].values[k]
            st = ", ".join(f"{STATUS_NAMES[j]} {n}" for j, n in enumerate(counts) if n)
            out.append(f"case {c}: {st}; {'finite where ok' if int(ds['finite_ok'][k]) else 'NON-FINITE'}")
        return out
